"""The platoon (specs/platoon, the second paper's section 6) across real processes.

Its scenarios and golden traces (bounding overwatch, the spot report, a vehicle immobilised)
run in tests/test_golden.py, in one process and as its three processes in lockstep. Here the
committed package is launched paced, as `python -m platoon` starts it, and one vehicle's
process is killed mid-bound: the section declares `on_lost: continue` for both vehicles
(docs/semantics.md section 14), so only the lost vehicle's actuators are latched safe and the
survivor goes on alone, driven by the section's own rules; nothing halts the system.
"""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import json
import os
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import read_whole, wait_for
from support.running import alive

from rcsgen.tools.harness import Harness, import_package
from rcsgen.tools.scenario import load_scenario, open_harness, read_trace, run

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "generated" / "platoon"
SPECS = ROOT / "specs" / "platoon"
_names = itertools.count()

# Each vehicle's actuators, and their safe values (template.yaml: brake `safe: true`, the
# others their type's default).
SAFE = {"brake": True, "throttle": 0.0, "steer": 0.0, "pan_cmd": 0.0}


@pytest.fixture(scope="module")
def package() -> ModuleType:
    return import_package(PACKAGE, SPECS)


def runtime(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


@pytest.fixture
def launched(package: ModuleType) -> Iterator[Any]:
    """The platoon launched paced (processes command, pa, pb) on a segment of this test's
    own; at the end: stopped, its segment gone from /dev/shm, no process of it alive."""
    launcher_module = runtime(package, "rcs.operate.launcher")
    layout = runtime(package, "layout")
    system = launcher_module.System(
        PACKAGE.name,
        layout,
        {p: runtime(package, f"main_{p}").PLAN for p in layout.PROCESSES},
        (str(PACKAGE.parent), str(SPECS)),
    )
    launcher = launcher_module.Launcher(system, f"rcsgen_pl_{os.getpid()}_{next(_names)}")
    launcher.start()
    buf = launcher.block.buf
    pids = [int(read_whole(layout.PROCESSES[p], buf)["pid"]) for p in layout.PROCESSES]
    try:
        yield launcher
    finally:
        segment = launcher.segment
        launcher.stop()
        assert not os.path.exists(f"/dev/shm/{segment}"), "segment left behind"
        for pid in pids:
            wait_for(lambda pid=pid: not alive(pid), f"process {pid} gone", deadline=10)


def watch(launcher: Any, condition: Callable[[], object], what: str, deadline: float = 30) -> None:
    """wait_for with the launcher polling meanwhile (it marks a dead child DEAD)."""
    wait_for(
        lambda: launcher.poll() is not None and condition(),
        f"{what} (the launcher saw {launcher.events})",
        deadline,
    )


def test_a_vehicle_lost_mid_bound_leaves_the_survivor_to_go_on_alone(
    launched: Any, package: ModuleType
) -> None:
    """kill -9 of pb (Bravo, overwatching while Alpha bounds): Bravo's actuators are latched
    at their safe values, Alpha's are not; the section reads Bravo ERROR (LOST), halts it and
    goes on with Alpha alone (A_ALONE); Alpha keeps driving towards the objective; the
    platoon's command and the system run on."""
    layout, buf = launched.system.layout, launched.block.buf
    command = runtime(package, "rcs.operate.command")
    contract = runtime(package, "rcs.contract")
    override = runtime(package, "rcs.override")

    def world(name: str) -> object:
        return read_whole(layout.WORLD[name], buf)[name]

    def status(module: str) -> tuple[str, str]:
        values = read_whole(layout.STATUS_OUT[module], buf)
        state = layout.STATE_NAMES[module][values["state"]]
        return contract.STATUS_NAMES[values["status"]], state

    def actuators(vehicle: str) -> dict[str, object]:
        return {name: world(f"{vehicle}_{name}") for name in SAFE}

    def working(module: str) -> str:
        """The command `module` has taken up and is executing ('' when none)."""
        sent = read_whole(layout.COMMAND_IN[module], buf)
        values = read_whole(layout.STATUS_OUT[module], buf)
        taken = values["status_num"] == sent["command_num"]
        running = contract.STATUS_NAMES[values["status"]] == "EXECUTING"
        return layout.COMMAND_NAMES[module][sent["command"]] if taken and running else ""

    order = command.parse_command(layout, "pl", "ESTABLISH_OP", ["objective=1200.0"])
    command.write_command(layout, buf, order)
    watch(
        launched,
        lambda: (
            status("sec") == ("EXECUTING", "A_BOUNDS")
            and float(world("alpha_speed")) > 1.0  # type: ignore[arg-type]
            and status("bravo")[0] == "EXECUTING"
        ),
        "Alpha bounding, Bravo overwatching",
    )
    launched.children["pb"].popen.send_signal(signal.SIGKILL)
    watch(launched, lambda: actuators("bravo") == SAFE, "Bravo's actuators latched safe")
    watch(launched, lambda: status("sec") == ("EXECUTING", "A_ALONE"), "the section: A_ALONE")
    assert "pb died (exit -9)" in launched.events
    assert set(override.overrides(layout, buf)) == {f"bravo_{name}" for name in SAFE}
    halted = read_whole(layout.COMMAND_IN["bravo"], buf)
    assert layout.COMMAND_NAMES["bravo"][halted["command"]] == "HALT", "the section halted it"
    # The survivor drives on: its throttle is its own, and it gets further.
    before = float(world("alpha_x"))  # type: ignore[arg-type]
    watch(
        launched,
        lambda: float(world("alpha_x")) > before + 20.0,  # type: ignore[arg-type]
        "Alpha moves on alone",
    )
    assert actuators("alpha")["brake"] is False
    assert status("pl") == ("EXECUTING", "ADVANCE")
    assert not launched.halted, "a contained loss does not halt the system"
    # `ctl status` as the platoon leader reads it: each instance's modules rows of their own,
    # Bravo's dead with its process, Alpha's running its bound, the section's result `alone`.
    ctl = runtime(package, "rcs.operate.ctl")
    console = ctl.Console(layout, launched.segment)
    try:
        shown = ctl.render(console.snapshot())
    finally:
        console.close()
    rows = {line.split()[0]: line.split() for line in shown[2 : 2 + len(layout.MODULES)]}
    assert list(rows) == list(layout.MODULES)
    assert rows["alpha_loco"][1] == "MOVE_TO" and rows["alpha_loco"][-1] != "dead"
    assert rows["alpha_drive"][1] == "SPEED"
    assert all(rows[m][-1] == "dead" for m in layout.MODULES if m.startswith("bravo"))
    assert "alone true" in next(line for line in shown if line.startswith("results sec:"))
    assert any(line.startswith("process pb: dead") for line in shown)


VEHICLE = ("", "_loco", "_drive", "_rsta", "_pan", "_motion", "_sensor")


def test_each_instance_is_modules_of_its_own_in_the_layout_code_graph_and_traces(
    package: ModuleType,
) -> None:
    """The template written once is, per instance, modules of their own: in the layout (each
    in its vehicle's process), in the generated files (each readable alone: its header names
    the template and the instance, its names and constants are its own, none of the other
    instance's), in the hierarchy graph and in the golden traces."""
    from click.testing import CliRunner

    from rcsgen.cli import main

    layout = runtime(package, "layout")
    for name, process in (("alpha", "pa"), ("bravo", "pb")):
        other = "bravo" if name == "alpha" else "alpha"
        modules = [f"{name}{part}" for part in VEHICLE]
        assert {m: layout.PLACEMENT[m] for m in modules} == dict.fromkeys(modules, process)
        assert layout.SUBORDINATES[name] == (f"{name}_loco", f"{name}_rsta")
        for module in modules:
            member = module.removeprefix(name).removeprefix("_") or "veh"
            text = (PACKAGE / f"{module}.py").read_text(encoding="utf-8")
            assert text.splitlines()[0].startswith(
                f"# Generated by rcsgen from platoon/vehicle/{member}.yaml, `{member}` of "
                f"template `vehicle` as instance `{name}`."
            )
            assert other not in text.lower(), f"{module}.py names {other}"
        drive = (PACKAGE / f"{name}_drive.py").read_text(encoding="utf-8")
        corridor = "-250.0" if name == "alpha" else "250.0"
        assert f"\nCORRIDOR_Y = {corridor}\n" in drive
        assert f"class {name.capitalize()}DriveController:" in drive
    graph = CliRunner().invoke(main, ["graph", str(SPECS)], catch_exceptions=False)
    assert graph.exit_code == 0, graph.output
    for edge in ("m_sec --> m_alpha", "m_alpha --> m_alpha_loco", "m_bravo_rsta --> m_bravo_pan"):
        assert edge in graph.output
    assert 'm_bravo["bravo<br/>Vehicle Bravo (Jerry, the right corridor)"]' in graph.output
    golden = ROOT / "tests" / "golden" / "platoon" / "lost_vehicle.jsonl"
    lines = [json.loads(line) for line in read_trace(golden)]
    assert all(set(line["modules"]) == set(layout.MODULES) for line in lines)
    immobile = [line["cycle"] for line in lines if line["modules"]["bravo"]["reason"] == "IMMOBILE"]
    assert immobile[:1] == [126], "Bravo's locomotion's reason, passed up by Bravo"
    assert all(line["modules"]["alpha"]["status"] != "ERROR" for line in lines)


def test_the_monitor_puts_each_instance_under_its_supervisor(package: ModuleType) -> None:
    pytest.importorskip("textual")
    from rcsgen.tools.monitor import tree_order

    rows = dict(tree_order(runtime(package, "layout")))
    assert list(rows)[:5] == ["pl", "sec", "alpha", "alpha_loco", "alpha_drive"]
    # the section is the platoon's first subordinate; its last is the leader's channel
    assert rows["alpha"] == "│  ├─ " and rows["bravo"] == "│  └─ "
    assert rows["bravo_loco"] == "│     ├─ " and rows["bravo_pan"] == "│        └─ "
    assert (
        rows["ldr/pl"] == "└─ " and list(rows).index("ldr/pl") == list(rows).index("bravo_pan") + 1
    )


def test_a_halted_vehicle_holds_every_actuator_at_its_safe_value() -> None:
    """lost_vehicle: the section halts Bravo (mobility kill). From the cycle its drive and pan
    servos read that HALT, all four of Bravo's actuators are at their safe values and stay
    there (drive centres and stops steering, pan orders bearing 0), while Alpha steers on."""
    scenario = load_scenario(SPECS / "scenarios" / "lost_vehicle.yaml")
    fields = [f"{v}_{name}" for v in ("alpha", "bravo") for name in SAFE]
    scenario = dataclasses.replace(scenario, trace_world=fields)
    harness = open_harness(scenario, PACKAGE)
    try:
        lines = [json.loads(line) for line in run(scenario, harness).trace]
    finally:
        harness.close()
    halted = [
        line["cycle"]
        for line in lines
        if line["modules"]["bravo_drive"]["command"] == "HALT"
        and line["modules"]["bravo_pan"]["command"] == "HALT"
    ]
    assert halted, "the section never halted Bravo's servos"
    before = [line for line in lines if line["cycle"] < halted[0]]
    after = [line for line in lines if line["cycle"] >= halted[0]]
    # Before the HALT Bravo steered and pointed its sensor: the check below can fail.
    assert any(line["world"]["bravo_steer"] != 0.0 for line in before)
    assert any(line["world"]["bravo_pan_cmd"] != 0.0 for line in before)
    for line in after:
        for name, safe in SAFE.items():
            assert line["world"][f"bravo_{name}"] == safe, (line["cycle"], name)
    assert any(line["world"]["alpha_steer"] != 0.0 for line in after), "Alpha stopped steering"


def test_the_last_vehicle_erring_is_halted_before_the_section_reports_both_lost() -> None:
    """Bravo lost, Alpha alone; then Alpha's ERROR: the section sends Alpha HALT (whatever its
    ERROR left moving below it) and reports ERROR BOTH_LOST only on the HALT's echo."""
    harness = Harness.load(PACKAGE, hooks_dir=SPECS)
    try:
        harness.command("sec", "SC_EST_OBS", objective=1200.0)
        harness.step("sec")  # S0: Alpha bounds, Bravo watches
        harness.reply("bravo", "ERROR")
        harness.step("sec")
        assert harness.status("sec").state == "A_ALONE"
        goto = harness.sent("alpha")
        harness.reply("alpha", "ERROR")
        harness.step("sec")
        halt = harness.sent("alpha")
        assert halt.command == "HALT" and halt.number == goto.number + 1
        assert harness.status("sec").status == "EXECUTING"  # waits for the HALT's echo
        harness.step("sec")
        assert harness.status("sec").status == "EXECUTING"
        harness.reply("alpha", "DONE")
        harness.step("sec")
        status = harness.status("sec")
        assert (status.status, status.reason) == ("ERROR", "BOTH_LOST")
    finally:
        harness.close()
