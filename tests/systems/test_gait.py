"""One type for prescribed shapes: the same Gait drives a simulation and, with a period, is a phase loop."""

from __future__ import annotations

import numpy as np
import pytest

import geomech as gm
from geomech.analysis import gait_loop
from geomech.errors import InputError
from geomech.systems.nonholonomic_examples import snakeboard

SNAKE = dict(m=1.0, r=0.5, J=0.18, J0=0.05, J1=0.01)


def test_derivatives_are_exact_and_T_is_the_period():
    g = gm.Gait.from_expressions({"psi": "sin(2*pi*t/T)", "phi": "0.5*t**2"}, period=2.0)
    t = np.array([0.0, 0.3, 1.7])
    w = np.pi  # 2 pi / T
    np.testing.assert_allclose(g.r(t)[:, 0], np.sin(w * t), rtol=0, atol=1e-15)
    np.testing.assert_allclose(g.rdot(t)[:, 0], w * np.cos(w * t), rtol=1e-14)
    np.testing.assert_allclose(g.rddot(t)[:, 0], -(w**2) * np.sin(w * t), rtol=1e-14, atol=1e-14)
    r, rd, rdd = g(0.3)
    assert (r[1], rd[1], rdd[1]) == pytest.approx((0.045, 0.3, 1.0), rel=1e-14)
    with pytest.raises(InputError, match="`T` is the period: give `period`"):
        gm.Gait.from_expressions({"psi": "sin(2*pi*t/T)"})
    # a corner has no acceleration: refused where the gait is made, by name
    with pytest.raises(InputError, match=r"shapes\['phi'\].*no second derivative.*smooth formula"):
        gm.Gait.from_expressions({"psi": "sin(t)", "phi": "abs(sin(2*pi*t))"})
    with pytest.raises(InputError, match="no second derivative"):
        gm.solve(snakeboard(**SNAKE), "bkmm", t_final=1.0, shapes={"psi": "sign(t - 0.5)", "phi": "0"})


def test_a_gait_at_one_time_is_its_formulas_there_however_often_asked():
    """The values at a time are kept for the next run from the same start: the same numbers, which no caller can
    change, and right at every time however many times came between."""
    g = gm.Gait.from_expressions({"psi": "cos(3*t)", "phi": "t**3"})
    first = g(0.25)
    for t in [0.25, *np.linspace(-1.0, 1.0, 40), 0.25, 0.7]:
        r, rd, rdd = g(t)
        expected = [[np.cos(3 * t), t**3], [-3 * np.sin(3 * t), 3 * t**2], [-9 * np.cos(3 * t), 6 * t]]
        np.testing.assert_allclose([r, rd, rdd], expected, rtol=1e-14, atol=1e-14)
    for kept, again in zip(first, g(0.25)):
        np.testing.assert_array_equal(kept, again)
        with pytest.raises(ValueError, match="read-only"):
            kept[0] = 1.0


def test_a_gait_without_period_drives_a_simulation_but_is_not_a_loop():
    s = snakeboard(**SNAKE)
    gait = gm.Gait.from_expressions({"psi": "0.3*t", "phi": "0.2"})
    sol = gm.solve(s, "bkmm", t_final=1.0, shapes=gait, saveat=5)
    np.testing.assert_allclose(sol.r[:, 0], 0.3 * sol.t, atol=1e-13)
    np.testing.assert_allclose(sol.r[:, 1], 0.2, atol=1e-13)
    with pytest.raises(InputError, match="has no period"):
        gait_loop(s, gait)


def test_the_same_periodic_gait_is_a_simulation_input_and_a_closed_loop():
    s = snakeboard(**SNAKE)
    loop = gm.Gait.from_expressions({"psi": "0.4*sin(2*pi*t)", "phi": "0.3*cos(2*pi*t)"}, period=1.0)
    assert gait_loop(s, loop) is loop
    by_object = gm.solve(s, "bkmm", t_final=1.0, shapes=loop, saveat=3)
    by_text = gm.solve(s, "bkmm", t_final=1.0, shapes={"psi": "0.4*sin(2*pi*t)", "phi": "0.3*cos(2*pi*t)"}, saveat=3)
    np.testing.assert_array_equal(by_object.q, by_text.q)


def test_a_gait_without_names_prescribes_every_shape_in_order_or_is_refused():
    s = snakeboard(**SNAKE)
    both = gm.Gait.ellipse([0.0, 0.0], [0.4, 0.3], 1.0)  # no names: (psi, phi) in the system's order
    named = gm.Gait.ellipse([0.0, 0.0], [0.4, 0.3], 1.0, names=("psi", "phi"))
    a = gm.solve(s, "bkmm", t_final=1.0, shapes=both, saveat=3)
    b = gm.solve(s, "bkmm", t_final=1.0, shapes=named, saveat=3)
    np.testing.assert_array_equal(a.q, b.q)
    one = gm.Gait.from_expressions(["sin(t)"])
    with pytest.raises(InputError, match="without names"):
        gm.solve(s, "bkmm", t_final=1.0, shapes=one)
