"""A shipped scenario's run, read from its golden trace instead of being run again.

test_golden runs every shipped scenario on the committed generated package and compares
the trace with the golden file byte for byte (and test_generated_current keeps that package
the specs' build): the golden's lines are that run's lines. A test that asserts what a
scenario does reads them here, a fraction of a second, instead of running the scenario once
more in every test module and xdist worker (seconds each). A wrong golden still fails those
tests; a golden that the run no longer leaves fails test_golden.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

from rcsgen.tools.scenario import load_scenario, read_trace

ROOT = Path(__file__).resolve().parent.parent.parent
GOLDEN = ROOT / "tests" / "golden"


def golden_path(system: str, name: str) -> Path:
    """The golden trace of `system`'s scenario `name` (the miner's in tests/golden/)."""
    return GOLDEN / ("" if system == "miner" else system) / f"{name}.jsonl"


@cache
def golden_run(system: str, name: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(the stop module's last status, the trace lines) of the run the golden records: the
    status as the scenario's run reports it (`RunResult.final`: status, state, reason and
    results), taken from the last line."""
    scenario = load_scenario(ROOT / "specs" / system / "scenarios" / f"{name}.yaml")
    lines = [json.loads(line) for line in read_trace(golden_path(system, name))]
    stop = scenario.stop_when_done
    if not stop:
        return {}, lines
    entry = lines[-1]["modules"][stop]
    final = {"status": entry["status"], "state": entry["state"]}
    final["reason"] = entry.get("reason")  # None: the module declares no reasons
    final["results"] = entry.get("result", {})
    return final, lines
