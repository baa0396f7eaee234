"""Scenario: a scenario file -> a deterministic run of a generated system and its trace.

A scenario names the commands an operator gives and the world changes that happen, by
cycle number, and what to trace. Runs use the harness on a private block and no clock, so
the same scenario gives the same trace on every machine. Traces are JSON Lines, one
canonical line (sorted keys) per cycle: every module's command, command number, status,
status number, state and the rule that fired (with its reason and results, for a module
that declares them), and the world fields the scenario names. Never wall time.
"""

from __future__ import annotations

import importlib
import json
import math
import time
import zlib
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any, BinaryIO, Protocol

from ...compiler.diagnostics import Diagnostics, Span, SpecError
from ...compiler.front_end.loader import decode, read_bytes
from ...compiler.frontend import display_path
from ...runtime import override
from ...runtime.contract import PERIODICITY_FIELDS, field_names, periodicity
from ...runtime.io_points import COUNTS, device_status
from ...runtime.loop import Periodicity
from ...runtime.operate.ctl import channel_requests, write_answer
from .. import traces
from ..harness import AnyHarness, Harness, LaunchedHarness, Status
from .check import check_scenario
from .model import (
    TAKES_DOWN,
    DeviceFault,
    Event,
    Expected,
    OperatorScript,
    Scenario,
    ScriptedAnswer,
    find_system_dir,
)

__all__ = ["Event", "Expected", "OperatorScript", "Scenario", "ScriptedAnswer", "find_system_dir"]


class ScriptedPerson:
    """An `OperatorScript` played before each cycle: one person per operator module takes
    its open requests up one at a time, in the order they were asked (same cycle: in the
    layout's channel order), and answers each `after` cycles after taking it up, writing
    the answer record as `ctl answer` does; a request withdrawn meanwhile is dropped."""

    def __init__(self, script: OperatorScript) -> None:
        self.script = script
        self.queues: dict[str, list[tuple[str, int]]] = {}  # operator -> (channel, number)
        self.taken_up: dict[str, tuple[tuple[str, int], int]] = {}  # operator -> (head, at)

    def before_cycle(self, harness: AnyHarness) -> None:
        now = harness.cycles
        requests = channel_requests(harness.layout, harness.buf)
        open_now = {(r["name"], r["number"]): r for r in requests}
        for request in requests:
            queue = self.queues.setdefault(request["operator"], [])
            key = (request["name"], request["number"])
            if key not in queue and self.script.how(request) is not None:
                queue.append(key)
        for operator, queue in self.queues.items():
            queue[:] = [key for key in queue if key in open_now]
            while queue:
                head = queue[0]
                taken = self.taken_up.get(operator)
                if taken is None or taken[0] != head:
                    taken = self.taken_up[operator] = (head, now)
                how = self.script.how(open_now[head])
                assert how is not None
                if now - taken[1] < how.after:
                    break
                write_answer(
                    harness.layout,
                    harness.buf,
                    open_now[head],
                    how.answer,
                    how.reason,
                    dict(how.results),
                    typed=True,
                )
                queue.pop(0)


def load_scenario(path: Path) -> Scenario:
    """Read and check a scenario file against its system (the specs above it): raises
    SpecError with located diagnostics (the checks are in `check`)."""
    scenario, diags = check_scenario(path)
    if scenario is None or diags.errors:
        raise SpecError(diags)
    return scenario


def open_harness(
    scenario: Scenario, package_dir: Path, processes: bool = False, transport: str = "shm"
) -> AnyHarness:
    """The harness a scenario runs on: its process (or every process), settings and
    stand-ins, INIT sent. With `processes`, every process runs as its own OS process, in
    lockstep (close the harness to stop them), over one segment or (`transport="zenoh"`)
    each on its own block, connected through Zenoh."""
    if processes:
        return LaunchedHarness(
            package_dir, scenario.system_dir, scenario.settings, scenario.simulate, transport
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


class ScenarioError(Exception):
    """A scenario cannot go on as written: what happened, in one line."""


@dataclass
class RunResult:
    scenario: Scenario
    trace: list[str]
    cycles: int
    final: dict[str, Any]  # the stop module's last status
    phase_cycles: Counter[str]  # cycles per command of the `phases` module
    max_cycle_ns: dict[str, int]
    figures: dict[str, Any]  # the summary's figures at the end
    statuses: dict[str, Status] = field(default_factory=dict)  # every module's, at the end
    # after each device fault: the safe state seen within its bound (a line for the
    # summary), or not (where the fault is written, and what was missing)
    device_checks: list[str] = field(default_factory=list)
    device_failures: list[tuple[Span, str]] = field(default_factory=list)


def interrupted_line(cycle: int, signal_name: str) -> str:
    """The last line of a trace whose run was interrupted: the signal, and the cycle that
    did not finish (the lines above are the cycles before it)."""
    return json.dumps(
        {"cycle": cycle, "interrupted": signal_name}, sort_keys=True, separators=(",", ":")
    )


def final_value(name: str, world: dict[str, Any], statuses: dict[str, Status]) -> Any:
    """What a figure names at the end of a run: a world field, `<module>.reason` (its name)
    or `<module>.result.<name>`; None when the run has no such value."""
    module, dot, rest = name.partition(".")
    if not dot:
        return world.get(name)
    status = statuses.get(module)
    if status is None:
        return None
    if rest == "reason":
        return status.reason
    return status.results.get(rest.removeprefix("result."))


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
        if status.reason is not None:  # only modules that declare reasons
            modules[name]["reason"] = status.reason
        if status.cause:  # only while an ERROR has a cause: goldens keep their other lines
            modules[name]["cause"] = status.cause
        if status.results:  # every result slot of the module (docs/decisions.md)
            modules[name]["result"] = status.results
        if status.plans:  # modules with plans only: each plan's step, steps and replans left
            modules[name]["plans"] = status.plans
    line = {"cycle": harness.cycles, "modules": modules, "world": harness.world.snapshot(world)}
    held = harness.world.overrides()
    if held:  # world fields forced or latched safe (only then: goldens keep their shape)
        line["overrides"] = held
    devices = getattr(harness.layout, "IO_DEVICES", None)
    if devices:  # fieldbus I/O (only then): each device's state and counts
        line["io"] = {name: io_counts(harness, name, device) for name, device in devices.items()}
    return json.dumps(line, sort_keys=True, separators=(",", ":"))


def io_counts(harness: AnyHarness, name: str, device: Any) -> dict[str, Any]:
    """A device's state and counts (rcs/io_points.py) for a trace line."""
    values = dict(harness.layout.IO_RECORDS[name].read(harness.buf))
    shown = device_status(device, values, 0)
    return {key: shown[key] for key in ("state", *COUNTS, "stale")}


def _apply(harness: AnyHarness, event: Event) -> None:
    segment = harness.launcher.segment if isinstance(harness, LaunchedHarness) else None
    for name in event.unforce:  # as `ctl unforce`: the field's module writes it again
        override.unforce(harness.layout, harness.buf, name, segment)
    for name, value in event.force.items():  # as `ctl force`: its module keeps this value
        override.force(harness.layout, harness.buf, name, value, segment)
    harness.world.update(event.world)
    for module, status in event.replies.items():
        reply(harness, module, status)
    for module, mode in event.mode.items():
        harness.set_mode(module, **mode)
    if event.answer is not None:
        channel, status, reason = event.answer
        request = next(
            (r for r in channel_requests(harness.layout, harness.buf) if r["name"] == channel),
            None,
        )
        if request is None:
            raise ScenarioError(
                f"cycle {event.cycle}: `{channel}` has no open request to answer"
                + (f" ({event.doc})" if event.doc else "")
            )
        try:
            write_answer(
                harness.layout, harness.buf, request, status, reason, event.answer_results, True
            )
        except ValueError as error:  # results that fit another task of the channel
            raise ScenarioError(f"cycle {event.cycle}: `{channel}`: {error}") from None
    if event.command is not None:
        module, name = event.command
        # Under a supervisor (`overrides`) the command is written as an operator's: it stays
        # until the supervisor's next send, numbered after it (docs/semantics.md §12). The
        # supervisor's own memory is not touched: no running system could reach it.
        harness.command(module, name, **event.args)


def reply(harness: AnyHarness, module: str, status: str) -> None:
    """A scripted answer: `module`'s status buffer echoes the command it last received with
    `status` (`ERROR(REASON)`: with that reason); in one process the module takes it up as
    its own (so it does not echo that command again), as a stand-in answering in its place
    would; an operator module's channel (`op/fx`) is taken up by the operator module."""
    name, _, reason = status.partition("(")
    harness.reply(module, name, reason=reason.rstrip(")"))
    if isinstance(harness, Harness) and module in harness.modules:
        harness.controller(module.partition("/")[0]).resume()


class Devices(Protocol):
    """The soft PLCs of a scenario's `devices:` (tools/scenario/devices.py's Bench)."""

    def apply(self, name: str, do: str) -> None: ...

    def not_safe_on_survivors(self, layout: ModuleType) -> list[str]: ...


def cycle_period(harness: AnyHarness) -> float:
    """The system's cycle period, seconds (its processes' shortest)."""
    package = harness.layout.__name__.rsplit(".", 1)[0]
    plans = [importlib.import_module(f"{package}.main_{p}").PLAN for p in harness.layout.PROCESSES]
    return float(min(plan.cycle_period for plan in plans))


def safe_check(harness: Any, name: str) -> list[str]:
    """What is not yet as a lost device asks of the block (empty: all of it): the device
    LOST, every input field it feeds marked stale, every actuator of the system latched at
    its safe value (what the devices still up hold: `Bench.not_safe_on_survivors`)."""
    layout = harness.layout
    device = layout.IO_DEVICES[name]
    shown = io_counts(harness, name, device)
    missing = []
    if shown["state"] != "LOST":
        missing.append(f"device `{name}` is {shown['state']}, not LOST")
    inputs = [p.field for p in device.inputs]
    if sorted(shown["stale"]) != sorted(inputs):
        missing.append(f"its inputs marked stale are {shown['stale']}, not {inputs}")
    safe = dict(getattr(layout, "SAFE_VALUES", {}))
    world = harness.world.snapshot(list(safe))
    held = harness.world.overrides()
    for actuator, value in safe.items():
        if world[actuator] != value or held.get(actuator) != "SAFE":
            missing.append(f"`{actuator}` is {world[actuator]!r}, not latched at safe {value!r}")
    return missing


@dataclass
class Watched:
    """A fault being watched: when it was done, its two bounds (cycles after it), and the
    cycle the block's part of the reaction was complete (None: not yet)."""

    fault: DeviceFault
    at: int  # the cycles run when it was done (it came before cycle at + 1)
    bound: int  # the device LOST, its inputs stale, the actuators latched: timeout + 1 cycle
    reach: int  # the survivors holding the safe values: + their poll and 1 cycle more
    safe_after: int | None = None


class FaultWatch:
    """After each device fault that takes a device down (unplug, freeze), in cycles of the
    paced run: the device LOST, its inputs stale and every actuator latched at its safe
    value within the device's timeout + 1 cycle (devices.safe_check); then the devices
    still up holding those values (read back from them) by their next poll after the
    latch, + 1 cycle for the read-back (the device threads write the latched values at
    their own pace, never inside the cycle)."""

    def __init__(self, harness: AnyHarness, devices: Devices | None) -> None:
        self.period, self.devices = cycle_period(harness), devices
        self.open: list[Watched] = []
        self.checks: list[str] = []
        self.failures: list[tuple[Span, str]] = []
        self.pace = Pace(self.period)

    def event(self, harness: AnyHarness, event: Event) -> None:
        """A device event: done to its soft PLC now, and watched if it takes it down."""
        if event.device is None:
            return
        if self.devices is None:
            raise ScenarioError(f"cycle {event.cycle}: device events need the soft PLCs")
        self.devices.apply(event.device.name, event.device.do)
        self.fault(harness, event.device)

    def before_cycle(self) -> None:
        self.pace.wait()

    def finish(self, result: RunResult, harness: AnyHarness) -> None:
        """What was seen, into the result; a fault still open when the run ended fails."""
        result.device_checks, result.device_failures = self.checks, self.failures
        for w in self.open:
            result.device_failures.append(
                (
                    w.fault.span,
                    f"{w.fault.do} of device `{w.fault.name}` before cycle {w.at + 1}: the run "
                    f"ended {harness.cycles - w.at} cycles later, before its safe state was "
                    "complete",
                )
            )

    def timing(self, cycle: int) -> str | None:
        """The trace's timing record of the paced run."""
        return self.pace.line(cycle)

    def cycles(self, seconds: float) -> int:
        return math.ceil(seconds / self.period - 1e-9)

    def fault(self, harness: AnyHarness, fault: DeviceFault) -> None:
        if fault.do in TAKES_DOWN:
            devices = harness.layout.IO_DEVICES
            bound = self.cycles(devices[fault.name].timeout) + 1
            poll = max(d.poll_period for d in devices.values())
            self.open.append(Watched(fault, harness.cycles, bound, bound + self.cycles(poll) + 1))

    def after_cycle(self, harness: AnyHarness) -> None:
        still = []
        for watched in self.open:
            fault, after = watched.fault, harness.cycles - watched.at
            said = f"{fault.do} of device `{fault.name}` before cycle {watched.at + 1}"
            if watched.safe_after is None:
                missing = safe_check(harness, fault.name)
                if not missing:
                    watched.safe_after = after
                elif after >= watched.bound:
                    self.failures.append(
                        (fault.span, f"{said}: {after} cycles later {'; '.join(missing)}")
                    )
                    continue
            if watched.safe_after is not None:
                missing = self.devices.not_safe_on_survivors(harness.layout) if self.devices else []
                if not missing:
                    self.checks.append(
                        f"{fault.name} {fault.do} before cycle {watched.at + 1}: lost, inputs "
                        f"stale, every actuator latched safe {watched.safe_after} cycles later "
                        f"(bound {watched.bound}: timeout + 1 cycle), held safe by the devices "
                        f"up {after} cycles later (bound {watched.reach})"
                    )
                    continue
                if after >= watched.reach:
                    self.failures.append((fault.span, f"{said}: {'; '.join(missing)}"))
                    continue
            still.append(watched)
        self.open = still


class Pace:
    """Cycles at the system's period, on an absolute schedule (a late cycle is not caught up
    with a burst): a run against devices keeps time as they do. How well it held (each
    wake-up's lateness and period error) is measured as a paced process measures it
    (rcs/loop.py `Periodicity`), for the trace's last line."""

    def __init__(self, period: float) -> None:
        self.period, self.next_at = period, time.monotonic()
        self.periodicity = Periodicity("run", period)
        self.woke: float | None = None

    def wait(self) -> None:
        delay = self.next_at - time.monotonic()
        if delay > 0:
            time.sleep(delay)
            now = time.monotonic()
        else:
            now = self.next_at = time.monotonic()
        if self.woke is not None:  # the first cycle starts the schedule: nothing to measure
            self.periodicity.add(now, now - self.next_at, now - self.woke - self.period)
        self.woke = now
        self.next_at += self.period

    def line(self, cycle: int) -> str | None:
        """The trace's timing record (traces.TIMING), None before two paced cycles."""
        if not self.periodicity.count:
            return None
        self.periodicity.p99()
        names = field_names(PERIODICITY_FIELDS)
        figures = periodicity(dict(zip(names, self.periodicity.fields(), strict=True)))
        return json.dumps(
            {"cycle": cycle, traces.TIMING: figures}, sort_keys=True, separators=(",", ":")
        )


class Unwatched:
    """A run without devices: nothing to apply to them, no pacing, nothing to watch."""

    open: list[Watched] = []

    def event(self, harness: AnyHarness, event: Event) -> None:
        """(A device event needs `devices:`: the check refuses one without, E426.)"""

    def before_cycle(self) -> None:
        """Flat out: no clock."""

    def after_cycle(self, harness: AnyHarness) -> None:
        """Nothing watched."""

    def finish(self, result: RunResult, harness: AnyHarness) -> None:
        """Nothing to report."""

    def timing(self, cycle: int) -> str | None:
        """Not paced: no timing record (golden traces keep their shape)."""
        return None


def run(
    scenario: Scenario,
    harness: AnyHarness,
    on_cycle: Callable[[AnyHarness], None] | None = None,
    trace: list[str] | None = None,
    devices: Devices | None = None,
) -> RunResult:
    """Run a scenario to its stop condition (or `max_cycles`) and collect its trace, a line
    per cycle appended to `trace` as the run goes (so an interrupted run keeps what it
    ran). A scenario that serves devices (`devices`, its soft PLCs) runs paced, its device
    events applied to them, and each fault that takes a device down is watched until the
    safe state is complete or its bound has passed."""
    pending = list(scenario.events)
    person = ScriptedPerson(scenario.operator) if scenario.operator is not None else None
    stop = scenario.stop_when_done
    trace = [] if trace is None else trace
    phases: Counter[str] = Counter()
    watch = FaultWatch(harness, devices) if scenario.devices else Unwatched()
    while harness.cycles < scenario.max_cycles:
        while pending and pending[0].cycle <= harness.cycles + 1:
            event = pending.pop(0)
            _apply(harness, event)
            watch.event(harness, event)
        if person is not None:
            person.before_cycle(harness)
        watch.before_cycle()
        harness.cycle()
        trace.append(trace_line(harness, scenario.trace_world))
        if scenario.phases_of is not None:
            module = scenario.phases_of
            busy = harness.status(module).status == "EXECUTING"
            phases[harness.sent(module).command if busy else "idle"] += 1
        if on_cycle is not None:
            on_cycle(harness)
        watch.after_cycle(harness)
        if stop is not None and not pending and not watch.open and _finished(harness, stop):
            break
    timing = watch.timing(harness.cycles)
    if timing is not None:
        trace.append(timing)
    result = _result(scenario, harness, trace, phases)
    watch.finish(result, harness)
    return result


def _result(
    scenario: Scenario, harness: AnyHarness, trace: list[str], phases: Counter[str]
) -> RunResult:
    """What a run that ended leaves: the stop module's status, cycle times, figures."""
    stop = scenario.stop_when_done
    final = harness.status(stop).__dict__ if stop else {}
    modules = dict.fromkeys(m.split("/")[0] for m in harness.modules)  # an operator's once
    max_ns = {m: harness.performance(m)["max_cycle_ns"] for m in modules}
    statuses = {m: harness.status(m) for m in harness.modules}
    world = harness.world.snapshot([f for f in scenario.figures if "." not in f])
    figures = {name: final_value(name, world, statuses) for name in scenario.figures}
    return RunResult(scenario, trace, harness.cycles, final, phases, max_ns, figures, statuses)


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
    """The first differing cycle and field between two traces, or None when identical;
    a timing record (`traces.is_timing`) is left out of both."""
    expected = [line for line in expected if not traces.is_timing(line)]
    actual = [line for line in actual if not traces.is_timing(line)]
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


TRACE_LIMIT = 1 << 30  # bytes of text a trace (a golden one) may hold


def read_trace(path: Path) -> list[str]:
    """A trace file's lines (a golden trace's), plain or gzip-compressed; SpecError if it
    cannot be read."""
    shown = display_path(path)
    data = read_bytes(path, shown, TRACE_LIMIT)
    try:
        data = traces.decompressed(data, TRACE_LIMIT)
    except ValueError as error:
        diags = Diagnostics()
        diags.error(Span(shown), "E419", f"not a trace: {error}", "record it again")
        raise SpecError(diags) from None
    lines: list[str] = []
    try:  # as stored, a full line now and then and the changes in between (traces.stored)
        lines.extend(traces.expanded(decode(data, shown).splitlines()))
    except ValueError as error:  # (at the line after the last one expanded)
        diags = Diagnostics()
        diags.error(Span(shown, len(lines) + 1), "E419", f"not a trace: {error}", "record it again")
        raise SpecError(diags) from None
    return lines


class LiveTrace(list[str]):
    """A run's trace lines, each also written to the file at `path` as it comes (stored,
    flushed at once; the file made at the first cycle): a run killed outright (SIGKILL, a
    crash, the power) leaves a readable trace up to its last finished cycle. A `.gz` trace
    is one gzip stream flushed to a whole line each cycle (zlib's sync flush: the readers
    take a stream that stops there, `traces.read`). A file that cannot be written is left
    to the write at the end to report (E419). `rcsgen run` still writes the whole trace
    when the run ends."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path, self.condenser = path, traces.Condenser()
        self.stored: list[str] = []  # the lines as stored, one per line (for the final write)
        self.out: BinaryIO | None = None
        self.failed = False
        self.deflate = zlib.compressobj(wbits=31) if path.name.endswith(".gz") else None

    def append(self, line: str) -> None:
        super().append(line)
        self.stored.append(self.condenser.line(line))
        if self.failed:
            return
        data = (self.stored[-1] + "\n").encode("utf-8")
        if self.deflate is not None:
            data = self.deflate.compress(data) + self.deflate.flush(zlib.Z_SYNC_FLUSH)
        try:
            if self.out is None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self.out = self.path.open("wb")
            self.out.write(data)
            self.out.flush()
        except OSError:
            self.failed = True

    def close(self) -> None:
        if self.out is not None:
            self.out.close()


def write_trace(path: Path, lines: list[str]) -> None:
    """Write a trace as stored (traces.stored: a full line every KEYFRAME cycles, the
    changes in between), gzip-compressed when the name ends in `.gz`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    stored: Iterable[str] = traces.condensed(lines)
    if isinstance(lines, LiveTrace) and len(lines.stored) == len(lines):
        stored = lines.stored  # (condensed already, cycle by cycle)
    text = "".join(line + "\n" for line in stored)
    if path.name.endswith(".gz"):
        path.write_bytes(traces.compressed(text))
    else:
        path.write_text(text, encoding="utf-8")
