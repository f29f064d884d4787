"""``geomech gait``: summary, JSON, files, and one-line errors with exit status 2."""

import json

import click
import numpy as np
import pytest

from geomech.cli.gait import gait_cmd
from geomech.cli.main import cli, main

BOARD = ["snakeboard_bkmm", "--param", "m=1", "--param", "r=1", "--param", "J0=0.3", "--param", "J1=0.1"]
DRIVE = ["--shape-loop", "psi=sin(2*pi*t/T)", "--shape-loop", "phi=0.4*sin(2*pi*t/T)"]


def run(capsys, *args):
    # a no-op once `gait` is registered in cli/main.py
    if "gait" not in cli.commands:
        cli.add_command(gait_cmd)
    code = main(["gait", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_json_summary_matches_the_closed_form_momentum_gain(capsys):
    from scipy.special import jv

    code, out, err = run(capsys, *BOARD, *DRIVE, "--period", "1.5", "--periods", "2", "--p0", "-0.25", "--json")
    assert code == 0, err
    s = json.loads(out)
    want = 4 * np.pi * 0.3 * 1.0 * (2 * np.pi / 1.5) * jv(1, 0.4)  # Bessel closed form, see the analysis tests
    assert np.allclose(np.array(s["summary"]["momentum_change_per_period"])[:, 0], want, rtol=1e-9)
    assert s["p0"] == [-0.25] and s["periods"] == 2 and len(s["displacement_per_period"]) == 2
    assert set(s["summary"]["net_displacement"]) == {"x", "y", "theta"}
    assert "not a geometric/dynamic phase decomposition" in s["note"]


def test_text_and_files(capsys, tmp_path):
    xr = pytest.importorskip("xarray")
    code, out, err = run(
        capsys,
        *BOARD,
        "--shape-loop",
        "psi=sin(4*pi*t/T)",
        "--shape-loop",
        "phi=0.4*sin(2*pi*t/T)",
        "--period",
        "1",
        "--samples",
        "41",
        "--g0",
        "theta=0.5",
        "--out",
        str(tmp_path),
    )
    assert code == 0, err
    assert "net displacement" in out and "connection term" in out and "momentum term" in out
    for f in (
        "gait_path.png",
        "gait_momentum.png",
        "curvature.png",
        "connection_omega.png",
        "curvature_v_x.png",
        "curvature_v_y.png",
        "gait.nc",
        "gait.json",
    ):
        assert (tmp_path / f).stat().st_size > 0
    ds = xr.load_dataset(tmp_path / "gait.nc")
    assert ds["g"].shape == (41, 3) and abs(float(ds["g"][0, 2]) - 0.5) < 1e-15
    s = json.loads((tmp_path / "gait.json").read_text())
    assert abs(s["summary"]["net_displacement"]["theta"]) > 0.2  # the rotate gait turns the board


def test_model_file(capsys, tmp_path):
    f = tmp_path / "car.py"
    f.write_text(
        "import sympy as sp\n"
        "from geomech.lie import SE2\nfrom geomech.systems.nonholonomic import NonholonomicSystem\n"
        "x, y, th, psi, phi = sp.symbols('x y theta psi phi', real=True)\n"
        "xd, yd, thd, psid, phid = sp.symbols('x_dot y_dot theta_dot psi_dot phi_dot', real=True)\n"
        "L = (xd**2 + yd**2)/2 + thd**2/5 + psid**2/10 + phid**2/10\n"
        "cons = [sp.cos(th)*xd + sp.sin(th)*yd - psid/2, -sp.sin(th)*xd + sp.cos(th)*yd, thd - sp.tan(phi)*psid/2]\n"
        "system = NonholonomicSystem.from_lagrangian(L, SE2(x, y, th), (psi, phi), cons, name='car')\n"
    )
    code, out, err = run(
        capsys,
        str(f),
        "--shape-loop",
        "psi=2*sin(2*pi*t)",
        "--shape-loop",
        "phi=0.3*cos(2*pi*t)",
        "--period",
        "1",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["momentum_change_per_period"] == [[]]
    assert s["momentum_alone"] == {"x": 0.0, "y": 0.0, "theta": 0.0}
    assert s["summary"]["net_displacement"] == pytest.approx(s["connection_alone"], abs=1e-12)


@pytest.mark.parametrize(
    "args, words",
    [
        (["--shape-loop", "psi=t", "--shape-loop", "phi=0.4*sin(2*pi*t)", "--period", "1"], "closed"),
        (["--shape-loop", "psi=sin(2*pi*t)", "--period", "1"], "one `--shape-loop` for each"),
        (
            ["--shape-loop", "psi=sin(2*pi*t)", "--shape-loop", "beta=sin(2*pi*t)", "--period", "1"],
            "not a shape variable",
        ),
        (["--shape-loop", "psi=sin(2*pi*t)", "--shape-loop", "phi=pi/2*cos(2*pi*t)", "--period", "1"], "singular"),
        (
            ["--shape-loop", "psi=sin(2*pi*t)", "--shape-loop", "phi=0.1*cos(2*pi*t)", "--period", "1", "--p0", "1,2"],
            "p0",
        ),
        (["--shape-loop", "psi=sin(2*pi*t)", "--shape-loop", "phi=0.1*cos(2*pi*t)", "--period", "-1"], "period"),
    ],
)
def test_errors_are_one_line_and_status_2(capsys, args, words):
    code, out, err = run(capsys, *BOARD, *args)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("geomech: error:") and words in err


def test_unknown_model_and_missing_parameters(capsys):
    code, _, err = run(capsys, "no_such_board", *DRIVE, "--period", "1")
    assert code == 2 and "Unknown example 'no_such_board'" in err and err.count("\n") == 1
    code, _, err = run(capsys, "snakeboard_bkmm", *DRIVE, "--period", "1")
    assert code == 2 and "--param J0=VALUE" in err and err.count("\n") == 1


def test_command_object():
    assert isinstance(gait_cmd, click.Command) and gait_cmd.name == "gait"


class _NoDerivation(dict):
    """Stands in for the store of derived symbolic objects: any look-up is a derivation begun."""

    def __getitem__(self, key):
        raise AssertionError(f"derived {key[2]} of {key[0]} before checking the names")


BALL = ["chaplygin_ball", *(f"--param={k}={v}" for k, v in (("I1", 1), ("I2", 1.2), ("I3", 1.4), ("m", 1), ("r", 0.5)))]


@pytest.mark.parametrize(
    "args, words",
    [
        (["gait", *BALL, "--shape-loop", "nosuch=sin(2*pi*t)", "--period", "1"], "'nosuch', which is not a shape"),
        (["simulate", *BALL, "--shape", "nosuch=t"], "`--shape` names ['nosuch'], which are not shape variables"),
        (["simulate", *BALL, "--q0", "nosuch=1"], "`--q0` names ['nosuch']"),
        (["gait", *BALL[:-1], "--param", "nosuch=1", "--shape-loop", "theta=t", "--period", "1"], "nosuch"),
        (["simulate", *BALL, "--param", "nosuch=1"], "nosuch"),
    ],
)
def test_names_are_checked_before_any_derivation(capsys, monkeypatch, args, words):
    # the Chaplygin ball's derivation takes seconds to minutes: a misspelt name must not wait for it
    monkeypatch.setattr("geomech.symbolic.cache._SHARED", _NoDerivation())
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and words in err, err


def test_a_sweep_of_coefficients_and_parameters_is_a_resumable_study(capsys, tmp_path):
    xr = pytest.importorskip("xarray")
    from scipy.special import jv

    loop = ["--shape-loop", "psi=a*sin(2*pi*t/T)", "--shape-loop", "phi=0.4*sin(2*pi*t/T)"]
    args = [
        *BOARD,
        *loop,
        "--period",
        "1.5",
        "--sweep",
        "a=0.5:1.5:3",
        "--sweep",
        "J0=0.2:0.4:2",
        "--out",
        str(tmp_path),
    ]
    code, out, err = run(capsys, *args, "--json")
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["members"] == 6 and s["summary"]["failed"] == 0
    ds = xr.open_dataset(tmp_path / "gait_sweep.nc").load()
    want = 4 * np.pi * ds["J0"].values[None, :] * ds["a"].values[:, None] * (2 * np.pi / 1.5) * jv(1, 0.4)
    np.testing.assert_allclose(ds["momentum_change"].values[..., 0], want, rtol=1e-8)
    code, _, err = run(capsys, *args)
    assert code == 2 and "--resume" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, *args, "--resume")
    assert code == 0, err
    code, _, err = run(capsys, *BOARD, *DRIVE, "--period", "1", "--resume")
    assert code == 2 and "give `--sweep`" in err
