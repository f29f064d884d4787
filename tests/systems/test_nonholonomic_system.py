"""Nonholonomic systems with symmetry: groups in coordinates, parsing, invariance checks, input errors."""

import dataclasses

import numpy as np
import pytest
import sympy as sp

from geomech.errors import InputError, ShapeError, SymbolicError
from geomech.lie import S1, SE2, SE3, SO3, Rn, se2, se3, so3
from geomech.symbolic import GroupChart
from geomech.systems.nonholonomic import NonholonomicSystem

SNAKE_L = (
    "m/2*(x_dot**2+y_dot**2) + (J+J0+2*J1)/2*theta_dot**2 + J0*theta_dot*psi_dot + J0/2*psi_dot**2 + J1*phi_dot**2"
)
SNAKE_C = [
    "-sin(theta+phi)*x_dot + cos(theta+phi)*y_dot - r*cos(phi)*theta_dot",
    "-sin(theta-phi)*x_dot + cos(theta-phi)*y_dot + r*cos(phi)*theta_dot",
]


def _snake(**kw):
    args = dict(lagrangian=SNAKE_L, group=SE2("x", "y", "theta"), shape=["psi", "phi"], constraints=SNAKE_C)
    args.update(kw)
    return NonholonomicSystem.from_lagrangian(**args)


def _numeric_body_velocity(g_of_q, q, qd, log, h=1e-6):
    """g^{-1} dg/dt by a central difference of log(g(q)^{-1} g(q + t qd)), independent of the symbolic route."""
    g0 = g_of_q(q)
    gp, gm = g_of_q(q + h * qd), g_of_q(q - h * qd)
    return (log(np.linalg.inv(g0) @ gp) - log(np.linalg.inv(g0) @ gm)) / (2 * h)


@pytest.mark.parametrize(
    "group, numeric, log",
    [
        (
            SE2(),
            lambda q: np.array([[np.cos(q[2]), -np.sin(q[2]), q[0]], [np.sin(q[2]), np.cos(q[2]), q[1]], [0, 0, 1]]),
            se2.log,
        ),
        (SO3(seq="ZXZ"), lambda q: so3.rot_z(q[0]) @ so3.rot_x(q[1]) @ so3.rot_z(q[2]), so3.log),
        (
            SE3(seq="ZYX"),
            lambda q: np.block(
                [
                    [so3.rot_z(q[3]) @ so3.rot_y(q[4]) @ so3.rot_x(q[5]), q[:3, None]],
                    [np.zeros((1, 3)), np.ones((1, 1))],
                ]
            ),
            se3.log,
        ),
    ],
)
def test_body_velocity_matrix_against_finite_differences(group, numeric, log, rng):
    group = GroupChart(group)
    lam = sp.lambdify(group.coordinates, group.body_velocity_matrix)
    lam_inv = sp.lambdify(group.coordinates, group.body_velocity_inverse)
    for _ in range(3):
        q = rng.uniform(0.3, 1.2, group.dim)  # away from the gimbal lock of the Euler-angle charts
        qd = rng.uniform(-1.0, 1.0, group.dim)
        xi = np.asarray(lam(*q), float) @ qd
        np.testing.assert_allclose(xi, _numeric_body_velocity(numeric, q, qd, log), atol=1e-7)
        np.testing.assert_allclose(np.asarray(lam_inv(*q), float) @ xi, qd, atol=1e-12)


@pytest.mark.parametrize("group, ad", [(SE2(), se2.ad), (SO3(), so3.ad), (SE3(), se3.ad)])
def test_structure_constants_match_the_lie_module(group, ad, rng):
    C = np.array(GroupChart(group).structure_constants, dtype=float)  # C[a, b, d]
    for _ in range(3):
        xi, eta = rng.normal(size=group.dim), rng.normal(size=group.dim)
        np.testing.assert_allclose(np.einsum("abd,b,d->a", C, xi, eta), ad(xi) @ eta, atol=1e-12)
    # Jacobi identity of the constants: C^a_{be} C^e_{cd} + cyclic(b, c, d) = 0
    jac = np.einsum("abe,ecd->abcd", C, C) + np.einsum("ace,edb->abcd", C, C) + np.einsum("ade,ebc->abcd", C, C)
    assert np.abs(jac).max() < 1e-12


def test_products_are_block_diagonal_and_abelian_factors_commute():
    G = GroupChart(SE2("x", "y", "th") * S1("a") * Rn("u", "v"))
    assert G.dim == 6 and [s.name for s in G.coordinates] == ["x", "y", "th", "a", "u", "v"]
    C = np.array(G.structure_constants, dtype=float)
    assert np.abs(C[3:]).max() == 0 and np.abs(C[:, 3:]).max() == 0 and np.abs(C[:3, :3, :3]).max() == 1
    assert G.angles == (2, 3)


def test_snakeboard_from_strings_body_form_and_velocities():
    s = _snake()
    assert [p.name for p in s.parameter_symbols] == ["J", "J0", "J1", "m", "r"]
    assert s.shape_angles == (0, 1)
    x1, x2, x3 = s.xi
    J, J0, J1, m, r = s.parameter_symbols
    psid, phid = s.shape_dot
    expected = (
        m / 2 * (x1**2 + x2**2) + (J + J0 + 2 * J1) / 2 * x3**2 + J0 * x3 * psid + J0 / 2 * psid**2 + J1 * phid**2
    )
    assert sp.expand(s.body_lagrangian - expected) == 0
    Axi, Ar = s.body_constraints
    phi = s.shape[1]
    assert sp.simplify(
        Axi - sp.Matrix([[-sp.sin(phi), sp.cos(phi), -r * sp.cos(phi)], [sp.sin(phi), sp.cos(phi), r * sp.cos(phi)]])
    ) == sp.zeros(2, 3)
    assert Ar == sp.zeros(2, 2)


def test_dynamicsymbols_input_is_accepted():
    from sympy.physics.mechanics import dynamicsymbols

    x, y, th = dynamicsymbols("x y theta")
    t = sp.Symbol("t")
    m, I = sp.symbols("m I", positive=True)
    L = m / 2 * (x.diff(t) ** 2 + y.diff(t) ** 2) + I / 2 * th.diff(t) ** 2
    s = NonholonomicSystem.from_lagrangian(L, SE2(), (), [-sp.sin(th) * x.diff(t) + sp.cos(th) * y.diff(t)])
    assert s.c == 1 and {p.name for p in s.parameter_symbols} == {"m", "I"}
    xd, yd, thd = s.qdot
    P = {p.name: p for p in s.parameter_symbols}
    assert sp.expand(s.lagrangian - (P["m"] / 2 * (xd**2 + yd**2) + P["I"] / 2 * thd**2)) == 0
    # an acceleration is not a velocity: refused by name, not differentiated away
    with pytest.raises(SymbolicError, match="first derivatives of the coordinates"):
        NonholonomicSystem.from_lagrangian(L + x.diff(t, 2) * y.diff(t), SE2(), (), [])


def test_invariance_report_names_the_breaking_term():
    with pytest.raises(SymbolicError, match=r"g\*m\*y"):
        _snake(lagrangian=SNAKE_L + " - m*g*y")
    # An anisotropic translational inertia is not rotation invariant: the report shows the theta dependence.
    with pytest.raises(SymbolicError, match="sin\\(theta\\)"):
        _snake(lagrangian=SNAKE_L.replace("y_dot**2", "2*y_dot**2"))
    report = _snake(
        check=False, constraints=["-sin(phi)*x_dot + cos(theta+phi)*y_dot - r*cos(phi)*theta_dot", SNAKE_C[1]]
    ).check_invariance()
    assert report.lagrangian_invariant and not report.constraints_invariant and report.breaking_constraints == (0,)


def test_the_invariance_report_is_made_once_per_system_and_sampling(monkeypatch, tmp_path):
    """Building a system checks invariance and ``derive`` shows the report: the second asks for the kept one, and a
    later process (here: the same system built again, the disk cache in tmp_path) reads it from disk."""
    from geomech.systems import nonholonomic as nh

    monkeypatch.setenv("GEOMECH_CACHE_DIR", str(tmp_path))
    calls = []
    real = nh.invariance_report
    monkeypatch.setattr(nh, "invariance_report", lambda *a, **k: calls.append(k) or real(*a, **k))
    s = _snake(check=False)
    first = s.check_invariance()
    assert s.check_invariance() is first and len(calls) == 1
    other = s.check_invariance(samples=5)
    assert other.ok and len(calls) == 2 and calls[-1]["samples"] == 5
    again = _snake(check=False).check_invariance()
    assert again == first and len(calls) == 2
    broken = _snake(
        check=False, constraints=["-sin(phi)*x_dot + cos(theta+phi)*y_dot - r*cos(phi)*theta_dot", SNAKE_C[1]]
    )
    assert not broken.check_invariance().ok and len(calls) == 3


def test_rescaled_constraints_define_the_same_invariant_distribution():
    # Multiplying a one-form by a function of the group variables changes the form but not the distribution.
    scaled = [f"(2 + cos(x))*({SNAKE_C[0]})", SNAKE_C[1]]
    assert _snake(constraints=scaled).check_invariance().ok


@pytest.mark.parametrize(
    "constraint, match",
    [
        ("x_dot**2 - y_dot", "not linear homogeneous"),
        ("x_dot + 1", "velocity-free term"),
        ("sin(x_dot)", "not even polynomial"),
        ("x - y", "contains no velocity"),
    ],
)
def test_constraints_must_be_linear_homogeneous_one_forms(constraint, match):
    with pytest.raises(InputError, match=match):
        _snake(constraints=[constraint, SNAKE_C[1]])


def test_bad_descriptions_raise_clear_errors():
    with pytest.raises(InputError, match="distinct coordinate names"):
        _snake(shape=["theta", "phi"])
    with pytest.raises(ShapeError, match="5 coefficients"):
        _snake(constraints=[[1, 0, 0], SNAKE_C[1]])
    with pytest.raises(InputError, match="linearly dependent"):
        _snake(constraints=[SNAKE_C[0], f"2*({SNAKE_C[0]})"])
    with pytest.raises(SymbolicError, match="linear in the velocities|quadratic"):
        _snake(lagrangian=SNAKE_L + " + x_dot")
    with pytest.raises(InputError, match="dimension assumption"):
        _snake(constraints=[SNAKE_C[0], "psi_dot - phi_dot"])
    with pytest.raises(SymbolicError, match="positive definite on the constraint"):
        _snake(lagrangian="m/2*(x_dot**2+y_dot**2) + J1*phi_dot**2")
    with pytest.raises(InputError, match="parameters"):
        _snake(parameters={"mass": 1.0})
    with pytest.raises(InputError, match="Lie group"):
        _snake(group="SE7")


def test_parameter_values_are_checked_and_merged():
    s = _snake(parameters={"m": 1.0, "r": 0.5})
    with pytest.raises(InputError, match=r"\['J', 'J0', 'J1'\]"):
        s.parameter_values()
    s2 = s.with_parameters(J=0.18, J0=0.05, J1=0.01)
    assert s2 == s and hash(s2) == hash(s)
    values = {k.name: v for k, v in s2.parameter_values().items()}
    assert values == {"J": 0.18, "J0": 0.05, "J1": 0.01, "m": 1.0, "r": 0.5}
    with pytest.raises(InputError, match="Unknown parameter"):
        s.with_parameters(mass=2.0)


def test_energy_and_mass_matrix():
    s = _snake()
    M = s.mass_matrix
    assert M.shape == (5, 5) and sp.simplify(M - M.T) == sp.zeros(5, 5)
    assert sp.expand(s.energy - s.lagrangian) == 0  # no potential: E = T = L


@pytest.mark.parametrize(
    "lagrangian",
    [
        SNAKE_L,
        # products of sums, a shape-dependent metric, a potential and a mixed term left unexpanded
        "m/2*(x_dot*cos(theta) + y_dot*sin(theta) + r*phi_dot*cos(psi))**2 + J/2*(theta_dot + psi_dot)**2"
        " + J0/2*psi_dot**2 + J1/2*(1 + sin(phi)**2)*phi_dot**2 - m*r*cos(psi) + J0*theta_dot*psi_dot/(2 + cos(phi))",
    ],
)
def test_the_mass_matrix_is_the_hessian_of_the_lagrangian_in_the_velocities(lagrangian):
    """Read off the coefficients in one walk, against sympy's Hessian (equal after expansion); a Lagrangian with a
    velocity inside a function still gets its Hessian, and is refused by name as not mechanical."""
    s = _snake(lagrangian=lagrangian)
    H = sp.hessian(s.lagrangian, s.qdot)
    assert s.mass_matrix.shape == (5, 5)
    assert all(sp.expand(a - b) == 0 for a, b in zip(s.mass_matrix, H))
    assert not any(e.free_symbols & set(s.qdot) for e in s.mass_matrix)
    bad = dataclasses.replace(s, lagrangian=s.lagrangian + sp.sqrt(1 + s.qdot[0] ** 2))
    assert sp.simplify(bad.mass_matrix[0, 0] - H[0, 0] - 1 / (1 + s.qdot[0] ** 2) ** sp.Rational(3, 2)) == 0
    with pytest.raises(SymbolicError, match="not polynomial in the velocities"):
        _snake(lagrangian=SNAKE_L + " + sqrt(1 + x_dot**2)")


def test_a_shape_group_split_that_does_not_match_the_lagrangian_is_reported():
    # phi is used in L and the constraints but not declared: its velocity would silently become a parameter.
    with pytest.raises(InputError, match=r"\['phi_dot'\].*declare them"):
        _snake(shape=["psi"])
    with pytest.raises(InputError, match="Expected 3 coordinate names for SE\\(2\\)"):
        SE2("x", "y")


def test_single_letter_parameters_are_symbols_not_constants():
    s = _snake(lagrangian=SNAKE_L + " + 0*I*E")
    assert s.lagrangian.has(sp.Symbol("J0", real=True)) and not s.lagrangian.has(sp.I)
    sleigh = NonholonomicSystem.from_lagrangian(
        "m/2*(x_dot**2 + y_dot**2) + I/2*theta_dot**2", SE2(), (), ["-sin(theta)*x_dot + cos(theta)*y_dot"]
    )
    assert {p.name for p in sleigh.parameter_symbols} == {"I", "m"}
