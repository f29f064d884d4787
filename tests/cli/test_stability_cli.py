"""`geomech stability` and `geomech stability-map`: JSON a script can read, figures and data files, and
one-line errors with exit status 2."""

import json

import numpy as np
import pytest
from cli_helpers import run


def spin(summary, m):
    return min(summary["equilibria"], key=lambda e: np.linalg.norm(np.array(e["m"]) - m))


@pytest.mark.parametrize(
    "k, expected", [(0.51, ("stable", "stable", "inconclusive")), (0.49, ("inconclusive", "inconclusive", "unstable"))]
)
def test_stability_json_issue_example(capsys, k, expected):
    code, out, err = run(
        capsys, "stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", f"k={k}", "--json"
    )
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["complete"] and len(s["equilibria"]) == 6
    e = spin(s, [0.0, 1.0, 0.0])
    assert (
        e["verdicts"]["lagrange_dirichlet"],
        e["verdicts"]["energy_casimir"],
        e["verdicts"]["linearisation"],
    ) == expected
    # Hessian of h_p at (l, L) = (0, 0): diag(-(1/lambda2 - 1/lambda1) G^2, 1/I3 - 1/lambda2 - k/I3)
    assert e["chart_axis"] == 3 and abs(e["l"]) < 1e-12 and abs(e["L"]) < 1e-12
    np.testing.assert_allclose(e["hessian"], np.diag([-1 / 6, 0.5 - k]), atol=1e-13)
    np.testing.assert_allclose(sorted(e["hessian_eigenvalues"]), sorted([-1 / 6, 0.5 - k]), atol=1e-13)
    eig = [complex(z["re"], z["im"]) for z in e["linearisation_eigenvalues"]]
    np.testing.assert_allclose(sorted(abs(z) for z in eig), [np.sqrt(abs(0.5 - k) / 6)] * 2, rtol=1e-10)
    assert s["hyperregularity"]["status"] == "yes"
    assert s["lemma4"]["max_relative_error"] < 1e-12


def test_stability_text_p_G_and_out(capsys, tmp_path):
    code, out, err = run(
        capsys,
        "stability",
        "--lambda",
        "3",
        "2",
        "--I3",
        "1",
        "--phi",
        "k*v + a*v**3",
        "--param",
        "k=0.3",
        "--param",
        "a=0.5",
        "--p",
        "0.1",
        "--G",
        "1.5",
        "--out",
        str(tmp_path),
    )
    assert code == 0, err
    assert "Lagrange-Dirichlet" in out and "energy-Casimir" in out and "Poincare-Hopf" in out
    s = json.loads((tmp_path / "stability.json").read_text())
    assert s["G"] == 1.5 and all(abs(np.linalg.norm(e["m"]) - 1.5) < 1e-12 for e in s["equilibria"])
    assert (tmp_path / "stability_phase_portrait.png").stat().st_size > 20_000


def test_three_rotors(capsys):
    code, out, err = run(
        capsys,
        "stability",
        "--lambda",
        "3",
        "2",
        "1.2",
        "--phi",
        "0",
        "--phi",
        "0",
        "--phi",
        "k*v",
        "--param",
        "k=0.5",
        "--p",
        "0.05",
        "0",
        "0",
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    assert s["model"]["kind"] == "diagonal" and s["summary"]["complete"]
    code, out, err = run(
        capsys,
        "stability",
        "--lambda",
        "3",
        "2",
        "1.2",
        "--phi",
        "3*c*m2",
        "--phi",
        "2*c*m1",
        "--phi",
        "0",
        "--param",
        "c=0.2",
        "--json",
    )
    assert code == 0, err
    assert json.loads(out)["model"]["kind"] == "three-rotors"


def test_stability_map_writes_figure_and_data(capsys, tmp_path):
    xr = pytest.importorskip("xarray")
    # k is swept: it needs no --param value
    code, out, err = run(
        capsys,
        "stability-map",
        "--lambda",
        "3",
        "2",
        "--I3",
        "1",
        "--phi",
        "k*v",
        "--x",
        "k=0.05:0.95:8",
        "--y",
        "lambda2=1.2:2.8:5",
        "--out",
        str(tmp_path),
        "--json",
    )
    assert code == 0, err
    s = json.loads(out)
    assert s["summary"]["verdict_counts"]["stable"] > 0 and s["summary"]["verdict_counts"]["unstable"] > 0
    assert (tmp_path / "stability_map.png").stat().st_size > 10_000
    ds = xr.open_dataset(tmp_path / "stability_map.nc")
    margin = ds["k"].values[None, :] - (1 - 1 / ds["lambda2"].values[:, None])
    assert np.all((ds["verdict"].values == 1) == (margin > 0))
    ds.close()


def test_stability_map_resumes_its_study(capsys, tmp_path):
    xr = pytest.importorskip("xarray")
    args = ["stability-map", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--x", "k=0.05:0.95:5"]
    args += ["--y", "lambda2=1.2:2.8:4", "--out", str(tmp_path)]
    code, _, err = run(capsys, *args)
    assert code == 0, err
    first = xr.open_dataset(tmp_path / "stability_map.nc").load()
    # run again: the store is there; without --resume that is one line on stderr, with it nothing is left to do
    code, _, err = run(capsys, *args)
    assert code == 2 and "--resume" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, *args, "--resume")
    assert code == 0, err
    again = xr.open_dataset(tmp_path / "stability_map.nc").load()
    np.testing.assert_array_equal(again["verdict"].values, first["verdict"].values)
    np.testing.assert_array_equal(again["m"].values, first["m"].values)
    # other arguments on the same store: refused, naming the study it holds
    code, _, err = run(capsys, *args[:-4], "--y", "lambda2=1.2:2.8:3", "--out", str(tmp_path), "--resume")
    assert code == 2 and "holds another study" in err


@pytest.mark.parametrize(
    "args, needle",
    [
        (["stability", "--lambda", "2", "3", "--I3", "1", "--phi", "k*v", "--param", "k=0.5"], "lambda1 > lambda2"),
        (["stability", "--lambda", "3", "2", "--I3", "-1", "--phi", "k*v", "--param", "k=0.5"], "positive"),
        (["stability", "--lambda", "3", "-2", "--I3", "1", "--phi", "k*v", "--param", "k=0.5"], "positive"),
        (["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v + m1", "--param", "k=0.5"], "v alone"),
        (["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v"], "'k'"),
        (
            [
                "stability",
                "--lambda",
                "3",
                "2",
                "1",
                "--phi",
                "a*m2",
                "--phi",
                "a*m1",
                "--phi",
                "0",
                "--param",
                "a=0.3",
            ],
            "no closed-loop Hamiltonian",
        ),
        (["stability", "--lambda", "3", "--I3", "1", "--phi", "v"], "expected 2 or 3 numbers"),
        (["stability", "--lambda", "3", "2", "1", "--phi", "m1 +", "--phi", "0", "--phi", "0"], "Could not parse"),
        (["stability", "--lambda", "3", "2", "1", "--phi", "v", "--phi", "0"], "three --phi"),
        (["stability", "--lambda", "3", "2", "--phi", "v"], "--I3"),
        (["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", "k=x"], "not a number"),
        (["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", "k=0.5", "--G", "0"], "positive"),
        (
            [
                "stability-map",
                "--lambda",
                "3",
                "2",
                "--I3",
                "1",
                "--phi",
                "k*v",
                "--param",
                "k=0.5",
                "--x",
                "k=0:1",
                "--y",
                "I3=0.5:1:3",
                "--out",
                "unused",
            ],
            "NAME=START:STOP:N",
        ),
        (
            [
                "stability-map",
                "--lambda",
                "3",
                "2",
                "--I3",
                "1",
                "--phi",
                "k*v",
                "--param",
                "k=0.5",
                "--x",
                "q=0:1:3",
                "--y",
                "I3=0.5:1:3",
                "--out",
                "unused",
            ],
            "not a parameter",
        ),
    ],
)
def test_bad_input_is_one_line_and_status_2(capsys, args, needle):
    code, out, err = run(capsys, *args)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("geomech: error:")
    assert needle in err
    assert "Traceback" not in err


def test_stability_map_text_is_a_sentence_not_a_dict(capsys, tmp_path):
    args = ["stability-map", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--x", "k=0.05:0.95:5"]
    code, out, err = run(capsys, *args, "--y", "lambda2=1.2:2.8:4", "--out", str(tmp_path / "a"))
    assert code == 0, err
    code, js, err = run(capsys, *args, "--y", "lambda2=1.2:2.8:4", "--out", str(tmp_path / "b"), "--json")
    counts = json.loads(js)["summary"]["verdict_counts"]
    first = out.splitlines()[0]
    assert "{" not in first and "'" not in first
    assert all(f"{n} {v}" in first for v, n in counts.items() if n)


def test_stability_json_starts_with_its_summary(capsys):
    code, out, err = run(
        capsys, "stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", "k=0.51", "--json"
    )
    assert code == 0, err
    s = json.loads(out)
    assert list(s)[:3] == ["schema", "command", "summary"]
    head, detail = s["summary"], s["equilibria"]
    assert head["n_equilibria"] == len(detail) == 6
    assert head["verdicts"] == [{"m": e["m"], "verdict": e["verdict"]} for e in detail]
    assert sum(head["verdict_counts"].values()) == 6 and head["verdict_counts"]["unstable"] == 2
