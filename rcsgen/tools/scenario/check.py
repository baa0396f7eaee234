"""Scenario check: a scenario file -> located diagnostics and, when clean, the `Scenario`.

Scenario files get the spec's front end: the same located loader (strict YAML 1.2: `no` is a
string, never false), a JSON Schema (`compiler/schemas/scenario.schema.json`, the file
editors use: S001-S006), then checks against the system the scenario runs, before cycle 0:
every module, command, parameter (all of them, each of its type, ints within 64 bits), world
field, process, stand-in, trace field, report figure (a world field, or a module's `reason`
or `result.<name>`) and stop module exists and runs in that process; bool fields take only
true/false; cycles are within max_cycles and in order; a command to a module whose
supervisor runs is an error unless the event says it `overrides` the supervisor;
expectations name what the run can show. Every problem has a code (E401-E415; E285-E289
for the scripted operator and console answers) and, for names, a did-you-mean.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ...compiler.diagnostics import Diagnostics, Span, SpecError, known_names_hint, listed
from ...compiler.expressions import int_range_problem, text_problem_of
from ...compiler.front_end.loader import LocDict, key_span, load_file, span_of, value_span
from ...compiler.front_end.model import exact_cycles
from ...compiler.front_end.schema import check_document
from ...compiler.frontend import SYSTEM_FILE, compile_paths, display_path
from ...compiler.ir import IRController, IRProcess, IRSystem
from ...compiler.types import BOOL, INT, Bool, Enum, ReasonOf, Str, Type
from ...runtime.contract import range_problem
from ...runtime.operate.command import value_problem
from ..traces.read import whole_system
from .model import (
    DEVICE_ACTIONS,
    FREEZE,
    REPLUG,
    THAW,
    UNPLUG,
    DeviceFault,
    Event,
    Expected,
    OperatorScript,
    Scenario,
    ScriptedAnswer,
    SoftPlc,
    find_system_dir,
)

DEFAULT_MAX_CYCLES = 1000


def check_scenario(
    path: Path, system: IRSystem | None = None
) -> tuple[Scenario | None, Diagnostics]:
    """Load and check a scenario file. `system` is the system it runs (compiled from the
    specs above the file when not given). The Scenario is None when it has errors."""
    diags = Diagnostics()
    shown = display_path(path)
    try:
        data = load_file(path, shown)
    except SpecError as error:
        return None, error.diagnostics
    top = span_of(data, Span(shown))
    if data is None:
        hint = "write the scenario here (at least `scenario: <name>`), or delete the file"
        diags.error(top, "E013", f"`{path.name}` is empty: it holds no YAML", hint)
        return None, diags
    if not isinstance(data, LocDict) or "scenario" not in data:
        hint = "a scenario starts with `scenario: <name>`; see docs/spec.md section 10"
        diags.error(top, "E401", "not a scenario file (no `scenario:` key)", hint)
        return None, diags
    declared = data.get("system")
    system_dir = find_system_dir(path, declared)
    if system_dir is None and isinstance(declared, str):
        hint = "name the system's directory, relative to this file (the one with system.yaml)"
        where = value_span(data, "system", top)
        what = f"no {SYSTEM_FILE} in `{declared}` (this scenario's `system:`)"
        diags.error(where, "E403", what, hint)
    elif system_dir is None:
        hint = (
            "keep scenarios in the system's scenarios/ directory, or name the system's "
            "directory with `system:`"
        )
        diags.error(top, "E403", f"no {SYSTEM_FILE} above `{shown}`", hint)
    diags.extend(check_document(data, "scenario", shown))
    if diags.errors or system_dir is None:
        return None, diags
    if system is None:
        front = compile_paths([system_dir])
        if not front.systems:  # the specs have errors: `rcsgen validate` shows them
            hint = f"run `rcsgen validate {display_path(system_dir)}`"
            diags.error(top, "E403", "the system this scenario runs does not build", hint)
            return None, diags
        system = front.systems[0]
    checker = _Checker(data, system, diags, top)
    scenario = checker.check(path, system_dir)
    return (None if diags.errors else scenario), diags


def check_system_scenarios(directory: Path, system: IRSystem) -> Diagnostics:
    """Every scenario in `<system dir>/scenarios/` (what `rcsgen validate` checks)."""
    diags = Diagnostics()
    folder = directory / "scenarios"
    if not folder.is_dir():
        return diags
    for path in sorted(folder.glob("*.yaml")):
        _, found = check_scenario(path, system)
        diags.extend(found.items)
    return diags


# ---------------------------------------------------------------- the checks


@dataclass
class _Run:
    """The process a scenario runs, with stand-ins applied."""

    process: IRProcess
    running: list[str]  # the modules that run (a stand-in under its controller's name)
    skipped: dict[str, str]  # module -> the simulated controller whose stand-in replaces it


class _Checker:
    def __init__(self, data: LocDict, system: IRSystem, diags: Diagnostics, top: Span):
        self.data, self.system, self.diags, self.top = data, system, diags, top
        self.controllers = {c.name: c for c in system.controllers if c.buffers == c.name}
        self.operators = {c.name: c for c in system.controllers if c.is_operator}
        self.world = {f.name: f.type for f in system.world}

    def error(self, span: Span, code: str, message: str, hint: str = "") -> None:
        self.diags.error(span, code, message, hint)

    def span(self, container: object, key: str | int) -> Span:
        return value_span(container, key, span_of(container, self.top))

    # ------------------------------------------------------------ names

    def module(self, name: str, span: Span, run: _Run | None, what: str) -> IRController | None:
        """A controller the scenario names; E405 unknown, E414 not run in this scenario."""
        controller = self.controllers.get(name)
        if controller is None:
            self.error(
                span,
                "E405",
                f"{what} `{name}` is not a controller of `{self.system.name}`",
                known_names_hint("controllers", self.controllers, name),
            )
            return None
        if run is not None and name not in run.running:
            if name in run.skipped:
                why = f"`{run.skipped[name]}` is simulated, so its stand-in replaces `{name}`"
            else:
                why = f"process `{run.process.name}` does not run it"
            self.error(
                span,
                "E414",
                f"{what} `{name}` does not run in this scenario: {why}",
                f"modules that run: {', '.join(run.running)}",
            )
            return None
        return controller

    def field(self, name: str, span: Span, what: str) -> Type | None:
        """A world field's type; E409 when there is no such field."""
        kind = self.world.get(name)
        if kind is None:
            self.error(
                span,
                "E409",
                f"{what} `{name}` is not a world field of `{self.system.name}`",
                known_names_hint("world fields", self.world, name),
            )
        return kind

    def figure(self, name: str, span: Span, run: _Run | None, what: str) -> Type | None:
        """The type of what a figure names: a world field's (E409), or a module's
        `result.<name>` (E405/E414 for the module, E415 for the result), or `ReasonOf` the
        module for `<module>.reason` (E415 when the module declares no reasons)."""
        if "." not in name:
            return self.field(name, span, what)
        module, _, rest = name.partition(".")
        controller = self.module(module, span, run, f"{what}'s module")
        if controller is None:
            return None
        if rest == "reason":
            if not controller.reasons:
                self.error(
                    span,
                    "E415",
                    f"{what} `{name}`: `{module}` declares no reasons, so it never gives one",
                    "declare `reasons:` on its commands, or expect its `status`",
                )
                return None
            return ReasonOf(module)
        result = rest.removeprefix("result.")
        results = {r.name: r.type for r in controller.results}
        if result not in results:
            self.error(
                span,
                "E415",
                f"{what} `{name}`: `{module}` has no result `{result}`",
                known_names_hint(f"results of {module}", results, result),
            )
            return None
        return results[result]

    def reason(self, value: Any, module: str, span: Span) -> bool:
        """E408 unless `value` is a reason `module` can give (NONE, LOST or a declared one)."""
        names = [c.removeprefix("REASON_") for c, _ in self.controllers[module].reasons]
        if isinstance(value, str) and value in names:
            return True
        shown = _shown(value)
        hint = known_names_hint(f"reasons of {module}", names, str(value))
        self.error(span, "E408", f"`{shown}` is not a reason `{module}` can give", hint)
        return False

    def value(self, value: Any, kind: Type, span: Span, what: str) -> bool:
        """E408 unless `value` is of spec type `kind` (bool: true/false only; int: 64-bit; a
        float: a finite number; an enumeration: one of its value names; a string: one that
        fits its size): the one contract a command's values meet (rcs/operate/command.py), said
        as a scenario's author reads it."""
        names = kind.values if isinstance(kind, Enum) else ()
        if not value_problem(value, kind.code, names):
            return True
        hint = ""
        if names:
            problem = f"{what} is an enum: give one of {', '.join(names)}, not `{_shown(value)}`"
            hint = known_names_hint("values", names, str(value))
        elif isinstance(kind, Str):
            said = value_problem(value, kind.code)  # bytes that are not UTF-8 too
            said = said if "not text" in said else text_problem_of(value, kind)
            problem = f"{what} is a string of at most {kind.size} bytes: {said}"
        elif kind == BOOL:
            problem = f"{what} is a bool: give true or false, not `{_shown(value)}`"
        elif kind == INT and int_range_problem(value):
            problem = f"{what}: {int_range_problem(value)}"
        elif kind == INT:
            problem = f"{what} is an int: give a whole number, not `{_shown(value)}`"
        else:
            problem = f"{what} is a float: give a finite number, not `{_shown(value)}`"
        if isinstance(value, str) and value.lower() in ("yes", "no", "on", "off"):
            hint = f"`{value}` is a string in YAML 1.2; write true or false"
        self.error(span, "E408", problem, hint)
        return False

    # ------------------------------------------------------------ the file

    def check(self, path: Path, system_dir: Path) -> Scenario:
        data = self.data
        run = self.process()
        max_cycles = data.get("max_cycles", DEFAULT_MAX_CYCLES)
        stop = data.get("stop_when_done")
        if stop is not None:
            span = self.span(data, "stop_when_done")
            found = self.module(stop, span, run, "stop_when_done module")
            self.not_an_operator(found, span, "finishes no command of its own: stop on a client")
        trace = data.get("trace") or {}
        for index, name in enumerate(trace.get("world") or []):
            self.field(name, self.span(trace["world"], index), "trace field")
        report = data.get("report") or {}
        if "phases" in report:
            span = self.span(report, "phases")
            found = self.module(report["phases"], span, run, "phases module")
            self.not_an_operator(found, span, "has no phases of its own: name a client")
        for index, name in enumerate(report.get("figures") or []):
            self.figure(name, self.span(report["figures"], index), run, "report figure")
        expected = self.expectations(stop, run)
        self.served = self.devices(system_dir)
        events = self.events(run, max_cycles)
        script = self.operator_script() if "operator" in data else None
        settings = {
            str(k): (str(v).lower() if isinstance(v, bool) else str(v))
            for k, v in (data.get("settings") or {}).items()
        }
        self.settings(data.get("settings") or {})
        return Scenario(
            name=str(data["scenario"]),
            title=str(data.get("title", "")),
            path=path,
            system_dir=system_dir,
            process=run.process.name if run and "process" in self.data else None,
            max_cycles=max_cycles,
            stop_when_done=stop,
            trace_world=[str(w) for w in trace.get("world") or []],
            events=events,
            settings=settings,
            simulate=tuple(str(m) for m in data.get("simulate") or ()),
            phases_of=report.get("phases"),
            figures=[str(f) for f in report.get("figures") or []],
            expect=expected,
            operator=script,
            devices=self.served,
        )

    def settings(self, given: Any) -> None:
        """E424 for a setting the system does not take (`settings:` in system.yaml), the one
        check `--set` makes (rcs/operate/startup.py)."""
        declared = self.system.settings
        factories = any(c.hooks_state for c in self.system.controllers)
        for key in given:
            span = key_span(given, key, self.span(self.data, "settings"))
            if declared is not None and key not in dict(declared):
                names = [name for name, _ in declared]
                self.error(
                    span,
                    "E424",
                    f"`{self.system.name}` has no setting `{key}`",
                    known_names_hint("settings", names, str(key))
                    if names
                    else "it declares none (system.yaml `settings:`)",
                )
            elif declared is None and not factories:
                self.error(
                    span,
                    "E424",
                    f"`{self.system.name}` reads no setting `{key}`: none of its controllers "
                    "has a `hooks_state` factory",
                    "remove `settings:`",
                )

    def process(self) -> _Run | None:
        """The process the scenario runs and the stand-ins it uses (E410, E411)."""
        processes = {p.name: p for p in self.system.processes}
        name = self.data.get("process")
        if name is None:  # every process, as one run: process by process
            process = whole_system(self.system)
        elif name in processes:
            process = processes[name]
        else:
            self.error(
                self.span(self.data, "process"),
                "E410",
                f"`{self.system.name}` has no process `{name}`",
                known_names_hint("processes", processes, name),
            )
            return None
        skipped: dict[str, str] = {}
        simulate = self.data.get("simulate") or []
        for index, module in enumerate(simulate):
            span = self.span(simulate, index)
            stand_in = process.stand_ins.get(module)
            if module not in self.controllers:
                self.module(module, span, None, "simulated controller")
            elif stand_in is None:
                others = {n for p in self.system.processes for n in p.stand_ins}
                why = (
                    f"process `{process.name}` does not run it"
                    if module in others
                    else "system.yaml declares no stand-in for it"
                )
                self.error(
                    span,
                    "E411",
                    f"`{module}` cannot be simulated in this scenario: {why}",
                    f"process `{process.name}` can simulate "
                    + (", ".join(f"`{n}`" for n in sorted(process.stand_ins)) or "none"),
                )
            else:
                skipped.update((m, module) for m in stand_in[1] if m != module)
        running = [m for m in process.modules if m not in skipped]
        return _Run(process, running, skipped)

    def expectations(self, stop: str | None, run: _Run | None) -> list[Expected]:
        """What `expect:` asks of the run (E415 for what no run can show)."""
        expect = self.data.get("expect")
        if expect is None:  # a run that stops on a module expects it to finish DONE
            if stop is None:
                return []
            return [Expected("status", self.span(self.data, "stop_when_done"), value="DONE")]
        found = []
        if "status" in expect:
            span = self.span(expect, "status")
            if stop is None:
                self.error(
                    span,
                    "E415",
                    "`expect: status` needs `stop_when_done`: the status is the stop module's",
                    "add `stop_when_done: <module>`",
                )
            found.append(Expected("status", span, value=expect["status"]))
        if "cycles" in expect:
            found.append(self.bounds("cycles", expect["cycles"], self.span(expect, "cycles")))
        figures = expect.get("figures") or {}
        for name, wanted in figures.items():
            span = key_span(figures, name, self.span(expect, "figures"))
            kind = self.figure(name, span, run, "expected figure")
            if kind is None:
                continue
            if isinstance(wanted, dict):
                word = _UNRANGED.get(type(kind))
                if word is not None:
                    self.error(
                        span, "E415", f"`{name}` is {word[0]}: expect {word[1]}, not a range"
                    )
                    continue
                found.append(self.bounds(name, wanted, span))
            elif isinstance(kind, ReasonOf):
                if self.reason(wanted, name.partition(".")[0], self.span(figures, name)):
                    found.append(Expected(name, span, value=wanted))
            elif self.value(wanted, kind, self.span(figures, name), f"expected `{name}`"):
                found.append(Expected(name, span, value=wanted))
        return found

    def bounds(self, what: str, bounds: dict[str, Any], span: Span) -> Expected:
        low, high = bounds.get("min"), bounds.get("max")
        if low is not None and high is not None and low > high:
            self.error(span, "E415", f"`{what}`: min {low} is greater than max {high}")
        return Expected(what, span, low=low, high=high)

    def events(self, run: _Run | None, max_cycles: int) -> list[Event]:
        events = []
        forced: set[str] = set()  # the fields forced by the events so far
        raw_events = self.data.get("events") or []
        last = 0
        for index, raw in enumerate(raw_events):
            where = self.span(raw_events, index)
            cycle = raw["cycle"]
            cycle_span = self.span(raw, "cycle")
            if cycle > max_cycles:
                self.error(
                    cycle_span,
                    "E412",
                    f"an event at cycle {cycle} never happens: the run stops after "
                    f"max_cycles {max_cycles}",
                    "raise max_cycles, or move the event earlier",
                )
            elif cycle < last:
                self.error(
                    cycle_span,
                    "E412",
                    f"events are out of order: cycle {cycle} comes after cycle {last}",
                    "write the events in the order of their cycles",
                )
            last = max(last, cycle)
            event = Event(cycle=cycle, doc=str(raw.get("doc", "")))
            if "command" in raw:
                self.command(raw, event, run, where)
            if "answer" in raw:
                self.answer(raw["answer"], event, self.span(raw, "answer"))
            replies = raw.get("reply") or {}
            for name, status in replies.items():
                found = self.replied(name, key_span(replies, name, where))
                if found is not None and self.reply_reason(str(status), replies, name, found.name):
                    event.replies[name] = str(status)
            world = raw.get("set") or {}
            for name, value in world.items():
                span = key_span(world, name, where)
                kind = self.field(name, span, "field")
                if kind is not None:
                    self.value(value, kind, self.span(world, name), f"world field `{name}`")
                event.world[name] = value
            self.forcing(raw, event, where, forced)
            if "device" in raw:
                event.device = self.device_fault(raw["device"], self.span(raw, "device"))
            modes = raw.get("mode") or {}
            for module, mode in modes.items():
                self.module(module, key_span(modes, module, where), run, "mode of module")
                event.mode[module] = dict(mode)
            events.append(event)
        return sorted(events, key=lambda e: e.cycle)

    # ------------------------------------------------------------ devices

    def devices(self, system_dir: Path) -> dict[str, SoftPlc]:
        """`devices:`, the soft PLCs the run serves: each a device of the system's `io:`
        (E426), its plant a spec directory (E426)."""
        given = self.data.get("devices") or {}
        declared = {d.name: d for d in self.system.io}
        served: dict[str, SoftPlc] = {}
        for name, how in given.items():
            span = key_span(given, name, self.span(self.data, "devices"))
            if name not in declared:
                self.unknown_device(name, span)
                continue
            plant = None
            if "plant" in (how or {}):
                plant = (system_dir / str(how["plant"])).resolve()
                if not (plant / SYSTEM_FILE).is_file():
                    self.error(
                        self.span(how, "plant"),
                        "E426",
                        f"plant `{how['plant']}` of device `{name}` is not a spec directory: "
                        f"no {SYSTEM_FILE} in {display_path(plant)}",
                        "name the directory of the system whose simulators run in the PLC, "
                        "relative to this system's (e.g. ../miner)",
                    )
                    continue
            served[str(name)] = SoftPlc(str(name), plant, span)
        self.down: dict[str, str] = {}  # device -> the fault it is under, as events go
        return served

    def unknown_device(self, name: str, span: Span) -> None:
        names = [d.name for d in self.system.io]
        if not names:
            self.error(
                span,
                "E426",
                f"`{self.system.name}` declares no I/O: it has no device `{name}`",
                "devices are declared under `io:` in system.yaml (docs/io.md)",
            )
        else:
            self.error(
                span,
                "E426",
                f"`{self.system.name}` has no I/O device `{name}`",
                known_names_hint("devices", names, name),
            )

    def device_fault(self, raw: Any, span: Span) -> DeviceFault | None:
        """An event's `device: {name, do}`: a device the scenario serves (E426), and an
        action that follows from the one before (replug after unplug, thaw after freeze)."""
        name, do = str(raw["name"]), str(raw["do"])
        assert do in DEVICE_ACTIONS  # the schema's enum
        if name not in self.served:
            if name in {d.name for d in self.system.io}:
                self.error(
                    span,
                    "E426",
                    f"device `{name}` is not served by this scenario: no soft PLC to fault",
                    f"add `devices: {{{name}: {{}}}}` (with its `plant:`) to the scenario",
                )
            else:
                self.unknown_device(name, span)
            return None
        before = self.down.get(name)
        needs = {REPLUG: UNPLUG, THAW: FREEZE}.get(do)
        if before != needs:
            said = (
                f"it is {'unplugged' if before == UNPLUG else 'frozen'}" if before else ("it is up")
            )
            self.error(
                span,
                "E426",
                f"cannot {do} device `{name}` here: {said}",
                "a device is unplugged then replugged, frozen then thawed, in that order",
            )
            return None
        if do in (UNPLUG, FREEZE):
            self.down[name] = do
        else:
            self.down.pop(name, None)
        return DeviceFault(name, do, span)

    def forcing(self, raw: LocDict, event: Event, where: Span, forced: set[str]) -> None:
        """An event's `unforce:` then `force:` (as `ctl unforce`/`ctl force`): each field
        known (E409), a forced value of its type (E408), and a release only of what an
        earlier event forced (E425). Ground truth may be forced: only simulators and
        stand-ins write it (E280), and in a scenario they all simulate."""
        for index, name in enumerate(raw.get("unforce") or []):
            span = self.span(raw["unforce"], index)
            if self.field(name, span, "field") is None:
                continue
            if name not in forced:
                self.error(
                    span,
                    "E425",
                    f"`{name}` is not forced here: no earlier event forces it",
                    "force it with an earlier event's `force:`, or remove the `unforce:`",
                )
            forced.discard(name)
            event.unforce.append(name)
        values = raw.get("force") or {}
        for name, value in values.items():
            span = key_span(values, name, where)
            kind = self.field(name, span, "field")
            if kind is None:
                continue
            self.value(value, kind, self.span(values, name), f"forced world field `{name}`")
            forced.add(name)
            event.force[name] = value

    def command(self, raw: LocDict, event: Event, run: _Run | None, where: Span) -> None:
        """A command event: module, command, every parameter of its type, supervisor."""
        span = self.span(raw, "command")
        module, _, name = str(raw["command"]).partition(".")
        event.command = (module, name)
        args = raw.get("with") or {}
        event.args = dict(args)
        controller = self.module(module, span, run, "command to module")
        if controller is None:
            return
        if controller.is_operator:
            self.error(
                span,
                "E285",
                f"`{module}` is an operator module: its clients ({', '.join(controller.clients)}) "
                "ask it, a person answers",
                "answer its requests with an event's `answer: {request: "
                f"{(controller.channels or ('op/client',))[0]}, status: DONE}}`, or script the "
                "person under `operator:`",
            )
            return
        commands = {c.name: c for c in controller.commands}
        command = commands.get(name)
        if command is None:
            self.error(
                span,
                "E406",
                f"`{module}` has no command `{name}`",
                known_names_hint(f"commands of {module}", commands, name),
            )
            return
        params = {p.name: p.type for p in command.params}
        for param, value in args.items():
            if param not in params:
                self.error(
                    key_span(args, param, span),
                    "E407",
                    f"`{module}.{name}` has no parameter `{param}`",
                    known_names_hint("parameters", params, param),
                )
            else:
                self.value(value, params[param], self.span(args, param), f"parameter `{param}`")
        missing = [p for p in params if p not in args]
        if missing:
            given = ", ".join(f"{p}: ..." for p in missing)
            self.error(
                span,
                "E407",
                f"`{module}.{name}` needs {listed('parameter', missing)}",
                f"give every parameter under `with: {{{given}}}`: a missing one would be 0",
            )
        supervisor = controller.supervisor
        if supervisor is not None and run is not None and supervisor in run.running:
            if raw.get("overrides") is True:
                event.overrides = supervisor
            else:
                self.error(
                    span,
                    "E413",
                    f"`{module}` is commanded by `{supervisor}`, which runs in this scenario "
                    "and would overwrite this command",
                    f"command `{supervisor}` instead, or add `overrides: true` to command "
                    f"`{module}` in `{supervisor}`'s place",
                )

    # ------------------------------------------------------------ the operator

    def not_an_operator(self, found: IRController | None, span: Span, why: str) -> None:
        """E285 for an operator module where a scenario needs a controller's command."""
        if found is not None and found.is_operator:
            self.error(
                span,
                "E285",
                f"`{found.name}` is an operator module: it {why}",
                f"its clients: {', '.join(found.clients) or 'none'}",
            )

    def operator_script(self) -> OperatorScript | None:
        """The scripted person (`operator:`): every operator module, task, client and reason
        it names exists (E285-E288), each duration in cycles of the module's process."""
        section = self.data["operator"] or {}
        span = self.span(self.data, "operator")
        if not self.operators:
            self.error(
                span,
                "E285",
                f"`{self.system.name}` has no operator module for `operator:` to script",
                "an operator module is a `<mnemonic>.yaml` with `operator:` (docs/spec.md 15)",
            )
            return None
        entries = section.get("answers") or []
        answers = [
            self.scripted(entry, self.span(entries, index), True)
            for index, entry in enumerate(entries)
        ]
        default = None
        if "default" in section:
            default = self.scripted(section["default"], self.span(section, "default"), False)
        if any(a is None for a in answers) or ("default" in section and default is None):
            return None
        script = OperatorScript(tuple(a for a in answers if a is not None), default)
        self.default_results(script, self.span(section, "default") if default else span)
        return script

    def scripted(self, raw: LocDict, where: Span, matching: bool) -> ScriptedAnswer | None:
        before = len(self.diags.errors)
        chosen = list(self.operators.values())
        name = raw.get("operator")
        if name is not None:
            chosen = [self.operators[name]] if name in self.operators else []
            if not chosen:
                self.error(
                    self.span(raw, "operator"),
                    "E285",
                    f"`{name}` is not an operator module of `{self.system.name}`",
                    known_names_hint("operator modules", self.operators, name),
                )
        tasks = {c.name: c for o in chosen for c in o.commands if c.text}
        task = raw.get("task")
        if task is not None and chosen and task not in tasks:
            self.error(
                self.span(raw, "task"),
                "E286",
                f"`{task}` is not a task of {_names(chosen)}",
                known_names_hint("tasks", tasks, task),
            )
        clients = {client for o in chosen for client in o.clients}
        client = raw.get("client")
        if client is not None and chosen and client not in clients:
            self.error(
                self.span(raw, "client"),
                "E287",
                f"`{client}` is not a client of {_names(chosen)}",
                known_names_hint("clients", sorted(clients), client),
            )
        answer, reason = str(raw.get("answer", "DONE")), str(raw.get("reason", ""))
        if reason:
            asked = [tasks[task]] if task in tasks else list(tasks.values())
            self.answer_reason(reason, answer, asked, self.span(raw, "reason"))
        period = min(
            (p.cycle_period for p in self.system.processes for o in chosen if o.name in p.modules),
            default=self.system.cycle_period,
        )
        after = exact_cycles(raw["after"], period)[0] if "after" in raw else 0
        asked = [tasks[task]] if task in tasks else list(tasks.values())
        # (a default answers what no entry does: default_results checks it against those)
        results = self.answer_results(raw, answer, asked, where, every=matching)
        if len(self.diags.errors) > before:
            return None
        return ScriptedAnswer(after, answer, reason, name, task, client, results)

    def answer_results(
        self, raw: LocDict, answer: str, tasks: list[Any], where: Span, every: bool
    ) -> tuple[tuple[str, Any], ...]:
        """The results an answer gives (E911): with DONE only; each a result of the tasks it
        may answer, of its type (E408) and within its range; with `every`, all of each such
        task's results (an event's answer is checked against the open task when it runs)."""
        given = raw.get("results") or {}
        span = self.span(raw, "results") if "results" in raw else where
        if given and answer != "DONE":
            self.error(
                span,
                "E911",
                f"results given with {answer}: what the person records goes with DONE only",
                "write `answer: DONE`, or leave `results:` out",
            )
            return ()
        if answer != "DONE":
            return ()
        declared = {r.name: r for t in tasks for r in t.results}
        for name in given:
            if name not in declared:
                self.error(
                    key_span(given, name, span),
                    "E911",
                    f"`{name}` is not a result of "
                    f"{' or '.join(t.name for t in tasks) or 'any task'}",
                    known_names_hint("results", sorted(declared), name)
                    if declared
                    else "a task records results under `results:` in its operator module",
                )
                return ()
        for task in tasks if every else []:
            missing = [r.name for r in task.results if r.name not in given]
            if missing:
                self.error(
                    span,
                    "E911",
                    f"this answer DONE may answer {task.name}, which records "
                    f"{', '.join(r.name for r in task.results)}: {', '.join(missing)} not given",
                    "give every result under `results:`, or name the `task:` it answers",
                )
                return ()
        for name, value in given.items():
            for task in tasks:
                result = next((r for r in task.results if r.name == name), None)
                if result is None:
                    continue
                at = self.span(given, name)
                if not self.value(value, result.type, at, f"result `{name}`"):
                    return ()
                problem = range_problem(value, result.low, result.high)
                if problem:
                    self.error(
                        at,
                        "E911",
                        f"result `{name}` of {task.name} {problem}",
                        "an answer out of its range is refused before it reaches the client",
                    )
                    return ()
        return tuple(given.items())

    def default_results(self, script: OperatorScript, span: Span) -> None:
        """A default DONE records nothing: E911 when it may answer a task that records
        results (one no earlier entry answers whatever its client)."""
        default = script.default
        if default is None or default.answer != "DONE":
            return
        covered = {
            (a.operator, a.task) for a in script.answers if a.task is not None and a.client is None
        }
        for operator in self.operators.values():  # (a default names no operator: the schema)
            for task in operator.commands:
                if not task.results or {(None, task.name), (operator.name, task.name)} & covered:
                    continue
                self.error(
                    span,
                    "E911",
                    f"the default answer DONE records no results, but `{operator.name}."
                    f"{task.name}` records {', '.join(r.name for r in task.results)}",
                    f"script {task.name} in an entry of `answers:` with `results:`",
                )
                return

    def replied(self, name: str, span: Span) -> IRController | None:
        """The module a scripted answer (`reply:`) is written for: a controller (E405), or an
        operator module answering on one client's channel, `op/fx` (E289)."""
        if "/" not in name:
            return self.module(name, span, None, "reply to")
        channels = {ch: o for o in self.operators.values() for ch in o.channels}
        if name not in channels:
            self.error(
                span,
                "E289",
                f"reply to `{name}`: not a channel of an operator module of `{self.system.name}`",
                known_names_hint("channels", sorted(channels), name),
            )
            return None
        return channels[name]

    def reply_reason(self, status: str, replies: dict[str, Any], key: str, module: str) -> bool:
        """A scripted ERROR's reason (`ERROR(BLOCKED)`): one the module can give (E408)."""
        reason = status.partition("(")[2].rstrip(")")
        return not reason or self.reason(reason, module, self.span(replies, key))

    def answer_reason(self, reason: str, answer: str, tasks: list[Any], span: Span) -> None:
        """A reason given with ERROR only, and one that a task it may answer declares (E288);
        at run time an answer's reason must be the answered task's."""
        if answer != "ERROR":
            self.error(
                span,
                "E288",
                f"reason `{reason}` given with {answer}: a reason goes with ERROR only",
                "write `answer: ERROR`, or leave the reason out",
            )
            return
        if not any(reason in t.reasons for t in tasks):
            declared = sorted({r for t in tasks for r in t.reasons})
            self.error(
                span,
                "E288",
                f"`{reason}` is not a reason of {' or '.join(t.name for t in tasks) or 'any task'}",
                known_names_hint("reasons", declared, reason)
                if declared
                else "declare it under the task's `reasons:`",
            )

    def answer(self, raw: LocDict, event: Event, span: Span) -> None:
        """A console answer event: an operator module's channel, a status, a reason (E289)."""
        channel = str(raw["request"])
        status, reason = str(raw.get("status", "DONE")), str(raw.get("reason", ""))
        event.answer = (channel, status, reason)
        channels = {ch: o for o in self.operators.values() for ch in o.channels}
        if channel not in channels:
            self.error(
                self.span(raw, "request"),
                "E289",
                f"`{channel}` is not a channel of an operator module of `{self.system.name}`",
                known_names_hint("channels", sorted(channels), channel),
            )
            return
        tasks = [c for c in channels[channel].commands if c.text]
        if reason:
            self.answer_reason(reason, status, tasks, self.span(raw, "reason"))
        event.answer_results = dict(self.answer_results(raw, status, tasks, span, every=False))


def _names(operators: list[IRController]) -> str:
    return " or ".join(f"`{o.name}`" for o in operators)


# The types a figure cannot be expected in a range of: how a message names each, and what to
# expect instead.
_UNRANGED: dict[type[Type], tuple[str, str]] = {
    ReasonOf: ("a reason", "one of its names"),
    Enum: ("an enum", "one value"),
    Str: ("a str", "one value"),
    Bool: ("a bool", "true or false"),
}


def _shown(value: Any) -> str:
    text = str(value).lower() if isinstance(value, bool) else str(value)
    return text if len(text) <= 30 else text[:27] + "..."
