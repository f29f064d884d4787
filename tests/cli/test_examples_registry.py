"""One registry of built-in examples, read by the API and by every command that takes a MODEL: the systems with
and without constraints, snake_case names (dashes accepted), parameter values through ``--param`` for all."""

import json
import math

import pytest
from cli_helpers import run

from geomech.systems import HolonomicSystem, holonomic_examples, nonholonomic_examples
from geomech.systems.models import EXAMPLES, example_name, example_system


def test_the_registry_holds_both_kinds_under_one_naming():
    assert set(EXAMPLES) == set(holonomic_examples.EXAMPLES) | set(nonholonomic_examples.EXAMPLES)
    assert all(name == name.lower() and "-" not in name for name in EXAMPLES)
    assert example_name("three-link-middle") == "three_link_middle" and example_name("nosuch") is None
    chain = example_system("three-link")
    assert isinstance(chain, HolonomicSystem) and chain.c == 0
    bodies = example_system("two_bodies", {"I2": 2.0})
    assert bodies.parameters["I2"] == 2.0


def test_kind_and_parameter_errors_say_what_fits():
    with pytest.raises(Exception, match="needs a HolonomicSystem: choose one of two_bodies"):
        example_system("snakeboard", kind=HolonomicSystem, purpose="phase loop")
    with pytest.raises(Exception, match=r"has no parameter\(s\) \['mass'\]; its parameters are \['I1', 'I2'\]"):
        example_system("two_bodies", {"mass": 1.0})


def test_phase_loop_takes_either_spelling_and_parameters_of_a_built_in(capsys):
    # two pinned bodies, one turn of the hinge: geometric phase -2 pi I2 / (I1 + I2) (section 2.2 of the seed)
    loop = ("--shape", "psi=2*pi*t/T", "--period", "2", "--json")
    code, out_dash, err = run(capsys, "phase", "loop", "two-bodies", *loop)
    assert code == 0, err
    code, out_snake, err = run(capsys, "phase", "loop", "two_bodies", *loop)
    assert code == 0, err
    a, b = json.loads(out_dash), json.loads(out_snake)
    assert a["summary"]["phase"] == b["summary"]["phase"]
    assert abs(a["summary"]["phase"]["geometric"] + 2 * math.pi * 3 / 4) < 1e-12
    code, out, err = run(capsys, "phase", "loop", "two_bodies", "--param", "I2=2", *loop)
    assert code == 0, err
    assert abs(json.loads(out)["summary"]["phase"]["geometric"] + 2 * math.pi * 2 / 3) < 1e-12
    code, _, err = run(capsys, "phase", "loop", "snakeboard", *loop)
    assert code == 2 and err.count("\n") == 1 and "needs a HolonomicSystem" in err and "two_bodies" in err


def test_derive_and_simulate_take_a_system_without_constraints(capsys):
    code, out, err = run(capsys, "derive", "two_bodies", "--json")
    assert code == 0, err
    assert json.loads(out)["bkmm"]["text"]["connection A_nh(r)"] == [["I2/(I1 + I2)"]]
    # theta(t) = -I2/(I1 + I2) (psi(t) - psi(0)) + mu t / (I1 + I2): the gait returns psi at t = 1
    mu = 0.6
    code, out, err = run(
        capsys,
        "simulate",
        "two_bodies",
        "--param",
        "I2=2",
        "--shape",
        "psi=sin(2*pi*t)",
        "--p0",
        str(mu),
        "--t-final",
        "1",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    assert abs(s["summary"]["final_configuration"]["theta"] - mu / 3.0) < 1e-8


def test_gait_of_a_system_without_constraints_agrees_with_phase_loop(capsys):
    # Two routes on the falling-cat chain at zero momentum: `gait` integrates the momentum equation (1.2) along
    # the loop (p stays 0 only if (1.2) is right for c = 0), `phase loop` reconstructs with the conserved
    # spatial momentum; both from the one registry name.
    shapes = ("alpha1=0.4+0.5*cos(2*pi*t/T)", "alpha2=-0.2+0.5*sin(2*pi*t/T)")
    code, out, err = run(
        capsys,
        "gait",
        "three-link-middle",
        *(x for s in shapes for x in ("--shape-loop", s)),
        "--period",
        "1",
        "--json",
    )
    assert code == 0, err
    gait = json.loads(out)["summary"]["net_displacement"]
    code, out, err = run(
        capsys, "phase", "loop", "three_link_middle", *(x for s in shapes for x in ("--shape", s)), "--json"
    )
    assert code == 0, err
    loop = json.loads(out)["summary"]["net_displacement"]
    assert abs(loop["theta"]) > 1e-3  # a real reorientation
    for c in ("x", "y", "theta"):
        assert abs(gait[c] - loop[c]) < 1e-9
