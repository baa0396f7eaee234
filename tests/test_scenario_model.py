"""What a scenario's `expect:` means and how a failure says it, on values, in process: the
bounds are inclusive, a bool is no number, and a figure names a world field, a module's
reason or one of its results (`<module>.result.<name>`); which answer the scripted person
gives; a checked scenario's parts are values no run can change."""

from __future__ import annotations

import dataclasses

import pytest

from rcsgen.compiler.diagnostics import Span
from rcsgen.tools.harness import Status
from rcsgen.tools.scenario.model import (
    DeviceFault,
    Expected,
    OperatorScript,
    ScriptedAnswer,
    SoftPlc,
)
from rcsgen.tools.scenario.run import final_value

AT = Span("s.yaml", 3, 5)


@pytest.mark.parametrize(
    ("expected", "wanted"),
    [
        (Expected("depth", AT, low=1.0), "at least 1"),
        (Expected("depth", AT, high=2.5), "at most 2.5"),
        (Expected("depth", AT, low=1.0, high=2.5), "between 1 and 2.5"),
        (Expected("done", AT, value=True), "true"),
        (Expected("status", AT, value="DONE"), "DONE"),
        (Expected("cycles", AT, value=12), "12"),
    ],
)
def test_a_failure_says_what_was_wanted(expected: Expected, wanted: str) -> None:
    assert expected.wanted() == wanted


def test_bounds_are_inclusive_and_a_bool_is_no_number() -> None:
    between = Expected("depth", AT, low=1.0, high=2.5)
    assert [between.met(v) for v in (0.99, 1, 1.0, 2.5, 2.51)] == [False, True, True, True, False]
    assert not between.met(True) and not between.met("2")
    assert Expected("depth", AT, low=1.0).met(1e9) and not Expected("depth", AT, high=1.0).met(2)
    assert Expected("done", AT, value=True).met(True)
    assert not Expected("done", AT, value=True).met(1)
    assert Expected("status", AT, value="DONE").met("DONE")
    assert not Expected("status", AT, value="DONE").met("ERROR")


def test_an_exact_number_is_met_by_that_number_only() -> None:
    twelve = Expected("cycles", AT, value=12)
    assert twelve.met(12) and twelve.met(12.0)
    assert not any(twelve.met(v) for v in (13, 11.5, "12", None))


def test_a_figure_names_a_world_field_a_reason_or_a_result() -> None:
    world = {"depth": 1.5}
    statuses = {
        "helm": Status("DONE", 3, "NOP", 0, reason="NONE", results={"at_goal": True}),
        "cc": Status("ERROR", 2, "NOP", 1, reason="BLOCKED"),
    }
    assert final_value("depth", world, statuses) == 1.5
    assert final_value("helm.result.at_goal", world, statuses) is True
    assert final_value("cc.reason", world, statuses) == "BLOCKED"
    assert final_value("helm.reason", world, statuses) == "NONE"
    # what the run does not have is None, never another value
    assert final_value("speed", world, statuses) is None
    assert final_value("cc.result.at_goal", world, statuses) is None
    assert final_value("sm.result.at_goal", world, statuses) is None


def test_the_scripted_person_answers_by_the_first_answer_that_matches_else_the_default() -> None:
    by_task = ScriptedAnswer(2, "DONE", task="SPOT_REPORT")
    by_client = ScriptedAnswer(1, "ERROR", "BLOCKED", client="pa")
    refuses = ScriptedAnswer(0, "never", operator="ldr", task="HALT_ALL")
    default = ScriptedAnswer(5, "DONE")
    script = OperatorScript((refuses, by_task, by_client), default)

    def request(operator: str, task: str, by: str) -> dict[str, str]:
        return {"operator": operator, "task": task, "by": by}

    assert script.how(request("ldr", "SPOT_REPORT", "pa")) is by_task  # the first that matches
    assert script.how(request("ldr", "MOVE", "pa")) is by_client
    assert script.how(request("ldr", "MOVE", "pb")) is default
    assert script.how(request("ldr", "HALT_ALL", "pa")) is None  # `never`: the console answers
    assert script.how(request("sgt", "HALT_ALL", "pa")) is by_client  # another operator's
    assert OperatorScript((by_task,)).how(request("ldr", "MOVE", "pa")) is None  # no default
    assert OperatorScript((), ScriptedAnswer(0, "never")).how(request("a", "b", "c")) is None
    # a scenario's runs share its script: an answer is a value no run can change
    with pytest.raises(dataclasses.FrozenInstanceError):
        by_task.after = 0  # type: ignore[misc]
    assert len({by_task, ScriptedAnswer(2, "DONE", task="SPOT_REPORT")}) == 1
    everything = ScriptedAnswer(0, "DONE", operator="ldr", task="MOVE", client="pa")
    assert everything.matches(request("ldr", "MOVE", "pa"))
    for other in (
        request("x", "MOVE", "pa"),
        request("ldr", "X", "pa"),
        request("ldr", "MOVE", "x"),
    ):
        assert not everything.matches(other)


def test_a_checked_scenarios_parts_are_values_no_run_can_change() -> None:
    """What the checks approved is what runs: an expectation, a scripted answer, the script,
    a device fault and a served device refuse a change, and are values (equal when equal,
    usable as keys)."""
    parts = [
        Expected("depth", AT, low=1.0),
        ScriptedAnswer(2, "DONE", task="SPOT_REPORT"),
        OperatorScript((ScriptedAnswer(2, "DONE"),)),
        DeviceFault("plc", "unplug", AT),
        SoftPlc("plc", None, AT),
    ]
    for part in parts:
        name = dataclasses.fields(part)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(part, name, getattr(part, name))
        assert part == dataclasses.replace(part) and len({part, dataclasses.replace(part)}) == 1
