"""Run a geomech command line in a forked process and classify what happened.

Used by tests/cli/test_fuzz.py (a few hundred cases in `make test`) and `make fuzz` (thousands). The child
process runs ``geomech.cli.main.main(argv)`` in a fresh directory with its stdout and stderr in files; the
parent waits up to a time limit. Outcomes, as in the table of the issue that asked for this:

- ``ok``: exit 0, stdout free of NaN/inf (strict JSON with --json), stderr only ``geomech: warning:`` lines;
- ``clean``: exit 2 with exactly one line ``geomech: error: ...``, or exit 1 with exactly one line
  ``geomech: numerical failure: ...``;
- ``messy``: a failure status with more or other lines on stderr;
- ``traceback``: a Python traceback, or ``geomech: internal error`` (a bug caught at the top);
- ``nan``: exit 0 with NaN or inf in the output;
- ``hang``: still running at the time limit;
- ``files``: a failed run left files behind.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import geomech.cli.main  # noqa: F401 - imported once here, so that each forked child starts warm

_NONFINITE = re.compile(r"(?<![A-Za-z_])(nan|inf|infinity)(?![A-Za-z_(])", re.IGNORECASE)


@dataclass(frozen=True)
class Outcome:
    kind: str
    code: int | None
    stdout: str
    stderr: str
    argv: tuple[str, ...]

    def describe(self) -> str:
        return f"{self.kind} (exit {self.code}) for geomech {' '.join(map(repr, self.argv))}:\n{self.stderr[-2000:]}"


def _child(argv: list[str], workdir: str, out_path: str, err_path: str) -> None:  # pragma: no cover - forked
    os.chdir(workdir)
    out_fd = os.open(out_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    err_fd = os.open(err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(out_fd, 1)
    os.dup2(err_fd, 2)
    import sys

    sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115 - the child's whole life
    sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
    code = 1
    try:
        from geomech.cli.main import main

        code = main(argv)
    except BaseException:  # noqa: BLE001 - the harness reports it as a traceback
        import traceback

        traceback.print_exc()
        code = 99
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def run_cli(argv: list[str] | tuple[str, ...], timeout: float = 60.0) -> Outcome:
    """Run ``geomech argv`` in a forked child in a fresh directory; classify the result."""
    argv = list(argv)
    base = Path(tempfile.mkdtemp(prefix="geomech-fuzz-"))
    work = base / "work"
    work.mkdir()
    out_path, err_path = base / "stdout", base / "stderr"
    try:
        ctx = mp.get_context("fork")
        proc = ctx.Process(target=_child, args=(argv, str(work), str(out_path), str(err_path)))
        proc.start()
        proc.join(timeout)
        if proc.is_alive():
            proc.kill()
            proc.join()
            return Outcome("hang", None, _read(out_path), _read(err_path), tuple(argv))
        code = proc.exitcode
        stdout, stderr = _read(out_path), _read(err_path)
        leftovers = [p for p in work.rglob("*")]
        return Outcome(_classify(code, stdout, stderr, argv, bool(leftovers)), code, stdout, stderr, tuple(argv))
    finally:
        shutil.rmtree(base, ignore_errors=True)


def _read(path: Path) -> str:
    try:
        return path.read_text(errors="replace")
    except OSError:
        return ""


def _classify(code: int | None, stdout: str, stderr: str, argv: list[str], leftovers: bool) -> str:
    lines = stderr.splitlines()
    if "Traceback (most recent call last)" in stderr or "geomech: internal error" in stderr or code == 99:
        return "traceback"
    if code == 0:
        if any(not line.startswith("geomech: warning:") for line in lines):
            return "messy"
        if "--json" in argv:
            try:
                json.loads(stdout, parse_constant=_refuse)
            except ValueError:
                return "nan" if _NONFINITE.search(stdout) else "messy"
        elif _NONFINITE.search(stdout):
            return "nan"
        return "ok"
    if leftovers:
        return "files"
    if code == 2 and len(lines) == 1 and lines[0].startswith("geomech: error:"):
        return "clean"
    if code == 1 and len(lines) == 1 and lines[0].startswith("geomech: numerical failure:"):
        return "clean"
    if code == 130 and lines == ["geomech: interrupted"]:
        return "clean"
    return "messy"


def _refuse(token: str) -> float:
    raise ValueError(f"non-finite JSON constant {token}")
