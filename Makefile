# rcsgen: `make run` builds the specs and runs the miner example; `make test` runs the suite.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test lint typecheck check build clean fuzz bench

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# --strict: the shipped specs acknowledge every intended finding, so a new warning fails.
run: $(STAMP)
	$(VENV)/bin/rcsgen build specs/ --strict
	$(VENV)/bin/rcsgen run specs/miner/scenarios/box_cut.yaml

test: $(STAMP)
	$(PY) -m pytest -q

# Longer fuzzing than `make test` does: 5,000 mutated specs through the front end (and every
# 10th through `rcsgen build`), 200 random state tables run against the reference
# interpreter, 2,000 random scenario files checked and run, with fresh randomness each
# time; prints a summary of each.
fuzz: $(STAMP)
	FUZZ_EXAMPLES=5000 DIFF_EXAMPLES=200 SCENARIO_FUZZ_EXAMPLES=2000 FUZZ_RANDOM=1 \
		$(PY) -m pytest -q -s tests/test_fuzz.py tests/test_differential.py \
		tests/test_scenario_fuzz.py

lint: $(STAMP)
	$(PY) -m ruff check rcsgen tests
	$(PY) -m ruff format --check rcsgen tests

# Strict for rcsgen.compiler, rcsgen.runtime and the public API, plain for tools and cli;
# generated/ is not checked (configuration: [tool.mypy] in pyproject.toml).
typecheck: $(STAMP)
	$(PY) -m mypy

build: $(STAMP)
	$(VENV)/bin/rcsgen build specs/

# What CI runs, plus lint, the type check and the generated-code-is-current check.
check: lint typecheck test
	$(VENV)/bin/rcsgen build specs/ --check --strict

clean:
	rm -rf $(VENV) build dist *.egg-info

# Benchmarks (not part of `make test`): generated code against hand-written code and the
# state-machine libraries, in their own venv; writes bench/RESULTS.md (see bench/README.md).
BENCH_VENV := bench/.venv
BENCH_STAMP := $(BENCH_VENV)/.installed

$(BENCH_STAMP): pyproject.toml bench/requirements.txt
	$(PYTHON) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(BENCH_VENV)/bin/python -m pip install --quiet -e . -r bench/requirements.txt
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(BENCH_VENV)/bin/python bench/run.py
