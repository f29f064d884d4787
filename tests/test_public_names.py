"""Every name a module of geomech exports (its ``__all__``) exists: a name listed but not imported is an
AttributeError for the user who follows the listing (and for the documentation build, which reads it)."""

import importlib
import pkgutil

import pytest

import geomech

MODULES = sorted(
    info.name
    for info in pkgutil.walk_packages(geomech.__path__, "geomech.")
    if not info.name.rsplit(".", 1)[-1].startswith("_k_") and "__main__" not in info.name
)


@pytest.mark.parametrize("name", MODULES)
def test_every_exported_name_exists(name):
    module = importlib.import_module(name)
    missing = [n for n in getattr(module, "__all__", ()) if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ lists {missing}, which it does not define"
