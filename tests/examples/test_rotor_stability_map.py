import pytest
from example_runner import run_example


@pytest.mark.slow
def test_rotor_stability_map(tmp_path):
    text = run_example("rotor_stability_map.py", tmp_path)
    assert (tmp_path / "rotor_stability_map.png").stat().st_size > 10_000
    assert (tmp_path / "stability_map.html").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    assert float(values["points where the assessment failed"]) == 0
    # phi = k v: every verdict is Theorem 5's, k > 1 - I3/lambda2 stable and below it unstable
    assert float(values["linear map: points compared"]) >= 50
    assert float(values["linear map: points where the verdict disagrees with Theorem 5"]) == 0
    # phi = k v + a v^3, p = 0.1: every verdict is that of phi'(L*) > 1 - I3/lambda2 at the meridian root L*
    assert float(values["cubic map: points compared"]) >= 50
    assert float(values["cubic map: points where the verdict disagrees with the meridian root"]) == 0
    # both verdicts occur on the cubic map (the boundary crosses it)
    assert 0.1 < float(values["cubic map: stable fraction"]) < 0.95
