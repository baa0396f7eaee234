"""`rcsgen run`'s steps around a run (rcsgen/tools/scenario/session.py), in the unit tier:
the scenario checked against the system above it (or not, when that system does not build),
the traces written or refused with E419, and an interrupted run's trace ended by a line
saying so, with what was written said back."""

from __future__ import annotations

import io
import os
import signal
from pathlib import Path

import pytest

from rcsgen.tools.scenario import session
from rcsgen.tools.scenario.model import Scenario
from rcsgen.tools.scenario.session import Ran, check, write_interrupted, write_traces
from rcsgen.tools.traces import full_lines

HERE = Path(__file__).resolve().parent
SCENARIO = HERE.parent / "specs" / "cell" / "scenarios" / "plan_ahead.yaml"
GOLDEN = HERE / "golden" / "cell" / "plan_ahead.jsonl"


def test_a_scenario_is_checked_against_the_system_above_it() -> None:
    checked = check(SCENARIO)
    assert checked.system is not None and checked.system.name == "cell"
    assert checked.scenario is not None and checked.scenario.name == "plan_ahead"
    assert [len(d.errors) for d in checked.diagnostics] == [0, 0]  # the specs', the scenario's


def test_a_system_that_does_not_build_leaves_the_scenario_unchecked(tmp_path: Path) -> None:
    (tmp_path / "system.yaml").write_text("system: broken\nprocesses: 3\n")
    (tmp_path / "scenarios").mkdir()
    path = tmp_path / "scenarios" / "s.yaml"
    path.write_text("scenario: s\ntitle: A scenario\nmax_cycles: 20\n")
    checked = check(path)
    assert checked.system is None and checked.scenario is None
    assert len(checked.diagnostics) == 1 and checked.diagnostics[0].errors  # the specs' only


def test_a_scenario_with_no_system_above_it_says_so(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text("scenario: s\ntitle: A scenario\nmax_cycles: 20\n")
    checked = check(path)
    assert checked.system is None and checked.scenario is None
    assert [d.code for batch in checked.diagnostics for d in batch.errors] == ["E403"]


def test_traces_are_written_each_or_refused_each_with_e419(tmp_path: Path) -> None:
    lines = full_lines(GOLDEN)[:3]
    (tmp_path / "file").write_text("")  # where the trace's directory would be
    good, bad = tmp_path / "out" / "t.jsonl", tmp_path / "file" / "t.jsonl"
    deeper = tmp_path / "file" / "day" / "t.jsonl"
    problems = write_traces(lines, [good, bad, deeper])
    assert full_lines(good) == lines
    # which folder on the way is a file, not the system's bare "File exists"
    assert [(d.code, d.message) for d in problems] == [
        ("E419", f"cannot write trace `{bad}`: `{tmp_path / 'file'}` is a file, not a folder"),
        ("E419", f"cannot write trace `{deeper}`: `{tmp_path / 'file'}` is a file, not a folder"),
    ]


def test_an_interrupted_runs_trace_ends_with_a_line_saying_so(tmp_path: Path) -> None:
    lines = full_lines(GOLDEN)[:2]
    path = tmp_path / "t.jsonl"
    said = write_interrupted(Ran(lines=list(lines)), path, "SIGINT")
    assert said == f"{path} holds cycles 1-2 and a last line saying so"
    assert full_lines(path)[-1] == '{"cycle":3,"interrupted":"SIGINT"}'
    empty = tmp_path / "e.jsonl"
    assert write_interrupted(Ran(lines=[]), empty, "SIGTERM") == (
        f"{empty} holds only a line saying so"
    )
    (tmp_path / "file").write_text("")
    refused = tmp_path / "file" / "t.jsonl"
    assert write_interrupted(Ran(lines=[]), refused, "SIGTERM") == (
        f"cannot write trace `{refused}`: `{tmp_path / 'file'}` is a file, not a folder"
    )


def test_a_signal_while_the_harness_opens_stops_the_run_and_says_which_signal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """SIGTERM while the system is being made: nothing ran, nothing failed, the run says it
    was SIGTERM, and the handlers are the default ones again afterwards."""

    def opening(*_: object) -> None:
        os.kill(os.getpid(), signal.SIGTERM)  # its handler raises in this frame
        raise AssertionError("the signal did not stop the opening")

    monkeypatch.setattr(session, "open_harness", opening)
    scenario = Scenario("s", "S", tmp_path / "s.yaml", tmp_path, None, 5, None, [], [])
    saved = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    try:
        ran = session.execute(scenario, tmp_path, False, lambda _: None, io.StringIO())
        handlers = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    finally:
        signal.signal(signal.SIGINT, saved[0])
        signal.signal(signal.SIGTERM, saved[1])
    assert (ran.signal, ran.failed, ran.harness, ran.result) == (signal.SIGTERM, None, None, None)
    assert handlers == (signal.default_int_handler, signal.SIG_DFL)


def test_a_signal_a_hook_turned_into_its_own_error_still_stops_the_run_as_that_signal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """SIGINT while the system is being made, and a hook-state factory there catches the
    interruption and fails in its own words: the run stops as interrupted by SIGINT, not as
    that error."""

    def opening(*_: object) -> None:
        try:
            os.kill(os.getpid(), signal.SIGINT)
        except KeyboardInterrupt:
            raise ValueError("the map could not be read") from None

    monkeypatch.setattr(session, "open_harness", opening)
    scenario = Scenario("s", "S", tmp_path / "s.yaml", tmp_path, None, 5, None, [], [])
    saved = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    try:
        ran = session.execute(scenario, tmp_path, False, lambda _: None, io.StringIO())
    finally:
        signal.signal(signal.SIGINT, saved[0])
        signal.signal(signal.SIGTERM, saved[1])
    assert (ran.signal, ran.failed, ran.harness, ran.result) == (signal.SIGINT, None, None, None)


def test_a_trace_path_that_is_a_folder_is_refused_with_the_systems_reason(tmp_path: Path) -> None:
    folder = tmp_path / "t.jsonl"
    folder.mkdir()
    [problem] = write_traces(full_lines(GOLDEN)[:1], [folder])
    assert (problem.code, problem.message) == (
        "E419",
        f"cannot write trace `{folder}`: Is a directory",
    )


def test_a_system_that_builds_with_an_error_leaves_the_scenario_unchecked(tmp_path: Path) -> None:
    """A system directory holding a copy of its system (E231: two systems named `cell`):
    the system built, but with an error, so the scenario is not checked against it."""
    specs = HERE.parent / "specs" / "cell"
    for folder in (tmp_path, tmp_path / "copy"):
        folder.mkdir(exist_ok=True)
        for spec in specs.glob("*.yaml"):
            (folder / spec.name).write_bytes(spec.read_bytes())
    (tmp_path / "scenarios").mkdir()
    path = tmp_path / "scenarios" / "s.yaml"
    path.write_text("scenario: s\ntitle: A scenario\nmax_cycles: 20\n")
    checked = check(path)
    assert checked.system is None and checked.scenario is None
    [specs_said] = checked.diagnostics
    assert [d.code for d in specs_said.errors] == ["E231"]
