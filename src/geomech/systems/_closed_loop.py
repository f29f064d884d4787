"""The theory behind a structure-preserving control (Lemma 4 (ii) of the Serret-Andoyer paper), for
:class:`~geomech.systems.control.StructurePreservingControl`: the exact existence condition of a closed-loop
Hamiltonian (:math:`\\Lambda^{-1}A\\,D\\varphi` symmetric, not the printed condition: below), decided structurally,
symbolically or numerically, and the potential :math:`\\psi` with :math:`\\nabla\\psi = \\Lambda^{-1}A\\varphi`,
:math:`\\psi(0) = 0`, in closed form where sympy finds and differentiation confirms it, else as an integral to
evaluate by quadrature.

**The exact existence condition.** Eq. (27a) asks :math:`\\nabla H_c = F` exactly (Lemma 4 (ii)), and
on a star-shaped domain :math:`F` is a gradient if and only if its Jacobian
:math:`DF = \\Lambda^{-1}(I - A\\,D\\varphi)` is symmetric, i.e. iff

.. math::

    \\Lambda^{-1} A\\, D\\varphi(m) \\ \\text{is symmetric for every } m

(for three rotors on the principal axes: :math:`\\partial_j\\varphi_i/\\lambda_i = \\partial_i\\varphi_j/\\lambda_j`).
The condition printed in Proposition 5, :math:`D\\varphi` symmetric, is neither necessary nor
sufficient unless the :math:`\\lambda_i` involved are equal: :math:`\\varphi = (a m_2, a m_1, 0)` has a
symmetric :math:`D\\varphi` and no :math:`H_c` when :math:`\\lambda_1 \\ne \\lambda_2`, while
:math:`\\varphi = (\\lambda_1 c\\, m_2, \\lambda_2 c\\, m_1, 0)` has an :math:`H_c` and a non-symmetric
:math:`D\\varphi`. A :math:`\\varphi` that fails the condition is rejected with the reason.

Then :math:`H_c(m) = \\tfrac12 m\\cdot\\Lambda^{-1}m - (Ap)\\cdot\\Lambda^{-1}m - \\psi(m)` with
:math:`\\nabla\\psi = \\Lambda^{-1}A\\varphi` and :math:`\\psi(0) = 0`: the constant of integration is fixed
by integrating from 0. For one rotor on axis 3 this is eq. (29b), for the diagonal controls of
Corollary 2 eq. (41). :math:`\\psi` is computed by sympy where it finds an antiderivative (checked by
differentiation at random points) and by Gauss-Legendre quadrature otherwise.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..symbolic.compile import M_SYMBOLS, compile_scalar, compile_vector
from ..symbolic.integrals import integral_from_zero
from ._hyperregularity import V_SYMBOL
from .left_invariant import LeftInvariantSystem

__all__ = [
    "ClosedLoopCondition",
    "ClosedLoopFamily",
    "Lemma4Check",
    "existence_condition",
    "lemma4_check",
    "potential_integral",
    "symbolic_potential",
]

#: The asymmetry of Lambda^-1 A Dphi is simplified symbolically only up to this size (sympy operations).
_SIMPLIFY_MAX_OPS = 400


@dataclass(frozen=True)
class ClosedLoopCondition:
    """Whether :math:`\\Lambda^{-1}A\\,D\\varphi` is symmetric, i.e. whether a closed-loop Hamiltonian exists.

    ``method`` is ``"symbolic"`` (sympy simplified the asymmetry to 0 for these parameter values),
    ``"numeric"`` (checked at random points, to ``tolerance`` relative) or ``"structural"`` (one rotor on
    a principal axis: a 1x1 block). ``detail`` says what was checked and, when it fails, where.
    """

    holds: bool
    method: str
    detail: str
    max_asymmetry: float


def _asymmetry(control: Any, m: np.ndarray, theta: np.ndarray) -> np.ndarray:
    lam_inv, _ = control._model(theta)
    with np.errstate(all="ignore"):
        M = lam_inv @ control.body.A @ control._dphi(m, theta)
    scale = np.maximum(np.abs(M).max(axis=(-1, -2)), np.abs(lam_inv).max())
    rel = np.abs(M - np.swapaxes(M, -1, -2)).max(axis=(-1, -2)) / scale
    return np.where(np.isfinite(rel), rel, 0.0)


def existence_condition(control: Any, theta: np.ndarray | None = None) -> ClosedLoopCondition:
    theta = control.theta() if theta is None else theta
    if control.n_rotors == 1 and control._separable:
        # One scalar phi(a.m): Lambda^-1 A Dphi = phi' (Lambda^-1 a) a^T, symmetric iff a is a principal axis.
        a = control.body.axes[0]
        w = control._model(theta)[0] @ a
        if np.linalg.norm(np.cross(w, a)) <= 1e-12 * np.linalg.norm(w):
            return ClosedLoopCondition(
                True,
                "structural",
                "Lambda^-1 A Dphi = phi'(v) (Lambda^-1 a) a^T is "
                "symmetric: the rotor axis a is a principal axis of Lambda.",
                0.0,
            )
    pts = control._sample(64)
    asym = _asymmetry(control, pts, theta)
    worst = float(asym.max())
    tol = 1e-9
    if control.phi_expression is not None:
        M = control._lam_inv_sym * control._A_sym * control.phi_expression.jacobian(sp.Matrix(M_SYMBOLS))
        # Exact rationals (the binary values of the floats), so that an asymmetry that cancels for these
        # values simplifies to exactly 0 rather than to a round-off residue.
        subs = {s: sp.Rational(float(x)) for s, x in zip(control._psyms, theta)}
        entries = []
        for i in range(3):
            for j in range(i + 1, 3):
                d = M[i, j] - M[j, i]
                # simplified only below a size bound (a rule, not a timer); larger ones are checked
                # numerically below
                zero = sp.count_ops(d) <= _SIMPLIFY_MAX_OPS and sp.simplify(d.subs(subs)) == 0
                entries.append((i, j, d, zero))
        if all(z for *_, z in entries):
            return ClosedLoopCondition(
                True, "symbolic", "Lambda^-1 A Dphi is symmetric (sympy, for these parameter values).", worst
            )
        if worst <= tol:
            return ClosedLoopCondition(
                True,
                "numeric",
                f"Lambda^-1 A Dphi symmetric to {tol:g} at 64 random "
                "momenta (sympy could not simplify the asymmetry to 0).",
                worst,
            )
        k = int(np.argmax(asym))
        bad = [f"({i + 1},{j + 1}): {sp.simplify(d)}" for i, j, d, z in entries if not z]
        return ClosedLoopCondition(
            False,
            "numeric",
            f"Lambda^-1 A Dphi is not symmetric; asymmetry M_ij - M_ji at {', '.join(bad)}, "
            f"e.g. relative asymmetry {worst:.3g} at m = {np.round(pts[k], 6).tolist()}.",
            worst,
        )
    if worst <= tol:
        return ClosedLoopCondition(
            True,
            "numeric",
            f"Lambda^-1 A Dphi symmetric to {tol:g} at 64 random momenta with |m| <= {control.probe_radius:g}.",
            worst,
        )
    k = int(np.argmax(asym))
    return ClosedLoopCondition(
        False,
        "numeric",
        f"Lambda^-1 A Dphi is not symmetric: relative asymmetry {worst:.3g} at m = {np.round(pts[k], 6).tolist()}.",
        worst,
    )


def potential_integral(control: Any) -> sp.Expr:
    """:math:`\\psi` as an unevaluated integral, for display when sympy has no antiderivative."""
    s = sp.Dummy("s", real=True)
    if control._separable and control.body.is_principal:
        terms = []
        for i, a in enumerate(np.rint(control.body.axes).astype(int)):
            j = int(np.argmax(np.abs(a)))
            coeff = (sp.Matrix(a.tolist()).T * control._lam_inv_sym * sp.Matrix(a.tolist()))[0, 0]
            f = control._phi_1d_exprs[i] if control._phi_1d_exprs is not None else sp.Function(f"phi{i + 1}")(V_SYMBOL)
            terms.append(coeff * sp.Integral(f.xreplace({V_SYMBOL: s}), (s, 0, int(a[j]) * M_SYMBOLS[j])))
        return sp.Add(*terms)
    t = sp.Dummy("t", real=True)
    g = (
        control._lam_inv_sym
        * control._A_sym
        * (
            control.phi_expression
            if control.phi_expression is not None
            else sp.Matrix([sp.Function(f"phi{i + 1}")(*M_SYMBOLS) for i in range(control.n_rotors)])
        )
    )
    gm = g.xreplace({x: t * x for x in M_SYMBOLS})
    return sp.Integral((gm.T * sp.Matrix(M_SYMBOLS))[0, 0], (t, 0, 1))


def symbolic_potential(control: Any) -> sp.Expr | None:
    g = control._lam_inv_sym * control._A_sym * control.phi_expression
    m1, m2, m3 = M_SYMBOLS
    # The path 0 -> (m1,0,0) -> (m1,m2,0) -> m: three one-dimensional integrals, each easier for sympy
    # than the ray integral, and exact for a curl-free g.
    pieces = [(g[0].xreplace({m2: 0, m3: 0}), m1), (g[1].xreplace({m3: 0}), m2), (g[2], m3)]
    psi = sp.Integer(0)
    for integrand, var in pieces:
        if integrand == 0:
            continue
        val = integral_from_zero(integrand, var, var, control._integral)
        if val is None:
            return None
        psi += val
    if not _verify_potential(control, psi, g):
        return None
    return psi


def _verify_potential(control: Any, psi: sp.Expr, g: sp.Matrix) -> bool:
    variables = [*M_SYMBOLS, *control._psyms]
    try:
        grad = compile_vector([sp.diff(psi, s) for s in M_SYMBOLS], variables)
        gf = compile_vector(list(g), variables)
        val = compile_scalar(psi, variables)
    except Exception:  # noqa: BLE001 - lambdify cannot print some special functions; quadrature then
        return False
    x = control._cat(control._sample(12, seed=11), control.theta())
    with np.errstate(all="ignore"):
        a, b, v0 = grad(x), gf(x), val(control._cat(np.zeros((1, 3)), control.theta()))
    ok = np.all(np.isfinite(b), axis=-1)
    if not np.any(ok) or not np.all(np.isfinite(a[ok])) or not np.all(np.isfinite(v0)):
        return False
    return bool(np.abs(a[ok] - b[ok]).max() <= 1e-9 * max(1.0, np.abs(b[ok]).max()) and abs(v0[0]) < 1e-12)


@dataclass(frozen=True)
class Lemma4Check:
    """Lemma 4 (ii), :math:`\\nabla H_c(m) = D_1H_f(m, \\Gamma(m))`, at random states.

    ``gradient_route`` says how :math:`\\nabla H_c` was obtained independently of :math:`F`: by sympy
    differentiation of the closed-form :math:`H_c`, or by 4th-order central differences of the
    quadrature :math:`H_c`.
    """

    max_error: float
    max_relative_error: float
    n_points: int
    gradient_route: str

    def passed(self, rtol: float = 1e-8) -> bool:
        return self.max_relative_error <= rtol


def lemma4_check(control: Any, n: int = 32, seed: int = 3) -> Lemma4Check:
    """Check Lemma 4 (ii), :math:`\\nabla H_c(m) = D_1H_f(m, \\Gamma(m))`, at ``n`` random momenta.

    :math:`D_1H_f` comes from the body's free Hamiltonian (eq. 24 / 37) at :math:`\\Gamma = \\varphi(m)+p`;
    :math:`\\nabla H_c` from sympy's derivative of the closed-form :math:`H_c` or, for a quadrature
    :math:`H_c`, from 4th-order central differences of it.
    """
    m = control._sample(int(n), seed=seed)
    with np.errstate(all="ignore"):
        ok = np.all(np.isfinite(control.phi(m)), axis=-1)
    m = m[ok]
    d1 = control.body.angular_velocity(m, control.rotor_momentum(m))
    if control.hamiltonian_is_closed_form:
        variables = [*M_SYMBOLS, *control._psyms]
        grad = compile_vector([sp.diff(control.H_c, s) for s in M_SYMBOLS], variables)
        g = grad(control._cat(m, control.theta()))
        route = "sympy derivative of the closed-form H_c"
    else:
        h = 1e-3 * max(control.probe_radius, 1e-3)
        cols = []
        for j in range(3):
            e = np.zeros(3)
            e[j] = h
            H = [control.closed_loop_hamiltonian(m + c * e) for c in (-2, -1, 1, 2)]
            cols.append((H[0] - 8 * H[1] + 8 * H[2] - H[3]) / (12 * h))
        g = np.stack(cols, -1)
        route = "4th-order central differences of the quadrature H_c"
    err = np.abs(g - d1).max(axis=-1)
    rel = err / np.maximum(np.abs(d1).max(axis=-1), 1e-300)
    return Lemma4Check(float(err.max()), float(rel.max()), int(m.shape[0]), route)


class ClosedLoopFamily:
    """The closed loop :math:`H_c` as a function of the control's parameters.

    ``family(k=0.6, lambda2=2.1)`` returns a :class:`LeftInvariantSystem` built from compiled callables
    (:math:`H_c`, the exact gradient :math:`F` and Hessian :math:`DF`); the existence condition is
    re-checked numerically for the new values, since it can depend on them.
    """

    def __init__(self, control: Any):
        self.control = control
        self.names = control._names

    @functools.cached_property
    def _formula(self) -> LeftInvariantSystem | None:
        c = self.control
        if not c.hamiltonian_is_closed_form:
            return None
        names = {str(s) for s in c.H_c.free_symbols}
        params = {k: v for k, v in c.parameters.items() if k in names}
        return LeftInvariantSystem.from_expression(c.H_c, params, name="closed loop H_c")

    def formula_system(self) -> LeftInvariantSystem | None:
        """The closed loop as one formula in :math:`m` and every parameter (at the control's values), for analyses
        that compile it once and sweep the parameters; None when :math:`H_c` has no closed form."""
        return self._formula

    @functools.cached_property
    def _condition_everywhere(self) -> bool:
        r"""Whether the existence condition holds for every value of the parameters: rotors on principal axes of a
        diagonal :math:`\Lambda` under a separable :math:`\varphi` (:math:`\Lambda^{-1}A\,D\varphi` is diagonal),
        or an asymmetry that sympy simplifies to 0 with the parameters as symbols."""
        c = self.control
        if c._separable and c.body.is_principal:
            return True
        if c.phi_expression is None:
            return False
        M = c._lam_inv_sym * c._A_sym * c.phi_expression.jacobian(sp.Matrix(M_SYMBOLS))
        for i in range(3):
            for j in range(i + 1, 3):
                d = M[i, j] - M[j, i]
                if d != 0 and (sp.count_ops(d) > _SIMPLIFY_MAX_OPS or sp.simplify(d) != 0):
                    return False
        return True

    def check_values(self, values: Mapping[str, Any]) -> None:
        """Raise the :class:`InputError` that ``family(**point)`` raises, for any point of ``values`` (name ->
        array of the points' values, or one value for all): an unknown name, a value that is not finite, a
        nonpositive inertia, or a point where no closed-loop Hamiltonian exists."""
        c = self.control
        columns = {str(k): np.atleast_1d(V.finite(v, str(k))).ravel() for k, v in values.items()}
        if not columns:
            return
        n = max(col.size for col in columns.values())
        columns = {k: np.broadcast_to(col, (n,)) for k, col in columns.items()}

        def point(i: int) -> dict[str, float]:
            return {k: float(col[i]) for k, col in columns.items()}

        c.theta(point(0))  # every name known
        for s in c._lam_syms or ():
            col = columns.get(str(s))
            if col is not None and np.any(col <= 0):
                c._model(c.theta(point(int(np.argmax(col <= 0)))))  # raises, naming the inertias
        if not self._condition_everywhere:
            for i in range(n):
                self._require_condition(point(i), c.theta(point(i)))

    def _require_condition(self, values: Mapping[str, float], theta: np.ndarray) -> None:
        cond = existence_condition(self.control, theta)
        if not cond.holds:
            raise InputError(f"For {dict(values)} this phi has no closed-loop Hamiltonian: {cond.detail}")

    def __call__(self, **values: float) -> LeftInvariantSystem:
        c = self.control
        theta = c.theta(values)
        if values and not self._condition_everywhere:
            self._require_condition(values, theta)
        label = ", ".join(f"{k}={v:g}" for k, v in zip(c._names, theta))
        lam_inv, p = c._model(theta)
        Ap, A, axes = p @ c.body.axes, c.body.A, c.body.axes
        eye = np.eye(3)

        # Unchecked closures (LeftInvariantSystem validates its arguments): these run in Newton's inner loops.
        def gradient(m: np.ndarray) -> np.ndarray:
            return (m - Ap - c._phi(m, theta) @ axes) @ lam_inv.T

        def hessian(m: np.ndarray) -> np.ndarray:
            H = lam_inv @ (eye - A @ c._dphi(m, theta))
            return 0.5 * (H + np.swapaxes(H, -1, -2))

        return LeftInvariantSystem.from_callable(
            lambda m: c.closed_loop_hamiltonian(m, theta), gradient, hessian, name=f"closed loop H_c ({label})"
        )
