import pytest
from example_runner import run_example


@pytest.mark.slow
def test_snakeboard_gaits(tmp_path):
    text = run_example("snakeboard_gaits.py", tmp_path)
    assert (tmp_path / "snakeboard_gaits.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # both simulations run at rtol 1e-10 over paths of a few metres; a wrong term in either set of equations
    # would separate them by centimetres
    assert float(values["max |reduced - full| planar position (m)"]) < 1e-7
    # the momentum gained per period is of order 1 (1.7 at delta = 0)
    assert float(values["max |momentum gain per period - Bessel formula|"]) < 1e-7
    # printed to 3 digits: 4 pi J0 a omega J_1(b) = 1.698
    assert abs(float(values["momentum gain per period at delta = 0"]) - 1.698) < 0.01
    # at delta = pi/2 the momentum returns and the board still moves every period
    assert float(values["distance travelled per period at delta = pi/2 (m)"]) > 0.1
