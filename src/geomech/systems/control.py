"""Structure-preserving feedback for rigid bodies with rotors (sections 6.1 and 7 of the Serret-Andoyer paper).

A feedback torque on the rotors of a :class:`~geomech.systems.rotors.RotorBody` *preserves the rigid-body
structure* (Definition 2) when the closed-loop motion of the main body is that of a left-invariant
Hamiltonian :math:`H_c(m)` on :math:`T^*SO(3)`: :math:`\\dot R = R\\,\\widehat{\\nabla H_c}`,
:math:`\\dot m = m\\times\\nabla H_c` (eq. 27). For a map :math:`\\varphi: \\mathbb R^3\\to\\mathbb R^N`,
the control of Proposition 5,

.. math::

    u = D\\varphi(m)\\,\\dot m, \\qquad \\dot m = m\\times D_1H_f(m, \\Gamma),

keeps :math:`p = \\Gamma - \\varphi(m)` constant (Lemma 4 (i)), so along the closed loop
:math:`\\Gamma = \\varphi(m) + p` and the body's angular velocity is

.. math::

    F(m) = D_1H_f(m, \\varphi(m) + p) = \\Lambda^{-1}\\bigl(m - A(\\varphi(m) + p)\\bigr).

**The exact existence condition** (Lemma 4 (ii)) is :math:`\\Lambda^{-1}A\\,D\\varphi(m)` symmetric for every
:math:`m`, not the printed :math:`D\\varphi` symmetric; it and the closed-loop potential :math:`\\psi` are in
:mod:`geomech.systems._closed_loop`.

**One rotor, eq. (29a).** With :math:`\\varphi(m) = \\varphi(m_3)` the control is
:math:`u = \\varphi'(m_3)\\,\\dot m_3` and Euler's equation (30c) gives
:math:`\\dot m_3 = (1/\\lambda_2 - 1/\\lambda_1) m_1 m_2`, so

.. math::

    u = \\varphi'(m_3) \\Bigl(\\frac{1}{\\lambda_2} - \\frac{1}{\\lambda_1}\\Bigr) m_1 m_2 .

Eq. (29a) as printed has :math:`(1/\\lambda_1 - 1/\\lambda_2)`, the opposite sign, with which
:math:`\\Gamma - \\varphi(m_3)` is not conserved (:meth:`StructurePreservingControl.eq29a_torque`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, SymbolicError
from ..symbolic.compile import M_SYMBOLS, compile_scalar, compile_vector
from ..symbolic.integrals import integral_choice, quadrature_from_zero, ray_quadrature
from ._closed_loop import (
    ClosedLoopCondition,
    ClosedLoopFamily,
    Lemma4Check,
    existence_condition,
    lemma4_check,
    potential_integral,
    symbolic_potential,
)
from ._control_phi import parse_phi, wrap_phi_callables
from ._hyperregularity import V_SYMBOL, HyperregularityReport, hyperregularity_report
from .left_invariant import LeftInvariantSystem
from .rotors import RotorBody

__all__ = [
    "V_SYMBOL",
    "ClosedLoopCondition",
    "ClosedLoopFamily",
    "HyperregularityReport",
    "Lemma4Check",
    "StructurePreservingControl",
]


class StructurePreservingControl:
    """A structure-preserving feedback :math:`u = D\\varphi(m)\\,\\dot m` for a :class:`RotorBody`.

    Build it with :meth:`one_rotor` (eq. 29a), :meth:`three_rotors` (Proposition 5), :meth:`diagonal`
    (Corollary 2) or :meth:`general` (any rotor layout, same construction). Construction checks the
    exact existence condition of a closed-loop Hamiltonian and raises :class:`~geomech.errors.InputError`
    with the reason when it fails.

    Attributes
    ----------
    body : the :class:`RotorBody`.
    kind : ``"one-rotor"``, ``"three-rotors"``, ``"diagonal"`` or ``"general"``.
    phi_expression : sympy Matrix (N x 1) in ``m1, m2, m3`` and the parameters, or None for a callable phi.
    parameters : the values of every parameter symbol: the model's (``lambda1, lambda2, I3, p`` for one
        rotor, ``lambda1..3, p1..3`` for three, ``p1..pN`` otherwise) and phi's.
    condition : the :class:`ClosedLoopCondition` that was verified.
    H_c : the closed-loop Hamiltonian :math:`H_c` as sympy (with an unevaluated ``Integral`` where sympy found no
        antiderivative; then :attr:`hamiltonian_is_closed_form` is False and quadrature is used).
    """

    def __init__(
        self,
        body: RotorBody,
        kind: str,
        *,
        phi_exprs: list[sp.Expr] | None,
        variables: str,
        phi_params: Mapping[str, float],
        phi_callables: tuple[Any, ...] | None,
        p: Any,
        probe_radius: float,
        integral: str,
    ):
        if not isinstance(body, RotorBody):
            raise InputError(f"Expected `body` to be a RotorBody, got {type(body).__name__}.")
        self.body = body
        self.kind = kind
        # what with_parameters needs to build the same law again with other values
        self._law: dict[str, Any] = dict(
            phi_exprs=phi_exprs, variables=variables, phi_callables=phi_callables, integral=integral
        )
        n = body.n_rotors
        self.n_rotors = n
        self.probe_radius = V.positive_scalar(probe_radius, "probe_radius")
        self._integral = integral_choice(integral)
        p_arr = V.finite(p, "p")
        p_arr = np.broadcast_to(p_arr, (n,)).astype(float) if p_arr.ndim == 0 else p_arr
        if p_arr.shape != (n,):
            raise InputError(f"Expected `p` to have one entry per rotor ({n}), got shape {p_arr.shape}.")
        lam_syms, _ = body.symbols()
        self._lam_syms = None if lam_syms is None else tuple(sp.Symbol(str(s), real=True) for s in lam_syms)
        self._p_syms = (sp.Symbol("p", real=True),) if n == 1 else sp.symbols(f"p1:{n + 1}", real=True)
        model = {str(s): float(v) for s, v in zip(self._p_syms, p_arr)}
        if self._lam_syms is not None:
            model.update({str(s): float(v) for s, v in zip(self._lam_syms, np.diag(body.inertia))})
        self._separable = variables == "v"
        self._A_sym = (
            sp.Matrix(np.rint(body.A).astype(int).tolist()) if body.is_principal else sp.Matrix(body.A.tolist())
        )
        self._lam_inv_sym = (
            sp.diag(*[1 / s for s in self._lam_syms])
            if self._lam_syms is not None
            else sp.Matrix(np.linalg.inv(body.inertia).tolist())
        )
        self.parameters: dict[str, float] = {**model, **{k: float(v) for k, v in phi_params.items()}}
        self._names = tuple(sorted(self.parameters))
        self._lam_idx = (
            None if self._lam_syms is None else np.array([self._names.index(str(x)) for x in self._lam_syms])
        )
        self._p_idx = np.array([self._names.index(str(x)) for x in self._p_syms])
        self._model_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._psyms = tuple(sp.Symbol(k, real=True) for k in self._names)
        if phi_exprs is not None:
            v_of_m = [
                sum(int(c) * s if body.is_principal else float(c) * s for c, s in zip(a, M_SYMBOLS))
                for a in (np.rint(body.axes) if body.is_principal else body.axes)
            ]
            comps = (
                [e.xreplace({V_SYMBOL: v_of_m[i]}) for i, e in enumerate(phi_exprs)] if self._separable else phi_exprs
            )
            self.phi_expression: sp.Matrix | None = sp.Matrix(comps)
            self._phi_1d_exprs = phi_exprs if self._separable else None
            variables_all = [*M_SYMBOLS, *self._psyms]
            jac = self.phi_expression.jacobian(sp.Matrix(M_SYMBOLS))
            phi_f = compile_vector(list(self.phi_expression), variables_all)
            jac_f = compile_vector(jac.tolist(), variables_all)
            self._phi = lambda m, th: phi_f(self._cat(m, th))
            self._dphi = lambda m, th: jac_f(self._cat(m, th))
            if self._separable:
                fs = [compile_vector([e], [V_SYMBOL, *self._psyms]) for e in phi_exprs]
                self._phi_1d = [
                    lambda x, th, f=f: f(
                        np.concatenate(
                            [np.asarray(x, float)[..., None], np.broadcast_to(th, np.shape(x) + th.shape)], -1
                        )
                    )[..., 0]
                    for f in fs
                ]
        else:
            self.phi_expression = None
            self._phi_1d_exprs = None
            self._phi, self._dphi, self._phi_1d = wrap_phi_callables(
                phi_callables, self.body.axes, self._separable, self.n_rotors
            )
            self._check_derivative()
        self.condition = existence_condition(self)
        if not self.condition.holds:
            raise InputError(
                f"This phi has no closed-loop Hamiltonian: {self.condition.detail} A control u = Dphi(m) m' "
                "preserves the rigid-body structure (Definition 2, eq. 27) only if the closed-loop angular "
                "velocity F(m) = Lambda^-1 (m - A (phi(m) + p)) is a gradient, i.e. only if Lambda^-1 A Dphi(m) "
                "is symmetric (the symmetry of Dphi printed in Proposition 5 is not the condition unless the "
                "lambda_i involved are equal). Fix: take phi = A^+ Lambda grad(psi) for a potential psi, e.g. "
                "diagonal phi_i(m_i) (Corollary 2)."
            )
        self._build_hamiltonian()

    # -- constructors -----------------------------------------------------------------------------
    @classmethod
    def one_rotor(
        cls,
        body: RotorBody,
        phi: Any,
        *,
        p: float = 0.0,
        parameters: Mapping[str, float] | None = None,
        dphi: Callable[[np.ndarray], np.ndarray] | None = None,
        probe_radius: float = 1.0,
        integral: str = "auto",
    ) -> StructurePreservingControl:
        """The control of eq. (29a) for one rotor: :math:`u = \\varphi'(v)\\,\\dot v`, :math:`v = a\\cdot m`
        (:math:`m_3` for the seed's rotor on axis 3), which keeps :math:`p = \\Gamma - \\varphi(v)` constant.

        Parameters
        ----------
        body : a :class:`RotorBody` with one rotor (:meth:`RotorBody.one_rotor`).
        phi : a sympy expression or string in ``v`` (other symbols are parameters), or a vectorised
            callable ``phi(v)``, then with ``dphi`` its derivative.
        p : the conserved :math:`p = \\Gamma - \\varphi(m_3)`.
        parameters : values of the parameters of ``phi``.
        probe_radius : radius of the ball of momenta where numeric checks sample (use about ``|m|``).
        integral : ``"auto"`` (default), ``"symbolic"`` or ``"quadrature"``: how the closed-loop Hamiltonian's
            integral is done. ``"auto"`` uses sympy for integrands in the class of
            :func:`geomech.symbolic.integrals.symbolic_friendly` (a rule on the expression, the same on every
            machine) and Gauss-Legendre quadrature otherwise; ``"symbolic"`` always tries sympy first.
        """
        if body.n_rotors != 1:
            raise InputError(
                f"Expected a body with one rotor for `one_rotor`, got {body.n_rotors}; use "
                "`three_rotors`, `diagonal` or `general`."
            )
        return cls._build(
            body,
            "one-rotor",
            [phi],
            "v",
            parameters,
            None if dphi is None else [dphi],
            p,
            probe_radius,
            integral,
            "dphi",
        )

    @classmethod
    def diagonal(
        cls,
        body: RotorBody,
        phis: Sequence[Any],
        *,
        p: Any = 0.0,
        parameters: Mapping[str, float] | None = None,
        derivatives: Sequence[Any] | None = None,
        probe_radius: float = 1.0,
        integral: str = "auto",
    ) -> StructurePreservingControl:
        """Corollary 2: :math:`u_i = \\varphi_i'(v_i)\\,\\dot v_i`, :math:`v_i = a_i\\cdot m` (:math:`m_i` for
        rotors on the principal axes); ``phis`` are expressions in ``v`` or callables with ``derivatives``."""
        phis = list(phis)
        if len(phis) != body.n_rotors:
            raise InputError(f"Expected one phi_i per rotor ({body.n_rotors}), got {len(phis)}.")
        return cls._build(
            body, "diagonal", phis, "v", parameters, derivatives, p, probe_radius, integral, "derivatives"
        )

    @classmethod
    def three_rotors(
        cls,
        body: RotorBody,
        phi: Any,
        *,
        p: Any = 0.0,
        parameters: Mapping[str, float] | None = None,
        jacobian: Callable[[np.ndarray], np.ndarray] | None = None,
        probe_radius: float = 1.0,
        integral: str = "auto",
    ) -> StructurePreservingControl:
        """Proposition 5 for three rotors on the principal axes: :math:`u = D\\varphi(m)\\,\\dot m`.

        ``phi`` is three expressions in ``m1, m2, m3`` (with parameters), or a callable
        ``phi(m) -> (..., 3)`` with ``jacobian(m) -> (..., 3, 3)``.
        """
        if body.n_rotors != 3:
            raise InputError(f"Expected a body with three rotors for `three_rotors`, got {body.n_rotors}.")
        return cls.general(
            body,
            phi,
            p=p,
            parameters=parameters,
            jacobian=jacobian,
            probe_radius=probe_radius,
            integral=integral,
            _kind="three-rotors",
        )

    @classmethod
    def general(
        cls,
        body: RotorBody,
        phi: Any,
        *,
        p: Any = 0.0,
        parameters: Mapping[str, float] | None = None,
        jacobian: Callable[[np.ndarray], np.ndarray] | None = None,
        probe_radius: float = 1.0,
        integral: str = "auto",
        _kind: str = "general",
    ) -> StructurePreservingControl:
        """:math:`u = D\\varphi(m)\\,\\dot m` for any rotor layout, :math:`\\varphi: \\mathbb R^3 \\to \\mathbb R^N`
        (N expressions in ``m1, m2, m3``, or a callable with ``jacobian(m) -> (..., N, 3)``)."""
        if callable(phi) and not isinstance(phi, (str, sp.Basic)):
            return cls._build(
                body,
                _kind,
                [phi],
                "m",
                parameters,
                None if jacobian is None else [jacobian],
                p,
                probe_radius,
                integral,
                "jacobian",
            )
        if isinstance(phi, (str, sp.Basic)) and not isinstance(phi, sp.MatrixBase):
            phi = [phi]
        phi = list(phi)
        if len(phi) != body.n_rotors:
            raise InputError(f"Expected `phi` to have one component per rotor ({body.n_rotors}), got {len(phi)}.")
        return cls._build(body, _kind, phi, "m", parameters, None, p, probe_radius, integral, "jacobian")

    @classmethod
    def _build(cls, body, kind, phis, variables, parameters, derivs, p, probe_radius, integral, dname):
        if all(callable(f) and not isinstance(f, (str, sp.Basic)) for f in phis):
            if derivs is None or len(list(derivs)) != len(phis) or not all(callable(d) for d in derivs):
                raise InputError(
                    f"A callable phi needs its derivative: pass `{dname}` "
                    f"({'phi_i' if variables == 'v' else 'Dphi'} as callables)."
                )
            if parameters:
                raise InputError("`parameters` applies to a symbolic phi; a callable carries its own.")
            return cls(
                body,
                kind,
                phi_exprs=None,
                variables=variables,
                phi_params={},
                phi_callables=(tuple(phis), tuple(derivs)),
                p=p,
                probe_radius=probe_radius,
                integral=integral,
            )
        if any(callable(f) and not isinstance(f, (str, sp.Basic)) for f in phis):
            raise InputError("Expected every phi component to be symbolic, or every one a callable, not a mix.")
        n = body.n_rotors
        lam_syms, _ = body.symbols()
        reserved = {"p"} if n == 1 else {f"p{i + 1}" for i in range(n)}
        reserved |= set() if lam_syms is None else {str(s) for s in lam_syms}
        names_ok = ("v",) if variables == "v" else ("m1", "m2", "m3")
        exprs = parse_phi(phis, names_ok, "phi", reserved)
        given = {str(k): v for k, v in dict(parameters or {}).items()}
        used = sorted({str(s) for e in exprs for s in e.free_symbols} - set(names_ok))
        missing = sorted(set(used) - set(given))
        if missing:
            raise SymbolicError(
                f"`phi` has symbols {missing} that are neither its variable(s) {list(names_ok)} nor given in "
                f"`parameters`; pass parameters={{{', '.join(repr(x) + ': ...' for x in missing)}}}."
            )
        unused = sorted(set(given) - set(used))
        if unused:
            raise SymbolicError(f"`parameters` names {unused}, which do not appear in `phi`.")
        values = {}
        for k in used:
            try:
                values[k] = float(given[k])
            except (TypeError, ValueError) as exc:
                raise SymbolicError(f"Expected parameter `{k}` to be a number, got {given[k]!r}.") from exc
            if not np.isfinite(values[k]):
                raise SymbolicError(f"Expected parameter `{k}` to be finite, got {values[k]}.")
        return cls(
            body,
            kind,
            phi_exprs=exprs,
            variables=variables,
            phi_params=values,
            phi_callables=None,
            p=p,
            probe_radius=probe_radius,
            integral=integral,
        )

    @property
    def phi_of_v(self) -> tuple[sp.Expr, ...] | None:
        """The scalar :math:`\\varphi_i(v)` as given, for one rotor and Corollary 2 (None for a callable or a
        general :math:`\\varphi(m)`)."""
        return None if self._phi_1d_exprs is None else tuple(self._phi_1d_exprs)

    # -- numeric plumbing -------------------------------------------------------------------------------
    def _cat(self, m: np.ndarray, theta: np.ndarray) -> np.ndarray:
        m = np.asarray(m, dtype=float)
        return np.concatenate([m, np.broadcast_to(theta, m.shape[:-1] + theta.shape)], -1)

    def _check_derivative(self) -> None:
        """A callable phi comes with its derivative: check it against central differences of phi."""
        m = self._sample(16, seed=13)
        th = self.theta()
        h = 1e-6 * self.probe_radius
        with np.errstate(all="ignore"):
            D = self._dphi(m, th)
            fd = np.stack([(self._phi(m + h * e, th) - self._phi(m - h * e, th)) / (2 * h) for e in np.eye(3)], -1)
        ok = np.all(np.isfinite(D), axis=(-1, -2)) & np.all(np.isfinite(fd), axis=(-1, -2))
        if not np.any(ok):
            raise InputError(
                f"phi or its derivative is not finite at any of 16 momenta with |m| <= "
                f"{self.probe_radius:g}; set `probe_radius` to the size of the momenta of interest."
            )
        err = np.abs(D[ok] - fd[ok]).max() / max(1.0, np.abs(fd[ok]).max())
        if err > 1e-5:
            k = int(np.argmax(np.abs(D - fd).max(axis=(-1, -2)) * ok))
            raise InputError(
                f"The derivative passed with phi does not match it: relative difference {err:.3g} "
                f"from central differences at m = {np.round(m[k], 6).tolist()}; pass the derivative "
                "of this phi."
            )

    def with_parameters(self, **values: float) -> StructurePreservingControl:
        """The same control law with other parameter values: the model's (the body's named inertias
        ``lambda_i``, ``I3`` and the conserved ``p``) and phi's, as every system's ``with_parameters``; the new
        control is checked and built as a new one (its closed loop, Hamiltonian and existence condition)."""
        lam_names = () if self._lam_syms is None else tuple(str(s) for s in self._lam_syms)
        new = V.parameter_update(values, self.parameters, f"this {self.kind} control", lam_names)
        merged = {**self.parameters, **new}
        body = self.body
        if any(k in new for k in lam_names):
            body = body.with_parameters(**{k: merged[k] for k in lam_names})
        p_names = [str(s) for s in self._p_syms]
        model = set(p_names) | set(lam_names)
        return type(self)(
            body,
            self.kind,
            phi_params={k: v for k, v in merged.items() if k not in model},
            p=[merged[k] for k in p_names],
            probe_radius=self.probe_radius,
            **self._law,
        )

    def theta(self, values: Mapping[str, float] | None = None) -> np.ndarray:
        """The parameter vector (sorted by name), with ``values`` overriding the control's own."""
        vals = dict(self.parameters)
        for k, v in dict(values or {}).items():
            if k not in vals:
                raise InputError(f"Unknown parameter {k!r}; this control's parameters are {list(self._names)}.")
            vals[k] = float(V.finite(v, k))
        return np.array([vals[k] for k in self._names], dtype=float)

    def _model(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:math:`\\Lambda^{-1}` and :math:`p` for the parameter vector ``theta``."""
        key = theta.tobytes()
        cached = self._model_cache.get(key)
        if cached is not None:
            return cached
        if self._lam_idx is not None:
            lam = theta[self._lam_idx]
            if np.any(lam <= 0):
                raise InputError(
                    f"Expected the inertias {[str(s) for s in self._lam_syms or ()]} to be positive, "
                    f"got {lam.tolist()}."
                )
            lam_inv = np.diag(1.0 / lam)
        else:
            lam_inv = np.linalg.inv(self.body.inertia)
        out = (lam_inv, theta[self._p_idx])
        if len(self._model_cache) > 64:
            self._model_cache.clear()
        self._model_cache[key] = out
        return out

    def _sample(self, n: int, seed: int = 7) -> np.ndarray:
        rng = np.random.default_rng(seed)
        x = rng.normal(size=(n, 3))
        r = self.probe_radius * rng.uniform(0.05, 1.0, size=(n, 1)) ** (1 / 3)
        return r * x / np.linalg.norm(x, axis=1, keepdims=True)

    # -- the existence condition --------------------------------------------------------------------
    # -- the closed-loop Hamiltonian (eqs. 29b, 41) --------------------------------------------------------
    def _build_hamiltonian(self) -> None:
        m = sp.Matrix(M_SYMBOLS)
        p = sp.Matrix(self._p_syms)
        quad = (m.T * self._lam_inv_sym * m)[0, 0] / 2 - ((self._A_sym * p).T * self._lam_inv_sym * m)[0, 0]
        psi = None
        if self.phi_expression is not None:
            psi = symbolic_potential(self)
        self.potential_expression: sp.Expr | None = psi
        self.hamiltonian_is_closed_form = psi is not None
        if psi is not None:
            self.H_c = quad - psi
        else:
            self.H_c = quad - potential_integral(self)
        self._psi_f = None if psi is None else compile_scalar(psi, [*M_SYMBOLS, *self._psyms])

    def potential(self, m: Any, theta: np.ndarray | None = None) -> np.ndarray:
        """:math:`\\psi(m)` with :math:`\\nabla\\psi = \\Lambda^{-1}A\\varphi(m)`, :math:`\\psi(0) = 0`."""
        theta = self.theta() if theta is None else theta
        m = V.trailing_shape(m, "m", (3,))
        if self._psi_f is not None:
            return self._psi_f(self._cat(m, theta))
        lam_inv, _ = self._model(theta)
        if self._separable and self.body.is_principal:
            total = np.zeros(m.shape[:-1])
            for i, a in enumerate(self.body.axes):
                coeff = a @ lam_inv @ a

                def phi_i(x: np.ndarray, i: int = i) -> np.ndarray:
                    return self._phi_1d[i](x, theta)

                total = total + coeff * quadrature_from_zero(phi_i, m @ a, what=f"the integral of phi_{i + 1} from 0")
            return total
        A = self.body.A
        return ray_quadrature(
            lambda x: self._phi(x, theta) @ (lam_inv @ A).T, m, what="the closed-loop potential along the ray from 0"
        )

    # -- numeric closed loop ---------------------------------------------------------------------------
    def phi(self, m: Any, values: Mapping[str, float] | None = None) -> np.ndarray:
        """:math:`\\varphi(m)`, shape ``(..., N)`` (``values`` overrides parameters)."""
        return self._phi(V.trailing_shape(m, "m", (3,)), self.theta(values))

    def phi_jacobian(self, m: Any, values: Mapping[str, float] | None = None) -> np.ndarray:
        """:math:`D\\varphi(m)`, shape ``(..., N, 3)`` (``values`` overrides parameters)."""
        return self._dphi(V.trailing_shape(m, "m", (3,)), self.theta(values))

    def conserved_p(self, m: Any, Gamma: Any) -> np.ndarray:
        """:math:`p = \\Gamma - \\varphi(m)`, constant along the controlled motion."""
        Gamma = V.trailing_shape(Gamma, "Gamma", (self.n_rotors,))
        return Gamma - self.phi(m)

    def rotor_momentum(self, m: Any) -> np.ndarray:
        """:math:`\\Gamma(m) = \\varphi(m) + p` on the closed loop (use it as the initial rotor momentum)."""
        _, p = self._model(self.theta())
        return self.phi(m) + p

    def feedback(self, m: Any, Gamma: Any) -> np.ndarray:
        """The torque :math:`u = D\\varphi(m)\\,(m \\times D_1H_f(m, \\Gamma))` from the measured state."""
        m = V.trailing_shape(m, "m", (3,))
        mdot = np.cross(m, self.body.angular_velocity(m, Gamma))
        return np.einsum("...ij,...j->...i", self.phi_jacobian(m), mdot)

    def eq29a_torque(self, m: Any, *, as_printed: bool = False) -> np.ndarray:
        """Eq. (29a) written out for the rotor on axis 3: :math:`u = \\varphi'(m_3)(1/\\lambda_2 - 1/\\lambda_1)
        m_1 m_2`; with ``as_printed=True`` the printed sign :math:`(1/\\lambda_1 - 1/\\lambda_2)`, which does
        not keep :math:`\\Gamma - \\varphi(m_3)` constant given eq. (30c). Shape ``(..., 1)``."""
        if self.kind != "one-rotor" or not self.body.is_principal or abs(self.body.axes[0, 2]) != 1.0:
            raise InputError("eq29a_torque is the seed's formula for one rotor on body axis 3.")
        m = V.trailing_shape(m, "m", (3,))
        lam1, lam2 = self.parameters["lambda1"], self.parameters["lambda2"]
        sign = -1.0 if as_printed else 1.0
        dphi = self.phi_jacobian(m)[..., 0, 2] * self.body.axes[0, 2]
        return (sign * dphi * (1 / lam2 - 1 / lam1) * m[..., 0] * m[..., 1])[..., None]

    def closed_loop_gradient(self, m: Any, theta: np.ndarray | None = None) -> np.ndarray:
        """:math:`F(m) = D_1H_f(m, \\varphi(m) + p) = \\Lambda^{-1}(m - A(\\varphi(m) + p))` (eq. 28)."""
        theta = self.theta() if theta is None else theta
        m = V.trailing_shape(m, "m", (3,))
        lam_inv, p = self._model(theta)
        return (m - (self._phi(m, theta) + p) @ self.body.axes) @ lam_inv.T

    def closed_loop_hessian(self, m: Any, theta: np.ndarray | None = None) -> np.ndarray:
        """:math:`DF(m) = \\Lambda^{-1}(I - A\\,D\\varphi(m))`, symmetric when :attr:`condition` holds."""
        theta = self.theta() if theta is None else theta
        m = V.trailing_shape(m, "m", (3,))
        lam_inv, _ = self._model(theta)
        H = lam_inv @ (np.eye(3) - self.body.A @ self._dphi(m, theta))
        return 0.5 * (H + np.swapaxes(H, -1, -2))

    def closed_loop_hamiltonian(self, m: Any, theta: np.ndarray | None = None) -> np.ndarray:
        """:math:`H_c(m)` (eqs. 29b, 41), :math:`H_c(0) = 0`."""
        theta = self.theta() if theta is None else theta
        m = V.trailing_shape(m, "m", (3,))
        lam_inv, p = self._model(theta)
        lin = lam_inv @ (self.body.A @ p)
        return 0.5 * np.einsum("...i,ij,...j->...", m, lam_inv, m) - m @ lin - self.potential(m, theta)

    def closed_loop(self) -> LeftInvariantSystem:
        """The closed loop as a :class:`LeftInvariantSystem` with Hamiltonian :math:`H_c`.

        From the formula when :math:`H_c` has one (every symbolic feature of the rigid-body core applies:
        ``GeneralizedSerretAndoyer(...).h_p()`` is :math:`h_p = H_c\\circ U_p`); otherwise
        from callables: :math:`H_c` by quadrature, its gradient :math:`F` and Hessian :math:`DF` exact.
        """
        family = self.family()
        formula = family.formula_system()
        return family() if formula is None else formula

    def family(self) -> ClosedLoopFamily:
        """The closed loop as a function of the parameters (for sweeps: nothing symbolic per call)."""
        return ClosedLoopFamily(self)

    # -- checks --------------------------------------------------------------------------------------------
    def lemma4_check(self, n: int = 32, seed: int = 3) -> Lemma4Check:
        """Check Lemma 4 (ii), :math:`\\nabla H_c(m) = D_1H_f(m, \\Gamma(m))`, at ``n`` random momenta
        (:func:`~geomech.systems._closed_loop.lemma4_check`)."""
        return lemma4_check(self, n, seed)

    def hyperregularity(self, *, scan_radius: float | None = None) -> HyperregularityReport:
        """Whether :math:`H_c` is hyperregular: :math:`\\varphi'(v) \\ne 1` (one rotor, Theorem 4),
        :math:`\\varphi_i'(v)\\ne 1` (Corollary 2), :math:`\\det(I - A D\\varphi(m))\\ne 0` in general.

        A symbolic scalar condition is solved by sympy over the reals; otherwise the condition is scanned
        numerically on :math:`|m| \\le` ``scan_radius`` (default 3 x :attr:`probe_radius`), which can show
        failure but not prove success. The Hamiltonian side is never refused on this account.
        """
        R = 3.0 * self.probe_radius if scan_radius is None else V.positive_scalar(scan_radius, "scan_radius")
        return hyperregularity_report(self, R)

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "body": self.body.to_json(),
            "phi": None if self.phi_expression is None else [str(e) for e in self.phi_expression],
            "parameters": dict(self.parameters),
            "closed_loop_hamiltonian": str(self.H_c),
            "closed_loop_hamiltonian_closed_form": self.hamiltonian_is_closed_form,
            "condition": {
                "holds": self.condition.holds,
                "method": self.condition.method,
                "detail": self.condition.detail,
            },
        }

    def __repr__(self) -> str:
        phi = "callable" if self.phi_expression is None else [str(e) for e in self.phi_expression]
        return f"StructurePreservingControl({self.kind}, phi={phi}, parameters={self.parameters})"
