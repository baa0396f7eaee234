"""The planner/executor template (W1/W2) as specs/cell writes it (docs/spec.md section 16,
"Planning ahead"): its golden trace shows the planner planning move k+1 in the very cycles
the executor makes move k, for every move after the first, and the executor waiting for
the planner only after the moves shorter than the planning (the first and the fourth)."""

from __future__ import annotations

import json
from pathlib import Path

from rcsgen.tools.scenario import read_trace

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden" / "cell" / "plan_ahead.jsonl"


def lines() -> list[dict]:
    return [json.loads(line)["modules"] for line in read_trace(GOLDEN)]


def test_each_move_after_the_first_is_planned_while_the_one_before_is_made():
    overlap: dict[int, int] = {}  # the planner's command number -> cycles of overlap
    for m in lines():
        pln, exe = m["pln"], m["exe"]
        if (pln["command"], exe["command"]) == ("PLAN", "MOVE") and pln["status"] == exe[
            "status"
        ] == "EXECUTING":
            overlap[pln["command_num"]] = overlap.get(pln["command_num"], 0) + 1
    plans = sorted({m["pln"]["command_num"] for m in lines() if m["pln"]["command"] == "PLAN"})
    assert len(plans) == 5, "one plan per move"
    assert sorted(overlap) == plans[1:], "every plan but the first overlaps a move"
    assert all(cycles >= 1 for cycles in overlap.values())


def test_the_executor_waits_only_after_a_move_shorter_than_the_planning():
    waits = [m["sup"]["result"]["made"] for m in lines() if m["sup"]["rule"] == "RUN/MOVING/4"]
    assert sorted(set(waits)) == [0, 3]  # 0 -> 20 mm and 50 -> 60 mm: 2 and 1 cycles
    last = lines()[-1]["sup"]
    assert (last["status"], last["result"]) == ("DONE", {"made": 5, "waited": len(waits)})
