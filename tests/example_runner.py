"""Run a script of examples/ as a user would (``python examples/NAME.py --out DIR``) and return what it printed."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_example(script: str, out: Path) -> str:
    path = str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=path)
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / script), "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout
