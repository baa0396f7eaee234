"""Fail safe: overrides, safe outputs, liveness, the watchdog, start-up (docs/semantics.md).

The system is `tests/fixtures/runtime/fleet`: a leader `lead` (process pl) commanding two
vehicles, `v1` (pa) and `v2` (pb), each writing actuator fields. The in-process tests drive
one process's modules through the harness; the fault tests run the three processes as real
OS processes, inject a fault (kill -9, SIGSTOP, starvation, the launcher's death, a second
copy, another layout) and wait, with generous bounded deadlines, for the actuator fields in
the block to reach their safe values; nothing here asserts how fast (`make bench` does).
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import read_whole, wait_for
from support.running import alive, attached, segment_names

from rcsgen.tools.harness import Harness, generate, import_package

FLEET = Path(__file__).resolve().parent / "fixtures" / "runtime" / "fleet"


@pytest.fixture(scope="module")
def fleet() -> Iterator[Path]:
    """The fleet system generated into a scratch directory: the package's directory."""
    scratch, name = generate(FLEET)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def package(fleet: Path) -> ModuleType:
    return import_package(fleet, FLEET)


def runtime(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


def world(layout: ModuleType, buf: memoryview, name: str) -> object:
    return read_whole(layout.WORLD[name], buf)[name]


# ---------------------------------------------------------------- overrides


def test_a_forced_field_keeps_its_value_whatever_its_writer_does(package: ModuleType) -> None:
    """force: the block holds the forced value and the module that writes the field keeps
    it (its rules still set their own); unforce: the field keeps the forced value until the
    module sets it again, and then the module's value is written."""
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    h = Harness(package, "pa")
    h.command("v1", "DRIVE")
    h.cycle()
    assert world(layout, h.buf, "v1_drive") == 1.0
    override.force(layout, h.buf, "v1_drive", 0.25)
    assert world(layout, h.buf, "v1_drive") == 0.25
    h.command("v1", "DRIVE")  # a new command: S0 sets v1_drive = 1.0 again
    h.cycle(3)
    assert world(layout, h.buf, "v1_drive") == 0.25, "the writer overwrote a forced field"
    assert world(layout, h.buf, "v1_note") == 1, "the fields not forced are written"
    assert override.overrides(layout, h.buf) == {"v1_drive": ("FORCED", 0.25)}
    override.unforce(layout, h.buf, "v1_drive")
    assert override.overrides(layout, h.buf) == {}
    assert h.buf[layout.OVERRIDDEN_AT] == 0
    h.cycle()
    assert world(layout, h.buf, "v1_drive") == 0.25, "released: kept until set again"
    h.command("v1", "DRIVE")
    h.cycle()
    assert world(layout, h.buf, "v1_drive") == 1.0


def test_a_field_clobbered_by_a_racing_writer_is_restored_next_cycle(package: ModuleType) -> None:
    """A writer that wrote between the override and its own check (a freeze at the wrong
    moment) is corrected on its next cycle: the override's value is written back."""
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    h = Harness(package, "pa")
    h.command("v1", "DRIVE")
    h.cycle()
    override.force(layout, h.buf, "v1_drive", 0.5)
    layout.WORLD["v1_drive"].write(h.buf, v1_drive=3.0)  # the racing write
    h.cycle()
    assert world(layout, h.buf, "v1_drive") == 0.5


def test_latched_safe_values_stay_until_an_explicit_reset(package: ModuleType) -> None:
    """latch_safe writes each actuator's declared safe value (the type's zero by default)
    and latches it: the writer cannot change it, a force is refused, unforce is refused;
    reset releases it and the module's next command drives it again."""
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    h = Harness(package, "pb")
    h.command("v2", "DRIVE")
    h.cycle()
    assert (world(layout, h.buf, "v2_drive"), world(layout, h.buf, "v2_brake")) == (2.0, False)
    assert layout.SAFE_VALUES == {"v1_drive": 0.0, "v2_drive": -0.5, "v2_brake": True}
    assert override.latch_safe(layout, h.buf, ["v2_drive", "v2_brake"]) == ["v2_drive", "v2_brake"]
    assert override.latch_safe(layout, h.buf, ["v2_drive"]) == [], "already latched"
    h.command("v2", "DRIVE")
    h.cycle(2)
    assert (world(layout, h.buf, "v2_drive"), world(layout, h.buf, "v2_brake")) == (-0.5, True)
    assert override.overrides(layout, h.buf) == {
        "v2_drive": ("SAFE", -0.5),
        "v2_brake": ("SAFE", True),
    }
    with pytest.raises(override.OverrideError, match="latched at its safe value: reset"):
        override.force(layout, h.buf, "v2_drive", 1.0)
    with pytest.raises(override.OverrideError, match="reset releases it"):
        override.unforce(layout, h.buf, "v2_drive")
    with pytest.raises(override.OverrideError, match="not an actuator"):
        override.latch_safe(layout, h.buf, ["mode"])
    assert override.reset(layout, h.buf, ["v2_drive"]) == ["v2_drive"]
    assert h.buf[layout.OVERRIDDEN_AT] == 1, "v2_brake is still latched"
    assert override.reset(layout, h.buf) == ["v2_brake"]
    assert h.buf[layout.OVERRIDDEN_AT] == 0
    h.cycle()
    assert world(layout, h.buf, "v2_drive") == -0.5, "a reset does not restart the machine"
    h.command("v2", "DRIVE")
    h.cycle()
    assert (world(layout, h.buf, "v2_drive"), world(layout, h.buf, "v2_brake")) == (2.0, False)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("v1_drive", "fast", "v1_drive holds a number, not 'fast'"),
        ("v1_drive", True, "v1_drive holds a number, not True"),
        ("v1_note", 1.5, "v1_note holds an int, not 1.5"),
        ("v1_note", 2**63, "v1_note holds an int"),
        ("v2_brake", 1, "v2_brake holds a bool, not 1"),
        ("mode", "FAST", "'FAST' is not one of IDLE, TOGETHER, ALONE"),
        ("mode", 7, "mode: 7 is not one of IDLE, TOGETHER, ALONE"),
        ("nowhere", 1, "no world field 'nowhere'"),
    ],
)
def test_an_override_the_field_cannot_hold_is_refused(
    package: ModuleType, field: str, value: object, message: str
) -> None:
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    block = runtime(package, "rcs.block").Block(layout)
    with pytest.raises(override.OverrideError) as error:
        override.force(layout, block.buf, field, value)
    assert message in str(error.value)
    assert override.overrides(layout, block.buf) == {}


def test_an_enumeration_is_forced_by_name(package: ModuleType) -> None:
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    block = runtime(package, "rcs.block").Block(layout)
    override.force(layout, block.buf, "mode", "ALONE")
    assert world(layout, block.buf, "mode") == 2
    assert override.overrides(layout, block.buf) == {"mode": ("FORCED", 2)}


# ---------------------------------------------------------------- faults, in real processes

ACTUATORS_SAFE = {"v1_drive": 0.0, "v2_drive": -0.5, "v2_brake": True}
DRIVING = {"v1_drive": 1.0, "v2_drive": 2.0, "v2_brake": False}


segment_name = segment_names("fs")


def actuators(
    layout: ModuleType, buf: memoryview, names: Iterable[str] = ACTUATORS_SAFE
) -> dict[str, object]:
    return {name: world(layout, buf, name) for name in names}


def pids(layout: ModuleType, buf: memoryview) -> list[int]:
    return [int(read_whole(layout.PROCESSES[p], buf)["pid"]) for p in layout.PROCESSES]


def system_of(fleet: Path, package: ModuleType, spec: Path = FLEET) -> object:
    launcher = runtime(package, "rcs.operate.launcher")
    return launcher.System(
        fleet.name,
        runtime(package, "layout"),
        {p: runtime(package, f"main_{p}").PLAN for p in ("pl", "pa", "pb")},
        (str(fleet.parent), str(spec)),
    )


@pytest.fixture
def convoy(fleet: Path, package: ModuleType) -> Iterator[Callable[..., Any]]:
    """The fleet launched paced (three OS processes) and driving: lead in CONVOY S1, every
    actuator commanded. At the end: stopped, nothing left in /dev/shm, no process alive."""
    made: list[Any] = []
    seen: list[int] = []

    def launch(drive: bool = True, **options: object) -> Any:
        launcher = runtime(package, "rcs.operate.launcher").Launcher(
            system_of(fleet, package), segment_name(), **options
        )
        made.append(launcher)
        launcher.start()
        layout, buf = runtime(package, "layout"), launcher.block.buf
        seen.extend(pids(layout, buf))
        if drive:
            convoy_command(layout, buf)
            watch(launcher, lambda: actuators(layout, buf) == DRIVING, "the convoy driving")
        return launcher

    yield launch
    for launcher in made:
        segment = launcher.segment
        seen.extend(child.popen.pid for child in launcher.children.values())  # restarted ones
        launcher.stop()
        assert not os.path.exists(f"/dev/shm/{segment}"), "segment left behind"
    for pid in seen:
        wait_for(lambda pid=pid: not alive(pid), f"process {pid} gone", deadline=10)


def convoy_command(layout: ModuleType, buf: memoryview) -> None:
    """The operator's CONVOY to lead (the root)."""
    record = layout.COMMAND_IN["lead"]
    number = read_whole(record, buf)["command_num"] + 1
    record.write(buf, command_num=number, command=layout.COMMAND_NAMES["lead"].index("CONVOY"))


def lead_status(layout: ModuleType, buf: memoryview) -> tuple[str, int]:
    """lead's status by name and its error_num (1: LOST, the runtime's safe state)."""
    values = read_whole(layout.STATUS_OUT["lead"], buf)
    contract = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.contract"]
    return contract.STATUS_NAMES[values["status"]], int(values["error_num"])


def lost_mask(layout: ModuleType, buf: memoryview, watcher: str) -> int:
    return int(read_whole(layout.PROCESSES[watcher], buf)["lost"])


def watch(launcher: Any, condition: Callable[[], object], what: str, deadline: float = 20) -> None:
    """wait_for with the launcher watching meanwhile (its poll records every fault it sees);
    a wait that gives up says what the launcher saw, what is latched, and each process's
    lost mask and watchdog trips: a re-latch under load is named, not guessed at."""
    try:
        wait_for(lambda: launcher.poll() is not None and condition(), what, deadline)
    except AssertionError as error:
        raise AssertionError(f"{error}; {seen(launcher)}") from None


def seen(launcher: Any) -> str:
    layout = launcher.system.layout
    override = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.override"]
    buf = launcher.block.buf
    records = {p: read_whole(layout.PROCESSES[p], buf) for p in layout.PROCESSES}
    return (
        f"the launcher saw {launcher.events}; overrides {override.overrides(layout, buf)}; "
        + ", ".join(
            f"{p}: lost mask {r['lost']}, {r['watchdog_trips']} trips, {r['overruns']} overruns"
            for p, r in records.items()
        )
    )


@pytest.mark.parametrize("fault", ["kill", "stop"])
def test_a_dead_or_frozen_process_latches_every_actuator_and_halts_the_hierarchy(
    convoy: Callable[..., Any], package: ModuleType, fleet: Path, fault: str
) -> None:
    """kill -9 or SIGSTOP of pa (v1, on_lost: halt_all): the launcher and every other
    process see it lost; every actuator of the system is latched at its safe value (v2's
    too, though pb runs on), lead goes to its safe state (ERROR, LOST) though CONVOY's
    table ignores it; a frozen process that runs again beats, is no longer lost, and its
    outputs stay latched until an explicit reset."""
    launcher = convoy()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    override = runtime(package, "rcs.override")
    pa = launcher.children["pa"].popen
    pa.send_signal(signal.SIGKILL if fault == "kill" else signal.SIGSTOP)
    watch(launcher, lambda: actuators(layout, buf) == ACTUATORS_SAFE, "every actuator safe", 10)
    watch(launcher, lambda: lost_mask(layout, buf, "pl") & 0b010, "pl reports pa lost")
    watch(launcher, lambda: lead_status(layout, buf) == ("ERROR", 1), "lead ERROR(LOST)")
    sent = read_whole(layout.COMMAND_IN["v2"], buf)
    assert layout.COMMAND_NAMES["v2"][sent["command"]] == "HALT", "lead halted v2 too"
    assert set(override.overrides(layout, buf)) == set(ACTUATORS_SAFE)
    watch(launcher, lambda: launcher.halted, "the launcher saw it")
    # ISO 13850: no reset un-safes an actuator while its controller is not back, whether
    # all latches are named or only those of the survivor pb (v2_*: written by pb, alive)
    latched = override.overrides(layout, buf)
    for fields in (None, ["v2_drive", "v1_drive"]):
        with pytest.raises(override.OverrideError, match=r"writer is lost \(v1_drive by pa\)"):
            override.reset(layout, buf, fields, segment=launcher.segment)
        assert override.overrides(layout, buf) == latched, "a refused reset releases nothing"
    if fault == "kill":
        assert "pa died (exit -9)" in launcher.events
        # the operator's `ctl reset`: one line, exit 1 (refused), nothing released
        path = os.pathsep.join([str(fleet.parent), str(FLEET), *sys.path])
        reset = subprocess.run(
            [sys.executable, "-m", fleet.name, "ctl", "--shm", launcher.segment, "reset"],
            capture_output=True,
            text=True,
            env=dict(os.environ, PYTHONPATH=path),
            timeout=60,
        )
        assert reset.returncode == 1, reset.stdout
        assert reset.stderr.splitlines() == [
            "ctl: error: refused: a reset cannot release an actuator whose writer is lost "
            "(v1_drive by pa): restart pa first (or wait until it beats again)"
        ]
        assert override.overrides(layout, buf) == latched
        return
    assert any(e.startswith("pa lost: no heartbeat") for e in launcher.events)
    pa.send_signal(signal.SIGCONT)
    watch(launcher, lambda: not lost_mask(layout, buf, "pl") & 0b010, "pa beats again: not lost")
    watch(launcher, lambda: "pa" not in launcher.lost, "nor for the launcher")
    assert actuators(layout, buf) == ACTUATORS_SAFE, "latched: nothing un-safes them"
    assert override.reset(layout, buf, segment=launcher.segment) == list(ACTUATORS_SAFE)
    assert override.overrides(layout, buf) == {}


def test_the_survivor_keeps_going_when_its_supervisor_continues_on_a_loss(
    convoy: Callable[..., Any], package: ModuleType
) -> None:
    """kill -9 of pb (v2; lead declares on_lost: continue for it): only v2's actuators are
    latched; lead's own rules see v2 ERROR(LOST) and carry on ALONE with v1 still driving."""
    launcher = convoy()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    launcher.children["pb"].popen.send_signal(signal.SIGKILL)
    watch(launcher, lambda: world(layout, buf, "mode") == 2, "lead goes on ALONE")
    expected = {"v1_drive": 1.0, "v2_drive": -0.5, "v2_brake": True}
    assert actuators(layout, buf) == expected, seen(launcher)
    assert lead_status(layout, buf) == ("EXECUTING", 0)
    assert layout.STATE_NAMES["lead"][read_whole(layout.STATUS_OUT["lead"], buf)["state"]] == "S2"
    launcher.poll()
    assert not launcher.halted, "a contained loss does not halt the system"


def test_a_starved_process_trips_its_watchdog_and_latches_safe(
    convoy: Callable[..., Any], package: ModuleType
) -> None:
    """CPU starvation of pa (stopped and continued in a duty cycle: 10 ms of CPU in every
    300 ms, never silent as long as the heartbeat timeout): its watchdog adds up how late
    its cycles start and trips, and the trip latches every actuator safe."""
    launcher = convoy()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    pa = launcher.children["pa"].popen
    end = time.monotonic() + 10
    try:
        while time.monotonic() < end and actuators(layout, buf) != ACTUATORS_SAFE:
            pa.send_signal(signal.SIGSTOP)
            time.sleep(0.29)
            pa.send_signal(signal.SIGCONT)
            time.sleep(0.01)
    finally:
        pa.send_signal(signal.SIGCONT)
    assert actuators(layout, buf) == ACTUATORS_SAFE, seen(launcher)
    assert read_whole(layout.PROCESSES["pa"], buf)["watchdog_trips"] >= 1, seen(launcher)
    watch(launcher, lambda: launcher.halted, "the launcher saw it")


def test_a_restarted_process_resumes_its_command_with_its_outputs_latched(
    convoy: Callable[..., Any], package: ModuleType
) -> None:
    """--restart, pb killed mid-command: it is started again and resumes DRIVE from the
    block; its actuators stay latched safe (a restart does not un-safe them) until a reset,
    and a reset does not restart them: v2 drives again only when commanded again.

    The new pb is told from the dead one by its pid (the dead one's record keeps its
    heartbeat), and the reset waits until every watcher has seen it beat again: a reset
    while a watcher still holds pb lost is re-latched by that watcher, as it must be."""
    launcher = convoy(restart=True)
    layout, buf = runtime(package, "layout"), launcher.block.buf
    override, contract = runtime(package, "rcs.override"), runtime(package, "rcs.contract")
    launcher.children["pb"].popen.send_signal(signal.SIGKILL)
    restarted(launcher, "pb")
    record = layout.PROCESSES["pb"]
    v2 = read_whole(layout.STATUS_OUT["v2"], buf)
    assert layout.STATE_NAMES["v2"][v2["state"]] == "S1", "v2 resumed DRIVE"
    assert contract.STATUS_NAMES[v2["status"]] == "EXECUTING"
    assert v2["status_num"] == read_whole(layout.COMMAND_IN["v2"], buf)["command_num"]
    assert actuators(layout, buf, ["v2_drive", "v2_brake"]) == {"v2_drive": -0.5, "v2_brake": True}
    assert override.reset(layout, buf, segment=launcher.segment) == ["v2_drive", "v2_brake"]
    beat = read_whole(record, buf)["heartbeat"]
    watch(launcher, lambda: read_whole(record, buf)["heartbeat"] > beat + 5, "five cycles of pb")
    assert actuators(layout, buf, ["v2_drive", "v2_brake"]) == {"v2_drive": -0.5, "v2_brake": True}
    command = layout.COMMAND_IN["v2"]
    command.write(
        buf,
        command_num=read_whole(command, buf)["command_num"] + 1,
        command=layout.COMMAND_NAMES["v2"].index("DRIVE"),
    )
    watch(
        launcher,
        lambda: (
            actuators(layout, buf, ["v2_drive", "v2_brake"]) == {"v2_drive": 2.0, "v2_brake": False}
        ),
        "v2 driving again",
    )


def restarted(launcher: Any, name: str) -> int:
    """Wait, after `name` was killed, until the launcher has started it again, the new one
    (told by its pid: the dead one's record keeps its heartbeat) has run three cycles, and
    every watcher sees it beat again; its pid."""
    layout, buf = launcher.system.layout, launcher.block.buf
    contract = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.contract"]
    watch(launcher, lambda: launcher.children[name].restarts > 0, f"{name} restarted")
    new = launcher.children[name].popen.pid
    record = layout.PROCESSES[name]

    def running() -> bool:
        now = read_whole(record, buf)
        return bool(now["pid"] == new and now["state"] == contract.RUNNING and now["heartbeat"] > 3)

    watch(launcher, running, f"the new {name} running three cycles")
    bit = 1 << list(layout.PROCESSES).index(name)
    others = [p for p in layout.PROCESSES if p != name]
    watch(
        launcher,
        lambda: (
            not any(lost_mask(layout, buf, p) & bit for p in others) and name not in launcher.lost
        ),
        f"every watcher sees {name} beat again",
    )
    return new


def status_of(layout: ModuleType, buf: memoryview, module: str) -> tuple[str, str, str, bool]:
    """(its last command, its status, its state, whether it has echoed that command)."""
    contract = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.contract"]
    command, status = (
        read_whole(layout.COMMAND_IN[module], buf),
        read_whole(layout.STATUS_OUT[module], buf),
    )
    return (
        layout.COMMAND_NAMES[module][command["command"]],
        contract.STATUS_NAMES[status["status"]],
        layout.STATE_NAMES[module][status["state"]],
        status["status_num"] == command["command_num"],
    )


@pytest.mark.parametrize(
    ("victim", "point"),
    [("pa", "before"), ("pa", "mid"), ("pa", "after"), ("pb", "before"), ("pb", "after")],
)
def test_a_restart_at_each_point_of_a_command_keeps_the_outputs_safe_and_the_mission_told(
    convoy: Callable[..., Any], package: ModuleType, victim: str, point: str
) -> None:
    """--restart; a vehicle's process killed at each point of its DRIVE: `before` it has
    seen it (its process frozen when lead sends it), `mid` (driving), `after` it reported
    ERROR but before lead read it (pl frozen meanwhile; the vehicle's drive forced out of
    range). The launcher starts it again only once pl has seen it dead (pl frozen across
    the death: no restart meanwhile), or the loss could go unseen on a loaded machine.
    Every time, the actuators it leaves are latched safe and stay so through the
    restart and after a reset, and the mission never goes on silently:

    - pa (v1, halt_all): every actuator latched; lead ends CONVOY with ERROR(LOST) and the
      launcher has halted the system naming pa's death; the restarted v1 takes the last
      command in its buffer, the HALT of lead's safe state, never the DRIVE;
    - pb (v2, on_lost: continue): only v2's actuators latched; lead goes on ALONE with v1
      driving (its rules, told v2 was lost); the restarted v2 resumes what its buffers
      hold: the DRIVE it had not seen (run, its outputs still latched), or its ERROR, kept.

    pb mid-command is test_a_restarted_process_resumes_its_command_with_its_outputs_latched.
    """
    launcher = convoy(restart=True, drive=point != "before")
    layout, buf = runtime(package, "layout"), launcher.block.buf
    override = runtime(package, "rcs.override")
    vehicle = {"pa": "v1", "pb": "v2"}[victim]
    process = launcher.children[victim].popen
    pl = launcher.children["pl"].popen
    if point == "before":
        process.send_signal(signal.SIGSTOP)
        convoy_command(layout, buf)
        watch(launcher, lambda: status_of(layout, buf, vehicle)[0] == "DRIVE", "lead sends DRIVE")
        assert not status_of(layout, buf, vehicle)[3], f"{vehicle} has not seen it"
    elif point == "after":
        pl.send_signal(signal.SIGSTOP)
        field, out_of_range = {"v1": ("v1_drive", -1.0), "v2": ("v2_drive", 6.0)}[vehicle]
        override.force(layout, buf, field, out_of_range, launcher.segment)
        watch(
            launcher,
            lambda: status_of(layout, buf, vehicle) == ("DRIVE", "ERROR", "NOP", True),
            f"{vehicle} reports ERROR",
        )
    if point != "after":  # lead's process frozen across the death, for half its timeout
        pl.send_signal(signal.SIGSTOP)
        frozen_until = time.monotonic() + 0.5 * launcher.system.layout.HEARTBEAT_TIMEOUT
    process.send_signal(signal.SIGKILL)
    if point != "after":
        watch(launcher, lambda: f"{victim} died (exit -9)" in launcher.events, "the death seen")
        while time.monotonic() < frozen_until:  # restarted, it would unmark DEAD unseen
            launcher.poll()
            assert not launcher.children[victim].restarts, f"{victim} restarted before pl saw"
            time.sleep(0.01)
    pl.send_signal(signal.SIGCONT)
    restarted(launcher, victim)
    if victim == "pa":
        watch(launcher, lambda: lead_status(layout, buf) == ("ERROR", 1), "lead ERROR(LOST)")
        watch(
            launcher,
            lambda: status_of(layout, buf, "v1") == ("HALT", "DONE", "NOP", True),
            "the new v1 runs lead's HALT",
        )
        assert "pa died (exit -9)" in launcher.events and launcher.halted, seen(launcher)
        expected = ACTUATORS_SAFE
    else:
        watch(launcher, lambda: world(layout, buf, "mode") == 2, "lead goes on ALONE")
        assert lead_status(layout, buf) == ("EXECUTING", 0), seen(launcher)
        resumed = ("EXECUTING", "S1") if point == "before" else ("ERROR", "NOP")
        watch(
            launcher,
            lambda: status_of(layout, buf, "v2") == ("DRIVE", *resumed, True),
            f"v2 resumed: DRIVE {resumed}",
        )
        assert not launcher.halted, seen(launcher)
        expected = {"v1_drive": 1.0, "v2_drive": -0.5, "v2_brake": True}
    assert actuators(layout, buf) == expected, seen(launcher)
    latched = [f for f in ACTUATORS_SAFE if expected[f] == ACTUATORS_SAFE[f]]
    assert override.overrides(layout, buf) == {f: ("SAFE", expected[f]) for f in latched}
    assert override.reset(layout, buf, segment=launcher.segment) == latched
    record = layout.PROCESSES[victim]
    beat = read_whole(record, buf)["heartbeat"]
    watch(
        launcher,
        lambda: read_whole(record, buf)["heartbeat"] > beat + 5,
        f"five cycles of {victim}",
    )
    assert actuators(layout, buf) == expected, "a reset moves nothing"


# ---------------------------------------------------------------- the miner's restart rules

MINER = Path(__file__).resolve().parent.parent / "specs" / "miner"


@pytest.fixture(scope="module")
def miner() -> Iterator[tuple[Path, ModuleType]]:
    """specs/miner generated into a scratch directory: (the package's directory, it)."""
    scratch, name = generate(MINER)
    yield scratch / name, import_package(scratch / name, MINER)
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture
def mining(miner: tuple[Path, ModuleType]) -> Iterator[Any]:
    """The two-process miner launched paced with --restart, sent BOX_CUT and moving (an
    actuator away from its safe value). At the end: stopped, nothing left, nobody alive."""
    directory, package = miner
    launcher_module, layout = runtime(package, "rcs.operate.launcher"), runtime(package, "layout")
    system = launcher_module.System(
        directory.name,
        layout,
        {p: runtime(package, f"main_{p}").PLAN for p in layout.PROCESSES},
        (str(directory.parent), str(MINER)),
    )
    launcher = launcher_module.Launcher(system, segment_name(), restart=True)
    launcher.start()
    try:
        buf = launcher.block.buf
        send = launcher_module.parse_send(layout, "sec.BOX_CUT:depth=1.5")
        watch(launcher, lambda: launcher_module.give(send, layout, buf), "BOX_CUT sent")
        watch(launcher, lambda: moving(layout, buf), "the miner moving", deadline=60)
        yield launcher
    finally:
        started = [child.popen.pid for child in launcher.children.values()]
        segment = launcher.segment
        launcher.stop()
        assert not os.path.exists(f"/dev/shm/{segment}"), "segment left behind"
        for pid in started:
            wait_for(lambda pid=pid: not alive(pid), f"process {pid} gone", deadline=10)


def moving(layout: ModuleType, buf: memoryview) -> bool:
    return any(world(layout, buf, f) != v for f, v in layout.SAFE_VALUES.items())


def all_latched_safe(layout: ModuleType, buf: memoryview) -> bool:
    override = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.override"]
    held = override.overrides(layout, buf)
    return held == {f: ("SAFE", v) for f, v in layout.SAFE_VALUES.items()} and not moving(
        layout, buf
    )


def test_the_miner_s_pc1_refuses_a_restart_and_the_mission_ends_with_the_reason(
    mining: Any, capfd: pytest.CaptureFixture[str]
) -> None:
    """pc1 (every controller, actuator and simulator) killed mid-BOX_CUT with --restart: the
    launcher starts it again, and the new pc1 refuses, naming the simulator whose hook state
    (the simulated mine) a restart would lose; the launcher stops restarting it. Every
    actuator is latched safe, and the system is halted with the reason a `--send
    --until-done` prints (test_a_killed_pc1_ends_the_operator_s_mission_with_the_reason)."""
    launcher = mining
    layout, buf = launcher.system.layout, launcher.block.buf
    launcher.children["pc1"].popen.send_signal(signal.SIGKILL)
    watch(launcher, lambda: "pc1" not in launcher.children, "the launcher gives pc1 up")
    assert launcher.events[:2] == [
        "pc1 died (exit -9)",
        "latched safe: " + ", ".join(layout.SAFE_VALUES),
    ]
    assert "pc1 restarted" in launcher.events
    assert "pc1 refused to restart: see its error above" in launcher.events
    assert launcher.halted == "pc1 died (exit -9)"
    refusal = capfd.readouterr().err
    assert (
        "pc1: bas keeps hook state outside the block, which a restart of process pc1 would lose"
        in refusal
    )
    watch(launcher, lambda: all_latched_safe(layout, buf), "every actuator latched safe")
    assert "pc2" in launcher.children, "pc2 runs on (its supervisors in their safe state)"
    sec = read_whole(layout.STATUS_OUT["sec"], buf)
    assert sec["status"] != 2, "sec, in the dead pc1, never reports DONE"


def test_the_miner_s_pc2_resumes_after_a_restart_and_mines_again_when_commanded(
    mining: Any,
) -> None:
    """pc2 (the path planner, `hooks_state_on_restart: reset`) killed mid-BOX_CUT with
    --restart: halt_all latches every actuator and sec, the root, ends BOX_CUT with
    ERROR(LOST); the new pc2 starts, resumes, and every watcher sees it; the actuators stay
    latched until the operator's reset, the reset moves nothing, and the next BOX_CUT the
    operator sends moves the miner again."""
    launcher = mining
    layout, buf = launcher.system.layout, launcher.block.buf
    contract = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.contract"]
    override = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.override"]
    launcher.children["pc2"].popen.send_signal(signal.SIGKILL)
    restarted(launcher, "pc2")
    watch(launcher, lambda: all_latched_safe(layout, buf), "every actuator latched safe")
    sec = read_whole(layout.STATUS_OUT["sec"], buf)
    assert (contract.STATUS_NAMES[sec["status"]], sec["error_num"]) == ("ERROR", 1)
    assert launcher.halted == "pc2 died (exit -9)"
    assert override.reset(layout, buf, segment=launcher.segment) == list(layout.SAFE_VALUES)
    cycles = read_whole(layout.PROCESSES["pc1"], buf)["heartbeat"]
    watch(
        launcher, lambda: read_whole(layout.PROCESSES["pc1"], buf)["heartbeat"] > cycles + 5, "pc1"
    )
    assert not moving(layout, buf), "a reset moves nothing"
    launcher_module = sys.modules[layout.__name__.rsplit(".", 1)[0] + ".rcs.operate.launcher"]
    send = launcher_module.parse_send(layout, "sec.BOX_CUT:depth=1.5")
    watch(launcher, lambda: launcher_module.give(send, layout, buf), "BOX_CUT sent again")
    watch(launcher, lambda: moving(layout, buf), "the miner moving again", deadline=60)
    assert read_whole(layout.STATUS_OUT["sec"], buf)["status"] == 1, "sec EXECUTING its BOX_CUT"


def attach_when_made(package: ModuleType, layout: Any, segment: str) -> Any:
    """Attach to a segment another process is creating: its file exists a moment before its
    header is written, and an attach in between is (rightly) refused as not an rcsgen block."""
    return wait_for(attached(runtime(package, "rcs.block"), layout, segment), "the segment made")


def test_a_killed_pc1_ends_the_operator_s_mission_with_the_reason(
    miner: tuple[Path, ModuleType],
) -> None:
    """`python -m miner --restart --send sec.BOX_CUT:depth=1.5 --until-done`, pc1 killed
    while the miner moves: the run does not wait for a mission that cannot finish; it
    says why and exits 1."""
    directory, package = miner
    layout = runtime(package, "layout")
    segment = segment_name()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(directory.parent), str(MINER)]))
    command = [sys.executable, "-m", directory.name, "--shm", segment, "--restart"]
    command += ["--send", "sec.BOX_CUT:depth=1.5", "--until-done"]
    run = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    block = None
    try:
        block = attach_when_made(package, layout, segment)
        buf = block.buf
        wait_for(lambda: moving(layout, buf), "the miner moving", deadline=60)
        children = pids(layout, buf)
        os.kill(int(read_whole(layout.PROCESSES["pc1"], buf)["pid"]), signal.SIGKILL)
        out, err = run.communicate(timeout=60)
    finally:
        if run.poll() is None:
            run.kill()
            run.communicate()
        if block is not None:
            block.close()
    assert run.returncode == 1, err
    assert "sec did not finish: the system halted (pc1 died (exit -9))" in out
    assert "miner: pc1 died (exit -9)" in err
    for pid in children:
        wait_for(lambda pid=pid: not alive(pid), f"process {pid} gone", deadline=10)
    assert not os.path.exists(f"/dev/shm/{segment}")


def test_a_second_copy_of_a_process_is_refused_naming_the_owner(
    convoy: Callable[..., Any], package: ModuleType, fleet: Path
) -> None:
    launcher = convoy()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    owner = launcher.children["pb"].popen.pid
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(fleet.parent), str(FLEET), *sys.path]))
    second = subprocess.run(
        [sys.executable, "-m", fleet.name, "pb", "--shm", launcher.segment, "--attach"],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert second.returncode == 1
    assert f"process pb is already running (pid {owner}): a second copy is refused" in second.stderr
    assert read_whole(layout.PROCESSES["pb"], buf)["pid"] == owner
    assert actuators(layout, buf) == DRIVING, "nothing disturbed"


def test_a_process_that_never_starts_fails_the_start_up_barrier_by_name(
    fleet: Path, package: ModuleType, tmp_path: Path
) -> None:
    """pb exits before its first cycle: the launcher says which process is missing and
    how it ended, stops the others, and leaves no segment."""
    wrapper = tmp_path / "python"
    wrapper.write_text(
        f'#!/bin/sh\ncase " $* " in *" pb "*) exit 7;; esac\nexec {sys.executable} "$@"\n'
    )
    wrapper.chmod(0o755)
    launcher_module = runtime(package, "rcs.operate.launcher")
    launcher = launcher_module.Launcher(
        system_of(fleet, package), segment_name(), python=str(wrapper)
    )
    with pytest.raises(launcher_module.StartupFailed, match=r"pb \(exited 7\) did not start"):
        launcher.start()
    assert not os.path.exists(f"/dev/shm/{launcher.segment}")
    assert not launcher.children


def test_the_start_up_barrier_waits_the_declared_startup_timeout_then_names_the_missing(
    tmp_path: Path,
) -> None:
    """`startup_timeout: 5` in system.yaml reaches the layout and the launcher: pb hangs
    before its first cycle (its interpreter never starts); after 5 s (time enough for pl and
    pa to start on a loaded machine) the launch fails naming pb as not started, stops every
    process (pb too) and leaves no segment."""
    spec = tmp_path / "fleet"
    shutil.copytree(FLEET, spec)
    text = (spec / "system.yaml").read_text()
    (spec / "system.yaml").write_text(
        text.replace("heartbeat_timeout: 1.0\n", "heartbeat_timeout: 1.0\nstartup_timeout: 5\n")
    )
    scratch, name = generate(spec)
    try:
        package = import_package(scratch / name, spec)
        layout = runtime(package, "layout")
        assert layout.STARTUP_TIMEOUT == 5
        wrapper = tmp_path / "python"
        hang = 'case " $* " in *" pb "*) exec sleep 60;; esac'  # pb: a start that never ends
        wrapper.write_text(f'#!/bin/sh\n{hang}\nexec {sys.executable} "$@"\n')
        wrapper.chmod(0o755)
        launcher_module = runtime(package, "rcs.operate.launcher")
        launcher = launcher_module.Launcher(
            system_of(scratch / name, package, spec), segment_name(), python=str(wrapper)
        )
        began = time.monotonic()
        with pytest.raises(
            launcher_module.StartupFailed,
            match=r"not become ready within 5 s: pb \(no cycle yet\) did not start",
        ):
            launcher.start()
        assert time.monotonic() - began >= 5
        assert not os.path.exists(f"/dev/shm/{launcher.segment}")
        assert not launcher.children
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


@pytest.mark.parametrize("pa_is", ["running", "frozen", "stalled"])
def test_when_the_launcher_dies_its_children_drive_every_actuator_safe_and_clean_up(
    fleet: Path, package: ModuleType, pa_is: str
) -> None:
    """kill -9 of the launcher (`python -m fleet`): each child sees its pipe close, latches
    every actuator safe (the last line of defence does not depend on the launcher), stops,
    and the last one out removes the segment. With pa frozen first, the others still do it;
    pa, continued, stops too. With pa blocked for good in its hook, pa latches from its
    watcher's thread and, its loop never coming back, exits after STOP_GRACE: no child is
    left, whatever a hook does."""
    layout = runtime(package, "layout")
    segment = segment_name()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(fleet.parent), str(FLEET), *sys.path]))
    launcher = subprocess.Popen(
        [sys.executable, "-m", fleet.name, "--shm", segment],
        env=env,
        stderr=subprocess.DEVNULL,
    )
    block = None
    try:
        block = attach_when_made(package, layout, segment)
        buf = block.buf
        wait_for(
            lambda: all(
                read_whole(layout.PROCESSES[p], buf)["heartbeat"] > 2 for p in layout.PROCESSES
            ),
            "running",
        )
        children = pids(layout, buf)
        record = layout.COMMAND_IN["lead"]
        record.write(
            buf,
            command_num=read_whole(record, buf)["command_num"] + 1,
            command=layout.COMMAND_NAMES["lead"].index("CONVOY"),
        )
        wait_for(lambda: actuators(layout, buf) == DRIVING, "the convoy driving")
        pa = int(read_whole(layout.PROCESSES["pa"], buf)["pid"])
        if pa_is == "frozen":
            os.kill(pa, signal.SIGSTOP)
        elif pa_is == "stalled":
            layout.WORLD["v1_stall"].write(buf, v1_stall=True)
            beat = read_whole(layout.PROCESSES["pa"], buf)["heartbeat"]
            time.sleep(0.5)  # five periods: if pa still beats, it did not stall
            assert read_whole(layout.PROCESSES["pa"], buf)["heartbeat"] <= beat + 1, "pa stalled"
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(timeout=30)
        wait_for(lambda: actuators(layout, buf) == ACTUATORS_SAFE, "every actuator safe")
        if pa_is == "frozen":
            os.kill(pa, signal.SIGCONT)
        for pid in children:  # a stalled pa: STOP_GRACE (5 s), then it exits
            wait_for(lambda pid=pid: not alive(pid), f"child {pid} gone", deadline=30)
        wait_for(lambda: not os.path.exists(f"/dev/shm/{segment}"), "the segment removed")
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
        if block is not None:
            block.close()
        runtime(package, "rcs.block").unlink(segment)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
def test_a_child_learns_its_launcher_died_even_when_its_pipe_stays_open(
    fleet: Path, package: ModuleType
) -> None:
    """pa started by a stand-in launcher that hands the write end of pa's stdin pipe to
    another process (as a fork of a launcher would hold it): when the stand-in dies no EOF
    comes, and pa's parent-death signal tells it instead: every actuator latched safe, pa
    gone, the segment removed (pa, orphaned, is the last one out)."""
    layout, block_module = runtime(package, "layout"), runtime(package, "rcs.block")
    segment = segment_name()
    block = block_module.Block(layout, segment, create=True)
    block.owner = False  # pa removes it
    stand_in = (
        "import subprocess, sys, time\n"
        "child = subprocess.Popen(sys.argv[1:], stdin=subprocess.PIPE)\n"
        "keeper = subprocess.Popen(['sleep', '120'], pass_fds=[child.stdin.fileno()])\n"
        "print(child.pid, keeper.pid, flush=True)\n"
        "time.sleep(120)\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(fleet.parent), str(FLEET), *sys.path]))
    pa = [sys.executable, "-m", fleet.name, "pa", "--shm", segment, "--attach", "--child"]
    parent = subprocess.Popen(
        [sys.executable, "-c", stand_in, *pa], env=env, stdout=subprocess.PIPE, text=True
    )
    assert parent.stdout is not None
    child, keeper = (int(pid) for pid in parent.stdout.readline().split())
    buf = block.buf
    try:
        wait_for(lambda: read_whole(layout.PROCESSES["pa"], buf)["heartbeat"] > 2, "pa running")
        record = layout.COMMAND_IN["v1"]
        number = read_whole(record, buf)["command_num"] + 1
        record.write(buf, command_num=number, command=layout.COMMAND_NAMES["v1"].index("DRIVE"))
        wait_for(lambda: world(layout, buf, "v1_drive") == 1.0, "v1 driving")
        parent.kill()
        parent.wait(10)
        override = runtime(package, "rcs.override")
        wait_for(
            lambda: (
                actuators(layout, buf) == ACTUATORS_SAFE
                and set(override.overrides(layout, buf)) == set(ACTUATORS_SAFE)
            ),
            "every actuator latched safe",
        )
        wait_for(lambda: not alive(child), "pa gone", deadline=10)
        wait_for(lambda: not os.path.exists(f"/dev/shm/{segment}"), "the segment removed")
        assert alive(keeper), "the pipe's other end was open all along"
    finally:
        for pid in (child, keeper):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        parent.stdout.close()
        block.close()
        block_module.unlink(segment)


def test_a_latch_corrects_a_value_a_racing_write_changed(package: ModuleType) -> None:
    """latch_safe on a field already latched whose value a writer changed past its look at
    the flag writes the safe value again (a stopping process has no next cycle to do it);
    it is not counted as newly latched."""
    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    block = runtime(package, "rcs.block").Block(layout)
    assert override.latch_safe(layout, block.buf, ["v2_drive"]) == ["v2_drive"]
    layout.WORLD["v2_drive"].write(block.buf, v2_drive=2.0)  # the racing write
    assert override.latch_safe(layout, block.buf, ["v2_drive"]) == []
    assert world(layout, block.buf, "v2_drive") == -0.5


# ---------------------------------------------------------------- tests that catch a broken runtime


def test_the_watchdog_trips_when_the_recent_cycles_ran_five_periods_late_in_all(
    package: ModuleType,
) -> None:
    """The watchdog adds up how late the cycles of the last ten periods started: five periods
    in all trip it, whether the lateness came in one stall or in many (a starved process
    wakes late now and on time then: the cycles on time do not start the count again);
    jitter under a tenth of a period is not counted; lateness older than the window is
    forgotten; one cycle longer than three periods trips it at once. A trip starts the
    count again."""
    loop = runtime(package, "rcs.loop")
    now = [0.0]
    oversleep = [0.0]

    def sleep(seconds: float) -> None:
        now[0] += seconds + oversleep[0]

    pacer = loop.Pacer(0.1, clock=lambda: now[0], sleep=sleep)
    dog = loop.Watchdog()

    def cycle(took: float = 0.01, asleep: float = 0.0) -> bool:
        now[0] += took
        oversleep[0] = asleep
        pacer.wait()
        oversleep[0] = 0.0
        return bool(dog.trips(pacer, int(took * 1e9), 0.1))

    assert not any(cycle(asleep=0.009) for _ in range(30)), "jitter"
    assert pacer.behind(10) == 0 and pacer.late == 0
    trips = []
    for _ in range(4):  # 1.5 periods late, then a cycle on time
        trips += [cycle(asleep=0.15), cycle()]
    assert trips == [False] * 6 + [True, False], "6 periods late in 0.9 s"
    assert pacer.behind(10) == 0, "a trip starts the count again"
    for _ in range(3):
        assert not cycle(asleep=0.15)
    assert pacer.behind(10) == pytest.approx(4.5)
    for _ in range(11):  # a whole window on time: forgotten
        assert not cycle()
    assert pacer.behind(10) == 0
    assert not cycle(asleep=0.45), "one stall of 4.5 periods"
    for _ in range(11):
        cycle()
    assert cycle(asleep=0.55), "one stall of 5.5 periods"
    before = pacer.overruns
    now[0] = pacer.deadline + 3.0 - 0.01  # a 3 s stall, running
    pacer.wait()
    assert pacer.overruns == before + 30, "a stall counts each period it ran past"
    assert dog.trips(pacer, 50_000_000, 0.1)
    assert not cycle()
    assert not dog.trips(pacer, 290_000_000, 0.1)
    assert dog.trips(pacer, 310_000_000, 0.1), "one cycle longer than three periods"


def test_declared_watchdog_limits_reach_the_process_and_decide_its_trips(tmp_path: Path) -> None:
    """`watchdog:` of a process in system.yaml: pa declares one cycle may last 6 periods and
    10 periods of lateness may add up, so the 4-period cycle that trips the default limits
    (the test below) does not trip pa; its PLAN carries the limits, the process it runs
    uses them, and the limits left out keep their defaults."""
    spec = tmp_path / "fleet"
    shutil.copytree(FLEET, spec)
    system = spec / "system.yaml"
    text = system.read_text()
    old = "  pa:\n    modules: [v1]\n"
    assert old in text
    system.write_text(text.replace(old, old + "    watchdog: {period_factor: 6, behind: 10}\n", 1))
    scratch, name = generate(spec)
    try:
        package = import_package(scratch / name, spec)
        layout, loop = runtime(package, "layout"), runtime(package, "rcs.loop")
        plan = runtime(package, "main_pa").PLAN
        assert plan.watchdog == {"behind": 10.0, "period_factor": 6.0}
        assert runtime(package, "main_pb").PLAN.watchdog == {}
        assert loop.Watchdog(**plan.watchdog) == loop.Watchdog(behind=10.0, period_factor=6.0)
        assert (loop.Watchdog().window, loop.Watchdog().load_warning) == (10, 0.8)
        period = plan.cycle_period
        real = plan.classes["v1"]

        class Slow:
            def __init__(self, buf: memoryview, settings: dict[str, str] | None) -> None:
                self.module, self.cycles = real(buf, settings), 0

            def run_cycle(self, began: int = 0) -> int:
                self.cycles += 1
                if self.cycles == 4:
                    time.sleep(4 * period)
                return self.module.run_cycle(began)

            def resume(self) -> None:
                self.module.resume()

        slow = plan._replace(classes={**plan.classes, "v1": Slow})
        process = loop.run(slow, layout, cycles=6)
        try:
            record = layout.PROCESSES["pa"].read(process.block.buf)
        finally:
            process.block.close()
        assert record["overruns"] >= 3, "the long cycle missed its periods"
        assert record["watchdog_trips"] == 0, "within the declared limits"
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def test_a_paced_process_trips_from_its_second_cycle_on(package: ModuleType) -> None:
    """run: a first cycle four periods long (the start-up: cold code; the start-up barrier
    bounds it) does not trip the watchdog; the same cycle later does, once, and the trip
    latches pa's reaction (halt_all: every actuator of the system)."""
    layout, loop = runtime(package, "layout"), runtime(package, "rcs.loop")
    plan = runtime(package, "main_pa").PLAN
    period = plan.cycle_period
    slow_cycles = {1, 4}
    real = plan.classes["v1"]

    class Slow:
        def __init__(self, buf: memoryview, settings: dict[str, str] | None) -> None:
            self.module, self.cycles = real(buf, settings), 0

        def run_cycle(self, began: int = 0) -> int:
            self.cycles += 1
            if self.cycles in slow_cycles:
                time.sleep(4 * period)
            return self.module.run_cycle(began)

        def resume(self) -> None:
            self.module.resume()

    slow = plan._replace(classes={**plan.classes, "v1": Slow})
    trips: list[int] = []
    process = loop.run(
        slow,
        layout,
        cycles=6,
        on_cycle=lambda p: trips.append(p.counters["watchdog_trips"]) and False,
    )
    try:
        record = layout.PROCESSES["pa"].read(process.block.buf)
        overridden = runtime(package, "rcs.override").overrides(layout, process.block.buf)
    finally:
        process.block.close()
    assert record["overruns"] >= 8, "both long cycles missed their periods"
    assert record["watchdog_trips"] == 1, trips
    assert set(overridden) == set(ACTUATORS_SAFE), "a trip of pa: halt_all, every actuator"


def test_a_process_that_beats_again_is_no_longer_lost(package: ModuleType) -> None:
    """check_liveness with a clock in hand: pa silent past the timeout is lost (lead in its
    safe state, every actuator latched); pa beating again is no longer lost; the latches
    stay."""
    layout, override = runtime(package, "layout"), runtime(package, "rcs.override")
    loop = runtime(package, "rcs.loop")
    block = runtime(package, "rcs.block").Block(layout)
    pl = loop.Process(runtime(package, "main_pl").PLAN, layout, block)
    pa = layout.PROCESSES["pa"]
    pa.write(block.buf, state=2, heartbeat=10, beat_ns=1_000_000_000)
    pl.check_liveness(300_000_000, 1_200_000_000, ["pa"])
    assert "pa" not in pl.lost
    pl.check_liveness(300_000_000, 1_400_000_000, ["pa"])
    assert pl.lost == {"pa"}
    assert set(override.overrides(layout, block.buf)) == set(ACTUATORS_SAFE)
    pa.write(block.buf, heartbeat=11, beat_ns=1_390_000_000)
    pl.check_liveness(300_000_000, 1_400_000_000, ["pa"])
    assert pl.lost == set()
    pl.beat()
    assert layout.PROCESSES["pl"].read(block.buf)["lost"] == 0
    assert set(override.overrides(layout, block.buf)) == set(ACTUATORS_SAFE)


def test_a_segment_without_rcsgen_s_header_is_refused_on_attach(package: ModuleType) -> None:
    layout, block_module = runtime(package, "layout"), runtime(package, "rcs.block")
    name = segment_name()
    raw = block_module.Segment(name, layout.SIZE)
    try:
        with pytest.raises(block_module.BlockError, match="is not an rcsgen block"):
            block_module.Block(layout, name, create=False)
    finally:
        raw.close()
        block_module.unlink(name)


def seq_offsets(module: ModuleType) -> set[int]:
    """The offsets of the sequence words a generated module checks around its read."""
    return {word * 8 for word in module.SEQ_WORDS}


def test_every_input_another_process_writes_is_read_under_its_seqlock(package: ModuleType) -> None:
    """The command of a module supervised from another process (v1, v2) or of a root (lead:
    an operator's tool writes it), and the status of a subordinate in another process, are
    each read with their sequence word checked."""
    layout = runtime(package, "layout")
    lead, v1 = runtime(package, "lead"), runtime(package, "v1")
    assert seq_offsets(v1) == {layout.COMMAND_IN["v1"].offset}
    assert seq_offsets(lead) == {
        layout.COMMAND_IN["lead"].offset,
        layout.STATUS_OUT["v1"].offset,
        layout.STATUS_OUT["v2"].offset,
    }


class TornOnce:
    """Stands for a module's INPUTS struct: its first read lands in the middle of a write
    (the command's number from before the write, its code from after; the sequence word
    read first still even), and the write completes before the module reads the sequence
    words again. Every later read is a plain one."""

    def __init__(self, real: Any, write: Callable[[], None]) -> None:
        self.real, self.write, self.done = real, write, False

    def unpack_from(self, buf: memoryview, at: int) -> tuple[Any, ...]:
        before = self.real.unpack_from(buf, at)
        if self.done:
            return before  # type: ignore[no-any-return]
        self.done = True
        self.write()
        after = self.real.unpack_from(buf, at)
        changed = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
        torn = list(before)
        torn[changed[-1]] = after[changed[-1]]  # a field written, its sequence word not yet
        return tuple(torn)


def test_a_generated_module_never_accepts_a_read_torn_by_a_write(package: ModuleType) -> None:
    """A read that a write tore (the sequence word changed between the read and its second
    look at it) is read again: lead takes the whole new command, never the torn mix."""
    layout = runtime(package, "layout")
    lead_module = runtime(package, "lead")
    block = runtime(package, "rcs.block").Block(layout)
    record, names = layout.COMMAND_IN["lead"], layout.COMMAND_NAMES["lead"]
    record.write(block.buf, command_num=1, command=names.index("HALT"))
    lead = lead_module.LeadController(block.buf)
    assert (lead.command_num, lead.command) == (1, names.index("HALT"))

    def write() -> None:  # an operator's command arrives meanwhile
        record.write(block.buf, command_num=2, command=names.index("CONVOY"))

    real = lead_module.INPUTS
    lead_module.INPUTS = TornOnce(real, write)
    try:
        lead.run_cycle()  # its one look finds the read torn: read again, out of line
    finally:
        lead_module.INPUTS = real
    assert (lead.command_num, lead.command) == (2, names.index("CONVOY")), "a torn read accepted"
    assert lead.stale_reads == 0, "read again, whole, within READ_TRIES"


def test_a_first_read_that_stays_torn_leaves_the_module_stale_not_crashed(
    package: ModuleType,
) -> None:
    """v2's status buffer left odd (its writer died mid-write) before lead is made: lead's
    first read fails three times; lead is made, holds (no command taken, its table not run),
    counts the stale reads, and runs once the buffer is whole again."""
    layout, contract = runtime(package, "layout"), runtime(package, "rcs.contract")
    block = runtime(package, "rcs.block").Block(layout)
    buf, at = block.buf, layout.STATUS_OUT["v2"].offset
    contract.SEQ.pack_into(buf, at, contract.SEQ.unpack_from(buf, at)[0] + 1)  # odd: mid-write
    record = layout.COMMAND_IN["lead"]
    record.write(buf, command_num=1, command=layout.COMMAND_NAMES["lead"].index("CONVOY"))
    lead = runtime(package, "lead").LeadController(buf)
    assert lead.stale_reads == 1
    lead.run_cycle()
    assert lead.stale_reads == 2
    assert layout.COMMAND_IN["v1"].read(buf)["command_num"] == 0, "nothing sent while stale"
    contract.SEQ.pack_into(buf, at, contract.SEQ.unpack_from(buf, at)[0] + 1)  # whole again
    lead.run_cycle()
    assert layout.COMMAND_NAMES["v1"][layout.COMMAND_IN["v1"].read(buf)["command"]] == "DRIVE"


def test_a_trace_line_shows_the_overrides_only_while_there_are_some(package: ModuleType) -> None:
    from rcsgen.tools.scenario import trace_line

    override, layout = runtime(package, "rcs.override"), runtime(package, "layout")
    h = Harness(package, "pb")
    h.cycle()
    assert "overrides" not in json.loads(trace_line(h, ["v2_drive"]))
    override.latch_safe(layout, h.buf, ["v2_drive"])
    override.force(layout, h.buf, "mode", "ALONE")
    h.cycle()
    assert json.loads(trace_line(h, ["v2_drive"]))["overrides"] == {
        "mode": "FORCED",
        "v2_drive": "SAFE",
    }


@pytest.mark.parametrize(
    ("file", "old", "new", "code", "message"),
    [
        (
            "lead.yaml",
            "when: v2.status == ERROR and v1.status != ERROR",
            "when: v2.status == DONE and v1.status != ERROR",
            "E802",
            "CONVOY S1 waits on v2, whose loss `on_lost: continue` leaves to these rules",
        ),
        ("lead.yaml", "  v2: continue", "  v3: continue", "E802", "`on_lost` names `v3`"),
        (
            "system.yaml",
            "heartbeat_timeout: 1.0\n",
            "heartbeat_timeout: 1.0\nstartup_timeout: 0\n",
            "S005",
            "`startup_timeout`: must be greater than 0",
        ),
        (
            "system.yaml",
            "    initial: 0\n",
            "    initial: 0\n    safe: 3\n",
            "E801",
            "not an actuator",
        ),
    ],
)
def test_a_policy_or_safe_value_that_cannot_hold_is_refused_at_build(
    tmp_path: Path, file: str, old: str, new: str, code: str, message: str
) -> None:
    from rcsgen.compiler.frontend import compile_paths

    spec = tmp_path / "fleet"
    shutil.copytree(FLEET, spec)
    text = (spec / file).read_text()
    assert old in text
    (spec / file).write_text(text.replace(old, new, 1))
    found = [(d.code, d.message) for d in compile_paths([spec]).diagnostics.errors]
    assert any(c == code and message in m for c, m in found), found


# ---------------------------------------------------------------- lockstep


@pytest.mark.parametrize("fault", ["kill", "stop"])
def test_lockstep_never_waits_for_a_lost_process_and_latches_every_actuator(
    fleet: Path, package: ModuleType, fault: str
) -> None:
    """In lockstep, a process killed (kill -9) or stopped (SIGSTOP) between two cycles is
    lost at the next step: ProcessLost, the step bounded (a stopped process by the
    coordinator's timeout, here 2 s), every actuator of the block latched at its safe value
    at once (v1's drive it had set too); closing leaves no child and no segment."""
    from rcsgen.tools.harness import LaunchedHarness

    override = runtime(package, "rcs.override")
    h = LaunchedHarness(fleet, FLEET)
    lost = sys.modules[type(h.coordinator).__module__].ProcessLost
    pa = h.launcher.children["pa"].popen
    segment = h.launcher.segment
    try:
        h.command("lead", "CONVOY")  # both vehicles drive
        h.cycle(3)  # (at the default timeout: on a busy host a healthy step may take 2 s)
        h.coordinator.timeout = 2.0
        driving = {name: h.world[name] for name in ("v1_drive", "v2_drive", "v2_brake")}
        assert driving == {"v1_drive": 1.0, "v2_drive": 2.0, "v2_brake": False}
        pa.send_signal(signal.SIGKILL if fault == "kill" else signal.SIGSTOP)
        with pytest.raises(lost, match="did not answer within 2 s" if fault == "stop" else "pa"):
            h.cycle(3)
        safe = {"v1_drive": 0.0, "v2_drive": -0.5, "v2_brake": True}
        assert {name: h.world[name] for name in safe} == safe
        latched = override.overrides(h.layout, h.buf)
        assert {name: latched[name][0] for name in safe} == dict.fromkeys(safe, "SAFE")
    finally:
        if fault == "stop":
            pa.send_signal(signal.SIGCONT)  # its SIGTERM is then handled at once
        h.close()
    assert all(child.popen.poll() is not None for child in h.launcher.children.values())
    assert pa.poll() is not None
    assert not [p for p in Path("/dev/shm").glob(f"{segment}*")], "a segment left behind"


def _eventfds() -> int:
    fds = Path("/proc/self/fd")
    return sum(1 for fd in fds.iterdir() if "eventfd" in _link(fd))


def _link(path: Path) -> str:
    try:
        return os.readlink(path)
    except OSError:  # closed meanwhile (the listing's own fd)
        return ""


@pytest.mark.parametrize("fault", ["kill", "stop"])
def test_the_lockstep_ring_loses_a_process_holding_the_token(
    fleet: Path, package: ModuleType, fault: str
) -> None:
    """The token ring (rcs/ring.py): the token handed to the ring's second process, which
    is stopped (SIGSTOP) so it holds it, the first one having run its part of the cycle.
    Killed then, it is lost at once (its answer pipe closes: not the timeout); left
    stopped, within the coordinator's timeout (2 s here), named as the holder. Either way
    every actuator is latched safe, the ring refuses another cycle, and closing leaves no
    child, no segment, none of the ring's eventfds and not its page (memfd)."""
    import threading

    from rcsgen.tools.harness import LaunchedHarness

    eventfds, memfds = _eventfds(), _memfds()
    h = LaunchedHarness(fleet, FLEET)
    lost = sys.modules[type(h.coordinator).__module__].ProcessLost
    first, victim = h.launcher.order[:2]
    popen = h.launcher.children[victim].popen
    segment = h.launcher.segment
    beat = h.contract.BEAT
    record = h.layout.PROCESSES[first]
    errors: list[BaseException] = []

    def step() -> None:
        try:
            h.cycle(1)
        except BaseException as error:  # noqa: BLE001 - the test reads it
            errors.append(error)

    try:
        assert _eventfds() == eventfds + len(h.launcher.order) + 1
        assert _memfds() > memfds  # the ring's page
        h.command("lead", "CONVOY")
        h.cycle(3)  # (at the default timeout: on a busy host a healthy step may take 2 s)
        h.coordinator.timeout = 2.0
        popen.send_signal(signal.SIGSTOP)
        ran = beat.unpack_from(h.buf, record.offset)[4]
        stepping = threading.Thread(target=step, daemon=True)
        stepping.start()
        wait_for(
            lambda: beat.unpack_from(h.buf, record.offset)[4] > ran,
            f"{first} handing the token to {victim}",
        )
        if fault == "kill":
            popen.send_signal(signal.SIGKILL)
        stepping.join(30.0)
        assert not stepping.is_alive()
        assert len(errors) == 1 and isinstance(errors[0], lost), errors
        if fault == "kill":
            assert f"process {victim} stopped answering (it died?)" in str(errors[0])
        else:
            assert f"process {victim} did not answer within 2 s" in str(errors[0])
        safe = {"v1_drive": 0.0, "v2_drive": -0.5, "v2_brake": True}
        assert {name: h.world[name] for name in safe} == safe
        with pytest.raises(lost, match=victim):
            h.cycle(1)  # the ring is broken: no cycle after a loss
    finally:
        if fault == "stop":
            popen.send_signal(signal.SIGCONT)
        h.close()
    assert popen.poll() is not None
    assert all(child.popen.poll() is not None for child in h.launcher.children.values())
    assert not [p for p in Path("/dev/shm").glob(f"{segment}*")], "a segment left behind"
    assert _eventfds() == eventfds, "an eventfd of the ring left open"
    assert _memfds() == memfds, "the ring's page left open"


def _memfds() -> int:
    fds = Path("/proc/self/fd")
    return sum(1 for fd in fds.iterdir() if "memfd:rcs-ring" in _link(fd))


def test_a_ring_member_that_dies_while_the_next_one_spins_is_lost_and_nothing_spins_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The token ring on its page (rcs/ring.py) across real processes: member 0 takes the
    token and nudges member 1, which spins for it (its budget 60 s here, spinning forced:
    `Load` says a core is free); member 0 is killed holding the token. The coordinator,
    itself spinning on the return, sees the death at once (the answer pipe closes), not
    at its timeout; member 1, told to stop (its control pipe closes), stops spinning long
    before its budget and exits; no child is left, and the page is unmapped."""
    from rcsgen.runtime import ring

    monkeypatch.setattr(
        ring.Load, "core_free", lambda self, spinners=0: True
    )  # the forks inherit it
    memfds = _memfds()
    links = ring.new_links(3)
    page = ring.Page.create(3)
    assert page is not None and _memfds() > memfds  # its fd (and the mmap's own copy)
    controls, answers, pids = [], [], []
    for at in range(2):
        control, keep = os.pipe()
        answer, tell = os.pipe()
        pid = os.fork()
        if pid == 0:  # pragma: no cover - a member, in the child
            try:
                os.close(keep)
                os.close(answer)
                receiver = ring.Receiver(links[at].read, 60.0, page, at)
                nudge = ring.Nudge(links[at + 1].write, 60.0, page, at + 1)
                give = ring.Giver(links[at + 1].write, page, at + 1)
                ring.stop_on_control(control, links[at].write, page, at)
                while receiver.wait():
                    nudge()
                    if at == 0:
                        time.sleep(120)  # a long segment: it dies holding the token
                    give()
            finally:
                os._exit(0)
        os.close(control)
        os.close(tell)
        controls.append(keep)
        answers.append(answer)
        pids.append(pid)
    back = ring.Return(links[-1].read, answers, 60.0, page, 2)
    spinning = lambda: page.words[1 * ring.SLOT_WORDS + ring.SPINNING] == 1  # noqa: E731

    def nudged() -> bool:
        """Spinning for a while: the nudged spin (its budget 60 s), not the short eager one
        (50 µs and up) a waiter begins with, before member 0 may even have the token."""
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            if not spinning():
                return False
            time.sleep(0.01)
        return True

    try:
        ring.Giver(links[0].write, page, 0)()
        wait_for(nudged, "member 1 nudged by member 0, spinning")
        os.kill(pids[0], signal.SIGKILL)
        began = time.monotonic()
        assert back.wait(60.0) == answers[0]  # the death, not the timeout
        assert time.monotonic() - began < 30.0
        assert os.waitpid(pids[0], 0)[0] == pids.pop(0)  # reaped: not one to kill below
        assert spinning()  # member 1 spins on: the coordinator stops it
        for keep in controls:
            os.close(keep)
        controls = []
        began = time.monotonic()
        wait_for(lambda: os.waitpid(pids[0], os.WNOHANG)[0] == pids[0], "member 1 exits")
        assert time.monotonic() - began < 30.0  # told to stop, long before its 60 s spin
        pids = []
    finally:
        back.close()
        for keep in controls:
            os.close(keep)
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        for answer in answers:
            os.close(answer)
        ring.close_links(links)
        page.close()
    assert _memfds() == memfds, "the ring's page left open"
