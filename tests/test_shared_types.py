"""One class per runtime type: rcsgen's own runtime and a generated package's copy of it
(`<system>/rcs/`), loaded in one process, agree on every exception and record class.

The monitor once showed a 175-line `StaleRead` traceback: the package's records raised the
package's `StaleRead` while rcsgen's console caught its own. Every exception class the
runtime defines (found by walking its modules, so a new one is covered too) and its record
types must be one class whichever copy defines it; a definition that differs keeps its own.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import shutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

import rcsgen.runtime
from rcsgen.runtime import contract
from rcsgen.tools.harness import generate, import_package

REPO = Path(__file__).resolve().parent.parent
DUO = REPO / "tests" / "fixtures" / "runtime" / "duo"
RIG = REPO / "tests" / "fixtures" / "runtime" / "rig"  # declares a Modbus and an OPC UA device
# the fieldbus links: copied only into a package whose system declares such a device
LINKS = {"io_modbus": "pymodbus", "io_opcua": "asyncua"}
RECORD_TYPES = {("contract", "Record"), ("loop", "ProcessPlan"), ("operate.command", "Command")}


@pytest.fixture(scope="module")
def package() -> Iterator[ModuleType]:
    scratch, name = generate(DUO)
    yield import_package(scratch / name, DUO)
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def rig() -> Iterator[ModuleType]:
    scratch, name = generate(RIG)
    yield import_package(scratch / name, RIG)
    shutil.rmtree(scratch, ignore_errors=True)


def runtime_modules() -> list[str]:
    """Every module of the runtime, its folders' too (`loop`, `operate.ctl`)."""
    prefix = "rcsgen.runtime."
    found = pkgutil.walk_packages(rcsgen.runtime.__path__, prefix)
    return sorted(m.name.removeprefix(prefix) for m in found if not m.ispkg)


def test_every_exception_and_record_type_is_one_class_in_both_copies(
    package: ModuleType, rig: ModuleType
) -> None:
    checked = []
    for name in runtime_modules():
        if name == "zenoh_transport":
            pytest.importorskip("zenoh")
        if name in LINKS:
            pytest.importorskip(LINKS[name])
        ours = importlib.import_module(f"rcsgen.runtime.{name}")
        copy = rig if name in LINKS else package
        theirs = importlib.import_module(f"{copy.__name__}.rcs.{name}")
        for cls_name, cls in vars(ours).items():
            if not inspect.isclass(cls) or not cls.__module__.endswith(f".{name}"):
                continue  # not a class, or one imported from another module
            if issubclass(cls, BaseException) or (name, cls_name) in RECORD_TYPES:
                assert getattr(theirs, cls_name) is cls, f"{name}.{cls_name} is two classes"
                checked.append(f"{name}.{cls_name}")
    # the exceptions this test was written for, and the records: all found by the walk
    for expected in (
        "contract.StaleRead",
        "contract.HookError",
        "contract.HookOverrun",
        "contract.Record",
        "block.BlockError",
        "operate.ctl.CtlError",
        "operate.command.Command",
        "loop.RestartRefused",
        "loop.ProcessPlan",
        "transport.TransportError",
        "operate.launcher.ProcessLost",
        "operate.deploy.DeployError",
        "operate.launcher.StartupFailed",
        "loop.DuplicateProcess",
        "override.OverrideError",
    ):
        assert expected in checked


def test_a_torn_record_of_the_package_is_caught_by_rcsgens_except(package: ModuleType) -> None:
    """The failure the monitor showed: a package's record raises, rcsgen's code catches."""
    layout = importlib.import_module(f"{package.__name__}.layout")
    buf = memoryview(bytearray(layout.SIZE))
    layout.initialise(buf)
    record = layout.COMMAND_IN["top"]
    buf[record.offset] = 1  # an odd sequence word: a write in progress that never ends
    with pytest.raises(contract.StaleRead):
        record.read(buf)


def test_a_different_definition_keeps_its_own_class() -> None:
    """A package of another rcsgen version must not borrow a class that behaves otherwise."""

    def make(message: str) -> type:
        source = (
            f"class StaleRead(Exception):\n    def describe(self):\n        return {message!r}\n"
        )
        space: dict[str, object] = {"__name__": "other.rcs.contract"}
        exec(source, space)  # a definition as another copy of the runtime would make it
        made = space["StaleRead"]
        assert isinstance(made, type)
        return contract.shared(made)

    one, same = make("torn"), make("torn")
    other = make("being written")
    assert one is same  # the same definition: one class
    assert other is not one and other is not contract.StaleRead
