"""Geometric and dynamic phases: closed forms, Stokes, reconstruction against direct simulations."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from geomech import RigidBody, solve  # noqa: E402
from geomech.analysis import (  # noqa: E402
    Gait,
    curvature_integral,
    decompose_displacement,
    geometric_phase,
    integrate_path,
    phase_history,
    phases,
    reconstruct,
    rigid_body_phase,
    spherical_polygon_area,
)
from geomech.errors import InputError, ShapeError, SingularityError  # noqa: E402
from geomech.lie import named_group, se2, so3  # noqa: E402
from geomech.systems import (  # noqa: E402
    planar_point_masses,
    planar_point_positions,
    spacecraft_with_rotors,
    three_link_chain,
    two_pinned_bodies,
)


@pytest.fixture(scope="module")
def pinned():
    return two_pinned_bodies(1.0, 3.0)


@pytest.fixture(scope="module")
def chain():
    return three_link_chain(origin="middle")


@pytest.fixture(scope="module")
def bodies():
    return planar_point_masses([1.0, 2.0, 1.5])


def random_loop(rng, center, scale, period, harmonics=3, winding=None):
    n = len(center)
    k = np.arange(1, harmonics + 1)[:, None]
    a = rng.normal(size=(harmonics, n)) * scale / k**2
    b = rng.normal(size=(harmonics, n)) * scale / k**2
    return Gait.from_fourier(center, a, b, period, winding=winding)


def simulate(system, q0, qd0, t, loop=None):
    """The Euler-Lagrange equations of the full Lagrangian in coordinates, the shapes prescribed by ``loop``:
    the direct route, independent of the connection."""
    t = np.asarray(t, dtype=float)
    return solve(
        system,
        "lagrange_dalembert",
        t0=t[0],
        t_final=t[-1],
        saveat=t,
        q0=q0,
        qdot0=qd0,
        shapes=loop,
        rtol=1e-12,
        atol=1e-12,
    )


def full_initial_state(system, loop, mu, g0):
    q0 = np.concatenate([g0, loop.r(0.0)])
    qd0 = np.concatenate([system.group_velocity(g0, loop.r(0.0), loop.rdot(0.0), mu), loop.rdot(0.0)])
    return q0, qd0


# -- two pinned bodies (section 2.2) --------------------------------------------------------------
@pytest.mark.parametrize("mu, turns", [(0.0, 1), (0.0, -2), (-2.5, -1), (1.7, 1)])
def test_pinned_bodies_closed_form(pinned, mu, turns):
    I1, I2, T = 1.0, 3.0, 5.5
    loop = Gait.from_expressions([f"2*pi*{turns}*t/5.5 + 0.4*sin(2*pi*t/5.5)**2"], T)
    ph = phases(pinned, loop, mu)
    # from the conservation law (I1 + I2) theta' + I2 psi' = mu (not the seed's printed closed form)
    want = -2 * np.pi * turns * I2 / (I1 + I2) + mu * T / (I1 + I2)
    assert ph.winding == (turns,)
    assert abs(ph.geometric - (-2 * np.pi * turns * I2 / (I1 + I2))) < 1e-12
    assert abs(ph.total - want) < 1e-10
    rec = reconstruct(pinned, loop, mu)
    assert abs(rec.path.g[-1, 0] - want) < 1e-9
    if mu != 0:
        printed = I2 / (I1 + I2) * (-2 * np.pi * turns + mu * T)  # the misprinted form differs
        assert abs(printed - want) > 0.1


def test_pinned_bodies_direct_simulation(pinned):
    loop = Gait.from_expressions(["2*pi*t/3 + 0.3*sin(4*pi*t/3)"], 3.0)
    q0, qd0 = full_initial_state(pinned, loop, np.array([0.8]), np.zeros(1))
    sol = simulate(pinned, q0, qd0, np.linspace(0, 3, 5), loop)
    assert abs(sol.q[-1, 0] - phases(pinned, loop, 0.8).total) < 1e-9


def test_phase_formula_equals_reconstruction_random_loops_pinned(pinned, rng):
    for _ in range(4):
        loop = random_loop(rng, [0.3], 1.0, rng.uniform(1, 4), winding=[int(rng.integers(-2, 3))])
        mu = rng.normal()
        ph = phases(pinned, loop, mu)
        rec = reconstruct(pinned, loop, mu, t_eval=np.array([0.0, loop.period]))
        assert abs(rec.path.g[-1, 0] - ph.total) < 1e-9


# -- the free rigid body (Montgomery) -------------------------------------------------------------
@pytest.mark.parametrize(
    "inertia, m0, R0",
    [
        ([3.0, 2.0, 1.0], [1.0, 0.3, 0.2], None),
        ([3.0, 2.0, 1.0], [0.2, 0.3, 1.0], None),
        ([3.0, 2.0, 1.0], [1.0, 0.1, -0.4], [0.4, -1.0, 2.0]),
        ([1.0, 2.0, 2.5], [-0.3, 0.9, 0.4], None),
        ([[3.0, 0.2, 0.0], [0.2, 2.0, 0.1], [0.0, 0.1, 1.5]], [0.2, 0.5, 1.0], [0.3, 1.0, 2.0]),
    ],
)
def test_montgomery_formula_against_direct_integration(inertia, m0, R0):
    res = rigid_body_phase(RigidBody(inertia), m0, R0=None if R0 is None else so3.exp(R0))
    assert abs(res.difference) < 1e-8
    assert abs(np.angle(np.exp(1j * (res.reconstructed_wrapped - res.direct_wrapped)))) < 1e-8
    assert res.attitude_residual < 1e-9
    assert res.geometric == -res.solid_angle
    assert abs(res.dynamic - 2 * res.energy * res.period / res.momentum) < 1e-12


def test_solid_angle_two_routes():
    body = RigidBody([3.0, 2.0, 1.0])
    for m0 in ([1.0, 0.3, 0.2], [0.2, 0.3, 1.0], [0.6, -0.8, 0.5]):
        res = rigid_body_phase(body, m0, direct=False, reconstructed=False)
        pole = res.pole_sign * np.eye(3)[res.axis]
        poly = spherical_polygon_area(res.momentum_curve(20001)[:-1], pole)
        assert abs(poly - res.solid_angle) < 1e-6


def test_axisymmetric_solid_angle_is_a_cap():
    # m circulates about e3 at constant m3: the cap has area 2 pi (1 - |m3|/G).
    res = rigid_body_phase(RigidBody([2.0, 2.0, 1.0]), [0.6, 0.0, 0.8])
    assert abs(abs(res.solid_angle) - 2 * np.pi * (1 - 0.8)) < 1e-12
    assert abs(res.difference) < 1e-8


def test_rigid_body_without_a_period_is_refused():
    with pytest.raises(InputError, match="periodic"):
        rigid_body_phase(RigidBody([3.0, 2.0, 1.0]), [0.0, 1.0, 0.0])


# -- the planar N-body ----------------------------------------------------------------------------
def test_planar_bodies_rotation_formula_vs_full_simulation(bodies):
    loop = Gait.from_fourier([1.2, 0.3, 0.9], [[0.2, 0.1, 0.0], [0.05, 0, 0.1]], [[0.0, 0.3, 0.2], [0, 0.05, 0]], 3.0)
    mu, g0 = np.array([0.4, -0.2, 0.8]), np.array([0.5, -1.0, 0.3])
    ph = phases(bodies, loop, mu, g0=g0)
    q0, qd0 = full_initial_state(bodies, loop, mu, g0)
    sol = simulate(bodies, q0, qd0, np.linspace(0, 3.0, 4), loop)
    assert abs(sol.q[-1, 2] - g0[2] - ph.total) < 1e-8
    rec = reconstruct(bodies, loop, mu, g0=g0, t_eval=np.linspace(0, 3.0, 4))
    np.testing.assert_allclose(rec.path.g, sol.q[:, :3], atol=1e-9)


def test_two_body_kepler_dynamic_phase_is_a_full_turn():
    # Kepler (k = 1): the relative vector sweeps exactly 2 pi per radial period (no apsidal precession);
    # the shape space is the distance alone, the connection vanishes, the whole phase is dynamic.
    system = planar_point_masses([1.0, 3.0])
    a, e, M = 1.3, 0.4, 4.0
    n = np.sqrt(M / a**3)
    T = 2 * np.pi / n

    def ecc_anomaly(t):
        E = n * t
        for _ in range(50):
            E -= (E - e * np.sin(E) - n * t) / (1 - e * np.cos(E))
        return E

    def rho(t):
        return np.array([a * (1 - e * np.cos(ecc_anomaly(t)))])

    def rhodot(t):
        E = ecc_anomaly(t)
        return np.array([a * e * np.sin(E) * n / (1 - e * np.cos(E))])

    loop = Gait.from_callable(rho, rhodot, T)
    m_red = 3.0 / 4.0
    L = m_red * np.sqrt(M * a * (1 - e**2))  # angular momentum of the relative orbit
    ph = phases(system, loop, [0.0, 0.0, L])
    assert abs(ph.geometric) < 1e-14
    assert abs(ph.total - 2 * np.pi) < 1e-8


@pytest.mark.slow  # a long verification run against Newton's equations
def test_reconstruction_vs_newtonian_three_body(bodies):
    # Free gravitational motion by Newton's law; the shape and momentum from it, g(t) reconstructed.
    m = np.array([1.0, 2.0, 1.5])

    def newton(_t, y):
        x = y[:6].reshape(3, 2)
        acc = np.zeros((3, 2))
        for i in range(3):
            for j in range(3):
                if i != j:
                    d = x[j] - x[i]
                    acc[i] += m[j] * d / np.linalg.norm(d) ** 3
        return np.concatenate([y[6:], acc.ravel()])

    x0 = np.array([[0, 0], [1.5, 0.2], [0.3, 1.4]], float)
    v0 = np.array([[0.1, -0.3], [0.2, 0.4], [-0.5, 0.1]])
    sol = solve_ivp(
        newton,
        (0, 2),
        np.concatenate([x0.ravel(), v0.ravel()]),
        method="DOP853",
        rtol=1e-13,
        atol=1e-13,
        dense_output=True,
    )
    J = np.array([[0.0, -1.0], [1.0, 0.0]])

    def state(t):
        y = sol.sol(t)
        x, v = y[:6].reshape(3, 2), y[6:].reshape(3, 2)
        r1, dr1 = x[1] - x[0], v[1] - v[0]
        th = np.arctan2(r1[1], r1[0])
        thd = (r1[0] * dr1[1] - r1[1] * dr1[0]) / (r1 @ r1)
        c2, dc2 = (m[0] * x[0] + m[1] * x[1]) / 3.0, (m[0] * v[0] + m[1] * v[1]) / 3.0
        R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
        s2 = R.T @ (x[2] - c2)
        ds2 = R.T @ (v[2] - dc2) - thd * J @ s2
        g = np.array([*(m @ x / m.sum()), th])
        return g, np.array([np.linalg.norm(r1), *s2]), np.array([r1 @ dr1 / np.linalg.norm(r1), *ds2])

    class Path:
        def r(self, t):
            return state(t)[1]

        def rdot(self, t):
            return state(t)[2]

    P = m @ v0
    L = float(np.sum(m * (x0[:, 0] * v0[:, 1] - x0[:, 1] * v0[:, 0])))
    te = np.linspace(0.1, 1.9, 10)
    rec = reconstruct(bodies, Path(), [P[0], P[1], L], g0=state(0.1)[0], t_eval=te)
    direct = np.array([state(t)[0] for t in te])
    d = rec.path.g - direct
    d[:, 2] = np.angle(np.exp(1j * d[:, 2]))
    assert np.abs(d).max() < 1e-9
    # and the Euler-Lagrange equations of the full Lagrangian in (x, y, theta, rho, a, b) agree with Newton
    g0, r0, rd0 = state(0.1)
    q0 = np.concatenate([g0, r0])
    qd0 = np.concatenate([bodies.group_velocity(g0, r0, rd0, [P[0], P[1], L]), rd0])
    sol_el = simulate(bodies, q0, qd0, te)
    X = planar_point_positions(bodies, sol_el.q)
    np.testing.assert_allclose(X, np.array([sol.sol(t)[:6].reshape(3, 2) for t in te]), atol=1e-9)


# -- the three-link chain (falling-cat mechanism) -------------------------------------------------
@pytest.mark.parametrize("L", [0.0, 0.7])
def test_three_link_reorientation_vs_simulation(chain, L):
    # Middle-link frame: with zero linear momentum the rotation obeys (2.3) in any body frame.
    loop = Gait.ellipse([0.4, -0.2], [0.9, 0.6], 2.0, tilt=0.3)
    mu = np.array([0.0, 0.0, L])
    ph = phases(chain, loop, mu)
    assert abs(ph.geometric) > 1e-3 and (ph.dynamic == 0) == (L == 0)
    q0, qd0 = full_initial_state(chain, loop, mu, np.zeros(3))
    sol = simulate(chain, q0, qd0, np.linspace(0, 2.0, 5), loop)
    assert abs(sol.q[-1, 2] - ph.total) < 1e-8


def test_stokes_equals_line_integral_on_random_loops(chain, rng):
    for _ in range(5):
        loop = random_loop(rng, rng.uniform(-0.8, 0.8, 2), 0.7, 1.0)
        line = geometric_phase(chain, loop)[2]
        area = curvature_integral(chain, loop)[2]
        assert abs(line + area) < 1e-10 * max(1.0, abs(line))


def test_stokes_counts_winding_number(chain):
    once = Gait.ellipse([0.2, 0.1], [0.5, 0.4], 1.0)
    twice = Gait.from_expressions(["0.2 + 0.5*cos(4*pi*t)", "0.1 + 0.4*sin(4*pi*t)"], 1.0)
    backwards = Gait.ellipse([0.2, 0.1], [0.5, 0.4], 1.0, clockwise=True)
    b1, b2, bb = (curvature_integral(chain, lp)[2] for lp in (once, twice, backwards))
    assert abs(b2 - 2 * b1) < 1e-11 and abs(bb + b1) < 1e-11 and abs(b1) > 1e-3


def test_phase_formula_vs_reconstruction_random_loops_and_momenta_se2(bodies, rng):
    # Centre-of-mass frame of the N-body: the rotation obeys (2.3) for any momentum, linear part included.
    for _ in range(3):
        loop = random_loop(rng, [1.2, 0.2, 0.8], 0.3, rng.uniform(0.5, 2))
        mu, g0 = rng.normal(size=3), rng.normal(size=3)
        ph = phases(bodies, loop, mu, g0=g0)
        rec = reconstruct(bodies, loop, mu, g0=g0, t_eval=np.array([0.0, loop.period]))
        assert abs(rec.path.g[-1, 2] - g0[2] - ph.total) < 1e-9


@pytest.mark.slow
def test_phase_formula_vs_reconstruction_random_loops_and_momenta_chain_com_frame(rng):
    system = three_link_chain(origin="com")
    for _ in range(3):
        loop = random_loop(rng, rng.uniform(-0.5, 0.5, 2), 0.6, rng.uniform(0.5, 2))
        mu, g0 = rng.normal(size=3), rng.normal(size=3)
        ph = phases(system, loop, mu, g0=g0)
        rec = reconstruct(system, loop, mu, g0=g0, t_eval=np.array([0.0, loop.period]))
        assert abs(rec.path.g[-1, 2] - g0[2] - ph.total) < 1e-9
        q0, qd0 = full_initial_state(system, loop, mu, g0)
        sol = simulate(system, q0, qd0, np.array([0.0, loop.period]), loop)
        assert abs(sol.q[-1, 2] - g0[2] - ph.total) < 1e-8


def test_so3_reconstruction_with_momentum_against_the_full_simulation(rng):
    # SO(3), non-abelian, G_mu not the whole group: no phase formula, the reconstruction on the group is the
    # answer. Checked against the Euler-Lagrange equations of the full system in Euler angles (another
    # route: no connection, no group integrator) along a random loop of the two rotor angles.
    s = spacecraft_with_rotors(inertia=(3.0, 2.0, 1.0), axes=((1, 0, 0), (0.3, 1, 0.2)), rotor_inertias=(0.2, 0.3))
    loop = random_loop(rng, [0.2, -0.1], 1.0, 3.0)
    mu = np.array([0.3, -0.5, 0.8])
    g0 = np.array([0.3, 1.2, -0.4])  # 3-1-3 Euler angles away from gimbal lock
    t = np.linspace(0.0, 3.0, 7)
    rec = reconstruct(s, loop, mu, g0=g0, t_eval=t)
    q0, qd0 = full_initial_state(s, loop, mu, g0)
    sol = simulate(s, q0, qd0, t, loop)
    R_sim = s.group.from_coordinates(sol.q[:, :3])
    np.testing.assert_allclose(rec.path.element, R_sim, atol=1e-9)
    assert np.abs(rec.path.element[-1] - R_sim[0]).max() > 0.1  # the attitude did move


def test_rkmk4_is_fourth_order(chain):
    loop = Gait.ellipse([0.4, -0.2], [0.9, 0.6], 2.0)
    mu = np.array([0.2, -0.3, 0.5])
    ref = reconstruct(chain, loop, mu, t_eval=np.array([0.0, 2.0])).path.element[-1]
    hs = np.array([0.2, 0.1, 0.05])
    errs = [
        np.abs(
            reconstruct(chain, loop, mu, t_eval=np.array([0.0, 2.0]), method="rkmk4", h=h).path.element[-1] - ref
        ).max()
        for h in hs
    ]
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 3.7 < order < 4.4


def test_integrate_path_exact_for_constant_velocity(rng):
    for name, xi in (("SE2", np.array([0.3, -1.2, 2.5])), ("SO3", np.array([1.0, -2.0, 0.5]))):
        G = named_group(name)
        g0 = G.from_coordinates(np.array([0.2, 0.9, -0.4]))
        t = np.linspace(0.0, 3.0, 7)
        path = integrate_path(G, lambda _t, _g, xi=xi: xi, g0, t)
        exact = g0 @ (se2 if name == "SE2" else so3).exp(t[:, None] * xi)
        np.testing.assert_allclose(path.element, exact, atol=1e-10)
        if name == "SE2":
            np.testing.assert_allclose(path.g[:, 2] - path.g[0, 2], t * xi[2], atol=1e-10)  # unwrapped


def test_decomposition_adds_up_only_when_abelian(pinned, chain):
    loop1 = Gait.from_expressions(["2*pi*t + 0.3*sin(2*pi*t)"], 1.0)
    rec = reconstruct(pinned, loop1, 0.9, decompose=True, t_eval=np.array([0.0, 1.0]))
    parts = rec.alone["connection"].g[-1, 0] + rec.alone["momentum"].g[-1, 0]
    assert abs(parts - rec.path.g[-1, 0]) < 1e-12
    out = decompose_displacement(
        chain.group,
        {"a": lambda t, g: np.array([1.0, 0.0, 0.0]), "b": lambda t, g: np.array([0.0, 0.0, 1.0])},
        np.eye(3),
        [0.0, 1.0],
    )
    assert np.abs(out["total"].element[-1] - out["a"].element[-1] @ out["b"].element[-1]).max() > 1e-3


# -- bad input -------------------------------------------------------------------------------------
def test_bad_loops_and_groups(chain, bodies, pinned):
    with pytest.raises(InputError, match="closed"):
        phases(chain, Gait.from_expressions(["t", "sin(2*pi*t)"], 1.0))
    with pytest.raises(ShapeError, match="2-D shape space"):
        phases(chain, Gait.from_expressions(["sin(t)"], 2 * np.pi))
    with pytest.raises(ShapeError, match="3 component"):
        phases(chain, Gait.ellipse([0, 0], [1, 1], 1.0), [1.0, 2.0])
    with pytest.raises(InputError, match="centre-of-mass"):
        phases(chain, Gait.ellipse([0, 0], [0.5, 0.5], 1.0), [1.0, 0.0, 0.0])
    with pytest.raises(InputError, match="Theorem 2.2"):
        phases(spacecraft_with_rotors(), Gait.ellipse([0, 0], [0.5, 0.5], 1.0))
    with pytest.raises(InputError, match="bounds no"):
        curvature_integral(chain, Gait.from_expressions(["2*pi*t", "0.3*sin(2*pi*t)"], 1.0))
    with pytest.raises(SingularityError, match="singular"):
        phases(bodies, Gait.from_expressions(["0.3*sin(2*pi*t)", "0.3*sin(2*pi*t)", "0.3*sin(2*pi*t)"], 1.0))
    # the pinned bodies' hinge angle is an angle: whole turns are closed, half turns are not
    with pytest.raises(InputError, match="closed"):
        phases(pinned, Gait.from_expressions(["pi*t"], 1.0))
    # a pole passes a closure test that is scaled by the loop's size: refused by where it is
    with pytest.raises(InputError, match="non-finite one at t = 0.5"):
        phases(pinned, Gait.from_expressions(["1/(t - 1/2) - 1/(t + 1/2) + 1/(t - 3/2)"], 1.0))


# -- pictures -------------------------------------------------------------------------------------
def test_plots_draw_and_shade(chain, tmp_path):
    import matplotlib.pyplot as plt

    from geomech.plot.phases import connection_field, curvature_map, group_path, momentum_solid_angle

    loop = Gait.ellipse([0.4, -0.2], [0.9, 0.6], 2.0)
    ax = curvature_map(chain, loop=loop, n=161)
    label = [t.get_text() for t in ax.texts if "iint" in t.get_text()][0]
    # the figure states the exact -iint B (Stokes), the geometric phase -oint A computed by another route
    value = float(label.split("=$")[1].split()[0])
    assert abs(value - phases(chain, loop).geometric) < 1e-5 * abs(value)  # printed to 6 digits
    assert "geometric phase" in label  # SE(2)'s rotation: the value is the phase
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend == ["enclosed counterclockwise (winding +1)"]
    assert connection_field(chain, loop=loop, component="theta") is not None
    # a loop run backwards is clockwise; on SO(3) the default is the component that does not vanish
    ax = curvature_map(chain, loop=Gait.ellipse([0.4, -0.2], [0.9, -0.6], 2.0), n=81)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["enclosed clockwise (winding -1)"]
    craft = spacecraft_with_rotors()
    ax = curvature_map(craft, loop=loop, n=41)
    assert "omega_1" not in ax.get_title() and "leading order" in ax.texts[-1].get_text()
    ax = group_path(reconstruct(chain, loop, [0.0, 0.0, 0.5]))
    assert ax.get_xlabel() == "$x$"
    ax = momentum_solid_angle(rigid_body_phase(RigidBody([3, 2, 1]), [1, 0.3, 0.2], direct=False))
    assert "Lambda" in ax.get_title()
    plt.close("all")


def test_phase_history_ends_at_the_split_and_adds_up_to_the_reconstruction():
    # two pinned bodies, body 2 turning once in T: theta(t) = -I2/(I1+I2) psi(t) + mu t/(I1+I2) exactly
    from geomech.plot.phases import phase_split

    system = two_pinned_bodies(1.0, 3.0)
    loop = Gait.from_expressions(["2*pi*t/T + 0.4*sin(2*pi*t/T)"], 2.0)
    mu = -0.7
    hist = phase_history(system, loop, mu)
    split = phases(system, loop, mu)
    assert abs(hist["geometric"][-1] - split.geometric) < 1e-12 and abs(hist["dynamic"][-1] - split.dynamic) < 1e-12
    t = hist["t"]
    psi = 2 * np.pi * t / 2.0 + 0.4 * np.sin(2 * np.pi * t / 2.0)
    np.testing.assert_allclose(hist["geometric"], -3.0 / 4.0 * psi, atol=1e-12)
    np.testing.assert_allclose(hist["dynamic"], mu * t / 4.0, atol=1e-12)
    ax = phase_split(system, loop, mu)
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert any(f"{split.geometric:.6g}" in s for s in labels) and any(f"{split.dynamic:.6g}" in s for s in labels)
    rec = [ln for ln in ax.get_lines() if ln.get_label() == "reconstructed on the group"][0]
    np.testing.assert_allclose(rec.get_ydata(), hist["total"], atol=1e-9)
