"""Fast exact propagation of periodic one-degree-of-freedom motion: one period, integrated once.

A bounded orbit of a canonical system :math:`H(q, p)` with one degree of freedom that meets no critical point
is periodic, :math:`y(t + T) = y(t) + (wP, 0)` (``w`` the winding of a rotation in the angle ``q`` of
period ``P``, 0 for a libration), so the state at any time needs the motion over one period only:

.. math::

    y(t) = y(t - nT) + (nwP, 0), \\qquad n = \\lfloor t / T \\rfloor .

:class:`PeriodicOrbitPropagator` integrates :math:`\\dot y = J\\nabla H(y)` once over a period with the
8th-order Runge-Kutta method of Dormand and Prince (DOP853's tableau and error estimate, adaptive steps at
a tolerance near machine precision, time and state summed with compensation), in a loop compiled with
numba from the symbolic model as the fixed-step methods are. The period is the first return to the
section through :math:`y_0` normal to the flow, :math:`g(y) = \\dot y_0 \\cdot (y - y_0 - wP e_q) = 0`,
found by Newton's method in the length of the last step. The accepted mesh is kept, and the state at
:math:`r = t \\bmod T` is one Runge-Kutta step from the mesh point before ``r``: the cost is independent
of ``t``. It is the same motion as :class:`~geomech.integrators.QuadraturePropagator`'s (eq. 11 of the
Serret-Andoyer paper), computed a thousand times faster for one orbit, without that propagator's tables
(turning points, integrals along the orbit).

Where the integration does not close the orbit cleanly (y0 at or near a critical point, an orbit that
passes close to a saddle, one that leaves ``L_bounds`` or does not return), the orbit is classified by
:class:`~geomech.integrators.QuadraturePropagator`, which reports equilibria and separatrices (and raises
its errors) as documented there.
"""

from __future__ import annotations

import math
import time
import weakref
from typing import Any

import numpy as np

from .. import _validate as V
from ..errors import InputError, SingularityError
from ..systems.canonical import CanonicalSystem
from . import _codegen
from ._native import loop_of
from ._one_dof import one_dof_arguments
from ._problem import make_problem
from .methods import embedded_pair
from .quadrature import QuadraturePropagator

__all__ = ["PeriodicOrbitPropagator"]

_EPS = float(np.finfo(float).eps)
_AUTO: Any = object()
#: An orbit whose speed |y'| drops below this fraction of its maximum passes close to a critical point:
#: it may be a separatrix to within the resolution of H, which the quadrature propagator decides. (A
#: saddle at energy distance dE is passed at speed ~ sqrt(|D^2H| dE); dE at the resolution of H, 1e-14,
#: gives ~1e-7.)
_NEAR_CRITICAL = 1e-5
_STATUS = {
    1: "did not return within max_steps steps",
    2: "left L_bounds or became non-finite",
    3: "the step size underflowed (y0 at, or the orbit through, a critical point)",
}
_KERNELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _kernels(system: CanonicalSystem) -> tuple[Any, str, np.ndarray]:
    """The compiled module of ``system``, the backend and the model's parameter values (cached with the
    system: a later propagator skips the look-up)."""
    entry = _KERNELS.get(system)
    if entry is None:
        problem = make_problem(system, attitude=False)
        entry = (*problem.module(frozenset(), "auto"), problem.prm)
        _KERNELS[system] = entry
    return entry


def _states_args(fp: int, YM: Any, TM: Any, idx: Any, tau: Any, out: Any, prm: Any) -> tuple[Any, ...]:
    """The arguments of the loop ``orbit_states``: the state one DOP853 step of size ``tau[j]`` from the mesh point
    ``idx[j]``, into ``out[j]``."""
    pair = embedded_pair("DOP853")
    return (fp, YM, TM, idx, tau, pair.A, pair.b, out, prm)


class PeriodicOrbitPropagator:
    """The periodic motion of a one-degree-of-freedom system, from one period integrated to near machine
    precision by a compiled 8th-order Runge-Kutta method; the state at any ``t`` at a cost independent of
    ``t``.

    .. math::

        T:\\ g\\bigl(y(T)\\bigr) = 0 \\text{ (first return)}, \\qquad
        y(t) = \\Phi_{r - t_k}\\bigl(y_k\\bigr) + (n w P, 0), \\quad r = t - nT \\in [t_k, t_{k+1}),

    with :math:`(t_k, y_k)` the accepted mesh over one period and :math:`\\Phi_\\tau` one step of the
    8th-order method (Dormand & Prince, [HNW] II.10).

    Parameters
    ----------
    system : CanonicalSystem with ``n = 1``, ``y = (q, p)`` (e.g. ``GeneralizedSerretAndoyer(H).reduced_system(G)``).
    y0 : (2,) the initial state.
    L_bounds, angle_period, energy_tol : as in :class:`QuadraturePropagator` (used to classify the orbit
        when the integration does not close it).
    tol : float, default 1e-14
        Relative and absolute tolerance of the local error (in ``[1e-15, 1e-6]``). The 8th-order solution is
        well below it: at 1e-14 the period of the benchmark's orbit is right to a few units of 1e-15
        (relative), and the state at t = 1000 (68 periods) to about 1e-13.
    max_steps : int, default 20000
        Steps allowed over one period before the orbit is handed to the quadrature propagator.

    Attributes
    ----------
    kind : ``"libration"``, ``"rotation"``, or (from the quadrature propagator) ``"separatrix"`` or
        ``"equilibrium"``.
    energy, period (``inf`` for a separatrix or an equilibrium), winding, frequency,
    period_error : an estimate of the error of the period: four times the local error estimates summed over
        the period, divided by :math:`|\\dot y_0|` (on the free body's orbits, 1.5 to 4 times the true error),
    n_mesh (accepted steps + 1), nfev (evaluations of the vector field),
    quadrature : the :class:`QuadraturePropagator` when it was needed to classify the orbit, else None,
    stats : ``compile_time`` (getting the kernels at their first use in this process: their machine code
        loaded from the cache, or numba compiling them) and ``run_time`` (the integration of the period), in
        seconds.

    Notes
    -----
    The error of the state at time ``t`` is the error over one period plus :math:`n\\,\\delta T |\\dot y|`
    from the period's error :math:`\\delta T`: it grows linearly in ``t`` as for any method that uses the
    period, with a slope set by the period's few units in the last place. Cost on the benchmark's reduced
    closed loop: about 35 us for the period at ``tol = 1e-14`` (80 steps of 12 evaluations) and 1-2 us a
    state, beside 0.76 ms for heyoka's Taylor integrator to reach t = 1000 (benchmarks/README.md).
    """

    def __init__(
        self,
        system: CanonicalSystem,
        y0: Any,
        *,
        L_bounds: Any = None,
        angle_period: Any = _AUTO,
        tol: float = 1e-14,
        max_steps: int = 20_000,
        energy_tol: float | None = None,
    ):
        self.system, self.y0, tol = one_dof_arguments(system, y0, tol, (1e-15, 1e-6), "periodic propagation")
        y0 = self.y0
        if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
            raise InputError(f"Expected `max_steps` to be a positive integer, got {max_steps!r}.")
        self.tol = tol
        if angle_period is _AUTO:
            angle_period = 2 * np.pi if 0 in system.angle_coordinates else None
        if angle_period is not None:
            angle_period = V.positive_scalar(angle_period, "angle_period")
        self.angle_period = angle_period
        lo, hi = (-math.inf, math.inf) if L_bounds is None else V.as_float_array(L_bounds, "L_bounds").tolist()
        if not (isinstance(lo, float) and isinstance(hi, float) and lo < hi):
            raise InputError(f"Expected `L_bounds` to be an increasing pair (p_min, p_max), got {L_bounds!r}.")
        if not lo < y0[1] < hi:
            raise InputError(f"Expected the initial p = y0[1] = {y0[1]:.17g} inside `L_bounds` ({lo:g}, {hi:g}).")
        self._args = {"L_bounds": L_bounds, "angle_period": angle_period, "energy_tol": energy_tol}

        module, self.backend, prm = _kernels(system)
        self._prm = prm
        pair = embedded_pair("DOP853")
        A, b, e5, e3 = pair.A, pair.b, pair.e, pair.e2
        shift = np.array([angle_period or 0.0, 0.0])
        # the model's C right-hand side, then the loops (their C entries loaded from the cache without numba, else
        # numba's kernels, compiled or loaded from numba's cache, on a one-step problem): timed apart
        start = time.perf_counter()
        first = self.backend == "numba" and not module.ready(_codegen.RHS)
        self._fp = fp = _codegen.rhs_address(module)
        compile_time = time.perf_counter() - start if first else 0.0
        TM, YM, info = np.empty(max_steps + 1), np.empty((max_steps + 1, 2)), np.zeros(9)

        def run_args(n: int, tm: np.ndarray, ym: np.ndarray, out: np.ndarray) -> tuple[Any, ...]:
            return (fp, y0, A, b, e5, e3, tol, shift, lo, hi, n, tm, ym, out, prm)

        orbit_return, seconds = loop_of(
            module, "orbit_return", run_args(int(max_steps), TM, YM, info),
            lambda: module.orbit_return(*run_args(1, np.empty(2), np.empty((2, 2)), np.zeros(9))),
        )  # fmt: skip
        probe = _states_args(
            fp, np.zeros((1, 2)), np.zeros(1), np.zeros(1, np.int64), np.zeros(1), np.empty((1, 2)), prm
        )
        self._states, more = loop_of(module, "orbit_states", probe, lambda: module.orbit_states(*probe))
        compile_time += seconds + more
        start = time.perf_counter()
        with np.errstate(all="ignore"):
            orbit_return(*run_args(int(max_steps), TM, YM, info))
        self.stats = {"compile_time": compile_time, "run_time": time.perf_counter() - start}
        status, n_mesh = int(info[0]), int(info[1])
        self.nfev, self.n_mesh = int(info[5]), n_mesh
        self._TM, self._YM = TM[:n_mesh], YM[:n_mesh]
        self.energy = float(system.hamiltonian(y0))
        self.quadrature: QuadraturePropagator | None = None
        self._use_quadrature = False
        self.failure: str | None = None
        self.equilibrium = None
        self.saddles: tuple = ()
        if status == 0 and info[6] >= _NEAR_CRITICAL * info[7]:
            self.period, self.winding = float(info[2]), int(info[3])
            self.kind = "rotation" if self.winding else "libration"
            # the local error estimates summed over the period, over |y0'|, underestimate the error of the
            # period by up to 2x on the free body's orbits (the propagated part): a factor 4 for safety
            self.period_error = 4.0 * float(info[4])
            return
        # not closed cleanly: the quadrature propagator classifies (and raises where the orbit is not periodic)
        self.quadrature = quad = QuadraturePropagator(system, y0, tol=max(tol, 1e-14), **self._args)
        self.kind, self.saddles = quad.kind, getattr(quad, "saddles", ())
        self.equilibrium = getattr(quad, "equilibrium", None)
        self.period, self.winding = quad.period, int(getattr(quad, "winding", 0) or 0)
        self.period_error = getattr(quad, "period_error", 0.0)
        if status == 0 and quad.kind in ("libration", "rotation"):
            # a periodic orbit that only comes close to a critical point: the integrated period stands
            self.period, self.winding = float(info[2]), int(info[3])
        elif quad.kind in ("libration", "rotation"):
            # the integration did not close the orbit where quadrature did: its tables give the state
            self._use_quadrature = True
            self.failure = _STATUS.get(status, "")

    @property
    def frequency(self) -> float:
        """:math:`2\\pi / T` (0 for an infinite period)."""
        return 2 * np.pi / self.period

    def state(self, t: Any) -> np.ndarray:
        """The state :math:`y(t) = (q, p)` with :math:`y(0) = y_0`, shape ``t.shape + (2,)``.

        ``q`` is the continuous lift (a rotation advances it by ``winding * angle_period`` per period).
        ``t`` may be negative. Raises :class:`~geomech.errors.SingularityError` on a separatrix.
        """
        t = V.finite(t, "t")
        if self.kind == "separatrix":
            at = ", ".join(str(np.round(s.y, 12).tolist()) for s in self.saddles)
            raise SingularityError(
                f"state: the orbit through y0 = {self.y0.tolist()} is a separatrix (it reaches the saddle(s) "
                f"{at} in infinite time); it has no period, use an integrator (geomech.solve)."
            )
        if self.kind == "equilibrium":
            return np.broadcast_to(self.y0, t.shape + (2,)).copy()
        if self._use_quadrature:
            assert self.quadrature is not None  # set whenever it is used
            return self.quadrature.state(t)
        T = self.period
        if t.size and np.max(np.abs(t)) > T / _EPS:
            raise InputError(
                f"Expected |t| below period / eps = {T / _EPS:.3g}, got {np.max(np.abs(t)):.3g}: beyond it not "
                "one digit of the phase t mod T is known in double precision."
            )
        flat = t.ravel()
        n = np.floor(flat / T)
        r = flat - n * T
        idx = np.clip(np.searchsorted(self._TM, r, side="right") - 1, 0, self.n_mesh - 2)
        out = np.empty((flat.size, 2))
        self._states(
            *_states_args(
                self._fp, self._YM, self._TM, idx.astype(np.int64, copy=False), r - self._TM[idx], out, self._prm
            )
        )
        if self.winding:
            out[:, 0] += n * (self.winding * self.angle_period)
        return out.reshape(t.shape + (2,))

    def __repr__(self) -> str:
        return (
            f"PeriodicOrbitPropagator(kind={self.kind!r}, energy={self.energy:.17g}, period={self.period:.17g}, "
            f"winding={self.winding})"
        )
