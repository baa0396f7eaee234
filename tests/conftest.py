"""The suite's fixtures (shared helpers that are not fixtures are in tests/support/) and its
tiers: every test module belongs to one (TIERS; tests/README.md says what each is for), and
each test carries its tier's marker, so `pytest -m unit` runs one tier.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result
from mutation_runtime import under_mutmut
from support.running import children

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

# Each tier, what it is for, and its modules (tests/README.md says more).
TIERS: dict[str, tuple[str, tuple[str, ...]]] = {
    "unit": (
        "one stage or tool in process, on specs and files; no generated system runs",
        (
            "test_acknowledge",
            "test_analysis",
            "test_analysis_calls",
            "test_analysis_exact",
            "test_analysis_plans",
            "test_api",
            "test_architecture",
            "test_bench_report",
            "test_codes",
            "test_check_messages",
            "test_build_permissions",
            "test_config",
            "test_ctl_wait",
            "test_doc_sizes",
            "test_emit",
            "test_corpus",
            "test_files",
            "test_expression_messages",
            "test_expression_forms",
            "test_fragment_shapes",
            "test_frozen_values",
            "test_generated_current",
            "test_graph",
            "test_graph_render",
            "test_harness_world",
            "test_hook_annotations",
            "test_hook_deadline",
            "test_hooks_isolation",
            "test_hooks_read",
            "test_instances",
            "test_model_mut",
            "test_io_checks",
            "test_io_connect_errors",
            "test_loader",
            "test_lowered",
            "test_module_names",
            "test_mine_replay",
            "test_monitor_panels",
            "test_new",
            "test_operator_task_checks",
            "test_periodicity",
            "test_property_checks",
            "test_prove_bounds_text",
            "test_prove_seed_list",
            "test_prove_smv_ltl",
            "test_prove_small",
            "test_prove_world",
            "test_prove_lost",
            "test_prove_adapter",
            "test_prove_seed_verdicts",
            "test_prove_smv_export",
            "test_prove_catalogue",
            "test_prove_encode",
            "test_prove_text",
            "test_prove_graph",
            "test_prove_user_mut",
            "test_reference",
            "test_reference_current",
            "test_replay_scenario",
            "test_report",
            "test_report_exact",
            "test_reserved_names",
            "test_run_errors",
            "test_ring",
            "test_scenario_checks",
            "test_scenario_events_checked",
            "test_scenario_faults_checked",
            "test_scenario_model",
            "test_scenario_runner",
            "test_scenario_session",
            "test_scenario_verdicts",
            "test_scaffold_edits",
            "test_schema_grid",
            "test_schema",
            "test_sea_scene",
            "test_trace_checks",
            "test_trace_cut",
            "test_trace_payload",
            "test_trace_recording",
            "test_trace_stored",
            "test_station_mut",
            "test_tool_values",
            "test_type_words",
            "test_traces",
            "test_validate",
            "test_waiting",
        ),
    ),
    "system": (
        "a generated package built and run in one process (harness, scenarios, goldens)",
        (
            "test_build",
            "test_cell",
            "test_co_appendix_c",
            "test_fragments",
            "test_golden",
            "test_hook_contract",
            "test_injection",
            "test_inspection",
            "test_language",
            "test_mine_view",
            "test_miner",
            "test_monitor_screen",
            "test_operator",
            "test_operator_results",
            "test_state_time",
            "test_plans",
            "test_prove",
            "test_prove_numbers",
            "test_prove_operator_replay",
            "test_prove_properties",
            "test_prove_seeds",
            "test_prove_shortcuts",
            "test_reasons_survive",
            "test_process_writes",
            "test_results_visible",
            "test_run",
            "test_runtime_safety",
            "test_scenarios",
            "test_sea_view",
            "test_station_view",
            "test_semantics",
            "test_shared_types",
            "test_softplc",
            "test_submarine",
            "test_trace_view",
            "test_tutorial",
            "test_types",
        ),
    ),
    "processes": (
        "real OS processes over shared memory or Zenoh: faults, signals, the console",
        (
            "test_command_contract",
            "test_ctl",
            "test_deploy",
            "test_access",
            "test_failsafe",
            "test_io",
            "test_io_scenario",
            "test_platoon",
            "test_realtime",
            "test_monitor",
            "test_operate",
            "test_runtime",
            "test_runtime_mutants",
            "test_zenoh",
            "test_zenoh_security",
            "test_zenoh_faults",
        ),
    ),
    "fuzz": (
        "random inputs, a few hundred here and many more under `make fuzz`",
        (
            "test_differential",
            "test_expr",
            "test_fuzz",
            "test_prove_differential",
            "test_scenario_fuzz",
        ),
    ),
    "suite": ("the suite's own machinery (`make mutate`)", ("test_mutation",)),
}
_TIER_OF = {module: tier for tier, (_, modules) in TIERS.items() for module in modules}


def pytest_configure(config: pytest.Config) -> None:
    for tier, (purpose, _) in TIERS.items():
        config.addinivalue_line("markers", f"{tier}: {purpose}")
    # `make test` runs on two workers (pytest-xdist, --dist loadgroup): the processes tier
    # is one group, so its tests run one after another on one worker, never two systems'
    # watchdogs racing each other for the two cores; the other tiers share out module by module.
    config.addinivalue_line("markers", "xdist_group(name): tests that run on one worker")


def pytest_itemcollected(item: pytest.Item) -> None:
    module = Path(str(item.fspath)).stem
    if module not in _TIER_OF:
        raise pytest.UsageError(
            f"tests/{module}.py is in no tier: add it to TIERS in tests/conftest.py "
            "(tests/README.md says what each tier is for)"
        )
    item.add_marker(_TIER_OF[module])
    if _TIER_OF[module] == "processes":
        item.add_marker(pytest.mark.xdist_group("processes"))


# `make mutate-templates` (tests/mutation_templates.py): builds render from a scratch copy of
# the templates holding one mutant.
if os.environ.get("RCSGEN_MUTATE_TEMPLATES"):
    from rcsgen.compiler.back_end import emit

    emit.template_dir = lambda: Path(os.environ["RCSGEN_MUTATE_TEMPLATES"])  # type: ignore[assignment]

REPO = Path(__file__).resolve().parent.parent
# The foundation issue's small miner, frozen as a fixture: the CLI tests mutate it.
MINER = REPO / "tests" / "fixtures" / "foundation" / "miner"


def rcsgen(*args: str | Path) -> Result:
    """Run the `rcsgen` command line in-process (in the current directory)."""
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert "Traceback" not in result.output, result.output
    return result


class _Polls:
    """One bounded wait on a condition, for `wait_for` and `until`: each `poll` says the
    condition's value, a record caught mid-write (StaleRead: its writer was descheduled
    between the sequence word's two stores, or died) counting as not yet; `failed` names
    what was awaited, and the mid-write read if that was the last thing seen."""

    def __init__(self, condition: Callable[[], object], what: str, deadline: float) -> None:
        self.condition, self.what, self.end = condition, what, time.monotonic() + deadline
        self.stale: Exception | None = None

    def poll(self) -> object:
        from rcsgen.runtime.contract import StaleRead  # one class for every package's copy

        try:
            return self.condition()
        except StaleRead as error:
            self.stale = error
            return None

    def running(self) -> bool:
        return time.monotonic() < self.end

    def failed(self) -> AssertionError:
        last = f" (last read: {self.stale})" if self.stale else ""
        return AssertionError(f"gave up waiting: {self.what}{last}")


def wait_for(
    condition: Callable[[], object], what: str, deadline: float = 20.0, every: float = 0.01
) -> object:
    """Poll `condition` until it is true (its value); fail naming `what` after `deadline`
    seconds: how the tests of running systems wait, never asserting on wall-clock time. A
    record caught mid-write is not yet: polled again, and named if it never settles."""
    polls = _Polls(condition, what, deadline)
    while polls.running():
        value = polls.poll()
        if value:
            return value
        time.sleep(every)
    raise polls.failed()


async def until(
    pilot: Any, condition: Callable[[], object], what: str, deadline: float = 30.0
) -> object:
    """`wait_for` for a test that drives a Textual app (`pilot`; None: a bare asyncio
    loop): the app runs on between polls (its timers, its refresh, a pressed key's action),
    20 ms at a time, until `condition()` holds; never a fixed pause before an assertion."""
    polls = _Polls(condition, what, deadline)
    while polls.running():
        value = polls.poll()
        if value:
            return value
        await (asyncio.sleep(0.02) if pilot is None else pilot.pause(0.02))
    raise polls.failed()


def read_whole(record: Any, buf: memoryview, deadline: float = 20.0) -> dict[str, Any]:
    """A record of a running system, read whole: how a test reads one outside `wait_for`.
    A bare `record.read` raises StaleRead when it meets the record mid-write, and on a busy
    host its writer can be descheduled between the sequence word's two stores for longer
    than the read's few tries; this reads again until the record is whole, and fails naming
    it only when it stays mid-write `deadline` seconds (its writer died mid-write)."""
    found = wait_for(
        lambda: record.read(buf), f"the record at offset {record.offset} whole", deadline
    )
    return found  # type: ignore[return-value]


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


def _our_segments(systems: bool = True) -> set[str]:
    """Shared-memory segments this test run creates: named after its pid, or (`systems`) the
    default segments of the systems it launches (`rcs_<system>_<layout hash>`)."""
    shm = Path("/dev/shm")
    if not shm.is_dir():
        return set()
    found = set(shm.glob(f"rcsgen_*{os.getpid()}*"))
    for system in ("miner", "duo", "pair") if systems else ():
        found |= set(shm.glob(f"rcs_{system}_*"))
    return {p.name for p in found}


def _xdist_worker(config: pytest.Config) -> bool:
    return hasattr(config, "workerinput")


@pytest.fixture(scope="session", autouse=True)
def nothing_left_behind(request: pytest.FixtureRequest):
    """After the whole suite: no shared-memory segment of ours is left in /dev/shm, and no
    child process of the test run survives (every launched system was stopped). A worker of
    a parallel run checks its own segments and children; the systems' default segments,
    which another worker may hold at that moment, are checked once all workers have ended
    (`pytest_sessionfinish`)."""
    systems = not _xdist_worker(request.config)
    before = _our_segments(systems)
    yield
    left = _our_segments(systems) - before
    assert not left, f"the suite left shared-memory segments behind: {sorted(left)}"
    survivors = [c for c in children() if "resource_tracker" not in c]
    assert not survivors, f"child processes survived the suite: {survivors}"


def _parallel_controller(config: pytest.Config) -> bool:
    """The pytest-xdist controller of a parallel run (it runs no test itself)."""
    return not _xdist_worker(config) and getattr(config.option, "dist", "no") != "no"


_SYSTEM_SEGMENTS_BEFORE: set[str] = set()


def _note_system_segments(session: pytest.Session) -> None:
    if _parallel_controller(session.config):
        _SYSTEM_SEGMENTS_BEFORE.update(_our_segments())


def _no_system_segment_left(session: pytest.Session, exitstatus: int) -> None:
    """The controller of a parallel run: no system's default segment is left once every
    worker has ended (a run in one process checks them in `nothing_left_behind`)."""
    if not _parallel_controller(session.config):
        return
    left = _our_segments() - _SYSTEM_SEGMENTS_BEFORE
    if left:
        print(f"\nthe suite left shared-memory segments behind: {sorted(left)}")
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


if not under_mutmut():  # mutmut's own session hooks are imported above instead
    pytest_sessionstart = _note_system_segments
    pytest_sessionfinish = _no_system_segment_left
