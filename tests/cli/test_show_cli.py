"""``geomech show``: a NetCDF file geomech wrote, read back and summarised (and re-plotted)."""

import json

import numpy as np
import pytest
from cli_helpers import run

from geomech import LeftInvariantSystem, solve

xr = pytest.importorskip("xarray")


def test_a_written_trajectory_reads_back(capsys, tmp_path):
    system = LeftInvariantSystem.from_expression("m1**2/(2*a) + m2**2/4 + m3**2/2", {"a": 3.0})
    sol = solve(system, "implicit_midpoint", m0=[1.0, 0.3, 0.2], h=0.01, t_final=2.0, saveat=21)
    path = tmp_path / "run.nc"
    sol.to_dataset().to_netcdf(path)
    code, out, err = run(capsys, "show", str(path), "--json", "--out", str(tmp_path / "fig"))
    assert code == 0, err
    s = json.loads(out)
    assert s["dims"]["t"] == 21 and s["attributes"]["status"] == "success"
    assert s["attributes"]["parameters"] == {"a": 3.0}
    np.testing.assert_allclose(s["variables"]["m"]["final"], sol.m[-1], rtol=1e-15)
    assert (tmp_path / "fig" / "show.png").stat().st_size > 5_000
    code, text, err = run(capsys, "show", str(path))
    assert code == 0 and text.startswith("run.nc: t 21") and "a = 3" in text


def test_bad_files_are_one_line(capsys, tmp_path):
    bad = tmp_path / "not.nc"
    bad.write_text("not netcdf")
    for p in (bad, tmp_path / "missing.nc"):
        code, _, err = run(capsys, "show", str(p))
        assert code == 2 and err.count("\n") == 1
