"""``geomech phase``: the two subcommands of issue 6 and the holonomic loop command; one-line errors."""

import json
import math

import pytest
from cli_helpers import run


def test_two_bodies_json_is_the_closed_form(capsys):
    code, out, err = run(
        capsys,
        "phase",
        "two-bodies",
        "--I1",
        "1",
        "--I2",
        "3",
        "--mu",
        "-2.5",
        "--period",
        "5.5",
        "--turns",
        "-1",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    want = -2 * math.pi * (-1) * 3 / 4 + (-2.5) * 5.5 / 4  # from (I1 + I2) theta' + I2 psi' = mu
    head, ph = s["summary"], s["summary"]["phase"]
    assert abs(ph["total"] - want) < 1e-10
    assert abs(ph["geometric"] - 3 * math.pi / 2) < 1e-12
    assert abs(ph["dynamic"] - (-2.5 * 5.5 / 4)) < 1e-12
    assert abs(head["reconstructed"] - want) < 1e-9 and abs(head["closed_form"] - want) < 1e-12
    assert (
        -math.pi < ph["total_wrapped"] <= math.pi
        and abs(math.remainder(ph["total"] - ph["total_wrapped"], 2 * math.pi)) < 1e-12
    )


def test_two_bodies_default_turns_and_text(capsys):
    code, out, err = run(capsys, "phase", "two-bodies", "--I1", "2", "--I2", "2")
    assert code == 0, err
    assert "geometric phase" in out and f"{-math.pi:.12g}" in out


def test_rigid_body_json(capsys):
    code, out, err = run(
        capsys, "phase", "rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--json"
    )
    assert code == 0, err
    s = json.loads(out)
    head, ph = s["summary"], s["summary"]["phase"]
    assert abs(head["difference"]) < 1e-8
    assert abs(ph["total"] - (ph["geometric"] + ph["dynamic"])) < 1e-14
    assert abs(s["period"] - 19.1353045602) < 1e-8
    assert -math.pi < head["direct_wrapped"] <= math.pi and s["axis"] in (1, 3)  # 1-based, as on the CLI


def test_rigid_body_out_dir(capsys, tmp_path):
    code, out, err = run(
        capsys,
        "phase",
        "rigid-body",
        "--inertia",
        "3,2,1",
        "--momentum",
        "0.2,0.3,1",
        "--attitude",
        "0.1",
        "0.2",
        "0.3",
        "--out",
        str(tmp_path),
    )
    assert code == 0, err
    assert (tmp_path / "rigid_body_phase.json").exists() and (tmp_path / "rigid_body_solid_angle.png").exists()
    assert "wrapped to (-pi, pi]" in out


def test_loop_command(capsys, tmp_path):
    code, out, err = run(
        capsys,
        "phase",
        "loop",
        "three-link-middle",
        "--shape",
        "alpha1=0.4+0.9*cos(2*pi*t/T)",
        "--shape",
        "alpha2=-0.2+0.6*sin(2*pi*t/T)",
        "--period",
        "2",
        "--json",
        "--out",
        str(tmp_path),
    )
    assert code == 0, err
    s = json.loads(out)
    head = s["summary"]
    assert abs(head["phase"]["geometric"] + s["curvature_integral"][2]) < 1e-10
    assert abs(head["net_displacement"]["theta"] - head["phase"]["total"]) < 1e-9
    for f in ("loop.json", "connection.png", "curvature.png", "path.png"):
        assert (tmp_path / f).exists()


@pytest.mark.parametrize(
    "args, match",
    [
        (("phase", "two-bodies", "--I1", "0", "--I2", "0"), "singular"),
        (("phase", "two-bodies", "--period", "-1"), "--period"),
        (("phase", "rigid-body", "--inertia", "3", "2", "1", "--momentum", "0", "1", "0"), "periodic"),
        (("phase", "rigid-body", "--inertia", "3", "2", "--momentum", "1", "0", "0"), "inertia"),
        (("phase", "loop", "three-link-middle", "--shape", "alpha1=t", "--shape", "alpha2=sin(2*pi*t)"), "closed"),
        (("phase", "loop", "three-link-middle", "--shape", "alpha1=sin(2*pi*t)"), "one `--shape` for each"),
        (("phase", "loop", "three-link-middle", "--shape", "alpha1=sin(2*pi*t)", "--shape", "beta=0"), "not a shape"),
        (
            (
                "phase",
                "loop",
                "planar-3-body",
                "--shape",
                "rho=0.3*sin(2*pi*t)",
                "--shape",
                "a2=0.3*sin(2*pi*t)",
                "--shape",
                "b2=0.3*sin(2*pi*t)",
            ),
            "singular",
        ),
        (
            (
                "phase",
                "loop",
                "three-link-middle",
                "--shape",
                "alpha1=cos(2*pi*t)",
                "--shape",
                "alpha2=sin(2*pi*t)",
                "--mu",
                "1",
            ),
            "3 component",
        ),
    ],
)
def test_bad_input_is_one_line_and_status_2(capsys, args, match):
    code, out, err = run(capsys, *args)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("geomech: error:") and match in err


MODEL_FILE = """
from geomech.systems import HolonomicSystem

def build(I1=1.0, I2=3.0):
    return HolonomicSystem.from_lagrangian("I1*theta_dot**2/2 + I2*(theta_dot + psi_dot)**2/2", "S1", ["psi"],
                                           parameters={"I1": I1, "I2": I2}, shape_angles=[0], name="my bodies")
"""


def test_loop_on_a_users_holonomic_model_file(tmp_path, capsys):
    f = tmp_path / "bodies.py"
    f.write_text(MODEL_FILE)
    code, out, err = run(
        capsys,
        "phase",
        "loop",
        str(f),
        "--shape",
        "psi=-2*pi*t/T",
        "--period",
        "5.5",
        "--mu",
        "-2.5",
        "--param",
        "I1=2",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    # body 1 turns by (mu T - 2 pi turns I2) / (I1 + I2) with I1 = 2 from --param, I2 = 3, turns = -1
    want = (-2.5 * 5.5 + 2 * math.pi * 3) / 5
    head = s["summary"]
    assert abs(head["phase"]["total"] - want) < 1e-10 and abs(head["net_displacement"]["theta"] - want) < 1e-9
    code, _, err = run(capsys, "phase", "loop", str(f), "--shape", "psi=t", "--param", "I9=2")
    assert code == 2 and err.count("\n") == 1 and "I9" in err
    nonholonomic = tmp_path / "nh.py"
    nonholonomic.write_text(
        "from geomech.systems.nonholonomic_examples import chaplygin_sleigh\nsystem = chaplygin_sleigh()\n"
    )
    code, _, err = run(capsys, "phase", "loop", str(nonholonomic), "--shape", "psi=t")
    assert code == 2 and "expected `system` to be a HolonomicSystem" in err


def test_loop_on_the_spacecraft_reconstructs_on_so3(capsys):
    shape = ("--shape", "varphi1=0.05*cos(2*pi*t/T)", "--shape", "varphi2=0.05*sin(2*pi*t/T)")
    code, out, err = run(capsys, "phase", "loop", "spacecraft", *shape, "--mu", "0", "0", "0", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["phase"] is None and "phase_unavailable" in s  # SO(3) with a shape space: no formula
    # a small loop at zero momentum: the holonomy is exp(-iint B) to leading order in the loop's size
    rot = [s["summary"]["net_displacement"][f"log_omega_{i}"] for i in (1, 2, 3)]
    B = s["curvature_integral"]
    assert abs(rot[2] + B[2]) < 1e-3 * abs(B[2]) and abs(rot[0]) + abs(rot[1]) < 1e-2 * abs(B[2])
    code, _, err = run(capsys, "phase", "loop", "spacecraft", *shape, "--mu", "0.1")
    assert code == 2 and "3 component(s) for SO(3)" in err
    code, _, err = run(capsys, "phase", "loop", "no-such-model", *shape)
    assert code == 2 and "Unknown example" in err


def test_two_bodies_out_draws_the_split(capsys, tmp_path):
    code, _, err = run(capsys, "phase", "two-bodies", "--mu", "-2.5", "--period", "5.5", "--out", str(tmp_path))
    assert code == 0, err
    assert {"two_bodies.json", "two_bodies_theta.png", "two_bodies_phases.png"} <= {p.name for p in tmp_path.iterdir()}
