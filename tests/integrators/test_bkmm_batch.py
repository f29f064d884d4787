"""Batches of nonholonomic runs in one compiled BKMM call: over the coefficients of a gait or of torques, the
system's parameters and the initial states, broadcast together. Each member is checked against its own run by
the Python equations (numpy's linear algebra stepped by scipy's DOP853, an independent implementation), and the
observation of the saved states (q, qdot, shape forces, energy, constraints) compiled against the same source run
as Python."""

import numpy as np
import pytest

from geomech import solve
from geomech.errors import InputError
from geomech.integrators import BKMM, Status, _observe
from geomech.systems.nonholonomic_examples import kinematic_car, roller_racer, rolling_disk, snakeboard

SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
TOL = dict(rtol=1e-11, atol=1e-12)


def _agree(batch, b, one):
    """Member ``b`` of ``batch`` against the single run ``one``: both to the tolerance of the runs (1e-11)."""
    for name in ("q", "qdot", "p", "work", "energy"):
        x, y = getattr(batch, name)[b], getattr(one, name)
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-8 * max(1.0, float(np.abs(y).max())), err_msg=name)
    tau = one.quantities["tau"]
    np.testing.assert_allclose(batch.quantities["tau"][b], tau, rtol=0, atol=1e-8 * max(1.0, float(np.abs(tau).max())))


def test_a_batch_of_gaits_is_each_gait_run_alone():
    s = snakeboard(**SNAKE)
    gait = {"psi": "a*sin(2*pi*t)", "phi": "b*sin(2*pi*t + c)"}
    a, b, c = np.array([0.6, 1.0, 1.4]), np.array([0.3, 0.5]), np.array([0.0, 0.8])
    sol = solve(
        s,
        BKMM(),
        t_final=2.0,
        saveat=5,
        shapes=gait,
        parameters={"a": a[:, None, None], "b": b[:, None], "c": c},
        **TOL,
    )
    assert sol.batch_shape == (3, 2, 2) and sol.states.shape == (3, 2, 2, 5, 10)
    assert sol.stats["backend"] == "numba" and sol.status is Status.SUCCESS
    np.testing.assert_array_equal(sol.parameters["a"], np.broadcast_to(a[:, None, None], (3, 2, 2)))
    for i, j, k in [(0, 0, 0), (2, 1, 1), (1, 0, 1)]:
        one = solve(
            s,
            BKMM(),
            t_final=2.0,
            saveat=5,
            shapes={"psi": f"{a[i]}*sin(2*pi*t)", "phi": f"{b[j]}*sin(2*pi*t + {c[k]})"},
            backend="python",
            **TOL,
        )
        _agree(sol, (i, j, k), one)
    # the members differ (the coefficients were read per member), the constraints hold along each
    assert np.ptp(sol.q[:, 0, 0, -1, 0]) > 1e-2
    assert np.abs(sol.quantities["constraint_residual"]).max() < 1e-10 * max(1.0, float(np.abs(sol.qdot).max()))


def test_parameters_and_initial_states_broadcast_together():
    s = rolling_disk(m=1.2, R=0.4, I=0.7, J=0.3)
    masses = np.array([0.8, 1.2, 2.0])
    p0 = np.array([[0.6], [-0.4]])  # (2, 1): two momenta, broadcast against the three masses
    sol = solve(
        s, BKMM(), t_final=3.0, saveat=7, parameters={"m": masses}, p0=p0[:, None, :], rdot0={"phi": 1.3}, **TOL
    )
    assert sol.batch_shape == (2, 3)
    for i, j in [(0, 0), (1, 2), (0, 1)]:
        one = solve(
            rolling_disk(m=masses[j], R=0.4, I=0.7, J=0.3),
            BKMM(),
            t_final=3.0,
            saveat=7,
            p0=p0[i],
            rdot0={"phi": 1.3},
            backend="python",
            **TOL,
        )
        _agree(sol, (i, j), one)
    # the rolling disk conserves its energy: each member its own
    drift = np.abs(sol.energy - sol.energy[..., :1]).max()
    assert drift < 1e-8 * float(np.abs(sol.energy).max())
    ds = sol.to_dataset()
    assert ds["energy"].dims[:2] == ("batch_0", "batch_1") and ds["m"].shape == (2, 3)


def test_torque_coefficients_and_a_state_batch():
    s = roller_racer(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)
    gains = np.array([0.1, 0.3, 0.5, 0.7])
    q0 = np.zeros((4, s.n))
    q0[:, s.k] = [0.0, 0.1, 0.2, 0.3]  # the joint angle phi
    sol = solve(
        s,
        BKMM(),
        t_final=2.0,
        saveat=5,
        tau={"phi": "g*sin(3*t) - 0.05*phi_dot"},
        parameters={"g": gains},
        q0=q0,
        threads=2,
        **TOL,
    )
    for b in (0, 3):
        one = solve(
            s,
            BKMM(),
            t_final=2.0,
            saveat=5,
            tau={"phi": f"{gains[b]}*sin(3*t) - 0.05*phi_dot"},
            q0={"phi": q0[b, s.k]},
            backend="python",
            **TOL,
        )
        _agree(sol, b, one)


def test_the_compiled_observation_is_the_python_one(monkeypatch):
    s = snakeboard(**SNAKE)
    kw = dict(t_final=1.0, saveat=4, shapes={"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, **TOL)
    monkeypatch.setattr(_observe, "_compiled_observation", lambda name, compiled, rows: False)
    python = solve(s, BKMM(), parameters={"a": [0.5, 1.0]}, **kw)
    monkeypatch.setattr(_observe, "_compiled_observation", lambda name, compiled, rows: True)
    compiled = solve(s, BKMM(), parameters={"a": [0.5, 1.0]}, **kw)
    np.testing.assert_array_equal(compiled.states, python.states)
    for name in ("energy", "tau", "constraint_residual"):
        x, y = compiled.quantities[name], python.quantities[name]
        np.testing.assert_allclose(x, y, rtol=1e-14, atol=1e-14 * max(1.0, float(np.abs(y).max())))


def test_an_observation_in_numba_disk_cache_is_known_before_it_is_loaded():
    """A module whose observation numba's disk cache holds loads it (milliseconds) rather than observe as Python."""
    import numba

    from geomech.integrators import _codegen
    from geomech.integrators.nonholonomic._compiled import bkmm_module
    from geomech.integrators.nonholonomic._inputs import _setup
    from geomech.reduction import bkmm_reduction

    s = snakeboard(**SNAKE)
    shapes = {"psi": "sin(2*pi*t)", "phi": "0.25*sin(2*pi*t)"}
    # more states than the Python observation takes: compiled, and written to the disk cache
    solve(s, BKMM(), t_final=1.0, saveat=_observe.PYTHON_ROWS + 1, shapes=shapes, **TOL)
    made = bkmm_module(_setup(s, shapes, None), bkmm_reduction(s))
    assert made is not None
    assert _codegen.on_disk(made[0].observe_all) and _codegen.loaded(made[0].observe_all)
    fresh = numba.njit(lambda x: x)
    assert not _codegen.on_disk(fresh) and not _codegen.loaded(fresh)  # no disk cache, not yet compiled
    assert fresh(2.0) == 2.0 and _codegen.loaded(fresh)
    assert not _codegen.on_disk(lambda x: x)  # not a kernel


def test_the_observation_is_compiled_once_python_has_cost_as_much(monkeypatch):
    """Runs observed as Python (no compilation for a few small runs) until the states a module has observed so in
    the process would pass PYTHON_ROWS; then, and for a larger run at once, by the compiled code."""
    monkeypatch.setattr(_observe, "PYTHON_ROWS", 12)
    monkeypatch.setattr(_observe, "_PYTHON_SEEN", {})
    choices = [_observe._compiled_observation("m", False, rows) for rows in (5, 5, 5)]
    assert choices == [False, False, True]
    assert _observe._compiled_observation("other", False, 13) and not _observe._compiled_observation("other", False, 4)
    assert _observe._compiled_observation("new", True, 1)  # already compiled in this process


def test_a_failing_member_is_its_own_failure():
    # the kinematic car's steering reaches pi/2, where its constraints are singular, only at the larger rate
    car = kinematic_car(m=1.0, I=0.2, R=0.3, ell=1.0, J=0.1, K=0.1)
    sol = solve(
        car,
        BKMM(),
        t_final=2.0,
        saveat=9,
        shapes={"psi": "t", "phi": "A*t"},
        parameters={"A": [0.5, 1.0]},
        raise_on_failure=False,
    )
    assert len(sol.failures) == 1 and sol.failures[0].batch_index == (1,)
    assert sol.failures[0].kind is Status.ADAPTIVE_FAILED and "1 of 2 trajectories" in sol.message
    assert abs(sol.failures[0].time - np.pi / 2) < 1e-6
    assert np.all(np.isfinite(sol.q[0])) and np.all(np.isnan(sol.q[1, -1])) and np.all(np.isfinite(sol.q[1, 0]))


def test_batches_are_refused_where_they_cannot_run():
    s = snakeboard(**SNAKE)
    gait = {"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}
    with pytest.raises(InputError, match="compiled BKMM loop.*backend 'python'"):
        solve(s, BKMM(), t_final=1.0, shapes=gait, parameters={"a": [0.5, 1.0]}, backend="python")
    with pytest.raises(InputError, match="compiled BKMM loop.*Radau"):
        solve(s, BKMM(solver="Radau"), t_final=1.0, shapes=gait, parameters={"a": [0.5, 1.0]})
    with pytest.raises(InputError, match="not `qdot0`"):
        solve(s, BKMM(), t_final=1.0, shapes=gait, parameters={"a": [0.5, 1.0]}, qdot0=np.zeros(s.n))
    with pytest.raises(InputError, match="broadcast"):
        solve(s, BKMM(), t_final=1.0, shapes=gait, parameters={"a": [0.5, 1.0], "m": [1.0, 2.0, 3.0]})
    with pytest.raises(InputError, match=r"names \['w'\].*neither"):
        solve(s, BKMM(), t_final=1.0, shapes=gait, parameters={"a": 0.5, "w": 2.0})
    with pytest.raises(InputError, match="unknown symbols|only"):
        solve(s, BKMM(), t_final=1.0, shapes=gait)  # `a` has no value
    with pytest.raises(InputError, match=r"not positive definite.*member 1 of the batch"):
        solve(s, BKMM(), t_final=1.0, shapes=gait, parameters={"a": 0.5, "m": [1.0, -1.0]})


def test_a_coefficient_alone_is_a_number_of_the_gait():
    # one value per coefficient: the Python equations (which substitute it) and the compiled ones (which read it)
    s = snakeboard(**SNAKE)
    gait = {"psi": "a*sin(w*t)", "phi": "0.5*sin(w*t)"}
    values = {"a": 0.8, "w": 5.0}
    a = solve(s, BKMM(), t_final=1.0, saveat=3, shapes=gait, parameters=values, **TOL)
    b = solve(s, BKMM(), t_final=1.0, saveat=3, shapes=gait, parameters=values, backend="python", **TOL)
    assert a.stats["backend"] == "numba" and a.batch_shape == ()
    _agree(a, (), b)
