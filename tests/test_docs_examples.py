"""Every ```python block of docs/*.md runs as written (each file's blocks in order, in one namespace): the same
runner as the documentation build's (docs/_ext/guide_blocks.py)."""

import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

from guide_blocks import python_blocks, run_blocks  # noqa: E402

PAGES = sorted(p for p in DOCS.glob("*.md") if python_blocks(p.read_text()))


def test_the_guides_have_code_to_run():
    assert {p.name for p in PAGES} >= {"phases.md", "nonholonomic.md", "spacecraft_example.md"}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_docs_code_blocks_run(page, tmp_path):
    assert run_blocks(page, tmp_path)
