"""Results and reasons made visible (issue 14, item 2 follow-up): the harness's `Status`,
trace lines, the trace tools (changes, coverage, the trace view), scenarios' `expect:` and
`report:` figures, and `rcsgen ctl status`, on the results fixture (a mission, a helm with
results, a fixturing operator who refuses or times out).
"""

from __future__ import annotations

import importlib
import json
import shutil
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import wait_for
from test_ctl import Running

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness, generate, import_package
from rcsgen.tools.scenario import check_scenario, load_scenario, open_harness, run, runs, trace_line
from rcsgen.tools.traces import changes, coverage
from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces import view as trace_view

FIXTURE = Path(__file__).resolve().parent / "fixtures" / "language" / "results"
REPO = Path(__file__).resolve().parent.parent

REFUSAL = """\
scenario: refusal
title: The operator refuses to clamp
max_cycles: 50
stop_when_done: mission
expect:
  status: ERROR
  figures:
    mission.reason: OPERATOR_REFUSED
    fx.reason: REFUSED
    helm.result.at_goal: false
    mission.result.legs: 0
report:
  figures: [distance, mission.reason, helm.result.course_error]
events:
  - cycle: 1
    set: {answer: 2, distance: 0.5}
    command: mission.GO
"""


@pytest.fixture
def system_dir(tmp_path: Path) -> Path:
    """A scratch copy of the results fixture, with a scenarios/ directory."""
    copy = tmp_path / "results"
    shutil.copytree(FIXTURE, copy)
    (copy / "scenarios").mkdir()
    return copy


@pytest.fixture
def package(system_dir: Path) -> Iterator[Path]:
    scratch, name = generate(system_dir)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


def scenario_at(system_dir: Path, text: str) -> Path:
    path = system_dir / "scenarios" / "refusal.yaml"
    path.write_text(text, encoding="utf-8")
    return path


# ---------------------------------------------------------------- harness and trace line


def test_status_carries_the_reason_by_name_and_the_results() -> None:
    with Harness.build(FIXTURE) as h:
        h.world["answer"] = 2
        h.world["distance"] = 0.5
        h.command("mission", "GO")
        h.cycle(1)
        helm, fx = h.status("helm"), h.status("fx")
        assert (fx.status, fx.reason, fx.results) == ("ERROR", "REFUSED", {})
        assert (helm.status, helm.reason) == ("EXECUTING", "NONE")  # no reason but in ERROR
        assert helm.results == {"at_goal": True, "course_error": 0.5}
        h.cycle(1)
        mission = h.status("mission")
        assert (mission.status, mission.reason) == ("ERROR", "OPERATOR_REFUSED")
        assert mission.results == {"legs": 0}
        line = json.loads(trace_line(h, []))["modules"]
        assert line["fx"]["reason"] == "REFUSED" and "result" not in line["fx"]
        assert line["mission"]["reason"] == "OPERATOR_REFUSED"
        assert line["mission"]["result"] == {"legs": 0}
        # HALT is a new command for the helm: its results start again from nothing
        assert line["helm"]["result"] == {"at_goal": False, "course_error": 0.0}


def test_a_module_without_reasons_or_results_keeps_its_trace_line() -> None:
    """The miner declares neither: its trace lines have no `reason` or `result` keys, so
    its golden traces do not change."""
    h = Harness.load(REPO / "generated" / "miner", REPO / "specs" / "miner", send_init=True)
    h.cycle(1)
    line = json.loads(trace_line(h, []))["modules"]
    assert all(set(m) == set(traces.FIELDS) for m in line.values())
    assert h.status("co").reason is None and h.status("co").results == {}


# ---------------------------------------------------------------- the trace tools


def test_changes_coverage_and_the_trace_view_show_reasons_and_results(
    system_dir: Path, package: Path
) -> None:
    scenario = load_scenario(scenario_at(system_dir, REFUSAL))
    harness = open_harness(scenario, package)
    try:
        result = run(scenario, harness)
    finally:
        harness.close()
    trace = traces.parse("\n".join(result.trace), "refusal.jsonl")
    assert trace.columns["fx"]["reason"][-1] == "REFUSED"
    assert trace.columns["helm"]["result"][0] == {"at_goal": True, "course_error": 0.5}
    assert "reason" not in trace.columns["helm"] or trace.columns["helm"]["reason"][0] == "NONE"
    system = compile_paths([system_dir]).systems[0]
    lanes = traces.lanes(trace, system)
    text = "\n".join(changes.timeline(trace, lanes, trace.modules, world="none"))
    assert "fx       command CLAMP #1  status ERROR(REFUSED) #1" in text
    assert "-> ERROR(OPERATOR_REFUSED <- fx: REFUSED) #" in text  # and what it came from
    assert "result.at_goal true -> false" in text  # the helm's HALT starts its results again
    assert "result.course_error 0.5 -> 0.0" in text
    covered = coverage.measure(system, [trace])
    fired = {(r.module, r.rule) for r in covered.rules if r.cycles}
    assert ("mission", "GO/S1/1") in fired and ("fx", "CLAMP/S0/2") in fired
    data = json.loads(trace_view.payload(trace, lanes, system.name, 0.1))
    assert "ERROR(OPERATOR_REFUSED <- fx: REFUSED)" in data["strings"]
    mission = next(lane for lane in data["lanes"] if lane["module"] == "mission")
    codes = mission["status"][1::3]  # (start, string, number) per run
    assert data["strings"][codes[-1]] == "ERROR(OPERATOR_REFUSED <- fx: REFUSED)"


def test_a_reason_or_result_missing_from_a_later_line_is_one_line_error() -> None:
    first = {"command": "GO", "command_num": 1, "status": "EXECUTING", "status_num": 1}
    first |= {"state": "S0", "rule": None, "reason": "NONE", "result": {"legs": 0}}
    second = {k: v for k, v in first.items() if k != "reason"}
    lines = [
        json.dumps({"cycle": 1, "modules": {"mission": first}}),
        json.dumps({"cycle": 2, "modules": {"mission": second}}),
    ]
    with pytest.raises(traces.TraceError, match=r"^t:2: module mission has no `reason`$"):
        traces.parse("\n".join(lines), "t")
    with pytest.raises(traces.TraceError, match=r"^t:2: module mission has a `reason` the first"):
        traces.parse("\n".join(reversed(lines)).replace('"cycle": 2', '"cycle": 0'), "t")


# ---------------------------------------------------------------- scenarios' expect:


def test_expectations_on_reasons_and_results_are_met_or_reported(
    system_dir: Path, package: Path
) -> None:
    scenario = load_scenario(scenario_at(system_dir, REFUSAL))
    harness = open_harness(scenario, package)
    try:
        result = run(scenario, harness)
    finally:
        harness.close()
    assert runs.unmet_expectations(scenario, result, {}) == []
    assert result.figures == {
        "distance": 0.5,
        "mission.reason": "OPERATOR_REFUSED",
        "helm.result.course_error": 0.0,
    }
    wrong = scenario_at(
        system_dir,
        REFUSAL.replace("fx.reason: REFUSED", "fx.reason: TIMED_OUT").replace(
            "mission.result.legs: 0", "mission.result.legs: {min: 1}"
        ),
    )
    unmet = runs.unmet_expectations(load_scenario(wrong), result, {})
    assert [(d.code, d.span.line, d.message) for d in unmet] == [
        (
            "E416",
            9,
            "expected `fx.reason` TIMED_OUT at the end; it was REFUSED",
        ),
        ("E416", 11, "expected `mission.result.legs` at least 1 at the end; it was 0"),
    ]


@pytest.mark.parametrize(
    ("old", "new", "code", "where", "message", "hint"),
    [
        (
            "fx.reason: REFUSED",
            "fx.reason: REFUSD",
            "E408",
            (9, 16),
            "`REFUSD` is not a reason `fx` can give",
            "did you mean `REFUSED`?",
        ),
        (
            "helm.result.at_goal",
            "helm.result.at_gaol",
            "E415",
            (10, 5),
            "expected figure `helm.result.at_gaol`: `helm` has no result `at_gaol`",
            "did you mean `at_goal`?",
        ),
        (
            "fx.reason: REFUSED",
            "fz.reason: REFUSED",
            "E405",
            (9, 5),
            "expected figure's module `fz` is not a controller of `results`",
            "did you mean `fx`?",
        ),
        (
            "fx.reason: REFUSED",
            "fx.result.clamped: true",
            "E415",
            (9, 5),
            "expected figure `fx.result.clamped`: `fx` has no result `clamped`",
            "no results of fx are declared",
        ),
        (
            "mission.reason: OPERATOR_REFUSED",
            "mission.reason: {min: 1}",
            "E415",
            (8, 5),
            "`mission.reason` is a reason: expect one of its names, not a range",
            "",
        ),
        (
            "[distance, mission.reason",
            "[distance, mission.raeson",
            "S004",
            (13, 23),
            "",
            "",
        ),
    ],
)
def test_a_bad_reason_or_result_expectation_is_located(
    system_dir: Path, old: str, new: str, code: str, where, message: str, hint: str
) -> None:
    path = scenario_at(system_dir, REFUSAL.replace(old, new))
    scenario, diags = check_scenario(path)
    assert scenario is None
    found = [d for d in diags.items if d.code == code]
    assert found, [str(d) for d in diags.items]
    assert (found[0].span.line, found[0].span.col) == where
    if message:
        assert found[0].message == message
        assert found[0].hint == hint


# ---------------------------------------------------------------- ctl status


def test_ctl_status_shows_the_reason_beside_an_error_and_the_results(package: Path) -> None:
    layout = importlib.import_module(f"{import_package(package, FIXTURE).__name__}.layout")
    running = Running(package, FIXTURE, layout, "--world", "answer=2", "--world", "distance=0.5")
    try:
        assert running.ctl("send", "mission", "GO").returncode == 0
        wait_for(lambda: running.module("mission")["status"] == "ERROR", "mission ERROR")
        # the helm, commanded in the mission's place, reaches the goal and says so
        sent = running.ctl("send", "helm", "TRANSIT", "--override")
        assert sent.returncode == 0, sent.stderr
        wait_for(lambda: running.module("helm")["results"]["at_goal"], "helm at goal")
        text = running.ctl("status")
        assert text.returncode == 0, text.stderr
        lines = text.stdout.splitlines()
        mission = next(line for line in lines if line.startswith("mission "))
        # the mission's error with what it came from: fx's refusal (reasons survive)
        assert mission.split()[1:3] == ["GO", "2"], mission
        assert " ERROR(OPERATOR_REFUSED <- fx: REFUSED) " in mission, mission
        fx = next(line for line in lines if line.startswith("fx "))
        assert fx.split()[3] == "ERROR(REFUSED)", fx
        assert "results helm: at_goal true, course_error 0.5" in lines
        assert "results mission: legs 0" in lines
        snapshot = running.json()["modules"]
        assert snapshot["fx"]["reason"] == "REFUSED"  # type: ignore[index]
        assert snapshot["mission"]["cause"] == "fx: REFUSED"  # type: ignore[index]
        assert "cause" not in snapshot["fx"]  # type: ignore[operator]
        assert snapshot["helm"]["reason"] == "NONE"  # type: ignore[index]
        assert snapshot["helm"]["results"] == {"at_goal": True, "course_error": 0.5}  # type: ignore[index]
    finally:
        running.stop()


# ---------------------------------------------------------------- a reason passed up

PASSING_SUB = """\
controller: sub
title: Sub
commands:
  CLAMP:
    reasons: [REFUSED]
    states:
      S0:
        - do: [{report: ERROR, reason: REFUSED}]
  UNCLAMP:
    reasons: [JAMMED]
    states:
      S0:
        - do: [{report: ERROR, reason: JAMMED}]
"""
PASSING_TOP = """\
controller: top
title: Top
subordinates: [sub]
commands:
  GO:
    doc: Clamp; a failure is passed up as the sub's reason.
    reasons: [BUSY, REFUSED]  # REFUSED is code 3 here, 2 in sub
    states:
      S0:
        - do: [send: sub.CLAMP]
          next: S1
      S1:
        - when: sub.status == ERROR
          do: [{report: ERROR, reason: sub.reason}]
"""
PASSING_SYSTEM = """\
system: passing
title: A reason passed up
cycle_period: 0.1
processes:
  p:
    modules: [top, sub]
"""


@pytest.fixture
def passing(tmp_path: Path) -> Iterator[Harness]:
    for name, text in (("sub", PASSING_SUB), ("top", PASSING_TOP), ("system", PASSING_SYSTEM)):
        (tmp_path / f"{name}.yaml").write_text(text, encoding="utf-8")
    with Harness.build(tmp_path) as h:
        yield h


def test_a_subordinates_reason_is_passed_up_by_name(passing: Harness) -> None:
    """sub's REFUSED (its code 2) is top's REFUSED (its code 3): the name is passed, not the
    code; LOST stays LOST; a reason top's command does not declare (JAMMED, which an
    operator's UNCLAMP could leave) is passed up as NONE."""
    h = passing
    h.command("top", "GO")
    h.cycle(2)
    assert (h.status("top").status, h.status("top").reason) == ("ERROR", "REFUSED")
    assert h.status("top").error_num == 3 and h.status("sub").error_num == 2
    for given, passed in (("LOST", "LOST"), ("JAMMED", "NONE"), ("NONE", "NONE")):
        h.command("top", "GO")
        h.step("top")  # S0: sends CLAMP
        h.reply("sub", "ERROR")
        code = h.layout.REASON_NAMES["sub"].index(given)
        h.layout.STATUS_OUT["sub"].write(h.buf, error_num=code)
        h.step("top")
        assert (h.status("top").status, h.status("top").reason) == ("ERROR", passed), given


@pytest.mark.parametrize(
    ("guard", "warned"),
    [
        ("sub.status == ERROR", False),
        ("ERROR == sub.status", False),
        ("sub.reason == REFUSED", False),
        ("sub.reason != NONE", False),
        ("sub.command == CLAMP and sub.status == ERROR", False),
        ("sub.status != EXECUTING", True),
        ("sub.reason == NONE", True),
        ("sub.status == ERROR or sub.status == DONE", True),
        ("not (sub.status != ERROR)", True),  # said another way: the check is by its terms
    ],
)
def test_w306_when_the_guard_does_not_require_the_subordinates_error(
    tmp_path: Path, guard: str, warned: bool
) -> None:
    top = PASSING_TOP.replace("when: sub.status == ERROR", f"when: {guard}")
    for name, text in (("sub", PASSING_SUB), ("top", top), ("system", PASSING_SYSTEM)):
        (tmp_path / f"{name}.yaml").write_text(text, encoding="utf-8")
    found = compile_paths([tmp_path]).diagnostics.items
    assert not [d for d in found if d.code.startswith("E")], found
    w306 = [d for d in found if d.code == "W306"]
    assert bool(w306) == warned, [str(d) for d in found]
    if warned:
        assert (w306[0].span.line, w306[0].span.col) == (14, 40)
