import pytest
from example_runner import run_example


@pytest.mark.slow
def test_roller_racer(tmp_path):
    text = run_example("roller_racer.py", tmp_path)
    assert (tmp_path / "roller_racer.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # the momentum reaches about 4 and the racer travels about 7 m; both routes integrate at rtol ~1e-10
    assert float(values["max |p printed equations - p full|"]) < 1e-7
    assert float(values["max |position printed equations - full| (m)"]) < 1e-7
    # the joint torque does several joules of work over the run
    assert float(values["work done over the run (J)"]) > 1.0
    assert float(values["max |E(t) - E(0) - W(t)| (J)"]) < 1e-7
    assert float(values["momentum gained per period"]) < -0.1
