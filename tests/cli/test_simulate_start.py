"""``geomech simulate``: where the board starts (at rest unless told otherwise) and the NetCDF data file."""

import json

import numpy as np
import pytest

from geomech.cli.main import main
from geomech.errors import InputError
from geomech.integrators import LagrangeDAlembert, initial_state, solve
from geomech.systems.nonholonomic_examples import roller_racer, snakeboard

BOARD = ["--param", "m=1", "--param", "r=0.5", "--param", "J=0.18", "--param", "J0=0.05", "--param", "J1=0.01"]


def test_the_board_starts_at_rest_even_off_phi_zero(tmp_path, capsys):
    # phi(0) = 0.5: the old default (momentum 0) gave x' and theta' != 0 at the start
    code = main(
        [
            "simulate",
            "snakeboard",
            *BOARD,
            "--shape",
            "psi=sin(2*pi*t)",
            "--shape",
            "phi=0.5*cos(2*pi*t)",
            "--t-final",
            "0.5",
            "--json",
            "--out",
            str(tmp_path),
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    s = json.loads(out)
    assert s["initial_state"].startswith("at rest")
    v0 = s["initial_velocity"]
    assert v0["x_dot"] == v0["y_dot"] == v0["theta_dot"] == 0.0 and v0["psi_dot"] == pytest.approx(2 * np.pi)
    # at rest the momentum is not zero: the rotor and the wheels carry it (p from the shape velocities)
    assert abs(s["initial_momentum"][0]) > 1e-3
    import xarray as xr

    ds = xr.open_dataset(tmp_path / "trajectory.nc")
    assert list(ds.coordinate.values) == ["x", "y", "theta", "psi", "phi"]
    assert ds.attrs["command"].startswith("geomech simulate snakeboard") and ds.attrs["initial_state"].startswith("at")
    np.testing.assert_allclose(ds.q.isel(t=-1).values, list(s["summary"]["final_configuration"].values()), atol=1e-12)
    assert float(np.abs(ds.constraint_residual).max()) < 1e-8


def test_rest_where_the_constraints_forbid_it():
    # the roller racer's rear-wheel constraint holds phi': a turning joint moves the body
    racer = roller_racer().with_parameters(**{k: 1.0 for k in ("m1", "m2", "I1", "I2", "d1", "d2")})
    with pytest.raises(InputError, match="cannot start at rest"):
        initial_state(racer, {"phi": "0.3*sin(2*pi*t)"}, qdot0="rest")


def test_api_rest_start_equals_the_cli_one():
    board = snakeboard(m=1, r=0.5, J=0.18, J0=0.05, J1=0.01)
    sol = solve(
        board, LagrangeDAlembert(), t_final=0.2, shapes={"psi": "sin(2*pi*t)", "phi": "0.5*cos(2*pi*t)"}, qdot0="rest"
    )
    assert np.all(sol.qdot[0, :3] == 0.0) and float(np.abs(sol.constraint_residual).max()) < 1e-8
    with pytest.raises(InputError, match="not both"):
        initial_state(board, {"psi": "sin(2*pi*t)", "phi": "0"}, qdot0="rest", p0=[0.0])
