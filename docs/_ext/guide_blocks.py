"""The ```python blocks of a Markdown guide, run as a reader would: in order, in one namespace, in a scratch
directory. The documentation build runs them (geomech_docs.py) and so does the test suite
(tests/test_docs_examples.py); a block that raises fails both."""

from __future__ import annotations

import os
import re
from pathlib import Path

BLOCK = re.compile(r"```python\n(.*?)```", re.S)


def python_blocks(text: str) -> list[str]:
    """The code of every ```python block of a Markdown text, in order."""
    return BLOCK.findall(text)


def run_blocks(page: Path, workdir: Path) -> dict:
    """Run the ```python blocks of ``page`` in one namespace with ``workdir`` as the working directory (blocks may
    write files); return the namespace. Open matplotlib figures are closed afterwards."""
    namespace: dict = {"__name__": f"guide:{page.stem}"}
    blocks = python_blocks(page.read_text(encoding="utf-8"))
    cwd = os.getcwd()
    os.chdir(workdir)
    try:
        for i, code in enumerate(blocks):
            exec(compile(code, f"{page.name}[block {i}]", "exec"), namespace)
    finally:
        os.chdir(cwd)
        import matplotlib.pyplot as plt

        plt.close("all")
    return namespace
