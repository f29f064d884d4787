"""A system the package has never seen, written here from its Lagrangian and constraints: a Chaplygin sleigh
whose knife edge is tilted by an angle beta from the body axis, carrying a point mass that slides along that
axis. It goes through the reduction and through solve() with the three Lagrangian methods, which must agree,
and at beta = 0 with the mass held still it must be the Chaplygin sleigh, whose reduced equations
dv/dt = a w^2, dw/dt = -M a v w / J_o are integrated here independently of geomech."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import geomech as gm
from geomech.integrators import BKMM, DiscreteLagrangeDAlembert, LagrangeDAlembert
from geomech.lie import SE2
from geomech.reduction import bkmm_reduction
from geomech.systems import NonholonomicSystem

VALUES = {"m": 2.0, "m2": 0.5, "J": 0.3, "a": 0.4}


def tilted_sleigh(beta: float) -> NonholonomicSystem:
    x, y, th, s = sp.symbols("x y theta s", real=True)
    xd, yd, thd, sd = sp.symbols("x_dot y_dot theta_dot s_dot", real=True)
    m, m2, J, a = sp.symbols("m m2 J a", positive=True)
    c, n = sp.cos(th), sp.sin(th)
    # body centre of mass a ahead of the contact point (x, y); the point mass at distance s along the body axis
    vcm = (xd - a * n * thd, yd + a * c * thd)
    vm2 = (xd + sd * c - s * n * thd, yd + sd * n + s * c * thd)
    L = m / 2 * (vcm[0] ** 2 + vcm[1] ** 2) + J / 2 * thd**2 + m2 / 2 * (vm2[0] ** 2 + vm2[1] ** 2)
    blade = th + beta
    constraint = -sp.sin(blade) * xd + sp.cos(blade) * yd
    return NonholonomicSystem.from_lagrangian(
        L,
        SE2(x, y, th),
        (s,),
        [constraint],
        parameters=VALUES,
        velocities=(xd, yd, thd, sd),
        shape_angles=(),
        name=f"tilted_sleigh_{beta:g}",
    )


@pytest.mark.parametrize("beta", [0.0, 0.3])
def test_three_methods_agree_and_energy_is_kept(beta):
    system = tilted_sleigh(beta)
    red = bkmm_reduction(system)
    assert red.m == 2  # the constraint leaves two group directions: along the blade, and the rotation
    start = dict(q0={"s": 0.2}, rdot0={"s": 0.3}, p0=[0.4, 0.2], t_final=2.0)
    a = gm.solve(system, LagrangeDAlembert(), saveat=21, **start)
    b = gm.solve(system, BKMM(), saveat=21, **start)
    c = gm.solve(system, DiscreteLagrangeDAlembert(), h=1e-3, saveat=21, **start)
    scale = np.abs(a.q).max()
    assert np.abs(a.q - b.q).max() < 1e-8 * scale
    # second order: the midpoint scheme at h = 1e-3 is within a few h^2 of the adaptive solution
    assert 1e-9 < np.abs(a.q - c.q).max() < 1e-4 * scale
    # free shape, no torque: the energy is conserved, and the constraint holds along the exact motion
    energy = a.energy
    assert np.abs(energy - energy[0]).max() < 1e-8 * energy[0]
    assert np.abs(b.constraint_residual).max() < 1e-10 * np.abs(b.qdot).max()
    # the motion is not trivial: the sleigh turns and the mass moves
    assert np.ptp(a.q[:, 2]) > 0.05 and np.ptp(a.r) > 0.05


def test_with_the_mass_held_still_it_is_the_chaplygin_sleigh():
    system = tilted_sleigh(0.0)
    s0 = 0.25
    v0, w0 = 0.7, 1.1
    sol = gm.solve(
        system,
        BKMM(),
        t_final=3.0,
        saveat=31,
        shapes={"s": str(s0)},
        q0={"s": s0},
        qdot0=[v0, 0.0, w0, 0.0],
    )
    m, m2, J, a = (VALUES[k] for k in ("m", "m2", "J", "a"))
    M = m + m2
    a_eff = (m * a + m2 * s0) / M
    J_o = J + m * a**2 + m2 * s0**2  # inertia about the contact point

    def reduced(_t, z):
        v, w = z
        return [a_eff * w**2, -M * a_eff * v * w / J_o]

    ref = solve_ivp(reduced, (0.0, 3.0), [v0, w0], t_eval=sol.t, rtol=1e-12, atol=1e-14, method="DOP853")
    theta = sol.q[:, 2]
    forward = np.cos(theta) * sol.qdot[:, 0] + np.sin(theta) * sol.qdot[:, 1]
    assert np.abs(forward - ref.y[0]).max() < 1e-8
    assert np.abs(sol.qdot[:, 2] - ref.y[1]).max() < 1e-8
    assert np.abs(ref.y[1][-1] - w0) > 0.1  # the rotation is damped into forward motion: a real test


def test_the_solution_is_a_dataset_with_the_systems_names():
    system = tilted_sleigh(0.3)
    sol = gm.solve(system, "bkmm", t_final=1.0, saveat=[0.0, 0.5, 1.0], q0={"s": 0.1}, p0=[0.2, 0.1])
    ds = sol.to_dataset()
    assert list(ds["coordinate"].values) == ["x", "y", "theta", "s"]
    assert ds["q"].dims == ("t", "coordinate") and ds["momentum"].shape == (3, 2)
    assert list(ds["shape"].values) == ["s"]
    assert ds.attrs["status"] == "success" and '"m2": 0.5' in ds.attrs["parameters"]
    assert sol.g.shape == (3, 3) and sol.r.shape == (3, 1)


def test_the_discrete_map_of_a_new_system_compiles_to_the_python_steps():
    """The compiled discrete Lagrange-d'Alembert map on this system, a constraint and a free shape under a torque
    of the state: the Python engine's steps, to round-off."""
    system = tilted_sleigh(0.3)
    run = dict(q0={"s": 0.2}, rdot0={"s": 0.3}, p0=[0.4, 0.2], tau={"s": "-0.5*s"}, t_final=2.0, h=0.01, saveat=21)
    a = gm.solve(system, DiscreteLagrangeDAlembert(), backend="python", **run)
    b = gm.solve(system, DiscreteLagrangeDAlembert(), **run)
    assert a.stats["backend"] == "python" and b.stats["backend"] == "numba"
    for x, y in [(a.q, b.q), (a.qdot, b.qdot), (a.work, b.work), (a.constraint_residual, b.constraint_residual)]:
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-11 * max(1.0, float(np.abs(x).max())))
    assert abs(a.work[-1]) > 1e-3


# -- the same system as a user's model file, through the gait analysis and the command line ----------------
MODEL = """
from geomech.lie import SE2
from geomech.systems import NonholonomicSystem


def build(beta=0.3, m=2.0, m2=0.5, J=0.3, a=0.4):
    L = (
        "m/2*((x_dot - a*sin(theta)*theta_dot)**2 + (y_dot + a*cos(theta)*theta_dot)**2) + J/2*theta_dot**2"
        " + m2/2*((x_dot + s_dot*cos(theta) - s*sin(theta)*theta_dot)**2"
        " + (y_dot + s_dot*sin(theta) + s*cos(theta)*theta_dot)**2)"
    )
    blade = "-sin(theta + beta)*x_dot + cos(theta + beta)*y_dot"
    return NonholonomicSystem.from_lagrangian(
        L, SE2("x", "y", "theta"), ["s"], [blade], parameters=dict(beta=beta, m=m, m2=m2, J=J, a=a),
        shape_angles=(), name="tilted sleigh",
    )
"""


@pytest.mark.slow  # the derivation and gait of a new model through the command line, at beta = 0 and 0.3
@pytest.mark.parametrize("beta", [0.0, 0.3])
def test_a_gait_of_the_model_file_from_the_command_line(beta, tmp_path, capsys):
    # The model file writes the sleigh as text (parsed by the whitelist), the test above with sympy: the two
    # descriptions, the gait analysis (momentum equation along the gait, reconstruction on the group) and the
    # full constrained simulation with the shape prescribed must all tell the same motion.
    import json

    from geomech.analysis import analyse_gait
    from geomech.cli.main import main
    from geomech.integrators import initial_state
    from geomech.systems.models import load_model

    path = tmp_path / "sleigh.py"
    path.write_text(MODEL)
    loop, T, p0 = "s=0.3*sin(2*pi*t/T)", 2.0, [0.4, 0.2]
    code = main(
        [
            "gait",
            "--model",
            str(path),
            "--shape-loop",
            loop,
            "--period",
            "2",
            "--p0",
            "0.4,0.2",
            "--param",
            f"beta={beta}",
            "--json",
        ]
    )
    out = capsys.readouterr()
    assert code == 0, out.err
    cli = json.loads(out.out)["summary"]["net_displacement"]
    # the file's system in-process: the same analysis; p0 is in its reduction's basis, which scales with how beta
    # is given (a symbol there, a number here), so the other description starts from the velocity p0 means
    mine = load_model(str(path), {"beta": beta})
    api = analyse_gait(mine, {"s": "0.3*sin(2*pi*t/T)"}, period=T, p0=p0)
    assert cli == pytest.approx(dict(zip(["x", "y", "theta"], api.net_displacement)), abs=1e-10)
    gait = {"s": "0.3*sin(pi*t)"}
    _, qd0 = initial_state(mine, gait, p0=p0)
    full = gm.solve(
        tilted_sleigh(beta), LagrangeDAlembert(), t_final=T, saveat=2, shapes=gait, qdot0=qd0, rtol=1e-12, atol=1e-12
    )
    np.testing.assert_allclose(full.g[-1], [cli["x"], cli["y"], cli["theta"]], atol=1e-8)
    assert abs(cli["theta"]) > 0.05  # it moved
    # the same file as MODEL, simulated: the shape free, from rest in s
    code = main(["simulate", str(path), "--p0", "0.4,0.2", "--t-final", "1", "--param", f"beta={beta}", "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    final = json.loads(out.out)["summary"]["final_configuration"]
    _, qd0 = initial_state(mine, p0=p0)
    free = gm.solve(tilted_sleigh(beta), LagrangeDAlembert(), t_final=1.0, saveat=2, qdot0=qd0, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([final[k] for k in ("x", "y", "theta", "s")], free.q[-1], atol=1e-8)
    code = main(["derive", "--model", str(path), "--section", "bkmm", "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert any("momentum" in key for key in json.loads(out.out)["bkmm"]["text"])
    assert main(["gait", str(path), "--model", str(path), "--shape-loop", loop, "--period", "2"]) == 2
    assert "not both" in capsys.readouterr().err
