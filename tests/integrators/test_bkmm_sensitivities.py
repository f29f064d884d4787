"""Sensitivities of the BKMM equations (the variational equations by forward differentiation of their generated
straight-line code, integrated with the state) against central differences of runs from perturbed initial states
and parameters: a second route to every column."""

import numpy as np
import pytest

from geomech import solve
from geomech.errors import InputError
from geomech.integrators import BKMM, LagrangeDAlembert
from geomech.systems.nonholonomic_examples import roller_racer, snakeboard

SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)
RACER = dict(m1=1.0, m2=0.8, I1=0.3, I2=0.2, d1=0.5, d2=0.6)
TOL = dict(rtol=1e-12, atol=1e-13)


def test_the_snakeboards_gait_sensitivities_are_central_differences():
    gait = {"psi": "a*sin(2*pi*t)", "phi": "b*sin(2*pi*t)"}
    kw = dict(t_final=2.0, saveat=5, shapes=gait, **TOL)

    def state(a=1.0, b=0.5, m=1.0, p=0.2):
        sol = solve(snakeboard(**{**SNAKE, "m": m}), BKMM(), parameters={"a": a, "b": b}, p0=[p], **kw)
        return np.r_[sol.q[-1, :3], sol.quantities["momentum"][-1], sol.quantities["work"][-1]]

    sol = solve(snakeboard(**SNAKE), BKMM(), parameters={"a": 1.0, "b": 0.5}, p0=[0.2], sensitivities=["a", "m"], **kw)
    stm, sens = sol.quantities["stm"], sol.quantities["parameter_sensitivity"]
    assert stm.shape == (5, 5, 5) and sens.shape == (5, 5, 2)
    np.testing.assert_array_equal(stm[0], np.eye(5))
    np.testing.assert_array_equal(sens[0], 0.0)
    e = 1e-5
    for column, (lo, hi) in {
        0: (state(a=1 - e), state(a=1 + e)),
        1: (state(m=1 - e), state(m=1 + e)),
    }.items():
        fd = (hi - lo) / (2 * e)
        np.testing.assert_allclose(sens[-1][:, column], fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))
    fd = (state(p=0.2 + e) - state(p=0.2 - e)) / (2 * e)
    np.testing.assert_allclose(stm[-1][:, 3], fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))
    # the group coordinates do not enter the reduced equations but through x, y's rotation by theta
    np.testing.assert_array_equal(stm[-1][3, :3], 0.0)


def test_a_free_shape_under_a_torque_with_a_coefficient():
    # the roller racer's joint is a free shape: its angle and rate are state too, the torque's gain a coefficient
    tau = {"phi": "0.3*sin(3*t) - k*phi_dot"}
    kw = dict(t_final=2.0, saveat=3, tau=tau, q0={"phi": 0.2}, p0=[0.1], **TOL)

    def state(k=0.05, phi=0.2, I1=0.3):
        sol = solve(roller_racer(**{**RACER, "I1": I1}), BKMM(), parameters={"k": k}, **{**kw, "q0": {"phi": phi}})
        return np.r_[sol.q[-1], sol.qdot[-1, 3], sol.quantities["momentum"][-1], sol.quantities["work"][-1]]

    sol = solve(roller_racer(**RACER), BKMM(), parameters={"k": 0.05}, sensitivities=["k", "I1"], **kw)
    stm, sens = sol.quantities["stm"][-1], sol.quantities["parameter_sensitivity"][-1]
    assert stm.shape == (7, 7) and sens.shape == (7, 2)  # (x, y, theta, phi, phi_dot, p, W)
    e = 1e-5
    for column, (lo, hi) in {
        0: (state(k=0.05 - e), state(k=0.05 + e)),
        1: (state(I1=0.3 - e), state(I1=0.3 + e)),
    }.items():
        fd = (hi - lo) / (2 * e)
        np.testing.assert_allclose(sens[:, column], fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))
    fd = (state(phi=0.2 + e) - state(phi=0.2 - e)) / (2 * e)
    np.testing.assert_allclose(stm[:, 3], fd, rtol=0, atol=1e-6 * max(1.0, np.abs(fd).max()))


def test_a_batch_carries_each_members_sensitivities():
    s = snakeboard(**SNAKE)
    kw = dict(t_final=1.0, saveat=3, shapes={"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, **TOL)
    batch = solve(s, BKMM(), parameters={"a": np.array([0.8, 1.2])}, sensitivities=["a"], threads=2, **kw)
    assert batch.quantities["parameter_sensitivity"].shape == (2, 3, 5, 1)
    for i, a in enumerate((0.8, 1.2)):
        one = solve(s, BKMM(), parameters={"a": a}, sensitivities=["a"], **kw)
        for name in ("stm", "parameter_sensitivity"):
            np.testing.assert_allclose(batch.quantities[name][i], one.quantities[name], rtol=0, atol=1e-10)


def test_what_has_no_variational_equations_is_refused_by_name():
    s = snakeboard(**SNAKE)
    kw = dict(t_final=0.5, shapes={"psi": "a*sin(2*pi*t)", "phi": "0.5*sin(2*pi*t)"}, parameters={"a": 1.0})
    for method, extra in [
        (LagrangeDAlembert(), {}),
        (BKMM(solver="taylor"), {}),
        (BKMM(solver="Radau"), {}),
        (BKMM(), {"backend": "python"}),
        (BKMM(), {"events": {"e": "psi"}}),
    ]:
        with pytest.raises(InputError, match="variational equations of its BKMM equations"):
            solve(s, method, sensitivities=True, **kw, **extra)
    with pytest.raises(
        InputError, match=r"names of the parameters of snakeboard .*'J0', 'J1', 'm', 'r', 'a'\]\), got \['c'\]"
    ):
        solve(s, BKMM(), sensitivities=["c"], **kw)
