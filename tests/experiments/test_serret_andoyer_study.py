"""The seed's section 8.1 study: runs end to end, writes self-describing output all-or-nothing, and its
numbers say what the methods' structure promises."""

import json

import numpy as np
import pytest

from geomech.cli.main import main
from geomech.errors import InputError
from geomech.experiments import serret_andoyer_study as study


@pytest.mark.slow  # the whole study through the command line: over 10 s each
def test_cli_writes_figures_data_and_summary(tmp_path, capsys):
    code = main(["reproduce", "serret-andoyer", "--out", str(tmp_path), "--t-final", "2", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    summary = json.loads(out)
    assert summary == json.loads((tmp_path / "summary.json").read_text())
    for name in ("figure5_errors.png", "figure6_trajectories.png", "figure7_reduced_flow.png"):
        assert (tmp_path / name).stat().st_size > 20_000
    assert not list(tmp_path.glob(".*partial*"))
    import xarray as xr

    ds = xr.open_dataset(tmp_path / "serret_andoyer_study.nc")
    assert ds.attrs["command"].startswith("geomech reproduce serret-andoyer")
    assert json.loads(ds.attrs["parameters"])["Hc"] == 0.47
    assert ds.time.attrs["units"] == "s" and ds.time.size == 201
    per = summary["approaches"]
    assert set(per) >= {"full6d_adams", "euler_adams", "reduced_adams", "reduced_generating", "reduced_midpoint"}
    # the reduced representations keep |m| = G by construction; the splitting keeps it to round-off
    for k in ("reduced_adams", "reduced_generating", "reduced_midpoint", "reduced_gauss3"):
        assert per[k]["max_momentum_error"] < 1e-14  # G = 1: |m| = G to a few ulps, far below a drift
    assert per["euler_splitting4"]["max_momentum_error"] < 1e-13
    assert per["euler_adams"]["max_momentum_error"] > 1e-9  # Adams does not, at tolerance 1e-6
    # at h = 1 ms the symplectic second-order methods beat Adams at tolerance 1e-6 on energy
    assert per["reduced_midpoint"]["max_energy_error"] < per["reduced_adams"]["max_energy_error"]
    assert per["reduced_gauss3"]["max_energy_error"] < 1e-13
    first = ds.m.isel(time=0).values
    np.testing.assert_allclose(first, np.broadcast_to(first[0], first.shape), atol=1e-12)
    # the data behind figure 7: (l, L) of every reduced approach on the level H_c, and the h_p grid
    reduced = [str(k) for k in ds.reduced_approach.values]
    assert set(reduced) == {
        "reduced_adams",
        "reduced_generating",
        "reduced_midpoint",
        "reduced_gauss2",
        "reduced_gauss3",
    }
    assert ds.h_p.dims == ("L_grid", "l_grid") and ds.lL.attrs["units"]
    l0, L0 = ds.lL.sel(reduced_approach="reduced_midpoint").isel(time=0).values
    hp_at = ds.h_p.interp(l_grid=l0, L_grid=L0).item()
    assert hp_at == pytest.approx(0.47, abs=2e-3)  # bilinear on the grid: the level is the study's H_c
    # the seed's "output every h": maxima over every step, the data file keeps every save_every-th
    for k, a in per.items():
        assert a["errors_sampled_every_s"] == pytest.approx(1e-3)
        assert a["max_energy_error"] >= float(ds.energy_error.sel(approach=k).max())
    # compile time is apart: the run time of a numba method is its loop, not the compiler's
    for a in per.values():
        assert a["wall_time_s"] >= 0 and a["compile_time_s"] >= 0
    np.testing.assert_allclose(ds.compile_time.values, [per[k]["compile_time_s"] for k in ds.approach.values])
    # the orbit's period, and each approach's signed drift of |m| read off its own data
    assert summary["summary"]["orbit"]["kind"] == "libration" and summary["summary"]["orbit"]["period_s"] > 2.0
    final = np.linalg.norm(ds.m.isel(time=-1).values, axis=-1) - 1.0
    for k, d in zip(ds.approach.values, final):
        if abs(d) > 1e-10:  # the data file keeps the run's last state
            assert np.sign(per[str(k)]["momentum_drift_final"]) == np.sign(d)
            assert per[str(k)]["momentum_drift_direction"] == ("outward" if d > 0 else "inward")
    inside = summary["summary"]["claims"]["full_6d_stays_inside_the_sphere"]
    assert inside["holds"] == (per["full6d_adams"]["momentum_drift_final"] < 0)
    # "whatever the method": the midpoint rule also runs on Euler's equations
    assert (
        "reduced_midpoint vs euler_midpoint"
        in summary["summary"]["claims"]["reduced_form_better_whatever_the_method"]["evidence"]
    )


@pytest.mark.slow  # the whole study through the command line: over 10 s each
def test_cli_lambda_sets_the_inertias(tmp_path, capsys):
    code = main(
        [
            "reproduce",
            "serret-andoyer",
            "--out",
            str(tmp_path),
            "--t-final",
            "0.05",
            "--lambda",
            "1.3",
            "1.0",
            "--no-extras",
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(out)["config"]["lambda1"] == 1.3
    code = main(["reproduce", "serret-andoyer", "--out", str(tmp_path), "--lambda", "1.3"])
    assert code == 2 and "expected 2 numbers" in capsys.readouterr().err


def test_cli_refuses_an_unwritable_directory_and_an_oversized_run_before_any_work(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("")
    code = main(["reproduce", "serret-andoyer", "--out", str(blocker / "sub"), "--t-final", "0.01"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Cannot write into `--out`" in err
    code = main(["reproduce", "serret-andoyer", "--out", str(tmp_path / "big"), "--t-final", "1e5"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "raise save_every (--save-every) to at least 20" in err
    code = main(["reproduce", "serret-andoyer", "--out", str(tmp_path / "big"), "--t-final", "1e308"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "beyond the range of double precision" in err and "--max-steps" in err
    assert not (tmp_path / "big").exists()


@pytest.mark.slow  # a convergence study over step sizes
def test_midpoint_energy_error_is_second_order():
    errs = []
    for h in (4e-3, 2e-3):
        cfg = study.StudyConfig(h=h, t_final=2.0, save_every=1, extras=False)
        model = study.build_model(cfg)
        mid = [a for a in study.approaches(cfg) if a.key == "reduced_midpoint"][0]
        errs.append(study.run_approach(model, mid, cfg)["energy_error"].max())
    assert 3.6 < errs[0] / errs[1] < 4.4


def test_initial_state_is_on_the_level_about_the_intermediate_axis():
    cfg = study.StudyConfig()
    model = study.build_model(cfg)
    assert float(model.system.hamiltonian(model.m0)) == pytest.approx(0.47, abs=1e-14)
    assert abs(model.m0[1]) > abs(model.m0[0]) and model.m0[2] == 0.0
    p = model.R0 @ model.m0
    assert np.degrees(np.arccos(p[2] / np.linalg.norm(p))) == pytest.approx(30.0)


@pytest.mark.slow  # runs of the study, interrupted and resumed
def test_inadmissible_inertias_and_interrupted_runs(tmp_path, monkeypatch):
    with pytest.raises(InputError, match="intermediate"):
        study.StudyConfig(lambda1=1.0, lambda2=1.2).validate()
    with pytest.raises(InputError, match="orbit about the intermediate axis"):
        study.StudyConfig(lambda1=3.0, lambda2=2.0, I3=1.0).validate()
    cfg = study.StudyConfig(t_final=0.2, extras=False)
    ds, summary, model = study.run_study(cfg)

    def boom(*_a, **_k):
        raise KeyboardInterrupt

    monkeypatch.setattr(study, "figure7", boom)
    with pytest.raises(KeyboardInterrupt):
        study.write_study(tmp_path, ds, summary, model, cfg)
    assert list(tmp_path.iterdir()) == []
    # interrupted in the middle of writing a file: the partial file is removed too
    original = study.figure6

    def half_written(ds_, G):
        fig = original(ds_, G)

        def savefig(path, **_k):
            open(path, "wb").write(b"\x89PNG half")
            raise KeyboardInterrupt

        fig.savefig = savefig
        return fig

    monkeypatch.setattr(study, "figure6", half_written)
    with pytest.raises(KeyboardInterrupt):
        study.write_study(tmp_path, ds, summary, model, cfg)
    assert list(tmp_path.iterdir()) == []


def test_the_orbit_period_of_the_named_preset():
    # lambda = (1.5, 1.0), I3 = 0.6, J3 = 0.3: 7.0155791512 s by an independent computation (the issue's); the
    # periodic-orbit propagator and the quadrature of the level curve agree with it
    from geomech.experiments.serret_andoyer_study import StudyConfig, _orbit, build_model
    from geomech.integrators.quadrature import QuadraturePropagator

    cfg = StudyConfig(lambda1=1.5, lambda2=1.0, I3=0.6, J3=0.3)
    model = build_model(cfg)
    orbit = _orbit(cfg, model)
    assert orbit["kind"] == "libration" and abs(orbit["period_s"] - 7.0155791512) < 1e-9
    quad = QuadraturePropagator(model.reduction.reduced_system(cfg.G, 2), model.lL0)
    assert abs(quad.period - orbit["period_s"]) < 1e-9 * orbit["period_s"]


@pytest.mark.slow  # a run of the study through the command line
def test_the_cross_checked_preset_from_the_command_line(tmp_path, capsys):
    # the preset's period (independent: 7.0155791512 s) and the errors of the seed's approaches over half a second
    args = ["reproduce", "serret-andoyer", "--preset", "cross-checked", "--t-final", "0.5", "--no-extras"]
    code = main([*args, "--out", str(tmp_path), "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(out)
    assert {k: doc["config"][k] for k in ("lambda1", "lambda2", "I3", "J3")} == study.PRESETS["cross-checked"][
        "inertias"
    ]
    assert abs(doc["summary"]["orbit"]["period_s"] - 7.0155791512) < 1e-9
    per = doc["approaches"]
    for k in ("reduced_adams", "reduced_generating", "reduced_midpoint"):
        assert per[k]["max_momentum_error"] < 1e-14  # |m| = G by construction (G = 1)
    # Adams at tolerance 1e-6 keeps neither; the midpoint rule's energy error is O(h^2) = 1e-6 at most here
    assert per["euler_adams"]["max_momentum_error"] > 1e-12 and per["full6d_adams"]["max_momentum_error"] > 1e-12
    assert per["reduced_midpoint"]["max_energy_error"] < 1e-6
    code = main([*args, "--lambda", "1.5", "1.0", "--out", str(tmp_path / "b")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--preset" in err and "--lambda" in err
    from geomech.cli.reproduce import _PRESET_NAMES

    assert set(_PRESET_NAMES) == set(study.PRESETS)
    assert study.StudyConfig.preset("default") == study.StudyConfig()


def test_chart_coordinates_invert_the_chart():
    from geomech.reduction import SerretAndoyerChart

    rng = np.random.default_rng(5)
    lL = np.column_stack([rng.uniform(-3, 3, 50), rng.uniform(-0.95, 0.95, 50)])
    m = SerretAndoyerChart(2).inverse(lL, 1.0)
    from geomech.experiments.serret_andoyer_figures import chart_coordinates

    np.testing.assert_allclose(chart_coordinates(m), lL, atol=1e-14)
    # off the sphere the chart still reads l from the direction and L = m3
    np.testing.assert_allclose(chart_coordinates(1.01 * m), np.column_stack([lL[:, 0], 1.01 * lL[:, 1]]))


@pytest.mark.slow  # a run of the study
def test_figures_6_and_7_show_every_approach_and_the_drift():
    cfg = study.StudyConfig(t_final=0.2, extras=False)
    ds, _, _ = study.run_study(cfg)
    n = ds.approach.size
    ax = study.figure7(ds, cfg).axes[0]
    labels = [line.get_label() for line in ax.lines if not line.get_label().startswith("_")]
    assert len(labels) == n and sum("(mapped by the chart)" in x for x in labels) == n - ds.reduced_approach.size
    drift = study.figure6(ds, cfg.G).axes[-1]
    assert drift.get_yscale() == "symlog" and len(drift.lines) == n + 1  # every approach, and the zero line
    full = next(
        line for line in drift.lines if line.get_label().startswith(str(ds.label.sel(approach="full6d_adams").values))
    )
    want = np.linalg.norm(ds.m.sel(approach="full6d_adams").values, axis=-1) - cfg.G
    np.testing.assert_allclose(full.get_ydata(), want)
    import matplotlib.pyplot as plt

    plt.close("all")
