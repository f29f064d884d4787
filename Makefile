# Two entry points: `make demo` and `make test`. Both create .venv from scratch when it is missing
# or older than pyproject.toml.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast fuzz lint venv clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test,dev]"
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(PY) examples/demo.py --out demo-output

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -n 2 --dist worksteal -q

# The quick loop: no slow runs, and the compiled kernels and derivations kept in .test-cache/ between runs
test-fast: $(STAMP)
	GEOMECH_TEST_ROOT=$(CURDIR)/.test-cache MPLBACKEND=Agg $(PY) -m pytest -n 2 --dist worksteal -q -m "not slow"

fuzz: $(STAMP)
	GEOMECH_FUZZ_EXAMPLES=$${GEOMECH_FUZZ_EXAMPLES:-300} MPLBACKEND=Agg $(PY) -m pytest -q -s -p no:xdist \
		tests/cli/test_fuzz.py tests/test_api_fuzz.py

lint: $(STAMP)
	$(VENV)/bin/ruff check src tests benchmarks examples
	$(VENV)/bin/ruff format --check src tests benchmarks examples
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV) demo-output .pytest_cache .hypothesis .test-cache
