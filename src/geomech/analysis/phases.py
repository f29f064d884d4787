r"""Geometric and dynamic phases, and reconstruction on the group (section 2 of the nonholonomic paper).

For a holonomic system with symmetry (:class:`~geomech.systems.holonomic.HolonomicSystem`) the group
variable obeys the reconstruction equation (eq. 2.2)

.. math::

    g^{-1}\dot g = -A_{loc}(r)\dot r + \mathbb I_{loc}^{-1}(r)\,p, \qquad p = \mathrm{Ad}_g^*\mu,

with :math:`\mu` the conserved spatial momentum. :func:`reconstruct` integrates it on the group with a
Lie-group method (:func:`integrate_on_group`: Runge-Kutta-Munthe-Kaas, in exponential coordinates about
a moving centre), for any of the groups. Where the group is abelian (or the rotation of SE(2) when it
decouples, and the free rigid body, :math:`G_\mu = S^1`) the change of the group variable over a closed
shape loop of period :math:`T` splits as in Theorem 2.2 (eq. 2.3):

.. math::

    \Delta\theta = \underbrace{-\oint A_{loc}(r)\,dr}_{\text{geometric}}
                 + \underbrace{\mu\int_0^T \mathbb I_{loc}^{-1}(r(t))\,dt}_{\text{dynamic}},

(:func:`phases`), and on a 2-D shape space the geometric phase is also minus the integral of the
curvature over the enclosed area (Stokes; :func:`curvature_integral`, which weights the area by the
winding number of the loop). For the free rigid body :func:`rigid_body_phase` gives Montgomery's formula.

Every phase here is unwrapped (a real number, not reduced modulo :math:`2\pi`) unless its name says
``wrapped``; a rotation read off an attitude matrix is defined only modulo :math:`2\pi` and is wrapped
to :math:`(-\pi, \pi]`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from .. import _validate as V
from ..errors import ConvergenceError, InputError, NumericalError, ShapeError
from ..lie._common import wrap_angle
from ..symbolic.charts import group_chart
from ..symbolic.compile import compile_vector
from ..symbolic.formula import to_expression

__all__ = [
    "ShapeLoop",
    "bind_loop",
    "PhaseSplit",
    "GroupPath",
    "Reconstruction",
    "phases",
    "geometric_phase",
    "curvature_integral",
    "integrate_on_group",
    "reconstruct",
    "decompose_displacement",
]

T_SYMBOL = sp.Symbol("t", real=True)


# ---------------------------------------------------------------------------------------------------
# Shape loops
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ShapeLoop:
    """A closed path :math:`r(t)`, :math:`0 \\le t \\le T`, in shape space, with its first two derivatives.

    Build it with :meth:`from_expressions` (formulas in ``t``, derivatives exact), :meth:`from_fourier`
    or :meth:`ellipse`. ``r(t)``, ``rdot(t)``, ``rddot(t)`` take a scalar (returning ``(n,)``) or an
    array of times (returning ``(m, n)``). Angles may wind: ``r(T) - r(0)`` is then a multiple of
    :math:`2\\pi` in those coordinates, which :func:`bind_loop` checks against the system.
    """

    period: float
    dim: int
    _funcs: tuple[Callable, Callable, Callable] = field(repr=False)
    names: tuple[str, ...] | None = None
    expressions: tuple[sp.Expr, ...] | None = None

    def _eval(self, i: int, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = self._funcs[i](np.atleast_1d(t))
        return out[0] if t.ndim == 0 else out

    def r(self, t: Any) -> np.ndarray:
        return self._eval(0, t)

    def rdot(self, t: Any) -> np.ndarray:
        return self._eval(1, t)

    def rddot(self, t: Any) -> np.ndarray:
        return self._eval(2, t)

    @classmethod
    def from_expressions(
        cls,
        expressions: Any,
        period: float,
        *,
        names: Sequence[str] | None = None,
        parameters: Mapping[str, float] | None = None,
    ) -> ShapeLoop:
        """Each shape coordinate as a formula in ``t`` (strings or sympy), e.g.
        ``["0.5*sin(2*pi*t)", "0.5*cos(2*pi*t)"]`` or ``{"alpha1": "...", "alpha2": "..."}``."""
        T = V.positive_scalar(period, "period")
        if isinstance(expressions, Mapping):
            names = tuple(str(k) for k in expressions)
            expressions = list(expressions.values())
        exprs = []
        for i, e in enumerate(expressions):
            label = f"expressions[{names[i]!r}]" if names is not None and i < len(names) else f"expressions[{i}]"
            ex = to_expression(e, label, {"t": T_SYMBOL})
            sub = {s: float(parameters[s.name]) for s in ex.free_symbols if parameters and s.name in parameters}
            ex = ex.subs(sub)
            extra = sorted(str(s) for s in ex.free_symbols if s != T_SYMBOL)
            if extra:
                raise InputError(
                    f"Shape-loop expression {e!r} has symbols {extra} other than t; give their "
                    "values in `parameters` or write numbers."
                )
            exprs.append(ex)
        if not exprs:
            raise ShapeError("Expected at least one shape-loop expression.")
        derivs = [[sp.diff(ex, T_SYMBOL, k) for ex in exprs] for k in range(3)]
        funcs = tuple(_time_function(d) for d in derivs)
        return cls(T, len(exprs), funcs, tuple(names) if names is not None else None, tuple(exprs))

    @classmethod
    def from_callable(
        cls,
        r: Callable,
        rdot: Callable,
        period: float,
        *,
        rddot: Callable | None = None,
        names: Sequence[str] | None = None,
    ) -> ShapeLoop:
        """A loop from functions of time (e.g. a closed form, or a periodic orbit's shape from a
        simulation). Each takes a scalar ``t`` and returns ``(n,)``; ``rddot`` is needed only to drive a
        full simulation (:meth:`HolonomicSystem.simulate`)."""
        T = V.positive_scalar(period, "period")
        n = np.atleast_1d(np.asarray(r(0.0), dtype=float)).size

        def vec(f: Callable | None, what: str) -> Callable:
            def g(t: np.ndarray) -> np.ndarray:
                if f is None:
                    raise InputError(f"This ShapeLoop was built without `{what}`; pass it to from_callable.")
                return np.stack([np.atleast_1d(np.asarray(f(float(x)), dtype=float)) for x in t]).reshape(t.size, n)

            return g

        return cls(
            T, n, (vec(r, "r"), vec(rdot, "rdot"), vec(rddot, "rddot")), tuple(names) if names is not None else None
        )

    @classmethod
    def from_fourier(
        cls, mean: Any, cos_coefficients: Any, sin_coefficients: Any, period: float, *, winding: Any = None
    ) -> ShapeLoop:
        """:math:`r(t) = \\bar r + 2\\pi w t/T + \\sum_{j\\ge1} a_j\\cos(2\\pi jt/T) + b_j\\sin(2\\pi jt/T)`,
        coefficients of shape ``(harmonics, n)``, ``winding`` the integers :math:`w` (angles only)."""
        T = V.positive_scalar(period, "period")
        mean = V.finite(mean, "mean").reshape(-1)
        a = np.atleast_2d(V.finite(cos_coefficients, "cos_coefficients"))
        b = np.atleast_2d(V.finite(sin_coefficients, "sin_coefficients"))
        n = mean.size
        if a.shape != b.shape or a.shape[1] != n:
            raise ShapeError(f"Expected cos and sin coefficients of shape (harmonics, {n}), got {a.shape}, {b.shape}.")
        w = np.zeros(n) if winding is None else np.asarray(winding, dtype=float).reshape(n)
        omega = 2 * np.pi / T * np.arange(1, a.shape[0] + 1)

        def make(order: int) -> Callable:
            def f(t: np.ndarray) -> np.ndarray:
                ph = np.outer(t, omega)
                c, s = np.cos(ph), np.sin(ph)
                # d^k/dt^k of cos and sin cycle through (c, -s, -c, s) and (s, c, -s, -c) times omega^k
                cc, ss = [(c, s), (-s, c), (-c, -s)][order]
                out = (cc * omega**order) @ a + (ss * omega**order) @ b
                if order == 0:
                    out = out + mean + np.outer(t, 2 * np.pi * w / T)
                elif order == 1:
                    out = out + 2 * np.pi * w / T
                return out

            return f

        return cls(T, n, (make(0), make(1), make(2)))

    @classmethod
    def ellipse(
        cls, center: Any, radii: Any, period: float, *, tilt: float = 0.0, phase: float = 0.0, clockwise: bool = False
    ) -> ShapeLoop:
        """An ellipse in a 2-D shape space, counterclockwise unless ``clockwise``."""
        c = V.exact_shape(center, "center", (2,))
        ra = V.exact_shape(radii, "radii", (2,))
        s = -1.0 if clockwise else 1.0
        R = np.array([[np.cos(tilt), -np.sin(tilt)], [np.sin(tilt), np.cos(tilt)]])
        # r = c + R (ra0 cos(wt + phase), s ra1 sin(wt + phase)), expanded in cos(wt) and sin(wt)
        a = np.array([R @ np.array([ra[0] * np.cos(phase), s * ra[1] * np.sin(phase)])])
        b = np.array([R @ np.array([-ra[0] * np.sin(phase), s * ra[1] * np.cos(phase)])])
        return cls.from_fourier(c, a, b, period)


def _time_function(exprs: list) -> Callable:
    f = compile_vector(exprs, [T_SYMBOL])

    def g(t: np.ndarray) -> np.ndarray:
        return f(np.asarray(t, dtype=float)[..., None])

    return g


def bind_loop(system: Any, loop: Any, *, atol: float = 1e-9) -> np.ndarray:
    """Check that ``loop`` lives in ``system``'s shape space and is closed; return the winding integers.

    Raises :class:`ShapeError` for a wrong dimension, :class:`InputError` for an open loop (angle
    coordinates may wind by whole turns) and :class:`SingularityError` where the locked inertia is singular.
    """
    if not isinstance(loop, ShapeLoop):
        raise InputError(f"Expected `loop` to be a ShapeLoop, got {type(loop).__name__}.")
    names = [str(s) for s in system.shape_coordinates]
    if loop.dim != system.shape_dim:
        raise ShapeError(
            f"Expected a shape loop in the {system.shape_dim}-D shape space ({', '.join(names)}) of "
            f"{system.name}, got one with {loop.dim} coordinate(s)."
        )
    if loop.names is not None and list(loop.names) != names:
        raise ShapeError(
            f"Expected the shape loop's coordinates to be ({', '.join(names)}), got ({', '.join(loop.names)})."
        )
    d = loop.r(loop.period) - loop.r(0.0)
    t_check = np.linspace(0.0, loop.period, 257)
    with np.errstate(all="ignore"):
        samples = np.asarray(loop.r(t_check), dtype=float)
        rates = np.asarray(loop.rdot(t_check), dtype=float)
    bad = ~(
        np.all(np.isfinite(samples.reshape(t_check.size, -1)), axis=1)
        & np.all(np.isfinite(rates.reshape(t_check.size, -1)), axis=1)
    )
    if np.any(bad) or not np.all(np.isfinite(d)):
        t_bad = float(t_check[np.argmax(bad)]) if np.any(bad) else loop.period
        raise InputError(
            f"Expected a shape loop with finite values and rates, got a non-finite one at t = {t_bad:.6g} "
            f"(of T = {loop.period:g}); a loop must be a smooth closed curve."
        )
    scale = max(1.0, float(np.abs(samples).max()))
    turns = np.zeros(loop.dim)
    for i in range(loop.dim):
        if i in system.angle_shapes:
            turns[i] = np.round(d[i] / (2 * np.pi))
    gap = d - 2 * np.pi * turns
    if np.any(np.abs(gap) > atol * scale):
        raise InputError(
            f"Expected a closed shape loop: r(T) - r(0) = {np.round(d, 9).tolist()} for ({', '.join(names)}) "
            f"with T = {loop.period:g}; make the loop return to its start"
            + (" (angle coordinates may wind by whole turns)." if system.angle_shapes else ".")
        )
    system.check_locked_inertia(loop.r(np.linspace(0.0, loop.period, 65)))
    return turns.astype(int)


# ---------------------------------------------------------------------------------------------------
# Quadrature of periodic integrands
# ---------------------------------------------------------------------------------------------------
def _periodic_integral(
    f: Callable[[np.ndarray], np.ndarray],
    T: float,
    *,
    rtol: float = 1e-13,
    n0: int = 64,
    nmax: int = 2**17,
    what: str = "integral",
) -> np.ndarray:
    """:math:`\\int_0^T f`, ``f`` smooth and T-periodic, by the trapezoidal rule with doubling (spectrally
    accurate for smooth periodic integrands); falls back to adaptive Gauss-Kronrod for a kinked loop."""
    n = n0
    t = np.arange(n) * (T / n)
    prev = f(t).sum(0) * (T / n)
    while n < nmax:
        mid = (np.arange(n) + 0.5) * (T / n)
        cur = 0.5 * prev + f(mid).sum(0) * (T / (2 * n))
        n *= 2
        scale = max(np.abs(cur).max(), np.abs(f(t[:1])).max() * T, 1e-300)
        if np.abs(cur - prev).max() <= rtol * scale and n >= 2 * n0:
            return cur
        prev = cur
        t = np.arange(n) * (T / n)
        if n >= 4096:
            break
    from scipy.integrate import quad_vec

    val, err = quad_vec(lambda s: f(np.array([s]))[0], 0.0, T, epsabs=0.0, epsrel=max(rtol, 1e-13), limit=4000)
    scale = max(np.abs(val).max(), 1e-300)
    if np.max(err) > 1e-8 * scale:
        raise ConvergenceError(
            f"The quadrature of the {what} over the loop did not converge (error estimate "
            f"{np.max(err):.3g}); the loop is probably not smooth enough."
        )
    return val


# ---------------------------------------------------------------------------------------------------
# Phases (Theorem 2.2)
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseSplit:
    """Geometric, dynamic and total phase over one period of a closed shape loop (eq. 2.3), unwrapped.

    ``component`` names the group coordinate the phase is for (``"theta"``: the S^1 angle, or the
    rotation of SE(2)); ``momentum`` is the conserved momentum conjugate to it that enters the dynamic
    phase; ``winding`` the whole turns of the loop in its angle coordinates.
    """

    geometric: float
    dynamic: float
    total: float
    component: str
    momentum: float
    period: float
    winding: tuple[int, ...]
    group: str

    @property
    def total_wrapped(self) -> float:
        return float(wrap_angle(np.asarray(self.total)))

    def to_json(self) -> dict[str, Any]:
        return {
            "geometric": self.geometric,
            "dynamic": self.dynamic,
            "total": self.total,
            "total_wrapped": self.total_wrapped,
            "component": self.component,
            "momentum": self.momentum,
            "period": self.period,
            "winding": list(self.winding),
            "group": self.group,
            "wrapped": False,
        }


def _momentum(mu: Any, G: Any) -> np.ndarray:
    mu = V.finite(np.atleast_1d(mu), "mu").reshape(-1)
    if mu.size == 1 and G.dim > 1 and mu[0] == 0:
        return np.zeros(G.dim)
    if mu.size != G.dim:
        raise ShapeError(
            f"Expected `mu` with {G.dim} component(s) ({', '.join(G.algebra_names)} momenta) for "
            f"{G.name}, got {mu.size}."
        )
    return mu


def _connection(system: Any):
    from ..reduction.connections import MechanicalConnection

    return MechanicalConnection(system)


def geometric_phase(system: Any, loop: ShapeLoop, *, rtol: float = 1e-13) -> np.ndarray:
    """:math:`-\\oint A_{loc}(r)\\,dr` over the loop, shape ``(k,)`` (every algebra component).

    Only the abelian components are a holonomy (a phase): all of them for S^1, the rotation for SE(2).
    """
    bind_loop(system, loop)
    conn = _connection(system)

    def integrand(t: np.ndarray) -> np.ndarray:
        return -np.einsum("...aj,...j->...a", conn.connection(loop.r(t)), loop.rdot(t))

    return _periodic_integral(integrand, loop.period, rtol=rtol, what="connection")


def phases(system: Any, loop: ShapeLoop, mu: Any = 0.0, *, g0: Any = None, rtol: float = 1e-13) -> PhaseSplit:
    """Theorem 2.2 (eq. 2.3): the total phase over a closed shape loop as geometric + dynamic.

    Parameters
    ----------
    system : HolonomicSystem with G = S^1, or G = SE(2) (the rotation angle).
    loop : a closed :class:`ShapeLoop` of period T.
    mu : the conserved spatial momentum (a scalar for S^1, ``(p_x, p_y, L)`` for SE(2)).
    g0 : group coordinates at t = 0 (SE(2) with nonzero linear momentum only; default the identity).

    Notes
    -----
    For SE(2), :math:`\\dot\\theta = \\omega` and the rotation component of the bracket vanishes, so the
    rotation obeys (2.3) with :math:`(\\mathbb I^{-1})_{\\theta\\theta}` whenever the body angular momentum
    :math:`p_\\theta = (\\mathrm{Ad}_g^T\\mu)_\\theta` is constant: always when the linear momentum is zero
    (then :math:`p_\\theta = L`), and in a centre-of-mass frame (no translational connection, translational
    locked inertia :math:`M\\,\\mathrm{Id}`) for any momentum (:math:`p_\\theta` is then the angular momentum
    about the centre of mass). Otherwise, and for SO(3) with shape, no such formula holds: use
    :func:`reconstruct`.
    """
    G = system.group
    turns = bind_loop(system, loop)
    conn = _connection(system)
    T = loop.period
    mu = _momentum(mu, G)
    if len(G.angle_components) != 1:
        raise InputError(
            f"Theorem 2.2 (eq. 2.3) gives the phase of one angle, the component of the algebra on which the group "
            f"is a homomorphism to the circle (S^1, the rotation of SE(2)); {system.name} has G = {G.name} with "
            f"{len(G.angle_components) or 'no'} such components: integrate the reconstruction equation with "
            "geomech.analysis.reconstruct instead."
        )
    (c,) = G.angle_components
    others = [a for a in range(G.dim) if a != c]
    # The angle component is a homomorphism: row c of Ad_g is e_c, so (Ad_g^T mu)_c = mu_c when the other
    # components of mu vanish (and always on an abelian group, Ad = Id).
    if G.abelian or float(np.abs(mu[others]).max(initial=0.0)) <= 1e-14 * max(1.0, abs(mu[c])):
        p_rot = float(mu[c])
    else:
        _require_centre_of_mass_frame(system, conn, loop, c)
        g = G.from_coordinates(np.zeros(G.dim) if g0 is None else V.exact_shape(g0, "g0", (G.dim,)))
        p_rot = float((G.numeric.Ad(g).T @ mu)[c])

    def integrand(t: np.ndarray) -> np.ndarray:
        r = loop.r(t)
        A = conn.connection(r)[..., c, :]
        Iinv = np.linalg.inv(conn.locked_inertia(r))[..., c, c]
        return np.stack([-np.einsum("...j,...j->...", A, loop.rdot(t)), Iinv], -1)

    geo, inv_int = _periodic_integral(integrand, T, rtol=rtol, what="phase")
    dyn = p_rot * inv_int
    return PhaseSplit(
        float(geo), float(dyn), float(geo + dyn), G.coordinates[c].name, p_rot, T, tuple(int(x) for x in turns), G.name
    )


def _require_centre_of_mass_frame(system: Any, conn: Any, loop: ShapeLoop, c: int, tol: float = 1e-10) -> None:
    """The body frame is a centre-of-mass frame: no connection in the components other than the angle ``c``,
    and a locked inertia ``M Id`` in them with no coupling to ``c``."""
    r = loop.r(np.linspace(0.0, loop.period, 33))
    I = conn.locked_inertia(r)
    A = conn.connection(r)
    o = [a for a in range(I.shape[-1]) if a != c]
    Io = I[..., o, :][..., :, o]
    M = Io[..., 0, 0]
    scale = max(1.0, float(np.abs(I).max()))
    off = max(
        float(np.abs(A[..., o, :]).max()),
        float(np.abs(I[..., o, c]).max()) / scale,
        float(np.abs(Io - M[..., None, None] * np.eye(len(o))).max()) / scale,
        float(np.ptp(M)) / scale,
    )
    if off > tol:
        raise InputError(
            f"The rotational phase formula (eq. 2.3) for {system.name} needs zero linear momentum or a "
            "centre-of-mass body frame (no translational connection, translational locked inertia M Id); "
            "this frame is not one. Give mu with zero linear part, or use geomech.analysis.reconstruct."
        )


def curvature_integral(
    system: Any, loop: ShapeLoop, *, base_point: Any = None, rtol: float = 1e-12, n_radial: int = 24
) -> np.ndarray:
    """:math:`\\iint_D B_{12}\\, dr_1 dr_2` over the region the loop encloses, weighted by its winding
    number (Stokes: equals :math:`\\oint A\\,dr` for the abelian components), shape ``(k,)``.

    Computed as the integral of the pull-back of :math:`B` by the cone
    :math:`(s, t) \\mapsto c + s\\,(r(t) - c)`, whose boundary is the loop: Gauss-Legendre in ``s``,
    trapezoidal in ``t`` (spectral for smooth loops). The connection must be smooth on that cone
    (``base_point`` ``c``, default the loop's mean); the loop must not wind around an angle coordinate.
    """
    conn = _connection(system)
    if system.shape_dim != 2:
        raise ShapeError(
            f"Expected a 2-D shape space for the curvature integral, {system.name} has "
            f"{system.shape_dim} shape coordinates."
        )
    return stokes_integral(
        conn.curvature_2d, loop, bind_loop(system, loop), base_point=base_point, rtol=rtol, n_radial=n_radial
    )


def stokes_integral(
    curvature_2d: Callable[[np.ndarray], np.ndarray],
    loop: ShapeLoop,
    turns: np.ndarray,
    *,
    base_point: Any = None,
    rtol: float = 1e-12,
    n_radial: int = 24,
) -> np.ndarray:
    r""":math:`\iint_D B_{12}\,dr_1 dr_2` over the region a loop in a 2-D shape space encloses, weighted by its
    winding number, for a curvature given as ``curvature_2d(points (..., 2)) -> (..., k)``.

    The integral of the pull-back of :math:`B` by the cone :math:`(s, t) \mapsto c + s\,(r(t) - c)`, whose
    boundary is the loop: Gauss-Legendre in ``s`` (doubled until two rules agree), trapezoidal in ``t``.
    ``turns`` are the loop's windings around angle coordinates (from :func:`bind_loop`): a loop that winds
    bounds no region.
    """
    if np.any(turns != 0):
        raise InputError(
            f"The loop winds {np.asarray(turns).tolist()} times around the angle coordinates: it "
            "bounds no region of shape space, so Stokes' theorem does not apply."
        )
    T = loop.period
    c = (
        loop.r(np.linspace(0, T, 257)[:-1]).mean(0)
        if base_point is None
        else V.exact_shape(base_point, "base_point", (2,))
    )
    result = None
    for nr in (n_radial, 2 * n_radial):
        s, w = np.polynomial.legendre.leggauss(nr)
        s, w = 0.5 * (s + 1.0), 0.5 * w

        def integrand(t: np.ndarray, s=s, w=w) -> np.ndarray:
            d = loop.r(t) - c
            rd = loop.rdot(t)
            jac = d[:, 0] * rd[:, 1] - d[:, 1] * rd[:, 0]
            B = curvature_2d(c + s[None, :, None] * d[:, None, :])  # (m, nr, k)
            return np.einsum("mrk,r,m->mk", B, w * s, jac)

        val = _periodic_integral(integrand, T, rtol=rtol, what="curvature")
        if result is not None and np.abs(val - result).max() <= 1e-11 * max(1.0, np.abs(val).max()):
            return val
        result = val
    raise ConvergenceError(
        "The radial Gauss-Legendre rule for the curvature integral did not converge; "
        "the curvature may be singular inside the loop."
    )


# ---------------------------------------------------------------------------------------------------
# Reconstruction on the group (eq. 2.2): Runge-Kutta-Munthe-Kaas
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GroupPath:
    """A path :math:`g(t)` in the group, from :func:`integrate_on_group`.

    Attributes
    ----------
    group : the group's symbolic twin (:class:`~geomech.symbolic.GroupChart`; ``group.numeric`` the group).
    t : (n,) times. g : (n, N, N) elements (matrices).
    angles : (n, m) the unwrapped angles of the group's ``angle_components`` (the heading of SE(2), the angle
        of S^1, on the universal cover: turns are not wrapped), None if it has none.
    coordinates : (n, k) chart coordinates, with those angles unwrapped (SO(3): 3-1-3 Euler angles, wrapped).
    method, steps, nfev : the integrator, its steps and evaluations of the velocity.
    """

    group: Any
    t: np.ndarray
    g: np.ndarray
    angles: np.ndarray | None
    coordinates: np.ndarray
    method: str
    steps: int
    nfev: int

    @property
    def angle(self) -> np.ndarray | None:
        """(n,): the unwrapped angle when the group has exactly one (S^1, SE(2)), else None."""
        return self.angles[:, 0] if self.angles is not None and self.angles.shape[1] == 1 else None

    def displacement(self) -> np.ndarray:
        """:math:`g(t_0)^{-1} g(t_{end})` (the net motion in the body frame at the start)."""
        G = self.group.numeric
        return G.compose(G.inverse(self.g[0]), self.g[-1])

    def net_motion(self) -> dict[str, float]:
        """The net motion by name: the change of each chart coordinate (angles unwrapped), or where the chart
        is singular at the identity (SO(3) in 3-1-3 Euler angles, whose differences are no motion) the
        exponential coordinates of :meth:`displacement` (``log_<algebra name>``: the rotation vector)."""
        chart = self.group
        if chart.regular_at_identity:
            names = [c.name for c in chart.coordinates]
            values = self.coordinates[-1] - self.coordinates[0]
        else:
            names = [f"log_{n}" for n in chart.algebra_names]
            values = chart.numeric.log(self.displacement())
        return {n: float(v) for n, v in zip(names, values)}


def integrate_on_group(
    group: Any,
    xi: Callable[[float, np.ndarray], np.ndarray],
    g0: Any,
    t_eval: Any,
    *,
    method: str = "rkmk-dop853",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    step: float | None = None,
    chart_radius: float = 1.0,
) -> GroupPath:
    """Integrate :math:`g^{-1}\\dot g = \\xi(t, g)` on the group, staying on it exactly.

    Both methods write :math:`g = g_c\\exp(u)` about a centre :math:`g_c` and integrate
    :math:`\\dot u = \\mathrm{dexp}^{-1}_{-u}\\xi = J_r(u)^{-1}\\xi(t, g_c\\exp u)` (Munthe-Kaas 1999):

    - ``"rkmk4"``: the classical RKMK method of order 4, a new centre every step of size ``step``;
    - ``"rkmk-dop853"`` (default): scipy's adaptive DOP853 (order 8) on :math:`u`, a new centre when
      :math:`|u|` reaches ``chart_radius`` (well inside the injectivity radius of exp).

    The angles of the group's ``angle_components`` are integrated alongside, unwrapped.

    Parameters
    ----------
    group : a group of :mod:`geomech.lie`, its :class:`~geomech.symbolic.GroupChart`, or a group's name.
    xi : ``xi(t, g)`` -> ``(k,)`` body velocity.
    g0 : initial element, an ``(N, N)`` matrix.
    t_eval : increasing output times, the first being the initial time.
    """
    chart = group_chart(group)
    G = chart.numeric
    t_eval = V.finite(t_eval, "t_eval")
    if t_eval.ndim != 1 or t_eval.size < 2 or np.any(np.diff(t_eval) <= 0):
        raise InputError(f"Expected `t_eval` strictly increasing with at least 2 times, got shape {t_eval.shape}.")
    g0 = G.check(g0, "g0")
    if g0.ndim != 2:
        raise ShapeError(f"Expected one element `g0` of shape {(G.matrix_size,) * 2}, got {g0.shape}.")
    k, ac = G.dim, list(G.angle_components)
    angle0 = G.log(g0)[ac]
    out_g = np.empty((t_eval.size,) + g0.shape)
    out_a = np.empty((t_eval.size, len(ac)))
    out_g[0], out_a[0] = g0, angle0
    nfev = 0
    steps = 0

    def chart_rhs(t: float, u: np.ndarray, gc: np.ndarray) -> np.ndarray:
        nonlocal nfev
        nfev += 1
        v = np.asarray(xi(t, G.compose(gc, G.exp(u))), dtype=float).reshape(k)
        if not np.all(np.isfinite(v)):
            raise NumericalError(f"The body velocity is not finite at t = {t:.6g}: {v.tolist()}.")
        return G.right_jacobian_inverse(u) @ v

    gc, ac_angle, tc = g0.copy(), angle0.copy(), float(t_eval[0])
    # exp is a global chart of an abelian group's cover: never recentre there.
    radius = np.inf if G.abelian else float(chart_radius)
    if method == "rkmk4":
        if step is None or not (step > 0):
            raise InputError(f"Expected a positive `step` for method 'rkmk4', got {step!r}.")
        for i in range(1, t_eval.size):
            m = int(np.ceil((t_eval[i] - t_eval[i - 1]) / step - 1e-12))
            h = (t_eval[i] - t_eval[i - 1]) / m
            for j in range(m):
                t = t_eval[i - 1] + j * h
                z = np.zeros(k)
                k1 = chart_rhs(t, z, gc)
                k2 = chart_rhs(t + h / 2, h * k1 / 2, gc)
                k3 = chart_rhs(t + h / 2, h * k2 / 2, gc)
                k4 = chart_rhs(t + h, h * k3, gc)
                theta = h * (k1 + 2 * k2 + 2 * k3 + k4) / 6
                gc = G.compose(gc, G.exp(theta))
                ac_angle = ac_angle + theta[ac]
                steps += 1
            out_g[i], out_a[i] = gc, ac_angle
    elif method == "rkmk-dop853":
        i = 1
        t_end = float(t_eval[-1])
        while i < t_eval.size:

            def leave(_t, u, *_):
                return float(np.linalg.norm(u)) - radius

            leave.terminal = True
            leave.direction = 1
            sol = solve_ivp(
                chart_rhs,
                (tc, t_end),
                np.zeros(k),
                method="DOP853",
                rtol=rtol,
                atol=atol,
                dense_output=True,
                events=leave,
                args=(gc,),
            )
            steps += int(sol.t.size - 1)
            if sol.status < 0:
                raise NumericalError(f"Reconstruction on {G.name} failed at t = {sol.t[-1]:.6g}: {sol.message}")
            t_stop = float(sol.t[-1])
            last = sol.status == 0
            while i < t_eval.size and (t_eval[i] < t_stop or (last and t_eval[i] <= t_stop)):
                u = sol.sol(t_eval[i])
                out_g[i] = G.compose(gc, G.exp(u))
                out_a[i] = ac_angle + u[ac]
                i += 1
            u = sol.y[:, -1]
            gc = G.compose(gc, G.exp(u))
            ac_angle = ac_angle + u[ac]
            tc = t_stop
    else:
        raise InputError(f"Expected `method` to be 'rkmk-dop853' or 'rkmk4', got {method!r}.")
    coords = chart.to_coordinates(out_g)
    # the chart coordinate of an angle component's index is that angle (SO(2), SE(2), their products)
    coords[:, ac] = out_a
    return GroupPath(chart, t_eval, out_g, out_a if ac else None, coords, method, steps, nfev)


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """The group path of a holonomic system along a shape path, with the parts of its body velocity.

    ``path`` is the :class:`GroupPath`; ``r`` the shapes; ``p`` the body momenta
    :math:`\\mathrm{Ad}_g^T\\mu`; ``xi_connection`` :math:`= -A_{loc}\\dot r`, ``xi_momentum``
    :math:`= \\mathbb I^{-1}p` and ``xi`` their sum, all at the output times; ``alone`` maps ``"connection"``
    and ``"momentum"`` to the path each term would give by itself (when asked for).
    """

    t: np.ndarray
    path: GroupPath
    r: np.ndarray
    p: np.ndarray
    xi: np.ndarray
    xi_connection: np.ndarray
    xi_momentum: np.ndarray
    mu: np.ndarray
    alone: dict[str, GroupPath] | None = None


def decompose_displacement(
    group: Any, terms: Mapping[str, Callable[[float, np.ndarray], np.ndarray]], g0: Any, t_eval: Any, **options: Any
) -> dict[str, GroupPath]:
    """Integrate the sum of the body-velocity ``terms`` and each term alone, from the same ``g0``.

    Returns ``{"total": ..., name: ...}``. This is the split of a net displacement by contribution (e.g.
    the connection term :math:`-A\\dot r` and the momentum term :math:`\\mathbb I^{-1}p` of eq. 1.1 or
    2.2); on a non-abelian group, or when ``p`` depends on ``g``, the parts do not add up to the total.
    """
    names = list(terms)

    def total(t: float, g: np.ndarray) -> np.ndarray:
        return sum(np.asarray(terms[n](t, g), dtype=float) for n in names)

    out = {"total": integrate_on_group(group, total, g0, t_eval, **options)}
    for n in names:
        out[n] = integrate_on_group(group, terms[n], g0, t_eval, **options)
    return out


def reconstruct(
    system: Any,
    shape: Any,
    mu: Any = 0.0,
    *,
    g0: Any = None,
    t_eval: Any = None,
    method: str = "rkmk-dop853",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    step: float | None = None,
    decompose: bool = False,
) -> Reconstruction:
    """Reconstruct :math:`g(t)` along a shape path by eq. (2.2), for any of the groups.

    Parameters
    ----------
    system : HolonomicSystem.
    shape : a :class:`ShapeLoop` (checked to be closed), or any object with ``r(t)`` and ``rdot(t)``
        (e.g. a shape trajectory from a simulation; then give ``t_eval``).
    mu : conserved spatial momentum, ``(k,)`` (a scalar for S^1).
    g0 : group coordinates at the first time (default the identity).
    t_eval : output times (default 201 times over one period of the loop).
    decompose : also integrate the connection term and the momentum term alone.
    """
    G = system.group
    conn = _connection(system)
    if isinstance(shape, ShapeLoop):
        bind_loop(system, shape)
        if t_eval is None:
            t_eval = np.linspace(0.0, shape.period, 201)
    elif t_eval is None:
        raise InputError("Give `t_eval` when `shape` is not a ShapeLoop.")
    mu = _momentum(mu, G)
    alpha0 = np.zeros(G.dim) if g0 is None else V.exact_shape(np.atleast_1d(g0), "g0", (G.dim,))
    g_init = G.from_coordinates(alpha0)

    def xi_conn(t: float, g: np.ndarray) -> np.ndarray:
        r = shape.r(t)
        return -conn.connection(r) @ shape.rdot(t)

    def xi_mom(t: float, g: np.ndarray) -> np.ndarray:
        I = conn.locked_inertia(shape.r(t))
        return np.linalg.solve(I, G.numeric.Ad(g).T @ mu)

    opts = dict(method=method, rtol=rtol, atol=atol, step=step)
    t_eval = V.finite(t_eval, "t_eval")
    if decompose:
        parts = decompose_displacement(G, {"connection": xi_conn, "momentum": xi_mom}, g_init, t_eval, **opts)
        path, alone = parts.pop("total"), parts
    else:
        path = integrate_on_group(G, lambda t, g: xi_conn(t, g) + xi_mom(t, g), g_init, t_eval, **opts)
        alone = None
    if isinstance(shape, ShapeLoop):
        r, rd = shape.r(t_eval), shape.rdot(t_eval)
    else:
        r = np.stack([np.asarray(shape.r(t), dtype=float) for t in t_eval])
        rd = np.stack([np.asarray(shape.rdot(t), dtype=float) for t in t_eval])
    Ad = G.numeric.Ad(path.g)
    p = np.einsum("nji,j->ni", Ad, mu)
    xc = -np.einsum("naj,nj->na", conn.connection(r), rd)
    xm = np.linalg.solve(conn.locked_inertia(r), p[..., None])[..., 0]
    return Reconstruction(t_eval, path, r, p, xc + xm, xc, xm, mu, alone)
