# rcsgen: `make run` builds the specs and runs the miner example; `make test` runs the suite.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: run test lint typecheck prove check build clean fuzz bench mutate mutate-sample mutate-templates complexity

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

# --strict: the shipped specs acknowledge every intended finding, so a new warning fails.
run: $(STAMP)
	$(VENV)/bin/rcsgen build specs/ --strict
	$(VENV)/bin/rcsgen run specs/miner/scenarios/box_cut.yaml

# Two workers (pytest-xdist): the processes tier runs on one of them, one test after another,
# while the other tiers share both (tests/README.md); TEST_WORKERS=0 runs in one process.
TEST_WORKERS ?= 2
test: $(STAMP)
	$(PY) -m pytest -q $(if $(filter 0,$(TEST_WORKERS)),,-n $(TEST_WORKERS) --dist loadgroup)

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
# Every shipped system's running-hierarchy properties (rcsgen prove, about 7 s): a violated
# or undecided finding that no `allow:` acknowledges with its reason fails, before the tests.
prove: $(STAMP)
	$(VENV)/bin/rcsgen prove specs/ --strict -q

check: lint typecheck prove test
	$(VENV)/bin/rcsgen build specs/ --check --strict
	$(VENV)/bin/rcsgen doc specs/ --check

clean:
	rm -rf $(VENV) build dist *.egg-info

# Benchmarks (not part of `make test`): generated code against hand-written code and the
# state-machine libraries, in their own venv; writes bench/RESULTS.md (see bench/README.md).
BENCH_VENV := bench/.venv
BENCH_STAMP := $(BENCH_VENV)/.installed

$(BENCH_STAMP): pyproject.toml bench/requirements.txt Makefile
	$(PYTHON) -m venv $(BENCH_VENV)
	$(BENCH_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(BENCH_VENV)/bin/python -m pip install --quiet -e '.[zenoh,modbus,opcua]' -r bench/requirements.txt
	touch $(BENCH_STAMP)

bench: $(BENCH_STAMP)
	$(BENCH_VENV)/bin/python bench/run.py

# Mutation testing (not part of `make test`): mutmut 3, in its own venv, mutates the compiler,
# the tools and the runtime ([tool.mutmut] in pyproject.toml) and runs, for each mutant, the
# tests that reach the mutated function. The generated packages' runtime copies (`rcs/`) get
# the runtime mutant under test, in the test process and in every process it starts
# (tests/mutation_runtime.py says how). `make mutate` alone continues the whole campaign where
# the last one stopped (work is kept in mutants/; bench/README.md gives its duration);
# MUTANTS='rcsgen.tools.graph.*' (mutmut's name patterns, several allowed) runs just those,
# again from scratch; MUTATE_TESTS='tests/test_graph.py tests/test_reference.py' tries them
# against those test files only (quick, and the score a lower bound). The summary gives the
# score per package (compiler, tools, runtime) and lists the mutants not killed; survivors
# judged equivalent are listed, with the reason, in tests/mutation_equivalent.txt. Read one
# with `.venv-mutate/bin/mutmut show NAME` (or `browse`). MUTATE_CHILDREN=1: the suite's multi-process tests are timing-sensitive, and
# runtime mutants rewrite the working copy's generated/ (a lock keeps more children correct).
MUTATE_VENV := .venv-mutate
MUTATE_STAMP := $(MUTATE_VENV)/.installed
MUTANTS ?=
MUTATE_TESTS ?=
MUTATE_CHILDREN ?= 1
# Fewer random examples than `make test`: every surviving mutant reruns the properties. Bytecode
# is cached: a test that starts `python -m rcsgen` in mutants/ imports the trampolined package.
MUTATE_ENV := EXPR_EXAMPLES=200 DIFF_EXAMPLES=5 PYTHONDONTWRITEBYTECODE=

# The .pth file makes every Python of the venv import tests/mutation_site/mutation_hooks.py,
# which does nothing outside a mutation session.
$(MUTATE_STAMP): pyproject.toml
	$(PYTHON) -m venv $(MUTATE_VENV)
	$(MUTATE_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(MUTATE_VENV)/bin/python -m pip install --quiet -e '.[dev,mutate]'
	printf '%s\nimport mutation_hooks\n' '$(CURDIR)/tests/mutation_site' \
		> "$$($(MUTATE_VENV)/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')/rcsgen_mutation.pth"
	touch $(MUTATE_STAMP)

mutate: $(MUTATE_STAMP)
	$(MUTATE_ENV) RCSGEN_MUTATE_TESTS='$(MUTATE_TESTS)' $(MUTATE_VENV)/bin/mutmut run \
		--max-children $(MUTATE_CHILDREN) $(foreach m,$(MUTANTS),'$(m)')
	$(MUTATE_VENV)/bin/mutmut results --all true \
		| $(MUTATE_VENV)/bin/python tests/mutation_summary.py $(foreach m,$(MUTANTS),'$(m)')

# A bounded measure of the compiler and the tools (tests/mutation_sample.py, bench/README.md):
# a fixed-seed stratified sample of one-line mutants, each against the fast tiers' tests that
# run its lines, in a scratch copy of the tree; prints per module, per package and overall
# the score with its 95 % interval. 25-45 min to map the tests' lines (keep the map with
# --cover FILE; --add TESTFILE traces only new or changed test files into it), then mutants
# for --minutes (the default run fits in an hour on a quiet machine); MUTATE_SAMPLE='--total 300' etc.
MUTATE_SAMPLE ?= --minutes 30
mutate-sample: $(STAMP)
	nice -n 10 $(PY) tests/mutation_sample.py $(MUTATE_SAMPLE)

# The templates' safety code, which mutmut cannot reach (tests/mutation_templates.py): each
# one-line mutant of controller.py.j2's seqlocks, overrides, loss, resume and safe state,
# tried against the runtime's safety tests in a fresh pytest; prints the score and survivors.
mutate-templates: $(STAMP)
	$(PY) tests/mutation_templates.py
