"""Shared fixtures for the CLI tests: a scratch copy of the foundation miner, its build."""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner, Result
from mutation_runtime import under_mutmut

from rcsgen.cli import main

if under_mutmut():  # `make mutate`: the runtime copies of generated packages hold the mutant
    from mutation_runtime import (  # noqa: F401
        pytest_collection_modifyitems,
        pytest_report_header,
        pytest_runtest_protocol,
        pytest_runtest_teardown,
        pytest_sessionfinish,
        pytest_sessionstart,
    )

REPO = Path(__file__).resolve().parent.parent
# The foundation issue's small miner, frozen as a fixture: the CLI tests mutate it.
MINER = REPO / "tests" / "fixtures" / "foundation" / "miner"


def rcsgen(*args: str | Path) -> Result:
    """Run the `rcsgen` command line in-process (in the current directory)."""
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert "Traceback" not in result.output, result.output
    return result


def wait_for(
    condition: Callable[[], object], what: str, deadline: float = 20.0, every: float = 0.01
) -> object:
    """Poll `condition` until it is true (its value); fail naming `what` after `deadline`
    seconds: how the tests of running systems wait, never asserting on wall-clock time."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(every)
    raise AssertionError(f"gave up waiting: {what}")


def edit(path: Path, old: str, new: str) -> str:
    """Replace the first `old` in a file by `new`; fails when `old` is not there."""
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{path.name} no longer contains {old!r}"
    text = text.replace(old, new, 1)
    path.write_text(text, encoding="utf-8")
    return text


def snapshot(root: Path) -> dict[str, bytes]:
    """Every file under `root` (symlinks followed), by relative path."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.fixture(scope="session")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bytes]:
    """The files `rcsgen build` makes from an unmodified copy of specs/miner."""
    base = tmp_path_factory.mktemp("pristine")
    shutil.copytree(MINER, base / "specs" / "miner")
    result = rcsgen("build", base / "specs", "-o", base / "generated")
    assert result.exit_code == 0, result.output
    files = snapshot(base / "generated")
    assert "miner/co.py" in files
    return files


@pytest.fixture
def work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, pristine: dict[str, bytes]) -> Path:
    """A scratch project: specs/miner (a copy) and its generated/ tree; the cwd is its root."""
    shutil.copytree(MINER, tmp_path / "specs" / "miner")
    for rel, data in pristine.items():
        path = tmp_path / "generated" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _our_segments() -> set[str]:
    """Shared-memory segments this test run creates: named after its pid, or the default
    segments of the systems it launches (`rcs_<system>_<layout hash>`)."""
    shm = Path("/dev/shm")
    if not shm.is_dir():
        return set()
    found = set(shm.glob(f"rcsgen_*{os.getpid()}*"))
    for system in ("miner", "duo", "pair"):
        found |= set(shm.glob(f"rcs_{system}_*"))
    return {p.name for p in found}


def _children() -> list[str]:
    """Processes whose parent is this test process (read from /proc), with their commands."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == os.getpid():
            try:
                found.append((stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode())
            except OSError:
                continue
    return [command for command in found if command]


@pytest.fixture(scope="session", autouse=True)
def nothing_left_behind():
    """After the whole suite: no shared-memory segment of ours is left in /dev/shm, and no
    child process of the test run survives (every launched system was stopped)."""
    before = _our_segments()
    yield
    left = _our_segments() - before
    assert not left, f"the suite left shared-memory segments behind: {sorted(left)}"
    survivors = [c for c in _children() if "resource_tracker" not in c]
    assert not survivors, f"child processes survived the suite: {survivors}"
