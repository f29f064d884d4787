"""Left-invariant Hamiltonian systems on T*SO(3).

A left-invariant Hamiltonian on :math:`T^*SO(3)` depends on the body angular momentum only,
:math:`H(R, m) = H(m)` (section 4 of the Serret-Andoyer paper). Its Hamiltonian vector field in body
coordinates is (Lemma 1, eq. 13)

.. math::

    \\dot R = R\\,\\widehat{\\nabla H(m)}, \\qquad \\dot m = m \\times \\nabla H(m),

the spatial momentum :math:`p = R m` is conserved (Corollary 1) and so is the Casimir :math:`|m|^2`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, SymbolicError
from ..lie.so3 import hat
from ..symbolic.compile import M_SYMBOLS, bind_expression, compile_scalar, compile_vector
from ._hyperregularity import HyperregularityReport, hamiltonian_hyperregularity

__all__ = ["LeftInvariantSystem", "ParameterFamily", "as_left_invariant"]

ArrayFn = Callable[[np.ndarray], np.ndarray]


def _fd_hessian(gradient: ArrayFn) -> ArrayFn:
    """Hessian by central differences of an exact gradient (error O(h^2), h ~ eps^(1/3) |m|)."""

    def hessian(m: np.ndarray) -> np.ndarray:
        m = np.asarray(m, dtype=float)
        scale = np.maximum(np.linalg.norm(m, axis=-1, keepdims=True), 1.0)
        h = np.cbrt(np.finfo(float).eps) * scale
        cols = []
        for j in range(3):
            e = np.zeros(3)
            e[j] = 1.0
            cols.append((gradient(m + h * e) - gradient(m - h * e)) / (2 * h))
        hess = np.stack(cols, -1)
        return 0.5 * (hess + np.swapaxes(hess, -1, -2))

    return hessian


@dataclass(frozen=True, eq=False)
class LeftInvariantSystem:
    """A Hamiltonian system on :math:`T^*SO(3)` with a left-invariant Hamiltonian :math:`H(m)`.

    Build it with :meth:`from_expression` (a sympy formula in ``m1, m2, m3`` and named parameters; the
    gradient and Hessian are then exact and the symbolic machinery of :mod:`geomech.reduction` applies)
    or with :meth:`from_callable` (a Python function with its gradient; the symbolic features then say
    that they need a formula).

    All numeric methods are vectorised: ``m`` has shape ``(..., 3)``, ``R`` shape ``(..., 3, 3)``.
    """

    name: str
    expression: sp.Expr | None
    parameters: Mapping[str, float]
    _hamiltonian: ArrayFn = field(repr=False)
    _gradient: ArrayFn = field(repr=False)
    _hessian: ArrayFn = field(repr=False)
    hessian_is_exact: bool = True

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_expression(
        cls, expression: Any, parameters: Mapping[str, float] | None = None, *, name: str | None = None
    ) -> LeftInvariantSystem:
        """Build the system from a sympy expression :math:`H(m_1, m_2, m_3; \\text{parameters})`.

        Parameters
        ----------
        expression : sympy expression or str
            The Hamiltonian. Symbols named ``m1``, ``m2``, ``m3`` are the body momentum components
            (whatever their assumptions); every other free symbol is a parameter.
        parameters : mapping of str to float, optional
            Values of the parameters, by symbol name. Every parameter must be given.
        name : str, optional
            A label used in reprs, JSON and plots.
        """
        expr, params = bind_expression(expression, parameters, M_SYMBOLS, "expression")
        grad = [sp.diff(expr, s) for s in M_SYMBOLS]
        hess = [[sp.diff(g, s) for s in M_SYMBOLS] for g in grad]
        subs = {sp.Symbol(k, real=True): v for k, v in params.items()}
        num = expr.subs(subs)
        return cls(
            name=name or "H(m)",
            expression=expr,
            parameters=params,
            _hamiltonian=compile_scalar(num, M_SYMBOLS),
            _gradient=compile_vector([g.subs(subs) for g in grad], M_SYMBOLS),
            _hessian=compile_vector([[h.subs(subs) for h in row] for row in hess], M_SYMBOLS),
        )

    @classmethod
    def from_callable(
        cls,
        hamiltonian: ArrayFn,
        gradient: ArrayFn,
        hessian: ArrayFn | None = None,
        *,
        name: str = "H(m)",
    ) -> LeftInvariantSystem:
        """Build the system from Python callables.

        Each callable takes ``m`` of shape ``(..., 3)``; ``hamiltonian`` returns ``(...)``, ``gradient``
        ``(..., 3)`` and ``hessian`` ``(..., 3, 3)``. Without ``hessian`` it is computed by central
        differences of ``gradient`` (relative error about 1e-10), and :attr:`hessian_is_exact` is False.
        """
        for arg, fn in (("hamiltonian", hamiltonian), ("gradient", gradient)):
            if not callable(fn):
                raise InputError(f"Expected `{arg}` to be callable, got {type(fn).__name__}.")
        if hessian is not None and not callable(hessian):
            raise InputError(f"Expected `hessian` to be callable or None, got {type(hessian).__name__}.")
        probe = np.array([0.3, -0.2, 0.7])
        g = np.asarray(gradient(probe), dtype=float)
        if g.shape != (3,):
            raise InputError(f"Expected `gradient` to return shape (..., 3), got {g.shape} for m of shape (3,).")
        return cls(
            name=name,
            expression=None,
            parameters={},
            _hamiltonian=hamiltonian,
            _gradient=gradient,
            _hessian=hessian if hessian is not None else _fd_hessian(gradient),
            hessian_is_exact=hessian is not None,
        )

    def with_parameters(self, **values: float) -> LeftInvariantSystem:
        """The same Hamiltonian with other values of its parameters (as
        :meth:`NonholonomicSystem.with_parameters <geomech.systems.NonholonomicSystem.with_parameters>`)."""
        if self.expression is None:
            raise InputError(
                f"{self.name} was built from Python callables and has no named parameters; build it with "
                "LeftInvariantSystem.from_expression to set parameter values."
            )
        merged = {**self.parameters, **V.parameter_update(values, self.parameters, self.name)}
        return LeftInvariantSystem.from_expression(self.expression, merged, name=self.name)

    def family(self) -> ParameterFamily:
        """The system as a function of its parameters, ``family(**values)`` (for sweeps and stability maps:
        :func:`~geomech.analysis.stability_map` compiles the formula once for every point)."""
        if self.expression is None:
            raise InputError(
                f"{self.name} was built from Python callables and has no named parameters to sweep; build it with "
                "LeftInvariantSystem.from_expression."
            )
        return ParameterFamily(self)

    # -- the Hamiltonian and its derivatives ----------------------------------------------------
    def hamiltonian(self, m: Any) -> np.ndarray:
        """:math:`H(m)`, shape ``(...)``."""
        m = V.trailing_shape(m, "m", (3,))
        return np.asarray(self._hamiltonian(m), dtype=float)

    def gradient(self, m: Any) -> np.ndarray:
        """:math:`\\nabla H(m)`, the body angular velocity :math:`\\omega`, shape ``(..., 3)``."""
        m = V.trailing_shape(m, "m", (3,))
        return np.asarray(self._gradient(m), dtype=float)

    def hessian(self, m: Any) -> np.ndarray:
        """:math:`D^2 H(m)`, shape ``(..., 3, 3)``."""
        m = V.trailing_shape(m, "m", (3,))
        return np.asarray(self._hessian(m), dtype=float)

    # -- equations of motion (Lemma 1, eq. 13) -------------------------------------------------
    def euler_vector_field(self, m: Any) -> np.ndarray:
        """Euler's equation :math:`\\dot m = m \\times \\nabla H(m)` (second component of eq. 13)."""
        m = V.trailing_shape(m, "m", (3,))
        return np.cross(m, self._gradient(m))

    def attitude_vector_field(self, R: Any, m: Any) -> np.ndarray:
        """The attitude equation :math:`\\dot R = R\\,\\widehat{\\nabla H(m)}` (first component of eq. 13)."""
        R = V.trailing_shape(R, "R", (3, 3))
        m = V.trailing_shape(m, "m", (3,))
        return R @ hat(np.asarray(self._gradient(m), dtype=float), check=False)

    def vector_field(self, R: Any, m: Any) -> tuple[np.ndarray, np.ndarray]:
        """The full vector field :math:`X_H(R, m) = (R\\,\\widehat{\\nabla H}, m \\times \\nabla H)`."""
        return self.attitude_vector_field(R, m), self.euler_vector_field(m)

    # -- invariants ------------------------------------------------------------------------------
    @staticmethod
    def casimir(m: Any) -> np.ndarray:
        """The Casimir :math:`|m|^2` of the Lie-Poisson bracket on so(3)*."""
        m = V.trailing_shape(m, "m", (3,))
        return np.einsum("...i,...i->...", m, m)

    @staticmethod
    def spatial_momentum(R: Any, m: Any) -> np.ndarray:
        """The spatial angular momentum :math:`p = R m`, the momentum map of the left action (Theorem 1)."""
        R = V.trailing_shape(R, "R", (3, 3))
        m = V.trailing_shape(m, "m", (3,))
        return np.einsum("...ij,...j->...i", R, m)

    # -- Legendre transform --------------------------------------------------------------------
    def hessian_determinant(self, m: Any) -> np.ndarray:
        """:math:`\\det D^2H(m)`: the fibre derivative :math:`m \\mapsto \\nabla H(m)` is a local
        diffeomorphism where it does not vanish."""
        return np.linalg.det(self.hessian(m))

    def is_hyperregular_at(self, m: Any, *, rtol: float = 1e-10) -> np.ndarray:
        """Whether the Hessian of H is invertible at ``m`` (relative to its largest singular value).

        Hyperregularity (the fibre derivative :math:`FH` a diffeomorphism) is what the Lagrangian side
        (eq. 14, Euler-angle velocities) needs; the Hamiltonian side (Lie-Poisson flow, Serret-Andoyer
        reduction, stability) does not need it. Invertibility at every point is necessary for it;
        :meth:`hyperregularity` states what can be proved symbolically.
        """
        s = np.linalg.svd(self.hessian(m), compute_uv=False)
        return s[..., -1] > rtol * np.maximum(s[..., 0], np.finfo(float).tiny)

    def hyperregularity(self, radius: float = 10.0) -> HyperregularityReport:
        """Whether :math:`m \\mapsto \\nabla H(m)` is a diffeomorphism (Lemma 1's Legendre transform), as a
        :class:`~geomech.systems._hyperregularity.HyperregularityReport`: ``status`` ``"yes"`` (proved),
        ``"no"`` (with where it fails) or ``"unknown"`` (with the reason; ``radius`` bounds the numeric search of
        a non-separable H). Quadratic and separable H are decided exactly (sympy); see
        :func:`~geomech.systems._hyperregularity.hamiltonian_hyperregularity`."""
        return hamiltonian_hyperregularity(self, V.positive_scalar(radius, "radius"))

    def legendre(self, m: Any) -> np.ndarray:
        """The fibre derivative :math:`FH: m \\mapsto \\omega = \\nabla H(m)` (Lemma 1)."""
        return self.gradient(m)

    def inverse_legendre(
        self, omega: Any, m_guess: Any | None = None, *, tol: float = 1e-13, max_iter: int = 50
    ) -> np.ndarray:
        """Solve :math:`\\nabla H(m) = \\omega` for ``m`` by Newton's method with the exact Hessian.

        This is :math:`FL = (FH)^{-1}` of Lemma 1, defined where H is hyperregular. Raises
        :class:`~geomech.errors.ConvergenceError` with the residual when Newton does not converge, and
        :class:`~geomech.errors.SingularityError` where the Hessian is singular.
        """
        from ..errors import ConvergenceError, SingularityError

        omega = V.trailing_shape(omega, "omega", (3,))
        m = np.array(omega if m_guess is None else V.trailing_shape(m_guess, "m_guess", (3,)), dtype=float)
        m = np.broadcast_to(m, omega.shape).copy()
        scale = max(1.0, float(np.abs(omega).max(initial=0.0)))
        for _ in range(max_iter):
            r = self._gradient(m) - omega
            if np.abs(r).max(initial=0.0) <= tol * scale:
                return m
            hess = self._hessian(m)
            if np.any(~self.is_hyperregular_at(m)):
                raise SingularityError(
                    f"The Hessian of {self.name} is singular at m = {m.tolist()}: the Legendre transform "
                    "is not invertible there (H is not hyperregular)."
                )
            m = m - np.linalg.solve(hess, r[..., None])[..., 0]
        raise ConvergenceError(
            f"Newton for the inverse Legendre transform of {self.name} did not converge in {max_iter} "
            f"iterations; residual {np.abs(r).max():.3g} (tolerance {tol * scale:.3g})."
        )

    # -- display ---------------------------------------------------------------------------------
    def require_expression(self, feature: str) -> sp.Expr:
        """Return the symbolic Hamiltonian, or raise :class:`SymbolicError` saying ``feature`` needs one."""
        if self.expression is None:
            raise SymbolicError(
                f"{feature} needs a formula for H(m); {self.name} was built from a Python callable. "
                "Build it with LeftInvariantSystem.from_expression."
            )
        return self.expression

    def latex(self) -> str:
        """The Hamiltonian as LaTeX."""
        return "H(m) = " + sp.latex(self.require_expression("latex()"))

    def __str__(self) -> str:
        if self.expression is None:
            return f"LeftInvariantSystem({self.name}, from a callable)"
        params = ", ".join(f"{k}={v:g}" for k, v in self.parameters.items())
        return f"LeftInvariantSystem(H = {self.expression}{'; ' + params if params else ''})"

    def _repr_latex_(self) -> str | None:
        """Jupyter: :math:`H(m)` and the parameter values (nothing for a system built from a callable)."""
        if self.expression is None:
            return None
        from .._display import latex_block, latex_text

        lines = [("H(m)", sp.latex(self.expression))]
        lines += [(sp.latex(sp.Symbol(k)), f"{v:g}") for k, v in self.parameters.items()]
        return latex_block(latex_text(self.name) if self.name else "", lines)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready description."""
        return {
            "kind": "LeftInvariantSystem",
            "name": self.name,
            "hamiltonian": None if self.expression is None else str(self.expression),
            "latex": None if self.expression is None else sp.latex(self.expression),
            "parameters": dict(self.parameters),
        }


class ParameterFamily:
    """A left-invariant system given by a formula, as a function of its parameters: ``family(**values)`` is
    ``system.with_parameters(**values)``. Analyses that compile the formula read :meth:`formula_system`."""

    def __init__(self, system: LeftInvariantSystem):
        self.system = system

    def __call__(self, **values: float) -> LeftInvariantSystem:
        return self.system.with_parameters(**values) if values else self.system

    def formula_system(self) -> LeftInvariantSystem:
        """The formula in :math:`m` and every parameter, at the system's values."""
        return self.system

    def check_values(self, values: Mapping[str, Any]) -> None:
        """Raise the :class:`InputError` that ``family(**point)`` raises, for any point of ``values`` (name ->
        array of the points' values): an unknown name or a value that is not finite."""
        for k, v in values.items():
            V.finite(v, str(k))
        first = {k: float(np.ravel(v)[0]) for k, v in values.items()}
        V.parameter_update(first, self.system.parameters, self.system.name)

    def to_json(self) -> dict[str, Any]:
        return {"hamiltonian": str(self.system.expression), "parameters": dict(self.system.parameters)}


def as_left_invariant(system: Any) -> LeftInvariantSystem:
    """Return ``system`` as a :class:`LeftInvariantSystem` (objects that wrap one expose ``.system``)."""
    if isinstance(system, LeftInvariantSystem):
        return system
    inner = getattr(system, "system", None)
    if isinstance(inner, LeftInvariantSystem):
        return inner
    raise InputError(
        f"Expected a left-invariant system on T*SO(3) (LeftInvariantSystem, RigidBody, ...), "
        f"got {type(system).__name__}."
    )
