"""Every ```python block of docs/*.md runs as written (each file's blocks in order, in one namespace)."""

import os
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAGES = sorted(p for p in DOCS.glob("*.md") if "```python" in p.read_text())


def test_the_guides_have_code_to_run():
    assert {p.name for p in PAGES} >= {"phases.md", "nonholonomic.md", "spacecraft_example.md"}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_docs_code_blocks_run(page, tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
    namespace: dict = {}
    cwd = os.getcwd()
    os.chdir(tmp_path)  # blocks may write files (gait.nc)
    try:
        for i, code in enumerate(blocks):
            exec(compile(code, f"{page.name}[block {i}]", "exec"), namespace)
    finally:
        os.chdir(cwd)
        import matplotlib.pyplot as plt

        plt.close("all")
    assert namespace
