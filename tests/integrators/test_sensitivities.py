"""The variational equations through ``solve(..., sensitivities=...)``: the state transition matrix and the
sensitivities to parameters, checked against central differences of separate runs (and of separately built
systems), and against identities they must satisfy whatever the integrator: a Hamiltonian flow's Jacobian is
symplectic, and the gradient of a conserved quantity is carried by it (grad C(y(t))^T Phi(t) = grad C(y0)^T)."""

import numpy as np
import pytest

import geomech as gm
from geomech.errors import InputError
from geomech.integrators import IncompatibleMethodError

BODY = gm.RigidBody([2.5, 2.0, 1.0])
M0 = np.array([1.0, 0.3, 0.2])
TIGHT = dict(rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("method, options", [("rk4", {"h": 0.01}), ("dop853", {"rtol": 1e-12, "atol": 1e-12})])
def test_the_canonical_flow_map_is_symplectic_and_carries_the_energy_gradient(closed_loop_family, method, options):
    system = closed_loop_family()
    sol = gm.solve(system, method, y0=[0.3, 0.2], t_final=20.0, saveat=5, sensitivities=True, **options)
    Phi = sol.quantities["stm"]
    assert Phi.shape == (5, 2, 2) and sol.states.shape == (5, 2)
    J = np.array([[0.0, 1.0], [-1.0, 0.0]])
    scale = np.abs(Phi).max() ** 2
    assert scale > 4.0  # the flow shears: the test is not about the identity
    for k in range(5):
        assert np.abs(Phi[k].T @ J @ Phi[k] - J).max() < 1e-10 * scale
        np.testing.assert_allclose(
            system.gradient(sol.states[k]) @ Phi[k], system.gradient(sol.states[0]), rtol=0, atol=1e-9
        )


def test_the_rigid_body_matrix_and_parameter_sensitivity_against_central_differences():
    # (the attitude's equations too: the slow test of a body with rotors)
    kw = dict(m0=M0, t_final=10.0, saveat=3)
    sol = gm.solve(BODY, "dop853", sensitivities=("I1", "I3"), rtol=1e-12, atol=1e-12, **kw)
    Phi, S = sol.quantities["stm"][-1], sol.quantities["parameter_sensitivity"][-1]
    assert Phi.shape == (3, 3) and S.shape == (3, 2)
    eps = 1e-6
    for j in range(3):
        e = np.eye(3)[j] * eps
        plus = gm.solve(BODY, "dop853", **{**kw, "m0": M0 + e}, **TIGHT).states[-1]
        minus = gm.solve(BODY, "dop853", **{**kw, "m0": M0 - e}, **TIGHT).states[-1]
        np.testing.assert_allclose(Phi[:, j], (plus - minus) / (2 * eps), rtol=0, atol=1e-7 * np.abs(Phi).max())
    for column, moments in ((0, lambda x: [2.5 + x, 2.0, 1.0]), (1, lambda x: [2.5, 2.0, 1.0 + x])):
        plus = gm.solve(gm.RigidBody(moments(eps)), "dop853", **kw, **TIGHT).states[-1]
        minus = gm.solve(gm.RigidBody(moments(-eps)), "dop853", **kw, **TIGHT).states[-1]
        assert np.abs(S[:, column]).max() > 0.1
        np.testing.assert_allclose(S[:, column], (plus - minus) / (2 * eps), rtol=0, atol=1e-7 * np.abs(S).max())
    # |m|^2 is a Casimir: m(t)^T dm(t)/dm0 = m0^T, and dm(t)/dI1 is orthogonal to m(t)
    m = sol.m[-1]
    np.testing.assert_allclose(m @ Phi[:3, :3], M0, rtol=0, atol=1e-10)
    np.testing.assert_allclose(m @ S[:3], 0.0, rtol=0, atol=1e-10)


def test_a_batch_of_parameters_and_states_with_sensitivities_is_its_members():
    values = np.array([2.2, 2.6])
    batch = gm.solve(
        BODY, "rk4", m0=M0, h=0.01, t_final=3.0, saveat=4, parameters={"I1": values}, sensitivities=("I2",)
    )
    assert batch.quantities["stm"].shape == (2, 4, 3, 3) and batch.quantities["parameter_sensitivity"].shape == (
        2,
        4,
        3,
        1,
    )
    for i, v in enumerate(values):
        one = gm.solve(gm.RigidBody([v, 2.0, 1.0]), "rk4", m0=M0, h=0.01, t_final=3.0, saveat=4, sensitivities=("I2",))
        for name in ("stm", "parameter_sensitivity"):
            np.testing.assert_allclose(batch.quantities[name][i], one.quantities[name], rtol=0, atol=1e-13)
    ds = batch.to_dataset()
    assert ds["stm"].dims == ("batch_0", "t", "stm_0", "stm_1")


def test_the_python_backend_integrates_the_same_equations(closed_loop_family):
    kw = dict(y0=[0.3, 0.2], t_final=5.0, h=0.01, saveat=3, sensitivities=("k",))
    compiled = gm.solve(closed_loop_family(), "rk4", **kw)
    python = gm.solve(closed_loop_family(), "rk4", backend="python", **kw)
    assert python.stats["backend"] == "python"
    for name in ("stm", "parameter_sensitivity"):
        np.testing.assert_allclose(compiled.quantities[name], python.quantities[name], rtol=0, atol=1e-12)


def test_sensitivities_are_refused_where_they_do_not_apply():
    with pytest.raises(IncompatibleMethodError, match="explicit method"):
        gm.solve(BODY, "gauss_legendre_2", m0=M0, h=0.1, t_final=1.0, sensitivities=True)
    with pytest.raises(InputError, match=r"names of parameters of free rigid body \(\['I1', 'I2', 'I3'\]\)"):
        gm.solve(BODY, "rk4", m0=M0, h=0.1, t_final=1.0, sensitivities=("I4",))
    rotors = gm.RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    with pytest.raises(InputError, match="does not read the time"):
        gm.solve(
            rotors,
            "rk4",
            m0=M0,
            Gamma0=[0.0, 0.0, 0.0],
            h=0.1,
            t_final=1.0,
            tau=lambda *a: [0, 0, 0],
            sensitivities=True,
        )


@pytest.mark.slow
def test_a_body_with_rotors_under_its_control_law():
    from geomech.systems.control import StructurePreservingControl

    body = gm.RotorBody.three_rotors([3.0, 2.0, 1.2], [0.1, 0.2, 0.3])
    control = StructurePreservingControl.diagonal(body, ["2*tan(v/G)"] * 3, parameters={"G": 2.0})
    m0 = np.array([0.4, 1.0, -0.3])
    kw = dict(Gamma0=control.rotor_momentum(m0), tau=control, t_final=10.0, saveat=2)
    sol = gm.solve(body, "dop853", m0=m0, sensitivities=True, rtol=1e-12, atol=1e-12, **kw)
    Phi = sol.quantities["stm"][-1]
    assert Phi.shape == (18, 18)
    eps = 1e-6
    for j in range(3):
        e = np.eye(3)[j] * eps
        plus = gm.solve(body, "dop853", m0=m0 + e, **kw, **TIGHT).states[-1]
        minus = gm.solve(body, "dop853", m0=m0 - e, **kw, **TIGHT).states[-1]
        np.testing.assert_allclose(Phi[:, j], (plus - minus) / (2 * eps), rtol=0, atol=1e-7 * np.abs(Phi).max())
    # R m is conserved under internal torques: its gradient is carried by the flow
    R, m = sol.R[-1], sol.m[-1]
    for i in range(3):
        grad_t = np.zeros(18)
        grad_t[:3] = R[i]  # d(R m)_i / dm
        grad_t[3:12] = np.outer(np.eye(3)[i], m).ravel()  # d(R m)_i / dR (row-major)
        grad_0 = np.zeros(18)
        grad_0[:3] = np.eye(3)[i]
        grad_0[3:12] = np.outer(np.eye(3)[i], m0).ravel()
        np.testing.assert_allclose(grad_t @ Phi, grad_0, rtol=0, atol=1e-9)
