"""docs/integrators.md is the registry's table: a method added or changed without regenerating it fails here."""

from pathlib import Path

from geomech.integrators import REGISTRY
from geomech.integrators._docs import document

DOC = Path(__file__).resolve().parents[2] / "docs" / "integrators.md"


def test_docs_table_is_generated_from_the_registry():
    text = DOC.read_text()
    assert text == document(), "regenerate with: python -m geomech.integrators._docs > docs/integrators.md"
    for key in REGISTRY:
        assert f"| `{key}` |" in text
