"""The platoon (specs/platoon, the second paper's section 6) across real processes.

Its scenarios and golden traces (bounding overwatch, the spot report, a vehicle immobilised)
run in tests/test_golden.py, in one process and as its three processes in lockstep. Here the
committed package is launched paced, as `python -m platoon` starts it, and one vehicle's
process is killed mid-bound: the section declares `on_lost: continue` for both vehicles
(docs/semantics.md section 14), so only the lost vehicle's actuators are latched safe and the
survivor goes on alone, driven by the section's own rules; nothing halts the system.
"""

from __future__ import annotations

import importlib
import itertools
import os
import signal
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import wait_for

from rcsgen.tools.harness import import_package

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


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is not alive
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture
def launched(package: ModuleType) -> Iterator[Any]:
    """The platoon launched paced (processes command, pa, pb) on a segment of this test's
    own; at the end: stopped, its segment gone from /dev/shm, no process of it alive."""
    launcher_module = runtime(package, "rcs.launcher")
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
    pids = [int(layout.PROCESSES[p].read(buf)["pid"]) for p in layout.PROCESSES]
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
    command = runtime(package, "rcs.command")
    contract = runtime(package, "rcs.contract")
    override = runtime(package, "rcs.override")

    def world(name: str) -> object:
        return layout.WORLD[name].read(buf)[name]

    def status(module: str) -> tuple[str, str]:
        values = layout.STATUS_OUT[module].read(buf)
        state = layout.STATE_NAMES[module][values["state"]]
        return contract.STATUS_NAMES[values["status"]], state

    def actuators(vehicle: str) -> dict[str, object]:
        return {name: world(f"{vehicle}_{name}") for name in SAFE}

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
    halted = layout.COMMAND_IN["bravo"].read(buf)
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
    assert sys.modules[layout.__name__].PROCESSES  # the layout the processes ran
