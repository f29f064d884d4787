"""The Serret-Andoyer integrator study over a grid of step sizes (IntegratorSweep, `reproduce serret-andoyer
--sweep`): the midpoint rule's energy error shrinks as h^2 (its order) and the Adams runs, whose steps the
tolerance chooses, do not depend on h; bad sweeps are one line on stderr."""

import numpy as np
import pytest

from geomech.cli.main import main
from geomech.experiments.serret_andoyer_study import StudyConfig
from geomech.experiments.serret_andoyer_sweep import IntegratorSweep


@pytest.mark.slow
def test_the_midpoint_rule_is_second_order_across_the_sweep():
    ds = IntegratorSweep(StudyConfig(t_final=1.0, extras=False)).run(h=np.array([0.01, 0.02]))
    e = ds["max_energy_error"]
    midpoint = e.sel(approach="reduced_midpoint").values
    slope = np.log2(midpoint[1] / midpoint[0])
    assert abs(slope - 2.0) < 0.2, slope
    assert (ds["status"].values == 0).all() and np.isfinite(e.values).all()


@pytest.mark.parametrize(
    "args, words",
    [
        (["--sweep", "G=0.5:1:2"], "sweep one of h, lambda1"),
        (["--sweep", "h=0.01:0.02:2", "--sweep", "h=0.01:0.03:2"], "swept twice"),
        (["--resume"], "give --sweep"),
        (["--sweep", "h=0.02:0.01:2"], "START < STOP"),
    ],
)
def test_bad_sweeps_are_one_line(args, words, capsys, tmp_path):
    code = main(["reproduce", "serret-andoyer", "--t-final", "0.01", "--no-extras", "--out", str(tmp_path), *args])
    err = capsys.readouterr().err
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
