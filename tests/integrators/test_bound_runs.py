"""A prepared problem's single runs by a compiled adaptive method start from the compiled loop bound to its buffers
by the first run (``_runners.BoundRun``): each later run writes its start into the bound row and calls the loop,
its arguments neither checked nor gathered again. Every such run is the run a fresh preparation makes (to the last
bit), its outputs its own (the next run does not overwrite them); a run that fails, or outgrows its pilot's budget,
is made and reported the general way; threads sharing the problem each get their own run."""

import importlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.integrators import BKMM, Status
from geomech.systems import CanonicalSystem
from geomech.systems.control import StructurePreservingControl
from geomech.systems.nonholonomic_examples import chaplygin_sleigh
from geomech.systems.rotors import RotorBody

_continuous = importlib.import_module("geomech.integrators.nonholonomic._continuous")
_prepared = importlib.import_module("geomech.integrators._prepared")

_q, _p, _w = sp.symbols("q p w", real=True)
OSCILLATOR = CanonicalSystem.from_expression(_p**2 / 2 + _w**2 * _q**2 / 2, [_q], [_p], substitutions={_w: 1.0})
SLEIGH_OPTIONS = dict(t_final=10.0, saveat=5, rtol=1e-11, atol=1e-13)


def _engine_calls(monkeypatch, module, *names) -> list:
    """The calls of the runners ``names`` of ``module`` (the general way of a run), counted."""
    calls: list = []
    for name in names:
        real = getattr(module, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            calls.append(_name)
            return _real(*args, **kwargs)

        monkeypatch.setattr(module, name, counted)
    return calls


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.states, b.states)
    assert set(a.quantities) == set(b.quantities)
    for key in a.quantities:
        np.testing.assert_array_equal(a.quantities[key], b.quantities[key])
    assert a.status == b.status and a.stats["n_rhs"] == b.stats["n_rhs"]


@pytest.mark.parametrize("solver", ["taylor", "DOP853"])
def test_a_prepared_sleighs_runs_from_its_bound_loop_are_fresh_preparations_runs(monkeypatch, solver):
    s = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    method = BKMM(solver=solver)
    starts = [[0.3, 0.5], [3.0, 5.0], [-1.0, 2.0], [0.3, 0.5], [0.0, -0.7]]
    fresh = [gm.prepare(s, method, **SLEIGH_OPTIONS).solve(p0=p0) for p0 in starts]
    calls = _engine_calls(monkeypatch, _continuous, "run_taylor", "run_embedded")
    prepared = gm.prepare(s, method, **SLEIGH_OPTIONS)
    runs = [prepared.solve(p0=p0) for p0 in starts]
    assert len(calls) == 1  # the first run bound its loop; every later one started there
    kept = [sol.states.copy() for sol in runs]
    for p0, sol, ref, states in zip(starts, runs, fresh, kept):
        _same(sol, ref)
        np.testing.assert_array_equal(sol.states, states)  # not overwritten by the runs after it
        # and the physics, independently: the coasting sleigh keeps its energy, its momentum at t0 the one given
        energy = sol.quantities["energy"]
        np.testing.assert_allclose(energy, energy[0], rtol=1e-9, atol=0)
        np.testing.assert_allclose(sol.quantities["momentum"][0], p0, rtol=0, atol=1e-12 * max(1.0, np.abs(p0).max()))


def test_a_run_that_outgrows_the_pilot_or_fails_is_made_and_reported_the_general_way(monkeypatch):
    s = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    # DOP853 from p = (100, 160) takes more evaluations than the pilot's budget (2,000): the pilot spent, then the rest
    method = BKMM()
    starts = [[0.3, 0.5], [100.0, 160.0], [0.3, 0.5], [3.0, 5.0]]
    fresh = [gm.prepare(s, method, **SLEIGH_OPTIONS).solve(p0=p0) for p0 in starts]
    assert fresh[1].stats["n_rhs"] > 2000
    calls = _engine_calls(monkeypatch, _continuous, "run_embedded")
    prepared = gm.prepare(s, method, **SLEIGH_OPTIONS)
    for p0, ref in zip(starts, fresh):
        _same(prepared.solve(p0=p0), ref)
    assert len(calls) == 4  # the first run; the long one's pilot and rest; the next binds again; the last is bound
    # a budget too small for one start: that run fails as a fresh preparation's does, the others are unaffected
    limited = dict(SLEIGH_OPTIONS, max_evaluations=1000, raise_on_failure=False)
    prepared = gm.prepare(s, method, **limited)
    for p0 in ([0.3, 0.5], [100.0, 160.0], [0.3, 0.5]):
        sol, ref = prepared.solve(p0=p0), gm.prepare(s, method, **limited).solve(p0=p0)
        _same(sol, ref)
        assert sol.message == ref.message
    assert sol.success and ref.success
    failed = prepared.solve(p0=[100.0, 160.0])
    assert failed.status == Status.BUDGET_EXHAUSTED and "max_evaluations" in failed.message
    assert np.isnan(failed.states[-1]).all()


def test_threads_sharing_a_prepared_problem_each_get_their_own_run():
    s = chaplygin_sleigh(m=1.5, I_c=0.4, a=0.6)
    method = BKMM(solver="taylor")
    rng = np.random.default_rng(5)
    starts = rng.normal(size=(40, 2))
    serial = [gm.prepare(s, method, **SLEIGH_OPTIONS).solve(p0=p0) for p0 in starts]
    prepared = gm.prepare(s, method, **SLEIGH_OPTIONS)
    prepared.solve(p0=[0.3, 0.5])  # bound
    with ThreadPoolExecutor(max_workers=4) as pool:
        runs = list(pool.map(lambda p0: prepared.solve(p0=p0), starts))
    for sol, ref in zip(runs, serial):
        _same(sol, ref)


@pytest.mark.parametrize("method, runner", [("dop853", "run_embedded"), ("taylor", "run_taylor")])
def test_a_prepared_oscillators_runs_from_their_bound_loops_are_the_exact_motion(monkeypatch, method, runner):
    options = dict(t_final=3.0, saveat=7, rtol=1e-12, atol=1e-12)
    starts = [(1.0, 0.0, 1.0), (0.0, 2.0, 1.0), (-0.5, 0.7, 3.0), (0.2, 0.1, 1.0), (1.0, 1.0, 3.0)]
    fresh = [gm.prepare(OSCILLATOR, method, **options).solve(y0=[q0, p0], parameters={"w": w}) for q0, p0, w in starts]
    calls = _engine_calls(monkeypatch, _prepared, runner)
    prepared = gm.prepare(OSCILLATOR, method, **options)
    t = np.linspace(0.0, 3.0, 7)
    runs = []
    for (q0, p0, w), ref in zip(starts, fresh):
        sol = prepared.solve(y0=[q0, p0], parameters={"w": w})
        q = q0 * np.cos(w * t) + p0 / w * np.sin(w * t)
        p = -q0 * w * np.sin(w * t) + p0 * np.cos(w * t)
        scale = max(abs(q0), abs(p0) / w)
        np.testing.assert_allclose(sol.states[:, 0], q, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(sol.states[:, 1], p, rtol=0, atol=1e-9 * scale * w)
        _same(sol, ref)
        runs.append((sol, sol.states.copy()))
    assert len(calls) == 2  # one bound loop for each value of w
    for sol, states in runs:
        np.testing.assert_array_equal(sol.states, states)


def test_a_prepared_body_with_rotors_observes_its_bound_runs_energy_and_torques():
    body = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    control = StructurePreservingControl.diagonal(body, ["2*tan(v/G)"] * 3, parameters={"G": 2.0})
    kw = dict(t_final=4.0, rtol=1e-12, atol=1e-12, tau=control)
    rng = np.random.default_rng(9)
    m0, Gamma0 = rng.normal(size=(4, 3)), 0.1 * rng.normal(size=(4, 3))
    R0 = np.eye(3)
    # more saved states than a small run observes as Python: the observation compiled (or loaded from the cache)
    gm.solve(body, "taylor", m0=m0[0], R0=R0, Gamma0=Gamma0[0], **dict(kw, saveat=4001))
    kw = dict(kw, saveat=5, attitude=True)
    fresh = [gm.prepare(body, "taylor", **kw).solve(m0=m, R0=R0, Gamma0=G) for m, G in zip(m0, Gamma0)]
    prepared = gm.prepare(body, "taylor", **kw)
    runs = [prepared.solve(m0=m, R0=R0, Gamma0=G) for m, G in zip(m0, Gamma0)]
    (bound,) = prepared.bound.values()
    assert bound.then is not None  # the observation ran bound to the loop's outputs
    for sol, ref in zip(runs, fresh):
        _same(sol, ref)
        assert {"energy", "tau"} <= set(sol.quantities)
        # the observed energy is the body's free Hamiltonian at the states (its own Python, another route); the
        # spatial momentum R m is conserved (the rotors' torques are internal)
        m, Gam = sol.states[:, :3], sol.states[:, 12:15]
        np.testing.assert_allclose(sol.energy, body.hamiltonian(m, Gam), rtol=1e-12, atol=0)
        spatial = sol.quantities["spatial_momentum"]
        np.testing.assert_allclose(spatial, np.broadcast_to(spatial[0], spatial.shape), rtol=0, atol=1e-9)


def test_a_long_output_is_not_kept_for_a_bound_run():
    # a run saving more than BOUND_SIZE numbers is made the general way each time: its problem keeps no second copy
    prepared = gm.prepare(OSCILLATOR, "dop853", t_final=3.0, saveat=60_001, rtol=1e-10, atol=1e-10)
    for q0 in (1.0, 0.5):
        sol = prepared.solve(y0=[q0, 0.0])
        np.testing.assert_allclose(sol.states[:, 0], q0 * np.cos(sol.t), rtol=0, atol=1e-8)
    assert not prepared.bound
    small = gm.prepare(OSCILLATOR, "dop853", t_final=3.0, saveat=6, rtol=1e-10, atol=1e-10)
    small.solve(y0=[1.0, 0.0])
    assert len(small.bound) == 1
