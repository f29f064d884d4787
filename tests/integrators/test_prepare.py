"""A prepared problem: ``prepare(system, method, ...)`` made once, ``.solve(...)`` from many starts and parameter
values. Each call is checked against something it could differ from: an exact solution, a body built with the
value, a batch of members in one compiled call, a gait's closed form, a fresh preparation after calls with other
values (what a call keeps from an earlier one would show there)."""

import importlib

import numpy as np
import pytest
import sympy as sp

import geomech as gm
from geomech.errors import InputError
from geomech.integrators import BKMM, Event, IncompatibleMethodError, Prepared
from geomech.systems import CanonicalSystem
from geomech.systems.control import StructurePreservingControl
from geomech.systems.nonholonomic_examples import snakeboard
from geomech.systems.rotors import RotorBody

_q, _p, _w = sp.symbols("q p w", real=True)
OSCILLATOR = CanonicalSystem.from_expression(_p**2 / 2 + _w**2 * _q**2 / 2, [_q], [_p], substitutions={_w: 1.0})


@pytest.mark.parametrize(
    "method, options", [("dop853", {"rtol": 1e-12, "atol": 1e-12}), ("gauss_legendre_3", {"h": 0.05})]
)
def test_a_prepared_oscillator_from_many_starts_and_frequencies_is_the_exact_solution(method, options):
    prepared = gm.prepare(OSCILLATOR, method, t_final=2.0, saveat=5, **options)
    assert isinstance(prepared, Prepared) and "outputs" in repr(prepared)
    t = np.linspace(0.0, 2.0, 5)
    for q0, p0, w in [(1.0, 0.0, 1.0), (0.0, 2.0, 3.0), (-0.5, 0.7, 0.5), (1.0, 0.0, 1.0)]:
        sol = prepared.solve(y0=[q0, p0], parameters={"w": w})
        q = q0 * np.cos(w * t) + p0 / w * np.sin(w * t)
        p = -q0 * w * np.sin(w * t) + p0 * np.cos(w * t)
        # the method's error at these steps and tolerances is about 1e-11 of the unit amplitude
        np.testing.assert_allclose(sol.states[:, 0], q, rtol=0, atol=1e-9)
        np.testing.assert_allclose(sol.states[:, 1], p, rtol=0, atol=1e-9)


def test_a_prepared_body_with_attitude_takes_R0_each_call_and_refuses_it_otherwise():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    with_attitude = gm.prepare(body, "dop853", t_final=3.0, saveat=4, rtol=1e-11, atol=1e-11, attitude=True)
    rng = np.random.default_rng(3)
    for _ in range(3):
        m0 = rng.normal(size=3)
        R0, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        R0 *= np.sign(np.linalg.det(R0))
        sol = with_attitude.solve(m0=m0, R0=R0)
        # the spatial momentum R m is conserved: an independent check of the attitude and the momentum together
        p = np.einsum("tij,tj->ti", sol.states[:, 3:].reshape(-1, 3, 3), sol.states[:, :3])
        np.testing.assert_allclose(p, np.broadcast_to(R0 @ m0, p.shape), rtol=0, atol=1e-9 * np.abs(m0).max())
    with pytest.raises(InputError, match="attitude=True: give `R0`"):
        with_attitude.solve(m0=[1.0, 0.0, 0.0])
    without = gm.prepare(body, "dop853", t_final=3.0, rtol=1e-11, atol=1e-11)
    with pytest.raises(InputError, match="prepare it with attitude=True"):
        without.solve(m0=[1.0, 0.0, 0.0], R0=np.eye(3))


def test_what_a_prepared_problem_cannot_run_is_refused_before_any_start():
    body = gm.RigidBody([3.0, 2.0, 1.0])
    with pytest.raises(IncompatibleMethodError):
        gm.prepare(body, "stormer_verlet", t_final=1.0, h=0.1)
    with pytest.raises(InputError, match="attitude"):
        gm.prepare(body, "dop853", t_final=1.0, attitude="yes")
    with pytest.raises(InputError, match="shapes"):
        gm.prepare(body, "dop853", t_final=1.0, shapes={"psi": "sin(t)"})
    with pytest.raises(InputError, match="tau"):
        gm.prepare(body, "dop853", t_final=1.0, tau={"psi": "t"})
    with pytest.raises(InputError, match="max_newton"):
        gm.prepare(body, "implicit_midpoint", t_final=1.0, h=0.1, max_newton=0)
    with pytest.raises(InputError, match="`R0` applies to left-invariant systems"):
        gm.prepare(OSCILLATOR, "dop853", t_final=1.0).solve(y0=[1.0, 0.0], R0=np.eye(3))


def test_a_prepared_body_with_rotors_is_each_member_of_a_batch():
    body = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    control = StructurePreservingControl.diagonal(body, ["2*tan(v/G)"] * 3, parameters={"G": 2.0})
    rng = np.random.default_rng(7)
    m0, Gamma0 = rng.normal(size=(4, 3)), 0.1 * rng.normal(size=(4, 3))
    kw = dict(t_final=4.0, saveat=5, rtol=1e-11, atol=1e-11, tau=control)
    batch = gm.solve(body, "dop853", m0=m0, Gamma0=Gamma0, **kw)
    prepared = gm.prepare(body, "dop853", **kw)
    for i in (2, 0, 3, 1):
        one = prepared.solve(m0=m0[i], Gamma0=Gamma0[i])
        np.testing.assert_allclose(one.states, batch.states[i], rtol=0, atol=1e-10)
        np.testing.assert_allclose(one.energy, batch.energy[i], rtol=0, atol=1e-10)


def test_a_prepared_gait_with_coefficients_is_its_values_at_every_call():
    """The gait psi = a sin(2 pi t) starts with the rate 2 pi a: a call that kept an earlier call's a would start
    (and end) elsewhere. Python's route reads the gait made with the call's values; the compiled batch reads every
    member's from its parameter row: the same members either way."""
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    kw = dict(t_final=0.5, saveat=3, rtol=1e-10, atol=1e-10, shapes={"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"})
    amplitudes = np.array([0.5, 1.0, 0.25])
    batch = gm.solve(s, BKMM(), parameters={"a": amplitudes}, **kw)
    python = gm.prepare(s, BKMM(), backend="python", **kw)
    compiled = gm.prepare(s, BKMM(solver="taylor"), **kw)
    for i in (0, 1, 2, 0, 1):
        a = float(amplitudes[i])
        for prepared in (python, compiled):
            sol = prepared.solve(parameters={"a": a})
            assert sol.parameters["m"] == 1.0
            np.testing.assert_allclose(sol.states, batch.states[i], rtol=0, atol=1e-8)
            # the prescribed shape and its rate are the gait's closed forms at the saved times
            psi, psidot = sol.states[:, s.k], sol.states[:, s.n + s.k]
            np.testing.assert_allclose(psi, a * np.sin(2 * np.pi * sol.t), rtol=0, atol=1e-12)
            np.testing.assert_allclose(psidot, 2 * np.pi * a * np.cos(2 * np.pi * sol.t), rtol=0, atol=1e-10)
    assert np.ptp(batch.states[:, -1, 0]) > 1e-3  # the members differ where they are compared


def test_a_prepared_gait_after_many_values_is_a_fresh_preparation():
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    gait = {"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}
    kw = dict(t_final=0.5, saveat=2, rtol=1e-10, atol=1e-10, shapes=dict(gait))
    prepared = gm.prepare(s, BKMM(), **kw)
    kw["shapes"]["psi"] = "0"  # the prepared problem keeps the gait it was given
    kw["shapes"] = gait
    values = np.linspace(0.1, 2.0, 20)  # more than the distinct values kept
    for a in values:
        prepared.solve(parameters={"a": float(a)}, rdot0={"phi": 0.0})
    for a in (values[0], values[-1]):
        again = prepared.solve(parameters={"a": float(a)})
        fresh = gm.prepare(s, BKMM(), **kw).solve(parameters={"a": float(a)})
        np.testing.assert_array_equal(again.states, fresh.states)
    with pytest.raises(InputError, match="neither parameters"):
        prepared.solve(parameters={"a": 1.0, "b": 2.0})
    with pytest.raises(InputError, match="Lagrangian system"):
        prepared.solve(m0=[1.0, 0.0, 0.0])


def test_a_prepared_problem_locates_its_events_at_every_call_whatever_the_coefficients():
    """psi = a sin(2 pi t) passes upwards through 0 at every whole t, whatever a: the events are the gait's, found
    at each call with that call's a (the events made once with the prepared problem, from the events given then)."""
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    events = {"back": Event("psi", direction=1)}
    prepared = gm.prepare(
        s,
        BKMM(solver="taylor"),
        t_final=3.5,
        saveat=2,
        rtol=1e-10,
        atol=1e-10,
        shapes={"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"},
        events=events,
    )
    events["phi"] = Event("phi")  # the prepared problem keeps the events it was given
    for a in (0.5, 1.2, 0.5):
        sol = prepared.solve(parameters={"a": a})
        assert set(sol.events) == {"back"}
        rows = sol.events["back"]
        np.testing.assert_allclose(rows[:, 1], [1.0, 2.0, 3.0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(rows[:, 2 + s.k], 0.0, rtol=0, atol=1e-9)  # psi there
        np.testing.assert_allclose(rows[:, 2 + s.n + s.k], 2 * np.pi * a, rtol=1e-9)  # its rate, a's


def _counting(monkeypatch) -> list:
    """``solve``'s preparations, counted: each call of ``prepare`` made inside ``solve`` appends its options."""
    solve_module = importlib.import_module("geomech.integrators.solve")  # (the package's name is the function)
    made: list = []
    real = solve_module.prepare

    def counted(system, method, **options):
        made.append(options)
        return real(system, method, **options)

    monkeypatch.setattr(solve_module, "prepare", counted)
    return made


def test_solve_in_a_loop_prepares_once_and_each_call_is_the_run_a_fresh_preparation_makes(monkeypatch):
    made = _counting(monkeypatch)
    s = CanonicalSystem.from_expression(_p**2 / 2 + _w**2 * _q**2 / 2, [_q], [_p], substitutions={_w: 1.0})
    runs = [gm.solve(s, "rk4", t_final=1.0, h=0.1, y0=[q0, 0.0], parameters={"w": w})
            for q0, w in [(1.0, 1.0), (0.5, 2.0), (1.0, 1.0)]]  # fmt: skip
    assert len(made) == 1  # one preparation for the three runs
    for (q0, w), sol in zip([(1.0, 1.0), (0.5, 2.0), (1.0, 1.0)], runs):
        fresh = gm.prepare(s, "rk4", t_final=1.0, h=0.1).solve(y0=[q0, 0.0], parameters={"w": w})
        np.testing.assert_array_equal(sol.y, fresh.y)
        # and RK4's error against the exact motion q0 cos(w t), O(h^4)
        np.testing.assert_allclose(sol.y[:, 0], q0 * np.cos(w * sol.t), rtol=0, atol=1e-3 * q0 * w**4)
    # another option, or the same value of another type, is another preparation
    gm.solve(s, "rk4", t_final=1.0, h=0.05, y0=[1.0, 0.0], backend="python")
    assert len(made) == 2
    gm.solve(s, "rk4", t_final=1.0, h=0.1, y0=[1.0, 0.0], backend="python", threads=1)
    with pytest.raises(InputError, match="threads"):
        gm.solve(s, "rk4", t_final=1.0, h=0.1, y0=[1.0, 0.0], backend="python", threads=True)


def test_solve_reads_an_array_of_times_again_where_it_changed_in_place(monkeypatch):
    made = _counting(monkeypatch)
    s = CanonicalSystem.from_expression(_p**2 / 2 + _q**2 / 2, [_q], [_p])
    saveat = np.array([0.0, 0.5, 1.0])
    first = gm.solve(s, "dop853", t_final=1.0, saveat=saveat, rtol=1e-10, atol=1e-12, y0=[1.0, 0.0])
    saveat[1] = 0.25
    second = gm.solve(s, "dop853", t_final=1.0, saveat=saveat, rtol=1e-10, atol=1e-12, y0=[1.0, 0.0])
    assert len(made) == 2
    np.testing.assert_array_equal(first.t, [0.0, 0.5, 1.0])
    np.testing.assert_array_equal(second.t, [0.0, 0.25, 1.0])
    np.testing.assert_allclose(second.y[:, 0], np.cos(second.t), rtol=0, atol=1e-8)


def test_a_gait_given_anew_with_the_same_formulas_is_the_same_preparation(monkeypatch):
    made = _counting(monkeypatch)
    s = snakeboard(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
    options = dict(t_final=0.5, saveat=3, rtol=1e-9, atol=1e-11)
    a = gm.solve(s, BKMM(), shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, **options)
    b = gm.solve(s, BKMM(), shapes={"psi": "sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, **options)
    c = gm.solve(s, BKMM(), shapes={"psi": "sin(2*pi*t)", "phi": "0.4*sin(2*pi*t)"}, **options)
    assert len(made) == 2
    np.testing.assert_array_equal(a.states, b.states)
    assert np.abs(c.states[-1] - a.states[-1]).max() > 1e-4  # the other gait was run, not the first one again


def test_solves_preparations_are_bounded_and_go_with_their_system(monkeypatch):
    import copy
    import gc
    import weakref

    solve_module = importlib.import_module("geomech.integrators.solve")
    made = _counting(monkeypatch)
    s = CanonicalSystem.from_expression(_p**2 / 2 + _q**2 / 2, [_q], [_p])
    for i in range(solve_module._KEPT + 3):
        gm.solve(s, "rk4", t_final=1.0, h=0.1 / (i + 1), y0=[1.0, 0.0], backend="python")
    assert len(vars(s)[solve_module._ATTRIBUTE]) == solve_module._KEPT
    gm.solve(s, "rk4", t_final=1.0, h=0.1, y0=[1.0, 0.0], backend="python")  # the oldest went first
    assert len(made) == solve_module._KEPT + 4
    # a long output grid is not kept with it
    monkeypatch.setattr(solve_module, "_KEPT_SIZE", 10)
    gm.solve(s, "rk4", t_final=1.0, h=0.01, y0=[1.0, 0.0], backend="python", saveat=11)
    gm.solve(s, "rk4", t_final=1.0, h=0.01, y0=[1.0, 0.0], backend="python", saveat=11)
    assert len(made) == solve_module._KEPT + 6
    # a copy of the system does not carry them (nor does a pickle: the same reduction)
    assert vars(s)[solve_module._ATTRIBUTE] and not vars(copy.deepcopy(s)).get(solve_module._ATTRIBUTE)
    held = weakref.ref(s)
    del s
    gc.collect()
    assert held() is None  # the problems it prepared did not keep the system alive
