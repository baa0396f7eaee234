"""What `rcsgen run` says after a run (rcsgen/tools/scenario/runs.py), from results made by
hand, in the unit tier: each unmet expectation (E416) word for word, with the value as the
scenario writes it (true, a name, a number), a lost device not made safe in time (E427), and
a built package that is not what the specs make (E418) naming its files."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from rcsgen.compiler.diagnostics import Span, SpecError
from rcsgen.tools.scenario.model import Expected, Scenario
from rcsgen.tools.scenario.run import Mismatch, RunResult, first_difference, read_trace
from rcsgen.tools.scenario.runs import golden_differences, stale_package, unmet_expectations
from rcsgen.tools.traces import full_lines

AT = Span("s.yaml", 7, 3)
HINT = "if the scenario is meant to end this way, change its `expect:`"


def verdicts(expect: list[Expected], final: dict[str, Any], world: dict[str, Any]) -> list[str]:
    scenario = Scenario("s", "S", Path("s.yaml"), Path("."), None, 50, "sup", [], [])
    scenario.expect = expect
    result = RunResult(scenario, [], 42, final, Counter(), {}, {})
    found = unmet_expectations(scenario, result, world)
    assert all(d.code == "E416" and d.hint == HINT and d.span == AT for d in found)
    return [d.message for d in found]


def test_each_unmet_expectation_says_what_was_wanted_and_what_came() -> None:
    running = {"status": "EXECUTING", "state": "S1"}
    assert verdicts([Expected("status", AT, "DONE")], running, {}) == [
        "expected `sup` to finish DONE; it was still executing after 42 cycles (max_cycles)"
    ]
    failed = {"status": "ERROR", "state": "S3"}
    assert verdicts([Expected("status", AT, "DONE")], failed, {}) == [
        "expected `sup` to finish DONE; it finished ERROR (state S3) in cycle 42"
    ]
    assert verdicts([Expected("status", AT, "ERROR")], failed, {}) == []
    assert verdicts([Expected("cycles", AT, low=50.0)], failed, {}) == [
        "expected the run to take at least 50 cycles; it took 42"
    ]
    assert verdicts([Expected("cycles", AT, low=10.0, high=42.0)], failed, {}) == []
    assert verdicts([Expected("cycles", AT, high=1.0)], failed, {}) == [
        "expected the run to take at most 1 cycle; it took 42"  # once "at most 1 cycles"
    ]
    assert verdicts([Expected("cycles", AT, low=1.0, high=2.0)], failed, {}) == [
        "expected the run to take between 1 and 2 cycles; it took 42"
    ]
    met_then_unmet = [Expected("cycles", AT, low=10.0), Expected("status", AT, "DONE")]
    assert verdicts(met_then_unmet, failed, {}) == [  # a met one does not end the list
        "expected `sup` to finish DONE; it finished ERROR (state S3) in cycle 42"
    ]
    world_met = [
        Expected("status", AT, "ERROR"),
        Expected("x", AT, low=1.0),
        Expected("cycles", AT, low=50.0),
    ]
    assert verdicts(world_met, failed, {"x": 2.0}) == [
        "expected the run to take at least 50 cycles; it took 42"
    ]
    world = {"on": False, "mode": "LEFT", "text": "two words", "x": 2.5}
    wanted = [
        Expected("on", AT, True),
        Expected("mode", AT, "RIGHT"),
        Expected("text", AT, "one"),
        Expected("x", AT, high=2.0),
        Expected("x", AT, low=1.0, high=3.0),  # met
    ]
    assert verdicts(wanted, failed, world) == [
        "expected `on` true at the end; it was false",
        "expected `mode` RIGHT at the end; it was LEFT",
        "expected `text` one at the end; it was 'two words'",
        "expected `x` at most 2 at the end; it was 2.5",
    ]


def test_a_lost_device_not_made_safe_in_time_comes_first() -> None:
    scenario = Scenario("s", "S", Path("s.yaml"), Path("."), None, 50, None, [], [])
    result = RunResult(scenario, [], 42, {}, Counter(), {}, {})
    result.device_failures = [(AT, "device plc lost in cycle 9: drum_on_cmd not safe")]
    found = unmet_expectations(scenario, result, {})
    assert [(d.code, d.message, d.hint) for d in found] == [
        (
            "E427",
            "device plc lost in cycle 9: drum_on_cmd not safe",
            "a lost device must drive the safe state within its timeout + 1 cycle "
            "(docs/io.md, Faults)",
        )
    ]


def test_a_stale_package_names_the_files_that_differ(tmp_path: Path) -> None:
    root = tmp_path / "gen" / "cell"
    plan = SimpleNamespace(write=[root / "sup.py", tmp_path / "elsewhere.py"], delete=[])
    one = stale_package(plan, tmp_path / "gen", "cell")  # type: ignore[arg-type]
    assert one is not None and one.code == "E418"
    assert one.message.endswith("cell` is stale: sup.py differs from what the specs make")
    assert one.hint.startswith("run `rcsgen build -o ") and one.hint.endswith(
        "gen`, or drop --generated to build in memory"
    )
    many = [root / f"m{i}.py" for i in range(8)]
    plan = SimpleNamespace(write=many[:5], delete=[*many[5:], root / "rcs" / "old.py"])
    said = stale_package(plan, tmp_path / "gen", "cell", "rebuild")  # type: ignore[arg-type]
    assert said is not None
    assert said.message.endswith(
        "is stale: m0.py, m1.py, m2.py, m3.py, m4.py, m5.py and 3 more differ from what the "
        "specs make"
    )
    assert said.hint.endswith(", or rebuild")
    exactly = SimpleNamespace(write=many[:6], delete=[])
    six = stale_package(exactly, tmp_path / "gen", "cell")  # type: ignore[arg-type]
    assert six is not None and "m5.py differ from" in six.message and "more" not in six.message
    seven = SimpleNamespace(write=many[:7], delete=[])
    said = stale_package(seven, tmp_path / "gen", "cell")  # type: ignore[arg-type]
    assert said is not None and "m5.py and 1 more differ from" in said.message  # none left out
    none = SimpleNamespace(write=[tmp_path / "elsewhere.py"], delete=[])
    assert stale_package(none, tmp_path / "gen", "cell") is None  # type: ignore[arg-type]


def test_a_run_against_its_golden_trace_same_or_the_first_cycle_that_differs() -> None:
    golden = Path(__file__).resolve().parent / "golden" / "cell" / "plan_ahead.jsonl"
    lines = full_lines(golden)
    assert golden_differences(golden, lines, "plan_ahead") == []
    changed = [*lines[:3], lines[3].replace('"state":', '"state":"X", "was":', 1), *lines[4:]]
    found = golden_differences(golden, changed, "plan_ahead")
    assert [(d.code, d.span.line) for d in found] == [("E417", 4)]
    assert found[0].message.startswith("the run differs from the golden trace: ")
    assert found[0].hint.startswith("review the difference; to accept it: rcsgen run <scenario>")
    assert found[0].hint.endswith("plan_ahead.jsonl") and " --record " in found[0].hint


def test_a_run_longer_or_shorter_than_its_golden_and_a_golden_that_is_no_trace(
    tmp_path: Path,
) -> None:
    golden = Path(__file__).resolve().parent / "golden" / "cell" / "plan_ahead.jsonl"
    lines = full_lines(golden)
    short = first_difference(lines, lines[:-1])
    assert (
        str(short)
        == f"trace: `length` expected '{len(lines)} cycles', got '{len(lines) - 1} cycles'"
    )
    assert first_difference(lines[:2], lines) == Mismatch(
        None, "length", "2 cycles", f"{len(lines)} cycles"
    )
    assert first_difference(lines, list(lines)) is None
    # a length that differs is said at the golden's line after the shorter one's last
    [longer] = golden_differences(golden, [*lines, lines[-1]], "plan_ahead")
    [shorter] = golden_differences(golden, lines[:-2], "plan_ahead")
    assert (longer.code, longer.span.line) == ("E417", len(lines) + 1)
    assert (shorter.code, shorter.span.line) == ("E417", len(lines) - 1)
    damaged = tmp_path / "g.jsonl.gz"
    damaged.write_bytes(b"\x1f\x8b\x08\x00" + b"\xff" * 20)
    with pytest.raises(SpecError) as caught:
        read_trace(damaged)
    [said] = caught.value.diagnostics.items
    assert (said.code, said.span.line, said.hint) == ("E419", 1, "record it again")
    assert said.message.startswith("not a trace: a damaged gzip file (")
