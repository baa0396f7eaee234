"""Scenario: a scenario file -> a deterministic run of a generated system and its trace.

A scenario names the commands an operator gives and the world changes that happen, by
cycle number, and what to trace. Runs use the harness on a private block and no clock, so
the same scenario gives the same trace on every machine. Traces are JSON Lines, one
canonical line (sorted keys) per cycle: every module's command, command number, status,
status number and state, and the world fields the scenario names. Never wall time.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..compiler.diagnostics import Diagnostic, Diagnostics, Span, SpecError
from ..compiler.frontend import SYSTEM_FILE, display_path
from ..compiler.loader import LocDict, load_file, span_of, value_span
from .harness import AnyHarness, Harness, LaunchedHarness

SCENARIO_KEYS = {"scenario", "title", "doc", "process", "max_cycles", "stop_when_done", "trace"}
SCENARIO_KEYS |= {"events", "settings", "simulate", "report"}
EVENT_KEYS = {"cycle", "doc", "command", "with", "set", "mode"}


@dataclass
class Event:
    """What happens before cycle `cycle` runs: a command to a module, world or mode changes."""

    cycle: int
    command: tuple[str, str] | None = None  # (module, COMMAND)
    args: dict[str, Any] = field(default_factory=dict)
    world: dict[str, Any] = field(default_factory=dict)
    mode: dict[str, dict[str, Any]] = field(default_factory=dict)
    doc: str = ""


@dataclass
class Scenario:
    name: str
    title: str
    path: Path
    system_dir: Path
    process: str | None
    max_cycles: int
    stop_when_done: str | None
    trace_world: list[str]
    events: list[Event]
    settings: dict[str, str] = field(default_factory=dict)  # for the hook-state factories
    simulate: tuple[str, ...] = ()  # controllers replaced by their stand-ins
    phases_of: str | None = None  # the module whose commands are the run's phases
    figures: list[str] = field(default_factory=list)  # world fields the summary reports


def find_system_dir(path: Path) -> Path | None:
    for parent in path.resolve().parents:
        if (parent / SYSTEM_FILE).is_file():
            return parent
    return None


def load_scenario(path: Path) -> Scenario:
    """Read and check a scenario file; raises SpecError with located diagnostics."""
    shown = display_path(path)
    data = load_file(path, shown)
    diags = Diagnostics()
    top = span_of(data, Span(shown))
    if not isinstance(data, LocDict) or "scenario" not in data:
        raise SpecError([Diagnostic(top, "E401", "not a scenario file (no `scenario:` key)")])
    for key in sorted(set(data) - SCENARIO_KEYS):
        diags.error(data.key_spans.get(key, top), "E402", f"unknown scenario key `{key}`")
    system_dir = find_system_dir(path)
    if system_dir is None:
        diags.error(top, "E403", f"no {SYSTEM_FILE} above `{shown}`")
    events = []
    for index, raw in enumerate(data.get("events") or []):
        where = value_span(data["events"], index, top)
        if not isinstance(raw, LocDict) or not isinstance(raw.get("cycle"), int):
            diags.error(where, "E404", "an event needs `cycle: <number>`")
            continue
        for key in sorted(set(raw) - EVENT_KEYS):
            diags.error(raw.key_spans.get(key, where), "E402", f"unknown event key `{key}`")
        command = None
        if "command" in raw:
            module, _, name = str(raw["command"]).partition(".")
            command = (module, name)
        events.append(
            Event(
                cycle=raw["cycle"],
                command=command,
                args=dict(raw.get("with") or {}),
                world=dict(raw.get("set") or {}),
                mode={k: dict(v) for k, v in (raw.get("mode") or {}).items()},
                doc=str(raw.get("doc", "")),
            )
        )
    trace = data.get("trace") or {}
    report = data.get("report") or {}
    if diags.errors:
        raise SpecError(diags)
    return Scenario(
        name=str(data["scenario"]),
        title=str(data.get("title", "")),
        path=path,
        system_dir=system_dir or path.parent,
        process=data.get("process"),
        max_cycles=int(data.get("max_cycles", 1000)),
        stop_when_done=data.get("stop_when_done"),
        trace_world=[str(w) for w in trace.get("world") or []],
        events=sorted(events, key=lambda e: e.cycle),
        settings={str(k): str(v) for k, v in (data.get("settings") or {}).items()},
        simulate=tuple(str(m) for m in data.get("simulate") or ()),
        phases_of=report.get("phases"),
        figures=[str(f) for f in report.get("figures") or []],
    )


def open_harness(scenario: Scenario, package_dir: Path, processes: bool = False) -> AnyHarness:
    """The harness a scenario runs on: its process (or every process), settings and
    stand-ins, INIT sent. With `processes`, every process runs as its own OS process, in
    lockstep (close the harness to stop them)."""
    if processes:
        return LaunchedHarness(
            package_dir, scenario.system_dir, scenario.settings, scenario.simulate
        )
    return Harness.load(
        package_dir,
        scenario.system_dir,
        scenario.process,
        send_init=True,
        settings=scenario.settings,
        simulate=scenario.simulate,
    )


# ---------------------------------------------------------------- running


@dataclass
class RunResult:
    scenario: Scenario
    trace: list[str]
    cycles: int
    final: dict[str, Any]  # the stop module's last status
    phase_cycles: Counter[str]  # cycles per command of the `phases` module
    max_cycle_ns: dict[str, int]
    figures: dict[str, Any]  # the summary's world fields at the end


def trace_line(harness: AnyHarness, world: list[str]) -> str:
    """One canonical JSON line for the state of the system after the current cycle."""
    modules = {}
    for name in harness.modules:
        sent, status = harness.sent(name), harness.status(name)
        modules[name] = {
            "command": sent.command,
            "command_num": sent.number,
            "status": status.status,
            "status_num": status.number,
            "state": status.state,
            "rule": status.rule,
        }
    line = {"cycle": harness.cycles, "modules": modules, "world": harness.world.snapshot(world)}
    return json.dumps(line, sort_keys=True, separators=(",", ":"))


def _apply(harness: AnyHarness, event: Event) -> None:
    harness.world.update(event.world)
    for module, mode in event.mode.items():
        harness.set_mode(module, **mode)
    if event.command is not None:
        module, name = event.command
        harness.command(module, name, **event.args)


def run(
    scenario: Scenario,
    harness: AnyHarness,
    on_cycle: Callable[[AnyHarness], None] | None = None,
) -> RunResult:
    """Run a scenario to its stop condition (or `max_cycles`) and collect its trace."""
    pending = list(scenario.events)
    stop = scenario.stop_when_done
    trace: list[str] = []
    phases: Counter[str] = Counter()
    while harness.cycles < scenario.max_cycles:
        while pending and pending[0].cycle <= harness.cycles + 1:
            _apply(harness, pending.pop(0))
        harness.cycle()
        trace.append(trace_line(harness, scenario.trace_world))
        if scenario.phases_of is not None:
            module = scenario.phases_of
            busy = harness.status(module).status == "EXECUTING"
            phases[harness.sent(module).command if busy else "idle"] += 1
        if on_cycle is not None:
            on_cycle(harness)
        if stop is not None and not pending and _finished(harness, stop):
            break
    final = harness.status(stop).__dict__ if stop else {}
    max_ns = {m: harness.performance(m)["max_cycle_ns"] for m in harness.modules}
    figures = harness.world.snapshot(scenario.figures)
    return RunResult(scenario, trace, harness.cycles, final, phases, max_ns, figures)


def _finished(harness: AnyHarness, module: str) -> bool:
    status = harness.status(module)
    return status.number == harness.sent(module).number and status.status in ("DONE", "ERROR")


# ---------------------------------------------------------------- golden traces


@dataclass
class Mismatch:
    """The first place two traces differ."""

    cycle: int | None
    field: str
    expected: Any
    actual: Any

    def __str__(self) -> str:
        where = f"cycle {self.cycle}" if self.cycle is not None else "trace"
        return f"{where}: `{self.field}` expected {self.expected!r}, got {self.actual!r}"


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key in sorted(value):
            out.update(_flatten(value[key], f"{prefix}.{key}" if prefix else key))
        return out
    return {prefix: value}


def first_difference(expected: list[str], actual: list[str]) -> Mismatch | None:
    """The first differing cycle and field between two traces, or None when identical."""
    for want_line, got_line in zip(expected, actual, strict=False):
        if want_line == got_line:
            continue
        want, got = _flatten(json.loads(want_line)), _flatten(json.loads(got_line))
        for key in sorted(set(want) | set(got)):
            if want.get(key) != got.get(key):
                return Mismatch(want.get("cycle"), key, want.get(key), got.get(key))
    if len(expected) != len(actual):
        return Mismatch(None, "length", f"{len(expected)} cycles", f"{len(actual)} cycles")
    return None


def read_trace(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").splitlines()


def write_trace(path: Path, lines: list[str]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(line + "\n" for line in lines), encoding="utf-8")
