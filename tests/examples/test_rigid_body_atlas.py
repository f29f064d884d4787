import pytest
from example_runner import run_example


@pytest.mark.slow
def test_rigid_body_atlas(tmp_path):
    text = run_example("rigid_body_atlas.py", tmp_path)
    assert (tmp_path / "rigid_body_atlas.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # the atlas runs DOP853 at rtol = atol = 1e-12 over t = 50 (up to four periods, two orbits near the separatrix)
    assert float(values["max |m - m_exact|"]) < 1e-8
    assert float(values["max attitude error at whole periods (Montgomery)"]) < 1e-8
    assert float(values["max energy drift |E - E0|"]) < 1e-9
    # the charts map (l, L) onto the sphere |m| = G exactly: the Casimir is kept to round-off, not to the tolerance
    assert float(values["max Casimir drift ||m| - |m0||"]) < 1e-13
    # the orbit about axis 3 that enters the cap |m3| > 0.9 |m| must leave the seed's chart
    assert float(values["chart switches"]) >= 1
