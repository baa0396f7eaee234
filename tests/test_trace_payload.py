"""The trace page's data (rcsgen/tools/traces/view.py) from a trace made by hand, in the unit
tier: what each lane draws (commands, statuses with their reason and cause, states, where a
rule fired) run-length encoded over the cycles or over only the cycles where a module's
values change, the world's plots by the type of their values, the cycle numbers when some
are missing, a paced run's figures, and the page's title. test_trace_view draws a golden
trace's page in a browser; here every number of the data is read.
"""

from __future__ import annotations

import json
from typing import Any

import pytest

from rcsgen.tools.traces import view
from rcsgen.tools.traces.read import Lane, Trace

FIGURES = {
    "period_ms": 20.0,
    "wakeups": 4,
    "period_error_mean_us": 12.5,
    "period_error_max_us": 480.0,
    "lateness_p99_us": 90.0,
    "lateness_max_us": 150.0,
    "lateness_warnings": 0,
}


def trace(cycles: list[int] | None = None, **over: Any) -> Trace:
    a = {
        "command": ["INIT", "INIT", "RUN", "RUN"],
        "command_num": [1, 1, 2, 2],
        "status": ["EXECUTING", "DONE", "EXECUTING", "ERROR"],
        "status_num": [1, 1, 2, 2],
        "reason": [None, None, None, "TIMED_OUT"],
        "cause": ["", "", "", "b: REFUSED"],
        "state": ["S0", "S0", "S1", "S1"],
        "rule": [None, "R1", None, "R2"],
    }
    b = {  # no reason or cause recorded; its values change at cycles 0 and 2 only
        "command": ["INIT"] * 4,
        "command_num": [1] * 4,
        "status": ["DONE"] * 4,
        "status_num": [1] * 4,
        "state": ["S0"] * 4,
        "rule": ["R3", "R3", None, None],
    }
    made = Trace(
        "t.jsonl",
        cycles or [10, 11, 12, 13],
        ["a", "b"],
        {"a": a, "b": b},
        {"on": [True, False, True, True], "n": [1, 2, 3, 4]},
        starts={"b": [0, 2]},
    )
    for key, value in over.items():
        setattr(made, key, value)
    return made


LANES = [Lane("a", "the arm", 2, runs_as="a"), Lane("b", "", 1, simulator=True, runs_as="a")]


def data(t: Trace, lanes: list[Lane] = LANES) -> dict[str, Any]:
    text = view.payload(t, lanes, "cell", 0.02)
    loaded: dict[str, Any] = json.loads(text)
    return loaded


def test_each_lane_is_run_length_encoded_with_its_numbers_reasons_and_rules() -> None:
    got = data(trace())
    assert got["strings"] == [
        "R1",
        "R2",
        "INIT",
        "RUN",
        "EXECUTING",
        "DONE",
        "ERROR(TIMED_OUT <- b: REFUSED)",
        "S0",
        "S1",
        "R3",
    ]
    a, b = got["lanes"]
    assert a == {
        "module": "a",
        "title": "the arm",
        "level": 2,
        "simulator": False,
        "runs_as": "",  # runs its own table
        "command": [0, 2, 1, 2, 3, 2],  # INIT #1 from index 0, RUN #2 from 2
        "status": [0, 4, 1, 1, 5, 1, 2, 4, 2, 3, 6, 2],
        "state": [0, 7, 2, 8],
        "rules": [1, 0, 3, 1],  # R1 fired at index 1, R2 at 3
    }
    assert b == {
        "module": "b",
        "title": "",
        "level": 1,
        "simulator": True,
        "runs_as": "a",
        "command": [0, 2, 1],
        "status": [0, 5, 1],
        "state": [0, 7],
        "rules": [0, 9, 1, 9],  # a run of cycles where R3 fired: each of them
    }
    assert {k: got[k] for k in ("source", "system", "period", "n", "cycle0", "cycles")} == {
        "source": "t.jsonl",
        "system": "cell",
        "period": 0.02,
        "n": 4,
        "cycle0": 10,
        "cycles": None,  # consecutive: the page counts from cycle0
    }
    assert "periodicity" not in got


def test_a_status_changes_run_when_only_its_reason_or_cause_changes() -> None:
    t = trace()
    a = t.columns["a"]
    a["status"] = ["ERROR"] * 4
    a["status_num"] = [1] * 4
    a["reason"] = ["TIMED_OUT", "TIMED_OUT", "REFUSED", "REFUSED"]
    a["cause"] = ["", "", "", "b: LOST"]
    got = data(t, LANES[:1])
    shown = [got["strings"][i] for i in got["lanes"][0]["status"][1::3]]
    assert shown == ["ERROR(TIMED_OUT)", "ERROR(REFUSED)", "ERROR(REFUSED <- b: LOST)"]
    assert got["lanes"][0]["status"][0::3] == [0, 2, 3]
    del a["cause"]  # a trace recorded before causes were: none shown
    got = data(t, LANES[:1])
    shown = [got["strings"][i] for i in got["lanes"][0]["status"][1::3]]
    assert shown == ["ERROR(TIMED_OUT)", "ERROR(REFUSED)"]


def test_a_trace_with_missing_cycles_gives_every_cycle_number() -> None:
    got = data(trace([10, 11, 13, 14]))
    assert got["cycles"] == [10, 11, 13, 14] and got["cycle0"] == 10


def test_each_world_field_is_plotted_by_the_type_of_its_values() -> None:
    world = {
        "on": [True, False, True, True],
        "n": [1, 2, 3, 4],
        "mode": ["B", "A", "B", "</script>"],
        "x": [0.5, 1.5, 2.5, 3.5],
        "gaps": [1.0, float("nan"), 2, "s"],
        "inf": [float("inf"), 1.0, 1.0, -1.0],
        "mixed": [True, 2, False, 3],
    }
    got = data(trace(world=world))["world"]
    assert got == [
        {"name": "on", "type": "bool", "values": [1, 0, 1, 1]},
        {"name": "n", "type": "int", "values": [1, 2, 3, 4]},
        {"name": "mode", "type": "text", "values": [2, 1, 2, 0], "names": ["</script>", "A", "B"]},
        {"name": "x", "type": "float", "values": [0.5, 1.5, 2.5, 3.5]},
        {"name": "gaps", "type": "float", "values": [1.0, None, 2.0, None]},
        {"name": "inf", "type": "float", "values": [None, 1.0, 1.0, -1.0]},
        {"name": "mixed", "type": "float", "values": [1.0, 2.0, 0.0, 3.0]},
    ]
    text = view.payload(trace(world=world), LANES, None, None)
    assert "</" not in text and "<\\/script>" in text  # cannot close the page's <script>
    assert [view.number(v) for v in (3, True, 2.5, float("nan"), float("-inf"), "7")] == [
        3.0,
        1.0,
        2.5,
        None,
        None,
        None,
    ]


def test_the_page_is_titled_with_the_trace_its_length_system_and_timing() -> None:
    many = list(range(1500))
    column = {
        "command": ["INIT"] * 1500,
        "command_num": [1] * 1500,
        "status": ["DONE"] * 1500,
        "status_num": [1] * 1500,
        "state": ["S0"] * 1500,
        "rule": [None] * 1500,
    }
    t = Trace("run <1>.jsonl", many, ["a"], {"a": column}, {})
    page = view.render(t, [Lane("a")], "cell", 0.02)
    assert "<title>run &lt;1&gt;.jsonl · 1,500 cycles · cell</title>" in page
    assert "{{DATA}}" not in page and "{{TITLE}}" not in page
    bare = view.render(t, [Lane("a")])
    assert "<title>run &lt;1&gt;.jsonl · 1,500 cycles</title>" in bare
    t.periodicity = FIGURES
    paced = view.render(t, [Lane("a")], "cell")
    assert (
        "<title>run &lt;1&gt;.jsonl · 1,500 cycles · cell · paced: period error mean 12.5 µs,"
        in paced
    )
    assert json.loads(view.payload(t, [Lane("a")], None, None))["periodicity"] == FIGURES


def test_the_payload_is_strict_json_and_refuses_a_figure_that_is_not_finite() -> None:
    """The page reads its data with JSON.parse, which has no NaN: a figure that is not a
    finite number (the reader refuses one; a trace made by hand may hold it) is refused here
    rather than written as `NaN`."""
    t = trace()
    t.periodicity = FIGURES | {"lateness_p99_us": float("nan")}
    with pytest.raises(ValueError, match="Out of range float values are not JSON compliant"):
        view.payload(t, [Lane("a")], None, None)
