"""The Python API: `rcsgen.check`, `rcsgen.build` and the names `rcsgen` exports."""

from __future__ import annotations

import importlib.metadata
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import MINER, snapshot

import rcsgen


def broken_copy(tmp_path: Path) -> Path:
    """A copy of the foundation miner whose co.yaml has an unknown key."""
    miner = tmp_path / "specs" / "miner"
    shutil.copytree(MINER, miner)
    with (miner / "co.yaml").open("a", encoding="utf-8") as handle:
        handle.write("bogus_key: 1\n")
    return miner


def test_check_returns_systems_and_diagnostics() -> None:
    result = rcsgen.check(MINER)
    assert [s.name for s in result.systems] == ["miner"]
    assert not result.diagnostics.errors
    assert all(isinstance(d, rcsgen.Diagnostic) for d in result.diagnostics)
    assert rcsgen.check([MINER]).diagnostics.items == result.diagnostics.items
    assert [s.name for s in rcsgen.check([str(MINER)]).systems] == ["miner"]


def test_check_reports_a_broken_spec_without_raising(tmp_path: Path) -> None:
    result = rcsgen.check([broken_copy(tmp_path)])
    assert result.systems == []
    [error] = result.diagnostics.errors
    assert (error.code, error.message) == ("S002", "unknown key `bogus_key`")
    assert error.span.file.endswith("co.yaml")


def test_build_writes_what_the_command_line_writes(
    tmp_path: Path, pristine: dict[str, bytes]
) -> None:
    out = tmp_path / "out"
    built = rcsgen.build([MINER], out)
    assert built.systems == ("miner",)
    assert built.output == out
    assert snapshot(out) == pristine
    assert sorted(p.relative_to(out).as_posix() for p in built.written) == sorted(pristine)
    assert (built.deleted, built.unchanged) == ((), 0)
    assert not built.diagnostics.errors and len(built.diagnostics)  # the miner's warnings

    again = rcsgen.build(MINER, str(out))
    assert (again.written, again.deleted, again.unchanged) == ((), (), len(pristine))


def test_build_deletes_what_it_no_longer_generates(tmp_path: Path) -> None:
    out = tmp_path / "out"
    rcsgen.build([MINER], out)
    stale = out / "miner" / "stale.py"
    shutil.copy(out / "miner" / "co.py", stale)  # as if an earlier build had written it:
    with (out / "miner" / ".rcsgen-manifest").open("a") as manifest:
        manifest.write("stale.py\n")  # its manifest lists it
    built = rcsgen.build([MINER], out)
    assert built.deleted == (stale,) and not stale.exists()


def test_build_never_deletes_a_file_it_did_not_write(tmp_path: Path) -> None:
    """A file with rcsgen's header that rcsgen did not write there (a copied module) stays."""
    out = tmp_path / "out"
    rcsgen.build([MINER], out)
    copied = out / "miner" / "my_copy_of_co.py"
    shutil.copy(out / "miner" / "co.py", copied)
    built = rcsgen.build([MINER], out)
    assert built.deleted == () and copied.read_bytes() == (out / "miner" / "co.py").read_bytes()


def test_build_with_an_error_raises_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with pytest.raises(rcsgen.SpecError) as caught:
        rcsgen.build([broken_copy(tmp_path)], out)
    assert isinstance(caught.value.diagnostics, rcsgen.Diagnostics)
    assert [d.code for d in caught.value.diagnostics.errors] == ["S002"]
    assert not out.exists()


def test_build_refuses_to_overwrite_a_users_file(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "miner").mkdir(parents=True)
    (out / "miner" / "co.py").write_text("# mine\n", encoding="utf-8")
    with pytest.raises(rcsgen.SpecError) as caught:
        rcsgen.build([MINER], out)
    assert [d.code for d in caught.value.diagnostics.errors] == ["E304"]
    assert sorted(p.name for p in (out / "miner").iterdir()) == ["co.py"]


def test_strict_build_fails_on_warnings(tmp_path: Path) -> None:
    with pytest.raises(rcsgen.SpecError) as caught:
        rcsgen.build([MINER], tmp_path / "out", strict=True)
    diagnostics = caught.value.diagnostics
    assert len(diagnostics) and not diagnostics.errors
    assert not (tmp_path / "out").exists()


def test_every_exported_name_resolves() -> None:
    assert sorted(rcsgen.__all__) == sorted(
        ["check", "build", "Harness", "Diagnostic", "Diagnostics", "SpecError", "__version__"]
    )
    for name in rcsgen.__all__:
        assert getattr(rcsgen, name) is not None, name
    assert set(rcsgen.__all__) <= set(dir(rcsgen))
    namespace: dict[str, object] = {}
    exec("from rcsgen import *", namespace)
    assert set(rcsgen.__all__) <= set(namespace)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        rcsgen.nope  # noqa: B018


def test_version_is_the_distributions() -> None:
    assert rcsgen.__version__ == importlib.metadata.version("rcsgen")


def test_import_rcsgen_loads_nothing_else() -> None:
    """`import rcsgen` stays cheap: no compiler, no yaml, jinja2, jsonschema or click."""
    code = "import sys, rcsgen; print(' '.join(sorted(sys.modules)))"
    loaded = set(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout.split()
    )
    assert sorted(m for m in loaded if m.startswith("rcsgen")) == ["rcsgen"]
    assert not loaded & {"yaml", "jinja2", "jsonschema", "click", "typing"}


def test_the_package_is_marked_typed() -> None:
    assert (Path(rcsgen.__file__).parent / "py.typed").is_file()


def test_checking_leaves_no_cyclic_garbage_and_restores_the_collector() -> None:
    """The front end runs with the cyclic collector off (rcsgen/compiler/collector.py): that
    is safe only while it makes no reference cycles it drops (the solver's self-calling
    search was one), and the collector must be back on afterwards."""
    import gc

    rcsgen.check(MINER)  # (first: imports and caches, which stay alive)
    gc.unfreeze()  # (all it froze, the test session's garbage too)
    gc.collect()
    gc.set_debug(gc.DEBUG_SAVEALL)
    try:
        result = rcsgen.check(MINER)
        assert gc.isenabled()
        gc.unfreeze()  # (what the front end left is frozen out of the collector's way)
        gc.collect()
        found = len(gc.garbage)  # (with DEBUG_SAVEALL: what every collection found, kept)
        kinds = sorted({type(item).__qualname__ for item in gc.garbage})
    finally:
        gc.set_debug(0)
        gc.garbage.clear()
    assert result.systems and not result.diagnostics.errors
    assert found == 0, f"cyclic garbage left by the front end: {kinds}"


def test_what_the_front_end_leaves_is_frozen_until_the_next_run() -> None:
    """Once checked, the system's objects are out of the collector's generations (no later
    collection walks them again, to free nothing); the next run hands them back, so garbage
    an earlier run left is still collected in the end."""
    import gc

    gc.unfreeze()
    result = rcsgen.check(MINER)
    system = result.systems[0]
    walked = {id(item) for item in gc.get_objects()}
    assert gc.isenabled() and gc.get_freeze_count() > 0
    assert id(system) not in walked and id(system.controllers[0]) not in walked
    seen: list[bool] = []  # whether the next run, as it started, had handed it back

    def progress(_: str) -> None:
        if not seen:
            seen.append(id(system) in {id(item) for item in gc.get_objects()})

    rcsgen.check(MINER, progress)
    assert seen == [True]
    gc.unfreeze()


def test_garbage_frozen_with_a_run_is_collected_once_the_heap_has_grown(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Freezing at a run's end takes along the cyclic garbage the process had not collected
    yet; a process that compiles again and again (the suite, the mutation sample's coverage
    run: 24 GiB, killed) must not keep it for good: once the heap has grown GROWTH times
    since the last full collection, the next run collects. (GROWTH lowered from 2 to 1.2
    here, so that a test worker's heap need not double.)"""
    import gc
    import sys
    import weakref

    from rcsgen.compiler import collector

    class Node:
        __slots__ = ("itself", "__weakref__")

    duo = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"
    rcsgen.check(duo)  # (a frozen heap to measure the next against)
    monkeypatch.setattr(collector, "GROWTH", 1.2)
    monkeypatch.setattr(collector, "_last", sys.getallocatedblocks())
    nodes = [Node() for _ in range(sys.getallocatedblocks() // 3)]
    for node in nodes:
        node.itself = node  # cycles: only the collector frees them
    gone = weakref.ref(nodes[0])
    del nodes, node  # (garbage the process has not collected when the next runs start)
    for _ in range(2):
        rcsgen.check(duo)
    gc.unfreeze()
    assert gone() is None, "cyclic garbage frozen with a run is never collected"


class _Collector:
    """A stand-in for the `gc` module: what `no_collections` asks of the collector, in order,
    and a heap whose size (in the allocator's blocks) the test sets."""

    def __init__(self, enabled: bool, blocks: int) -> None:
        self.enabled, self.blocks, self.calls = enabled, blocks, list[str]()
        self.left = blocks  # the heap a full collection leaves

    def isenabled(self) -> bool:
        return self.enabled

    def disable(self) -> None:
        self.enabled = False

    def enable(self) -> None:
        self.enabled = True
        self.calls.append("enable")

    def freeze(self) -> None:
        self.calls.append("freeze")

    def unfreeze(self) -> None:
        self.calls.append("unfreeze")

    def collect(self) -> int:
        self.calls.append("collect")
        self.blocks = self.left
        return 0

    def getallocatedblocks(self) -> int:  # (sys's, on the same heap)
        return self.blocks


def test_a_full_collection_comes_once_the_heap_has_more_than_doubled_since_the_last() -> None:
    """rcsgen/compiler/collector.py's policy, run by run in a process of its own (a fresh
    copy of the module): the first run measures the heap and collects nothing; a later run
    hands back what was frozen, and collects in full only once the heap is more than twice
    what the last collection left (GROWTH); a caller that had the collector off gets it
    back off, with nothing frozen or handed back."""
    import importlib.util

    from rcsgen.compiler import collector

    found = importlib.util.spec_from_file_location("fresh_collector", collector.__file__)
    assert found is not None and found.loader is not None
    fresh = importlib.util.module_from_spec(found)
    found.loader.exec_module(fresh)

    def run(enabled: bool, blocks: int, left: int = 0) -> list[str]:
        fake = _Collector(enabled, blocks)
        fake.left = left or blocks
        fresh.gc = fresh.sys = fake
        with fresh.no_collections():
            assert not fake.enabled
        assert fake.enabled is enabled
        return fake.calls

    assert fresh.GROWTH == 2 and fresh._last == 0
    assert run(True, 1000) == ["freeze", "enable"]  # the first: nothing to hand back
    assert fresh._last == 1000
    assert run(True, 2000) == ["unfreeze", "freeze", "enable"]  # doubled, not more
    assert fresh._last == 1000
    assert run(True, 2001, left=1500) == ["unfreeze", "collect", "freeze", "enable"]
    assert fresh._last == 1500  # (what survived the collection: the next measure)
    assert run(True, 3000) == ["unfreeze", "freeze", "enable"]
    assert run(False, 10_000) == []  # off when called: left off, nothing frozen
    assert fresh._last == 1500
