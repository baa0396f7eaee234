"""A scenario checked against the system it runs (rcsgen/tools/scenario/check.py), before
anything starts: the errors a person reads when a scenario scripts an operator that is not
there, records results a task does not have or out of their range, serves or faults a device
the system does not declare, or sets what the system does not take. Each word for word, in
the unit tier: the shipped systems are compiled once, each scenario written beside them in a
scratch directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.tools.scenario.check import check_scenario

SPECS = Path(__file__).resolve().parent.parent / "specs"


@pytest.fixture(scope="module")
def systems() -> dict[str, IRSystem]:
    front = compile_paths([SPECS / "platoon", SPECS / "inspection", SPECS / "cell"])
    assert not front.diagnostics.errors
    return {s.name: s for s in front.systems}


def written(tmp_path: Path, system: IRSystem, text: str) -> Path:
    """`text` as a scenario in a scratch system folder: the system file beside it, the rest
    compiled once (the scratch directory holds no controller)."""
    folder = tmp_path / "scenarios"
    folder.mkdir(exist_ok=True)
    (tmp_path / "system.yaml").write_bytes((SPECS / system.name / "system.yaml").read_bytes())
    path = folder / "s.yaml"
    path.write_text(text)
    return path


def said(tmp_path: Path, system: IRSystem, body: str) -> list[tuple[str, str, str]]:
    # a scenario lives in its system's scenarios/
    path = written(tmp_path, system, "scenario: s\ntitle: A scenario\nmax_cycles: 20\n" + body)
    _, found = check_scenario(path, system)
    return [(d.code, d.message, d.hint) for d in found.errors]


LDR = "operator:\n  answers:\n    - {task: SPOT_REPORT, "
RESULTS_HINT = "give every result under `results:`, or name the `task:` it answers"


@pytest.mark.parametrize(
    ("body", "want"),
    [
        (
            LDR + "answer: ERROR, results: {post: 1.0}}\n",
            (
                "E911",
                "results given with ERROR: what the person records goes with DONE only",
                "write `answer: DONE`, or leave `results:` out",
            ),
        ),
        (
            LDR + "answer: DONE, results: {decision: HOLD, pots: 1.0}}\n",
            ("E911", "`pots` is not a result of SPOT_REPORT", "did you mean `post`?"),
        ),
        (
            LDR + "answer: DONE, results: {decision: HOLD}}\n",
            (
                "E911",
                "this answer DONE may answer SPOT_REPORT, which records decision, post: post "
                "not given",
                RESULTS_HINT,
            ),
        ),
        (
            "operator:\n  answers:\n    - {answer: DONE}\n",
            (
                "E911",
                "this answer DONE may answer SPOT_REPORT, which records decision, post: "
                "decision, post not given",
                RESULTS_HINT,
            ),
        ),
        (
            LDR + "answer: DONE, results: {decision: HOLD, post: 6000.0}}\n",
            (
                "E911",
                "result `post` of SPOT_REPORT is 6000.0: above its maximum 5000.0",
                "an answer out of its range is refused before it reaches the client",
            ),
        ),
        (
            "operator:\n  default: {answer: DONE}\n",
            (
                "E911",
                "the default answer DONE records no results, but `ldr.SPOT_REPORT` records "
                "decision, post",
                "script SPOT_REPORT in an entry of `answers:` with `results:`",
            ),
        ),
        (
            "operator:\n  answers:\n    - {operator: lrd, task: SPOT_REPORT, answer: DONE}\n",
            ("E285", "`lrd` is not an operator module of `platoon`", "did you mean `ldr`?"),
        ),
        (
            "devices: {plc: {}}\n",
            (
                "E426",
                "`platoon` declares no I/O: it has no device `plc`",
                "devices are declared under `io:` in system.yaml (docs/io.md)",
            ),
        ),
        (
            "events:\n  - cycle: 2\n    device: {name: plc, do: unplug}\n",
            (
                "E426",
                "`platoon` declares no I/O: it has no device `plc`",
                "devices are declared under `io:` in system.yaml (docs/io.md)",
            ),
        ),
    ],
)
def test_the_platoon_leader_scripted_wrongly(systems, tmp_path, body, want) -> None:
    assert said(tmp_path, systems["platoon"], body) == [want]


def test_a_result_in_range_is_taken(systems, tmp_path) -> None:
    body = LDR + "answer: DONE, results: {decision: BYPASS, post: 900.0}}\n"
    assert said(tmp_path, systems["platoon"], body) == []


def test_a_default_done_is_taken_when_an_entry_scripts_the_task_that_records_results(
    systems, tmp_path
) -> None:
    """The default answers what no entry of `answers:` does: here nothing that records
    results, so DONE without results is right (it was refused, with a hint a default cannot
    follow: `results:` and `task:` are not keys of a default)."""
    body = LDR + "answer: DONE, results: {decision: HOLD, post: 1.0}}\n  default: {answer: DONE}\n"
    assert said(tmp_path, systems["platoon"], body) == []


def test_a_setting_the_system_does_not_take(systems, tmp_path) -> None:
    found = said(tmp_path, systems["inspection"], "settings: {programme: x}\n")
    assert found == [("E424", "`inspection` has no setting `programme`", "did you mean `program`?")]
    found = said(tmp_path, systems["inspection"], "settings: {zzz: x}\n")
    assert found == [
        (
            "E424",
            "`inspection` has no setting `zzz`",
            "declared settings: `part`, `program`, `seed`",
        )
    ]


def test_an_operator_script_for_a_system_without_operators(systems, tmp_path) -> None:
    found = said(tmp_path, systems["cell"], "operator:\n  default: {answer: DONE}\n")
    assert found == [
        (
            "E285",
            "`cell` has no operator module for `operator:` to script",
            "an operator module is a `<mnemonic>.yaml` with `operator:` (docs/spec.md 15)",
        )
    ]


def test_a_scenario_without_max_cycles_runs_1000_cycles(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """The default max_cycles (docs/spec.md: 1000): an event at cycle 1000 happens, one at
    1001 is refused as never happening, and the checked scenario runs 1000 cycles."""
    cell = systems["cell"]
    run = "events:\n  - cycle: 1000\n    command: sup.RUN\n    with: {moves: 1}\n"
    path = written(tmp_path, cell, "scenario: s\ntitle: A scenario\n" + run)
    scenario, found = check_scenario(path, cell)
    assert not found.errors and scenario is not None and scenario.max_cycles == 1000
    path.write_text("scenario: s\ntitle: A scenario\n" + run.replace("1000", "1001"))
    _, found = check_scenario(path, cell)
    assert [(d.code, d.message) for d in found.errors] == [
        (
            "E412",
            "an event at cycle 1001 never happens: the run stops after max_cycles 1000",
        )
    ]


def test_a_scenario_the_schema_refuses_is_checked_no_further(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """A `max_cycles` that is not a number is the schema's one error: the checks against the
    system (which compare each event's cycle with it) do not run on such a document."""
    path = written(
        tmp_path,
        systems["cell"],
        "scenario: s\ntitle: A scenario\nmax_cycles: many\n"
        "events:\n  - cycle: 3\n    command: sup.RUN\n    with: {moves: 1}\n",
    )
    scenario, found = check_scenario(path, systems["cell"])
    assert scenario is None
    assert [(d.code, d.span.line, d.span.col) for d in found.errors] == [("S003", 3, 13)]


def test_a_scenario_that_stops_on_a_module_and_expects_nothing_expects_it_done(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """Without `expect:`, a run that stops on a module expects that module DONE (at the
    stop_when_done line); one that stops on nothing expects nothing."""
    stops = "scenario: s\ntitle: A scenario\nstop_when_done: sup\n"
    scenario, _ = check_scenario(written(tmp_path, systems["cell"], stops), systems["cell"])
    assert scenario is not None
    assert [(e.what, e.value, e.span.line) for e in scenario.expect] == [("status", "DONE", 3)]
    runs = "scenario: s\ntitle: A scenario\n"
    scenario, _ = check_scenario(written(tmp_path, systems["cell"], runs), systems["cell"])
    assert scenario is not None and scenario.expect == []
    # how long the run takes (docs/spec.md's `cycles: {max: 300}`): bounds, no value
    bounded = stops + "expect:\n  status: DONE\n  cycles: {max: 300}\n"
    scenario, _ = check_scenario(written(tmp_path, systems["cell"], bounded), systems["cell"])
    assert scenario is not None
    assert [(e.what, e.value, e.low, e.high, e.span[1:]) for e in scenario.expect] == [
        ("status", "DONE", None, None, (5, 11)),  # at the value: where E416 says it unmet
        ("cycles", None, None, 300, (6, 11)),
    ]


def test_a_console_answer_without_a_status_answers_done(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """An event's `answer:` names the request; its status defaults to DONE (as `rcsgen ctl
    answer` does), its reason to none."""
    inspection = systems["inspection"]
    text = "scenario: s\ntitle: A scenario\nevents:\n  - cycle: 12\n    answer: {request: op/fx}\n"
    scenario, found = check_scenario(written(tmp_path, inspection, text), inspection)
    assert not found.errors and scenario is not None
    assert [e.answer for e in scenario.events] == [("op/fx", "DONE", "")]


def test_a_range_expected_of_a_figure_that_holds_no_number_says_what_to_expect(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """E415 names the figure's kind and what it takes instead of a range: an enum and a str
    one value, a bool true or false."""
    inspection = systems["inspection"]
    body = "expect:\n  figures: {cmm_op: {min: 1}, pdm_request: {max: 2}, pdm_online: {min: 0}}\n"
    assert [m for _, m, _ in said(tmp_path, inspection, body)] == [
        "`cmm_op` is an enum: expect one value, not a range",
        "`pdm_request` is a str: expect one value, not a range",
        "`pdm_online` is a bool: expect true or false, not a range",
    ]


def test_an_operator_script_is_refused_where_its_key_and_its_default_are_written(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """The errors of the script are located at what they are about: `operator:` for a
    system with no operator module, the `default:` for a default DONE that records no
    results, an entry's `results:` for results given with ERROR (not the top of the file
    nor the entry)."""
    head = "scenario: s\ntitle: A scenario\nmax_cycles: 20\n"
    cell = systems["cell"]
    path = written(tmp_path, cell, head + "operator:\n  default: {answer: DONE}\n")
    _, found = check_scenario(path, cell)
    assert [(d.code, d.span.line, d.span.col) for d in found.errors] == [("E285", 5, 3)]
    platoon = systems["platoon"]
    path = written(tmp_path, platoon, head + "operator:\n  default: {answer: DONE}\n")
    _, found = check_scenario(path, platoon)
    assert [(d.code, d.span.line, d.span.col) for d in found.errors] == [("E911", 5, 12)]
    # results with ERROR: at the results given
    path = written(tmp_path, platoon, head + LDR + "answer: ERROR, results: {post: 1.0}}\n")
    _, found = check_scenario(path, platoon)
    assert [(d.code, d.span.line, d.span.col) for d in found.errors] == [("E911", 6, 51)]


def test_what_the_checks_approved_of_the_script_and_the_answers_is_what_runs(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """A scripted answer keeps the results it records and its delay in cycles of its
    operator module's process (not another process's); a console answer DONE to a channel
    whose tasks record results is checked against the task open when it runs, not refused
    here for the results it does not give."""
    import dataclasses

    platoon = systems["platoon"]
    # the operator's process (command) twice as fast as the vehicles' (pa, pb)
    processes = tuple(
        dataclasses.replace(p, cycle_period=0.5 if "ldr" in p.modules else 1.0)
        for p in platoon.processes
    )
    faster = dataclasses.replace(platoon, processes=processes)
    text = (
        "scenario: s\ntitle: A scenario\nmax_cycles: 20\n"
        "operator:\n  answers:\n    - {task: SPOT_REPORT, answer: DONE, after: 2 s, "
        "results: {decision: HOLD, post: 2.0}}\n"
        "events:\n  - cycle: 3\n    answer: {request: ldr/pl}\n"
    )
    scenario, found = check_scenario(written(tmp_path, faster, text), faster)
    assert not found.errors and scenario is not None and scenario.operator is not None
    [answer] = scenario.operator.answers
    assert answer.after == 4 and answer.results == (("decision", "HOLD"), ("post", 2.0))
    [event] = scenario.events
    assert event.answer == ("ldr/pl", "DONE", "") and event.answer_results == {}


def test_a_report_that_phases_an_operator_module_names_its_clients(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """An operator module answers its clients' tasks and runs no command of its own: the
    phases of a run are a client's."""
    assert said(tmp_path, systems["inspection"], "report:\n  phases: op\n") == [
        (
            "E285",
            "`op` is an operator module: it has no phases of its own: name a client",
            "its clients: fx, tl",
        )
    ]
