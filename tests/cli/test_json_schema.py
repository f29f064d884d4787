"""One JSON schema for every command: each command's --json document validates against schema.json, starts
with schema, command and the summary block, and a name renamed in one command's document fails validation."""

import copy
import json

import jsonschema
import pytest
from cli_helpers import run

from geomech.cli._args import SCHEMA, schema

SNAKE = ["snakeboard_bkmm", "--param", "m=1", "--param", "r=1", "--param", "J0=0.3", "--param", "J1=0.1"]
SLEIGH = ["chaplygin_sleigh", "--param", "m=1", "--param", "a=0.5", "--param", "I_c=0.2"]
BODY = ["--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2"]
ROTOR = ["--lambda", "3", "2", "--I3", "1", "--phi", "k*v"]
H = ["--hamiltonian", "m1**2/(2*a) + m2**2/4 + m3**2/2", "--param", "a=3"]

# one invocation of every command (the cheap end of each); {out} is a fresh directory
COMMANDS = {
    "rigid-body": ["rigid-body", *BODY, "--t-final", "2", "--samples", "11"],
    "reduce": ["reduce", *H],
    "stability": ["stability", *ROTOR, "--param", "k=0.51"],
    "stability-map": ["stability-map", *ROTOR, "--x", "k=0.05:0.95:2", "--y", "lambda2=1.2:2.8:2", "--out", "{out}"],
    "phase two-bodies": ["phase", "two-bodies", "--I1", "1", "--I2", "3", "--mu", "-2.5", "--period", "5.5"],
    "phase rigid-body": ["phase", "rigid-body", *BODY],
    "phase loop": ["phase", "loop", "two_bodies", "--shape", "psi=2*pi*t/T", "--mu", "0.5"],
    "simulate": ["simulate", *SLEIGH, "--t-final", "0.2", "--out", "{out}"],
    "simulate --hamiltonian": ["simulate", *H, "--momentum", "1", "0.3", "0.2", "--t-final", "1"],
    "derive": ["derive", "chaplygin_sleigh", "--section", "bkmm"],
    "methods": ["methods", "--hamiltonian", "m1**2/6 + m2**2/4 + m3**2/2"],
    "gait": [
        "gait",
        *SNAKE,
        "--shape-loop",
        "psi=0.3*sin(2*pi*t/T)",
        "--shape-loop",
        "phi=0.2*cos(2*pi*t/T)",
        "--period",
        "1",
    ],
    "gait sweep": [
        "gait",
        *SNAKE,
        "--shape-loop",
        "psi=a*sin(2*pi*t/T)",
        "--shape-loop",
        "phi=0.2*cos(2*pi*t/T)",
        "--period",
        "1",
        "--sweep",
        "a=0.2:0.4:2",
        "--out",
        "{out}",
    ],
    "reproduce serret-andoyer": ["reproduce", "serret-andoyer", "--t-final", "0.02", "--no-extras", "--out", "{out}"],
    "reproduce serret-andoyer sweep": [
        "reproduce",
        "serret-andoyer",
        "--t-final",
        "0.02",
        "--no-extras",
        "--sweep",
        "h=0.001:0.002:2",
        "--out",
        "{out}",
    ],
}


def _document(capsys, tmp_path, args):
    code, out, err = run(capsys, *(a.replace("{out}", str(tmp_path / "out")) for a in args), "--json")
    assert code == 0, err
    return json.loads(out)


@pytest.fixture(scope="module")
def validator():
    return jsonschema.Draft202012Validator(schema())


def test_the_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(schema())
    assert schema()["properties"]["schema"]["const"] == SCHEMA
    # every command of the schema has an invocation here, and the other way round
    assert set(schema()["$defs"]["commands"]) == {"show"} | {
        a[0] if a[0] not in ("phase", "reproduce") else " ".join(a[:2]) for a in COMMANDS.values()
    } | {"gait sweep", "reproduce serret-andoyer sweep"}


# the study compiles five integrators for its own systems (15 s on a fresh cache): in the slow suite, where its
# own tests validate its document too
CASES = [pytest.param(n, marks=pytest.mark.slow) if n.startswith("reproduce") else n for n in COMMANDS]


@pytest.mark.parametrize("name", CASES)
def test_every_command_follows_the_schema(name, capsys, tmp_path, validator):
    doc = _document(capsys, tmp_path, COMMANDS[name])
    validator.validate(doc)
    assert list(doc)[:3] == ["schema", "command", "summary"]  # the answer first, the evidence after
    assert name.startswith(doc["command"])
    if "{out}" in " ".join(COMMANDS[name]) and name != "reproduce serret-andoyer":
        # the document written with --out is the printed one, with the files it wrote
        name_json = [f for f in doc["files"] if f.endswith(".json")]
        assert len(name_json) == 1 and json.loads(open(name_json[0]).read()) == doc


@pytest.mark.parametrize("name", CASES)
def test_every_command_prints_a_readable_summary(name, capsys, tmp_path):
    # without --json: text for a terminal, no Python reprs, no line over 120 columns
    code, out, err = run(capsys, *(a.replace("{out}", str(tmp_path / "out")) for a in COMMANDS[name]))
    assert code == 0, err
    lines = out.splitlines()
    assert lines and max(len(line) for line in lines) <= 120, max(lines, key=len)
    for line in lines:
        assert not any(r in line for r in ("['", "{'", "array(", "None", "np.float")), line


def test_show_follows_the_schema(capsys, tmp_path, validator):
    _document(capsys, tmp_path, COMMANDS["simulate"])
    doc = _document(capsys, tmp_path, ["show", str(tmp_path / "out" / "trajectory.nc")])
    validator.validate(doc)
    assert doc["summary"]["system"] == "chaplygin_sleigh" and doc["summary"]["status"] == "success"


def _fails(validator, doc):
    return any(True for _ in validator.iter_errors(doc))


def test_a_name_renamed_in_one_command_fails(capsys, tmp_path, validator):
    doc = _document(capsys, tmp_path, COMMANDS["phase rigid-body"])
    assert not _fails(validator, doc)
    for path, new in (
        (("summary", "phase"), "phases"),  # a summary field
        (("m0",), "momentum0"),  # a shared name of the detail
        (("axis",), "axis_index"),
    ):
        bad = copy.deepcopy(doc)
        where = bad
        for key in path[:-1]:
            where = where[key]
        where[new] = where.pop(path[-1])
        assert _fails(validator, bad), path
    # a shared name with another type, or a 0-based axis
    for key, value in (("m0", "1 0.3 0.2"), ("axis", 0), ("period", "7 s")):
        bad = copy.deepcopy(doc)
        bad[key] = value
        assert _fails(validator, bad), key
    bad = copy.deepcopy(doc)
    bad["schema"] = "geomech-cli/0"
    assert _fails(validator, bad)
