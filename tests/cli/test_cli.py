"""The command line: JSON output a script can read, and one-line errors with exit status 2."""

import json
import subprocess
import sys

import numpy as np
import pytest
from cli_helpers import run

from geomech.cli.main import main


def test_help(capsys):
    code, out, _ = run(capsys, "--help")
    assert code == 0 and "rigid-body" in out and "reduce" in out


def test_rigid_body_json_summary(capsys):
    code, out, err = run(
        capsys, "rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--t-final", "50", "--json"
    )
    assert code == 0, err
    s = json.loads(out)
    head = s["summary"]
    np.testing.assert_allclose(s["m_final"], s["m_exact_final"], atol=1e-9)
    assert head["m_error_max"] < 1e-9
    assert head["drift"]["energy_relative"] < 1e-10
    assert head["drift"]["casimir_relative"] < 1e-13
    assert s["period_quadrature"]["relative_difference"] < 1e-9
    assert head["family"] == "major"
    np.testing.assert_allclose(np.linalg.norm(s["m_exact_final"]), np.linalg.norm([1, 0.3, 0.2]))
    times = s["chart_switch_times"]
    assert len(times) == s["chart_switches"] and times == sorted(times) and all(0 < t < 50 for t in times)


def test_rigid_body_tensor_and_out_dir(capsys, tmp_path):
    code, out, err = run(
        capsys,
        "rigid-body",
        "--inertia",
        "3,0.1,0,0.1,2.5,0,0,0,1.5",
        "--momentum",
        "1,0.3,0.2",
        "--t-final",
        "5",
        "--samples",
        "51",
        "--out",
        str(tmp_path),
    )
    assert code == 0, err
    assert "eq. (11)" in out
    assert json.loads((tmp_path / "rigid_body.json").read_text())["t_final"] == 5.0
    assert (tmp_path / "rigid_body_momentum.png").stat().st_size > 10_000
    # the trajectory itself: m(t) on the 51 times, ending where the summary says, |m| conserved
    xr = pytest.importorskip("xarray")
    summary = json.loads((tmp_path / "rigid_body.json").read_text())
    with xr.open_dataset(tmp_path / "rigid_body.nc") as ds:
        names = [v for v in ds.data_vars if ds[v].sizes.get("t") == 51]
        assert ds.sizes["t"] == 51 and names
        m = np.stack([ds[k].values for k in ("m1", "m2", "m3")], -1) if "m1" in ds else ds["m"].values
    np.testing.assert_allclose(m[-1], summary["m_final"], rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(m, axis=-1), np.linalg.norm([1, 0.3, 0.2]), rtol=1e-10)


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--inertia", "3", "-2", "1", "--momentum", "1", "0.3", "0.2"], "positive"),
        (["--inertia", "5", "2", "1", "--momentum", "1", "0.3", "0.2"], "triangle inequality"),
        (["--inertia", "3", "2", "1", "--momentum", "0", "0", "0"], "nonzero"),
        (["--inertia", "3", "2", "nan", "--momentum", "1", "0.3", "0.2"], "finite"),
        (["--inertia", "3", "2", "1", "--momentum", "1", "inf", "0.2"], "finite"),
        (["--inertia", "3", "2", "--momentum", "1", "0.3", "0.2"], "expected 3 or 9 numbers, got 2"),
        (["--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "0.1"], "expected 3 numbers, got 4"),
        (["--inertia", "3", "2", "1"], "Missing option '--momentum'"),
        (["--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--t-final", "-1"], "positive"),
    ],
)
def test_bad_input_is_one_line_and_status_2(capsys, args, needle):
    code, out, err = run(capsys, "rigid-body", *args)
    assert code == 2
    assert needle in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_reduce_prints_the_reduced_hamiltonian(capsys):
    code, out, err = run(
        capsys,
        "reduce",
        "--hamiltonian",
        "m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)",
        "--param",
        "I1=3",
        "--param",
        "I2=2",
        "--param",
        "I3=1",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["hyperregularity"]["status"] == "yes"
    import sympy as sp

    l, L, G = sp.symbols("l L G")
    h = sp.sympify(s["summary"]["reduced_hamiltonian"], locals={"l": l, "L": L, "G": G})
    eq10 = (sp.sin(l) ** 2 / 3 + sp.cos(l) ** 2 / 2) * (G**2 - L**2) / 2 + L**2 / 2
    assert sp.simplify(h - eq10) == 0
    code, _, err = run(capsys, "reduce", "--hamiltonian", "m1**2 + a*m2")
    assert code == 2 and "'a'" in err and err.count("\n") == 1


def test_console_script_exit_status():
    proc = subprocess.run(
        [sys.executable, "-m", "geomech", "rigid-body", "--inertia", "1", "1", "--momentum", "1", "0", "0"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2 and proc.stderr.startswith("geomech: error:") and "Traceback" not in proc.stderr


def test_options_alike_everywhere_vectors_and_repeats(capsys):
    # a vector option takes spaces, commas or one quoted word; a single-valued option given twice is an error
    from geomech.cli._args import gather_vectors
    from geomech.cli.main import cli

    argv = ["simulate", "geared_body", "--p0", "0.1", "-0.2", "--t-final", "1"]
    assert gather_vectors(argv, cli) == ["simulate", "geared_body", "--p0", "0.1,-0.2", "--t-final", "1"]
    outs = []
    for mu in (["0", "0", "0.1"], ["0,0,0.1"], ["0 0 0.1"]):
        code = main(
            [
                "phase",
                "loop",
                "spacecraft",
                "--shape",
                "varphi1=0.2*cos(2*pi*t/T)",
                "--shape",
                "varphi2=0.2*sin(2*pi*t/T)",
                "--mu",
                *mu,
                "--json",
            ]
        )
        out, err = capsys.readouterr()
        assert code == 0, err
        outs.append(out)
    assert len(set(outs)) == 1
    code = main(["phase", "two-bodies", "--mu", "-2.5", "--period", "5.5", "--period=6", "--json"])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "'--period' is given twice" in err


def test_reduce_keeps_parameters_symbolic_when_asked(capsys):
    # the free rigid body with I1, I2 left symbolic and I3 = 1 gives eq. (10) of the seed (Andoyer's Hamiltonian)
    import sympy as sp

    from geomech.reduction import andoyer_hamiltonian

    H = "m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)"
    code, out, err = run(capsys, "reduce", "--hamiltonian", H, "--param", "I3=1", "--symbolic", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert s["symbolic_parameters"] == ["I1", "I2"] and s["summary"]["hyperregularity"]["status"] == "unknown"
    got = sp.sympify(s["summary"]["reduced_hamiltonian"])
    want = andoyer_hamiltonian().subs(sp.Symbol("I3", positive=True), 1)
    names = {x.name: x for x in want.free_symbols}
    got = got.xreplace({x: names.get(x.name, x) for x in got.free_symbols})
    assert sp.simplify(got - want) == 0
    code, _, err = run(capsys, "reduce", "--hamiltonian", H, "--param", "I3=1")
    assert code == 2 and "--param I1=VALUE" in err


def test_simulate_ones_own_hamiltonian_against_the_exact_solution(capsys, tmp_path):
    # H of the free body I = (3, 2, 1) given as a formula with a parameter; the atlas (default) and a fixed-step
    # method both land on the Jacobi-elliptic solution of the rigid body
    from geomech import RigidBody

    exact = RigidBody([3.0, 2.0, 1.0]).exact_solution([1.0, 0.3, 0.2]).momentum(10.0)
    H = ["--hamiltonian", "m1**2/(2*a) + m2**2/4 + m3**2/2", "--param", "a=3", "--momentum", "1", "0.3", "0.2"]
    code, out, err = run(capsys, "simulate", *H, "--t-final", "10", "--json")
    assert code == 0, err
    np.testing.assert_allclose(json.loads(out)["summary"]["m_final"], exact, atol=1e-8)
    args = ["simulate", *H, "--t-final", "10", "--method", "gauss_legendre_3", "--h", "0.01", "--attitude"]
    code, out, err = run(capsys, *args, "--json", "--out", str(tmp_path))
    assert code == 0, err
    s = json.loads(out)
    np.testing.assert_allclose(s["summary"]["m_final"], exact, atol=1e-9)
    assert s["summary"]["drift"]["spatial_momentum"] < 1e-12 and (tmp_path / "trajectory.nc").is_file()
    code, _, err = run(capsys, "simulate", *H, "--method", "bkmm")
    assert code == 2 and err.count("\n") == 1 and "implicit_midpoint" in err  # names the methods that fit
    code, _, err = run(capsys, "simulate", "snakeboard", *H)
    assert code == 2 and "not both" in err
