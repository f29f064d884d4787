"""Bad values found by attacking the API and the CLI: each is now a clean, named error."""

import numpy as np
import pytest
from cli_helpers import run

import geomech as gm
from geomech.errors import InputError, SingularityError
from geomech.systems.nonholonomic_examples import chaplygin_sleigh, snakeboard


@pytest.mark.parametrize(
    "kw, needle",
    [
        ({"m": float("nan")}, "`m` of snakeboard to be finite"),
        ({"r": 0.0}, "`r` of snakeboard to be positive"),
        ({"J": -1.0}, "`J` of snakeboard to be positive"),
        ({"m": "heavy"}, "to be a number"),
    ],
)
def test_example_parameters_are_checked_when_given(kw, needle):
    with pytest.raises(InputError, match=needle):
        snakeboard(**kw)
    assert chaplygin_sleigh(m=2.0).parameters["m"] == 2.0


def test_the_triangle_inequality_cannot_pass_by_overflow():
    with pytest.raises(InputError, match="triangle inequality"):
        gm.RigidBody(inertia=[1e308, 1.0, 1.0])
    assert gm.RigidBody(inertia=[1e300, 1e300, 5e299]).principal_moments.max() == 1e300


def test_the_compiled_euler_vector_field_raises_at_gimbal_lock_like_the_other():
    from geomech.reduction import EulerCoordinates

    m1, m2, m3 = gm.M_SYMBOLS
    e = EulerCoordinates(gm.LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2))
    q = np.array([0.1, 0.5, 0.2, 0.3, 0.1, 0.2])
    np.testing.assert_allclose(e.compiled_vector_field()(q), e.vector_field(q), rtol=1e-12, atol=1e-14)
    for theta in (0.0, np.pi):
        bad = q.copy()
        bad[1] = theta
        with pytest.raises(SingularityError, match="gimbal lock"):
            e.vector_field(bad)
        with pytest.raises(SingularityError, match="gimbal lock"):
            e.compiled_vector_field()(bad)


def test_a_stability_map_cannot_sweep_where_stability_refuses(capsys, tmp_path):
    base = [
        "stability-map",
        "--lambda",
        "3",
        "2",
        "--I3",
        "1",
        "--phi",
        "k*v",
        "--x",
        "k=0.05:0.95:3",
        "--out",
        str(tmp_path / "m"),
    ]
    code, _, err = run(capsys, *base, "--y", "lambda2=1.2:3.5:3")
    assert code == 2 and "lambda1 = 3 <= lambda2 = 3.5" in err and err.count("\n") == 1
    code, _, err = run(capsys, *base, "--y", "I3=-1:0.5:3")
    assert code == 2 and "I3 must stay positive" in err
    assert not (tmp_path / "m").exists()


def test_derive_says_that_parameters_do_not_change_a_symbolic_derivation(capsys):
    code, _, err = run(capsys, "derive", "rolling_disk", "--param", "m=2")
    assert code == 2 and "symbolic in every parameter" in err and "'--param'" in err


SLIDER_L = (
    "m/2*(x_dot**2 + y_dot**2) + I/2*theta_dot**2"
    " + ms/2*((x_dot - s*sin(theta)*theta_dot + cos(theta)*s_dot)**2"
    " + (y_dot + s*cos(theta)*theta_dot + sin(theta)*s_dot)**2)"
)
#: the blade sits at the sliding mass, tilted by beta from the body axis
SLIDER_BLADE = (
    "-sin(theta + beta)*(x_dot - s*sin(theta)*theta_dot + cos(theta)*s_dot)"
    " + cos(theta + beta)*(y_dot + s*cos(theta)*theta_dot + sin(theta)*s_dot)"
)


def test_an_automatic_basis_that_degenerates_at_the_given_values_is_named_and_a_valid_one_works():
    """At beta = 0 the generic null-space basis has two parallel vectors though S_q keeps dimension 2: a one-line
    error (once a KeyError 'ComplexInfinity'); the basis (cos b, sin b, 0), (0, -s, 1), valid for every beta, runs,
    and the reduced simulation agrees with the full one (an independent route)."""
    from geomech.integrators import BKMM, LagrangeDAlembert
    from geomech.lie import SE2
    from geomech.systems.nonholonomic import NonholonomicSystem

    values = dict(m=1.0, I=0.5, ms=0.3, beta=0.0)
    auto = NonholonomicSystem.from_lagrangian(
        SLIDER_L, SE2("x", "y", "theta"), ["s"], [SLIDER_BLADE], parameters=values, name="slider"
    )
    gait = {"s": "0.2*sin(2*pi*t)"}
    with pytest.raises(InputError, match=r"slider: the body-fixed basis .* degenerates at .*beta = 0,.*\(rank 1 < 2\)"):
        gm.solve(auto, BKMM(), t_final=1.0, shapes=gait, p0=[0.1, 0.1])
    good = NonholonomicSystem.from_lagrangian(
        SLIDER_L,
        SE2("x", "y", "theta"),
        ["s"],
        [SLIDER_BLADE],
        parameters=values,
        name="slider",
        basis=[["cos(beta)", "0"], ["sin(beta)", "-s"], ["0", "1"]],
    )
    red = gm.solve(good, BKMM(), t_final=1.0, shapes=gait, p0=[0.1, 0.1])
    full = gm.solve(good, LagrangeDAlembert(), t_final=1.0, shapes=gait, p0=[0.1, 0.1])
    assert np.abs(red.q[-1] - red.q[0]).max() > 1e-2  # it moves
    np.testing.assert_allclose(red.q[-1], full.q[-1], rtol=0, atol=1e-7)


def test_basis_entries_given_as_text_are_formulas_not_code(tmp_path, monkeypatch):
    from geomech.reduction import bkmm_reduction
    from geomech.systems.nonholonomic_examples import snakeboard_bkmm

    monkeypatch.chdir(tmp_path)
    attack = "0*len(open('PWNED', 'w').name)"
    with pytest.raises(InputError, match="k x m matrix"):
        bkmm_reduction(snakeboard_bkmm(), basis=[[attack], ["0"], ["1"]])
    assert not list(tmp_path.iterdir())
    red = bkmm_reduction(snakeboard_bkmm(), basis=[["-r*cos(phi)"], ["0"], ["sin(phi)"]])
    assert red.normalization == "given by the caller"
