import pytest
from example_runner import run_example


@pytest.mark.slow
def test_own_nonholonomic(tmp_path):
    text = run_example("own_nonholonomic.py", tmp_path)
    assert (tmp_path / "own_nonholonomic.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # energy drift follows the integrator's tolerance: rtol 1e-10 gives a few 1e-10, rtol 1e-7 a few 1e-7
    assert float(values["max relative energy drift (rtol 1e-10)"]) < 1e-8
    assert float(values["max relative energy drift (rtol 1e-7)"]) < 1e-5
    # speeds are of order 0.5 m/s
    assert float(values["max constraint residual (m/s)"]) < 1e-8
    # 48 s of motion with a turn-around (sensitive to perturbations); both routes at rtol <= 1e-10
    assert float(values["max |almost-Poisson flow - Lagrange-d'Alembert| (x, y, theta)"]) < 1e-5
    # the bracket is not Poisson: Jacobiators of order 1, the two formulas for them agree to round-off
    assert float(values["largest |Jacobiator| at random states"]) > 1e-2
    assert float(values["max |Jacobiator direct - curvature formula|"]) < 1e-9
