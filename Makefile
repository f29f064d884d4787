# Two entry points: `make demo` and `make test`. Both create .venv from scratch when it is missing
# or older than pyproject.toml.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast fuzz lint venv clean docs test-browser chromium

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test,dev]"
	touch $(STAMP)

venv: $(STAMP)

DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): $(STAMP)
	$(PY) -m pip install --quiet -e ".[test,dev,docs]"
	touch $(DOCS_STAMP)

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
	$(VENV)/bin/ruff check src tests benchmarks examples docs/conf.py docs/_ext docs/tutorials
	$(VENV)/bin/ruff format --check src tests benchmarks examples docs/conf.py docs/_ext docs/tutorials
	$(VENV)/bin/mypy

# The documentation site in docs/_build/html, warnings as errors: every example and tutorial runs, and so does
# every code block of the guides. Compiled kernels are cached in docs/_build/cache, never in the home directory.
docs: $(DOCS_STAMP)
	GEOMECH_CACHE_DIR=$(CURDIR)/docs/_build/cache MPLBACKEND=Agg $(VENV)/bin/sphinx-build -W --keep-going -j 2 \
		-b html docs docs/_build/html

# The built site opened in headless Chromium (the system's, installed from the package manager when missing):
# every page, its links, images, console and interactive figures (tests/browser/).
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
		if [ "$$(id -u)" = 0 ]; then SUDO=; else SUDO=sudo; fi; \
		$$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium; }

test-browser: docs chromium
	GEOMECH_SITE=$(CURDIR)/docs/_build/html GEOMECH_SCREENSHOTS=$(CURDIR)/docs/_build/screenshots \
		$(PY) -m pytest -q -p no:cacheprovider -n 2 tests/browser

clean:
	rm -rf $(VENV) demo-output .pytest_cache .hypothesis .test-cache docs/_build docs/api docs/auto_examples \
		docs/auto_tutorials
