"""The inspection workstation's scenarios, asserted directly (specs/inspection; the golden
comparison is in test_golden.py): each scenario's defining behaviour, so a wrong golden file
cannot hide a wrong workstation; the inspection-program and part readers' errors; and the
inspector at the console answering and refusing requests of the running system."""

from __future__ import annotations

import dataclasses
import importlib
import json
import shutil
from pathlib import Path

import pytest
import yaml
from conftest import edit, rcsgen
from support.golden_runs import golden_run
from support.workarounds import count, table

from rcsgen.tools.harness import import_package
from rcsgen.tools.scenario import Scenario, load_scenario, open_harness, run

ROOT = Path(__file__).resolve().parent.parent
SYSTEM = ROOT / "specs" / "inspection"
PACKAGE = ROOT / "generated" / "inspection"


def operator_timeout(controller: str) -> int:
    """The cycles `controller`'s commands wait for the operator: the `after:` duration of
    the fragment they all use (fragments.yaml), in seconds, over the system's cycle period."""
    spec = yaml.safe_load((SYSTEM / f"{controller}.yaml").read_text(encoding="utf-8"))
    shared = yaml.safe_load((SYSTEM / "fragments.yaml").read_text(encoding="utf-8"))
    system = yaml.safe_load((SYSTEM / "system.yaml").read_text(encoding="utf-8"))
    asking = [c for c in spec["commands"].values() if "use" in c["states"]["S0"]]
    assert {c["states"]["S0"]["use"] for c in asking} == {"ask_operator"}
    fragment = shared["fragments"]["ask_operator"]
    waits = {r["after"] for rules in fragment["states"].values() for r in rules if "after" in r}
    assert len(waits) == 1, f"one operator time-out in {controller}: {waits}"
    seconds = waits.pop()
    assert seconds.endswith(" s"), seconds
    return round(float(seconds.removesuffix(" s")) / system["cycle_period"])


def play(scenario: Scenario) -> tuple[dict, list[dict]]:
    harness = open_harness(scenario, PACKAGE)
    try:
        result = run(scenario, harness)
    finally:
        harness.close()
    return result.final, [json.loads(line) for line in result.trace]


def played(name: str) -> tuple[dict, list[dict]]:
    """A scenario's run on the committed generated package: (final status, trace lines),
    as its golden trace records them (support/golden_runs.py says why that is the run)."""
    return golden_run("inspection", name)


# The workcell's CORBA job (its command JOB) by the native job it converts the request into
# (its result `job`, set in the cycle the job arrives): the workstation's command.
NATIVE = {"INIT_JOB": "INIT_FOR_INSPECT", "INSPECT_JOB": "INSPECT_PART"}


def command_of(entry: dict) -> str:
    """A module's command in a trace line; the workcell's JOB as the native job it is."""
    if entry["command"] == "JOB":
        return NATIVE.get(entry["result"]["job"], "JOB")
    return str(entry["command"])


def commands_sent(lines: list[dict], module: str) -> list[tuple[int, str]]:
    """Each new command `module` received, with its cycle (one per command number)."""
    seen, out = 0, []
    for line in lines:
        entry = line["modules"][module]
        if entry["command_num"] != seen:
            seen = entry["command_num"]
            out.append((line["cycle"], command_of(entry)))
    return out


def names(sent: list[tuple[int, str]]) -> list[str]:
    return [command for _, command in sent]


def first(lines: list[dict], module: str, command: str, status: str) -> int:
    """The first cycle `module` shows `command` with `status`."""
    return next(
        line["cycle"]
        for line in lines
        if command_of(line["modules"][module]) == command
        and line["modules"][module]["status"] == status
    )


def outcome(line: dict, module: str) -> tuple[str, str, dict]:
    """A module's status, reason and results in one trace line."""
    entry = line["modules"][module]
    return entry["status"], entry.get("reason"), entry.get("result", {})


def open_cycles(lines: list[dict], field: str) -> list[int]:
    return [line["cycle"] for line in lines if line["world"][field]]


def asking(lines: list[dict], channel: str, task: str) -> list[int]:
    """The cycles the operator module's `channel` (op/fx) shows `task` open on the screen."""
    return [
        line["cycle"]
        for line in lines
        if line["modules"][channel]["command"] == task
        and line["modules"][channel]["state"] == "ASKING"
    ]


def test_nominal_init_for_inspect_then_the_part_is_accepted():
    final, lines = played("nominal_inspection")
    assert final["status"] == "DONE"
    assert names(commands_sent(lines, "ws")) == ["INIT", "INIT_FOR_INSPECT", "INSPECT_PART"]
    # Figure 4: equipSetup to MS and FX together; calibrateCMM to MS once both are done;
    # MS has tooling calibrate the sphere, then the probe; then the camera.
    ms, fx = commands_sent(lines, "ms"), commands_sent(lines, "fx")
    setup = dict((c, cycle) for cycle, c in ms)["EQUIP_SETUP"]
    assert dict((c, cycle) for cycle, c in fx)["EQUIP_SETUP"] == setup, "sent in one cycle"
    calibrate = dict((c, cycle) for cycle, c in ms)["CALIBRATE_CMM"]
    assert calibrate > max(
        first(lines, "ms", "EQUIP_SETUP", "DONE"), first(lines, "fx", "EQUIP_SETUP", "DONE")
    )
    assert names(ms) == [
        "INIT", "EQUIP_SETUP", "CALIBRATE_CMM", "CALIBRATE_CAMERA", "LOAD_PROBE", "MEASURE_PART",
        "MEASURE_PART",
    ]  # fmt: skip
    assert names(commands_sent(lines, "tl")) == [
        "INIT", "CALIBRATE_SPHERE", "CALIBRATE_PROBE", "LOAD_PROBE"
    ]  # fmt: skip
    cmm = names(commands_sent(lines, "cmm"))
    assert cmm[:4] == ["INIT", "HOME", "CALIBRATE_PROBE", "CALIBRATE_CAMERA"]
    # Figure 39: place the part and load the probe, then one Inspect_feature per feature
    inspect = dict((c, cycle) for cycle, c in commands_sent(lines, "ws"))["INSPECT_PART"]
    assert first(lines, "ws", "INIT_FOR_INSPECT", "DONE") < inspect, "prepared before use"
    assert cmm[4:] == ["INSPECT_FEATURE"] * 5
    assert names(fx)[1:] == ["EQUIP_SETUP", "PLACE_PART", "REFIXTURE_PART", "UNLOAD_PART"]
    assert outcome(lines[-1], "ws") == ("DONE", "NONE", {"accepted": True})
    # every result slot of MS: the camera's scale is CALIBRATE_CAMERA's, 0 after it
    assert outcome(lines[-1], "ms") == ("DONE", "NONE", {"measured": 2, "failed": 0, "scale": 0.0})
    # the shop passes the verdict up; its lot counts stay 0 (no lot was ordered)
    assert final["results"] == {"accepted": True, "passed": 0, "rejected": 0, "scheduled": 0}
    assert final["reason"] == "NONE"
    # one person serves both: each task asked through its client's channel, answered DONE
    tasks = {
        "op/fx": ["MOUNT_FIXTURE_PLATE", "PLACE_PART", "RESEAT_PART", "UNLOAD_PART"],
        "op/tl": ["MOUNT_SPHERE", "ORIENT_PROBE", "LOAD_PROBE"],
    }
    for channel, asked in tasks.items():
        assert names(commands_sent(lines, channel)) == ["INIT", *asked]
        for task in asked:
            assert asking(lines, channel, task), f"{task} was never on the screen"
            assert first(lines, channel, task, "DONE") == asking(lines, channel, task)[-1] + 1
        assert lines[-1]["modules"][channel]["state"] == "NOP", "nothing left on the screen"


def test_the_workstation_plans_setups_and_fixturing_and_measuring_take_turns():
    """Section 5.3.2: WS's PL interprets the inspection plan into fixturing instructions and
    feature inspection schedules; section 5.3.1: a series of place/fixture_part for
    fixturing corresponding to the Inspect_features, the two coordinated. The bracket's
    plan is two setups (3 features, then 2): FX fixtures the part in a setup, MS measures
    that setup's schedule, never while FX is at work, then the next setup."""
    _, lines = played("nominal_inspection")
    inspect = first(lines, "ws", "INSPECT_PART", "EXECUTING")
    assert lines[inspect - 1]["modules"]["ws"]["plans"]["setups"]["steps"] == 2
    turns = sorted(
        (cycle, f"{module}.{command}")
        for module in ("fx", "ms")
        for cycle, command in commands_sent(lines, module)
        if cycle >= inspect
    )
    assert [what for _, what in turns] == [
        "fx.PLACE_PART", "ms.LOAD_PROBE", "ms.MEASURE_PART",
        "fx.REFIXTURE_PART", "ms.MEASURE_PART", "fx.UNLOAD_PART",
    ]  # fmt: skip
    schedules = [
        lines[cycle - 2]["modules"]["ms"]["result"]["measured"]
        for cycle, what in turns[3:]
        if what in ("fx.REFIXTURE_PART", "fx.UNLOAD_PART")
    ]
    assert schedules == [3, 2], "each setup's feature schedule, measured in full"
    for line in lines:
        ms, fx = line["modules"]["ms"], line["modules"]["fx"]
        if ms["command"] == "MEASURE_PART" and ms["status"] == "EXECUTING":
            assert fx["status"] != "EXECUTING", f"cycle {line['cycle']}: measured while fixturing"


def test_nominal_readings_are_within_the_programs_tolerances(monkeypatch):
    monkeypatch.syspath_prepend(str(SYSTEM))
    ms = importlib.import_module("inspection_hooks.ms")
    features = ms.read_program(SYSTEM / "programs" / "bracket.dmi")
    _, lines = played("nominal_inspection")
    readings = [  # what MS read in the cycle it judged a reading (PROBING -> NEXT)
        line["world"]["cmm_reading"]
        for line, after in zip(lines, lines[1:], strict=False)
        if after["modules"]["ms"]["state"] == "NEXT" and line["modules"]["ms"]["state"] == "PROBING"
    ]
    assert len(readings) == len(features) == 5
    for feature, reading in zip(features, readings, strict=True):
        assert feature.accepts(reading), (feature, reading)


def test_the_camera_is_calibrated_last_against_the_reference_sphere():
    """calibrate Camera, the final activity of initForInspect (Figure 4): the camera images
    the reference sphere; the scale it finds is the world's and MS's result, within the
    edge-finding noise of the true 0.0125 mm/pixel, and 0 until then."""
    _, lines = played("nominal_inspection")
    done = first(lines, "ms", "CALIBRATE_CAMERA", "DONE")
    scale = lines[done - 1]["world"]["camera_scale"]
    assert abs(scale - 0.0125) < 0.0125 * 1e-3  # 0.5 px of a 2000 px sphere: 0.025 %
    assert lines[done - 1]["modules"]["ms"]["result"]["scale"] == scale
    ordered = dict((c, cycle) for cycle, c in commands_sent(lines, "cmm"))["CALIBRATE_CAMERA"]
    assert {ln["world"]["camera_scale"] for ln in lines if ln["cycle"] <= ordered} == {0.0}
    assert done > first(lines, "ms", "CALIBRATE_CMM", "DONE"), "the camera comes last"
    assert first(lines, "ws", "INIT_FOR_INSPECT", "DONE") > done


def test_a_part_out_of_tolerance_is_refixtured_remeasured_and_rejected():
    final, lines = played("rejected_part")
    assert final["status"] == "DONE", "rejecting a part completes the inspection"
    fx = names(commands_sent(lines, "fx"))
    assert fx[-3:] == ["PLACE_PART", "REFIXTURE_PART", "UNLOAD_PART"]
    assert names(commands_sent(lines, "ms")).count("MEASURE_PART") == 2
    measures = [cycle for cycle, c in commands_sent(lines, "ms") if c == "MEASURE_PART"]
    refixture = next(cycle for cycle, c in commands_sent(lines, "fx") if c == "REFIXTURE_PART")
    assert measures[0] < refixture < measures[1], "re-seated between the two measurements"
    # the bore (feature 0, 12.000 +/- 0.020) reads oversize both times
    bores = [  # what MS read in the cycles it judged the schedule's first feature
        line["world"]["cmm_reading"]
        for line, after in zip(lines, lines[1:], strict=False)
        if line["modules"]["ms"]["state"] == "PROBING"
        and after["modules"]["ms"]["state"] == "NEXT"
        and after["modules"]["ms"]["result"]["measured"] == 1
    ]
    assert bores and all(reading > 12.02 for reading in bores)
    assert outcome(lines[-1], "ws") == ("DONE", "NONE", {"accepted": False})  # rejected
    # setup 1's schedule (the bore, its depth, the hole spacing); setup 2 never measured
    assert outcome(lines[-1], "ms")[2] == {"measured": 3, "failed": 1, "scale": 0.0}  # the bore
    # the first measurement found the bore out too, and MS said so with DONE
    first_done = first(lines, "ms", "MEASURE_PART", "DONE")
    assert outcome(lines[first_done - 1], "ms") == (
        "DONE", "NONE", {"measured": 3, "failed": 1, "scale": 0.0}
    )  # fmt: skip
    unloaded = next(cycle for cycle, c in commands_sent(lines, "fx") if c == "UNLOAD_PART")
    assert lines[unloaded - 1]["modules"]["ws"]["state"] == "UNLOADING", "rejected, then unloaded"


def test_a_slow_operator_times_out_and_both_requests_are_withdrawn():
    final, lines = played("slow_operator")
    assert final["status"] == "ERROR"
    timeout = operator_timeout("fx")
    asked = asking(lines, "op/fx", "PLACE_PART")
    assert len(asked) == timeout + 1, "on the screen from the ask through the time-out cycle"
    assert not any(
        line["modules"]["op/fx"]["command"] == "PLACE_PART"
        and line["modules"]["op/fx"]["status"] == "DONE"
        for line in lines
    ), "never answered"
    failed = first(lines, "fx", "PLACE_PART", "ERROR")
    assert failed == asked[-1] + 1
    assert lines[failed - 1]["modules"]["op/fx"]["command"] == "HALT", "withdrawn at once"
    # the workstation withdraws the probe loading asked at the same time (HALT to MS, TL)
    assert ("HALT" in names(commands_sent(lines, "ms"))) and (
        "HALT" in names(commands_sent(lines, "tl"))
    )
    assert outcome(lines[-1], "ws") == ("ERROR", "TIMED_OUT", {"accepted": False})
    assert outcome(lines[-1], "fx")[:2] == ("ERROR", "TIMED_OUT")  # passed up by name
    assert outcome(lines[-1], "ms")[:2] == ("DONE", "NONE"), "MS was halted, not failed"
    assert [lines[-1]["modules"][c]["state"] for c in ("op/fx", "op/tl")] == ["NOP", "NOP"]
    assert lines[-1]["modules"]["ws"]["status"] == "ERROR"


def with_delay(delay: int) -> Scenario:
    """slow_operator.yaml with the person taking `delay` cycles over the part and the
    probe instead."""
    slow = load_scenario(SYSTEM / "scenarios" / "slow_operator.yaml")
    assert slow.operator is not None
    answers = tuple(dataclasses.replace(a, after=delay) for a in slow.operator.answers)
    assert {a.task for a in answers} == {"PLACE_PART", "LOAD_PROBE"}
    script = dataclasses.replace(slow.operator, answers=answers)
    return dataclasses.replace(slow, operator=script, expect=[])


def test_a_patient_operator_is_waited_for():
    """The operator slow but within the time-out for both tasks asked together: nothing is
    withdrawn and the part is accepted (the time-out bounds the wait; it does not hurry)."""
    timeout = operator_timeout("fx")
    final, lines = play(with_delay(timeout // 2 - 5))
    assert final["status"] == "DONE"
    assert outcome(lines[-1], "ws") == ("DONE", "NONE", {"accepted": True})
    assert len(asking(lines, "op/fx", "PLACE_PART")) > timeout // 3, "it took a while"


def test_one_operator_serves_the_requests_in_turn():
    """Placing the part and loading the probe are asked in the same cycle of one person, who
    does one after the other: each task takes less than the time-out, but the second one
    asked waits for the first and times out (the time-out runs from the ask)."""
    timeout = operator_timeout("fx")
    final, lines = play(with_delay(timeout - 10))
    assert final["status"] == "ERROR"
    assert first(lines, "fx", "PLACE_PART", "DONE") < first(lines, "tl", "LOAD_PROBE", "ERROR")
    assert outcome(lines[-1], "tl")[:2] == ("ERROR", "TIMED_OUT")
    # tooling's time-out is passed up: MS's LOAD_PROBE, then WS, fail TIMED_OUT
    assert outcome(lines[-1], "ms")[:2] == ("ERROR", "TIMED_OUT")
    assert outcome(lines[-1], "ws")[:2] == ("ERROR", "TIMED_OUT")


def test_an_operator_who_refuses_stops_the_workstation_with_that_reason():
    final, lines = played("operator_refuses")
    assert final["status"] == "ERROR"
    refused = first(lines, "fx", "PLACE_PART", "ERROR")
    assert first(lines, "op/fx", "PLACE_PART", "ERROR") == refused - 1, "the person refused"
    tl = commands_sent(lines, "tl")
    assert tl[-2:][0][1] == "LOAD_PROBE" and tl[-1][1] == "HALT", "the probe loading withdrawn"
    assert tl[-1][0] == refused + 1, "in the cycle after the refusal reached the workstation"
    assert "MEASURE_PART" not in names(commands_sent(lines, "ms"))
    assert outcome(lines[-1], "ws") == ("ERROR", "REFUSED", {"accepted": False})
    assert outcome(lines[-1], "fx")[:2] == ("ERROR", "REFUSED")
    assert outcome(lines[refused], "ws")[0] == "EXECUTING", "it waits for MS to stop first"
    assert names(commands_sent(lines, "op/tl"))[-2:] == ["LOAD_PROBE", "HALT"], "withdrawn"
    assert lines[-1]["modules"]["op/tl"]["state"] == "NOP", "nothing left on the screen"


def test_the_inspector_answers_then_refuses_at_the_console():
    """console_refusal writes what `ctl answer` writes: the plate is mounted, the sphere
    calibration refused; initForInspect fails in calibrateCMM and goes no further."""
    final, lines = played("console_refusal")
    assert final["status"] == "ERROR"
    assert first(lines, "op/fx", "MOUNT_FIXTURE_PLATE", "DONE") == 12, "answered at cycle 12"
    assert first(lines, "op/tl", "MOUNT_SPHERE", "ERROR") == 30, "refused at cycle 30"
    assert first(lines, "fx", "EQUIP_SETUP", "DONE") < first(
        lines, "tl", "CALIBRATE_SPHERE", "ERROR"
    )
    assert names(commands_sent(lines, "ms"))[-1] == "CALIBRATE_CMM", "no camera calibration"
    assert first(lines, "ws", "INIT_FOR_INSPECT", "ERROR")
    assert outcome(lines[-1], "ws")[:2] == ("ERROR", "REFUSED")  # passed up from MS
    assert outcome(lines[-1], "ms")[:2] == ("ERROR", "REFUSED")  # passed up from TL
    assert outcome(lines[-1], "tl")[:2] == ("ERROR", "REFUSED")
    assert [lines[-1]["modules"][c]["state"] for c in ("op/fx", "op/tl")] == ["NOP", "NOP"]


def test_a_machine_fault_climbs_one_level_per_cycle():
    final, lines = played("machine_fault")
    assert final["status"] == "ERROR"
    alarm = open_cycles(lines, "cmm_alarm")[0]
    chain = (
        ("servo", "MOVE_TO"),
        ("prim", "GO_TO_POINT"),
        ("cmm", "INSPECT_FEATURE"),
        ("ms", "MEASURE_PART"),
        ("ws", "INSPECT_PART"),
    )
    errors = [first(lines, module, command, "ERROR") for module, command in chain]
    assert errors == [alarm + n for n in range(1, 6)], "servo, Prim, Emove, then MS, then WS"
    reasons = [outcome(lines[cycle - 1], m)[1] for cycle, (m, _) in zip(errors, chain, strict=True)]
    assert reasons == ["MACHINE_FAULT"] * 5, "each says why as it fails"
    motors = [[lines[c - 1]["world"][f"motor_{a}"] for a in "xyz"] for c in (alarm, alarm + 1)]
    assert any(motors[0]) and motors[1] == [0.0] * 3, "the moving axes stopped by the servo"
    status, _, results = outcome(lines[-1], "ms")
    assert status == "ERROR" and 0 < results["measured"] < 5
    assert outcome(lines[-1], "ws") == ("ERROR", "MACHINE_FAULT", {"accepted": False})


# ---------------------------------------------------------------- the readers' errors


@pytest.fixture
def hooks(monkeypatch):
    monkeypatch.syspath_prepend(str(SYSTEM))
    return importlib.import_module("inspection_hooks.ms"), importlib.import_module(
        "inspection_hooks.cmm"
    )


HEAD = "DMISMN/'p',05.0\nUNITS/MM\n"
BORE = "F(BORE)=FEAT/CIRCLE,12.0\nT(BORE)=TOL/DIAM,-0.1,0.1\n"
SETUP = "FIXTID/'SETUP 1',CLAMPS,2\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("UNITS/MM\n", "p.dmi:1: the program must begin with DMISMN, not UNITS"),
        (HEAD + "GOTO/1,2,3\n", "p.dmi:3: 'GOTO/1,2,3' is not a statement of the subset"),
        (HEAD + "UNITS/INCH\n", "p.dmi:3: lengths must be in MM, not INCH"),
        (HEAD + "F(BORE)=FEAT/CIRCLE,x\n", "p.dmi:3: 'F(BORE)=FEAT/CIRCLE,x' is not a"),
        (HEAD + "T(BORE)=TOL/DIAM,-0.1,0.1\n", "p.dmi:3: tolerance for `bore`, which no F"),
        (HEAD + BORE.replace("-0.1", "0.05"), "p.dmi:4: the band of `bore` must hold its"),
        (HEAD + BORE + "MEAS/CIRCLE,F(BORE)\n", "p.dmi:5: `bore` measured before any FIXTID"),
        (HEAD + SETUP + "MEAS/CIRCLE,F(BORE)\n", "p.dmi:4: `bore` measured with no F(...)"),
        (HEAD + "FIXTID/'SETUP 0',CLAMPS,2\n", "p.dmi:3: a setup is numbered from 1"),
        (
            HEAD + BORE + SETUP + "MEAS/CIRCLE,F(BORE)\n" * 2,
            "p.dmi:7: feature `bore` is measured twice",
        ),
        (
            HEAD + BORE + SETUP + "MEAS/CIRCLE,F(BORE)\n",
            "p.dmi: the inspection program has no ENDFIL",
        ),
        (HEAD + "ENDFIL\nUNITS/MM\n", "p.dmi:4: UNITS after ENDFIL"),
        (HEAD + "$$ nothing\nENDFIL\n", "p.dmi: the inspection program measures no feature"),
    ],
)
def test_a_bad_program_line_is_named(hooks, tmp_path, text, message):
    """The planners' DMIS interpreter (inspection_hooks/dmis.py) refuses what it cannot
    read, naming file:line and what is wrong."""
    ms, _ = hooks
    program = tmp_path / "p.dmi"
    program.write_text(text)
    with pytest.raises(ms.ProgramError) as raised:
        ms.read_program(program)
    assert str(raised.value).startswith(f"{tmp_path}/{message}"), str(raised.value)


def test_the_task_level_planners_interpret_the_dmis_program(hooks):
    """Section 5.3.2: MS's and FX's PLs interpret the DMIS program. MS's planner makes a
    MEASURE_PART's schedule one step per feature with its band (nominal + T's limits); FX's
    makes the fixturing of a setup from its FIXTID (the clamps the operator is told)."""
    ms, _ = hooks
    fx = importlib.import_module("inspection_hooks.fx")
    program = ms.new_program({})
    slot, flange = (3, 5.97, 6.03), (4, 4.46, 4.54)
    assert ms.feature_schedule(program, "bracket", 3, 2) == [
        pytest.approx(slot),
        pytest.approx(flange),
    ]
    assert ms.feature_schedule(program, "bracket", 4, 9) == [pytest.approx(flange)]
    assert fx.fixturing("bracket", 1) == [(1, 2)] and fx.fixturing("bracket", 2) == [(2, 3)]
    with pytest.raises(ms.ProgramError, match=r"bracket.dmi has no FIXTID/'SETUP 3'"):
        fx.fixturing("bracket", 3)


def test_the_workstation_plan_is_a_step_per_run_of_one_setup(hooks, tmp_path, monkeypatch):
    """inspection_hooks.ws.setups: consecutive features of one setup are one step (the
    setup, the first feature, how many); a program that returns to a setup fixtures the
    part in it again."""
    ms, _ = hooks
    ws = importlib.import_module("inspection_hooks.ws")
    monkeypatch.setattr(ms, "SYSTEM_DIR", tmp_path)
    (tmp_path / "programs").mkdir()
    features = "".join(f"F({n})=FEAT/CIRCLE,1\nT({n})=TOL/DIAM,-0.1,0.1\n" for n in "ABCD")
    fixture = "FIXTID/'SETUP {}',CLAMPS,1\n"
    measured = "".join(
        (fixture.format(setup) if setup else "") + f"MEAS/CIRCLE,F({name})\n"
        for name, setup in (("A", 1), ("B", 0), ("C", 2), ("D", 1))
    )
    program = f"DMISMN/'p',05.0\nUNITS/MM\n{features}{measured}ENDFIL\n"
    (tmp_path / "programs" / "p.dmi").write_text(program)
    assert ws.setups("p") == [(1, 0, 2), (2, 2, 1), (1, 3, 1)]
    monkeypatch.undo()
    assert ws.setups("bracket") == [(1, 0, 3), (2, 3, 2)]


@pytest.mark.parametrize(
    ("request_text", "job", "why"),
    [
        ("Workcell::initForInspect()", ("INIT_JOB", ""), ""),
        ('Workcell::inspectPart("bracket")', ("INSPECT_JOB", "bracket"), ""),
        ("INSPECT_PART bracket", ("NO_JOB", ""), "is not a request `Interface::operation"),
        ('Hexapod::inspectPart("bracket")', ("NO_JOB", ""), "interface 'Hexapod' is not"),
        ("Workcell::initForInspect(1)", ("NO_JOB", ""), "initForInspect takes no argument"),
        ("Workcell::inspectPart(bracket)", ("NO_JOB", ""), "one program name in quotes"),
        ("Workcell::measurePart()", ("NO_JOB", ""), "Workcell has no operation 'measurePart'"),
    ],
)
def test_the_workcell_converts_a_corba_request_into_its_native_job(
    monkeypatch, request_text, job, why
):
    """Section 5.3.2: the workcell converts a job "implemented via a CORBA protocol" to the
    IWS native protocol. The shop marshals a job as a request of the workcell's interface;
    the workcell's hook reads it into the native job (wc.yaml's `job` enumeration) and its
    program, and a request that is not one of the interface's operations with its arguments
    is no job (refused with BAD_REQUEST), saying why."""
    monkeypatch.syspath_prepend(str(SYSTEM))
    corba = importlib.import_module("inspection_hooks.corba")
    wc = yaml.safe_load((SYSTEM / "wc.yaml").read_text())
    values = wc["locals"]["job"]["values"]
    index, program = corba.native_job(request_text)
    assert (values[index], program) == job
    assert why in corba.why_not(request_text) and bool(why) == bool(corba.why_not(request_text))
    assert corba.native_job(corba.inspect_request("bracket")) == (
        values.index("INSPECT_JOB"),
        "bracket",
    )


def test_a_part_file_names_only_program_features(hooks, tmp_path):
    ms, cmm = hooks
    features = ms.read_program(SYSTEM / "programs" / "bracket.dmi")
    part = tmp_path / "x.part"
    part.write_text("bore_diameter 12.01\nbore_diamter 3\n")
    with pytest.raises(
        ms.ProgramError, match=r"x.part:2: the program measures no feature `bore_diamter`"
    ):
        cmm.read_part(part, features)
    part.write_text("bore_diameter 12.01\n")
    sizes = cmm.read_part(part, features)
    assert sizes["bore_diameter"] == 12.01 and sizes["slot_width"] == 6.0, "unlisted: nominal"
    with pytest.raises(ms.ProgramError, match="cannot read the part file"):
        cmm.read_part(tmp_path / "missing.part", features)


def test_a_missing_program_stops_the_run_in_one_line(tmp_path, monkeypatch):
    """A run whose `program` setting names no file fails at start-up with E420 at the
    controller's hooks_state, not a traceback."""
    copy = tmp_path / "inspection"
    shutil.copytree(SYSTEM, copy, ignore=shutil.ignore_patterns("__pycache__"))
    edit(
        copy / "scenarios" / "nominal_inspection.yaml", "programs/bracket.dmi", "programs/nope.dmi"
    )
    monkeypatch.chdir(tmp_path)
    result = rcsgen("run", "inspection/scenarios/nominal_inspection.yaml")
    assert result.exit_code == 1
    lines = [line for line in result.output.splitlines() if "error[" in line]
    assert len(lines) == 1 and "E420" in lines[0], result.output
    assert lines[0].startswith("inspection/ms.yaml:"), lines[0]
    assert "nope.dmi: cannot read the inspection program" in lines[0]


def test_the_guardian_orders_a_lot_and_the_shop_plans_its_jobs():
    """Section 5.3.2: the shop obtains the order from the Guardian and plans the jobs; the
    workcell converts each to the workstation's own command. A lot of two parts: the station
    is prepared once, then each part inspected in turn, and the verdicts counted at the top."""
    final, lines = played("guardian_lot")
    assert final["status"] == "DONE"
    assert names(commands_sent(lines, "shop")) == ["INIT", "INSPECT_LOT"]
    assert names(commands_sent(lines, "wc")) == [
        "INIT", "INIT_FOR_INSPECT", "INSPECT_PART", "INSPECT_PART"
    ]  # fmt: skip
    assert names(commands_sent(lines, "ws")) == [
        "INIT", "INIT_FOR_INSPECT", "INSPECT_PART", "INSPECT_PART"
    ]  # fmt: skip
    jobs = [cycle for cycle, c in commands_sent(lines, "ws") if c == "INSPECT_PART"]
    # each job goes down in the cycle the shop orders it (command-first), the second only
    # once the first part's verdict has climbed back to the shop
    assert jobs[0] > first(lines, "ws", "INIT_FOR_INSPECT", "DONE")
    assert jobs[1] > first(lines, "wc", "INSPECT_PART", "DONE")
    assert outcome(lines[-1], "shop")[:2] == ("DONE", "NONE")
    assert lines[-1]["modules"]["shop"]["result"]["passed"] == 2
    assert lines[-1]["modules"]["shop"]["result"]["rejected"] == 0
    # the CMM's operation travels as a name, not a code
    ops = {line["world"]["cmm_op"] for line in lines}
    assert ops == {"NO_OPERATION", "HOMING", "PROBE_CALIBRATION", "CAMERA_CALIBRATION",
                   "MEASUREMENT"}  # fmt: skip


def test_the_shop_plans_the_next_part_while_the_workcell_inspects_this_one():
    """Section 5.2.1 (W1/W2): the job planner `jp` plans part k+1's job in the very cycles
    the workcell inspects part k, and part 0's while the station is prepared; a part's job
    goes down only once its plan is made, with the part the plan is for."""
    final, lines = played("guardian_lot")
    assert final["status"] == "DONE"
    plans = [cycle for cycle, c in commands_sent(lines, "jp") if c == "PLAN_JOB"]
    assert len(plans) == 2, "one plan per part"

    def busy(module: str, command: str) -> set[int]:
        return {
            ln["cycle"]
            for ln in lines
            if command_of(ln["modules"][module]) == command
            and ln["modules"][module]["status"] == "EXECUTING"
        }

    planning = busy("jp", "PLAN_JOB")
    setting_up, inspecting = busy("wc", "INIT_FOR_INSPECT"), busy("wc", "INSPECT_PART")
    first_plan = {c for c in planning if c < plans[1]}
    second_plan = planning - first_plan
    assert first_plan and first_plan <= setting_up, "part 0 planned during the set-up"
    assert second_plan and second_plan <= inspecting, "part 1 planned while part 0 is inspected"
    states = [at_cycle(lines, c)["modules"]["jp"]["state"] for c in sorted(second_plan)]
    retrieving = states.count("RETRIEVING")
    assert states == ["RETRIEVING"] * retrieving + ["PLANNING"] * 11, "then 5 s"
    assert retrieving == 3, "asked, then the PDM's query (2 cycles) answered, seen the next cycle"
    jobs = [cycle for cycle, c in commands_sent(lines, "wc") if c == "INSPECT_PART"]
    assert jobs[0] == plans[1], "part 0's inspection and part 1's planning start together"
    for job, part in zip(jobs, (0, 1), strict=True):
        plan = at_cycle(lines, job - 1)["modules"]["jp"]
        assert plan["status"] == "DONE" and plan["result"]["part"] == part
    assert final["results"]["scheduled"] == 10, "5 features a part, two parts"


def test_a_lot_by_a_program_that_does_not_exist_is_refused_by_the_planner():
    """unknown_program: the Guardian mistypes the program; the job planner, planning part
    0 while the station is prepared, reports ERROR NO_PROGRAM in its first cycles; the shop
    halts the workcell's set-up (the operator's request is withdrawn) and fails the lot
    with the planner's reason once the workcell has stopped; no part was placed."""
    final, lines = played("unknown_program")
    assert final["status"] == "ERROR" and final["reason"] == "NO_PROGRAM"
    refused = first(lines, "jp", "PLAN_JOB", "ERROR")
    halted = at_cycle(lines, refused + 1)["modules"]
    assert halted["shop"]["state"] == "PLAN_FAILED" and halted["wc"]["command"] == "HALT"
    assert halted["op/fx"]["state"] == "NOP", "the operator's request withdrawn"
    failed = next(ln["cycle"] for ln in lines if ln["modules"]["shop"]["status"] == "ERROR")
    assert at_cycle(lines, failed - 1)["modules"]["wc"]["status"] == "DONE", "after wc stopped"
    assert "PLACE_PART" not in names(commands_sent(lines, "fx"))


def test_the_planner_failing_mid_inspection_stops_the_station_safe_and_says_why():
    """planner_fails: the PDM system goes down (cycle 51) while the job planner retrieves
    part 1's program and the workcell inspects part 0 (W1 while W2, section 5.2.1). No
    answer comes: 3 s after asking the planner fails with PDM_DOWN; the next cycle the shop
    halts the workcell, and the HALT reaches every
    level below in that cycle: both operator requests are withdrawn and the CMM is ordered
    nothing; once the workcell has stopped the lot fails with the planner's reason, its
    cause naming the planner."""
    final, lines = played("planner_fails")
    assert final["status"] == "ERROR" and final["reason"] == "PDM_DOWN"
    failed = first(lines, "jp", "PLAN_JOB", "ERROR")
    asked = [cycle for cycle, c in commands_sent(lines, "jp") if c == "PLAN_JOB"][-1]
    down = next(ln["cycle"] for ln in lines if not ln["world"]["pdm_online"])
    assert asked < down < failed and failed - asked == 7, "asked, then 3 s with no answer"
    assert all(
        at_cycle(lines, c)["modules"]["jp"]["state"] == "RETRIEVING" for c in range(asked, failed)
    )
    before = at_cycle(lines, failed)
    assert command_of(before["modules"]["wc"]) == "INSPECT_PART", "mid-inspection"
    assert before["modules"]["wc"]["status"] == "EXECUTING"
    assert before["modules"]["jp"]["reason"] == "PDM_DOWN"
    halted = at_cycle(lines, failed + 1)["modules"]
    assert halted["shop"]["state"] == "PLAN_FAILED"
    for module in ("wc", "ws", "ms", "fx", "tl", "cmm"):
        assert halted[module]["command"] == "HALT", module
    assert halted["op/fx"]["state"] == "NOP" and halted["op/tl"]["state"] == "NOP", "withdrawn"
    assert all(ln["world"]["cmm_op"] == "NO_OPERATION" for ln in lines[failed - 1 :])
    stopped = next(ln["cycle"] for ln in lines if ln["modules"]["shop"]["status"] == "ERROR")
    assert at_cycle(lines, stopped - 1)["modules"]["wc"]["status"] == "DONE", "after wc stopped"
    top = at_cycle(lines, stopped)["modules"]["shop"]
    assert top["reason"] == "PDM_DOWN" and top["cause"] == "jp: PDM_DOWN"
    assert "MEASURE_PART" not in names(commands_sent(lines, "ms")), "no part measured unclamped"


def test_a_failed_part_job_is_planned_again_and_the_lot_completes():
    """Section 5.2.3: "The EX may report errors caused by executing earlier generated
    schedules. The planner will correspondingly replan." lot_replanned: the inspector
    refuses part 0 (cycle 53) while the planner plans part 1. The workcell fails part 0's
    job; the shop halts the planner (JOB_FAILED), plans part 0's job again (REPLANNING),
    and re-issues it with part 1's planning; the lot is done, both parts passed."""
    final, lines = played("lot_replanned")
    assert final["status"] == "DONE"
    result = lines[-1]["modules"]["shop"]["result"]
    assert result["passed"] == 2 and result["rejected"] == 0
    failed = first(lines, "wc", "INSPECT_PART", "ERROR")
    assert at_cycle(lines, failed)["modules"]["jp"]["status"] == "EXECUTING", "mid-planning"
    stopping = at_cycle(lines, failed + 1)["modules"]
    assert stopping["shop"]["state"] == "JOB_FAILED" and stopping["jp"]["command"] == "HALT"
    sent = [(c, n) for c, n in commands_sent(lines, "jp") if c > failed]
    assert sent[:2] == [(failed + 1, "HALT"), (failed + 2, "PLAN_JOB")], "planned again"
    replanned = at_cycle(lines, failed + 2)["modules"]["shop"]
    assert replanned["state"] == "REPLANNING" and replanned["status"] == "EXECUTING"
    again = [c for c, n in commands_sent(lines, "wc") if c > failed and n == "INSPECT_PART"]
    assert len(again) == 2, "part 0 again, then part 1"
    assert all(ln["modules"]["shop"]["status"] != "ERROR" for ln in lines)


def test_a_job_replanned_too_often_raises_the_error_flag_to_the_superior():
    """Section 5.2.3: "If the planner has replanned a particular task for too many times
    (beyond the designed threshold), an error flag will be generated for the superior
    node." lot_replanned_too_often: the inspector refuses part 0 twice; planned again once
    (REPLANS), the second failure halts the planner and fails the lot with the reason and
    its chain down to the operator."""
    final, lines = played("lot_replanned_too_often")
    assert final["status"] == "ERROR" and final["reason"] == "REFUSED"
    failures = [
        ln["cycle"]
        for prev, ln in zip(lines, lines[1:], strict=False)
        if ln["modules"]["wc"]["status"] == "ERROR" and prev["modules"]["wc"]["status"] != "ERROR"
    ]
    assert len(failures) == 2
    assert at_cycle(lines, failures[0] + 2)["modules"]["shop"]["state"] == "REPLANNING"
    assert at_cycle(lines, failures[1] + 1)["modules"]["shop"]["state"] == "JOB_FAILED"
    top = at_cycle(lines, failures[1] + 2)["modules"]["shop"]
    assert top["status"] == "ERROR" and top["reason"] == "REFUSED"
    assert top["cause"] == "wc: REFUSED <- ws: REFUSED <- fx: REFUSED <- op: REFUSED"
    assert sum(1 for _, n in commands_sent(lines, "wc") if n == "INSPECT_PART") == 2


def at_cycle(lines: list[dict], cycle: int) -> dict:
    assert lines[cycle - 1]["cycle"] == cycle
    return lines[cycle - 1]


def test_the_verdict_and_reasons_climb_through_workcell_and_shop():
    """The workcell and the shop pass the workstation's verdict and reasons up unchanged."""
    for scenario, status, reason in [
        ("nominal_inspection", "DONE", "NONE"),
        ("machine_fault", "ERROR", "MACHINE_FAULT"),
        ("operator_refuses", "ERROR", "REFUSED"),
        ("slow_operator", "ERROR", "TIMED_OUT"),
    ]:
        final, lines = played(scenario)
        last = lines[-1]["modules"]
        assert (last["wc"]["status"], last["wc"]["reason"]) == (status, reason), scenario
        assert (last["shop"]["status"], last["shop"]["reason"]) == (status, reason), scenario
        if status == "DONE":
            assert last["shop"]["result"]["accepted"] is last["ws"]["result"]["accepted"] is True


# ---------------------------------------------------------------- the console


def test_the_inspector_answers_and_refuses_at_the_console():
    """The workstation running paced as OS processes (`rcsgen up`'s launcher), nobody
    scripted: the Guardian (the shop's operator interface, the only role that may command,
    and only the shop) orders the station prepared; the inspector, who may not command,
    answers fixturing's request on the operator
    module's channel, refuses tooling's with a reason; a console without a role may not
    answer, a wrong reason is refused, and the inspector may not stop a module."""
    from conftest import wait_for
    from test_ctl import Running

    layout = importlib.import_module(f"{import_package(PACKAGE, SYSTEM).__name__}.layout")
    system = Running(PACKAGE, SYSTEM, layout)
    try:
        below = system.ctl("--role", "guardian", "send", "ws", "INIT_FOR_INSPECT")
        assert below.returncode == 1 and "ws is commanded by wc" in below.stderr, below.stderr
        inspector = system.ctl("--role", "inspector", "send", "shop", "INIT_FOR_INSPECT")
        assert inspector.returncode == 1 and "needs command on shop" in inspector.stderr
        sent = system.ctl("--role", "guardian", "send", "shop", "INIT_FOR_INSPECT", "--seen")
        assert sent.returncode == 0, sent.stderr
        wait_for(lambda: system.json().get("requests"), "fixturing's request")
        listed = system.ctl("requests").stdout.splitlines()
        assert listed == [
            "op/fx from fx: MOUNT_FIXTURE_PLATE #2: Clear the table and mount the fixture "
            "plate, then answer."
        ]
        refused = system.ctl("answer", "op/fx")  # no role: this console only monitors
        assert refused.returncode == 1
        assert "answering op/fx needs respond on op" in refused.stderr
        stop = system.ctl("stop", "ws", "--role", "inspector")
        assert stop.returncode == 1 and "needs override on ws" in stop.stderr
        typo = system.ctl("answer", "op/fx", "ERROR", "--reason", "REFUSD", "--role", "inspector")
        assert typo.returncode == 2 and "did you mean 'REFUSED'?" in typo.stderr
        answered = system.ctl("answer", "op/fx", "DONE", "--role", "inspector")
        assert answered.returncode == 0, answered.stderr
        assert answered.stdout == "answered op/fx: MOUNT_FIXTURE_PLATE #2 DONE\n"
        wait_for(lambda: system.module("fx")["status"] == "DONE", "fixturing done")
        wait_for(
            lambda: any(r.get("task") == "MOUNT_SPHERE" for r in system.json()["requests"]),
            "tooling's request",
        )
        no = system.ctl("answer", "op/tl", "ERROR", "--reason", "REFUSED", "--role", "inspector")
        assert no.returncode == 0, no.stderr
        wait_for(lambda: system.module("shop")["status"] == "ERROR", "the shop's job failed")
        assert system.module("ws")["status"] == "ERROR"
        assert system.module("op/tl")["status"] == "ERROR"
        assert system.ctl("requests").stdout == "no requests\n", "nothing left on the screen"
        again = system.ctl("answer", "op/fx", "--role", "inspector")
        assert again.returncode == 1 and "fx is asking nothing of op now" in again.stderr
    finally:
        out = system.stop()
    assert "iws: stopped" in out


def test_docs_report_the_current_workaround_count():
    """docs/inspection.md's table of `# workaround(kind)` lines is what the specs hold now."""
    doc = (ROOT / "docs" / "inspection.md").read_text(encoding="utf-8")
    result = count(SYSTEM)
    assert set(result.markers) <= {"time", "result", "expr", "reuse", "operator"}
    assert table(result) in doc, (
        "docs/inspection.md's workaround table is stale: update it from\n"
        "  python tests/support/workarounds.py specs/inspection"
    )


def test_the_workaround_count_follows_its_rule(tmp_path):
    (tmp_path / "a.yaml").write_text(
        "constants:\n"
        "  # workaround(time): kept by hand\n"
        "  TIMEOUT: 60\n"
        "  # workaround(result): codes\n"
        "  # (continued)\n"
        "  REFUSED: 1\n"
        "  TIMED_OUT: 2\n"
        "\n"
        "commands:\n"
        "  A:\n"
        "    # workaround(reuse): the pattern\n"
        "    states:\n"
        "      S0:\n"
        "        - when: waited >= TIMEOUT  # workaround(time)\n"
        "  B:\n"
        "    doc: not covered\n",
        encoding="utf-8",
    )
    result = count(tmp_path)
    assert result.markers == {"reuse": 1, "result": 1, "time": 2}
    assert result.lines == {"reuse": 3, "result": 2, "time": 2}
    assert (result.covered, result.total) == (6, 16)
