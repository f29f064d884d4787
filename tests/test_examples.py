"""The examples run as shipped (``make demo`` runs examples/demo.py) and write what they say they write."""

import pytest
from example_runner import run_example as _run


@pytest.mark.slow
def test_demo(tmp_path):
    text = _run("demo.py", tmp_path)
    for name in ("momentum_spheres.png", "serret_andoyer_plane.png", "snakeboard_gait.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert "Jacobi identity of the almost-Poisson bracket holds: False" in text
    assert "2*J0*phi_dot*psi_dot*cos(phi)**2" in text  # BKMM's momentum equation, derived


@pytest.mark.slow
def test_spacecraft_example(tmp_path):
    _run("spacecraft_control.py", tmp_path)
    assert any(p.suffix == ".png" for p in tmp_path.iterdir())


@pytest.mark.slow
def test_quaternion_midpoint_example(tmp_path):
    text = _run("quaternion_midpoint.py", tmp_path)
    for name in ("midpoint_momentum_drift.png", "quaternions_through_gimbal_lock.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    drift = {line.split(":")[0]: line for line in text.splitlines()}
    assert "e-15" in drift["quaternions"] or "e-16" in drift["quaternions"]


@pytest.mark.slow
def test_momentum_transport_example(tmp_path):
    text = _run("momentum_transport.py", tmp_path)
    assert (tmp_path / "momentum_transport.png").stat().st_size > 10_000
    values = [float(line.rsplit(":", 1)[1]) for line in text.splitlines() if ":" in line]
    assert len(values) == 2 and max(values) < 1e-9


@pytest.mark.slow
def test_spacecraft_phase_example(tmp_path):
    text = _run("spacecraft_phase.py", tmp_path)
    assert (tmp_path / "spacecraft_phase.png").stat().st_size > 10_000
    values = dict(line.rsplit(":", 1) for line in text.splitlines() if ":" in line)
    assert float(values["largest |formula - reconstruction| (rad)"]) < 1e-8
    assert abs(float(values["geometric phase at the largest amplitude (rad)"])) > 0.1
