"""Device faults in scenarios: `rcsgen run` against soft PLCs it starts (docs/io.md, "Scenarios").

A scenario's `devices:` serves the system's fieldbus devices with soft PLCs (separate OS
processes on free loopback ports), its run is paced at the cycle period, and its events
unplug, replug, freeze and thaw them. After a fault that takes a device down the run checks,
cycle by cycle, the lost-device reaction: the device LOST, its inputs stale and every
actuator latched safe within the device's timeout + 1 cycle, then held safe by the devices
still up (read back from them) by their next poll (E427 otherwise). Nothing is left: no
PLC process, no port (the run waits for each to close). The checks of the scenario file
itself (E426) are in tests/test_scenarios.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from conftest import rcsgen
from support.running import children

from rcsgen.tools import traces
from rcsgen.tools.scenario import read_trace

ROOT = Path(__file__).resolve().parent.parent
PLUG_PULL = ROOT / "specs" / "miner_hil" / "scenarios" / "plug_pull.yaml"
RIG = Path(__file__).resolve().parent / "fixtures" / "runtime" / "rig"


def softplcs() -> list[str]:
    """This test process's soft PLC children (none may be left after a run)."""
    return [c for c in children() if "rcsgen.tools.softplc" in c]


@pytest.mark.parametrize(
    ("scenario", "device", "stale", "survivor"),
    [
        ("plug_pull", "plc", ["pose_x", "boom_angle", "jack_down"], "conveyor"),
        ("conveyor_lost", "conveyor", ["tail_in_position"], "plc"),
    ],
)
def test_a_device_lost_mid_shear_stops_the_miner_safe_within_timeout_plus_one_cycle(
    tmp_path: Path, scenario: str, device: str, stale: list[str], survivor: str
) -> None:
    """specs/miner_hil/scenarios: the box cut on the soft PLC (the machine on Modbus TCP,
    the conveyor on OPC UA, one plant), one device's server stopped while the drum shears
    down the face: the run's own check finds the device lost, its inputs stale and every
    actuator latched safe within 0.5 s + 1 cycle (11 cycles of 0.05 s), the other device
    still up and holding the safe values, and the mission ends at the root with ERROR. The
    trace shows the same, cycle by cycle."""
    trace = tmp_path / f"{scenario}.jsonl"
    result = rcsgen("run", PLUG_PULL.with_name(f"{scenario}.yaml"), "--trace", trace)
    assert result.exit_code == 0, result.output
    assert "result    sec ERROR" in result.output
    said = [line for line in result.output.splitlines() if line.startswith("device    ")]
    assert len(said) == 1, said
    assert (
        f"{device} unplug before cycle 115: lost, inputs stale, every actuator latched "
        in (said[0])
    )
    text = read_trace(trace)
    # a paced run: its trace ends with how well it held its period (issue 24 item 4)
    assert traces.is_timing(text[-1]), text[-1]
    timing = json.loads(text[-1])
    assert timing["cycle"] == len(text) - 1 and timing["periodicity"]["period_ms"] == 50.0
    assert timing["periodicity"]["wakeups"] == len(text) - 2  # the first cycle starts it
    assert traces.parse("\n".join(text)).periodicity == timing["periodicity"]
    lines = [json.loads(line) for line in text[:-1]]
    # The fault comes at a fixed cycle (115): at the machine's pace that is mid-shear (the
    # boom going down, the conveyor running); on a starved host the plant, paced on its own,
    # may be a few cycles off, so this asks only that the drum is cutting in a
    # sump-shear-cusp. The safety checks above and below do not depend on the phase.
    before = lines[113]  # cycle 114, the last before the fault
    co = before["modules"]["co"]
    assert co["command"] == "SUMP_SHEAR_CUSP" and before["world"]["drum_on_cmd"] is True, before
    lost = next(line for line in lines if line["io"][device]["state"] == "LOST")
    assert lost["cycle"] - 114 <= 11, lost["cycle"]
    assert set(stale) <= set(lost["io"][device]["stale"])
    assert lost["io"][survivor]["state"] == "ONLINE" and lost["io"][survivor]["stale"] == []
    assert lost["overrides"]["drum_on_cmd"] == "SAFE" and lost["world"]["drum_on_cmd"] is False
    assert lines[-1]["modules"]["sec"]["status"] == "ERROR"
    assert softplcs() == []


@pytest.fixture
def rig(tmp_path: Path) -> Path:
    """A copy of the rig (tank on Modbus TCP, pumps on OPC UA), to hold scenarios."""
    copy = tmp_path / "rig"
    shutil.copytree(RIG, copy)
    (copy / "scenarios").mkdir()
    return copy


FREEZE = """
scenario: {name}
max_cycles: {cycles}
devices: {{tank: {{}}, pumps: {{}}}}
expect:
  figures: {{pump_on: false, alarm: true, valve_cmd: 0.0}}
events:
  - cycle: 1
    command: cell.RUN
  - cycle: 20
    device: {{name: tank, do: freeze}}
"""


def test_a_frozen_plc_s_survivor_holds_the_safe_values_and_a_run_too_short_is_e427(
    rig: Path, tmp_path: Path
) -> None:
    """The tank PLC frozen (it accepts, answers nothing), thawed later: within 0.5 s + 1
    cycle the tank is lost and the pumps' OPC UA server, still up, holds the pump off and
    the alarm lit (read back from it); the tank answers again once thawed. The same fault in
    a run that ends two cycles later cannot show the safe state: E427 at the fault."""
    (rig / "scenarios" / "freeze.yaml").write_text(
        FREEZE.format(name="freeze", cycles=45)
        + "  - cycle: 30\n    device: {name: tank, do: thaw}\n"
    )
    trace = tmp_path / "freeze.jsonl"
    result = rcsgen("run", rig / "scenarios" / "freeze.yaml", "--trace", trace)
    assert result.exit_code == 0, result.output
    assert "tank freeze before cycle 20: lost, inputs stale, every actuator latched safe " in (
        result.output
    )
    assert "held safe by the devices up" in result.output
    *cycles, timing = read_trace(trace)
    assert traces.is_timing(timing) and json.loads(timing)["periodicity"]["wakeups"] == 44
    last = json.loads(cycles[-1])
    assert last["io"]["tank"]["state"] == "ONLINE" and last["io"]["tank"]["reconnects"] >= 1
    assert last["overrides"] == dict.fromkeys(("alarm", "pump_on", "valve_cmd"), "SAFE")

    (rig / "scenarios" / "short.yaml").write_text(FREEZE.format(name="short", cycles=22))
    result = rcsgen("run", rig / "scenarios" / "short.yaml", "--trace", tmp_path / "short.jsonl")
    assert result.exit_code == 1, result.output
    assert "short.yaml:11:13: error[E427]: freeze of device `tank` before cycle 20: the run " in (
        result.output
    )
    assert "before its safe state was complete" in result.output
    assert softplcs() == []


def test_a_soft_plc_that_cannot_start_is_e428_at_its_device(rig: Path) -> None:
    """A plant whose world lacks the fields the device binds (the tiny system's, for the
    rig's tank): its soft PLC exits at start; the run stops before cycle 1 with E428 at the
    device, quoting the PLC's own line, and nothing is left running."""
    import os

    tiny = ROOT / "tests" / "cases" / "valid" / "tiny"
    plant = os.path.relpath(tiny, rig)
    (rig / "scenarios" / "bad_plant.yaml").write_text(
        f"scenario: bad_plant\nmax_cycles: 5\ndevices:\n  tank: {{plant: {plant}}}\n"
    )
    result = rcsgen("run", rig / "scenarios" / "bad_plant.yaml", "--trace", rig / "t.jsonl")
    assert result.exit_code == 1, result.output
    assert "bad_plant.yaml:4:3: error[E428]: the soft PLC of device `tank` did not start: " in (
        result.output
    )
    assert (
        "softplc: the plant has no world field 'valve_cmd' that device tank binds" in result.output
    )
    assert softplcs() == []
