"""``geomech derive`` and ``geomech simulate`` (registered here as the lead registers them in main)."""

import json
import textwrap

import numpy as np
import pytest
from cli_helpers import run as _run

from geomech.cli.main import cli
from geomech.cli.nonholonomic import derive_cmd, simulate_cmd
from geomech.integrators import LagrangeDAlembert, solve
from geomech.systems.nonholonomic_examples import snakeboard

for _cmd in (derive_cmd, simulate_cmd):
    if _cmd.name not in cli.commands:
        cli.add_command(_cmd)

SNAKE_ARGS = [
    "--param",
    "m=1",
    "--param",
    "r=0.5",
    "--param",
    "J=0.18",
    "--param",
    "J0=0.05",
    "--param",
    "J1=0.01",
    "--shape",
    "psi=sin(2*pi*t)",
    "--shape",
    "phi=0.5*sin(2*pi*t)",
    "--t-final",
    "1",
]


def test_simulate_snakeboard_json_matches_the_library(capsys, tmp_path):
    code, out, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--json", "--out", str(tmp_path))
    assert code == 0, err
    data = json.loads(out)
    ref = solve(
        snakeboard(m=1, r=0.5, J=0.18, J0=0.05, J1=0.01),
        LagrangeDAlembert(),
        t_final=1.0,
        shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"},
    )
    for k in ("x", "y", "theta"):
        assert data["summary"]["final_configuration"][k] == pytest.approx(ref.final()[k], abs=1e-9)
    assert data["nonholonomic_momentum"][0] == pytest.approx(ref.p[-1, 0], abs=1e-9)
    assert data["summary"]["constraint_residual_max"] < 1e-8
    assert data["work_by_shape_inputs"] == pytest.approx(ref.work[-1], abs=1e-9)
    assert abs(data["summary"]["energy_change_minus_work"]) < 1e-8
    header = (tmp_path / "trajectory.csv").read_text().splitlines()[0]
    assert header.startswith("t,x,y,theta") and (tmp_path / "path.png").stat().st_size > 1000
    assert json.loads((tmp_path / "summary.json").read_text())["system"] == "snakeboard"


def test_simulate_text_and_other_methods(capsys):
    code, out, _ = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "discrete", "--h", "0.01")
    assert code == 0 and "final configuration: x = " in out and "work by shape inputs" in out
    code, out, _ = _run(
        capsys,
        "simulate",
        "chaplygin_sleigh",
        "--param",
        "m=1",
        "--param",
        "I_c=0.5",
        "--param",
        "a=0.3",
        "--method",
        "reduced",
        "--json",
    )
    assert code == 0 and json.loads(out)["work_by_shape_inputs"] == 0.0
    # the BKMM equations by Taylor's method: the DOP853 run's final configuration, its events
    finals = {}
    for method in ("reduced", "reduced-taylor"):
        code, out, err = _run(
            capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", method, "--event", "back=psi", "--json"
        )
        assert code == 0, err
        data = json.loads(out)
        finals[method] = np.array(list(data["summary"]["final_configuration"].values()))
    assert "reduced (taylor)" in json.dumps(data)
    np.testing.assert_allclose(finals["reduced-taylor"], finals["reduced"], rtol=0, atol=1e-8)


def test_simulate_by_hamiltons_equations_and_the_group_discretisation(capsys):
    """The Hamiltonian forms drive the shapes by torques, and agree with the Lagrange-d'Alembert run."""
    args = [*SNAKE_ARGS[:10], "--tau", "psi=-psi", "--tau", "phi=0.2*cos(t) - 2*phi", "--t-final", "1", "--json"]
    finals = {}
    for method in ("full", "bates-sniatycki", "full-tensor", "almost-poisson"):
        code, out, err = _run(capsys, "simulate", "snakeboard", *args, "--p0", "0.5", "--method", method)
        assert code == 0, err
        data = json.loads(out)
        finals[method] = np.array(list(data["summary"]["final_configuration"].values()))
        assert abs(data["summary"]["energy_change_minus_work"]) < 1e-8 and data["work_by_shape_inputs"] != 0
    for method in ("bates-sniatycki", "full-tensor", "almost-poisson"):
        np.testing.assert_allclose(finals[method], finals["full"], atol=1e-8)
    code, out, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "discrete-group", "--h", "0.01")
    assert code == 0 and "discrete Lagrange-d'Alembert (group, h = 0.01)" in out
    code, _, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "bates-sniatycki")
    assert code == 2 and err.count("\n") == 1 and "prescribed gait" in err
    code, _, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "vm")
    assert code == 2 and "bates-sniatycki" in err


def test_derive_snakeboard_json_and_latex(capsys):
    code, out, err = _run(capsys, "derive", "snakeboard_bkmm", "--json")
    assert code == 0, err
    data = json.loads(out)
    sections = ["lagrange_dalembert", "bkmm", "almost_poisson", "poisson_reduction"]
    assert list(data) == ["schema", "command", "summary", "definition", *sections]
    assert data["summary"] == {"system": "snakeboard_bkmm", "sections": sections}
    assert "2*J0*phi_dot*psi_dot*cos(phi)**2" in data["bkmm"]["text"]["momentum equation p' (eq. 1.2)"][0][0]
    assert data["almost_poisson"]["text"]["Jacobi identity holds"] == "False"
    assert data["definition"]["invariance"]["ok"]
    code, out, _ = _run(capsys, "derive", "snakeboard_bkmm", "--latex", "--section", "bkmm")
    assert code == 0 and r"\dot{\phi}" in out and "== bkmm ==" in out


def test_a_derivation_runs_without_the_numeric_stack(tmp_path):
    """``geomech derive`` is symbolic: a fresh process derives and prints without importing scipy or numba (their
    import took longer than the derivation of a small system), through the command's own entry point."""
    import os
    import subprocess
    import sys

    code = (
        "import sys; sys.argv = ['geomech', 'derive', 'chaplygin_sleigh']; "
        "import _geomech_cli; rc = _geomech_cli.main(); "
        "print([m for m in ('scipy', 'numba', 'matplotlib', 'xarray') if m in sys.modules], rc)"
    )
    env = {**os.environ, "GEOMECH_CACHE_DIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "== bkmm ==" in done.stdout and done.stdout.strip().splitlines()[-1] == "[] 0"


MODEL = """
from geomech.lie import SE2
from geomech.systems.nonholonomic import NonholonomicSystem

def build(m=1.0, I=0.5, a=0.3):
    return NonholonomicSystem.from_lagrangian(
        "m/2*((x_dot - a*sin(theta)*theta_dot)**2 + (y_dot + a*cos(theta)*theta_dot)**2) + I/2*theta_dot**2",
        SE2("x", "y", "theta"), (), ["-sin(theta)*x_dot + cos(theta)*y_dot"],
        parameters={"m": m, "I": I, "a": a}, name="my_sleigh")
"""


def test_derive_and_simulate_a_model_file(capsys, tmp_path):
    f = tmp_path / "sleigh.py"
    f.write_text(MODEL)
    code, out, err = _run(capsys, "derive", "--model", str(f), "--json", "--section", "bkmm")
    assert code == 0, err
    assert json.loads(out)["bkmm"]["text"]["locked inertia I(r)"] == [["m", "0"], ["0", "I + a**2*m"]]
    code, out, err = _run(capsys, "simulate", "--model", str(f), "--param", "m=2", "--json", "--method", "reduced")
    assert code == 0, err
    assert np.isfinite(json.loads(out)["energy_final"])
    g = tmp_path / "plain.py"
    g.write_text(
        textwrap.dedent("""
        from geomech.systems.nonholonomic_examples import rolling_disk
        system = rolling_disk(m=1, R=0.5, I=0.2, J=0.1)
    """)
    )
    code, out, err = _run(capsys, "derive", "--model", str(g), "--section", "system")
    assert code == 0 and "rolling_disk" in out


@pytest.mark.parametrize(
    "body, match",
    [
        (
            """L = "m/2*(x_dot**2 + y_dot**2) + I/2*theta_dot**2 - m*g*y"\n"""
            """system = NonholonomicSystem.from_lagrangian(L, SE2(), (), ["-sin(theta)*x_dot + cos(theta)*y_dot"])""",
            "not invariant under SE(2)",
        ),
        (
            """system = NonholonomicSystem.from_lagrangian("m/2*(x_dot**2 + y_dot**2) + I/2*theta_dot**2", SE2(), (),"""
            """ ["x_dot**2 - y_dot"])""",
            "not linear homogeneous",
        ),
        (
            """system = NonholonomicSystem.from_lagrangian("m/2*(x_dot**2 + y_dot**2)", SE2("x", "y"), (), [])""",
            "Expected 3 coordinate names for SE(2)",
        ),
        ("""system = 3""", "expected `system` to be a NonholonomicSystem"),
        ("""raise RuntimeError("boom")""", "RuntimeError: boom"),
    ],
)
def test_bad_models_give_one_line_and_status_2(capsys, tmp_path, body, match):
    f = tmp_path / "bad.py"
    header = "from geomech.lie import SE2\nfrom geomech.systems.nonholonomic import NonholonomicSystem\n"
    f.write_text(header + body + "\n")
    code, out, err = _run(capsys, "derive", "--model", str(f))
    assert code == 2 and match in err and len(err.strip().splitlines()) == 1


def test_bad_command_lines(capsys):
    code, _, err = _run(capsys, "derive", "unicycle")
    assert code == 2 and "Unknown example" in err
    code, _, err = _run(capsys, "simulate", "snakeboard", "--param", "m=1", "--shape", "psi")
    assert code == 2 and "NAME=VALUE" in err
    code, _, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS[:10], "--shape", "rho=t")
    assert code == 2 and "not shape variables" in err and len(err.strip().splitlines()) == 1
    code, _, err = _run(capsys, "derive")
    assert code == 2 and "built-in name" in err


def test_simulate_with_initial_momentum(capsys):
    base = ("simulate", "chaplygin_sleigh", "--param", "m=1", "--param", "a=0.3", "--param", "I_c=0.2")
    code, out, _ = _run(capsys, *base, "--p0", "1,0.5", "--t-final", "5", "--json")
    assert code == 0
    summary = json.loads(out)
    assert (
        summary["summary"]["constraint_residual_max"] < 1e-8
        and abs(summary["summary"]["final_configuration"]["x"]) > 0.5
    )
    # the sleigh's known end state: the turning dies out and all the energy goes into forward motion,
    # p1 = m v -> sqrt(2 m E); here E = 0.931 (v0 = 1, omega0 = 0.5 / (I_c + m a^2))
    assert abs(summary["nonholonomic_momentum"][0] - (2 * summary["energy_initial"]) ** 0.5) < 1e-3
    code, _, err = _run(capsys, *base, "--p0", "1")
    assert code == 2 and "Expected `--p0` to have 2 entries" in err and err.count("\n") == 1
    # an event by Hamilton's equations (scipy's DOP853 on z = (q, pt)) and by the compiled BKMM equations
    times = {}
    for method in ("almost-poisson", "reduced"):
        code, out, err = _run(
            capsys,
            *base,
            "--p0",
            "1,0.5",
            "--t-final",
            "5",
            "--method",
            method,
            "--event",
            "turn=theta - 1/2",
            "--json",
        )
        assert code == 0, err
        times[method] = [e["t"] for e in json.loads(out)["events"]["turn"]]
    assert len(times["reduced"]) >= 1
    np.testing.assert_allclose(times["almost-poisson"], times["reduced"], rtol=0, atol=1e-8)


def test_derive_latex_prints_the_system_as_latex(capsys):
    code, out, err = _run(capsys, "derive", "snakeboard_bkmm", "--latex", "--section", "system")
    assert code == 0, err
    lagrangian = next(line for line in out.splitlines() if line.startswith("L = "))
    assert r"\dot{\theta}" in lagrangian and "theta_dot" not in lagrangian
    constraints = next(line for line in out.splitlines() if line.startswith(r"\text{constraints: }"))
    assert constraints.count("= 0") == 2 and r"\cos{\left(\phi \right)}" in constraints
    code, out, _ = _run(capsys, "derive", "snakeboard_bkmm", "--section", "system")
    assert code == 0 and "lagrangian: " in out and "theta_dot" in out and r"\dot" not in out


def test_derive_json_exports_the_short_forms(capsys):
    """Multipliers on D and the projected (multiplier-free) equations instead of the expanded forms valid off D;
    Jacobiators by their indices; the system in LaTeX too."""
    code, out, err = _run(capsys, "derive", "chaplygin_sleigh", "--json")
    assert code == 0, err
    data = json.loads(out)
    lda = data["lagrange_dalembert"]
    assert set(lda["text"]) >= {
        "multipliers lambda on D",
        "projected equations X^T(M qddot - f - B tau) (= 0)",
        "basis of D X(q) (columns)",
    }
    assert "multipliers lambda" not in lda["text"] and "accelerations qddot" not in lda["text"]
    assert list(lda["text"]["multipliers lambda on D"]) == ["lambda1(q, rdot, p, tau)"]
    assert r"\lambda_{1} = " in lda["latex"]["multipliers lambda on D"]
    jac = data["almost_poisson"]["text"]["Jacobiators Jac(q^i, pt_a, pt_b) = (Z K_ab)^i and Jac(pt_a, pt_b, pt_c)"]
    assert list(jac) == ["Jac(x, pt1, pt2)", "Jac(y, pt1, pt2)", "Jac(theta, pt1, pt2)"]
    assert data["definition"]["latex"]["constraints"] == [
        r"- \dot{x} \sin{\left(\theta \right)} + \dot{y} "
        r"\cos{\left(\theta \right)}"
    ]


def test_derive_text_has_no_python_reprs_and_fits_a_terminal(capsys):
    code, out, err = _run(capsys, "derive", "snakeboard_bkmm")
    assert code == 0, err
    lines = out.splitlines()
    assert max(len(line) for line in lines) <= 120
    assert not any("['" in line or "[[" in line for line in lines)
    assert "shape: psi, phi" in lines
    # a matrix row by row, its size said
    assert any(line.startswith("locked inertia I(r) = (") for line in lines)


def test_simulate_lists_the_events_of_a_gait_and_of_a_hamiltonian(capsys):
    """--event: the zeros of formulas in the state, with the reduced method of a model (the gait back at its start
    every period) and with dop853 on a Hamiltonian (the free body's m2 = 0, as the library finds them)."""
    code, out, err = _run(
        capsys, "simulate", "snakeboard", *SNAKE_ARGS[:-2], "--method", "reduced", "--t-final", "2.25",
        "--event", "back=psi", "--json",
    )  # fmt: skip
    assert code == 0, err
    back = json.loads(out)["events"]["back"]
    # psi = sin(2 pi t): zero at every half period (t = 0 itself is the start, not a crossing)
    np.testing.assert_allclose([e["t"] for e in back], [0.5, 1.0, 1.5, 2.0], atol=1e-9)
    assert set(back[0]["state"]) >= {"x", "y", "theta", "psi", "phi", "psi_dot"}
    code, out, err = _run(
        capsys, "simulate", "--hamiltonian", "m1**2/6 + m2**2/4 + m3**2/2", "--momentum", "1", "0.3", "0.2",
        "--method", "dop853", "--t-final", "25", "--event", "flip=m2", "--json",
    )  # fmt: skip
    assert code == 0, err
    flips = json.loads(out)["events"]["flip"]
    assert len(flips) >= 2 and all(abs(e["state"]["m2"]) < 1e-10 for e in flips)
    code, out, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "full", "--event", "back=psi")
    assert code == 0, err  # the Lagrange-d'Alembert equations, compiled: the same zeros of the gait
    code, out, err = _run(capsys, "simulate", "snakeboard", *SNAKE_ARGS, "--method", "discrete", "--event", "back=psi")
    assert code == 2 and "discrete Lagrange-d'Alembert map has none" in err and len(err.strip().splitlines()) == 1
