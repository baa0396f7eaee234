"""`rcsgen run` and scenario files: checked before cycle 0, built from the specs (never
stale), expected outcomes, golden traces, commands in a supervisor's place.

The corpus (tests/cases/invalid/e4*, s00*-scenario-*) holds one case per scenario mistake;
these tests are about the run around them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import REPO, rcsgen

from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import load_scenario, open_harness, run

TINY = REPO / "tests" / "cases" / "valid" / "tiny"
MINER = REPO / "specs" / "miner"
MOVE = """\
scenario: move
title: Move the subordinate, in its supervisor's place
max_cycles: 20
stop_when_done: sub
report:
  figures: [level]
events:
  - cycle: 2
    command: sub.MOVE
    overrides: true
    with: {x: 1.0}
"""


@pytest.fixture
def tiny(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(TINY, tmp_path / "sys")
    (tmp_path / "sys" / "scenarios").mkdir()
    (tmp_path / "sys" / "scenarios" / "move.yaml").write_text(MOVE)
    monkeypatch.chdir(tmp_path)
    return tmp_path / "sys"


@pytest.fixture
def miner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(MINER, tmp_path / "miner", ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.chdir(tmp_path)
    return tmp_path / "miner"


def edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


def test_a_command_in_the_supervisors_place_is_kept(tiny: Path) -> None:
    """With `overrides: true` the supervisor does not overwrite the command: sub runs MOVE
    to DONE under the number the scenario gave it, and top's next send is numbered after."""
    scenario = load_scenario(tiny / "scenarios" / "move.yaml")
    assert scenario.events[0].overrides == "top"
    result = rcsgen("run", "sys/scenarios/move.yaml")
    assert result.exit_code == 0, result.output
    assert "result    sub DONE (state NOP)" in result.stdout
    with open_harness(scenario, _built(tiny)) as h:
        outcome = run(scenario, h)
        assert outcome.final["status"] == "DONE"
        assert (h.sent("sub").command, h.sent("sub").number, h.sent("sub").args) == (
            "MOVE",
            2,
            {"x": 1.0},
        )
        h.command("top", "GO")
        h.cycle()
        assert (h.sent("sub").command, h.sent("sub").number) == ("MOVE", 3)


def test_an_override_under_a_supervisor_in_init_runs_alike_in_one_process_and_in_lockstep(
    tiny: Path,
) -> None:
    """The sub is commanded while top still waits in INIT for sub's echo. The one-process
    harness used to write the supervisor's locals (`adopt`), so top rewrote the command
    numbered 3 and kept waiting; the processes, where no one can reach into top, left it
    at 2 and top finished INIT. A scenario must leave the same trace either way."""
    scenario = load_scenario(tiny / "scenarios" / "move.yaml")
    package = _built(tiny)
    with open_harness(scenario, package) as one:
        alone = run(scenario, one).trace
    with open_harness(scenario, package, processes=True) as launched:
        lockstep = run(scenario, launched).trace
        # each process of the ring times its cycle (token to beat) into its control record
        for name in launched.layout.PROCESSES:
            record = launched.process_record(name)
            assert 0 < record["last_cycle_ns"] <= record["max_cycle_ns"], (name, record)
    cycle_2 = json.loads(alone[1])["modules"]
    assert cycle_2["top"]["command"] == "INIT" and cycle_2["sub"]["command_num"] == 2
    assert alone == lockstep


HELD = """\
scenario: held
title: Force, set, hold, answer and release in one process
max_cycles: 5
trace:
  world: [level, flag]
events:
  - cycle: 2
    force: {level: 7.5}
    mode: {sub: {dont_run: true}}
    command: sub.MOVE
    overrides: true
    with: {x: 1.0}
  - cycle: 3
    set: {flag: true}
    reply: {sub: ERROR}
  - cycle: 4
    unforce: [level]
"""


def test_events_force_set_hold_answer_and_release_in_one_process(tiny: Path) -> None:
    """Each event acts before its cycle, as `ctl` would: the forced field is held and shown
    under `overrides` until released; the held module takes its command but does not run
    it (run, it would report DONE at once); the scripted ERROR echoes the command's number."""
    (tiny / "scenarios" / "held.yaml").write_text(HELD)
    scenario = load_scenario(tiny / "scenarios" / "held.yaml")
    with open_harness(scenario, _built(tiny)) as h:
        lines = [json.loads(line) for line in run(scenario, h).trace]
    sub = [
        tuple(line["modules"]["sub"][k] for k in ("command", "command_num", "status", "status_num"))
        for line in lines
    ]
    assert sub == [
        ("INIT", 1, "DONE", 1),
        ("MOVE", 2, "EXECUTING", 2),
        ("MOVE", 2, "ERROR", 2),
        ("MOVE", 2, "ERROR", 2),
        ("MOVE", 2, "ERROR", 2),
    ]
    assert [line["world"] for line in lines] == [
        {"flag": False, "level": 0.0},
        {"flag": False, "level": 7.5},
        *[{"flag": True, "level": 7.5}] * 3,  # released, the last value stays: nothing writes it
    ]
    assert [line.get("overrides") for line in lines] == [
        None,
        {"level": "FORCED"},
        {"level": "FORCED"},
        None,
        None,
    ]


def test_simulate_runs_the_stand_ins_in_place_of_their_controllers_in_their_process() -> None:
    """The miner's cr simulated: its stand-in cr_sim runs in pc1 under cr's name (its states
    cr_sim's), and gh, which cr_sim stands in for too, never runs; pc2, which has no
    stand-in, is left as it is, and a process without one refuses the request."""
    package, hooks = REPO / "generated" / "miner", MINER
    with Harness.load(package, hooks, send_init=True, simulate=("cr",)) as whole:
        whole.cycle(3)
        assert {n: list(p.simulated) for n, p in whole.processes.items()} == {
            "pc1": ["cr"],
            "pc2": [],
        }
        assert whole._states_of == {"cr": "cr_sim"}
        assert whole.status("gh").status == "NOT_READY"
    with Harness.load(package, hooks, "pc1", send_init=True) as real:
        real.cycle(3)
        assert real._states_of == {} and real.status("gh").status == "DONE"
    with pytest.raises(ValueError, match=r"^no stand-in for \['cr'\]$"):
        Harness.load(package, hooks, "pc2", simulate=("cr",))


def _built(system: Path) -> Path:
    assert rcsgen("build", str(system), "-o", "gen").exit_code == 0
    return Path("gen") / "tiny"


def test_without_overrides_the_command_is_refused_before_cycle_0(tiny: Path) -> None:
    edit(tiny / "scenarios" / "move.yaml", "    overrides: true\n", "")
    result = rcsgen("run", "sys/scenarios/move.yaml")
    assert result.exit_code == 1
    assert "sys/scenarios/move.yaml:9:14: error[E413]" in result.output
    assert "run failed: nothing was run" in result.output
    assert "scenario  move" not in result.output  # no cycle ran


def test_a_late_mistake_is_found_before_the_run_starts(miner: Path) -> None:
    """A misspelt module in an event at cycle 400 used to fail after 399 cycles."""
    path = miner / "scenarios" / "box_cut.yaml"
    edit(path, "max_cycles: 2000", "max_cycles: 2000\n")
    text = path.read_text() + "  - cycle: 400\n    set: {tread_staled: true}\n"
    path.write_text(text)
    result = rcsgen("run", "miner/scenarios/box_cut.yaml")
    assert result.exit_code == 1
    assert "error[E409]: field `tread_staled` is not a world field of `miner`" in result.output
    assert "did you mean `tread_stalled`?" in result.output
    assert "cycle    100" not in result.output


def test_run_builds_from_the_specs_so_it_never_runs_stale_code(tiny: Path) -> None:
    """A constant changed in a spec, no `rcsgen build`: the run uses the new value."""
    assert rcsgen("build", "sys", "-o", "gen").exit_code == 0
    edit(tiny / "scenarios" / "move.yaml", "stop_when_done: sub\n", "")
    text = (tiny / "scenarios" / "move.yaml").read_text()
    text = text.replace(
        "    command: sub.MOVE\n    overrides: true\n    with: {x: 1.0}\n", "    command: top.GO\n"
    )
    (tiny / "scenarios" / "move.yaml").write_text(text + "  - cycle: 1\n    set: {flag: true}\n")
    text = (tiny / "scenarios" / "move.yaml").read_text()
    text = text.replace(
        "  - cycle: 2\n    command: top.GO\n  - cycle: 1\n    set: {flag: true}\n",
        "  - cycle: 1\n    set: {flag: true}\n  - cycle: 2\n    command: top.GO\n",
    )
    (tiny / "scenarios" / "move.yaml").write_text(text)
    edit(tiny / "top.yaml", "LIMIT: 3", "LIMIT: 1")  # now ready() holds once n reaches 1
    fresh = rcsgen("run", "sys/scenarios/move.yaml")
    assert fresh.exit_code == 0, fresh.output
    assert "level     2.500" in fresh.stdout  # GO finished: it sets world.level
    stale = rcsgen("run", "sys/scenarios/move.yaml", "--generated", "gen")
    assert stale.exit_code == 1
    assert (
        "gen/tiny:1:1: error[E418]: `gen/tiny` is stale: top.py differs from what the specs "
        "make" in stale.output
    )
    assert rcsgen("build", "sys", "-o", "gen").exit_code == 0
    assert rcsgen("run", "sys/scenarios/move.yaml", "--generated", "gen").exit_code == 0


def test_a_scenario_designed_to_end_in_error_passes(miner: Path) -> None:
    path = miner / "scenarios" / "stalled_tread.yaml"
    assert rcsgen("run", "miner/scenarios/stalled_tread.yaml", "-q").exit_code == 0
    edit(path, "  status: ERROR", "  status: DONE")
    result = rcsgen("run", "miner/scenarios/stalled_tread.yaml", "-q")
    assert result.exit_code == 1
    assert (
        "error[E416]: expected `sec` to finish DONE; it finished ERROR (state NOP) in cycle 262"
        in result.output
    )


def test_golden_comparison_from_the_command_line(miner: Path) -> None:
    golden = REPO / "tests" / "golden" / "sump_shear_cusp.jsonl"
    same = rcsgen("run", "miner/scenarios/sump_shear_cusp.yaml", "--golden", golden, "-q")
    assert same.exit_code == 0, same.output
    edit(miner / "co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 0.1")
    other = rcsgen("run", "miner/scenarios/sump_shear_cusp.yaml", "--golden", golden, "-q")
    assert other.exit_code == 1
    [line] = [x for x in other.output.splitlines() if "error[E417]" in x]
    cycle = int(line.split("differs from the golden trace: cycle ")[1].split(":")[0])
    shown = golden.resolve().as_posix()  # (outside the test's working directory: shown whole)
    assert line.startswith(f"{shown}:{cycle}:1: error[E417]")


def test_json_output_stays_valid_when_a_hook_prints(tiny: Path) -> None:
    """Machine formats own stdout: what a run prints goes to stderr."""
    result = rcsgen("run", "sys/scenarios/move.yaml", "--format", "json", "--ignore", "W5")
    assert result.exit_code == 0
    assert json.loads(result.stdout) == []
    assert "scenario  move" in result.stderr


def test_quiet_run_prints_only_problems(tiny: Path) -> None:
    result = rcsgen("run", "sys/scenarios/move.yaml", "-q", "--ignore", "W503,W506")
    assert result.exit_code == 0 and result.output == ""


def test_validate_checks_every_scenario_of_a_system(tiny: Path) -> None:
    edit(tiny / "scenarios" / "move.yaml", "command: sub.MOVE", "command: sub.MOVEE")
    (tiny / "scenarios" / "other.yaml").write_text("scenario: other\nmax_cycles: 0\n")
    result = rcsgen("validate", "sys")
    assert result.exit_code == 1
    assert "sys/scenarios/move.yaml:9:14: error[E406]" in result.output
    assert "sys/scenarios/other.yaml:2:13: error[S005]" in result.output


def test_the_miners_scenarios_validate_and_meet_their_expectations() -> None:
    assert rcsgen("validate", MINER, "--strict").exit_code == 0


def test_device_faults_name_a_served_device_of_the_system_in_order(
    tiny: Path, tmp_path: Path
) -> None:
    """E426: a device the system does not declare (a system without `io:` has none), a
    plant that is not a spec directory, a fault to a device the scenario does not serve,
    faults out of order (a replug of a device that is up, a second freeze); each at its
    line, before anything starts (tests/test_io_scenario.py runs the faults)."""
    (tiny / "scenarios" / "plc.yaml").write_text("scenario: plc\ndevices: {plc: {}}\n")
    result = rcsgen("validate", "sys")
    assert "sys/scenarios/plc.yaml:2:11: error[E426]: `tiny` declares no I/O: it has no " in (
        result.output
    ), result.output

    hil = tmp_path / "hil"
    shutil.copytree(REPO / "specs" / "miner_hil", hil, ignore=shutil.ignore_patterns("scenarios"))
    (hil / "scenarios").mkdir()
    (hil / "scenarios" / "faults.yaml").write_text(
        "scenario: faults\n"
        "devices:\n"
        "  plx: {}\n"
        "  plc: {plant: ../miner}\n"  # no ../miner next to this copy
        "events:\n"
        "  - cycle: 2\n"
        "    device: {name: plc, do: replug}\n"
        "  - cycle: 3\n"
        "    device: {name: plc, do: freeze}\n"
        "  - cycle: 4\n"
        "    device: {name: plc, do: freeze}\n"
    )
    result = rcsgen("validate", "hil")
    assert result.exit_code == 1
    out = result.output
    assert "hil/scenarios/faults.yaml:3:3: error[E426]: `miner_hil` has no I/O device `plx`" in out
    assert "did you mean `plc`?" in out
    assert "faults.yaml:4:16: error[E426]: plant `../miner` of device `plc` is not a spec " in out
    # the plant refused, plc is not served: its faults say so (the first; the others alike)
    assert "faults.yaml:7:13: error[E426]: device `plc` is not served by this scenario" in out

    (hil / "scenarios" / "faults.yaml").write_text(
        (hil / "scenarios" / "faults.yaml")
        .read_text()
        .replace("  plx: {}\n", "")
        .replace("{plant: ../miner}", "{}")
    )
    out = rcsgen("validate", "hil").output
    assert "faults.yaml:6:13: error[E426]: cannot replug device `plc` here: it is up" in out
    assert "faults.yaml:10:13: error[E426]: cannot freeze device `plc` here: it is frozen" in out
    assert out.count("E426") == 2, out
