import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from geomech import LeftInvariantSystem
from geomech.errors import ConvergenceError, InputError, ShapeError, SingularityError, SymbolicError

m1, m2, m3 = sp.symbols("m1 m2 m3")
a, c = sp.symbols("a c")
H_NONQUAD = m1**2 / (2 * a) + m2**2 / 4 + m3**2 / 2 + c * m3**4 + 0.2 * m1 * m2 * m3


def nonquad():
    return LeftInvariantSystem.from_expression(H_NONQUAD, {"a": 3.0, "c": 0.3})


def fd_grad(f, m, h=1e-6):
    return np.stack([(f(m + h * e) - f(m - h * e)) / (2 * h) for e in np.eye(3)], -1)


def test_gradient_and_hessian_match_finite_differences(rng):
    sys = nonquad()
    m = rng.normal(size=(7, 3))
    np.testing.assert_allclose(sys.gradient(m), fd_grad(sys.hamiltonian, m), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(sys.hessian(m), fd_grad(sys.gradient, m), rtol=1e-6, atol=1e-7)


def test_batch_shapes_broadcast_constant_entries(rng):
    sys = LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 4 + m3**2 / 6)
    m = rng.normal(size=(2, 5, 3))
    assert sys.hamiltonian(m).shape == (2, 5)
    assert sys.gradient(m).shape == (2, 5, 3)
    assert sys.hessian(m).shape == (2, 5, 3, 3)
    np.testing.assert_allclose(sys.hessian(m)[1, 3], np.diag([1, 1 / 2, 1 / 3]))


def test_spatial_momentum_energy_and_casimir_conserved_by_the_flow(rng):
    """Lemma 1's vector field (R' = R hat(grad H), m' = m x grad H) conserves p = R m (Corollary 1),
    H and |m|^2: a wrong sign in either equation breaks the first."""
    sys = nonquad()
    m0 = rng.normal(size=3)
    R0 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    R0 *= np.sign(np.linalg.det(R0))

    def rhs(_t, y):
        R, m = y[:9].reshape(3, 3), y[9:]
        dR, dm = sys.vector_field(R, m)
        return np.concatenate([dR.ravel(), dm])

    sol = solve_ivp(rhs, (0, 5), np.concatenate([R0.ravel(), m0]), method="DOP853", rtol=1e-12, atol=1e-12)
    R, m = sol.y[:9, -1].reshape(3, 3), sol.y[9:, -1]
    assert np.abs(m - m0).max() > 1e-2  # the motion is not trivial
    np.testing.assert_allclose(sys.spatial_momentum(R, m), R0 @ m0, atol=1e-9)
    np.testing.assert_allclose(sys.hamiltonian(m), sys.hamiltonian(m0), rtol=1e-10)
    np.testing.assert_allclose(sys.casimir(m), sys.casimir(m0), rtol=1e-10)


def test_callable_system_agrees_with_formula(rng):
    ref = nonquad()
    sys = LeftInvariantSystem.from_callable(ref.hamiltonian, ref.gradient, name="callable")
    m = rng.normal(size=(4, 3))
    np.testing.assert_allclose(sys.euler_vector_field(m), ref.euler_vector_field(m), rtol=1e-13)
    np.testing.assert_allclose(sys.hessian(m), ref.hessian(m), rtol=1e-6, atol=1e-8)
    assert not sys.hessian_is_exact and sys.hyperregularity().status == "unknown"
    with pytest.raises(SymbolicError, match="needs a formula"):
        sys.latex()


def test_inverse_legendre_round_trip_and_singular_hessian(rng):
    sys = nonquad()
    m = rng.normal(size=(5, 3)) * 0.5
    np.testing.assert_allclose(sys.inverse_legendre(sys.legendre(m), m_guess=m * 0.9), m, atol=1e-12)
    flat = LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 2)
    assert flat.hyperregularity().status == "no"
    assert not flat.is_hyperregular_at([1.0, 2.0, 3.0])
    with pytest.raises(SingularityError, match="not hyperregular"):
        flat.inverse_legendre([1.0, 1.0, 0.5])
    assert LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 4 + m3**2 / 6).hyperregularity().status == "yes"


def test_inverse_legendre_reports_non_convergence():
    # grad H = (m1^3, m2, m3) reaches 1 only at m1 = 1; from m1 = 0.01 Newton first overshoots to
    # about 3000 and then needs some 20 steps back
    sys = LeftInvariantSystem.from_expression(m1**4 / 4 + m2**2 / 2 + m3**2 / 2)
    with pytest.raises(ConvergenceError, match="did not converge"):
        sys.inverse_legendre([1.0, 0.0, 0.0], m_guess=[0.01, 0.0, 0.0], max_iter=5)


def test_input_errors_name_the_problem():
    with pytest.raises(SymbolicError, match=r"\['a', 'c'\]"):
        LeftInvariantSystem.from_expression(H_NONQUAD)
    with pytest.raises(SymbolicError, match="do not appear"):
        LeftInvariantSystem.from_expression(m1**2, {"b": 1.0})
    with pytest.raises(SymbolicError, match="finite"):
        LeftInvariantSystem.from_expression(H_NONQUAD, {"a": float("nan"), "c": 1.0})
    with pytest.raises(SymbolicError, match=r"unknown function\(s\) \['foo'\]"):
        LeftInvariantSystem.from_expression("m1**2 + foo(m2)")
    with pytest.raises(ShapeError, match=r"Expected `m` to have shape \(\.\.\., 3\), got \(4,\)"):
        nonquad().hamiltonian([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(InputError, match="finite"):
        nonquad().gradient([1.0, np.inf, 0.0])
    with pytest.raises(SymbolicError, match="parse"):
        LeftInvariantSystem.from_expression("m1**2 +* m2")


def test_string_formula_and_json():
    sys = LeftInvariantSystem.from_expression("m1**2/2 + m2**2/4 + m3**2/(2*I3)", {"I3": 1.5}, name="toy")
    assert sys.to_json()["parameters"] == {"I3": 1.5}
    assert "I_{3}" in sys.latex()
    np.testing.assert_allclose(sys.hamiltonian([1.0, 2.0, 3.0]), 0.5 + 1.0 + 3.0)


def test_with_parameters_is_the_system_built_with_those_values(rng):
    H = "m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3) + c*m1*m2*m3"
    base = LeftInvariantSystem.from_expression(H, {"I1": 3.0, "I2": 2.0, "I3": 1.0, "c": 0.1}, name="top")
    other = base.with_parameters(I2=5.0, c=-0.3)
    direct = LeftInvariantSystem.from_expression(H, {"I1": 3.0, "I2": 5.0, "I3": 1.0, "c": -0.3})
    m = rng.normal(size=(4, 3))
    np.testing.assert_allclose(other.hamiltonian(m), direct.hamiltonian(m), rtol=1e-14)
    np.testing.assert_allclose(other.hessian(m), direct.hessian(m), rtol=1e-14)
    assert other.name == "top" and base.parameters["I2"] == 2.0  # the original is unchanged
    with pytest.raises(InputError, match=r"Unknown parameter\(s\) \['J'\]"):
        base.with_parameters(J=1.0)
    with pytest.raises(InputError, match="finite|number"):
        base.with_parameters(I1=float("nan"))
    callable_system = LeftInvariantSystem.from_callable(lambda m: (m**2).sum(-1) / 2, lambda m: m)
    with pytest.raises(InputError, match="from_expression"):
        callable_system.with_parameters(I1=1.0)


def test_hyperregularity_of_non_quadratic_hamiltonians_is_decided():
    # separable with a quartic that softens: d^2H/dm3^2 = 1 - 6 m3^2 / 5 vanishes at |m3| = sqrt(5/6)
    soft = LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 - m3**4 / 10).hyperregularity()
    assert soft.status == "no" and abs(abs(soft.points[2]) - np.sqrt(5 / 6)) < 1e-12
    # separable and stiffening: f'' = 1 + 6 m3^2 / 5 > 0, f' = m3 + 2 m3^3 / 5 onto R: a diffeomorphism
    stiff = LeftInvariantSystem.from_expression(m1**2 / 6 + m2**2 / 4 + m3**2 / 2 + m3**4 / 10).hyperregularity()
    assert stiff.status == "yes" and "diffeomorphism" in stiff.where
    # strictly convex but grad H bounded (log cosh): no momentum for |omega_1| >= 1
    bounded = LeftInvariantSystem.from_expression("log(cosh(m1)) + m2**2/4 + m3**2/2").hyperregularity()
    assert bounded.status == "no" and "not onto" in bounded.where
    # not separable, with a singular surface: H = |m|^2/2 - (m1 m2)^2/4 has det D^2H = 0 where the bisection
    # lands; checked against the Hessian there
    mixed = LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 2 + m3**2 / 2 - (m1 * m2) ** 2 / 4)
    rep = mixed.hyperregularity(radius=3.0)
    assert rep.status == "no"
    eig = np.linalg.eigvalsh(mixed.hessian(np.array(rep.points)))
    assert np.abs(eig).min() < 1e-8 * np.abs(eig).max()
    # not separable and convex on the sampled ball: unknown, with the radius and the reason
    convex = LeftInvariantSystem.from_expression(m1**2 / 2 + m2**2 / 2 + m3**2 / 2 + (m1 * m2) ** 2 / 4)
    rep = convex.hyperregularity(radius=2.0)
    assert rep.status == "unknown" and "|m| <= 2" in rep.where and "positive" in rep.where
