# rcsgen: `make run` builds the specs and runs the miner example; `make test` runs the suite.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test lint check build clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/rcsgen build specs/
	$(VENV)/bin/rcsgen run specs/miner/scenarios/sump_shear_cusp.yaml

test: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(PY) -m ruff check rcsgen tests
	$(PY) -m ruff format --check rcsgen tests

build: $(STAMP)
	$(VENV)/bin/rcsgen build specs/

# What CI runs, plus lint and the generated-code-is-current check.
check: lint test
	$(VENV)/bin/rcsgen build specs/ --check

clean:
	rm -rf $(VENV) build dist *.egg-info
