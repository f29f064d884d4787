"""A user's model for benchmarks/derivation.py: a Chaplygin sleigh whose blade is tilted by ``beta`` from the body
axis, carrying a mass ``m2`` that slides on a track parallel to the axis at a lateral offset ``b``, held by a spring
(stiffness ``k``, rest position ``s0``). One shape variable ``s``, eight parameters. The tilt enters the constraint
as the number ``beta`` (a rational); with ``--param symbolic_tilt=1`` it is a symbol of the formulas.

    geomech derive benchmarks/models/tilted_sleigh.py --section bkmm [--param symbolic_tilt=1]
"""

import sympy as sp

from geomech.lie import SE2
from geomech.systems.nonholonomic import NonholonomicSystem


def build(m=2.0, J=0.3, a=0.4, m2=0.5, b=0.1, k=1.5, s0=0.2, beta=0.3, symbolic_tilt=0):
    x, y, th, s = sp.symbols("x y theta s", real=True)
    xd, yd, thd, sd = sp.symbols("x_dot y_dot theta_dot s_dot", real=True)
    M, I, A, M2, B, K, S0 = sp.symbols("m J a m2 b k s0", positive=True)
    c, n = sp.cos(th), sp.sin(th)
    # the contact point at (x, y); the body's centre of mass a ahead of it; the slider at (s, b) in the body frame
    vcm = (xd - A * n * thd, yd + A * c * thd)
    vm2 = (xd + sd * c - (s * n + B * c) * thd, yd + sd * n + (s * c - B * n) * thd)
    L = M / 2 * (vcm[0] ** 2 + vcm[1] ** 2) + I / 2 * thd**2 + M2 / 2 * (vm2[0] ** 2 + vm2[1] ** 2)
    L -= K / 2 * (s - S0) ** 2
    parameters = {"m": m, "J": J, "a": a, "m2": m2, "b": b, "k": k, "s0": s0}
    if symbolic_tilt:
        tilt = sp.Symbol("beta", real=True)
        parameters["beta"] = beta
    else:
        tilt = sp.nsimplify(beta)
    blade = th + tilt
    constraint = -sp.sin(blade) * xd + sp.cos(blade) * yd
    return NonholonomicSystem.from_lagrangian(
        L,
        SE2(x, y, th),
        (s,),
        [constraint],
        parameters=parameters,
        velocities=(xd, yd, thd, sd),
        shape_angles=(),
        name="tilted_sleigh",
    )
