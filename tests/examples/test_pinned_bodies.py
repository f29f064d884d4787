import math

import pytest
from example_runner import run_example


@pytest.mark.slow
def test_pinned_bodies(tmp_path):
    text = run_example("pinned_bodies.py", tmp_path)
    assert (tmp_path / "pinned_bodies.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # the holonomy of the connection I2/(I1 + I2) dpsi around the shape circle, I1 = 1, I2 = 3 (printed to 3 digits)
    assert abs(float(values["geometric phase (rad)"]) + 2 * math.pi * 3 / 4) < 5e-3
    # turns of up to 9 rad over T = 5.5; the simulations run at rtol = atol = 1e-12
    assert float(values["largest |geometric + dynamic - driven simulation| (rad)"]) < 1e-9
    assert float(values["largest |geometric + dynamic - free simulation| (rad)"]) < 1e-9
    assert float(values["largest |geometric + dynamic - closed form| (rad)"]) < 1e-10
    assert float(values["largest |turn of the free hinge - 2 pi| (rad)"]) < 1e-9
    assert float(values["largest drift of the angular momentum in the simulations"]) < 1e-9
