import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("geomech", max_examples=40, deadline=None, derandomize=True)
settings.load_profile("geomech")


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
