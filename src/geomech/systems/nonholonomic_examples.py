r"""The classical nonholonomic systems with symmetry, built with the public constructor a user has.

Each builder returns a :class:`~geomech.systems.nonholonomic.NonholonomicSystem` whose derivations are
symbolic in every parameter; numeric values given as keyword arguments are stored for simulation. The
symbolic system is built once per process (``functools.lru_cache``), so repeated calls are cheap and share
the cached derivations of :mod:`geomech.reduction.nonholonomic`.

==========================  ================  ============  =======================================
builder                     group             shape         constraints
==========================  ================  ============  =======================================
:func:`snakeboard`          SE(2) (x, y, th)  (psi, phi)    no lateral slip of both wheel pairs
:func:`snakeboard_bkmm`     SE(2)             (psi, phi)    same, with BKMM's inertia normalisation
:func:`roller_racer`        SE(2)             (phi,)        no lateral slip of both bodies' wheels
:func:`simplified_bicycle`  SE(2)             (phi, sigma)  rear and front wheel do not slip
:func:`chaplygin_sleigh`    SE(2)             ()            knife edge does not slip sideways
:func:`rolling_disk`        SE(2)             (phi,)        rolling without slipping
:func:`geared_body`         SE(2)             (psi,)        integrable: theta' = k psi'
:func:`kinematic_car`       SE(2)             (psi, phi)    rolling rear wheels, steered front axle
:func:`chaplygin_ball`      SE(2) (x, y, ph)  (theta, psi)  rolling without slipping on a plane
==========================  ================  ============  =======================================
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import sympy as sp

from ..lie.groups import SE2, SO3
from ..symbolic.polys import expand_terms
from ..symbolic.simplify import simplify_expr
from .nonholonomic import NonholonomicSystem

__all__ = [
    "snakeboard",
    "snakeboard_bkmm",
    "roller_racer",
    "simplified_bicycle",
    "chaplygin_sleigh",
    "rolling_disk",
    "geared_body",
    "kinematic_car",
    "chaplygin_ball",
    "EXAMPLES",
]


def _params(names: str) -> tuple[sp.Symbol, ...]:
    return sp.symbols(names, positive=True)


def _v(*names: str) -> tuple[sp.Symbol, ...]:
    return tuple(sp.Symbol(f"{n}_dot", real=True) for n in names)


def _q(*names: str) -> tuple[sp.Symbol, ...]:
    return tuple(sp.Symbol(n, real=True) for n in names)


def _no_slip(vx: sp.Expr, vy: sp.Expr, heading: sp.Expr) -> sp.Expr:
    """Velocity of a wheel's contact point across the wheel (heading ``heading``): it must vanish."""
    return -sp.sin(heading) * vx + sp.cos(heading) * vy


def _tidy(expr: sp.Expr, velocities: tuple[sp.Symbol, ...]) -> sp.Expr:
    """A polynomial in the velocities with each coefficient trigonometrically simplified (readable output)."""
    poly = sp.Poly(sp.expand(expr), *velocities)
    return sum(
        sp.factor_terms(sp.trigsimp(c)) * sp.prod([v**e for v, e in zip(velocities, mon)]) for mon, c in poly.terms()
    )


# --------------------------------------------------------------------------------------------------
# Snakeboard
# --------------------------------------------------------------------------------------------------
_SNAKEBOARD_DOC = """
    Coordinates :math:`(x, y, \\theta)` of the board's centre and heading (group SE(2)), the rotor angle
    :math:`\\psi` and the steering angle :math:`\\phi` (shape). The wheel axles sit at distance ``r`` ahead
    of and behind the centre; the back wheels point along :math:`\\theta + \\phi`, the front wheels along
    :math:`\\theta - \\phi` (BKMM's convention, the wheel pairs are steered opposite). So **+phi turns the
    back wheels counter-clockwise and the front wheels clockwise relative to the board**: rolling forward
    (towards the front wheels, speed :math:`v > 0`) with :math:`\\phi > 0` the board turns clockwise,
    :math:`\\dot\\theta = -v\\tan\\phi / r`. Constraints (no lateral slip of either wheel pair):

    .. math::

        -\\sin(\\theta+\\phi)\\dot x + \\cos(\\theta+\\phi)\\dot y - r\\cos\\phi\\,\\dot\\theta = 0, \\qquad
        -\\sin(\\theta-\\phi)\\dot x + \\cos(\\theta-\\phi)\\dot y + r\\cos\\phi\\,\\dot\\theta = 0 .

    ``m`` is the total mass, ``J`` the board's moment of inertia about the centre, ``J0`` the rotor's,
    ``J1`` each wheel pair's about its vertical axis; with :math:`\\dot\\phi_{back} = \\dot\\phi`,
    :math:`\\dot\\phi_{front} = -\\dot\\phi` the wheel terms are
    :math:`\\tfrac{J_1}{2}[(\\dot\\theta+\\dot\\phi)^2 + (\\dot\\theta-\\dot\\phi)^2]`. The body-fixed basis is BKMM's,
    :math:`e(\\phi) = (-2r\\cos^2\\phi,\\ 0,\\ \\sin 2\\phi)` in body velocities :math:`(v_x, v_y, \\omega)`, i.e.
    :math:`e_Q = -2r\\cos^2\\phi\\,(\\cos\\theta\\,\\partial_x + \\sin\\theta\\,\\partial_y)
    + \\sin 2\\phi\\,\\partial_\\theta`
    (rotation about the point where the wheel axes meet).
"""

_BKMM_BASIS = (
    "BKMM's body-fixed basis e = (-2 r cos(phi)**2, 0, sin(2 phi)) (Bloch, Krishnaprasad, Marsden, Murray 1996)"
)


@lru_cache(maxsize=None)
def _snakeboard(bkmm: bool) -> NonholonomicSystem:
    m, r, J, J0, J1 = _params("m r J J0 J1")
    x, y, th, psi, phi = _q("x", "y", "theta", "psi", "phi")
    xd, yd, thd, psid, phid = _v("x", "y", "theta", "psi", "phi")
    Jt = m * r**2 if bkmm else J + J0 + 2 * J1
    L = m / 2 * (xd**2 + yd**2) + Jt / 2 * thd**2 + J0 * thd * psid + J0 / 2 * psid**2 + J1 * phid**2
    # no slip across the back and front axles (at (x, y) -/+ r (cos theta, sin theta)), written out: the velocity of
    # each axle's centre across its wheels, simplified (the test of this example derives it from _no_slip)
    back = -sp.sin(th + phi) * xd + sp.cos(th + phi) * yd - r * sp.cos(phi) * thd
    front = -sp.sin(th - phi) * xd + sp.cos(th - phi) * yd + r * sp.cos(phi) * thd
    basis = sp.Matrix([-2 * r * sp.cos(phi) ** 2, 0, sp.sin(2 * phi)])
    desc = "snakeboard (BKMM 1996): a board with a rotor and two wheel pairs steered opposite; " + (
        "inertia normalised as in BKMM, J + J0 + 2 J1 = m r^2" if bkmm else "general inertias m, r, J, J0, J1"
    )
    return NonholonomicSystem.from_lagrangian(
        L,
        SE2(x, y, th),
        (psi, phi),
        [back, front],
        name="snakeboard_bkmm" if bkmm else "snakeboard",
        description=desc,
        basis=basis,
        basis_note=_BKMM_BASIS,
    )


def snakeboard(**values: float) -> NonholonomicSystem:
    r"""The snakeboard with general inertias (the seed's example; Lewis, Ostrowski, Murray and Burdick 1994).

    .. math::

        L = \tfrac m2(\dot x^2 + \dot y^2) + \tfrac12(J + J_0 + 2J_1)\dot\theta^2 + J_0\dot\theta\dot\psi
            + \tfrac{J_0}{2}\dot\psi^2 + J_1\dot\phi^2 .
    """
    return _snakeboard(False).with_parameters(**values) if values else _snakeboard(False)


snakeboard.__doc__ = (snakeboard.__doc__ or "") + _SNAKEBOARD_DOC


def snakeboard_bkmm(**values: float) -> NonholonomicSystem:
    r"""The snakeboard of BKMM (1996): inertias normalised so that :math:`J + J_0 + 2J_1 = m r^2`,

    .. math::

        L = \tfrac m2(\dot x^2 + \dot y^2) + \tfrac{m r^2}{2}\dot\theta^2 + J_0\dot\theta\dot\psi
            + \tfrac{J_0}{2}\dot\psi^2 + J_1\dot\phi^2 .

    With BKMM's basis the reduction gives their published equations: locked inertia
    :math:`\mathbb I = 4 m r^2\cos^2\phi`, momentum equation
    :math:`\dot p = 2J_0\cos^2\phi\,\dot\phi\dot\psi - \tan\phi\, p\,\dot\phi`, reconstruction
    :math:`\dot\theta = -\tfrac{J_0}{m r^2}\sin^2\phi\,\dot\psi + \tfrac{1}{2 m r^2}\tan\phi\, p`, and
    :math:`2J_1\ddot\phi = \tau_\phi` (checked by the tests).
    """
    return _snakeboard(True).with_parameters(**values) if values else _snakeboard(True)


snakeboard_bkmm.__doc__ = (snakeboard_bkmm.__doc__ or "") + _SNAKEBOARD_DOC


# --------------------------------------------------------------------------------------------------
# Roller racer
# --------------------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _roller_racer() -> NonholonomicSystem:
    m1, m2, I1, I2, d1, d2 = _params("m1 m2 I1 I2 d1 d2")
    x, y, th, phi = _q("x", "y", "theta", "phi")
    xd, yd, thd, phid = _v("x", "y", "theta", "phi")
    # Body 2's centre of mass: behind the joint, which is d1 behind body 1's centre of mass.
    X2 = x - d1 * sp.cos(th) - d2 * sp.cos(th + phi)
    Y2 = y - d1 * sp.sin(th) - d2 * sp.sin(th + phi)
    q, qd = (x, y, th, phi), (xd, yd, thd, phid)
    X2d = sum(sp.diff(X2, a) * b for a, b in zip(q, qd))
    Y2d = sum(sp.diff(Y2, a) * b for a, b in zip(q, qd))
    L = m1 / 2 * (xd**2 + yd**2) + I1 / 2 * thd**2 + m2 / 2 * (X2d**2 + Y2d**2) + I2 / 2 * (thd + phid) ** 2
    cons = [_no_slip(xd, yd, th), _tidy(_no_slip(X2d, Y2d, th + phi), qd)]
    return NonholonomicSystem.from_lagrangian(
        _tidy(L, qd),
        SE2(x, y, th),
        (phi,),
        cons,
        name="roller_racer",
        description="roller racer (Tsakiris and Krishnaprasad): two planar bodies joined by a pivot, a wheel pair "
        "at each body's centre of mass; phi is the relative angle (body 2 heads theta + phi)",
    )


def roller_racer(**values: float) -> NonholonomicSystem:
    r"""The roller racer: two planar bodies joined by a vertical pivot, each on a wheel pair at its centre of mass.

    Body 1 (mass ``m1``, inertia ``I1``) has its centre of mass at :math:`(x, y)` and heading :math:`\theta`;
    the pivot is ``d1`` behind it; body 2 (``m2``, ``I2``) has its centre of mass ``d2`` behind the pivot
    and heading :math:`\theta + \phi`. Neither wheel pair slips sideways. Shape: the joint angle
    :math:`\phi`; oscillating it propels the racer (Krishnaprasad and Tsakiris, 1995).
    """
    return _roller_racer().with_parameters(**values) if values else _roller_racer()


# --------------------------------------------------------------------------------------------------
# Simplified bicycle (Getz and Marsden)
# --------------------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _bicycle() -> NonholonomicSystem:
    m, h, c, b, g, Js = _params("m h c b g J_s")
    x, y, th, phi, sig = _q("x", "y", "theta", "phi", "sigma")
    xd, yd, thd, phid, sigd = _v("x", "y", "theta", "phi", "sigma")
    q, qd = (x, y, th, phi, sig), (xd, yd, thd, phid, sigd)
    e1 = sp.Matrix([sp.cos(th), sp.sin(th), 0])
    e2 = sp.Matrix([-sp.sin(th), sp.cos(th), 0])
    e3 = sp.Matrix([0, 0, 1])
    pos = sp.Matrix([x, y, 0]) + c * e1 + h * (-sp.sin(phi) * e2 + sp.cos(phi) * e3)
    vel = pos.jacobian(q) * sp.Matrix(qd)
    L = m / 2 * (vel.T * vel)[0, 0] + Js / 2 * sigd**2 - m * g * h * sp.cos(phi)
    rear = _no_slip(xd, yd, th)
    front = _no_slip(xd - b * sp.sin(th) * thd, yd + b * sp.cos(th) * thd, th + sig)
    return NonholonomicSystem.from_lagrangian(
        _tidy(L, qd),
        SE2(x, y, th),
        (phi, sig),
        [rear, _tidy(front, qd)],
        name="simplified_bicycle",
        description="simplified bicycle (Getz and Marsden 1995): a point mass on a leaning frame, rear wheel and "
        "steered front wheel rolling without lateral slip",
    )


def simplified_bicycle(**values: float) -> NonholonomicSystem:
    r"""The simplified bicycle of Getz and Marsden (1995), as treated by Koon and Marsden (1997).

    :math:`(x, y)` is the rear wheel's contact point and :math:`\theta` the frame's heading (group SE(2));
    the shape is the lean (roll) angle :math:`\phi` (positive to the left: the frame rotates by
    :math:`\phi` about the forward axis) and the steering angle :math:`\sigma` (the front wheel points along
    :math:`\theta + \sigma`). The mass ``m`` is a point at height ``h`` above the ground line, ``c`` ahead of
    the rear contact; ``b`` is the wheelbase, ``g`` gravity. Getz and Marsden treat :math:`\sigma` as an
    input with no inertia; a steering inertia ``J_s`` (a term :math:`\tfrac{J_s}{2}\dot\sigma^2`) keeps the
    kinetic metric regular; with :math:`\sigma(t)` prescribed, as in their model, it does not affect the
    motion. Constraints: :math:`-\sin\theta\,\dot x + \cos\theta\,\dot y = 0` (rear) and no lateral slip of
    the front contact :math:`(x, y) + b(\cos\theta, \sin\theta)`.
    """
    return _bicycle().with_parameters(**values) if values else _bicycle()


# --------------------------------------------------------------------------------------------------
# Chaplygin sleigh, rolling disk, geared body (integrable)
# --------------------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _sleigh() -> NonholonomicSystem:
    m, I, a = _params("m I_c a")
    x, y, th = _q("x", "y", "theta")
    xd, yd, thd = _v("x", "y", "theta")
    L = m / 2 * ((xd - a * sp.sin(th) * thd) ** 2 + (yd + a * sp.cos(th) * thd) ** 2) + I / 2 * thd**2
    return NonholonomicSystem.from_lagrangian(
        expand_terms(L),
        SE2(x, y, th),
        (),
        [_no_slip(xd, yd, th)],
        name="chaplygin_sleigh",
        description="Chaplygin sleigh: a planar body on a knife edge at (x, y), centre of mass a ahead of it",
    )


def chaplygin_sleigh(**values: float) -> NonholonomicSystem:
    r"""The Chaplygin sleigh: a planar body (mass ``m``, inertia ``I_c`` about its centre of mass) on a knife
    edge at :math:`(x, y)` pointing along :math:`\theta`, centre of mass a distance ``a`` ahead.

    No shape variables: :math:`S_q = \mathcal D_q`, the momentum equation is all the dynamics. With the
    default basis :math:`e_1 = (1, 0, 0)` (forward velocity :math:`v`), :math:`e_2 = (0, 0, 1)` (rotation
    :math:`\omega`) its solutions satisfy :math:`\dot v = a\omega^2`,
    :math:`\dot\omega = -m a v\omega/(I_c + m a^2)` (Neimark and Fufaev; Bloch's book, section 1.7).
    """
    return _sleigh().with_parameters(**values) if values else _sleigh()


@lru_cache(maxsize=None)
def _disk() -> NonholonomicSystem:
    m, R, I, J = _params("m R I J")
    x, y, th, phi = _q("x", "y", "theta", "phi")
    xd, yd, thd, phid = _v("x", "y", "theta", "phi")
    L = m / 2 * (xd**2 + yd**2) + I / 2 * thd**2 + J / 2 * phid**2
    cons = [xd - R * sp.cos(th) * phid, yd - R * sp.sin(th) * phid]
    return NonholonomicSystem.from_lagrangian(
        L,
        SE2(x, y, th),
        (phi,),
        cons,
        name="rolling_disk",
        description="vertical rolling disk: contact point (x, y), heading theta, rolling angle phi",
    )


def rolling_disk(**values: float) -> NonholonomicSystem:
    r"""The vertical rolling disk (radius ``R``, mass ``m``, inertia ``I`` about the vertical, ``J`` about its axle).

    .. math::

        L = \tfrac m2(\dot x^2 + \dot y^2) + \tfrac I2\dot\theta^2 + \tfrac J2\dot\phi^2, \qquad
        \dot x = R\cos\theta\,\dot\phi, \quad \dot y = R\sin\theta\,\dot\phi .

    Group SE(2) acting on :math:`(x, y, \theta)`, shape the rolling angle :math:`\phi`; :math:`S_q` is the
    spin about the vertical, whose momentum :math:`I\dot\theta` is conserved, and :math:`\dot\phi` is constant.
    """
    return _disk().with_parameters(**values) if values else _disk()


@lru_cache(maxsize=None)
def _geared(scaled: bool) -> NonholonomicSystem:
    m, J, J0, k, a = _params("m J J0 k a")
    x, y, th, psi = _q("x", "y", "theta", "psi")
    xd, yd, thd, psid = _v("x", "y", "theta", "psi")
    # A rotor whose axle sits a distance a ahead of the body's reference point (x, y).
    L = (
        m / 2 * ((xd - a * sp.sin(th) * thd) ** 2 + (yd + a * sp.cos(th) * thd) ** 2)
        + J / 2 * thd**2
        + J0 / 2 * (thd + psid) ** 2
    )
    factor = (2 + sp.sin(psi)) if scaled else 1
    return NonholonomicSystem.from_lagrangian(
        expand_terms(L),
        SE2(x, y, th),
        (psi,),
        [factor * (thd - k * psid)],
        name="geared_body_scaled" if scaled else "geared_body",
        description="planar body whose heading is geared to a rotor, theta' = k psi' (an integrable constraint "
        "written as a one-form" + (", multiplied by 2 + sin(psi)" if scaled else "") + ")",
    )


def geared_body(*, scaled: bool = False, **values: float) -> NonholonomicSystem:
    r"""A system with an integrable constraint written as a one-form: a planar body whose heading is geared
    to an internal rotor, :math:`\dot\theta = k\dot\psi` (so :math:`\theta - k\psi` is constant).

    .. math::

        L = \tfrac m2\big((\dot x - a\sin\theta\,\dot\theta)^2 + (\dot y + a\cos\theta\,\dot\theta)^2\big)
            + \tfrac J2\dot\theta^2 + \tfrac{J_0}{2}(\dot\theta + \dot\psi)^2,
        \qquad \omega = d\theta - k\,d\psi .

    With ``scaled=True`` the one-form is multiplied by :math:`2 + \sin\psi`: no longer exact, still integrable
    (Frobenius), so the almost-Poisson bracket still satisfies the Jacobi identity.
    """
    base = _geared(scaled)
    return base.with_parameters(**values) if values else base


#: Builders by name (used by the command line).
@lru_cache(maxsize=None)
def _car() -> NonholonomicSystem:
    m, I, R, ell, J, K = _params("m I R ell J K")
    x, y, th, psi, phi = _q("x", "y", "theta", "psi", "phi")
    xd, yd, thd, psid, phid = _v("x", "y", "theta", "psi", "phi")
    L = m / 2 * (xd**2 + yd**2) + I / 2 * thd**2 + J / 2 * psid**2 + K / 2 * phid**2
    cons = [sp.cos(th) * xd + sp.sin(th) * yd - R * psid, _no_slip(xd, yd, th), thd - R / ell * sp.tan(phi) * psid]
    return NonholonomicSystem.from_lagrangian(
        L,
        SE2(x, y, th),
        (psi, phi),
        cons,
        name="kinematic_car",
        description="kinematic car: rear axle at (x, y) heading theta, rear wheel angle psi (radius R), steering "
        "angle phi, wheelbase ell; principally kinematic (S_q = 0)",
    )


def kinematic_car(**values: float) -> NonholonomicSystem:
    r"""A rear-wheel-drive car with rolling rear wheels (radius ``R``, angle :math:`\psi`) and a front axle steered
    by :math:`\phi` at wheelbase ``ell``: three constraints,

    .. math::

        v_x = R\dot\psi, \qquad v_y = 0, \qquad \dot\theta = \frac{R}{\ell}\tan\phi\,\dot\psi,

    fix the body velocity from the shape velocity, so :math:`S_q = 0`: the system is *principally kinematic*,
    has no nonholonomic momentum, and its motion is the connection term alone. ``m``, ``I``: the body's mass
    and inertia; ``J``, ``K``: the inertias of the driven wheel and of the steering.
    """
    return _car().with_parameters(**values) if values else _car()


@lru_cache(maxsize=None)
def _ball() -> NonholonomicSystem:
    m, r, I1, I2, I3 = _params("m r I1 I2 I3")
    x, y, ph, th, ps = _q("x", "y", "phi", "theta", "psi")
    xd, yd, phd, thd, psd = _v("x", "y", "phi", "theta", "psi")
    R = SO3().sympy_element([ph, th, ps])[0]  # 3-1-3: Rz(phi) Rx(theta) Rz(psi)
    Rd = sum((R.diff(a) * b for a, b in zip((ph, th, ps), (phd, thd, psd))), sp.zeros(3))
    body = (R.T * Rd).applyfunc(simplify_expr)  # hat of the body angular velocity omega
    space = (Rd * R.T).applyfunc(simplify_expr)  # hat of the spatial angular velocity Omega = R omega
    w = (body[2, 1], body[0, 2], body[1, 0])
    Om = (space[2, 1], space[0, 2], space[1, 0])
    L = m / 2 * (xd**2 + yd**2) + (I1 * w[0] ** 2 + I2 * w[1] ** 2 + I3 * w[2] ** 2) / 2
    # the contact point, a distance r below the centre, does not slip: x' + Omega x (-r e3) = 0
    cons = [xd - r * Om[1], yd + r * Om[0]]
    return NonholonomicSystem.from_lagrangian(
        expand_terms(L),
        SE2(x, y, ph),
        (th, ps),
        cons,
        name="chaplygin_ball",
        description="Chaplygin's ball: a sphere (radius r, mass m, centre of mass at its centre, principal moments "
        "I1, I2, I3) rolling without slipping on a plane; attitude R = Rz(phi) Rx(theta) Rz(psi)",
    )


def chaplygin_ball(**values: float) -> NonholonomicSystem:
    r"""Chaplygin's ball: a sphere of radius ``r`` and mass ``m`` whose centre of mass is its geometric centre,
    with principal moments ``I1, I2, I3``, rolling without slipping on a horizontal plane.

    Attitude :math:`R = R_z(\phi)R_x(\theta)R_z(\psi)` (3-1-3), centre at :math:`(x, y, r)`;
    :math:`L = \tfrac m2(\dot x^2 + \dot y^2) + \tfrac12\sum_i I_i\omega_i^2` with :math:`\omega` the body angular
    velocity; no slip at the contact point, :math:`\dot x = r\Omega_y`, :math:`\dot y = -r\Omega_x`
    (:math:`\Omega = R\omega`, spatial). Rotating the ball about the vertical and translating it, SE(2) acts on
    :math:`(x, y, \phi)`, leaving the shape :math:`(\theta, \psi)`; :math:`S_q` is the spin about the vertical,
    and its momentum is conserved. Chaplygin (1903) showed the angular momentum about the contact point,
    :math:`K = R\,\mathbb I\omega + m r^2(\Omega - \Omega_z e_3)`, is constant in space, and the system integrable
    (Borisov and Mamaev, Regul. Chaotic Dyn. 7 (2002)); the tests check :math:`K`. The 3-1-3 chart is singular
    at :math:`\theta = 0, \pi` (a body axis vertical).
    """
    return _ball().with_parameters(**values) if values else _ball()


EXAMPLES: dict[str, Any] = {
    "snakeboard": snakeboard,
    "snakeboard_bkmm": snakeboard_bkmm,
    "roller_racer": roller_racer,
    "simplified_bicycle": simplified_bicycle,
    "chaplygin_sleigh": chaplygin_sleigh,
    "rolling_disk": rolling_disk,
    "geared_body": geared_body,
    "kinematic_car": kinematic_car,
    "chaplygin_ball": chaplygin_ball,
}
