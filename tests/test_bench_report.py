"""`bench/run.py --parts`: a run of some parts puts its figures into the full report.

Its sections replace the full run's sections of the same title, and each target line it
measured again (and each figure measured with no target) replaces the full run's line for
the same target, marked with when and under what load; every other line stays the full
run's.
"""

from __future__ import annotations

import datetime
import importlib.util
import sys
from pathlib import Path
from types import ModuleType

BENCH = Path(__file__).resolve().parent.parent / "bench"


def report_module() -> ModuleType:
    sys.path.insert(0, str(BENCH))  # run.py imports its neighbour `common`
    try:
        spec = importlib.util.spec_from_file_location("bench_run", BENCH / "run.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(BENCH))


FULL = """\
# rcsgen benchmark

## Targets

They do not gate CI; each line gives the measured value.

- **FAIL** `rcsgen validate specs/` ≤ 1000 ms CPU: 1018 ms (section 4)
- **PASS** generated co ≤ 1.0× the hand-written baseline: 0.87× (2.56 µs per cycle)
- **FAIL** 1,000-controller build ≤ 5 s CPU: 8.5 s (front end 5.4 s)

Measured, with no target:

- lockstep cost of the two-process miner: 50.2 µs more per system cycle
- start-up of the planner: 300 ms

## 1. co

co figures, full run

## 3. Scaling: 1,000 controllers

old scaling table

## Clean-up

nothing left
"""

PART = """\
# rcsgen benchmark

## Targets

They do not gate CI; each line gives the measured value.

- **PASS** `rcsgen validate specs/` ≤ 1000 ms CPU: 800 ms (section 4)
- **PASS** 1,000-controller build ≤ 5 s CPU: 4.9 s (front end 3.1 s)
- **PASS** a target the full run did not report: 3

Measured, with no target:

- lockstep cost of the two-process miner: 84.5 µs more per system cycle
- a figure the full run did not report: 7

## 3. Scaling: 1,000 controllers

new scaling table

## Clean-up

nothing left
"""


def test_a_subset_run_refreshes_its_sections_and_its_target_lines_only() -> None:
    run = report_module()
    when = datetime.datetime(2026, 11, 27, 18, 5, tzinfo=datetime.UTC)
    text = run.splice(FULL, PART, when, (0.5, 1.25))
    stamp = (
        "(refreshed: `bench/run.py --parts`, 2026-11-27 18:05 UTC, "
        "load average 0.50 before, 1.25 after)"
    )
    targets = [line for line in text.splitlines() if line.startswith("- **")]
    assert targets == [
        f"- **PASS** `rcsgen validate specs/` ≤ 1000 ms CPU: 800 ms (section 4) {stamp}",
        "- **PASS** generated co ≤ 1.0× the hand-written baseline: 0.87× (2.56 µs per cycle)",
        f"- **PASS** 1,000-controller build ≤ 5 s CPU: 4.9 s (front end 3.1 s) {stamp}",
        f"- **PASS** a target the full run did not report: 3 {stamp}",
    ]
    # the figures measured with no target, the same way
    measured = [line for line in text.splitlines() if line.startswith("- ") and "**" not in line]
    assert measured == [
        f"- lockstep cost of the two-process miner: 84.5 µs more per system cycle {stamp}",
        "- start-up of the planner: 300 ms",
        f"- a figure the full run did not report: 7 {stamp}",
    ]
    assert "co figures, full run" in text and "old scaling table" not in text
    assert (
        "new scaling table\n\n(This section: `bench/run.py --parts`, 2026-11-27 18:05 UTC" in text
    )
    assert text.count("## Targets") == 1 and text.count("## Clean-up") == 1
    assert text.index("## 1. co") < text.index("## 3. Scaling") < text.index("## Clean-up")
