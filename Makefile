# rcsgen: `make run` builds the specs and runs the miner example; `make test` runs the suite.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test lint typecheck check build clean fuzz bench mutate complexity

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
# interpreter, 10,000 random expressions per property printed, re-parsed and evaluated,
# 2,000 random scenario files checked and run, with fresh randomness each time; prints a
# summary of each.
fuzz: $(STAMP)
	FUZZ_EXAMPLES=5000 DIFF_EXAMPLES=200 EXPR_EXAMPLES=10000 SCENARIO_FUZZ_EXAMPLES=2000 \
		FUZZ_RANDOM=1 $(PY) -m pytest -q -s tests/test_fuzz.py tests/test_differential.py \
		tests/test_expr.py tests/test_scenario_fuzz.py

lint: $(STAMP)
	$(PY) -m ruff check rcsgen tests
	$(PY) -m ruff check --isolated rcsgen/runtime  # vendored as is: ruff's defaults too
	$(PY) -m ruff format --check rcsgen tests

# mypy --strict over the whole package (compiler, runtime, API, tools and the command line);
# generated/ is not checked (configuration: [tool.mypy] in pyproject.toml).
typecheck: $(STAMP)
	$(PY) -m mypy

# Cyclomatic complexity (radon) of the package and of each part, and every function at 20
# or more; the budget is at most 1.5 % of the functions there, none above 30.
complexity: $(STAMP)
	$(PY) tests/complexity_report.py

build: $(STAMP)
	$(VENV)/bin/rcsgen build specs/
	$(VENV)/bin/rcsgen doc specs/

# What CI runs, plus lint, the type check and the checks that generated/ and the generated
# reference (docs/reference/) are current.
check: lint typecheck test
	$(VENV)/bin/rcsgen build specs/ --check --strict
	$(VENV)/bin/rcsgen doc specs/ --check

clean:
	rm -rf $(VENV) build dist *.egg-info

# Benchmarks (not part of `make test`): generated code against hand-written code and the
# state-machine libraries, in their own venv; writes bench/RESULTS.md (see bench/README.md).
BENCH_VENV := bench/.venv
BENCH_STAMP := $(BENCH_VENV)/.installed

$(BENCH_STAMP): pyproject.toml bench/requirements.txt
	$(PYTHON) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(BENCH_VENV)/bin/python -m pip install --quiet -e '.[zenoh]' -r bench/requirements.txt
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(BENCH_VENV)/bin/python bench/run.py

# Mutation testing (not part of `make test`): mutmut 3 in its own venv mutates the compiler
# (rcsgen/compiler; [tool.mutmut] in pyproject.toml says why not rcsgen/runtime) and runs,
# for each mutant, the tests that reach the mutated function. A whole-compiler run takes
# hours, so MUTANTS defaults to the printer, emitter and checker; `make mutate
# MUTANTS='rcsgen.compiler.*'` runs them all. Work is kept in mutants/: a rerun resumes.
# Browse the survivors with `.venv-mutate/bin/mutmut browse` (or `results`, `show NAME`).
MUTATE_VENV := .venv-mutate
MUTATE_STAMP := $(MUTATE_VENV)/.installed
MUTANTS ?= rcsgen.compiler.expressions.* rcsgen.compiler.back_end.emit.* rcsgen.compiler.checks.check.*
# Fewer random examples than `make test`: every surviving mutant reruns the properties.
MUTATE_ENV := EXPR_EXAMPLES=200 DIFF_EXAMPLES=5

$(MUTATE_STAMP): pyproject.toml
	$(PYTHON) -m venv $(MUTATE_VENV)
	$(MUTATE_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(MUTATE_VENV)/bin/python -m pip install --quiet -e '.[mutate]'
	touch $(MUTATE_STAMP)

mutate: $(MUTATE_STAMP)
	$(MUTATE_ENV) $(MUTATE_VENV)/bin/mutmut run $(foreach m,$(MUTANTS),'$(m)')
	$(MUTATE_VENV)/bin/mutmut results --all true \
		| $(MUTATE_VENV)/bin/python tests/mutation_summary.py $(foreach m,$(MUTANTS),'$(m)')
