"""Model: schema-valid spec data -> the input model, dataclasses that mirror the YAML.

Every name and value keeps the span it was written at, so later stages can report
problems where the user wrote them. Nothing is resolved here; `check` does that.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

from .diagnostics import Span


class At(NamedTuple):
    """A value as written in a spec, with its span."""

    value: Any
    span: Span


def span_at(container: Any, key: str | int, fallback: Span) -> Span:
    """Span of `container[key]` (a loader LocDict/LocList), else `fallback`."""
    spans = getattr(container, "item_spans" if isinstance(key, int) else "value_spans", None)
    try:
        return spans[key] if spans is not None else fallback
    except (KeyError, IndexError):
        return fallback


def key_span(container: Any, key: str, fallback: Span) -> Span:
    spans = getattr(container, "key_spans", None)
    return spans.get(key, fallback) if spans else fallback


def span_of(data: Any, fallback: Span) -> Span:
    return getattr(data, "span", fallback)


# ---------------------------------------------------------------- system


@dataclass
class WorldField:
    name: str
    type: str
    initial: bool | int | float
    doc: str
    span: Span


@dataclass
class Process:
    name: str
    modules: list[At]
    doc: str
    span: Span


@dataclass
class SystemSpec:
    name: str
    title: str
    doc: str
    cycle_period: float
    world: dict[str, WorldField]
    processes: list[Process]
    simulators: list[At]
    stand_ins: dict[str, At]  # controller -> the controller simulator that can replace it
    directory: Path
    display: str  # the file's path as shown in diagnostics and headers
    span: Span

    @cached_property
    def world_types(self) -> dict[str, str]:
        """Each world field's type, by name (every controller's scope shares it)."""
        return {name: f.type for name, f in self.world.items()}


# ---------------------------------------------------------------- controller


@dataclass
class Typed:
    """A param or local: name, type, initial value (locals only) and doc."""

    name: str
    type: str
    initial: bool | int | float
    doc: str
    span: Span


@dataclass
class Hook:
    name: str
    doc: str
    args: list[At]
    returns: list[At]
    span: Span


@dataclass
class Send:
    sub: str
    command: str
    args: dict[str, At]  # parameter -> value expression (span of the value)
    span: Span
    arg_spans: dict[str, Span] = field(default_factory=dict)  # span of each parameter name


@dataclass
class Assign:
    target: At
    value: At


@dataclass
class SetWorld:
    """`set:` assigns world fields or locals, in the order written."""

    assignments: list[Assign]
    span: Span


@dataclass
class Report:
    status: str  # DONE or ERROR
    span: Span


@dataclass
class CallHook:
    hook: str
    span: Span


Action = Send | SetWorld | Report | CallHook


@dataclass
class Rule:
    doc: str
    when: At | None
    actions: list[Action]
    next: At | None
    span: Span


@dataclass
class State:
    name: str
    rules: list[Rule]
    span: Span


@dataclass
class Command:
    name: str
    doc: str
    params: dict[str, Typed]
    states: dict[str, State]
    span: Span
    generated: bool = False  # a default INIT/HALT table rcsgen supplies
    first_match: list[At] = field(default_factory=list)  # states whose rules may overlap


@dataclass
class ControllerSpec:
    name: str
    title: str
    doc: str
    subordinates: list[At]
    hooks_module: At | None
    world_reads: list[At]
    world_writes: list[At]
    constants: dict[str, At]
    locals: dict[str, Typed]
    predicates: dict[str, At]
    hooks: dict[str, Hook]
    commands: dict[str, Command]
    display: str
    span: Span
    name_span: Span = field(default_factory=lambda: Span("?"))
    every_cycle: list[Rule] = field(default_factory=list)  # tried every cycle, any command
    hooks_state: At | None = None  # factory of the state every hook call receives first


# ---------------------------------------------------------------- builders


def _items(data: Any, key: str, span: Span) -> list[At]:
    values = data.get(key) or []
    return [At(v, span_at(values, i, span)) for i, v in enumerate(values)]


def build_system(data: Any, directory: Path, display: str) -> SystemSpec:
    """The system model from a schema-valid system document."""
    top = span_of(data, Span(display))
    world = {
        name: WorldField(
            name,
            spec["type"],
            spec["initial"],
            spec.get("doc", ""),
            key_span(data["world"], name, top),
        )
        for name, spec in (data.get("world") or {}).items()
    }
    processes = [
        Process(
            name,
            _items(spec, "modules", top),
            spec.get("doc", ""),
            key_span(data["processes"], name, top),
        )
        for name, spec in data["processes"].items()
    ]
    return SystemSpec(
        name=data["system"],
        title=data["title"],
        doc=data.get("doc", ""),
        cycle_period=float(data["cycle_period"]),
        world=world,
        processes=processes,
        simulators=_items(data, "simulators", top),
        stand_ins={
            k: At(v, span_at(data["stand_ins"], k, top))
            for k, v in (data.get("stand_ins") or {}).items()
        },
        directory=directory,
        display=display,
        span=top,
    )


def _typed(name: str, spec: Any, span: Span) -> Typed:
    return Typed(name, spec["type"], spec.get("initial", False), spec.get("doc", ""), span)


def _action(raw: Any, span: Span) -> Action:
    if "send" in raw:
        sub, _, command = str(raw["send"]).partition(".")
        args = raw.get("with") or {}
        values = {k: At(v, span_at(args, k, span)) for k, v in args.items()}
        return Send(sub, command, values, span, {k: key_span(args, k, span) for k in args})
    if "set" in raw:
        values = raw["set"]
        assignments = [
            Assign(At(k, key_span(values, k, span)), At(v, span_at(values, k, span)))
            for k, v in values.items()
        ]
        return SetWorld(assignments, span)
    if "report" in raw:
        return Report(raw["report"], span_at(raw, "report", span))
    return CallHook(raw["call"], span_at(raw, "call", span))


def _rule(raw: Any, span: Span) -> Rule:
    actions = raw.get("do") or []
    when = At(raw["when"], span_at(raw, "when", span)) if "when" in raw else None
    nxt = At(raw["next"], span_at(raw, "next", span)) if "next" in raw else None
    return Rule(
        doc=raw.get("doc", ""),
        when=when,
        actions=[_action(a, span_at(actions, i, span)) for i, a in enumerate(actions)],
        next=nxt,
        span=span,
    )


def _command(name: str, raw: Any, span: Span) -> Command:
    params = raw.get("params") or {}
    states = raw.get("states") or {}
    return Command(
        name=name,
        doc=raw.get("doc", ""),
        params={p: _typed(p, spec, key_span(params, p, span)) for p, spec in params.items()},
        states={
            s: State(
                s,
                [_rule(r, span_at(rules, i, span)) for i, r in enumerate(rules)],
                key_span(states, s, span),
            )
            for s, rules in states.items()
        },
        span=span,
        first_match=_items(raw, "first_match", span),
    )


def build_controller(data: Any, display: str) -> ControllerSpec:
    """The controller model from a schema-valid controller document."""
    top = span_of(data, Span(display))
    world = data.get("world") or {}
    constants = data.get("constants") or {}
    local_specs = data.get("locals") or {}
    predicates = data.get("predicates") or {}
    hooks = data.get("hooks") or {}
    commands = data.get("commands") or {}
    return ControllerSpec(
        name=data["controller"],
        title=data["title"],
        doc=data.get("doc", ""),
        subordinates=_items(data, "subordinates", top),
        hooks_module=At(data["hooks_module"], span_at(data, "hooks_module", top))
        if "hooks_module" in data
        else None,
        world_reads=_items(world, "reads", top),
        world_writes=_items(world, "writes", top),
        constants={k: At(v, key_span(constants, k, top)) for k, v in constants.items()},
        locals={k: _typed(k, v, key_span(local_specs, k, top)) for k, v in local_specs.items()},
        predicates={k: At(v, span_at(predicates, k, top)) for k, v in predicates.items()},
        hooks={
            k: Hook(
                k,
                v.get("doc", ""),
                _items(v, "args", key_span(hooks, k, top)),
                _items(v, "returns", key_span(hooks, k, top)),
                key_span(hooks, k, top),
            )
            for k, v in hooks.items()
        },
        commands={k: _command(k, v, key_span(commands, k, top)) for k, v in commands.items()},
        display=display,
        span=top,
        name_span=span_at(data, "controller", top),
        every_cycle=[
            _rule(r, span_at(data["every_cycle"], i, top))
            for i, r in enumerate(data.get("every_cycle") or [])
        ],
        hooks_state=At(data["hooks_state"], span_at(data, "hooks_state", top))
        if "hooks_state" in data
        else None,
    )
