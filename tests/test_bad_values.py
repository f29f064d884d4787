"""Bad values found by attacking the API and the CLI: each is now a clean, named error."""

import numpy as np
import pytest

import geomech as gm
from geomech.cli.main import main
from geomech.errors import InputError, SingularityError
from geomech.systems.nonholonomic_examples import chaplygin_sleigh, snakeboard


@pytest.mark.parametrize("kw, needle", [
    ({"m": float("nan")}, "`m` of snakeboard to be finite"),
    ({"r": 0.0}, "`r` of snakeboard to be positive"),
    ({"J": -1.0}, "`J` of snakeboard to be positive"),
    ({"m": "heavy"}, "to be a number"),
])
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


def run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def test_a_stability_map_cannot_sweep_where_stability_refuses(capsys, tmp_path):
    base = ["stability-map", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--x", "k=0.05:0.95:3",
            "--out", str(tmp_path / "m")]
    code, _, err = run(capsys, *base, "--y", "lambda2=1.2:3.5:3")
    assert code == 2 and "lambda1 = 3 <= lambda2 = 3.5" in err and err.count("\n") == 1
    code, _, err = run(capsys, *base, "--y", "I3=-1:0.5:3")
    assert code == 2 and "I3 must stay positive" in err
    assert not (tmp_path / "m").exists()


def test_derive_says_that_parameters_do_not_change_a_symbolic_derivation(capsys):
    code, _, err = run(capsys, "derive", "rolling_disk", "--param", "m=2")
    assert code == 2 and "symbolic in every parameter" in err and "'--param'" in err
