import pytest
from example_runner import run_example


@pytest.mark.slow
def test_three_link_chain(tmp_path):
    text = run_example("three_link_chain.py", tmp_path)
    assert (tmp_path / "three_link_chain.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    rotation = {loop: float(values[f"net rotation, loop {loop} (rad)"]) for loop in "ABCD"}
    # loop A encloses the positive lobe of the curvature counterclockwise, B the negative one: opposite turns
    assert rotation["A"] < -0.3 and rotation["B"] > 0.1
    # the curvature is odd under alpha -> -alpha, so a loop symmetric about the straight chain does not turn it
    assert abs(rotation["C"]) < 1e-10
    # Stokes: dblquad is asked for 1e-10 (absolute and relative) on integrals of size ~0.5
    assert float(values["largest dblquad error estimate (rad)"]) < 1e-8
    assert float(values["largest |line integral - curvature integral| (rad)"]) < 1e-8
    # the full simulation runs at rtol = atol = 1e-12 over one period with turns below 1 rad
    assert float(values["largest |line integral - full simulation| (rad)"]) < 1e-8
    assert float(values["largest |spatial momentum| in the simulations"]) < 1e-9
