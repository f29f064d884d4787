"""3-1-3 Euler-angle canonical coordinates of T*SO(3) (Lemma 2 of the Serret-Andoyer paper): formulas
re-derived here with sympy from R = Rz(phi) Rx(theta) Rz(psi), canonicity checked against Euler's
equation for quadratic, non-quadratic and callable Hamiltonians, and the paper's misprints documented."""

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st

from geomech.errors import InputError, ShapeError, SingularityError, SymbolicError
from geomech.lie import euler, so3
from geomech.reduction.euler_coordinates import EulerCoordinates
from geomech.systems import LeftInvariantSystem, RigidBody

INERTIA = (3.0, 2.0, 1.0)
m1, m2, m3 = sp.symbols("m1 m2 m3", real=True)
H_QUARTIC = m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + sp.Rational(3, 10) * m3**4 + sp.Rational(1, 5) * m1 * m2 * m3


def quartic():
    return LeftInvariantSystem.from_expression(H_QUARTIC, name="quartic")


def callable_system():
    """The quartic H again, but as Python callables: no formula for the symbolic side."""

    def H(m):
        m = np.asarray(m)
        return (
            m[..., 0] ** 2 / 6
            + m[..., 1] ** 2 / 4
            + m[..., 2] ** 2 / 2
            + 0.3 * m[..., 2] ** 4
            + 0.2 * m[..., 0] * m[..., 1] * m[..., 2]
        )

    def grad(m):
        m = np.asarray(m)
        x, y, z = m[..., 0], m[..., 1], m[..., 2]
        return np.stack([x / 3 + 0.2 * y * z, y / 2 + 0.2 * x * z, z + 1.2 * z**3 + 0.2 * x * y], -1)

    return LeftInvariantSystem.from_callable(H, grad, name="quartic (callable)")


SYSTEMS = {
    "rigid body": lambda: RigidBody(INERTIA),
    "quartic": quartic,
    "callable": callable_system,
}


# -- independent symbolic derivation ------------------------------------------------------------------
PHI_, TH_, PSI_ = sp.symbols("phi theta psi", real=True)
P_, T_, S_ = sp.symbols("Phi Theta Psi", real=True)


def _rz(a):
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def _rx(a):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


@pytest.fixture(scope="module")
def derived():
    """omega from R^T R' = hat(omega), momenta m . d omega / d rate (eq. 15), their inverse (eq. 6)."""
    rates = sp.symbols("phidot thetadot psidot", real=True)
    R = _rz(PHI_) * _rx(TH_) * _rz(PSI_)
    Rdot = sum((R.diff(a) * r for a, r in zip((PHI_, TH_, PSI_), rates)), sp.zeros(3, 3))
    pythagoras = {sp.cos(a) ** 2: 1 - sp.sin(a) ** 2 for a in (PHI_, TH_, PSI_)}
    W = (R.T * Rdot).applyfunc(lambda e: sp.expand(sp.expand(e).subs(pythagoras)))
    assert W + W.T == sp.zeros(3, 3)
    omega = sp.Matrix([W[2, 1], W[0, 2], W[1, 0]])
    m = sp.Matrix([m1, m2, m3])
    momenta = [sp.expand(m.dot(omega.diff(r))) for r in rates]
    sol = sp.solve([P_ - momenta[0], T_ - momenta[1], S_ - momenta[2]], [m1, m2, m3], dict=True)[0]
    m_of_q = sp.Matrix([sp.simplify(sol[s]) for s in (m1, m2, m3)])
    return {"omega": omega, "rates": rates, "momenta": momenta, "m_of_q": m_of_q, "R": _rz(PHI_) * _rx(TH_) * _rz(PSI_)}


def random_q(rng, n):
    return np.column_stack(
        [
            rng.uniform(-np.pi, np.pi, n),
            rng.uniform(0.2, np.pi - 0.2, n),
            rng.uniform(-np.pi, np.pi, n),
            rng.normal(size=(n, 3)),
        ]
    )


def test_eq2_eq15_eq6_match_the_symbolic_derivation(derived, rng):
    ec = EulerCoordinates(RigidBody(INERTIA))
    q = random_q(rng, 20)
    rates = rng.normal(size=(20, 3))
    f_omega = sp.lambdify([PHI_, TH_, PSI_, *derived["rates"]], list(derived["omega"]))
    assert np.allclose(
        euler.angular_velocity(q[:, :3], rates, "ZXZ", frame="body"),
        np.array(f_omega(*q[:, :3].T, *rates.T)).T,
        rtol=0,
        atol=1e-13,
    )
    f_m = sp.lambdify([PHI_, TH_, PSI_, P_, T_, S_], list(derived["m_of_q"]))
    m_ref = np.array(f_m(*q.T), dtype=float).T
    assert np.allclose(ec.body_momentum(q), m_ref, rtol=0, atol=1e-12)
    # eq. 15 on the same points gives the momenta back
    f_P = sp.lambdify([PHI_, TH_, PSI_, m1, m2, m3], derived["momenta"])
    assert np.allclose(np.array(f_P(*q[:, :3].T, *m_ref.T)).T, q[:, 3:], atol=1e-12)
    # exact Jacobian of eq. 6 against sympy's
    J = sp.Matrix(derived["m_of_q"]).jacobian([PHI_, TH_, PSI_, P_, T_, S_])
    f_J = sp.lambdify([PHI_, TH_, PSI_, P_, T_, S_], J.tolist())
    J_ref = np.stack([np.broadcast_to(np.asarray(x, float), (20,)) for row in f_J(*q.T) for x in row], -1)
    assert np.allclose(ec.momentum_jacobian(q), J_ref.reshape(20, 3, 6), atol=1e-11)


def test_rotation_matrix_is_eq1(derived, rng):
    a = np.array([0.3, 1.1, -2.0])
    R_sym = np.array(derived["R"].subs({PHI_: a[0], TH_: a[1], PSI_: a[2]}), dtype=float)
    R, _ = EulerCoordinates(quartic()).inverse(np.concatenate([a, [0.1, 0.2, 0.3]]))
    assert np.allclose(R, R_sym, atol=1e-15)
    assert np.allclose(R_sym, so3.rot_z(a[0]) @ so3.rot_x(a[1]) @ so3.rot_z(a[2]), atol=1e-15)


# -- eq. 5, eq. 4 and eq. 16: the paper's formulas and misprints ---------------------------------------
def test_free_body_hamiltonian_simplifies_to_eq5():
    ec = EulerCoordinates(RigidBody(INERTIA))
    K = ec.canonical_hamiltonian()
    I1, I2, I3 = sp.symbols("I1 I2 I3", real=True)
    X = (P_ - S_ * sp.cos(TH_)) / sp.sin(TH_)
    s, c = sp.sin(PSI_), sp.cos(PSI_)
    eq5 = (
        sp.Rational(1, 2) * (s**2 / I1 + c**2 / I2) * X**2
        + S_**2 / (2 * I3)
        + sp.Rational(1, 2) * (c**2 / I1 + s**2 / I2) * T_**2
        + (1 / I1 - 1 / I2) * X * T_ * s * c
    )
    assert sp.simplify(K - eq5) == 0
    assert PHI_ not in K.free_symbols  # Remark 1: phi is cyclic
    q = np.array([0.4, 1.0, -0.7, 0.5, -1.2, 0.8])
    val = float(eq5.subs(dict(zip((PHI_, TH_, PSI_, P_, T_, S_, I1, I2, I3), (*q, *INERTIA)))))
    assert ec.hamiltonian(q) == pytest.approx(val, rel=1e-14)
    Kn = ec.canonical_hamiltonian(substitute_parameters=True)
    assert not (Kn.free_symbols - set(ec.symbols))


def test_free_body_momenta_from_rates_are_eq4_with_4c_corrected(rng):
    """Eq. (4c) is printed with cos(phi) in its second term; the Legendre transform gives cos(psi)."""
    ec = EulerCoordinates(RigidBody(INERTIA))
    I1, I2, I3 = INERTIA
    angles = np.array([0.9, 1.1, 0.4])  # cos(phi) != cos(psi)
    fd, td, pd = rates = np.array([0.7, -0.3, 1.5])
    ph, th, ps = angles
    P = ec.momenta_from_rates(angles, rates)
    eq4a = (
        I1 * (fd * np.sin(ps) * np.sin(th) + td * np.cos(ps)) * np.sin(th) * np.sin(ps)
        + I2 * (fd * np.cos(ps) * np.sin(th) - td * np.sin(ps)) * np.sin(th) * np.cos(ps)
        + I3 * (fd * np.cos(th) + pd) * np.cos(th)
    )
    eq4b = I3 * (fd * np.cos(th) + pd)
    eq4c = I1 * (fd * np.sin(th) * np.sin(ps) + td * np.cos(ps)) * np.cos(ps) - I2 * (
        fd * np.cos(ps) * np.sin(th) - td * np.sin(ps)
    ) * np.sin(ps)
    printed_4c = I1 * (fd * np.sin(th) * np.sin(ps) + td * np.cos(ps)) * np.cos(ps) - I2 * (
        fd * np.cos(ph) * np.sin(th) - td * np.sin(ps)
    ) * np.sin(ps)
    assert np.allclose(P, [eq4a, eq4c, eq4b], rtol=1e-12)
    assert abs(P[1] - printed_4c) > 0.1


def test_spatial_momentum_is_R_m_and_printed_eq16b_is_not(rng):
    ec = EulerCoordinates(quartic())
    q = random_q(rng, 50)
    R, m = ec.inverse(q)
    p = np.einsum("...ij,...j->...i", R, m)
    assert np.allclose(ec.spatial_momentum(q), p, atol=1e-12)
    phi, th, _, Phi, Th, Psi = q.T
    Y = (Psi - Phi * np.cos(th)) / np.sin(th)
    printed_16b = -Th * np.sin(phi) - Y * np.cos(phi)
    eq7b = Th * np.sin(phi) - Y * np.cos(phi)
    assert np.allclose(eq7b, p[:, 1], atol=1e-12)
    # the misprint is off by 2 Theta sin(phi), which is far from 0 at these random points
    assert np.allclose(p[:, 1] - printed_16b, 2 * Th * np.sin(phi), atol=1e-12)
    assert not np.allclose(printed_16b, p[:, 1], atol=1e-3)
    assert np.allclose(q[:, 3], p[:, 2])  # eq. 16c: Phi = p3


# -- canonicity ---------------------------------------------------------------------------------------
def _jacobian(f, x, h=1e-3):
    """Five-point central differences of f: R^n -> R^k (error ~ h^4)."""
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        cols.append((-f(x + 2 * e) + 8 * f(x + e) - 8 * f(x - e) + f(x - 2 * e)) / (12 * h))
    return np.stack(cols, -1)


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_hamiltons_equations_push_forward_to_eulers_equation(name, rng):
    """(R, m)' = D(inverse)(q) q' with q' from vector_field must be (R hat(grad H), m x grad H)."""
    sys_ = SYSTEMS[name]()
    ec = EulerCoordinates(sys_)
    system = ec.system

    def flat_inverse(q):
        R, m = ec.inverse(q)
        return np.concatenate([R.ravel(), m])

    for _ in range(6):
        R = so3.exp(rng.normal(size=3))
        m = rng.normal(size=3)
        q = ec.forward(R, m)
        if np.sin(q[1]) < 0.15:
            continue
        assert np.allclose(ec.inverse(q)[1], m, atol=1e-12)
        qdot = ec.vector_field(q)
        pushed = _jacobian(flat_inverse, q) @ qdot
        Rdot, mdot = system.vector_field(R, m)
        assert np.allclose(pushed[:9], Rdot.ravel(), atol=1e-9)
        assert np.allclose(pushed[9:], mdot, atol=1e-9)
        assert qdot[3] == 0.0  # phi cyclic: Phi = p3 conserved


@pytest.mark.parametrize("name", ["rigid body", "quartic"])
def test_symbolic_hamilton_equations_agree_with_the_numeric_chain_rule(name, rng):
    ec = EulerCoordinates(SYSTEMS[name]())
    q = random_q(rng, 30)
    assert np.allclose(ec.compiled_vector_field()(q), ec.vector_field(q), rtol=1e-12, atol=1e-12)
    eqs = ec.hamilton_equations()
    assert len(eqs) == 6 and eqs[3] == 0
    cs = ec.canonical_system()
    assert np.allclose(cs.vector_field(q), ec.vector_field(q), rtol=1e-12, atol=1e-12)
    assert np.allclose(cs.hamiltonian(q), ec.hamiltonian(q), rtol=1e-13)


def test_callable_system_numeric_side_works_and_symbolic_side_says_it_needs_a_formula(rng):
    ec = EulerCoordinates(callable_system())
    ref = EulerCoordinates(quartic())
    q = random_q(rng, 10)
    assert np.allclose(ec.vector_field(q), ref.vector_field(q), rtol=1e-12, atol=1e-12)
    assert np.allclose(ec.canonical_system().vector_field(q), ref.vector_field(q), atol=1e-12)
    with pytest.raises(SymbolicError, match="formula"):
        ec.canonical_hamiltonian()
    with pytest.raises(SymbolicError):
        ec.hamilton_equations()


# -- the Lagrangian side ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["rigid body", "quartic"])
def test_angle_rates_and_momenta_from_rates_invert_each_other(name, rng):
    ec = EulerCoordinates(SYSTEMS[name]())
    q = random_q(rng, 8) * np.array([1, 1, 1, 0.5, 0.5, 0.5])
    rates = ec.euler_angle_rates(q)
    # Hamilton's q' = dK/dP is the kinematic inversion of eq. 2
    assert np.allclose(rates, ec.vector_field(q)[:, :3], rtol=1e-12, atol=1e-12)
    m = ec.body_momentum(q)
    assert np.allclose(euler.angular_velocity(q[:, :3], rates, "ZXZ", frame="body"), ec.system.gradient(m), atol=1e-12)
    P = ec.momenta_from_rates(q[:, :3], rates, m_guess=m + 1e-3)
    assert np.allclose(P, q[:, 3:], atol=1e-10)


# -- round trips and singularities --------------------------------------------------------------------
@given(
    st.floats(-3.1, 3.1),
    st.sampled_from([1e-6, 1e-3, np.pi - 1e-6]) | st.floats(0.05, 3.09),
    st.floats(-3.1, 3.1),
    st.floats(-5, 5),
    st.floats(-5, 5),
    st.floats(-5, 5),
)
def test_round_trip(phi, theta, psi, Phi, Theta, Psi):
    ec = EulerCoordinates(RigidBody(INERTIA))
    q = np.array([phi, theta, psi, Phi, Theta, Psi])
    R, m = ec.inverse(q)
    q2 = ec.forward(R, m)
    scale = 1 + np.abs(m).max()
    assert np.allclose(q2[:3], q[:3], atol=1e-9 / np.sin(theta))
    assert np.allclose(q2[3:], q[3:], atol=1e-12 * scale)
    R2, m2_ = ec.inverse(q2)
    assert np.allclose(R2, R, atol=1e-12) and np.allclose(m2_, m, atol=1e-9 * scale)


def test_batches_broadcast(rng):
    ec = EulerCoordinates(quartic())
    R = so3.exp(rng.normal(size=(4, 1, 3)))
    m = rng.normal(size=(5, 3))
    q = ec.forward(R, m)
    assert q.shape == (4, 5, 6)
    assert ec.vector_field(q).shape == (4, 5, 6) and ec.hamiltonian(q).shape == (4, 5)
    R2, m2 = ec.inverse(q)
    assert R2.shape == (4, 5, 3, 3) and np.allclose(m2, np.broadcast_to(m, (4, 5, 3)))


@pytest.mark.parametrize("theta", [0.0, np.pi, -0.0, 2 * np.pi])
def test_gimbal_lock_raises_singularity_error(theta):
    ec = EulerCoordinates(RigidBody(INERTIA))
    q = np.array([0.1, theta, 0.2, 1.0, 0.5, 0.3])
    for f in (ec.inverse, ec.body_momentum, ec.spatial_momentum, ec.vector_field, ec.euler_angle_rates):
        with pytest.raises(SingularityError, match="theta = 0 or pi"):
            f(q)
    R = so3.rot_z(0.3) @ so3.rot_x(theta) @ so3.rot_z(-1.0)
    with pytest.raises(SingularityError, match="theta = 0 or pi"):
        ec.forward(R, [1.0, 2.0, 3.0])


def test_bad_input_raises_the_right_errors():
    ec = EulerCoordinates(RigidBody(INERTIA))
    with pytest.raises(InputError, match="finite"):
        ec.inverse([0.1, np.nan, 0.2, 1.0, 0.5, 0.3])
    with pytest.raises(ShapeError, match=r"\(\.\.\., 6\)"):
        ec.vector_field(np.zeros(5))
    with pytest.raises(ShapeError, match=r"\(\.\.\., 3\)"):
        ec.forward(np.eye(3), [1.0, 2.0])
    with pytest.raises(InputError, match="rotation matrix"):
        ec.forward(2 * np.eye(3), [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="finite"):
        ec.forward(np.eye(3), [1.0, np.inf, 3.0])
    with pytest.raises(InputError):
        EulerCoordinates("not a system")
    with pytest.raises(AttributeError):
        ec.system = None
