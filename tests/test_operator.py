"""Operator modules (docs/spec.md section 17, docs/semantics.md section 21): the generated
operator module against an independent model of its documented cycle (random commands,
answers, stale answers and withdrawals on two channels), a client's view of its channel,
the scripted person of a scenario, and the console's answer checks."""

from __future__ import annotations

import importlib
import json
import random
import shutil
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import rcsgen

from rcsgen.runtime.ctl import channel_requests, write_answer
from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import OperatorScript, ScriptedAnswer, load_scenario, run

DESK = Path(__file__).resolve().parent / "cases" / "valid" / "operator-module"
STATUS = ("NOT_READY", "EXECUTING", "DONE", "ERROR")


@pytest.fixture
def desk():
    with Harness.build(DESK) as harness:
        yield harness


# ---------------------------------------------------------------- an independent model


@dataclass
class Channel:
    """What docs/semantics.md section 21 says a channel's status is: the oracle."""

    number: int = 0  # status_num
    status: str = "NOT_READY"
    reason: int = 0
    asking: bool = False

    def cycle(self, command: tuple[int, str], answer: tuple[int, str, int]) -> None:
        number, task = command
        if number != self.number:
            self.number, self.reason = number, 0
            self.asking = task not in ("INIT", "HALT")
            self.status = "EXECUTING" if self.asking else "DONE"
        answered, status, reason = answer
        if self.asking and answered == self.number and status in ("DONE", "ERROR"):
            self.status, self.asking = status, False
            self.reason = reason if status == "ERROR" else 0


def test_the_operator_module_does_what_its_semantics_say(desk):
    """500 random steps on both channels: a client sends a task or a withdrawal, an answer
    is written to the current command or a stale one, or the module runs a cycle; after
    every cycle each channel's status buffer equals the model's."""
    layout, buf = desk.layout, desk.buf
    tasks = list(layout.COMMAND_NAMES["op/fx"][1:])
    assert tasks == ["INIT", "HALT", "PLACE_PART", "LOAD_PROBE"]
    chooser = random.Random(14)
    model = {channel: Channel() for channel in layout.OPERATORS["op"]}
    commands = dict.fromkeys(model, (0, "NONE"))
    answers = dict.fromkeys(model, (0, "NOT_READY", 0))
    seen = set()
    for _ in range(500):
        channel = chooser.choice(list(model))
        step = chooser.choice(["command", "answer", "stale", "cycle", "cycle"])
        if step == "command":
            task = chooser.choice(tasks)
            commands[channel] = (desk.command(channel, task, **_args(task)), task)
        elif step in ("answer", "stale"):
            number = max(0, commands[channel][0] - (1 if step == "stale" else 0))
            status = chooser.choice(["DONE", "ERROR"])
            reason = chooser.choice([0, 2, 3]) if status == "ERROR" else 0
            layout.ANSWERS[channel].write(
                buf, command_num=number, status=STATUS.index(status), reason=reason
            )
            answers[channel] = (number, status, reason)
        else:
            desk.step("op")
            for name, expected in model.items():
                expected.cycle(commands[name], answers[name])
                got = desk.status(name)
                state = "ASKING" if expected.asking else "NOP"
                assert (got.number, got.status, got.error_num, got.state) == (
                    expected.number,
                    expected.status,
                    expected.reason,
                    state,
                ), name
                seen.add((expected.status, state))
    assert {("EXECUTING", "ASKING"), ("DONE", "NOP"), ("ERROR", "NOP")} <= seen


def _args(task: str) -> dict[str, int]:
    return {"probe": 3} if task == "LOAD_PROBE" else {}


def test_a_client_writes_only_its_own_channel(desk):
    """fx sends op.PLACE_PART into op/fx's command buffer; op/tl's is untouched, and fx
    reads op/fx's status as any subordinate's: EXECUTING until answered."""
    before = desk.sent("op/tl")
    desk.command("fx", "PLACE")
    desk.step("fx")
    sent = desk.sent("op/fx")
    assert sent.command == "PLACE_PART"
    assert desk.sent("op/tl") == before
    desk.step("op")
    request = next(r for r in channel_requests(desk.layout, desk.buf) if r["name"] == "op/fx")
    assert (request["by"], request["task"], request["number"]) == ("fx", "PLACE_PART", sent.number)
    write_answer(desk.layout, desk.buf, request, "ERROR", "REFUSED")
    assert not any(r["name"] == "op/fx" for r in channel_requests(desk.layout, desk.buf))
    desk.step("op")
    desk.step("fx")
    assert desk.status("fx").status == "ERROR"
    fx = importlib.import_module(f"{desk.package.__name__}.fx")
    assert desk.controller("fx").error_num == fx.REASON_REFUSED


def test_an_answer_must_be_one_the_task_can_give(desk):
    desk.command("tl", "LOAD", probe=7)
    desk.step("tl")
    desk.step("op")
    request = next(r for r in channel_requests(desk.layout, desk.buf) if r["name"] == "op/tl")
    assert request["doc"] == "Load probe 7 into the probe head, then answer."
    assert request["reasons"] == ["REFUSED", "NO_SUCH_PROBE"]
    with pytest.raises(ValueError, match="a reason goes with ERROR only"):
        write_answer(desk.layout, desk.buf, request, "DONE", "REFUSED")
    with pytest.raises(ValueError, match="did you mean 'NO_SUCH_PROBE'"):
        write_answer(desk.layout, desk.buf, request, "ERROR", "NO_SUCH_PROB")
    with pytest.raises(ValueError, match="DONE or ERROR"):
        write_answer(desk.layout, desk.buf, request, "EXECUTING")
    assert any(r["name"] == "op/tl" for r in channel_requests(desk.layout, desk.buf))


# ---------------------------------------------------------------- the scripted person


def played(script: OperatorScript | None) -> list[dict]:
    scenario = load_scenario(DESK / "scenarios" / "go.yaml")
    scenario.operator = script
    with Harness.build(DESK, send_init=True) as harness:
        result = run(scenario, harness)
    return [json.loads(line) for line in result.trace]


def answered_at(lines: list[dict], channel: str, status: str) -> int | None:
    return next(
        (
            line["cycle"]
            for line in lines
            if line["modules"][channel]["status"] == status
            and line["modules"][channel]["command"] not in ("INIT", "HALT")
        ),
        None,
    )


def test_the_scripted_person_serves_requests_in_turn():
    """fx and tl ask in the same cycle; one person takes fx's up first (channel order),
    answers it 4 cycles later, then takes up tl's: its 4 cycles start only then."""
    lines = played(OperatorScript(default=ScriptedAnswer(after=4, answer="DONE")))
    asked = next(line["cycle"] for line in lines if line["modules"]["op/fx"]["state"] == "ASKING")
    assert lines[asked - 1]["modules"]["op/tl"]["state"] == "ASKING", "asked together"
    fx, tl = answered_at(lines, "op/fx", "DONE"), answered_at(lines, "op/tl", "DONE")
    assert fx == asked + 1 + 4
    assert tl == fx + 4


def test_the_scripted_person_matches_by_task_and_client_and_can_refuse():
    refuse = ScriptedAnswer(after=0, answer="ERROR", reason="NO_SUCH_PROBE", client="tl")
    never = ScriptedAnswer(after=0, answer="never", task="PLACE_PART")
    lines = played(OperatorScript((never, refuse), ScriptedAnswer(after=0, answer="DONE")))
    assert answered_at(lines, "op/fx", "DONE") is None, "PLACE_PART is left to the console"
    refused = answered_at(lines, "op/tl", "ERROR")
    assert refused is not None
    assert lines[refused]["modules"]["tl"]["status"] == "ERROR"
    assert lines[-1]["modules"]["op/fx"]["state"] == "ASKING"


def test_without_a_script_nobody_answers():
    lines = played(None)
    assert answered_at(lines, "op/fx", "DONE") is None
    assert answered_at(lines, "op/tl", "ERROR") is None


# ---------------------------------------------------------------- located errors


def test_an_operator_file_with_a_table_is_refused_where_it_is_written(tmp_path):
    copy = tmp_path / "desk"
    shutil.copytree(DESK, copy)
    op = copy / "op.yaml"
    op.write_text(op.read_text() + "    states: {S0: [{do: [report: DONE]}]}\n")
    result = rcsgen("validate", str(copy))
    assert result.exit_code == 1
    errors = [line for line in result.output.splitlines() if "error[" in line]
    assert errors and all(line.startswith(f"{op}:") or "op.yaml:" in line for line in errors)
    assert "states" in result.output and "Traceback" not in result.output


def test_the_inspection_operator_names_its_schema_for_editors_and_passes_it():
    from rcsgen.compiler.front_end.loader import load_text
    from rcsgen.compiler.front_end.schema import check_document

    path = Path(__file__).resolve().parent.parent / "specs" / "inspection" / "op.yaml"
    text = path.read_text(encoding="utf-8")
    target = (path.parent / text.splitlines()[0].split("$schema=", 1)[1]).resolve()
    assert target.name == "operator.schema.json" and target.is_file()
    assert check_document(load_text(text, path.name), "operator", path.name) == []
