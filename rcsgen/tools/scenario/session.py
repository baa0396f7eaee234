"""A scenario run as `rcsgen run` makes it: checked, packaged, run, stopped, written down.

Each step returns what the command line reports, in the order it reports it, and prints
nothing itself: `check` (the specs' and the scenario's diagnostics, one batch each),
`package` (the system rendered into a scratch directory, or a built one refused unless it
is current: E418), `execute` (the harness opened, the scenario run, the harness closed,
SIGINT and SIGTERM turned into an orderly stop that keeps the trace so far), then
`write_traces` (E419 for a trace that cannot be written) and `write_interrupted`.
"""

from __future__ import annotations

import contextlib
import signal
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from ...compiler.back_end import write
from ...compiler.diagnostics import Diagnostic, Diagnostics, Span
from ...compiler.frontend import compile_paths, display_path
from ...compiler.ir import IRSystem
from ..harness import AnyHarness, import_layout, write_package
from . import runs
from .check import check_scenario
from .devices import Bench
from .model import Scenario, declared_system, find_system_dir
from .run import LiveTrace, RunResult, interrupted_line, open_harness, run, write_trace


@dataclass
class Checked:
    """A scenario and the system it runs on, or the diagnostics that say why not (one
    batch per source: the specs', then the scenario's)."""

    scenario: Scenario | None = None
    system: IRSystem | None = None
    diagnostics: list[Diagnostics] = field(default_factory=list)


def check(path: Path) -> Checked:
    """The system above the scenario file at `path`, built from its specs, and the scenario
    checked against it (a system that does not build has an error among the diagnostics;
    without a system directory the scenario check reports E403)."""
    checked = Checked()
    system_dir = find_system_dir(path, declared_system(path))
    if system_dir is not None:
        front = compile_paths([system_dir])
        checked.diagnostics.append(front.diagnostics)
        if front.systems and not front.diagnostics.errors:
            checked.system = front.systems[0]
    if checked.system is not None or system_dir is None:
        checked.scenario, found = check_scenario(path, checked.system)
        checked.diagnostics.append(found)
    return checked


def package(
    system: IRSystem, generated: Path | None, scratch: Path
) -> tuple[Path, list[Diagnostic]]:
    """The package to run: the system rendered now into `scratch`, or the one in
    `generated`, with E418 (and the output's problems) unless it is exactly what the
    specs make."""
    if generated is None:
        return write_package(system, scratch), []
    plan, problems = write.plan_build([system], generated)
    stale = runs.stale_package(plan, generated, system.name)
    if problems.errors or stale is not None:
        return generated / system.name, [*problems.items, *([stale] if stale else [])]
    return generated / system.name, []


@dataclass
class Ran:
    """How a run ended: its result (and the world at the end), or the exception that
    stopped it and the cycle it was in, or the signal that interrupted it."""

    lines: list[str]  # the trace so far, a line per cycle that finished
    result: RunResult | None = None
    final_world: dict[str, Any] = field(default_factory=dict)
    failed: tuple[Exception, int] | None = None
    signal: int | None = None  # SIGINT or SIGTERM, when one stopped the run
    harness: AnyHarness | None = None  # the harness that ran (None: it never started)


def execute(
    scenario: Scenario,
    package_dir: Path,
    processes: bool,
    on_cycle: Callable[[AnyHarness], None],
    hooks_out: TextIO,
    live: Path | None = None,
) -> Ran:
    """Run `scenario` on the package (with `processes`, every process as its own OS process,
    in lockstep), what the hooks print going to `hooks_out`. SIGINT and SIGTERM stop the
    run where it is (the processes and the segment too) and keep the trace so far; `signal`
    says which came, even if a hook swallowed it. A second signal cannot cut the stop short.
    `live`: the trace file, written as the run goes (`LiveTrace`)."""
    lines = LiveTrace(live) if live is not None else []
    try:
        return _execute(scenario, package_dir, processes, on_cycle, hooks_out, lines)
    finally:
        if isinstance(lines, LiveTrace):
            lines.close()


def _execute(
    scenario: Scenario,
    package_dir: Path,
    processes: bool,
    on_cycle: Callable[[AnyHarness], None],
    hooks_out: TextIO,
    lines: list[str],
) -> Ran:
    ran = Ran(lines=lines)
    caught: list[int] = []

    def interrupt(signum: int, frame: object) -> None:
        caught.append(signum)
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
    with (
        contextlib.redirect_stdout(hooks_out),
        tempfile.TemporaryDirectory(prefix="rcsgen-devices-") as scratch,
    ):
        bench = Bench(scenario, package_dir, Path(scratch)) if scenario.devices else None
        try:
            if bench is not None:  # the soft PLCs first: the harness connects to them
                bench.start(import_layout(package_dir))
            harness = ran.harness = open_harness(scenario, package_dir, processes)
        except KeyboardInterrupt:  # what had started is stopped and removed already
            caught.append(caught[0] if caught else signal.SIGINT)
        except Exception as error:  # a hook-state factory, or a module that cannot be made
            if not caught:
                ran.failed = (error, 0)
        else:
            try:
                ran.result = run(scenario, harness, on_cycle, ran.lines, bench)
                ran.final_world = harness.world.snapshot()
            except KeyboardInterrupt:
                caught.append(caught[0] if caught else signal.SIGINT)
            except Exception as error:  # a hook, or a module's own code, in this cycle
                if not caught:  # (else a hook turned the interruption into its error)
                    ran.failed = (error, harness.cycles + 1)
            finally:  # a second signal must not cut the stop short (the segment stays)
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
                harness.close()
        finally:
            if bench is not None:  # after the harness: the devices' last writes are taken
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
                bench.close()
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    ran.signal = caught[0] if caught else None
    return ran


def write_traces(trace: list[str], paths: list[Path]) -> list[Diagnostic]:
    """Write the trace to each path; E419 for each that cannot be written."""
    problems = Diagnostics()
    for path in paths:
        try:
            write_trace(path, trace)
        except OSError as exc:
            where = Span(display_path(path))
            problems.error(where, "E419", f"cannot write trace `{path}`: {unwritable(path, exc)}")
    return problems.items


def unwritable(path: Path, error: OSError) -> str:
    """Why `path` cannot be written, in words: the folder on its way that is a file (the
    system's "File exists" or "Not a directory" says neither which nor why), else the
    system's reason."""
    if isinstance(error, (FileExistsError, NotADirectoryError)):
        for folder in reversed(path.parents):
            if folder.exists() and not folder.is_dir():
                return f"`{folder}` is a file, not a folder"
    return error.strerror or str(error)


def write_interrupted(ran: Ran, path: Path, signal_name: str) -> str:
    """The trace of an interrupted run, ended by a line saying so; what was written where
    (or why nothing could be)."""
    done = len(ran.lines)
    try:
        write_trace(path, [*ran.lines, interrupted_line(done + 1, signal_name)])
    except OSError as error:
        return f"cannot write trace `{path}`: {unwritable(path, error)}"
    if done:
        return f"{path} holds cycles 1-{done} and a last line saying so"
    return f"{path} holds only a line saying so"
