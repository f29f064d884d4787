"""Relative equilibria and their stability: Theorem 5 (the boundary k = 1 - I3/lambda2 found by the tool for
random admissible parameters and confirmed by simulation), the three verdicts and their independence,
equilibria located in an atlas (poles included) against closed forms, Poincare-Hopf, and stability maps."""

import functools
import json
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from scipy.optimize import brentq

from geomech import LeftInvariantSystem, RigidBody
from geomech.analysis import (
    analyse_stability,
    assess,
    energy_casimir,
    find_equilibria,
    perturbation_growth,
    refine_equilibrium,
    stability_boundary,
    stability_map,
    theorem5_margin,
)
from geomech.errors import ConvergenceError, InputError
from geomech.reduction.rotor_closed_forms import theorem5_boundary
from geomech.systems.control import StructurePreservingControl as SPC
from geomech.systems.rotors import RotorBody

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "spacecraft_control.py"


def one_rotor(lam1=3.0, lam2=2.0, I3=1.0, phi="k*v", p=0.0, **params):
    body = RotorBody.one_rotor(lam1, lam2, I3)
    return SPC.one_rotor(body, phi, parameters=params or {"k": 0.5}, p=p)


def random_admissible(rng):
    """lambda1 > lambda2 > I3 + J3: axis 2 is the intermediate axis of the locked body (section 6.3)."""
    I3 = rng.uniform(0.3, 2.0)
    J3 = rng.uniform(0.05, 0.5) * I3
    lam2 = (I3 + J3) * rng.uniform(1.1, 3.0)
    lam1 = lam2 * rng.uniform(1.05, 2.0)
    return lam1, lam2, I3, J3, rng.uniform(0.3, 5.0)


def test_theorem5_boundary_matches_the_closed_form_for_random_admissible_parameters(rng):
    for _ in range(6):
        lam1, lam2, I3, J3, G = random_admissible(rng)
        control = SPC.one_rotor(RotorBody.one_rotor(lam1, lam2, I3, J3), "k*v", parameters={"k": 0.5}, probe_radius=G)
        k_star = theorem5_boundary(lam2, I3)
        b = stability_boundary(control.family(), "k", (k_star - 0.3, k_star + 0.3), G=G)
        assert abs(b.value - k_star) < 1e-10
        assert b.stable_side == "above"
        np.testing.assert_allclose(b.m, [0.0, G, 0.0], atol=1e-12 * G)


def test_theorem5_generalised_phi_with_phi0_plus_p_zero(rng):
    """Theorem 5 for a nonlinear phi with phi(0) + p = 0: the boundary is on phi'(0) = k + b."""
    for _ in range(3):
        lam1, lam2, I3, J3, G = random_admissible(rng)
        b_coef = rng.uniform(-0.2, 0.2)
        control = SPC.one_rotor(
            RotorBody.one_rotor(lam1, lam2, I3),
            "k*v + a*v**3 + b*sin(v) + c",
            parameters={"k": 0.5, "a": 0.4, "b": b_coef, "c": 0.3},
            p=-0.3,
            probe_radius=G,
        )
        found = stability_boundary(control.family(), "k", (-1.0, 1.5), G=G)
        assert abs(found.value - (1 - I3 / lam2 - b_coef)) < 1e-10


def test_boundary_confirmed_by_simulation_just_above_and_below():
    control = one_rotor()
    fam = control.family()
    k_star = stability_boundary(fam, "k", (0.2, 0.9)).value
    spin = np.array([0.0, 1.0, 0.0])
    below = perturbation_growth(fam(k=k_star - 0.05), spin, delta=1e-4, t_final=250.0)
    above = perturbation_growth(fam(k=k_star + 0.05), spin, delta=1e-4, t_final=250.0)
    assert below.ratio > 1000 and above.ratio < 5
    # and the verdicts agree with what the simulation shows
    assert assess(fam(k=k_star - 0.05), refine_equilibrium(fam(k=k_star - 0.05), spin)).verdict == "unstable"
    assert assess(fam(k=k_star + 0.05), refine_equilibrium(fam(k=k_star + 0.05), spin)).verdict == "stable"


@pytest.mark.parametrize("k", [0.3, 0.7])
def test_hessian_at_the_intermediate_axis_is_the_seeds(k):
    """The proof of Theorem 5: d2 h_p(0, 0) = diag(-G^2 (1/lambda2 - 1/lambda1), 1/I3 - 1/lambda2 - phi'(0)/I3)."""
    lam1, lam2, I3, G = 3.0, 2.0, 1.2, 1.3
    control = one_rotor(lam1, lam2, I3, k=k)
    eq = refine_equilibrium(control.closed_loop(), [0.0, G, 0.0])
    assert eq.axis == 2 and np.allclose(eq.lL, [0.0, 0.0], atol=1e-14)
    np.testing.assert_allclose(
        eq.hessian, np.diag([-(G**2) * (1 / lam2 - 1 / lam1), 1 / I3 - 1 / lam2 - k / I3]), atol=1e-14
    )
    rep = assess(control.closed_loop(), eq)
    if k > 1 - I3 / lam2:
        assert rep.lagrange_dirichlet.verdict == "stable" and "negative definite" in rep.lagrange_dirichlet.reason
    else:
        # indefinite: Lagrange-Dirichlet and energy-Casimir are silent, never "unstable"
        assert rep.lagrange_dirichlet.verdict == "inconclusive" and "silent" in rep.lagrange_dirichlet.reason
        assert rep.energy_casimir.verdict == "inconclusive"
        sigma = np.sqrt(-np.linalg.det(eq.hessian))
        assert rep.linearisation.verdict == "unstable"
        np.testing.assert_allclose(sorted(rep.linearisation.eigenvalues.real), [-sigma, sigma], rtol=1e-12)


def random_system(rng):
    c = rng.normal(size=7)
    m1, m2, m3 = __import__("sympy").symbols("m1 m2 m3")
    H = (
        m1**2 / 3
        + m2**2 / 2.2
        + m3**2 / 1.4
        + c[0] * m3**4 / 10
        + c[1] * m1**2 * m2**2 / 10
        + c[2] * m1 * m3 / 5
        + c[3] * m1 / 5
        + c[4] * m2 / 5
        + c[5] * m3 / 5
        + c[6] * m2**3 / 10
    )
    return LeftInvariantSystem.from_expression(H)


def test_three_verdicts_are_consistent_on_random_systems(rng):
    """Lagrange-Dirichlet (chart Hessian) and energy-Casimir (so(3)*, no chart) are computed independently
    and must agree; linearisation's pair is real exactly where both are silent for a nondegenerate saddle;
    the reduced linearisation's eigenvalues are the nonzero ones of Euler's equation linearised in R^3."""
    for _ in range(4):
        system = random_system(rng)
        analysis = analyse_stability(system, G=rng.uniform(0.5, 1.5))
        assert analysis.equilibria.complete
        for r in analysis:
            assert r.lagrange_dirichlet.verdict == r.energy_casimir.verdict
            saddle = r.equilibrium.index == -1
            assert (r.linearisation.verdict == "unstable") == saddle
            lp = [complex(z["re"], z["im"]) for z in r.linearisation.extra["lie_poisson_eigenvalues"]]
            lp = [z for z in lp if abs(z) > 1e-9 * max(abs(x) for x in lp)]
            np.testing.assert_allclose(
                sorted(lp, key=lambda z: (z.real, z.imag)),
                sorted(r.linearisation.eigenvalues, key=lambda z: (z.real, z.imag)),
                atol=1e-9,
            )
            if r.energy_casimir.verdict == "stable":
                full = r.energy_casimir.extra["full_second_variation_eigenvalues"]
                assert np.all(full > 0) or np.all(full < 0)


def test_free_rigid_body_equilibria_including_the_poles_of_the_seeds_chart():
    body = RigidBody([3.0, 2.0, 1.0])
    analysis = analyse_stability(body.system, G=2.0)
    assert analysis.equilibria.complete and len(analysis) == 6
    for axis, verdict in ((0, "stable"), (1, "unstable"), (2, "stable")):
        for sign in (1, -1):
            m = np.zeros(3)
            m[axis] = 2.0 * sign
            rep = analysis.nearest(m)
            np.testing.assert_allclose(rep.equilibrium.m, m, atol=1e-12)
            assert rep.verdict == verdict
    # +-G e3 are the poles of the seed's chart: they were located in another chart of the atlas
    assert analysis.nearest([0, 0, 2.0]).equilibrium.axis != 2
    assert analysis.nearest([0, 0, 2.0]).equilibrium.coordinates(2) is None


def test_moved_equilibria_match_the_meridian_closed_form():
    """phi(0) + p != 0: the intermediate-axis spin moves along the meridian l = 0 to L* with
    g(L*) = L*(1 - I3/lambda2) - phi(L*) - p = 0, stable iff g'(L*) < 0 (d2h_p = diag(h_ll < 0, g'/I3))."""
    lam1, lam2, I3, G = 3.0, 2.0, 1.0, 1.0
    k, a, p = 0.3, 0.5, 0.1
    control = one_rotor(lam1, lam2, I3, phi="k*v + a*v**3", p=p, k=k, a=a)
    analysis = analyse_stability(control.closed_loop(), G)
    assert analysis.equilibria.complete

    def g(L):
        return L * (1 - I3 / lam2) - k * L - a * L**3 - p

    grid = np.linspace(-G + 1e-9, G - 1e-9, 2001)
    roots = [brentq(g, x0, x1) for x0, x1 in zip(grid[:-1], grid[1:]) if g(x0) * g(x1) < 0]
    assert roots
    for L in roots:
        m = np.array([0.0, np.sqrt(G**2 - L**2), L])
        rep = analysis.nearest(m)
        np.testing.assert_allclose(rep.equilibrium.m, m, atol=1e-10)
        dg = (1 - I3 / lam2) - k - 3 * a * L**2
        assert rep.verdict == ("stable" if dg < 0 else "unstable")
    # the unmoved point (0, G, 0) is not an equilibrium any more
    assert np.linalg.norm(analysis.nearest([0, 1.0, 0]).equilibrium.m - [0, 1.0, 0]) > 0.1


def test_degenerate_equilibria_are_reported():
    # lambda1 = lambda2: a circle of equilibria; no verdict claims stability from a singular Hessian
    body = RigidBody([2.0, 2.0, 1.0])
    eqs = find_equilibria(body.system, 1.0, n_points=300)
    assert not eqs.complete and eqs.n_degenerate > 0 and "degenerate" in eqs.message
    deg = next(e for e in eqs if e.index == 0)
    assert assess(body.system, deg).lagrange_dirichlet.verdict == "inconclusive"


def test_refine_reports_when_no_equilibrium_is_near():
    control = one_rotor(phi="k*v + a*v**3", p=0.1, k=0.3, a=0.5)
    with pytest.raises(ConvergenceError, match="none is near"):
        refine_equilibrium(control.closed_loop(), [0.0, 1.0, 0.0])


def test_energy_casimir_second_variation():
    control = one_rotor(k=0.7)
    system = control.closed_loop()
    eq = refine_equilibrium(system, [0.0, 1.0, 0.0])
    ec = energy_casimir(system, eq)
    # on the tangent space of the sphere at (0, G, 0): diag(1/lambda1 - 1/lambda2, (1 - phi'(0))/I3 - 1/lambda2)
    np.testing.assert_allclose(sorted(ec.eigenvalues), sorted([1 / 3 - 1 / 2, 0.3 - 1 / 2]), atol=1e-14)
    assert ec.verdict == "stable" and abs(ec.extra["casimir_dphi"] + 1 / 2) < 1e-14


def test_stability_boundary_bad_bracket():
    with pytest.raises(InputError, match="Widen or move"):
        stability_boundary(one_rotor().family(), "k", (0.6, 0.9))


def test_stability_map_linear_control_matches_theorem5():
    control = one_rotor()
    ks = np.linspace(0.05, 0.95, 10)
    lam2s = np.linspace(1.15, 2.85, 7)
    seen: list[int] = []
    ds = stability_map(
        control.family(),
        ("k", ks),
        ("lambda2", lam2s),
        closed_form=theorem5_margin(control),
        progress=seen.append,
        chunk=ks.size,
    )
    # the points done as blocks (here rows) complete: from none to all, never backwards
    assert seen[0] == 0 and seen[-1] == 70 and seen == sorted(seen) and len(seen) == 8
    margin = ks[None, :] - (1 - 1.0 / lam2s[:, None])
    np.testing.assert_allclose(ds["closed_form_margin"].values, margin, atol=1e-14)
    verdict = ds["verdict"].values
    assert np.all((verdict == 1) == (margin > 0)) and np.all((verdict == -1) == (margin < 0))
    assert np.all(ds["lagrange_dirichlet"].values[margin < 0] == 0)  # silent, never "unstable"
    np.testing.assert_allclose(ds["m"].values[..., 1], 1.0, atol=1e-12)


def test_stability_map_finds_a_pair_born_in_a_fold_between_grid_points():
    """phi = k v + a v^3 with p = 0.1: between k = 0.6 and k = 0.95 (a = -1) a pair of equilibria is born in a fold
    nearer to (0, G, 0) than the branch continued from k = 0.6. The map must assess the nearest one, as a fresh
    search at that point does, whatever the path through the grid."""
    control = SPC.one_rotor(
        RotorBody.one_rotor(3.0, 2.0, 1.0), "k*v + a*v**3", parameters={"k": 0.5, "a": 0.0}, p=0.1, probe_radius=1.0
    )
    ds = stability_map(control.family(), ("k", [0.6, 0.95]), ("a", [-1.0, -0.9]))
    for j, a in enumerate([-1.0, -0.9]):
        fresh = find_equilibria(control.family()(k=0.95, a=a), 1.0).nearest([0.0, 1.0, 0.0])
        np.testing.assert_allclose(ds["m"].values[j, 1], fresh.m, atol=1e-9)
        assert ds["verdict"].values[j, 1] == 1  # the nearer equilibrium is stable; the continued one is not
    assert ds["branch_jump"].values[:, 0].sum() == 0  # a row's first point has nothing to jump from


def test_stability_map_nonlinear_control_data_file(tmp_path):
    """phi(0) + p != 0: the equilibrium moves; the map's verdicts agree with the meridian criterion wherever
    the assessed equilibrium is on the meridian l = 0, and the data file round-trips through netCDF."""
    xr = pytest.importorskip("xarray")
    lam2, I3 = 2.0, 1.0
    control = one_rotor(phi="k*v + a*v**3", p=0.1, k=0.5, a=0.0)
    ks, As = np.linspace(0.05, 0.95, 7), np.linspace(-0.9, 0.9, 6)
    ds = stability_map(control.family(), ("k", ks), ("a", As))
    m = ds["m"].values
    checked = 0
    for j, a in enumerate(As):
        for i, k in enumerate(ks):
            if abs(m[j, i, 0]) < 1e-9 and m[j, i, 1] > 1e-6:
                L = m[j, i, 2]
                dg = (1 - I3 / lam2) - k - 3 * a * L**2
                assert ds["verdict"].values[j, i] == (1 if dg < 0 else -1)
                checked += 1
    assert checked >= 10
    path = tmp_path / "map.nc"
    ds.to_netcdf(path)
    back = xr.open_dataset(path)
    np.testing.assert_array_equal(back["verdict"].values, ds["verdict"].values)
    assert "stable" in back["verdict"].attrs["flag_meanings"]
    back.close()


def test_plots(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from geomech.plot.stability import equilibria_phase_portrait, stability_map_plot

    control = one_rotor(k=0.6)
    ax = equilibria_phase_portrait(control.closed_loop(), 1.0)
    labels = {t.get_text() for t in ax.get_legend().get_texts()}
    assert {"stable", "unstable"} <= labels
    ds = stability_map(
        control.family(),
        ("k", np.linspace(0.1, 0.9, 5)),
        ("lambda2", np.linspace(1.3, 2.8, 4)),
        closed_form=theorem5_margin(control),
    )
    ax2 = stability_map_plot(ds)
    assert ax2.get_xlabel() == "k" and ax2.get_ylabel() == "lambda2"
    with pytest.raises(InputError, match="variable"):
        stability_map_plot(ds, variable="nope")
    plt.close("all")


@pytest.mark.slow
def test_spacecraft_example_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["spacecraft_control.py", "--out", str(tmp_path)])
    namespace = runpy.run_path(str(EXAMPLE), run_name="not_main")
    summary = namespace["main"](tmp_path, t_final=600.0)
    assert abs(summary["k_boundary_found"] - summary["k_min_closed_form"]) < 1e-9
    assert summary["verdicts_at_spin"]["lagrange_dirichlet"] == "stable"
    assert summary["locked_verdict"] == "unstable"
    assert summary["max_tilt_deg"]["controlled"] < 5 < summary["max_tilt_deg"]["locked"]
    assert summary["max_wheel_momentum"] < summary["h_max"]
    assert summary["p_drift"] < 1e-10
    assert (tmp_path / "spacecraft_phase_portrait.png").stat().st_size > 20_000
    assert json.loads((tmp_path / "spacecraft_summary.json").read_text())["hyperregular"] in ("yes", "unknown")


@functools.cache
def _fixed_random_system():
    return random_system(np.random.default_rng(4))


@given(st.floats(-3.0, 3.0), st.floats(-0.95, 0.95), st.integers(0, 2))
@example(0.0, -0.9375, 0)  # once beyond the plain central differences' reach
@example(3.0, 0.95, 1).via("the nearest the strategy comes to a pole")
def test_chart_hessian_against_finite_differences(l, ratio, axis):
    """The chain-rule gradient and Hessian of h_p in each chart of the atlas against central differences of
    h_p = H o C U(l, L) itself."""
    from geomech.analysis import chart_derivatives
    from geomech.reduction import SerretAndoyerChart

    system = _fixed_random_system()
    G = 1.3
    chart = SerretAndoyerChart(axis)
    lL = np.array([l, ratio * G])
    h = lambda y: float(system.hamiltonian(chart.inverse(y, G)))  # noqa: E731
    _, grad, hess = chart_derivatives(system, chart.inverse(lL, G), axis)

    def fd_grad(e):
        return np.array([(h(lL + e * d) - h(lL - e * d)) / (2 * e) for d in np.eye(2)])

    def fd_hess(e):
        return np.array(
            [
                [
                    (h(lL + e * a + e * b) - h(lL + e * a - e * b) - h(lL - e * a + e * b) + h(lL - e * a - e * b))
                    / (4 * e * e)
                    for b in np.eye(2)
                ]
                for a in np.eye(2)
            ]
        )

    # Central differences are O(e^2) with constants that grow like (G^2 - L^2)^(-5/2) near the poles (at
    # |L|/G = 0.95 about 300 times those at L = 0): one Richardson step cancels the e^2 term, leaving O(e^4)
    # truncation and round-off of eps |h| / e (gradient) or eps |h| / e^2 (Hessian), both far below the
    # tolerances.
    np.testing.assert_allclose(grad, (4 * fd_grad(5e-5) - fd_grad(1e-4)) / 3, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(hess, (4 * fd_hess(5e-4) - fd_hess(1e-3)) / 3, rtol=1e-5, atol=1e-6)
