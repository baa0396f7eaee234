"""A scenario's events, scripted answers and stand-ins checked before the run starts
(rcsgen/tools/scenario/check.py), word for word, in the unit tier: a reply to a channel that
is not there or with a reason the module cannot give, a release of a field nothing forced, a
forced value of the wrong type, an answer's reason or result its task does not declare, and
a controller simulated where no stand-in runs (or a module its stand-in replaces)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from test_scenario_checks import SPECS, said

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem


@pytest.fixture(scope="module")
def systems() -> dict[str, IRSystem]:
    front = compile_paths([SPECS / "platoon", SPECS / "miner"])
    assert not front.diagnostics.errors
    return {s.name: s for s in front.systems}


EVENT = "events:\n  - cycle: 3\n    "
ANSWER = "operator:\n  answers:\n    - {task: "


@pytest.mark.parametrize(
    ("body", "want"),
    [
        (
            EVENT + "reply: {ldr/px: DONE}\n",
            (
                "E289",
                "reply to `ldr/px`: not a channel of an operator module of `platoon`",
                "did you mean `ldr/pl`?",
            ),
        ),
        (
            EVENT + "reply: {zzz/qq: DONE}\n",
            (
                "E289",
                "reply to `zzz/qq`: not a channel of an operator module of `platoon`",
                "declared channels: `ldr/pl`",
            ),
        ),
        (
            EVENT + "reply: {alpha: ERROR(BLOCKED)}\n",
            (
                "E408",
                "`BLOCKED` is not a reason `alpha` can give",
                "declared reasons of alpha: `IMMOBILE`, `LOST`, `NONE`, `SENSOR_FAULT`",
            ),
        ),
        (
            EVENT + "unforce: [alpha_x]\n",
            (
                "E425",
                "`alpha_x` is not forced here: no earlier event forces it",
                "force it with an earlier event's `force:`, or remove the `unforce:`",
            ),
        ),
        (
            EVENT + "force: {enemy_present: 3}\n",
            (
                "E408",
                "forced world field `enemy_present` is a bool: give true or false, not `3`",
                "",
            ),
        ),
        (
            EVENT + "force: {enemy_present: yes}\n",
            (
                "E408",
                "forced world field `enemy_present` is a bool: give true or false, not `yes`",
                "`yes` is a string in YAML 1.2; write true or false",
            ),
        ),
        (
            EVENT + "force: {enemy_presnt: true}\n",
            (
                "E409",
                "field `enemy_presnt` is not a world field of `platoon`",
                "did you mean `enemy_present`?",
            ),
        ),
        (
            ANSWER + "SPOT_REPORT, answer: ERROR, reason: BLOCKED}\n",
            # a task with no reasons: where to declare one, not an empty list of them
            (
                "E288",
                "`BLOCKED` is not a reason of SPOT_REPORT",
                "declare it under the task's `reasons:`",
            ),
        ),
        (
            ANSWER + "SPOT_REPORT, answer: DONE, results: {decision: HOLD, post: 2.0, extra: 1}}\n",
            (
                "E911",
                "`extra` is not a result of SPOT_REPORT",
                "declared results: `decision`, `post`",
            ),
        ),
        (
            EVENT + "answer: {request: ldr/pl, status: ERROR, results: {post: 1.0}}\n",
            (
                "E911",
                "results given with ERROR: what the person records goes with DONE only",
                "write `answer: DONE`, or leave `results:` out",
            ),
        ),
    ],
)
def test_platoon_events_and_answers(
    tmp_path: Path, systems: dict[str, IRSystem], body: str, want: tuple[str, str, str]
) -> None:
    assert said(tmp_path, systems["platoon"], body) == [want]


def test_a_valid_reply_with_a_reason_the_module_gives_passes(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    assert said(tmp_path, systems["platoon"], EVENT + "reply: {alpha: ERROR(IMMOBILE)}\n") == []


def test_simulated_controllers_and_the_modules_their_stand_ins_replace(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    miner = systems["miner"]
    assert said(tmp_path, miner, "process: pc1\nsimulate: [cr, nope, pp]\n") == [
        (
            "E405",
            "simulated controller `nope` is not a controller of `miner`",
            "declared controllers: `bas`, `bm`, `bss`, `cc`, `cd`, `co`, `cr`, `css` and 18 more",
        ),
        (
            "E411",
            "`pp` cannot be simulated in this scenario: system.yaml declares no stand-in for it",
            "process `pc1` can simulate `cr`",
        ),
    ]
    assert said(tmp_path, miner, "process: pc2\nsimulate: [cr]\n")[0][:2] == (
        "E411",
        "`cr` cannot be simulated in this scenario: process `pc2` does not run it",
    )
    command = "process: pc1\nsimulate: [cr]\n" + EVENT + "command: gh.HALT\n"
    [(code, message, hint)] = said(tmp_path, miner, command)
    assert (code, message) == (
        "E414",
        "command to module `gh` does not run in this scenario: `cr` is simulated, so its "
        "stand-in replaces `gh`",
    )
    assert hint.startswith("modules that run: sec, sb, co, cc, bm, cd, sj, cr, vg, tc, oi, ")
    assert " gh" not in hint and " cv" not in hint  # cr_sim stands in for cr, gh, cv and ct


@pytest.fixture(scope="module")
def submarine() -> IRSystem:
    [system] = compile_paths([SPECS / "submarine"]).systems
    return system


def test_a_string_field_set_or_forced_with_what_it_cannot_hold(
    tmp_path: Path, submarine: IRSystem
) -> None:
    too_long = "events:\n  - cycle: 3\n    set: {announcement: " + "x" * 49 + "}\n"
    assert said(tmp_path, submarine, too_long) == [
        (
            "E408",
            "world field `announcement` is a string of at most 48 bytes: "
            "'xxxxxxxxxxxxxxxxxxxx'... is 49 bytes: more than the 48 it holds",
            "",
        )
    ]
    assert said(tmp_path, submarine, EVENT + "force: {announcement: 7}\n") == [
        (
            "E408",
            "forced world field `announcement` is a string of at most 48 bytes: 7 is not a string",
            "",
        )
    ]
    fits = "events:\n  - cycle: 3\n    set: {announcement: " + "x" * 48 + "}\n"
    assert said(tmp_path, submarine, fits) == []


def test_a_wrong_value_is_quoted_whole_up_to_30_characters(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    said_of = {}
    for value in ("a" * 30, "b" * 31):
        [(_, message, _)] = said(
            tmp_path, systems["platoon"], EVENT + f"force: {{enemy_present: {value}}}\n"
        )
        said_of[len(value)] = message.removeprefix("forced world field `enemy_present` is a bool: ")
    assert said_of == {
        30: f"give true or false, not `{'a' * 30}`",
        31: f"give true or false, not `{'b' * 27}...`",
    }


def test_ground_truth_its_simulators_write_may_be_forced(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """The world itself (`ground_truth`) is forced where only simulators write it (tas writes
    true_x): what a test of a sensor's failure does. (A controller writing it for real is
    refused by E280 when the system compiles, so E425's other half is never reached here.)"""
    body = EVENT + "force: {true_x: 3.5}\n  - cycle: 5\n    unforce: [true_x]\n"
    assert said(tmp_path, systems["miner"], body) == []


def test_e411_names_every_controller_the_process_can_simulate_or_none(
    tmp_path: Path, systems: dict[str, IRSystem]
) -> None:
    """E411's hint lists the process's stand-ins in order, `none` where it has none."""
    assert said(tmp_path, systems["platoon"], "process: pa\nsimulate: [alpha]\n") == [
        (
            "E411",
            "`alpha` cannot be simulated in this scenario: system.yaml declares no stand-in for it",
            "process `pa` can simulate none",
        )
    ]
    miner = systems["miner"]
    pc1 = next(p for p in miner.processes if p.name == "pc1")
    two = replace(pc1, stand_ins=pc1.stand_ins | {"bm": ("bm_sim", ("bm",))})
    processes = tuple(two if p is pc1 else p for p in miner.processes)
    assert said(
        tmp_path, replace(miner, processes=processes), "process: pc1\nsimulate: [pp]\n"
    ) == [
        (
            "E411",
            "`pp` cannot be simulated in this scenario: system.yaml declares no stand-in for it",
            "process `pc1` can simulate `bm`, `cr`",
        )
    ]


def test_an_answer_for_any_task_checks_each_result_against_the_task_that_records_it(
    tmp_path: Path, submarine: IRSystem
) -> None:
    """An answer that names no task may answer any: `choice` is checked against the one
    task that records it (the OOD's DEPTH_CASUALTY), past the EOOW's tasks that record none."""
    body = "operator:\n  answers:\n    - {answer: DONE, results: {choice: FLY}}\n"
    assert said(tmp_path, submarine, body) == [
        (
            "E408",
            "result `choice` is an enum: give one of PLANES, MBT_BLOW, not `FLY`",
            "declared values: `MBT_BLOW`, `PLANES`",
        )
    ]
