"""Every failure of the command line is one line on stderr with its status: 2 bad input, 1 numerical or
internal failure, 130 interrupted; --debug adds the traceback; model files cannot break the output."""

import json
import os
import signal
import subprocess
import sys
import time

import pytest
from cli_helpers import run

from geomech.errors import ConvergenceError

RIGID = ["rigid-body", "--inertia", "3", "2", "1", "--momentum", "1", "0.3", "0.2", "--t-final", "1"]


@pytest.mark.parametrize(
    "args, needle",
    [
        (["reduce", "--hamiltonian", "m1**2 + 0*len(open('PWNED','w').name)"], "`--hamiltonian`"),
        (
            ["stability", "--lambda", "3", "2", "--I3", "1", "--phi", "__import__('os').system('touch PWNED')"],
            "`--phi`",
        ),
        (["reduce", "--hamiltonian", "10**10**10"], "beyond 1e300"),
        (["reduce", "--hamiltonian", "m1**2/I1", "--param", "I1=nan"], "not a finite number"),
        (["reduce", "--hamiltonian", "m1**2/I1", "--param", "I1=1", "--param", "I1=2"], "given twice"),
        (["simulate", "snakeboard", "--shape", "phi=sin(t)", "--tau", "psi=__import__('os')"], "`--tau psi`"),
        (
            ["phase", "loop", "three-link-middle", "--shape", "alpha1=cos(2*pi*t).real", "--shape", "alpha2=0"],
            "`--shape alpha1`",
        ),
        ([*RIGID, "--out", ""], "`--out` is empty"),
    ],
)
def test_bad_input_is_one_line_naming_the_option(capsys, tmp_path, monkeypatch, args, needle):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *args)
    assert code == 2 and err.count("\n") == 1 and err.startswith("geomech: error:") and needle in err, err
    assert not os.listdir(tmp_path)


def test_out_is_checked_before_the_work_and_a_file_is_refused(capsys, tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    calls = []
    monkeypatch.setattr("geomech.experiments.rigid_body.run_rigid_body", lambda *a, **k: calls.append(a))
    for out in (blocker, blocker / "sub"):
        code, _, err = run(capsys, *RIGID, "--out", str(out))
        assert code == 2 and err.count("\n") == 1 and "Cannot write into `--out`" in err
    assert not calls


def test_a_numerical_failure_is_status_1_and_an_unexpected_one_is_reported_not_raised(capsys, monkeypatch):
    def diverge(*a, **k):
        raise ConvergenceError("Newton did not converge at t = 3.2 (step 41): residual 1e3")

    monkeypatch.setattr("geomech.experiments.rigid_body.run_rigid_body", diverge)
    code, _, err = run(capsys, *RIGID)
    assert code == 1 and err == (
        "geomech: numerical failure: Newton did not converge at t = 3.2 (step 41): residual 1e3\n"
    )

    def bug(*a, **k):
        raise KeyError("oops")

    monkeypatch.setattr("geomech.experiments.rigid_body.run_rigid_body", bug)
    code, _, err = run(capsys, *RIGID)
    assert code == 1 and err.count("\n") == 1 and "internal error: KeyError" in err and "--debug" in err
    code, _, err = run(capsys, *RIGID, "--debug")
    assert code == 1 and "Traceback (most recent call last)" in err and err.rstrip().endswith("please report it)")


def test_nan_never_reaches_the_json(capsys, monkeypatch):
    from geomech.experiments import rigid_body

    real = rigid_body.run_rigid_body

    def with_nan(*a, **k):
        summary, traj = real(*a, **k)
        summary["summary"]["drift"]["energy_relative"] = float("nan")
        return summary, traj

    monkeypatch.setattr(rigid_body, "run_rigid_body", with_nan)
    code, out, err = run(capsys, *RIGID, "--json")
    assert code == 1 and out == "" and "summary.drift.energy_relative" in err and err.count("\n") == 1


def test_warnings_are_one_line_each_and_dropped_after_an_error(capsys, monkeypatch):
    import warnings

    from geomech.experiments import rigid_body

    real = rigid_body.run_rigid_body

    def warn(*a, **k):
        warnings.warn("something odd\nover two lines", UserWarning, stacklevel=1)
        return real(*a, **k)

    monkeypatch.setattr(rigid_body, "run_rigid_body", warn)
    code, out, err = run(capsys, *RIGID, "--json")
    assert code == 0 and json.loads(out) and err == "geomech: warning: something odd over two lines\n"
    code, out, err = run(capsys, *RIGID[:-1], "nan")
    assert code == 2 and err.count("\n") == 1 and "warning" not in err


MODEL_BODIES = {
    "raises.py": ("raise RuntimeError('broken model')", "RuntimeError: broken model"),
    "exits.py": ("import sys\nsys.exit(3)", "sys.exit(3)"),
    "prints.py": ("print('hello from the model')\nsystem = 1", "expected `system` to be a NonholonomicSystem"),
    "build_raises.py": ("def build(**kw):\n    return 1/0", "build(**params) failed: ZeroDivisionError"),
    "nothing.py": ("x = 1", "defines neither `system`"),
}


@pytest.mark.parametrize("name", sorted(MODEL_BODIES))
def test_a_broken_model_file_is_one_error_and_its_prints_stay_off_stdout(capsys, tmp_path, name):
    body, needle = MODEL_BODIES[name]
    path = tmp_path / name
    path.write_text(body + "\n")
    code, out, err = run(capsys, "simulate", "--model", str(path), "--t-final", "0.1", "--json")
    assert code == 2 and out == "" and needle in err, err
    assert err.strip().splitlines()[-1].startswith("geomech: error:")


def test_a_model_path_that_is_not_python_is_refused(capsys, tmp_path):
    (tmp_path / "model.txt").write_text("system = 1\n")
    code, _, err = run(capsys, "simulate", "--model", str(tmp_path / "model.txt"), "--t-final", "0.1")
    assert code == 2 and "ending in .py" in err


def _wait_until_sigint_is_caught(pid: int, timeout: float = 30.0) -> None:
    """Wait until process ``pid`` has a handler for SIGINT (bit 2 of SigCgt in /proc/PID/status, Linux)."""
    status = f"/proc/{pid}/status"
    if not os.path.exists(status):  # not Linux: a fixed start-up allowance instead
        time.sleep(0.5)
        return
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with open(status) as fh:
                caught = next((line.split()[1] for line in fh if line.startswith("SigCgt:")), "0")
        except FileNotFoundError:
            return  # it has already ended: the assertions below say how
        if int(caught, 16) & (1 << (signal.SIGINT - 1)):
            return
        time.sleep(0.002)
    raise AssertionError(f"process {pid} did not install a SIGINT handler within {timeout} s")


@pytest.mark.parametrize("delay", [0.05, 2.0])
def test_ctrl_c_at_any_moment_is_one_line_and_status_130(delay, tmp_path):
    """Early (while numpy, sympy and numba load) and late (integrating)."""
    exe = os.path.join(os.path.dirname(sys.executable), "geomech")
    p = subprocess.Popen(
        [
            exe,
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
            "1e6",
            "--max-turns",
            "1e9",
            "--out",
            str(tmp_path / "out"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # Before the interpreter has installed its SIGINT handler no program can answer Ctrl-C (the default action
    # kills it, status -2); on a loaded machine that start-up can outlast a fixed delay. So the delay counts from
    # the moment the child catches SIGINT: early, while numpy, sympy and numba load, or late, while integrating.
    _wait_until_sigint_is_caught(p.pid)
    time.sleep(delay)
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    # the message says which path an interrupt took where it did not end the command as Ctrl-C (seen once under load)
    assert p.returncode == 130 and err.decode() == "geomech: interrupted\n", (p.returncode, err.decode()[-600:])
    assert not (tmp_path / "out").exists()


def test_an_option_is_never_taken_as_another_options_value(capsys, tmp_path, monkeypatch):
    """`--out --json` once made a directory named --json and printed text."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *RIGID, "--out", "--json")
    assert code == 2 and out == "" and "--out takes a value, but the next word is the option --json" in err
    assert not os.listdir(tmp_path)
    code, out, _ = run(capsys, *RIGID, "--out=--json")  # spelled out, it is a name like any other
    assert code == 0 and (tmp_path / "--json" / "rigid_body.json").is_file()


def test_an_interrupt_python_swallowed_still_ends_the_command(monkeypatch, capsys):
    """Ctrl-C raised where Python ignores exceptions (a weak reference's callback during an import) is lost: one
    recorded during the imports ends the command once they end, and a process still running a moment after an
    interrupt is ended with the same line and status."""
    import threading

    import _geomech_cli

    stale = threading.Timer(60.0, lambda: None)  # an interrupt recorded, its exception swallowed
    monkeypatch.setattr(_geomech_cli, "_INTERRUPTED", [stale])
    monkeypatch.setattr(sys, "argv", ["geomech", "rigid-body", "--inertia", "3", "2", "1"])
    previous = signal.getsignal(signal.SIGINT)
    try:
        assert _geomech_cli.main() == 130
    finally:  # main installs its handler: the test process keeps its own
        signal.signal(signal.SIGINT, previous)
    assert capsys.readouterr().err == "geomech: interrupted\n"
    ended = threading.Event()
    monkeypatch.setattr(_geomech_cli, "_INTERRUPTED", [])
    monkeypatch.setattr(_geomech_cli, "GRACE", 0.05)
    monkeypatch.setattr(_geomech_cli, "_interrupted", ended.set)
    with pytest.raises(KeyboardInterrupt):
        _geomech_cli._on_sigint(signal.SIGINT, None)
    assert ended.wait(5.0)
