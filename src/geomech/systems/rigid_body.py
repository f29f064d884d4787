"""The free rigid body: :math:`H(m) = \\tfrac12\\, m \\cdot \\mathbb I^{-1} m`."""

from __future__ import annotations

from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError
from ..symbolic.compile import M_SYMBOLS
from .left_invariant import LeftInvariantSystem

__all__ = ["RigidBody"]


def _check_triangle(moments: np.ndarray, shown: Any) -> None:
    # A rigid body's principal moments satisfy I_i <= I_j + I_k (equality for a planar lamina); a small
    # relative slack absorbs the round-off of a diagonalised tensor. Compared relative to the largest
    # moment, so that moments near the top of the float range do not overflow the sum and pass.
    scaled = moments / moments.max()
    total = scaled.sum()
    worst = np.max(2 * scaled - total)
    if worst > 1e-12 * total:
        i = int(np.argmax(2 * scaled - total))
        j, k = [a for a in range(3) if a != i]
        raise InputError(
            f"Expected `inertia` to satisfy the triangle inequality I_i <= I_j + I_k of a rigid body, got "
            f"{np.array2string(np.asarray(shown), separator=', ')}: I{i + 1} = {moments[i]:g} > "
            f"I{j + 1} + I{k + 1} = {moments[j] + moments[k]:g}."
        )


class RigidBody:
    """A free rigid body about its centre of mass (sections 2-3 of the Serret-Andoyer paper).

    Parameters
    ----------
    inertia : array_like, shape (3,) or (3, 3)
        Either the three principal moments :math:`(I_1, I_2, I_3)`, the body frame being the principal
        frame, or the full inertia tensor in the user's body frame (symmetric positive definite), which
        is diagonalised: :attr:`principal_axes` ``Q`` (a rotation, columns the principal axes in the
        user's frame) and :attr:`principal_moments` satisfy ``tensor = Q diag(moments) Q^T``.

    Notes
    -----
    Everything here works in the user's body frame: :attr:`system` is the left-invariant Hamiltonian
    :math:`H(m) = \\tfrac12 m \\cdot \\mathbb I^{-1} m` there. :meth:`to_principal` and
    :meth:`from_principal` convert body vectors (``m_principal = Q^T m``), and an attitude ``R`` of the
    user's frame corresponds to ``R Q`` for the principal frame.
    """

    __slots__ = ("tensor", "principal_moments", "principal_axes", "system", "_diagonal")

    tensor: np.ndarray
    principal_moments: np.ndarray
    principal_axes: np.ndarray
    system: LeftInvariantSystem
    _diagonal: bool

    def __init__(self, inertia: Any):
        arr = V.finite(inertia, "inertia")
        if arr.shape == (3,):
            moments = V.positive(arr, "inertia")
            axes = np.eye(3)
            tensor = np.diag(moments)
            diagonal = True
        elif arr.shape == (3, 3):
            if not np.allclose(arr, arr.T, rtol=1e-12, atol=1e-14 * np.abs(arr).max()):
                raise InputError(
                    "Expected `inertia` to be a symmetric tensor, got one with "
                    f"max |I - I^T| = {np.abs(arr - arr.T).max():.3g}."
                )
            tensor = 0.5 * (arr + arr.T)
            moments, axes = np.linalg.eigh(tensor)
            if np.any(moments <= 0):
                raise InputError(f"Expected `inertia` to be positive definite, got eigenvalues {moments.tolist()}.")
            if np.linalg.det(axes) < 0:
                axes[:, 2] *= -1
            diagonal = bool(np.all(tensor == np.diag(np.diag(tensor))))
            if diagonal:
                moments, axes = np.diag(tensor).copy(), np.eye(3)
        else:
            raise InputError(
                f"Expected `inertia` to have shape (3,) (principal moments) or (3, 3) (a tensor), got {arr.shape}."
            )
        _check_triangle(moments, arr)
        set_ = object.__setattr__
        set_(self, "tensor", tensor)
        set_(self, "principal_moments", np.asarray(moments, dtype=float))
        set_(self, "principal_axes", axes)
        set_(self, "_diagonal", diagonal)
        set_(self, "system", self._build_system())
        for a in ("tensor", "principal_moments", "principal_axes"):
            getattr(self, a).setflags(write=False)

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("RigidBody is immutable; build a new one.")

    @property
    def parameters(self) -> dict[str, float]:
        """The principal moments ``I1, I2, I3`` by name (those of :attr:`system`); none for a body given by a
        full tensor, which has no named parameters."""
        return dict(self.system.parameters)

    def with_parameters(self, **values: float) -> RigidBody:
        """The same body with other principal moments (``I1``, ``I2``, ``I3``), as every system's
        ``with_parameters``; the triangle inequality of a real body is checked again."""
        if not self._diagonal:
            raise InputError(
                "This rigid body was given by a full inertia tensor and has no named parameters; build "
                "RigidBody(new_tensor) instead."
            )
        merged = {
            **self.parameters,
            **V.parameter_update(values, self.parameters, "free rigid body", ("I1", "I2", "I3")),
        }
        return RigidBody([merged["I1"], merged["I2"], merged["I3"]])

    def check_parameters(self, values: Any) -> None:
        """Check a batch of principal moments (``{"I1": array, ...}``, the others this body's; arrays
        broadcast) as :meth:`with_parameters` checks one: positive, and the triangle inequality of a real body.
        Raises :class:`~geomech.errors.InputError` naming the first offending member."""
        given = {k: np.asarray(v, dtype=float) for k, v in dict(values).items()}
        shape = np.broadcast_shapes(*(v.shape for v in given.values())) if given else ()
        moments = np.stack(
            [np.broadcast_to(given.get(k, self.parameters.get(k, np.nan)), shape) for k in ("I1", "I2", "I3")], -1
        ).reshape(-1, 3)
        bad = np.flatnonzero(~np.all(moments > 0, axis=1))
        if bad.size:
            raise InputError(f"Expected positive principal moments, got {moments[bad[0]].tolist()} (member {bad[0]}).")
        for member in moments:
            if np.max(2 * member - member.sum()) > 1e-12 * member.sum():
                _check_triangle(member, member)

    def _build_system(self) -> LeftInvariantSystem:
        m = sp.Matrix(M_SYMBOLS)
        if self._diagonal:
            syms = sp.symbols("I1 I2 I3", positive=True)
            expr = sum(mi**2 / (2 * Ii) for mi, Ii in zip(M_SYMBOLS, syms))
            params = {str(s): float(v) for s, v in zip(syms, self.principal_moments)}
        else:
            inv = np.linalg.inv(self.tensor)
            expr = sp.expand((m.T * sp.Matrix(inv.tolist()) * m)[0, 0] / 2)
            params = {}
        return LeftInvariantSystem.from_expression(expr, params, name="free rigid body")

    # -- frames ----------------------------------------------------------------------------------
    def to_principal(self, m: Any) -> np.ndarray:
        """Body vector in the user's frame -> principal frame: :math:`Q^T m`."""
        m = V.trailing_shape(m, "m", (3,))
        return m @ self.principal_axes

    def from_principal(self, m: Any) -> np.ndarray:
        """Body vector in the principal frame -> the user's frame: :math:`Q m`."""
        m = V.trailing_shape(m, "m", (3,))
        return m @ self.principal_axes.T

    # -- mechanics -------------------------------------------------------------------------------
    def angular_velocity(self, m: Any) -> np.ndarray:
        """Body angular velocity :math:`\\omega = \\mathbb I^{-1} m = \\nabla H(m)`."""
        m = V.trailing_shape(m, "m", (3,))
        return np.linalg.solve(self.tensor, m[..., None])[..., 0]

    def energy(self, m: Any) -> np.ndarray:
        """Kinetic energy :math:`\\tfrac12\\, m\\cdot\\mathbb I^{-1}m`."""
        m = V.trailing_shape(m, "m", (3,))
        return 0.5 * np.einsum("...i,...i->...", m, self.angular_velocity(m))

    def casimir(self, m: Any) -> np.ndarray:
        """:math:`|m|^2`."""
        return LeftInvariantSystem.casimir(m)

    def euler_vector_field(self, m: Any) -> np.ndarray:
        """Euler's equations :math:`\\dot m = m \\times \\mathbb I^{-1} m`."""
        m = V.trailing_shape(m, "m", (3,))
        return np.cross(m, self.angular_velocity(m))

    def exact_solution(self, m0: Any):
        """The exact solution :math:`m(t)` with :math:`m(0) = m_0` (Jacobi elliptic functions).

        Returns an object with ``momentum(t)`` (in the user's body frame), ``period``, ``family``
        (``"major"``, ``"minor"``, ``"separatrix"``, ``"steady"``, ``"axisymmetric"``, ``"spherical"``)
        and the constants of the motion; see :class:`geomech.systems.EulerTopSolution`.
        """
        from ._euler_top import EulerTopSolution

        m0 = V.exact_shape(m0, "m0", (3,))
        sol = EulerTopSolution.from_initial(self.principal_moments, self.to_principal(m0))
        return _FramedSolution(sol, self)

    def __repr__(self) -> str:
        if self._diagonal:
            return f"RigidBody(inertia={self.principal_moments.tolist()})"
        return f"RigidBody(inertia={self.tensor.tolist()})"

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready description: the tensor, the principal moments and the principal axes."""
        return {
            "kind": "RigidBody",
            "tensor": self.tensor.tolist(),
            "principal_moments": self.principal_moments.tolist(),
            "principal_axes": self.principal_axes.tolist(),
        }


class _FramedSolution:
    """An :class:`EulerTopSolution` in the principal frame seen from the user's body frame."""

    def __init__(self, solution: Any, body: RigidBody):
        self._solution = solution
        self._body = body

    def momentum(self, t: Any) -> np.ndarray:
        return self._body.from_principal(self._solution.momentum(t))

    def __getattr__(self, name: str) -> Any:
        return getattr(self._solution, name)

    def __repr__(self) -> str:
        return f"{self._solution!r} (in the frame of {self._body!r})"
