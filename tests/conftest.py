import os
import shutil
import tempfile

import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("geomech", max_examples=40, deadline=None, derandomize=True, database=None)
settings.load_profile("geomech")

#: Everything the tests (and the processes they start) cache goes under one temporary directory per run,
#: shared by the xdist workers (they inherit the controller's environment): never the user's home or cache.
#: A run may be given a directory that outlives it instead (`make test-fast` keeps .test-cache/ in the
#: checkout, so that kernels compiled by one run are loaded by the next).
_ROOT_VAR = "GEOMECH_TEST_ROOT"


def pytest_configure(config):
    if _ROOT_VAR not in os.environ:
        os.environ[_ROOT_VAR] = tempfile.mkdtemp(prefix="geomech-tests-")
        config._geomech_test_root = os.environ[_ROOT_VAR]
    root = os.environ[_ROOT_VAR]
    os.makedirs(root, mode=0o700, exist_ok=True)
    # numba reads its cache directory when it is first imported: set before any test imports it.
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(root, "numba")
    os.environ["MPLCONFIGDIR"] = os.path.join(root, "matplotlib")


def pytest_unconfigure(config):
    root = getattr(config, "_geomech_test_root", None)
    if root is not None:
        shutil.rmtree(root, ignore_errors=True)
        os.environ.pop(_ROOT_VAR, None)


@pytest.fixture(autouse=True, scope="session")
def check_every_json_document():
    """Every JSON document a command prints or writes in any test is validated against the schema."""
    before = os.environ.get("GEOMECH_CHECK_JSON")
    os.environ["GEOMECH_CHECK_JSON"] = "1"
    yield
    if before is None:
        os.environ.pop("GEOMECH_CHECK_JSON", None)
    else:
        os.environ["GEOMECH_CHECK_JSON"] = before


@pytest.fixture(autouse=True, scope="session")
def hermetic_cache():
    """GEOMECH_CACHE_DIR points at the run's temporary directory for the whole session."""
    path = os.path.join(os.environ[_ROOT_VAR], "cache")
    before = os.environ.get("GEOMECH_CACHE_DIR")
    os.environ["GEOMECH_CACHE_DIR"] = path
    yield path
    if before is None:
        os.environ.pop("GEOMECH_CACHE_DIR", None)
    else:
        os.environ["GEOMECH_CACHE_DIR"] = before


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
