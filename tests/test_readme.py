"""The README's tour runs as written, and its first two commands are the make targets."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_starts_with_the_two_commands():
    text = README.read_text()
    first_block = re.search(r"```\n(.*?)```", text, re.S).group(1)
    assert first_block.splitlines()[0].startswith("make demo")
    assert first_block.splitlines()[1].startswith("make test")


def test_readme_tour_runs():
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    exact = namespace["exact"]
    assert exact.family == "major" and abs(exact.period - 19.135304560260906) < 1e-9
    assert namespace["traj"].stats["chart_switches"] > 0


def test_readme_nonholonomic_block_runs():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    code = next(b for b in blocks if "snakeboard" in b)
    namespace: dict = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["red"].momentum_rhs.shape == (1, 1) or len(namespace["red"].momentum_rhs) == 1
    from geomech.reduction import almost_poisson

    assert almost_poisson(namespace["s"]).satisfies_jacobi is False


def _readme_commands() -> list[str]:
    block = re.search(r"\nCommand line \(.*?\n```\n(.*?)```", README.read_text(), re.S).group(1)
    joined = re.sub(r"\\\n\s*", "", block)
    return [line.split("   #")[0].strip() for line in joined.splitlines() if line.startswith("geomech ")]


@pytest.mark.slow  # every README command run through the CLI: a long verification
def test_readme_commands_run(tmp_path, capsys, monkeypatch):
    import shlex

    monkeypatch.chdir(tmp_path)  # files a command names without DIR (--html map.html) land here

    from geomech.cli.main import main

    commands = [c for c in _readme_commands() if "..." not in c]  # the elided stability-map line aside
    assert len(commands) >= 8
    for command in commands:
        argv = [a.replace("DIR", str(tmp_path / "out")) for a in shlex.split(command)[1:]]
        assert main(argv) == 0, command
        assert "error" not in capsys.readouterr().err, command
