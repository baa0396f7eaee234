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
import shutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

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
    return layout.WORLD[name].read(buf)[name]


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
