"""What every canonical chart of :math:`T^*SO(3)` shares: a left-invariant :math:`H(m)` read as :math:`K(y) =
H(m(y))` in the chart's coordinates :math:`y = (q, p)`, its gradient by the chain rule through the chart's exact
:math:`\\partial m/\\partial y`, Hamilton's equations, the :class:`~geomech.systems.CanonicalSystem` for the canonical
integrators, and the symbolic :math:`K` and equations. A chart (the 3-1-3 Euler angles, the quaternions) gives its
coordinates, their validation, :math:`m(y)`, its Jacobian and its expressions."""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np
import sympy as sp

from ..symbolic.compile import M_SYMBOLS
from ..systems.left_invariant import LeftInvariantSystem, as_left_invariant


class CotangentChart:
    """Base of :class:`~geomech.reduction.EulerCoordinates` and :class:`~geomech.reduction.QuaternionCoordinates`
    (immutable; ``system`` the Hamiltonian, ``_cache`` its symbolic derivations)."""

    __slots__ = ("_cache", "system")

    system: LeftInvariantSystem
    _cache: dict[Any, Any]

    #: The coordinate symbols, the n positions then their n momenta.
    symbols: ClassVar[tuple[sp.Symbol, ...]] = ()
    #: How the canonical system is named after the Hamiltonian ("in 3-1-3 Euler coordinates").
    chart_name: ClassVar[str] = ""
    #: Indices of the positions that are angles.
    angle_coordinates: ClassVar[tuple[int, ...]] = ()

    def __init__(self, system: Any):
        object.__setattr__(self, "system", as_left_invariant(system))
        object.__setattr__(self, "_cache", {})

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable; build a new one.")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.system})"

    @property
    def n(self) -> int:
        return len(self.symbols) // 2

    # -- what a chart provides (as staticmethods): the coordinates checked, m(y), dm/dy, and m's expressions --------
    _y: ClassVar[staticmethod[[Any], np.ndarray]]
    _m: ClassVar[staticmethod[[np.ndarray], np.ndarray]]
    _dm: ClassVar[staticmethod[[np.ndarray], np.ndarray]]
    _m_expressions: ClassVar[staticmethod[[], list[sp.Expr]]]

    # -- the Hamiltonian side ----------------------------------------------------------------------
    def hamiltonian(self, y: Any) -> np.ndarray:
        """:math:`K(y) = H(m(y))`, shape ``(...)``."""
        return self.system.hamiltonian(self._m(self._y(y)))

    def gradient(self, y: Any) -> np.ndarray:
        """:math:`\\partial K/\\partial y_j = \\nabla H(m)\\cdot\\partial m/\\partial y_j`, shape ``(..., 2n)``: only
        :meth:`LeftInvariantSystem.gradient` is needed, so it works for systems built from callables."""
        y = self._y(y)
        return np.einsum("...i,...ij->...j", self.system.gradient(self._m(y)), self._dm(y))

    def vector_field(self, y: Any) -> np.ndarray:
        """Hamilton's canonical equations
        :math:`(\\dot q, \\dot p) = (\\partial K/\\partial p, -\\partial K/\\partial q)` by the chain rule of
        :meth:`gradient`, shape ``(..., 2n)``."""
        g = self.gradient(y)
        n = self.n
        return np.concatenate([g[..., n:], -g[..., :n]], -1)

    def canonical_system(self):
        """This Hamiltonian as a :class:`~geomech.systems.CanonicalSystem` in the chart's coordinates, for the
        canonical integrators: from a formula with exact (symbolic) gradient and Hessian; from a callable with the
        chain rule of :meth:`gradient` and no Hessian."""
        from ..systems.canonical import CanonicalSystem

        name = f"{self.system.name} {self.chart_name}"
        n = self.n
        if self.system.expression is not None:
            return CanonicalSystem.from_expression(
                self.canonical_hamiltonian(),
                self.symbols[:n],
                self.symbols[n:],
                name=name,
                angle_coordinates=self.angle_coordinates,
                substitutions=self._parameter_subs(),
            )
        return CanonicalSystem(
            n=n,
            name=name,
            _hamiltonian=lambda y: self.hamiltonian(y),
            _gradient=lambda y: self.gradient(y),
            angle_coordinates=self.angle_coordinates,
        )

    # -- symbolic ----------------------------------------------------------------------------------
    def _parameter_subs(self) -> dict[sp.Symbol, float]:
        return {sp.Symbol(k, real=True): v for k, v in self.system.parameters.items()}

    def canonical_hamiltonian(self, *, substitute_parameters: bool = False) -> sp.Expr:
        """:math:`K = H(m(y))` as a sympy expression in :attr:`symbols`; parameters of H stay symbolic unless
        ``substitute_parameters``.

        Raises
        ------
        SymbolicError
            When the system was built from a callable.
        """
        key = ("K", substitute_parameters)
        if key not in self._cache:
            expr = self.system.require_expression(f"{type(self).__name__}.canonical_hamiltonian()")
            if substitute_parameters:
                expr = expr.subs(self._parameter_subs())
            self._cache[key] = expr.xreplace(dict(zip(M_SYMBOLS, self._m_expressions())))
        return self._cache[key]

    def hamilton_equations(self, *, substitute_parameters: bool = False) -> tuple[sp.Expr, ...]:
        """Right-hand sides of Hamilton's equations :math:`(\\partial_p K, -\\partial_q K)` as sympy expressions in
        :attr:`symbols`, :math:`K` from :meth:`canonical_hamiltonian`."""
        key = ("eqs", substitute_parameters)
        if key not in self._cache:
            K = self.canonical_hamiltonian(substitute_parameters=substitute_parameters)
            n = self.n
            q, P = self.symbols[:n], self.symbols[n:]
            self._cache[key] = tuple(sp.diff(K, s) for s in P) + tuple(-sp.diff(K, s) for s in q)
        return self._cache[key]
