"""Pictures of nonholonomic gaits: what is drawn is the data of the analysis."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from geomech.analysis import analyse_gait  # noqa: E402
from geomech.plot.gaits import gait_momentum, gait_paths  # noqa: E402
from geomech.plot.phases import connection_field, curvature_map  # noqa: E402
from geomech.reduction import bkmm_reduction  # noqa: E402
from geomech.systems.nonholonomic_examples import snakeboard_bkmm  # noqa: E402


@pytest.fixture(scope="module")
def analysis():
    model = bkmm_reduction(snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)).numeric()
    return analyse_gait(
        model, {"psi": "sin(2*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}, period=1.0, periods=2, samples_per_period=41
    )


def test_paths_full_and_parts(analysis):
    ax = gait_paths(analysis)
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    full = ax.get_lines()[0]
    assert np.allclose(full.get_xydata(), analysis.path.g[:, :2])
    conn = [ln for k, ln in lines.items() if k.startswith("connection")][0]
    mom = [ln for k, ln in lines.items() if k.startswith("momentum")][0]
    assert np.allclose(conn.get_xydata(), analysis.alone["connection"].g[:, :2])
    assert np.allclose(mom.get_xydata(), analysis.alone["momentum"].g[:, :2])
    plt.close(ax.figure)


def test_momentum_plot(analysis):
    ax = gait_momentum(analysis)
    assert np.allclose(ax.get_lines()[0].get_ydata(), analysis.p[:, 0])
    plt.close(ax.figure)


def test_connection_field_and_curvature(analysis):
    _, ax = plt.subplots()
    assert connection_field(analysis, component="omega", n=7, ax=ax) is ax
    q = [c for c in ax.collections if hasattr(c, "U")][0]
    X = np.asarray(q.X).reshape(7, 7)
    Y = np.asarray(q.Y).reshape(7, 7)
    A = analysis.model.connection(np.stack([X, Y], -1))[..., 2, :]
    assert np.allclose(np.asarray(q.U).reshape(7, 7), -A[..., 0]) and np.allclose(
        np.asarray(q.V).reshape(7, 7), -A[..., 1]
    )
    plt.close(ax.figure)
    ax = curvature_map(analysis, n=31, bounds=(-1.0, 1.0, -0.6, 0.6))
    B = np.asarray(ax.collections[0].get_array()).reshape(31, 31)
    X, Y = np.meshgrid(np.linspace(-1.0, 1.0, 31), np.linspace(-0.6, 0.6, 31))
    assert np.allclose(B, analysis.model.curvature(np.stack([X, Y], -1))[..., 2, 0, 1], rtol=1e-12, atol=0)
    plt.close(ax.figure)


def test_zero_component_is_said_not_drawn(analysis):
    ax = connection_field(analysis, component="v_y", n=5)
    assert not [c for c in ax.collections if hasattr(c, "U")]
    assert "vanishes" in ax.texts[0].get_text()
    plt.close(ax.figure)
