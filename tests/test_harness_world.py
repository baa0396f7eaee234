"""The harness's view of the world's overrides (rcsgen/tools/harness.py `World.overrides`), in
the unit tier on a layout made by hand: what a trace line shows under `overrides` and what
the device bench's fail-safe check reads (`held.get(...)`): every field forced or latched
safe by name, and an empty mapping, never None, while nothing is held (one byte read, so a
system without overrides pays nothing). And what `LaunchedHarness` hands its launcher, the
launcher stood in for (nothing started)."""

from __future__ import annotations

import importlib
import shutil
import sys
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import pytest

from rcsgen.tools import harness
from rcsgen.tools.harness import World

REPO = Path(__file__).resolve().parents[1]
INSPECTION, HOOKS = REPO / "generated" / "inspection", REPO / "specs" / "inspection"


class Record:
    def __init__(self, state: int) -> None:
        self.state = state

    def read(self, buf: object) -> dict[str, int]:
        return {"state": self.state}


def test_the_overrides_by_name_and_none_held_is_empty() -> None:
    layout = SimpleNamespace(
        OVERRIDDEN_AT=3, OVERRIDE={"a": Record(0), "b": Record(1), "c": Record(2)}, WORLD={}
    )
    buf = bytearray(8)
    assert World(layout, memoryview(buf)).overrides() == {}  # the flag byte clear: not read
    buf[3] = 1
    assert World(layout, memoryview(buf)).overrides() == {"b": "FORCED", "c": "SAFE"}
    layout.OVERRIDE["b"].state = 0
    assert World(layout, memoryview(buf)).overrides() == {"c": "SAFE"}
    older = SimpleNamespace(OVERRIDE={}, WORLD={})  # a package built before overrides
    assert World(older, memoryview(buf)).overrides() == {}


class Started(Exception):
    """The stand-in launcher's start: the harness got as far as starting its processes."""


def test_a_launched_harness_hands_its_launcher_the_settings_as_name_value(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`settings` reach the launcher as `name=value` (as `rcsgen run --set` gives them),
    none when none are given; a setting the system does not declare is refused first."""
    given: list[list[str]] = []
    importing = harness.import_package

    class Launcher:
        def __init__(self, system: Any, segment: str, **how: Any) -> None:
            given.append(how["settings"])

        def start(self) -> None:
            raise Started

    def imported(package_dir: Path, hooks_dir: Path | None = None) -> ModuleType:
        package = importing(package_dir, hooks_dir)
        launcher = importlib.import_module(f"{package.__name__}.rcs.operate.launcher")
        monkeypatch.setattr(launcher, "Launcher", Launcher)
        return package

    monkeypatch.setattr(harness, "import_package", imported)
    monkeypatch.setattr(sys, "path", list(sys.path))  # the hooks' directory put first: undone
    for settings in ({"seed": "7", "part": "worn"}, None):
        with pytest.raises(Started):
            harness.LaunchedHarness(INSPECTION, HOOKS, settings=settings)
    assert given == [["seed=7", "part=worn"], []]
    with pytest.raises(ValueError, match="inspection has no setting 'sed'"):
        harness.LaunchedHarness(INSPECTION, HOOKS, settings={"sed": "7"})
    assert len(given) == 2


def test_a_directory_without_a_generated_package_is_said_so(tmp_path: Path) -> None:
    """Not a traceback's `[Errno 2] ... __init__.py`: the directory named, as the soft PLC
    and the tools that import a package report it in one line."""
    for where in (tmp_path, tmp_path / "nowhere"):
        with pytest.raises(ImportError) as refused:
            harness.import_package(where)
        assert str(refused.value) == f"no generated package in {where}"


def test_a_command_written_is_read_back_with_its_arguments_by_name(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """What `command` writes into a module's command buffer, `sent` reads back: the command's
    name, its number and its arguments by their spec names; `results` a status buffer's;
    `reply` writes a status as the module would."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    h = harness.Harness(
        harness.import_package(REPO / "generated" / "cell", REPO / "specs" / "cell")
    )
    try:
        number = h.command("sup", "RUN", moves=3)
        assert h.sent("sup") == harness.Sent("RUN", number, {"moves": 3})
        assert h.sent("arm") == harness.Sent("NONE", 0, {})  # nothing sent yet
        # a module's results by their names, zero before it has run
        assert [h.results(m) for m in ("sup", "arm")] == [{"made": 0, "waited": 0}, {}]
        h.reply("sup", "DONE")  # as if it had run: its command number echoed, no reason
        assert (h.status("sup").status, h.status("sup").number) == ("DONE", number)
        assert h.status("sup").error_num == 0
    finally:
        h.close()


def test_the_stand_in_named_is_the_one_its_process_runs_in_the_modules_place() -> None:
    plans = {
        "pa": SimpleNamespace(stand_ins={}),
        "pb": SimpleNamespace(stand_ins={"cr": ("cr_sim", ("cr", "ct"))}),
    }
    assert harness.stand_in_of(plans, "cr") == "cr_sim"


def test_a_built_harness_removes_its_scratch_package_when_closed_or_finds_it_gone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`Harness.build` generates into a scratch directory of its own; closing removes it,
    closing twice is harmless, and a scratch something else removed already (a temporary
    files' cleaner, during a long run) is no error at the close."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    timed = REPO / "tests" / "fixtures" / "language" / "timed"
    h = harness.Harness.build(timed)
    scratch = Path(h.package.__file__ or "").parents[1]
    assert scratch.name.startswith("rcsgen-harness-") and scratch.is_dir()
    h.close()
    h.close()
    assert not scratch.exists()
    gone = harness.Harness.build(timed)
    shutil.rmtree(Path(gone.package.__file__ or "").parents[1])
    gone.close()
