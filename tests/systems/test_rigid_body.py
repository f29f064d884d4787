import numpy as np
import pytest
from scipy.integrate import solve_ivp

from geomech import RigidBody
from geomech.errors import InputError


def test_rejects_bad_inertia():
    with pytest.raises(InputError, match="positive"):
        RigidBody([3.0, -2.0, 1.0])
    with pytest.raises(InputError, match="triangle inequality"):
        RigidBody([5.0, 2.0, 1.0])
    with pytest.raises(InputError, match="finite"):
        RigidBody([3.0, np.nan, 1.0])
    with pytest.raises(InputError, match=r"shape \(3,\)"):
        RigidBody([3.0, 2.0])
    with pytest.raises(InputError, match="symmetric"):
        RigidBody([[2.0, 0.1, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.5]])
    with pytest.raises(InputError, match="positive definite"):
        RigidBody([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    RigidBody([1.0, 1.0, 2.0])  # a lamina (equality) is a rigid body


def test_full_tensor_is_diagonalised_with_its_rotation(rng):
    Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    Q *= np.sign(np.linalg.det(Q))
    tensor = Q @ np.diag([3.0, 2.0, 1.5]) @ Q.T
    body = RigidBody(tensor)
    P = body.principal_axes
    np.testing.assert_allclose(P @ np.diag(body.principal_moments) @ P.T, tensor, atol=1e-13)
    assert np.linalg.det(P) == pytest.approx(1.0)
    m = rng.normal(size=(4, 3))
    principal = RigidBody(body.principal_moments)
    np.testing.assert_allclose(body.energy(m), principal.energy(body.to_principal(m)), rtol=1e-12)
    np.testing.assert_allclose(body.system.hamiltonian(m), body.energy(m), rtol=1e-12)
    np.testing.assert_allclose(body.from_principal(body.to_principal(m)), m, atol=1e-14)


def test_exact_solution_in_a_non_principal_frame(rng):
    Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    Q *= np.sign(np.linalg.det(Q))
    body = RigidBody(Q @ np.diag([3.0, 2.0, 1.2]) @ Q.T)
    m0 = np.array([0.4, -1.0, 0.7])
    exact = body.exact_solution(m0)
    t = np.linspace(0, 3 * exact.period, 31)
    sol = solve_ivp(
        lambda _t, m: body.euler_vector_field(m), (0, t[-1]), m0, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=t
    )
    np.testing.assert_allclose(exact.momentum(t), sol.y.T, atol=1e-9)
