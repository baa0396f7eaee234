"""The layout's writer table (`WRITES`): every record a process writes into its own block.

Over Zenoh a process looks, after each cycle, only at the records its table names (the
rest of its block every slow push, ~0.1 s apart: rcs/transport.py `Mirror`), so a record a
process writes that the table leaves out would reach the other hosts late, and a lockstep
run's trace would differ. Here each shipped system runs one of its scenarios in one
process, each process's cycles watched apart: every record whose sequence word a process's
cycle moves is in its table; so is everything a process writes when it loses another
(the actuators latched safe) or stops.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from rcsgen.runtime.contract import SEQ
from rcsgen.runtime.transport import records
from rcsgen.tools.harness import Harness, import_layout
from rcsgen.tools.scenario import load_scenario, open_harness, run

ROOT = Path(__file__).resolve().parent.parent

# One scenario a system (miner_hil's need a device on the network: its table is built by
# the same code from the same facts, its I/O points the only addition, checked below)
SCENARIOS = {
    "cell": "plan_ahead",
    "inspection": "nominal_inspection",
    "miner": "sump_shear_cusp",
    "platoon": "lost_vehicle",
    "submarine": "ood_refuses",
}


def words(layout: ModuleType) -> Callable[[memoryview], dict[int, int]]:
    """Each record's sequence word in a block, by the record's offset."""
    offsets = sorted(record.offset for record in records(layout).values())
    return lambda buf: {at: SEQ.unpack_from(buf, at)[0] for at in offsets}


def moved(before: dict[int, int], after: dict[int, int]) -> set[int]:
    return {at for at, word in after.items() if before[at] != word}


def named(layout: ModuleType, offsets: set[int]) -> list[str]:
    where = {record.offset: key for key, record in records(layout).items()}
    return sorted(where[at] for at in offsets)


@pytest.mark.parametrize("system", sorted(SCENARIOS))
def test_every_record_a_process_writes_is_in_its_writer_table(system: str) -> None:
    scenario = load_scenario(ROOT / "specs" / system / "scenarios" / f"{SCENARIOS[system]}.yaml")
    harness = open_harness(scenario, ROOT / "generated" / system)
    assert isinstance(harness, Harness)
    layout, read = harness.layout, words(harness.layout)
    written: dict[str, set[int]] = {name: set() for name in harness.processes}
    for name, process in harness.processes.items():

        def watched(name: str = name, cycle: Callable[[], None] = process.run_cycle) -> None:
            before = read(harness.buf)
            cycle()
            written[name] |= moved(before, read(harness.buf))

        process.run_cycle = watched  # type: ignore[method-assign]
    try:
        run(scenario, harness)
        for name, process in harness.processes.items():  # a loss, then its own stop
            for other in harness.processes.keys() - {name}:
                before = read(harness.buf)
                process.react(other)
                written[name] |= moved(before, read(harness.buf))
            before = read(harness.buf)
            process.safe_stop(everything=True)
            written[name] |= moved(before, read(harness.buf))
    finally:
        harness.close()
    assert len(written) == len(layout.PROCESSES)
    for name, offsets in written.items():
        assert offsets, f"{name} wrote nothing"
        assert named(layout, offsets - set(layout.WRITES[name])) == [], name


def test_a_process_writes_its_io_devices_points() -> None:
    """miner_hil's I/O module writes its devices' points into the world fields."""
    layout = import_layout(ROOT / "generated" / "miner_hil")
    assert layout.IO_DEVICES
    for device in layout.IO_DEVICES.values():
        points = {layout.WORLD[p.field].offset for p in device.points}
        assert points <= set(layout.WRITES[device.process]), device.name
