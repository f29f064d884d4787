r"""Geometric and dynamic phases, and reconstruction on the group (section 2 of the nonholonomic paper).

For a holonomic system with symmetry (:class:`~geomech.systems.holonomic.HolonomicSystem`) the group
variable obeys the reconstruction equation (eq. 2.2)

.. math::

    g^{-1}\dot g = -A_{loc}(r)\dot r + \mathbb I_{loc}^{-1}(r)\,p, \qquad p = \mathrm{Ad}_g^*\mu,

with :math:`\mu` the conserved spatial momentum. :func:`reconstruct` integrates it on the group with a
Lie-group method (:func:`~geomech.solve` on a :class:`~geomech.systems.GroupFlow`: Runge-Kutta-Munthe-Kaas, in
exponential coordinates about a moving centre), for any of the groups. Where the group is abelian (or the
rotation of SE(2) when it decouples, and the free rigid body, :math:`G_\mu = S^1`) the change of the group
variable over a closed shape loop of period :math:`T` splits as in Theorem 2.2 (eq. 2.3):

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

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _validate as V
from .._display import ShowsItselfAsHTML
from ..errors import ConvergenceError, InputError, ShapeError
from ..integrators import Solution
from ..lie._common import wrap_angle
from ..reduction.nonholonomic import reduced_numeric
from ..systems.gait import Gait
from .gait_model import gait_loop
from .group_paths import decompose_displacement, integrate_path
from .shape_loops import bind_loop, periodic_integral

__all__ = [
    "PhaseSplit",
    "Reconstruction",
    "phases",
    "phase_history",
    "geometric_phase",
    "curvature_integral",
    "stokes_integral",
    "reconstruct",
]


# ---------------------------------------------------------------------------------------------------
# Phases (Theorem 2.2)
# ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhaseSplit(ShowsItselfAsHTML):
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


def geometric_phase(
    system: Any,
    loop: Any,
    *,
    period: float | None = None,
    parameters: Mapping[str, float] | None = None,
    rtol: float = 1e-13,
) -> np.ndarray:
    r""":math:`-\oint\mathcal A(r)\,dr` over a closed shape loop, shape ``(k,)`` (every algebra component).

    ``system``: any Lagrangian system on :math:`G\times S` (or its :class:`~geomech.reduction.ReducedNumeric`);
    ``loop``: a :class:`Gait` with a period, or formulas in ``t`` and ``T`` by shape variable with ``period``.
    Without constraints :math:`\mathcal A` is the mechanical connection and the abelian components are the
    geometric phase of Theorem 2.2 (all of them for S^1, the rotation for SE(2)); with constraints it is the
    nonholonomic connection, whose abelian components are the displacement of the connection term alone,
    whatever the loop's timing (the rotation of SE(2)). The other components are not displacements: integrate
    on the group (:func:`reconstruct`, :func:`~geomech.analysis.gaits.analyse_gait`).
    """
    model = reduced_numeric(system, parameters)
    loop = gait_loop(model.system, loop, period, parameters=parameters)
    bind_loop(model, loop)

    def integrand(t: np.ndarray) -> np.ndarray:
        return model.xi_connection(loop.r(t), loop.rdot(t))

    return periodic_integral(integrand, loop.T, rtol=rtol, what="connection")


def phases(system: Any, loop: Gait, mu: Any = 0.0, *, g0: Any = None, rtol: float = 1e-13) -> PhaseSplit:
    """Theorem 2.2 (eq. 2.3): the total phase over a closed shape loop as geometric + dynamic.

    Parameters
    ----------
    system : HolonomicSystem with G = S^1, or G = SE(2) (the rotation angle).
    loop : a closed :class:`Gait` of period T.
    mu : the conserved spatial momentum (a scalar for S^1, ``(p_x, p_y, L)`` for SE(2)).
    g0 : group coordinates at t = 0 (SE(2) with nonzero linear momentum only; default the identity).

    Notes
    -----
    For SE(2), :math:`\\dot\\theta = \\omega` and the rotation component of the bracket vanishes, so the
    rotation obeys (2.3) with :math:`(\\mathbb I^{-1})_{\\theta\\theta}` whenever the body angular momentum
    :math:`p_\\theta = (\\mathrm{Ad}_g^T\\mu)_\\theta` is constant: always when the linear momentum is zero
    (then :math:`p_\\theta = L`), and in a centre-of-mass frame (no translational connection, translational
    locked inertia :math:`M\\,\\mathrm{Id}`) for any momentum (:math:`p_\\theta` is then the angular momentum
    about the centre of mass). Otherwise no such formula holds: use :func:`reconstruct`; for SO(3) with shape and
    :math:`\\mu \\ne 0` (the isotropy a circle) see :func:`~geomech.analysis.isotropy_phase`.
    """
    T = loop.T
    c, p_rot, integrand, turns = _phase_integrand(system, loop, mu, g0)
    geo, inv_int = periodic_integral(integrand, T, rtol=rtol, what="phase")
    dyn = p_rot * inv_int
    G = system.group
    return PhaseSplit(
        float(geo), float(dyn), float(geo + dyn), G.coordinates[c].name, p_rot, T, tuple(int(x) for x in turns), G.name
    )


def phase_history(system: Any, loop: Gait, mu: Any = 0.0, t: Any = None, *, g0: Any = None) -> dict[str, np.ndarray]:
    """The geometric and dynamic parts of eq. (2.3) accumulated from 0 to each time of ``t`` (default 201 times
    over one period): ``{"t", "geometric", "dynamic", "total"}``, each integral a Gauss-Legendre rule of 8
    points per interval of ``t`` on the same integrand as :func:`phases` (the values at ``T`` are its parts)."""
    c, p_rot, integrand, _ = _phase_integrand(system, loop, mu, g0)
    t = np.linspace(0.0, loop.T, 201) if t is None else np.asarray(V.finite(t, "t"), dtype=float).ravel()
    x, w = np.polynomial.legendre.leggauss(8)
    a, b = t[:-1], t[1:]
    nodes = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * x[None, :]
    vals = integrand(nodes.ravel()).reshape(nodes.shape + (2,))
    steps = 0.5 * (b - a)[:, None] * np.einsum("n,knj->kj", w, vals)
    acc = np.concatenate([np.zeros((1, 2)), np.cumsum(steps, 0)])
    geometric, dynamic = acc[:, 0], p_rot * acc[:, 1]
    return {"t": t, "geometric": geometric, "dynamic": dynamic, "total": geometric + dynamic}


def _phase_integrand(system: Any, loop: Gait, mu: Any, g0: Any) -> tuple[int, float, Any, np.ndarray]:
    """The angle component, its body momentum and the integrand ``t -> (-A_c(r) r', (I^-1)_cc(r))`` of eq. (2.3),
    with the loop's windings; the checks of :func:`phases`."""
    G = system.group
    turns = bind_loop(system, loop)
    conn = reduced_numeric(system)
    mu = _momentum(mu, G)
    if len(G.angle_components) != 1:
        raise InputError(
            f"Theorem 2.2 (eq. 2.3) gives the phase of one angle, the component of the algebra on which the group "
            f"is a homomorphism to the circle (S^1, the rotation of SE(2)); {system.name} has G = {G.name} with "
            f"{len(G.angle_components) or 'no'} such components: for SO(3) with shapes and a momentum mu != 0 use "
            "geomech.analysis.isotropy_phase (G_mu a circle), otherwise integrate the reconstruction equation with "
            "geomech.analysis.reconstruct."
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

    return c, p_rot, integrand, turns


def _require_centre_of_mass_frame(system: Any, conn: Any, loop: Gait, c: int, tol: float = 1e-10) -> None:
    """The body frame is a centre-of-mass frame: no connection in the components other than the angle ``c``,
    and a locked inertia ``M Id`` in them with no coupling to ``c``."""
    r = loop.r(np.linspace(0.0, loop.T, 33))
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
    system: Any,
    loop: Any,
    *,
    period: float | None = None,
    parameters: Mapping[str, float] | None = None,
    base_point: Any = None,
    rtol: float = 1e-12,
    n_radial: int = 24,
) -> np.ndarray:
    r""":math:`\iint_D B_{12}\, dr_1 dr_2` over the region a loop in a 2-D shape space encloses, weighted by its
    winding number, shape ``(k,)``; :math:`B = d\mathcal A - [\mathcal A, \mathcal A]` the curvature of the
    mechanical or the nonholonomic connection (arguments as :func:`geometric_phase`).

    Stokes: its abelian components equal :math:`\oint\mathcal A\,dr`, minus the geometric phase (for SE(2)
    the rotation, the bracket having no rotation part); for a small loop around :math:`r_0` the whole
    connection-alone displacement is :math:`\exp(-\iint B) + O(\varepsilon^3)`. Computed as the integral of the
    pull-back of :math:`B` by the cone :math:`(s, t) \mapsto c + s\,(r(t) - c)`, whose boundary is the loop:
    Gauss-Legendre in ``s``, trapezoidal in ``t`` (spectral for smooth loops). The connection must be smooth on
    that cone (``base_point`` ``c``, default the loop's mean); the loop must not wind around an angle
    coordinate.
    """
    model = reduced_numeric(system, parameters)
    if model.sigma != 2:
        raise ShapeError(
            f"Expected a 2-D shape space for the curvature integral, {model.name} has {model.sigma} shape coordinates."
        )
    loop = gait_loop(model.system, loop, period, parameters=parameters)
    return stokes_integral(
        model.curvature_2d, loop, bind_loop(model, loop), base_point=base_point, rtol=rtol, n_radial=n_radial
    )


def stokes_integral(
    curvature_2d: Callable[[np.ndarray], np.ndarray],
    loop: Gait,
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
    T = loop.T
    c = (
        loop.r(np.linspace(0, T, 257)[:-1]).mean(0)
        if base_point is None
        else V.exact_shape(base_point, "base_point", (2,))
    )
    # the round-off of the integrand: |d| |r'| |B| (its terms cancel for a loop that encloses no area)
    t_probe = np.linspace(0.0, T, 64, endpoint=False)
    d_probe, rd_probe = loop.r(t_probe) - c, loop.rdot(t_probe)
    B_probe = curvature_2d(c + 0.5 * d_probe)
    floor = (
        1e-14
        * T
        * float((np.linalg.norm(d_probe, axis=1) * np.linalg.norm(rd_probe, axis=1)).max() * np.abs(B_probe).max())
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

        val = periodic_integral(integrand, T, rtol=rtol, what="curvature", atol=floor)
        if result is not None and np.abs(val - result).max() <= 1e-11 * max(1.0, np.abs(val).max()) + floor:
            return val
        result = val
    raise ConvergenceError(
        "The radial Gauss-Legendre rule for the curvature integral did not converge; "
        "the curvature may be singular inside the loop."
    )


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """The group path of a holonomic system along a shape path, with the parts of its body velocity.

    ``path`` is the path on the group, a :class:`~geomech.Solution` of layout ``"group"`` (``g`` its coordinates,
    angles unwrapped, ``element`` the matrices, ``displacement()``, ``net_motion()``); ``r`` the shapes; ``p``
    the body momenta :math:`\\mathrm{Ad}_g^T\\mu`; ``xi_connection`` :math:`= -A_{loc}\\dot r`, ``xi_momentum``
    :math:`= \\mathbb I^{-1}p` and ``xi`` their sum, all at the output times; ``alone`` maps ``"connection"``
    and ``"momentum"`` to the path each term would give by itself (when asked for).
    """

    t: np.ndarray
    path: Solution
    r: np.ndarray
    p: np.ndarray
    xi: np.ndarray
    xi_connection: np.ndarray
    xi_momentum: np.ndarray
    mu: np.ndarray
    alone: dict[str, Solution] | None = None


def reconstruct(
    system: Any,
    shape: Any,
    mu: Any = 0.0,
    *,
    g0: Any = None,
    t_eval: Any = None,
    method: Any = "rkmk",
    rtol: float = 1e-12,
    atol: float = 1e-12,
    h: float | None = None,
    decompose: bool = False,
) -> Reconstruction:
    """Reconstruct :math:`g(t)` along a shape path by eq. (2.2), for any of the groups.

    Parameters
    ----------
    system : HolonomicSystem.
    shape : a :class:`Gait` (checked to be closed), or any object with ``r(t)`` and ``rdot(t)``
        (e.g. a shape trajectory from a simulation; then give ``t_eval``).
    mu : conserved spatial momentum, ``(k,)`` (a scalar for S^1).
    g0 : group coordinates at the first time (default the identity).
    t_eval : output times (default 201 times over one period of the loop).
    method : ``"rkmk"`` (adaptive, ``rtol``/``atol``) or ``"rkmk4"`` (fixed step ``h``, ``t_eval`` on its grid), or
        a method value: a method of :func:`~geomech.solve` for a :class:`~geomech.systems.GroupFlow`.
    decompose : also integrate the connection term and the momentum term alone.
    """
    G = system.group
    conn = reduced_numeric(system)
    if isinstance(shape, Gait):
        bind_loop(system, shape)
        if t_eval is None:
            t_eval = np.linspace(0.0, shape.T, 201)
    elif t_eval is None:
        raise InputError("Give `t_eval` when `shape` is not a Gait.")
    mu = _momentum(mu, G)
    alpha0 = np.zeros(G.dim) if g0 is None else V.exact_shape(np.atleast_1d(g0), "g0", (G.dim,))

    def xi_conn(t: float, g: np.ndarray) -> np.ndarray:
        r = shape.r(t)
        return -conn.connection(r) @ shape.rdot(t)

    def xi_mom(t: float, g: np.ndarray) -> np.ndarray:
        I = conn.locked_inertia(shape.r(t))
        return np.linalg.solve(I, G.numeric.Ad(g).T @ mu)

    opts: dict[str, Any] = dict(method=method, rtol=rtol, atol=atol, h=h)
    t_eval = V.finite(t_eval, "t_eval")
    if decompose:
        parts = decompose_displacement(G, {"connection": xi_conn, "momentum": xi_mom}, alpha0, t_eval, **opts)
        path, alone = parts.pop("total"), parts
    else:
        path = integrate_path(G, lambda t, g: xi_conn(t, g) + xi_mom(t, g), alpha0, t_eval, **opts)
        alone = None
    if isinstance(shape, Gait):
        r, rd = shape.r(t_eval), shape.rdot(t_eval)
    else:
        r = np.stack([np.asarray(shape.r(t), dtype=float) for t in t_eval])
        rd = np.stack([np.asarray(shape.rdot(t), dtype=float) for t in t_eval])
    Ad = G.numeric.Ad(path.element)
    p = np.einsum("nji,j->ni", Ad, mu)
    xc = -np.einsum("naj,nj->na", conn.connection(r), rd)
    xm = np.linalg.solve(conn.locked_inertia(r), p[..., None])[..., 0]
    return Reconstruction(t_eval, path, r, p, xc + xm, xc, xm, mu, alone)
