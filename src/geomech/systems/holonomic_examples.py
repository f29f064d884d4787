"""Examples of holonomic systems with symmetry (section 2 of the nonholonomic paper and beyond), built with
the same public constructor a user has, :meth:`HolonomicSystem.from_lagrangian`."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from .. import _validate as V
from ..errors import InputError, ShapeError, SingularityError
from ..lie.groups import SO2
from ..symbolic.compile import bind_expression
from ..symbolic.polys import expand_terms
from .holonomic import HolonomicSystem


def _rot2(a: sp.Expr) -> sp.Matrix:
    return SO2().sympy_element([a])[0]


__all__ = [
    "EXAMPLES",
    "two_pinned_bodies",
    "planar_point_masses",
    "planar_point_positions",
    "three_link_chain",
    "three_link_positions",
    "spacecraft_with_rotors",
]


# ---------------------------------------------------------------------------------------------------
# Examples
# ---------------------------------------------------------------------------------------------------
def two_pinned_bodies(I1: float = 1.0, I2: float = 3.0) -> HolonomicSystem:
    """Two planar rigid bodies pinned together at their centres of mass (section 2.2 of the nonholonomic
    paper): :math:`G = S^1` the angle :math:`\\theta = \\theta_1` of body 1, shape the hinge angle
    :math:`\\psi = \\theta_2 - \\theta_1`, and

    .. math::

        L = \\tfrac12 I_1\\dot\\theta^2 + \\tfrac12 I_2(\\dot\\theta + \\dot\\psi)^2,\\qquad
        \\mathbb I = I_1 + I_2,\\quad A_{loc} = \\frac{I_2}{I_1 + I_2}\\,d\\psi.

    Parameters ``I1``, ``I2`` (symbols kept in the formulas) must be >= 0 with a positive sum.
    """
    I1v, I2v = float(V.finite(I1, "I1")), float(V.finite(I2, "I2"))
    if I1v < 0 or I2v < 0:
        raise InputError(f"Expected the moments of inertia `I1`, `I2` to be >= 0, got {I1v}, {I2v}.")
    if I1v + I2v <= 0:
        raise SingularityError(
            f"The locked inertia I1 + I2 = {I1v + I2v:g} of the pinned bodies is singular; give a positive moment."
        )
    L = "I1*theta_dot**2/2 + I2*(theta_dot + psi_dot)**2/2"
    return HolonomicSystem.from_lagrangian(
        L, "S1", ["psi"], parameters={"I1": I1v, "I2": I2v}, shape_angles=(0,), name="two pinned bodies"
    )


def planar_point_masses(
    masses: Sequence[float], pair_potential: Any = "-k*mi*mj/d", parameters: Mapping[str, float] | None = None
) -> HolonomicSystem:
    """The planar N-body problem, N >= 2 point masses with a pairwise potential, G = SE(2).

    Group coordinates ``(x, y, theta)``: the centre of mass and the direction of the first Jacobi vector
    :math:`\\rho_1 = x_2 - x_1`. Shape: ``rho`` = :math:`|\\rho_1|` and the body-frame components
    ``(a_j, b_j)`` of the Jacobi vectors :math:`\\rho_j = x_{j+1} - c_j` (:math:`c_j` the centre of mass
    of the first :math:`j` bodies), :math:`\\rho_j = R(\\theta) (a_j, b_j)`, :math:`j = 2..N-1`. In
    Jacobi vectors the kinetic energy is diagonal,
    :math:`T = \\tfrac12 M|\\dot c|^2 + \\tfrac12\\sum_j \\mu_j|\\dot\\rho_j|^2`,
    :math:`\\mu_j = m_{j+1} M_j / M_{j+1}`, so the connection has no translational part and the rotational
    part is :math:`A_\\theta = \\sum_j \\mu_j (s_j \\times ds_j) / \\sum_j \\mu_j |s_j|^2`.

    Parameters
    ----------
    masses : N positive masses (symbols ``m1..mN`` in the formulas).
    pair_potential : expression in ``d`` (distance), ``mi``, ``mj`` and parameters; default gravity
        ``-k mi mj / d`` with ``k = 1``.
    parameters : values of the potential's parameters.
    """
    ms = V.positive(masses, "masses")
    if ms.ndim != 1 or ms.size < 2:
        raise ShapeError(f"Expected `masses` to hold N >= 2 values, got shape {ms.shape}.")
    N = ms.size
    m = sp.symbols(f"m1:{N + 1}", positive=True)
    d, mi, mj = sp.symbols("d mi mj", positive=True)
    params = dict(parameters or {})
    if isinstance(pair_potential, str) and pair_potential == "-k*mi*mj/d":
        params.setdefault("k", 1.0)
    pot, pvals = bind_expression(pair_potential, params, (d, mi, mj), "pair_potential")
    rho = sp.Symbol("rho", positive=True)
    ab = [sp.symbols(f"a{j} b{j}", real=True) for j in range(2, N)]
    s = [sp.Matrix([rho, 0])] + [sp.Matrix([a, b]) for a, b in ab]
    x, y, th = sp.symbols("x y theta", real=True)
    shape = [rho] + [c for pair in ab for c in pair]
    qd = {q: sp.Symbol(f"{q}_dot", real=True) for q in [x, y, th] + shape}
    Mj = [sum(m[:j]) for j in range(1, N + 1)]
    R = _rot2(th)

    def tdiff(e):
        return sum(sp.diff(e, q) * v for q, v in qd.items())

    T = sp.Rational(1, 2) * Mj[-1] * (qd[x] ** 2 + qd[y] ** 2)
    for j in range(N - 1):
        mu_j = m[j + 1] * Mj[j] / Mj[j + 1]
        w = (R * s[j]).applyfunc(tdiff)
        T += sp.Rational(1, 2) * mu_j * sp.expand(sp.trigsimp(sp.expand(w.dot(w))))
    # the pair distances from the Jacobi vectors: a difference of positions needs no centre of mass, and each
    # component kept as one fraction (b2 and a2 + m2 rho/(m1 + m2) for the third body and the first), not expanded
    pos, _ = _chain_positions(s, m, Mj)
    Vexpr = 0
    for i in range(N):
        for j in range(i + 1, N):
            gap = [sp.factor(c) for c in pos[j] - pos[i]]
            dist = sp.sqrt(sum(c**2 for c in gap if c != 0))
            Vexpr += pot.xreplace({d: dist, mi: m[i], mj: m[j]})
    values = {f"m{i + 1}": float(v) for i, v in enumerate(ms)} | pvals
    return HolonomicSystem.from_lagrangian(T - Vexpr, "SE2", shape, parameters=values, name=f"planar {N} point masses")


def _chain_positions(s: list, m: Sequence[sp.Expr], Mj: list) -> tuple[list, sp.Matrix]:
    """Body-frame positions x_i relative to x_1 from the Jacobi vectors s_j = x_{j+1} - c_j, and the centre of mass
    c_N: x_{j+1} = c_j + s_j, c_{j+1} = (M_j c_j + m_{j+1} x_{j+1})/M_{j+1}."""
    xs = [sp.zeros(2, 1)]
    cj = sp.zeros(2, 1)
    for j in range(len(m) - 1):
        xn = cj + s[j]
        xs.append(xn)
        cj = (Mj[j] * cj + m[j + 1] * xn) / Mj[j + 1]
    return xs, cj


def _jacobi_positions(s: list, m: Sequence[sp.Expr], Mj: list) -> list:
    """Body-frame positions x_i (centre of mass at 0) from Jacobi vectors s_j = x_{j+1} - c_j."""
    xs, c = _chain_positions(s, m, Mj)
    return [(xi - c).applyfunc(sp.simplify) for xi in xs]


def planar_point_positions(system: HolonomicSystem, q: Any) -> np.ndarray:
    """Inertial positions ``(..., N, 2)`` of :func:`planar_point_masses` at coordinates ``q``."""
    q = np.asarray(q, dtype=float)
    key = "_positions_kernel"
    f = system.__dict__.get(key)
    if f is None:
        N = 1 + (system.sigma + 1) // 2
        by_name = {p.name: p for p in system.parameter_symbols}
        m = [by_name[f"m{i + 1}"] for i in range(N)]  # the system's own parameter symbols
        Mj = [sum(m[:j]) for j in range(1, N + 1)]
        sh = system.shape
        s = [sp.Matrix([sh[0], 0])] + [sp.Matrix([sh[1 + 2 * i], sh[2 + 2 * i]]) for i in range(N - 2)]
        x, y, th = system.group.coordinates
        pos = [sp.Matrix([x, y]) + _rot2(th) * p for p in _jacobi_positions(s, m, Mj)]
        f = system.compile(sp.Matrix.hstack(*pos).T, system.q)
        object.__setattr__(system, key, f)  # cache on the frozen instance
    return f(q)


def _chain_geometry(q: Sequence[sp.Expr], m: Sequence[sp.Expr], lengths: Sequence[sp.Expr], origin: str) -> tuple:
    """The three links' centres and the chain's four points (tail, joint 1, joint 2, head), as 2-vectors in the
    coordinates ``q = (x, y, theta, alpha1, alpha2)`` of :func:`three_link_chain` with ``origin``."""
    x, y, th, a1, a2 = q
    angles = [th - a1, th, th + a2]

    def e(a):
        return sp.Matrix([sp.cos(a), sp.sin(a)])

    # centres relative to the middle link's centre
    rel = [
        -(lengths[1] / 2) * e(angles[1]) - (lengths[0] / 2) * e(angles[0]),
        sp.zeros(2, 1),
        (lengths[1] / 2) * e(angles[1]) + (lengths[2] / 2) * e(angles[2]),
    ]
    base = sp.Matrix([x, y])
    if origin == "com":
        base = base - sum((mi * ri for mi, ri in zip(m, rel)), sp.zeros(2, 1)) / sum(m)
    centres = [base + ri for ri in rel]
    half = [lengths[i] / 2 * e(angles[i]) for i in range(3)]
    points = [centres[0] - half[0], centres[1] - half[1], centres[1] + half[1], centres[2] + half[2]]
    return centres, points


def three_link_positions(system: HolonomicSystem, q: Any) -> np.ndarray:
    """The four points of a :func:`three_link_chain` (its tail, the two joints and its head, in order along the
    chain) at coordinates ``q`` ``(..., 5)``: inertial positions ``(..., 4, 2)``, link ``i`` from point ``i`` to
    point ``i + 1``. For drawing and animating the chain, and for its head's path."""
    origin = {"three-link chain (com frame)": "com", "three-link chain (middle frame)": "middle"}.get(system.name)
    if origin is None:
        raise InputError(f"Expected a system made by three_link_chain(), got {system.name!r}.")
    q = np.asarray(q, dtype=float)
    key = "_positions_kernel"
    f = system.__dict__.get(key)
    if f is None:
        by_name = {p.name: p for p in system.parameter_symbols}
        m = [by_name[f"m{i + 1}"] for i in range(3)]  # the system's own parameter symbols
        lengths = [by_name[f"l{i + 1}"] for i in range(3)]
        _, points = _chain_geometry(list(system.q), m, lengths, origin)
        f = system.compile(sp.Matrix.hstack(*points).T, system.q)
        object.__setattr__(system, key, f)  # cache on the frozen instance
    return f(q)


def three_link_chain(
    masses: Sequence[float] = (1.0, 1.0, 1.0),
    lengths: Sequence[float] = (1.0, 1.0, 1.0),
    inertias: Sequence[float] | None = None,
    *,
    origin: str = "com",
) -> HolonomicSystem:
    """Three planar rigid links joined end to end by two pin joints, free in the plane, G = SE(2).

    Link :math:`i` has mass :math:`m_i`, length :math:`l_i` and inertia :math:`J_i` about its centre
    (default a slender rod, :math:`m_i l_i^2/12`). Group coordinates ``(x, y, theta)``: ``theta`` the
    orientation of the middle link and ``(x, y)`` the centre of mass of the chain (``origin="com"``, the
    translational part of the connection then vanishes) or the centre of the middle link
    (``origin="middle"``, the usual body frame for swimmers, with a translational connection). Shape:
    the joint angles ``alpha1 = theta_2 - theta_1`` and ``alpha2 = theta_3 - theta_2``.
    """
    ms = V.positive(masses, "masses")
    ls = V.positive(lengths, "lengths")
    if ms.shape != (3,) or ls.shape != (3,):
        raise ShapeError(f"Expected three `masses` and three `lengths`, got shapes {ms.shape}, {ls.shape}.")
    Js = ms * ls**2 / 12 if inertias is None else V.positive(inertias, "inertias")
    if Js.shape != (3,):
        raise ShapeError(f"Expected three `inertias`, got shape {Js.shape}.")
    if origin not in ("com", "middle"):
        raise InputError(f"Expected `origin` to be 'com' or 'middle', got {origin!r}.")
    m = sp.symbols("m1:4", positive=True)
    lsym = sp.symbols("l1:4", positive=True)
    J = sp.symbols("J1:4", positive=True)
    x, y, th, a1, a2 = sp.symbols("x y theta alpha1 alpha2", real=True)
    angles = [th - a1, th, th + a2]
    centres, _ = _chain_geometry([x, y, th, a1, a2], m, lsym, origin)
    q = [x, y, th, a1, a2]
    qd = {s: sp.Symbol(f"{s}_dot", real=True) for s in q}

    def tdiff(v):
        return v.applyfunc(lambda c: sum(sp.diff(c, s) * w for s, w in qd.items()))

    T = 0
    for i in range(3):
        v = tdiff(centres[i])
        T += m[i] * v.dot(v) / 2 + J[i] * tdiff(sp.Matrix([angles[i]]))[0] ** 2 / 2
    values = (
        {f"m{i + 1}": float(ms[i]) for i in range(3)}
        | {f"l{i + 1}": float(ls[i]) for i in range(3)}
        | {f"J{i + 1}": float(Js[i]) for i in range(3)}
    )
    return HolonomicSystem.from_lagrangian(
        expand_terms(T),
        "SE2",
        [a1, a2],
        parameters=values,
        shape_angles=(0, 1),
        name=f"three-link chain ({origin} frame)",
    )


def spacecraft_with_rotors(
    inertia: Sequence[float] = (3.0, 2.0, 1.0),
    axes: Any = ((1, 0, 0), (0, 1, 0)),
    rotor_inertias: Sequence[float] = (0.2, 0.2),
) -> HolonomicSystem:
    """A rigid spacecraft with internal rotors, G = SO(3), shape the rotor angles.

    With :math:`\\mathbb I` the locked inertia (rotors included), rotor :math:`k` spinning about the unit
    body axis :math:`a_k` with axial inertia :math:`J_k`:

    .. math::

        l = \\tfrac12\\,\\omega^T\\mathbb I\\,\\omega + \\sum_k J_k (a_k\\cdot\\omega)\\dot\\varphi_k
            + \\tfrac12\\sum_k J_k\\dot\\varphi_k^2,

    so :math:`A_{loc} = \\mathbb I^{-1}[J_1 a_1, J_2 a_2, \\dots]` is constant: :math:`dA = 0` and the
    curvature is the bracket term alone, :math:`-[A_1, A_2] = -A_1\\times A_2`.
    """
    I = V.positive(inertia, "inertia")
    if I.shape != (3,):
        raise ShapeError(f"Expected `inertia` to hold three principal moments, got shape {I.shape}.")
    ax = V.finite(axes, "axes")
    Jr = V.positive(rotor_inertias, "rotor_inertias")
    if ax.ndim != 2 or ax.shape[1] != 3 or ax.shape[0] != Jr.size:
        raise ShapeError(f"Expected `axes` of shape ({Jr.size}, 3), got {ax.shape}.")
    ax = ax / np.linalg.norm(ax, axis=1, keepdims=True)
    w = sp.symbols("omega_1 omega_2 omega_3", real=True)
    Isym = sp.symbols("I1:4", positive=True)
    n = Jr.size
    phis = sp.symbols(f"varphi1:{n + 1}", real=True)
    Jsym = sp.symbols(f"Jr1:{n + 1}", positive=True)
    l = sum(Ii * wi**2 for Ii, wi in zip(Isym, w)) / 2
    for k in range(n):
        pd = sp.Symbol(f"{phis[k]}_dot", real=True)
        a = [sp.nsimplify(c, rational=True) if abs(c - round(c)) < 1e-15 else c for c in ax[k]]
        l += Jsym[k] * sum(ai * wi for ai, wi in zip(a, w)) * pd + Jsym[k] * pd**2 / 2
    values = {f"I{i + 1}": float(I[i]) for i in range(3)} | {f"Jr{k + 1}": float(Jr[k]) for k in range(n)}
    return HolonomicSystem.from_reduced(
        l, "SO3", w, phis, parameters=values, shape_angles=tuple(range(n)), name=f"spacecraft with {n} rotors"
    )


#: The built-in holonomic examples by name (``geomech phase loop MODEL``): each a function of no arguments.
EXAMPLES: dict[str, Callable[[], HolonomicSystem]] = {
    # two pinned bodies, I1 = 1, I2 = 3; shape psi (an angle); G = S^1
    "two_bodies": lambda: two_pinned_bodies(1.0, 3.0),
    # the unit three-link chain in its centre-of-mass frame; shape alpha1, alpha2; SE(2)
    "three_link": lambda: three_link_chain(origin="com"),
    # the unit three-link chain in the middle link's frame; SE(2)
    "three_link_middle": lambda: three_link_chain(origin="middle"),
    # three unit point masses with gravity; shape rho, a2, b2; SE(2)
    "planar_3_body": lambda: planar_point_masses([1.0, 1.0, 1.0]),
    # a rigid body (3, 2, 1) with rotors (J = 0.2) on body axes 1 and 2; shape the rotor angles; SO(3)
    "spacecraft": lambda: spacecraft_with_rotors(),
}
