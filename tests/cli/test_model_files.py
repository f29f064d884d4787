"""A user's own model file for `geomech stability` and `geomech stability-map`: a left-invariant H of their own
(checked against the classical verdicts on the free rigid body) or a rotor control built in the file (checked
against the same control given by options), and the errors when the two ways are mixed."""

import json

import numpy as np
import pytest
from cli_helpers import run

FREE_BODY = """
from geomech import LeftInvariantSystem

system = LeftInvariantSystem.from_expression("m1**2/(2*I1) + m2**2/(2*I2) + m3**2/(2*I3)",
                                             {"I1": 3.0, "I2": 2.0, "I3": 1.0}, name="my free body")
"""

CONTROL = """
from geomech import RotorBody, StructurePreservingControl


def build(k=0.51, lambda2=2.0):
    body = RotorBody.one_rotor(3.0, lambda2, 1.0)
    return StructurePreservingControl.one_rotor(body, "k*v", parameters={"k": k}, probe_radius=1.0)
"""


def nearest(summary, m):
    return min(summary["equilibria"], key=lambda e: np.linalg.norm(np.array(e["m"]) - m))


def test_a_hamiltonian_of_ones_own_has_the_classical_verdicts(capsys, tmp_path):
    # Free rigid body I = (3, 2, 1): spins about the major and minor axes are stable (energy-Casimir), about
    # the intermediate axis unstable (a real pair of linearisation eigenvalues +-sqrt((1/2 - 1/3)(1 - 1/2)) G).
    f = tmp_path / "body.py"
    f.write_text(FREE_BODY)
    code, out, err = run(capsys, "stability", "--model", str(f), "--G", "2", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert len(s["equilibria"]) == 6 and "m1**2" in s["hamiltonian"]
    for axis, verdict in ((0, "stable"), (2, "stable")):
        m = np.zeros(3)
        m[axis] = 2.0
        assert nearest(s, m)["verdicts"]["energy_casimir"] == verdict
    e = nearest(s, [0.0, 2.0, 0.0])
    assert e["verdicts"]["linearisation"] == "unstable"
    eig = sorted(complex(z["re"], z["im"]).real for z in e["linearisation_eigenvalues"])
    want = 2.0 * np.sqrt((1 / 2 - 1 / 3) * (1 - 1 / 2))
    np.testing.assert_allclose([eig[0], eig[-1]], [-want, want], rtol=1e-9)
    code, out, err = run(capsys, "stability", "--model", str(f))
    assert code == 0 and out.startswith("H(m) = ")


def test_a_control_in_a_file_is_the_control_given_by_options(capsys, tmp_path):
    f = tmp_path / "control.py"
    f.write_text(CONTROL)
    by_file = json.loads(run(capsys, "stability", "--model", str(f), "--param", "k=0.49", "--json")[1])
    by_options = json.loads(
        run(capsys, "stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", "k=0.49", "--json")[1]
    )
    assert by_file["closed_loop_hamiltonian"] == by_options["closed_loop_hamiltonian"]
    assert by_file["equilibria"] == by_options["equilibria"]
    # the map over the file's build(k, lambda2) is the map of the same family given by options
    grid = ("--x", "k=0.3:0.7:5", "--y", "lambda2=1.5:2.5:3", "--json")
    code, out, err = run(capsys, "stability-map", "--model", str(f), *grid, "--out", str(tmp_path / "a"))
    assert code == 0, err
    code, out2, err = run(
        capsys,
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
        *grid,
        "--out",
        str(tmp_path / "b"),
    )
    assert code == 0, err
    assert json.loads(out)["summary"]["verdict_counts"] == json.loads(out2)["summary"]["verdict_counts"]
    xr = pytest.importorskip("xarray")
    a = xr.open_dataset(tmp_path / "a" / "stability_map.nc")
    b = xr.open_dataset(tmp_path / "b" / "stability_map.nc")
    np.testing.assert_array_equal(a["verdict"].values, b["verdict"].values)
    assert len(set(a["verdict"].values.ravel().tolist())) > 1  # the grid crosses the boundary k = 1/2


@pytest.mark.parametrize(
    "args, words",
    [
        (["stability", "--model", "{file}", "--lambda", "3", "2"], "not both"),
        (["stability"], "--model FILE.py"),
        (["stability-map", "--model", "{file}", "--x", "nope=0:1:3", "--y", "k=0:1:3", "--out", "{dir}"], "'nope'"),
        (["stability", "--model", "{file}", "--param", "zeta=1"], "rejected the parameters"),
    ],
)
def test_mixed_or_unknown_is_one_line_and_status_2(capsys, tmp_path, args, words):
    f = tmp_path / "control.py"
    f.write_text(CONTROL)
    argv = [a.format(file=f, dir=tmp_path / "out") for a in args]
    code, out, err = run(capsys, *argv)
    assert code == 2 and words in err and err.count("\n") == 1, err


def test_a_file_defining_system_takes_param_values(capsys, tmp_path):
    # I = (1.5, 2, 1): axis 1 is now the intermediate axis, so the spin about it is the unstable one
    f = tmp_path / "body.py"
    f.write_text(FREE_BODY)
    code, out, err = run(capsys, "stability", "--model", str(f), "--param", "I1=1.5", "--json")
    assert code == 0, err
    s = json.loads(out)
    assert nearest(s, [1.0, 0.0, 0.0])["verdicts"]["linearisation"] == "unstable"
    assert nearest(s, [0.0, 1.0, 0.0])["verdicts"]["energy_casimir"] == "stable"
