"""A sweep over a gait's coefficients and a system's parameters (GaitSweep): the momentum change against the
snakeboard's Bessel closed form at every member, and the net displacement against analyse_gait (the momentum
equation and the reconstruction on the group, an independent route) at a few."""

import numpy as np
import pytest
from scipy.special import jv

from geomech.analysis import GaitSweep, analyse_gait
from geomech.errors import InputError
from geomech.systems.nonholonomic_examples import snakeboard_bkmm

T = 1.3
LOOP = {"psi": "a*sin(2*pi*t/T)", "phi": "b*sin(2*pi*t/T)"}


@pytest.fixture(scope="module")
def board():
    return snakeboard_bkmm(m=1.0, r=1.0, J0=0.3, J1=0.1)


def test_the_momentum_change_is_the_bessel_closed_form_at_every_member(board):
    a, b, J0 = np.linspace(0.5, 1.5, 4), np.linspace(0.2, 0.8, 3), np.array([0.2, 0.3])
    ds = GaitSweep(board, LOOP, period=T, periods=2, p0=[0.7]).run(a=a, b=b, J0=J0, chunk=8)
    assert ds["net_displacement"].dims == ("a", "b", "J0", "coordinate")
    assert list(ds["coordinate"].values) == ["x", "y", "theta"]
    # per period Delta p = 4 pi J0 a w J_1(b), whatever p0 (derived in tests/analysis/test_gaits.py)
    w = 2 * np.pi / T
    want = 2 * 4 * np.pi * J0[None, None, :] * a[:, None, None] * w * jv(1, b)[None, :, None]
    np.testing.assert_allclose(ds["momentum_change"].values[..., 0], want, rtol=1e-8)
    assert (ds["failed"].values == 0).all() and (ds["status"].values == 0).all()


def test_the_net_displacement_is_that_of_analyse_gait(board):
    ds = GaitSweep(board, LOOP, period=T, periods=2, parameters={"b": 0.4}).run(a=np.array([0.6, 1.2]))
    for i, a in enumerate([0.6, 1.2]):
        one = analyse_gait(board, {"psi": f"{a}*sin(2*pi*t/T)", "phi": "0.4*sin(2*pi*t/T)"}, period=T, periods=2)
        np.testing.assert_allclose(ds["net_displacement"].values[i], one.net_displacement, rtol=0, atol=1e-8)


def test_what_a_gait_sweep_refuses(board):
    study = GaitSweep(board, LOOP, period=T)
    with pytest.raises(InputError, match=r"\['nope'\]"):
        study.run(a=np.array([0.5, 1.0]), nope=np.array([1.0, 2.0]), b=np.array([0.1, 0.2]))
    with pytest.raises(InputError, match=r"coefficients \['b'\] have no value"):
        study.run(a=np.array([0.5, 1.0]))
    with pytest.raises(InputError, match="period"):
        GaitSweep(board, LOOP, period=-1.0)
