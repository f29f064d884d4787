"""A body with rotors through every method for an ODE: the equations and a torque law given by formulas compile
(the body's inertias and the law's numbers read at run time), a law of Python code runs the same loops in Python.
Checked against scipy on the plain-numpy equations (an independent route), by the invariants of the open loop
(the spatial momentum R m for any torque, Gamma - phi(m) under a structure-preserving control), and by orders."""

import numpy as np
import pytest

import geomech as gm
from geomech.integrators import IncompatibleMethodError, _observe
from geomech.lie import so3
from geomech.systems.control import StructurePreservingControl
from geomech.systems.rotors import RotorBody

BODY = RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
CONTROL = StructurePreservingControl.diagonal(BODY, ["2*tan(v/G)"] * 3, parameters={"G": 2.0}, p=[0.01, 0.02, -0.01])
M0 = np.array([0.4, 1.0, -0.3])
R0 = so3.exp([0.2, -0.4, 1.0])
GAIT = gm.Gait.from_expressions(["0.05*sin(t)", "0.05*cos(0.7*t)", "-0.02"])


def gait_torque(t, R, m, gamma, Gamma):
    return np.array([0.05 * np.sin(t), 0.05 * np.cos(0.7 * t), -0.02])


def closed_loop(method, t_final=20.0, **kw):
    return gm.solve(
        BODY,
        method,
        t_final=t_final,
        saveat=np.linspace(0.0, t_final, 11),
        m0=M0,
        Gamma0=CONTROL.rotor_momentum(M0),
        R0=R0,
        tau=CONTROL,
        **kw,
    )


@pytest.fixture(scope="module")
def reference():
    # scipy's DOP853 on the numpy equations and the control's own feedback (the Python route)
    return closed_loop("solve_ivp", rtol=1e-13, atol=1e-13, backend="python")


@pytest.mark.parametrize(
    "method, options, tol",
    [
        ("dop853", {"rtol": 1e-12, "atol": 1e-12}, 1e-9),
        ("dopri5", {"rtol": 1e-11, "atol": 1e-11}, 1e-8),
        ("taylor", {"rtol": 1e-12, "atol": 1e-12}, 1e-9),
        ("rk4", {"h": 0.01}, 1e-8),
        ("gauss_legendre_3", {"h": 0.05}, 1e-9),
        ("implicit_midpoint", {"h": 0.002}, 1e-5),
        ("solve_ivp", {"rtol": 1e-12, "atol": 1e-12}, 1e-9),
    ],
)
def test_the_compiled_closed_loop_agrees_with_scipy_on_the_numpy_equations(reference, method, options, tol):
    sol = closed_loop(method, **options)
    assert sol.stats["backend"] == "numba" and sol.layout == "rotor"
    assert sol.states.shape == reference.states.shape == (11, 18)
    assert np.abs(sol.states - reference.states).max() < tol
    # the torques along the run are the control's feedback at the saved states
    np.testing.assert_allclose(sol.tau, CONTROL.feedback(sol.m, sol.Gamma), rtol=0, atol=1e-14)
    # the structure-preserving control keeps Gamma - phi(m) (its p) to the method's accuracy
    p = CONTROL.conserved_p(sol.m, sol.Gamma)
    assert np.abs(p - [0.01, 0.02, -0.01]).max() < tol


def test_gauss_legendre_keeps_the_spatial_momentum_where_rk4_does_not():
    # R m is conserved by the open loop under any internal torque; each component is a quadratic form in the state,
    # which the Gauss-Legendre methods keep exactly (up to round-off), a non-symplectic method only to its error
    # (|R m| is about 1; 500 steps of h = 0.4)
    runs = {k: closed_loop(k, t_final=200.0, h=0.4) for k in ("implicit_midpoint", "gauss_legendre_2", "rk4")}
    drift = {k: np.abs(s.spatial_momentum - s.spatial_momentum[0]).max() for k, s in runs.items()}
    assert max(drift["implicit_midpoint"], drift["gauss_legendre_2"]) < 1e-13 < 1e-10 < drift["rk4"]


@pytest.mark.parametrize(
    "method, order, steps, law", [("rk4", 4, (0.2, 0.1), "gait"), ("implicit_midpoint", 2, (0.1, 0.05), "control")]
)
def test_orders(method, order, steps, law):
    # the gait's torques read the time, appended to the state: RK4 keeps its order; the midpoint rule its own
    # under the feedback (its Jacobian compiled)
    if law == "gait":
        kw = dict(t_final=4.0, m0=M0, Gamma0=[0.05, -0.1, 0.2], R0=R0, tau=GAIT)
    else:
        kw = dict(t_final=4.0, m0=M0, Gamma0=CONTROL.rotor_momentum(M0), R0=R0, tau=CONTROL)
    exact = gm.solve(BODY, "dop853", rtol=1e-13, atol=1e-13, **kw).states[-1]
    errors = [np.abs(gm.solve(BODY, method, h=h, **kw).states[-1] - exact).max() for h in steps]
    assert abs(np.log2(errors[0] / errors[1]) - order) < 0.2


def test_a_gait_of_formulas_compiles_and_agrees_with_the_same_torques_as_python_code():
    kw = dict(t_final=10.0, saveat=np.linspace(0.0, 10.0, 21), m0=M0, Gamma0=[0.05, -0.1, 0.2], rtol=1e-12, atol=1e-12)
    compiled = gm.solve(BODY, "dop853", tau=GAIT, **kw)
    python = gm.solve(BODY, "dop853", tau=gait_torque, **kw)
    assert compiled.stats["backend"] == "numba" and python.stats["backend"] == "python"
    # the time is not part of the solution
    assert compiled.states.shape == python.states.shape == (21, 18)
    np.testing.assert_allclose(compiled.states, python.states, rtol=0, atol=1e-13)
    np.testing.assert_allclose(compiled.tau[:, 2], -0.02, rtol=0, atol=1e-15)
    # the motors' work: dH_f/dt = u . gamma_dot, integrated along the run
    rates = BODY.rotor_rates(compiled.m, compiled.Gamma)
    fine = gm.solve(BODY, "dop853", tau=GAIT, **{**kw, "saveat": np.linspace(0.0, 10.0, 2001)})
    power = np.sum(fine.tau * BODY.rotor_rates(fine.m, fine.Gamma), axis=-1)
    work = np.sum(0.5 * np.diff(fine.t) * (power[1:] + power[:-1]))
    assert abs(work) > 1e-3 and rates.shape == (21, 3)
    assert abs(fine.energy[-1] - fine.energy[0] - work) < 1e-6


def test_a_batch_is_its_members_one_by_one_and_inertias_share_one_compilation():
    rng = np.random.default_rng(7)
    m0 = M0 + 0.05 * rng.standard_normal((4, 3))
    batch = gm.solve(BODY, "rk4", h=0.02, t_final=5.0, m0=m0, Gamma0=CONTROL.rotor_momentum(m0), R0=R0, tau=CONTROL)
    assert batch.states.shape[0] == 4 and batch.tau.shape[:1] == (4,)
    for i in range(4):
        one = gm.solve(
            BODY, "rk4", h=0.02, t_final=5.0, m0=m0[i], Gamma0=CONTROL.rotor_momentum(m0[i]), R0=R0, tau=CONTROL
        )
        np.testing.assert_allclose(batch.states[i], one.states, rtol=0, atol=1e-14)
    # other inertias: the same compiled module (the values are read at run time), other dynamics
    heavier = BODY.with_parameters(lambda1=3.5, J2=0.25)
    control = StructurePreservingControl.diagonal(heavier, ["2*tan(v/G)"] * 3, parameters={"G": 2.0})
    from geomech.integrators._problem import make_problem
    from geomech.integrators._rotor import bind_torque

    modules = [
        bind_torque(make_problem(body, attitude=True), law).module(frozenset(), "auto")[0]
        for body, law in ((BODY, CONTROL), (heavier, control))
    ]
    assert modules[0] is modules[1]
    other = gm.solve(heavier, "rk4", h=0.02, t_final=5.0, m0=m0[0], Gamma0=control.rotor_momentum(m0[0]), tau=control)
    assert np.abs(other.m[-1] - batch.m[0, -1]).max() > 1e-3


def test_a_law_of_python_code_runs_explicit_methods_and_refuses_implicit_ones():
    kw = dict(t_final=2.0, m0=M0, Gamma0=[0.05, -0.1, 0.2], tau=gait_torque)
    python = gm.solve(BODY, "rk4", h=0.01, **kw)
    compiled = gm.solve(BODY, "rk4", h=0.01, **{**kw, "tau": GAIT})
    assert python.stats["backend"] == "python"
    np.testing.assert_allclose(python.states, compiled.states, rtol=0, atol=1e-13)
    with pytest.raises(IncompatibleMethodError, match="Jacobian"):
        gm.solve(BODY, "gauss_legendre_2", h=0.01, **kw)


def test_a_batch_of_inertias_is_the_bodies_built_with_them():
    # Monte Carlo over the body's inertias under the same control law: one compiled call, each member the body
    # built with its values (its own control law, whose feedback reads them), torques and energy included
    lam, J1 = np.array([2.6, 3.0, 3.4]), np.array([0.1, 0.15, 0.2])
    kw = dict(m0=M0, Gamma0=CONTROL.rotor_momentum(M0), t_final=10.0, saveat=3, rtol=1e-12, atol=1e-12)
    batch = gm.solve(BODY, "dop853", tau=CONTROL, parameters={"lambda1": lam, "J1": J1}, **kw)
    assert batch.states.shape == (3, 3, 18)
    for i in range(3):
        body = BODY.with_parameters(lambda1=lam[i], J1=J1[i])
        control = StructurePreservingControl.diagonal(
            body, ["2*tan(v/G)"] * 3, parameters={"G": 2.0}, p=[0.01, 0.02, -0.01]
        )
        one = gm.solve(body, "dop853", tau=control, **kw)
        np.testing.assert_allclose(batch.states[i], one.states, rtol=0, atol=1e-13)
        np.testing.assert_allclose(batch.energy[i], one.energy, rtol=0, atol=1e-13)
        np.testing.assert_allclose(batch.tau[i], one.tau, rtol=0, atol=1e-14)
    assert np.ptp(batch.tau[:, -1, 0]) > 1e-4  # the members' torques differ


def test_the_energy_and_torques_at_many_saved_states_are_the_body_and_control_own():
    """More saved states than the observation runs as Python: the generated observation compiled (or loaded), its
    energy and torques against the body's H_f and the control's feedback (their own Python), a batch of inertias
    each member's with its own values."""
    n_saved = _observe.PYTHON_ROWS + 1
    kw = dict(t_final=20.0, saveat=n_saved, rtol=1e-10, atol=1e-10, tau=CONTROL)
    sol = gm.solve(BODY, "dop853", m0=M0, Gamma0=CONTROL.rotor_momentum(M0), R0=R0, **kw)
    assert sol.energy.shape == (n_saved,) and sol.tau.shape == (n_saved, 3)
    np.testing.assert_allclose(sol.energy, BODY.hamiltonian(sol.m, sol.Gamma), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.tau, CONTROL.feedback(sol.m, sol.Gamma), rtol=0, atol=1e-13)
    assert np.ptp(np.abs(sol.tau)) > 1e-3  # torques that vary along the run
    lam1 = np.array([2.8, 3.3])
    batch = gm.solve(BODY, "dop853", m0=M0, Gamma0=np.zeros(3), parameters={"lambda1": lam1}, **kw)
    for i, value in enumerate(lam1):
        body = BODY.with_parameters(lambda1=value)
        np.testing.assert_allclose(batch.energy[i], body.hamiltonian(batch.m[i], batch.Gamma[i]), rtol=0, atol=1e-12)
    assert abs(batch.energy[0, 0] - batch.energy[1, 0]) > 1e-3  # each member with its own inertia
