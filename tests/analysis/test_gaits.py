"""Gaits of nonholonomic systems: net displacement by reconstruction on SE(2), and the split of the body
velocity into the connection term and the momentum term (issue 6, item 3)."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import jv

from geomech.analysis import (
    Gait,
    analyse_gait,
    curvature_integral,
    gait_loop,
    geometric_phase,
)
from geomech.errors import InputError, ShapeError, SingularityError
from geomech.lie import se2
from geomech.reduction import bkmm_reduction
from geomech.systems.nonholonomic_examples import kinematic_car, snakeboard_bkmm

M, R, J0, J1 = 1.0, 1.0, 0.3, 0.1
A_PSI, B_PHI = 1.0, 0.4
DRIVE = {"psi": f"{A_PSI}*sin(2*pi*t/T)", "phi": f"{B_PHI}*sin(2*pi*t/T)"}  # same frequency
ROTATE = {"psi": f"{A_PSI}*sin(4*pi*t/T)", "phi": f"{B_PHI}*sin(2*pi*t/T)"}  # rotor at twice the axles'
PARKING = {"psi": f"{A_PSI}*sin(6*pi*t/T)", "phi": f"{B_PHI}*sin(4*pi*t/T)"}  # rotor 3 : axles 2


@pytest.fixture(scope="module")
def board():
    return bkmm_reduction(snakeboard_bkmm(m=M, r=R, J0=J0, J1=J1)).numeric()


@pytest.fixture(scope="module")
def car():
    """The kinematic car: three constraints fix the body velocity from the shape velocity,
    xi = (R psi', 0, (R/ell) tan(phi) psi'), so S_q = 0 (principally kinematic)."""
    return kinematic_car(m=1.0, I=0.2, R=0.3, ell=1.0, J=0.1, K=0.1)


@pytest.mark.slow  # a long run; the CLI's test checks the same closed form on a shorter one
def test_drive_gait_momentum_gain_is_the_bessel_closed_form(board):
    # BKMM: p' = 2 J0 cos^2(phi) phi' psi' - tan(phi) p phi', so d/dt (p/cos phi) = 2 J0 cos(phi) phi' psi' and over
    # one period of psi = a sin(wt), phi = b sin(wt): Delta p = 2 J0 a b w^2 int cos(b sin wt) cos^2(wt) dt
    # = 4 pi J0 a w J_1(b) (Bessel), whatever p0.
    T = 1.3
    a = analyse_gait(board, DRIVE, period=T, periods=3, p0=[0.7])
    w = 2 * np.pi / T
    want = 4 * np.pi * J0 * A_PSI * w * jv(1, B_PHI)
    assert np.allclose(a.momentum_change[:, 0], want, rtol=1e-9, atol=0)
    # along the gait p(t) = cos(phi) (p0 + 2 J0 int_0^t cos(phi) phi' psi')
    i = 137
    ti = a.t[i]
    integral = quad(
        lambda s: 2 * J0 * np.cos(B_PHI * np.sin(w * s)) * (B_PHI * w * np.cos(w * s)) * (A_PSI * w * np.cos(w * s)),
        0,
        ti,
        epsabs=1e-14,
        epsrel=1e-13,
    )[0]
    assert abs(a.p[i, 0] - np.cos(B_PHI * np.sin(w * ti)) * (0.7 + integral)) < 1e-9


@pytest.mark.slow  # the reduced simulation is the fast suite's second route
def test_reconstruction_agrees_with_full_simulation(board):
    from geomech import solve
    from geomech.integrators import LagrangeDAlembert

    q0 = {"x": 0.4, "y": -1.1, "theta": 0.7}
    a = analyse_gait(board, ROTATE, period=1.0, periods=2, p0=[0.35], g0=q0, samples_per_period=101)
    tr = solve(
        board.system,
        LagrangeDAlembert(),
        t_final=a.t[-1],
        saveat=a.t,
        shapes={k: v.replace("T", "1.0") for k, v in ROTATE.items()},
        q0=q0,
        p0=[0.35],
        rtol=1e-12,
        atol=1e-13,
    )
    assert np.abs(tr.q[:, :3] - a.path.g).max() < 1e-8  # theta unwrapped in both
    assert np.abs(tr.p - a.p).max() < 1e-8
    assert np.abs(tr.q[:, 3:] - a.r).max() < 1e-12


def test_reconstruction_agrees_with_reduced_simulation(board):
    from geomech import solve
    from geomech.integrators import BKMM

    a = analyse_gait(board, DRIVE, period=1.0, periods=2, p0=[-0.2], samples_per_period=51)
    tr = solve(
        board.system,
        BKMM(),
        t_final=a.t[-1],
        saveat=a.t,
        shapes={k: v.replace("T", "1.0") for k, v in DRIVE.items()},
        p0=[-0.2],
        rtol=1e-12,
        atol=1e-13,
    )
    assert np.abs(tr.q[:, :3] - a.path.g).max() < 1e-8
    assert np.abs(tr.p - a.p).max() < 1e-8


def test_drive_gait_accelerates_along_the_board(board):
    drive = analyse_gait(board, DRIVE, period=1.0, periods=2, rtol=1e-11, atol=1e-11)
    # the momentum builds up every period and the board goes ever faster along its axis
    dp = drive.momentum_change[:, 0]
    assert np.all(np.abs(dp) > 1.0) and np.allclose(dp, dp[0], rtol=1e-9)
    step = np.hypot(*drive.per_period()[:, :2].T)
    assert step[1] - step[0] > 0.5
    dx, dy, dth = drive.net_displacement
    assert abs(dx) > 5 * max(abs(dy), abs(dth))


def test_rotate_gait_turns_in_place(board):
    rotate = analyse_gait(board, ROTATE, period=1.0, periods=2, rtol=1e-11, atol=1e-11)
    # the momentum returns, every period is the same rigid motion, a rotation about a point on the board
    assert np.abs(rotate.momentum_change).max() < 1e-9
    per = rotate.per_period()
    assert np.abs(per - per[0]).max() < 1e-9
    ex, ey, eth = per[0]
    assert abs(eth) > 0.2
    turn = np.array([[np.cos(eth), -np.sin(eth)], [np.sin(eth), np.cos(eth)]])
    centre = np.linalg.solve(np.eye(2) - turn, [ex, ey])
    assert np.linalg.norm(centre) < R  # inside the wheelbase: rotation in place


def test_parking_gait_moves_sideways(board):
    parking = analyse_gait(board, PARKING, period=2.0, rtol=1e-11, atol=1e-11)
    px, py, pth = parking.per_period()[0]
    assert abs(py) > 0.1 and abs(px) < 1e-9 and abs(pth) < 1e-9
    assert np.abs(parking.momentum_change).max() < 1e-9


def test_zero_amplitude_gait_gives_no_motion_and_constant_momentum_gives_exp(board):
    still = analyse_gait(board, {"psi": "0*t", "phi": "0*t"}, period=1.0)
    assert np.abs(still.net_displacement).max() == 0.0
    # a frozen shape phi0 with momentum p0: p' = 0 and xi = e I^-1 p0 with BKMM's e = (-2 r cos^2, 0, sin 2 phi0),
    # I = 4 m r^2 cos^2 phi0, so g(T) = exp(T xi)
    phi0, p0, T = 0.3, 0.8, 1.7
    a = analyse_gait(board, {"psi": "0*t", "phi": f"{phi0} + 0*t"}, period=T, p0=[p0])
    xi = np.array([-2 * R * np.cos(phi0) ** 2, 0.0, np.sin(2 * phi0)]) * p0 / (4 * M * R**2 * np.cos(phi0) ** 2)
    assert np.abs(a.displacement() - se2.exp(T * xi)).max() < 1e-11
    assert np.abs(a.p - p0).max() < 1e-13


def test_principally_kinematic_connection_is_the_whole_motion(car):
    loop = {"psi": "2*sin(2*pi*t)", "phi": "0.3*cos(2*pi*t)"}
    a = analyse_gait(car, loop, period=1.0, periods=2)
    assert a.model.m == 0 and a.p.shape == (a.t.size, 0)
    assert np.abs(a.path.element - a.alone["connection"].element).max() < 1e-12
    assert np.abs(a.alone["momentum"].element - np.eye(3)).max() == 0.0
    # theta' = (R/ell) tan(phi) psi', integrated by quadrature
    dth = quad(
        lambda t: 0.3 * np.tan(0.3 * np.cos(2 * np.pi * t)) * 4 * np.pi * np.cos(2 * np.pi * t),
        0,
        1,
        epsabs=1e-14,
        epsrel=1e-13,
    )[0]
    assert abs(a.per_period()[0, 2] - dth) < 1e-10
    # a kinematic system's displacement does not depend on how fast the loop is run
    slow = analyse_gait(car, {"psi": "2*sin(2*pi*t/T)", "phi": "0.3*cos(2*pi*t/T)"}, period=3.0)
    assert np.abs(slow.displacement(1) - a.displacement(1)).max() < 1e-10


def test_connection_alone_is_geometric_the_total_is_not(board):
    # s(t) = t + (0.6 T/2pi) sin(2pi t/T) is increasing with s(0) = 0, s(T) = T: the same loop run unevenly.
    base = {"psi": "sin(2*pi*t/T)", "phi": "0.2 + 0.4*cos(2*pi*t/T)"}
    s = "(t + 0.6*T/(2*pi)*sin(2*pi*t/T))"
    warped = {k: v.replace("t/T", f"{s}/T") for k, v in base.items()}
    a = analyse_gait(board, base, period=1.0, p0=[0.2])
    b = analyse_gait(board, warped, period=1.0, p0=[0.2])
    assert np.abs(a.displacement(part="connection") - b.displacement(part="connection")).max() < 1e-10
    assert np.abs(a.displacement() - b.displacement()).max() > 1e-3
    # run backwards the connection-alone motion is undone: g_rev(T) = g(T)^-1
    back = {k: v.replace("t/T", "(T - t)/T") for k, v in base.items()}
    c = analyse_gait(board, back, period=1.0)
    assert np.abs(c.displacement(part="connection") @ a.displacement(part="connection") - np.eye(3)).max() < 1e-11


def test_parts_do_not_compose_but_their_rotations_add(board):
    a = analyse_gait(board, ROTATE, period=1.0, p0=[0.3])
    gc, gm, g = (a.displacement(part=p) for p in ("connection", "momentum", "total"))
    assert np.abs(gc @ gm - g).max() > 1e-3 and np.abs(gm @ gc - g).max() > 1e-3
    tot = a.displacement_coordinates()
    assert (
        np.abs(
            a.displacement_coordinates(part="connection")[:2]
            + a.displacement_coordinates(part="momentum")[:2]
            - tot[:2]
        ).max()
        > 1e-3
    )
    # the rotation of SE(2) is abelian: theta' = omega_conn + omega_mom adds up exactly
    assert (
        abs(a.displacement_coordinates(part="connection")[2] + a.displacement_coordinates(part="momentum")[2] - tot[2])
        < 1e-10
    )


def test_stokes_for_small_loops(board):
    errs, eps_list = [], [0.16, 0.08, 0.04]
    for eps in eps_list:
        loop = Gait.ellipse([0.3, 0.5], [eps, 0.7 * eps], 1.0, tilt=0.4)
        a = analyse_gait(board, loop)
        B = curvature_integral(board, loop)
        line = geometric_phase(board, loop)
        u = se2.log(a.displacement(part="connection"))
        # rotation: exact (Stokes), the bracket of se(2) has no rotation part
        assert abs(u[2] + B[2]) < 1e-11 and abs(line[2] + B[2]) < 1e-11
        errs.append(np.abs(u + B).max())
        assert np.abs(u + B).max() < 0.05 * np.abs(B).max()
    slope = np.polyfit(np.log(eps_list), np.log(errs), 1)[0]
    assert slope > 2.7  # holonomy = exp(-iint B) + O(eps^3)


def test_curvature_integral_against_grid_quadrature(board):
    # the snakeboard's theta-row is A = (J0 sin^2(phi)/(m r^2), 0): B_theta = -2 J0 sin(phi) cos(phi)/(m r^2)
    loop = Gait.ellipse([0.1, 0.3], [0.5, 0.4], 2.0)
    val = curvature_integral(board, loop)
    f = lambda rho, ang: (-J0 * np.sin(2 * (0.3 + 0.4 * rho * np.sin(ang))) / (M * R**2)) * rho * 0.5 * 0.4
    from scipy.integrate import dblquad

    want = dblquad(lambda rho, ang: f(rho, ang), 0, 2 * np.pi, 0, 1, epsabs=1e-13, epsrel=1e-12)[0]
    assert abs(val[2] - want) < 1e-10


def test_dataset_and_summary(board, tmp_path):
    xr = pytest.importorskip("xarray")
    a = analyse_gait(board, DRIVE, period=1.0, periods=2, samples_per_period=21)
    ds = a.to_dataset()
    ds.to_netcdf(tmp_path / "g.nc")
    back = xr.load_dataset(tmp_path / "g.nc")
    assert back["g"].shape == (41, 3) and np.allclose(back["p"].values, a.p)
    s = a.summary()
    assert s["periods"] == 2 and len(s["displacement_per_period"]) == 2
    assert "not a geometric/dynamic phase decomposition" in s["note"]
    assert s["net_displacement"]["x"] == pytest.approx(a.net_displacement[0])


def test_bad_gaits_are_refused(board):
    with pytest.raises(InputError, match="closed"):
        analyse_gait(board, {"psi": "t", "phi": "0.2*sin(2*pi*t)"}, period=1.0)
    with pytest.raises(InputError, match="not shape variables"):
        analyse_gait(board, {"psi": "sin(2*pi*t)", "beta": "0.2*sin(2*pi*t)"}, period=1.0)
    with pytest.raises(ShapeError, match="2-D shape space"):
        analyse_gait(board, Gait.from_expressions(["sin(2*pi*t)"], 1.0), period=1.0)
    with pytest.raises(ShapeError, match="missing"):
        gait_loop(board.system, {"psi": "sin(2*pi*t)"}, 1.0)
    # phi reaches pi/2 exactly once per half period: I = 4 m r^2 cos^2(phi) touches 0 between samples
    with pytest.raises(SingularityError, match="singular"):
        analyse_gait(board, {"psi": "sin(2*pi*t)", "phi": "pi/2*sin(2*pi*t + 0.1234)"}, period=1.0)
    with pytest.raises(ShapeError, match="p0"):
        analyse_gait(board, DRIVE, period=1.0, p0=[0.1, 0.2])
    # an angle may wind by whole turns: the rotor spinning once per period is a closed gait
    a = analyse_gait(board, {"psi": "2*pi*t", "phi": "0.3*sin(2*pi*t)"}, period=1.0)
    assert a.winding == (1, 0)


def test_a_loop_enclosing_no_area_has_no_curvature_integral(board):
    # the drive gait runs psi and phi in phase: the loop is a segment traversed there and back, so Stokes gives
    # exactly 0, and the connection-alone turn (the abelian rotation) is 0 as well; the quadrature must
    # converge on the cancelling integrand rather than report a failure
    B = curvature_integral(board, DRIVE, period=1.0)
    assert np.abs(B).max() < 1e-12
    assert abs(geometric_phase(board, DRIVE, period=1.0)[2]) < 1e-12
