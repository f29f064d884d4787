import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import geomech as gm
from geomech import GeneralizedSerretAndoyer, RigidBody  # noqa: E402
from geomech.errors import ShapeError  # noqa: E402
from geomech.integrators import SerretAndoyerAtlas
from geomech.plot import momentum_sphere, reduced_phase_portrait  # noqa: E402
from geomech.plot.momentum import _sphere_level_curves  # noqa: E402


def atlas(system, m0, t, *, R0=None, axis=None, rtol=None, atol=None):
    """The Serret-Andoyer atlas through solve() at the times ``t`` (``axis``: the first chart, 0-based)."""
    t = np.asarray(t, dtype=float)
    method = SerretAndoyerAtlas(axis=None if axis is None else axis + 1)
    R0 = np.eye(3) if R0 is None else R0
    return gm.solve(system, method, t_final=t[-1], saveat=t, m0=m0, R0=R0, rtol=rtol, atol=atol)


def test_momentum_sphere_draws_level_curves_on_the_sphere():
    body = RigidBody([3.0, 2.0, 1.0])
    m = body.exact_solution([1.0, 0.3, 0.2]).momentum(np.linspace(0, 20, 200))
    ax = momentum_sphere(m, energy_curves=body.energy, chart=np.full(200, 2))
    assert len(ax.get_lines()) > 10
    G = float(np.linalg.norm(m[0]))
    curves = _sphere_level_curves(body.energy, G, 8)
    E = body.energy(np.concatenate(curves))
    assert len(curves) >= 8
    for c in curves:  # each curve lies on the sphere and on one level of the energy (contouring error)
        np.testing.assert_allclose(np.linalg.norm(c, axis=1), G, rtol=1e-12)
        assert np.ptp(body.energy(c)) < 2e-3 * np.ptp(E)
    plt.close("all")
    with pytest.raises(ShapeError):
        momentum_sphere(np.zeros((2, 5, 3)))


def test_reduced_phase_portrait_uses_given_axes():
    body = RigidBody([3.0, 2.0, 1.0])
    sa = GeneralizedSerretAndoyer(body)
    traj = atlas(body, [1.0, 0.3, 0.2], np.linspace(0, 10, 50))
    fig, ax = plt.subplots()
    assert reduced_phase_portrait(sa, float(np.linalg.norm([1.0, 0.3, 0.2])), trajectory=traj, ax=ax) is ax
    assert ax.get_xlabel() == "$l$"
    plt.close("all")
