"""Batches over parameter values: ``solve(system, method, parameters={name: array})`` runs one trajectory per value in
one compiled call (each trajectory reads its own row of parameters), checked member by member against the system
built with that value (an independent route: its own construction, its own formulas' numbers)."""

import numpy as np
import pytest

import geomech as gm
from geomech.errors import InputError

BODY = gm.RigidBody([3.0, 2.0, 1.0])
M0 = np.array([1.0, 0.3, 0.2])
I1 = np.linspace(2.2, 2.95, 4)


@pytest.mark.parametrize(
    "method, options",
    [
        ("rk4", {"h": 0.01}),
        ("dop853", {"rtol": 1e-11, "atol": 1e-11}),
        ("gauss_legendre_2", {"h": 0.02}),
        ("strang", {"h": 0.01}),
        ("lgvi", {"h": 0.01}),
        ("solve_ivp", {"rtol": 1e-10, "atol": 1e-10}),
    ],
)
def test_each_member_is_the_body_built_with_its_value(method, options):
    kw = dict(m0=M0, R0=np.eye(3), t_final=5.0, saveat=6, **options)
    batch = gm.solve(BODY, method, parameters={"I1": I1}, **kw)
    assert batch.states.shape == (4, 6, 12) and batch.batch_shape == (4,)
    np.testing.assert_array_equal(batch.parameters["I1"], I1)
    for i, value in enumerate(I1):
        one = gm.solve(gm.RigidBody([value, 2.0, 1.0]), method, **kw)
        np.testing.assert_allclose(batch.states[i], one.states, rtol=0, atol=1e-12)
        # the energy of each member with its own moments (with the body's I1 = 3 it would differ by O(0.1))
        np.testing.assert_allclose(batch.energy[i], one.energy, rtol=0, atol=1e-12)
    assert np.ptp(batch.energy[:, 0]) > 1e-2


def test_parameters_and_initial_states_broadcast_and_threads_change_nothing():
    m0 = np.array([[1.0, 0.3, 0.2], [0.2, 1.0, -0.4]])
    values = {"I1": I1[:, None], "I3": 1.1}
    batch = gm.solve(BODY, "rk4", m0=m0, h=0.01, t_final=3.0, saveat=4, parameters=values)
    assert batch.batch_shape == (4, 2)
    assert batch.parameters["I1"].shape == (4, 2) and batch.parameters["I3"].shape == (4, 2)
    for i in range(4):
        for j in range(2):
            one = gm.solve(gm.RigidBody([I1[i], 2.0, 1.1]), "rk4", m0=m0[j], h=0.01, t_final=3.0, saveat=4)
            np.testing.assert_allclose(batch.states[i, j], one.states, rtol=0, atol=1e-13)
    threaded = gm.solve(BODY, "rk4", m0=m0, h=0.01, t_final=3.0, saveat=4, parameters=values, threads=2)
    np.testing.assert_array_equal(threaded.states, batch.states)
    ds = batch.to_dataset()
    assert ds["I1"].dims == ("batch_0", "batch_1") and float(ds["I1"][2, 1]) == I1[2]


def test_a_canonical_system_built_from_a_formula_with_substituted_parameters(closed_loop_family):
    system = closed_loop_family(k=2.0)
    ks = np.array([1.5, 2.0, 2.5])
    batch = gm.solve(system, "implicit_midpoint", y0=[0.3, 0.2], h=0.01, t_final=5.0, saveat=6, parameters={"k": ks})
    for i, value in enumerate(ks):
        other = closed_loop_family(k=value)
        one = gm.solve(other, "implicit_midpoint", y0=[0.3, 0.2], h=0.01, t_final=5.0, saveat=6)
        np.testing.assert_allclose(batch.states[i], one.states, rtol=0, atol=1e-13)
    # each member's energy is its own H's, kept to the midpoint rule's accuracy
    assert np.ptp(batch.energy, axis=-1).max() < 1e-6
    assert np.ptp(system.hamiltonian(batch.states[0]), axis=-1) > 1e-3


def test_bad_parameter_batches_are_refused_with_the_reason():
    with pytest.raises(InputError, match=r"names \['I5'\].*parameters: \['I1', 'I2', 'I3'\]"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, parameters={"I5": [1.0]})
    with pytest.raises(InputError, match="triangle inequality"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, parameters={"I1": [2.5, 4.0]})
    with pytest.raises(InputError, match="positive"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, parameters={"I1": [2.5, -1.0]})
    with pytest.raises(InputError, match="finite"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, parameters={"I1": [np.nan]})
    with pytest.raises(InputError, match="broadcast"):
        gm.solve(BODY, "rk4", m0=[M0, M0, M0], h=0.1, t_final=1.0, parameters={"I1": [2.5, 2.6]})
    with pytest.raises(InputError, match="MoserVeselov takes the system's own"):
        gm.solve(BODY, "moser_veselov", m0=M0, h=0.1, t_final=1.0, parameters={"I1": [2.5]})
    with pytest.raises(InputError, match="compiled loops"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, parameters={"I1": [2.5]}, backend="python")
    rotors = gm.RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    with pytest.raises(InputError, match="with_parameters"):  # a torque law of Python code: not a formula
        gm.solve(
            rotors,
            "rk4",
            m0=M0,
            Gamma0=[0, 0, 0],
            h=0.1,
            t_final=1.0,
            tau=lambda *a: [0, 0, 0],
            parameters={"J1": [0.1]},
        )
