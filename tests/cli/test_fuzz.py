"""Property-based fuzzing of the command line: mutations of a valid command line of every command.

Every outcome must be a success with finite output or one clean line with its status; a traceback, a run
past the time limit, a NaN or inf in an output, extra lines on stderr or files left by a failed run fail
the test. ``make fuzz`` runs many more cases (``GEOMECH_FUZZ_EXAMPLES``) and prints the table of outcomes.
"""

from __future__ import annotations

import collections
import os

import pytest
from fuzz_harness import run_cli
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from geomech.cli._args import _is_number

#: Fuzzing is a long verification run: `make test` and `make fuzz` run it, `make test-fast` does not.
pytestmark = pytest.mark.slow

EXAMPLES = int(os.environ.get("GEOMECH_FUZZ_EXAMPLES", "20"))
TIMEOUT = float(os.environ.get("GEOMECH_FUZZ_TIMEOUT", "60"))
#: Commands whose first run compiles many kernels get a longer limit before a run counts as a hang: the Serret-Andoyer
#: study compiles five approaches and the orbit's period (about 40 s with a cold cache on 2 slow cores, alone).
SLOW_TO_START = {"reproduce": 4.0}

#: A valid, quick command line of each command: the mutations start from these.
BASES: dict[str, list[str]] = {
    "rigid-body": [
        "rigid-body",
        "--inertia",
        "3",
        "2",
        "1",
        "--momentum",
        "1",
        "0.3",
        "0.2",
        "--t-final",
        "2",
        "--samples",
        "11",
        "--json",
    ],
    "reduce": ["reduce", "--hamiltonian", "m1**2/(2*I1) + m2**2/4 + m3**2/2", "--param", "I1=3", "--json"],
    "stability": ["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "k*v", "--param", "k=0.51", "--json"],
    "stability-map": [
        "stability-map",
        "--lambda",
        "3",
        "2",
        "--I3",
        "1",
        "--phi",
        "k*v",
        "--x",
        "k=0.05:0.95:3",
        "--y",
        "lambda2=1.2:2.8:3",
        "--out",
        "out",
        "--json",
    ],
    "phase-two-bodies": [
        "phase",
        "two-bodies",
        "--I1",
        "1",
        "--I2",
        "3",
        "--mu",
        "-2.5",
        "--period",
        "5.5",
        "--turns",
        "-1",
        "--json",
    ],
    "phase-rigid-body": ["phase", "rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--json"],
    "phase-loop": [
        "phase",
        "loop",
        "three-link-middle",
        "--shape",
        "alpha1=0.5*cos(2*pi*t)",
        "--shape",
        "alpha2=0.5*sin(2*pi*t)",
        "--period",
        "1",
        "--json",
    ],
    "simulate": [
        "simulate",
        "chaplygin_sleigh",
        "--param",
        "m=1",
        "--param",
        "a=0.5",
        "--param",
        "I_c=0.2",
        "--t-final",
        "0.5",
        "--json",
    ],
    "derive": ["derive", "rolling_disk", "--json"],
    "reproduce": ["reproduce", "serret-andoyer", "--t-final", "0.02", "--out", "out", "--no-extras", "--json"],
}

NUMBERS = [
    "nan",
    "inf",
    "-inf",
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-300",
    "1e400",
    "2147483648",
    "1e9",
    "0.5",
    "3",
    "1e-9",
]
WORDS = [
    "",
    " ",
    "abc",
    "1,2",
    "3 2 1",
    "1,,2",
    "--json",
    "-",
    "=",
    "k=",
    "=1",
    "x=1",
    "k=nan",
    "k=1e308",
    "I1=0",
    "psi=t**1001",
    "alpha1=1/0",
    "alpha1=t",
    "phi=acos(2)",
]
FORMULAS = [
    "1/0",
    "acos(2)",
    "I",
    "oo",
    "nan",
    "sin(",
    "10**10**10",
    "m1**2 + 0*len(open('x','w').name)",
    "__import__('os').system('true')",
    "foo(m1)",
    "m1**2*1e308*1e308",
    "exp(m1*1000)",
    "sqrt(-m1**2-1)",
    "k*v**2",
    "0",
    "log(0*v)",
    "v/0.0",
    "1e308*v",
]
OPTIONS = [
    "--inertia",
    "--momentum",
    "--t-final",
    "--samples",
    "--rtol",
    "--hamiltonian",
    "--param",
    "--axis",
    "--lambda",
    "--I3",
    "--phi",
    "--p",
    "--G",
    "--x",
    "--y",
    "--near",
    "--I1",
    "--I2",
    "--mu",
    "--period",
    "--turns",
    "--shape",
    "--method",
    "--h",
    "--q0",
    "--p0",
    "--tau",
    "--save-every",
    "--J3",
    "--out",
]

tokens = st.sampled_from(NUMBERS + WORDS + FORMULAS)
RANGES = ["0:1:3", "0.05:0.95:1000", "nan:1:3", "0:inf:3", "1:1:3", "0:1:0", "0:1:100000", "1e308:-1e308:3"]


@st.composite
def value_for(draw, token: str) -> str:
    """A bad or extreme value of the same kind as ``token`` (a number, a formula, NAME=VALUE, a range)."""
    if _is_number(token):
        return draw(st.sampled_from(NUMBERS)) if draw(st.integers(0, 9)) else draw(tokens)
    name, sep, value = token.partition("=")
    if sep and ":" in value:
        return f"{name}={draw(st.sampled_from(RANGES))}"
    if sep:
        kind = FORMULAS if not _is_number(value) else NUMBERS
        return f"{name}={draw(st.sampled_from(kind))}" if draw(st.integers(0, 5)) else draw(tokens)
    return draw(st.sampled_from(FORMULAS)) if draw(st.integers(0, 5)) else draw(tokens)


@st.composite
def mutated(draw, base: list[str]) -> list[str]:
    """Mostly one value replaced by a bad one of its kind; sometimes an option dropped, added or repeated,
    or a stray word inserted."""
    argv = list(base)
    for _ in range(draw(st.sampled_from([1, 1, 1, 2, 3]))):
        kind = draw(st.sampled_from(["replace"] * 6 + ["drop", "repeat", "add", "insert"]))
        positions = [i for i, a in enumerate(argv) if i > 0 and not a.startswith("--") and argv[i - 1] != "phase"]
        if kind == "replace" and positions:
            i = draw(st.sampled_from(positions))
            argv[i] = draw(value_for(argv[i]))
        elif kind == "drop" and len(argv) > 2:
            del argv[draw(st.integers(1, len(argv) - 1))]
        elif kind == "repeat":
            opts = [i for i, a in enumerate(argv) if a.startswith("--") and i + 1 < len(argv)]
            if opts:
                i = draw(st.sampled_from(opts))
                argv += [argv[i], draw(value_for(argv[i + 1]))]
        elif kind == "add":
            argv += [draw(st.sampled_from(OPTIONS)), draw(tokens)]
        else:
            argv.insert(draw(st.integers(1, len(argv))), draw(tokens))
    return argv


BAD = {"traceback", "hang", "nan", "messy", "files"}


@pytest.mark.parametrize("name", sorted(BASES))
def test_the_base_command_lines_work(name):
    outcome = run_cli(BASES[name], timeout=TIMEOUT * SLOW_TO_START.get(name, 1.0))
    assert outcome.kind == "ok", outcome.describe()


@pytest.mark.parametrize("name", sorted(BASES))
def test_mutated_command_lines_fail_cleanly(name):
    seen: collections.Counter[str] = collections.Counter()
    bad = []
    done: set[tuple[str, ...]] = set()

    @settings(
        max_examples=EXAMPLES, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck)
    )
    @given(mutated(BASES[name]))
    def check(argv):
        if tuple(argv) in done:
            return
        done.add(tuple(argv))
        outcome = run_cli(argv, timeout=TIMEOUT * SLOW_TO_START.get(name, 1.0))
        seen[outcome.kind] += 1
        if outcome.kind in BAD:
            bad.append(outcome)

    check()
    print(f"\n{name}: " + ", ".join(f"{k} {v}" for k, v in sorted(seen.items())))
    assert not bad, f"{len(bad)} bad outcome(s); first:\n" + "\n\n".join(o.describe() for o in bad[:5])
