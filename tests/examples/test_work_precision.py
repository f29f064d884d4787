import pytest
from example_runner import run_example


@pytest.mark.slow
def test_work_precision(tmp_path):
    text = run_example("work_precision.py", tmp_path)
    assert (tmp_path / "work_precision.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    # the order fitted in log-log over about two decades of error matches the one methods_table states
    assert float(values["largest |fitted - stated order|"]) < 0.3
    # Gauss-Legendre methods keep quadratic invariants, so the energy of the free rigid body, to round-off
    for key in ("gauss_legendre_1", "gauss_legendre_2", "gauss_legendre_3"):
        assert float(values[f"{key} long-run max energy error"]) < 1e-12
    # the splittings: bounded energy error (the same size in both halves of 100 periods), of the size h^p
    assert float(values["strang long-run max energy error"]) < 1e-3
    assert float(values["splitting_4_yoshida long-run max energy error"]) < 1e-6
    for key in ("strang", "splitting_4_yoshida"):
        assert float(values[f"{key} energy error growth, second half / first half"]) < 1.3
    # RK4 is not symplectic: its energy drifts linearly, doubling from the first half of the run to the second
    assert float(values["rk4 energy error growth, second half / first half"]) > 1.6
