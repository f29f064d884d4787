"""``geomech methods``: the integrators and their traits, and which fit a given system (and why not)."""

import json

from cli_helpers import run

from geomech.integrators import REGISTRY


def test_every_method_is_listed_with_its_traits(capsys):
    code, out, err = run(capsys, "methods")
    assert code == 0, err
    rows = {line.split()[0]: line for line in out.splitlines()[1:] if not line.startswith(" ")}
    assert set(rows) == set(REGISTRY)
    assert "symplectic, symmetric" in rows["stormer_verlet"] and "canonical" in rows["stormer_verlet"]
    assert max(len(line) for line in out.splitlines()) <= 120


def test_which_methods_fit_a_hamiltonian_and_why_the_others_do_not(capsys):
    quad = ["--hamiltonian", "m1**2/(2*a) + m2**2/4 + m3**2/2", "--param", "a=3", "--json"]
    code, out, err = run(capsys, "methods", *quad)
    assert code == 0, err
    s = json.loads(out)
    assert (
        "moser_veselov" in s["summary"]["fit"] and "symplectic_euler" not in s["summary"]["fit"]
    )  # a free rigid body, not canonical
    code, out, err = run(capsys, "methods", "--hamiltonian", "m1**2/6 + m2**2/4 + m3**2/2 + m3**4/10", "--json")
    s = json.loads(out)
    mv = next(d for d in s["methods"] if d["key"] == "moser_veselov")
    assert not mv["fits"] and "not quadratic" in mv["why_not"]
    assert "splitting_4_yoshida" in s["summary"]["fit"]  # separable: the split flows apply


def test_a_nonholonomic_system_fits_its_own_methods(capsys):
    args = ["methods", "chaplygin_sleigh", "--param", "m=1", "--param", "I_c=0.2", "--param", "a=0.3"]
    code, out, err = run(capsys, *args, "--json")
    assert code == 0, err
    assert set(json.loads(out)["summary"]["fit"]) == {
        "lagrange_dalembert",
        "bkmm",
        "almost_poisson",
        "bates_sniatycki",
        "full_almost_poisson",
        "discrete_lagrange_dalembert",
        "discrete_lagrange_dalembert_group",
    }
    code, out, err = run(capsys, *args)
    assert out.startswith("methods that fit chaplygin_sleigh (7 of") and "not for this system:" in out
    code, _, err = run(capsys, "methods", "snakeboard", "--hamiltonian", "m1**2")
    assert code == 2 and err.count("\n") == 1 and "not both" in err
