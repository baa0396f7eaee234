"""Model: schema-valid spec data -> the input model, dataclasses that mirror the YAML.

Every name and value keeps the span it was written at, so later stages can report
problems where the user wrote them. Nothing is resolved here; `check` does that. The one
thing added to what the YAML says: every controller gets QQ1's default INIT and HALT tables
where it declares none (`default_table`), so every later stage sees the same commands.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

from ...runtime.contract import ACCESS_LEVELS, BUILTIN_COMMANDS
from ..diagnostics import Span
from ..types import NAMED, STR_DEFAULT_SIZE, Str, Type, enum_of
from .loader import key_span, span_of, value_span


class ModuleKind(StrEnum):
    """What a module of a system is."""

    CONTROLLER = "controller"  # a state table, run every cycle
    OPERATOR = "operator"  # a person at a screen: tasks answered, no table (build_operator)


class PlanVerb(StrEnum):
    """What an action does to a plan; its key in the spec (`plan: route`)."""

    PLAN = "plan"  # call the planner, load its steps
    REPLAN = "replan"  # the same, counted against the plan's `replans`
    ADVANCE = "advance"  # make the next step the current one


class Located(NamedTuple):
    """A value as written in a spec, with its span."""

    value: Any
    span: Span


# ---------------------------------------------------------------- system


@dataclass
class Typed:
    """A world field, param or local: name, type, initial value (not of params) and doc.

    `type` is BOOL, INT, FLOAT, an Enum or a Str (`declared_type`); an enum's initial value
    is the value's name as written, a string's its text."""

    name: str
    type: Type
    initial: bool | int | float | str
    doc: str
    span: Span
    initial_span: Span | None = None  # where `initial:` gives the value (not for params)
    actuator: bool = False  # world fields: commands an actuator (W520)
    ground_truth: bool = False  # world fields: the simulation's truth, no sensor's (E280)
    # world fields that command an actuator: the value it is driven to when the process that
    # writes it is lost or stops (None: not given, the type's zero; E801 without `actuator`)
    safe: bool | int | float | str | None = None
    safe_span: Span | None = None
    # an operator task's results: the range an answer's value must lie in (`min`, `max`)
    low: Located | None = None
    high: Located | None = None


@dataclass
class Process:
    name: str
    modules: list[Located]
    doc: str
    span: Span
    cycle_period: float | None = None  # its own period, if not the system's
    # its declared watchdog limits (`watchdog:`), the runtime Watchdog's field -> value
    watchdog: dict[str, float] = field(default_factory=dict)
    # its opt-in real-time settings (`realtime:`, rcs/realtime.py)
    realtime: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class Role:
    name: str
    doc: str
    span: Span
    # level -> the modules it is granted on (Located names), or "all" (Located("all"))
    grants: dict[str, list[Located]] = field(default_factory=dict)
    # who holds it: OS user and group names; neither: anyone who can open the segment
    users: list[Located] = field(default_factory=list)
    groups: list[Located] = field(default_factory=list)

    @property
    def members(self) -> bool:
        return bool(self.users or self.groups)


@dataclass(frozen=True)
class Request:
    name: str
    doc: str
    span: Span
    by: Located
    open_while: Located  # a bool world field
    answer: Located  # MODULE.COMMAND


@dataclass(frozen=True)
class Operators:
    roles: dict[str, Role] = field(default_factory=dict)
    requests: dict[str, Request] = field(default_factory=dict)
    # the OS group that shares the segment (mode 0660); None: its creator's alone (0600)
    segment_group: Located | None = None


@dataclass(frozen=True)
class IoPoint:
    """A world field bound to a point of a device, as written (checked in checks/io.py)."""

    field: str
    span: Span  # where the field is named under `points:`
    kinds: tuple[Located, ...]  # the point kinds given (coil: 3, node: ...): one is right
    register_type: Located | None = None
    scale: Located | None = None
    offset: Located | None = None
    word_order: Located | None = None
    direction: Located | None = None


@dataclass(frozen=True)
class IoDevice:
    """A fieldbus device of the system's `io:` section, as written."""

    name: str
    span: Span
    protocol: Located
    address: Located
    timeout: Located
    points: tuple[IoPoint, ...]
    unit: Located | None = None
    process: Located | None = None
    poll_period: Located | None = None
    doc: str = ""


@dataclass
class SystemSpec:
    name: str
    title: str
    doc: str
    cycle_period: float
    heartbeat_timeout: float | None
    startup_timeout: float | None
    world: dict[str, Typed]
    processes: list[Process]
    simulators: list[Located]
    stand_ins: dict[str, Located]  # controller -> the controller simulator that can replace it
    directory: Path
    display: str  # the file's path as shown in diagnostics and headers
    span: Span
    operators: Operators = field(default_factory=Operators)  # roles and requests
    name_span: Span = field(default_factory=lambda: Span("?"))  # where `system:` names it
    # The run settings the hook-state factories read, name -> doc; None: not declared
    settings: dict[str, str] | None = None
    io: dict[str, IoDevice] = field(default_factory=dict)  # fieldbus devices (docs/io.md)
    properties: list[UserProperty] = field(default_factory=list)  # checked by `rcsgen prove`

    @cached_property
    def world_types(self) -> dict[str, Type]:
        """Each world field's type, by name (every controller's scope shares it)."""
        return {name: f.type for name, f in self.world.items()}


# ---------------------------------------------------------------- controller


@dataclass
class Hook:
    name: str
    doc: str
    args: list[Located]
    returns: list[Located]
    span: Span
    deadline: Located | None = None  # a duration: how long one call may run


@dataclass
class Plan:
    """A plan: the steps its planner (a function of the hooks module) returns, each of the
    typed fields `steps`, at most `capacity` of them, and the replans a command may make."""

    name: str
    doc: str
    planner: Located
    args: list[Located]
    steps: dict[str, Type]  # field name -> type, in order
    capacity: int
    replans: int
    span: Span
    deadline: Located | None = None  # a duration: how long one call of the planner may run


@dataclass
class Function:
    """A pure function: typed parameters (in call order), a result type, a body."""

    name: str
    doc: str
    params: dict[str, Type]  # name -> type
    returns: Type
    body: Located
    span: Span


@dataclass
class Send:
    sub: str
    command: str
    args: dict[str, Located]  # parameter -> value expression (span of the value)
    span: Span
    arg_spans: dict[str, Span] = field(default_factory=dict)  # span of each parameter name


@dataclass
class Assign:
    target: Located
    value: Located


@dataclass
class SetWorld:
    """`set:` assigns world fields or locals, in the order written."""

    assignments: list[Assign]
    span: Span


@dataclass
class Report:
    status: str  # DONE or ERROR
    span: Span
    reason: Located | None = None  # with ERROR: one of the command's `reasons`


@dataclass
class CallHook:
    hook: str
    span: Span


@dataclass
class PlanAction:
    """`plan:`, `replan:` or `advance:` of a declared plan."""

    kind: PlanVerb
    plan: str
    span: Span


Action = Send | SetWorld | Report | CallHook | PlanAction


@dataclass
class UserProperty:
    """A property of the engineer's own (`properties:`, docs/spec.md section 19): `always`
    an invariant; else `whenever` a trigger, `then` its response `within` cycles."""

    name: Located
    doc: str
    span: Span
    always: Located | None = None
    whenever: Located | None = None
    then: Located | None = None
    within: Located | None = None


def build_properties(data: Any, top: Span) -> list[UserProperty]:
    """The `properties:` of a schema-valid system or controller document."""
    items = data.get("properties") or []
    found = []
    for index, raw in enumerate(items):
        at = value_span(items, index, top)
        found.append(
            UserProperty(
                Located(raw["name"], value_span(raw, "name", at)),
                str(raw.get("doc", "")),
                at,
                *(_optional(raw, key, at) for key in ("always", "whenever", "then", "within")),
            )
        )
    return found


@dataclass
class Allow:
    """An acknowledgement: a warning that is intended here, and why (`allow:`)."""

    code: Located
    reason: Located
    states: list[Located]  # of a command-level acknowledgement; empty: every state
    span: Span


@dataclass
class Rule:
    doc: str
    when: Located | None
    actions: list[Action]
    next: Located | None
    span: Span
    allow: list[Allow] = field(default_factory=list)
    after: Located | None = None  # a duration: time in the state before the rule may fire
    hold: Located | None = None  # `for:` a duration the guard must have held without a break


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
    first_match: list[Located] = field(default_factory=list)  # states whose rules may overlap
    allow: list[Allow] = field(default_factory=list)  # warnings of its table that are intended
    results: dict[str, Typed] = field(default_factory=dict)  # set while executing, in status
    reasons: list[Located] = field(default_factory=list)  # why it can end in ERROR
    lets: dict[str, Located] = field(default_factory=dict)  # named values of its table
    text: Located | None = None  # an operator's task: the instruction the screen shows


@dataclass(frozen=True)
class InstanceOf:
    """Where a controller of an instance comes from (docs/spec.md section 18): the instance,
    its template, the controller's name in the template and the template file's path as
    generated headers name it."""

    instance: str
    template: str
    member: str
    source: str


@dataclass
class ControllerSpec:
    name: str
    title: str
    doc: str
    subordinates: list[Located]
    hooks_module: Located | None
    world_reads: list[Located]
    world_writes: list[Located]
    constants: dict[str, Located]
    locals: dict[str, Typed]
    predicates: dict[str, Located]
    hooks: dict[str, Hook]
    commands: dict[str, Command]
    display: str
    span: Span
    name_span: Span = field(default_factory=lambda: Span("?"))
    every_cycle: list[Rule] = field(default_factory=list)  # tried every cycle, any command
    echo_timeouts: dict[str, Located] = field(default_factory=dict)  # subordinate -> duration
    # subordinate -> `halt_all` | `continue`: what the loss of its process does (E802)
    on_lost: dict[str, Located] = field(default_factory=dict)
    hooks_state_on_restart: str = "refuse"  # or "reset": what a restart does with hook state
    hooks_state: Located | None = None  # factory of the state every hook call receives first
    functions: dict[str, Function] = field(default_factory=dict)  # pure, callable anywhere
    plans: dict[str, Plan] = field(default_factory=dict)  # stepped through by its tables
    kind: ModuleKind = ModuleKind.CONTROLLER  # OPERATOR: a person at a screen, no table
    instance: InstanceOf | None = None  # a copy of a template's controller (section 18)
    properties: list[UserProperty] = field(default_factory=list)  # checked by `rcsgen prove`

    @property
    def is_operator(self) -> bool:
        return self.kind is ModuleKind.OPERATOR


# ---------------------------------------------------------------- builders


def declared_type(spec: Any) -> Type:
    """The type a schema-valid declaration (`{type, values, size}`) gives its value: the one
    place a type is read from the spec's text."""
    kind = str(spec["type"])
    if kind == "enum":
        return enum_of([str(v) for v in spec.get("values") or ()])
    if kind == "str":
        return Str(int(spec.get("size", STR_DEFAULT_SIZE)))
    return NAMED[kind]


def _items(data: Any, key: str, span: Span) -> list[Located]:
    values = data.get(key) or []
    return [Located(v, value_span(values, i, span)) for i, v in enumerate(values)]


def build_system(data: Any, directory: Path, display: str) -> SystemSpec:
    """The system model from a schema-valid system document."""
    top = span_of(data, Span(display))
    world = {
        name: Typed(
            name,
            declared_type(spec),
            spec["initial"],
            spec.get("doc", ""),
            key_span(data["world"], name, top),
            value_span(spec, "initial", top),
            bool(spec.get("actuator", False)),
            bool(spec.get("ground_truth", False)),
            spec.get("safe"),
            value_span(spec, "safe", top) if "safe" in spec else None,
        )
        for name, spec in (data.get("world") or {}).items()
    }
    processes = [
        Process(
            name,
            _items(spec, "modules", top),
            spec.get("doc", ""),
            key_span(data["processes"], name, top),
            float(spec["cycle_period"]) if "cycle_period" in spec else None,
            {
                str(k): int(v) if k == "window" else float(v)
                for k, v in (spec.get("watchdog") or {}).items()
            },
            dict(spec.get("realtime") or {}),
        )
        for name, spec in data["processes"].items()
    ]
    return SystemSpec(
        name=data["system"],
        title=data["title"],
        doc=data.get("doc", ""),
        cycle_period=float(data["cycle_period"]),
        heartbeat_timeout=float(data["heartbeat_timeout"]) if "heartbeat_timeout" in data else None,
        startup_timeout=float(data["startup_timeout"]) if "startup_timeout" in data else None,
        world=world,
        processes=processes,
        simulators=_items(data, "simulators", top),
        stand_ins={
            k: Located(v, value_span(data["stand_ins"], k, top))
            for k, v in (data.get("stand_ins") or {}).items()
        },
        directory=directory,
        display=display,
        span=top,
        operators=build_operators(data, top),
        name_span=value_span(data, "system", top),
        settings={str(k): str((v or {}).get("doc", "")) for k, v in data["settings"].items()}
        if isinstance(data.get("settings"), dict)
        else None,
        io=build_io(data, top),
        properties=build_properties(data, top),
    )


POINT_KINDS = ("coil", "discrete_input", "holding_register", "input_register", "node")


def build_io(data: Any, top: Span) -> dict[str, IoDevice]:
    """The `io:` section's devices from a schema-valid system document (none when absent)."""
    section = data.get("io") or {}
    devices = {}
    for name, spec in section.items():
        span = key_span(section, name, top)
        points = tuple(
            IoPoint(
                field,
                key_span(spec["points"], field, span),
                tuple(_at(point, k, span) for k in POINT_KINDS if k in point),
                _optional(point, "type", span),
                _optional(point, "scale", span),
                _optional(point, "offset", span),
                _optional(point, "word_order", span),
                _optional(point, "direction", span),
            )
            for field, point in spec["points"].items()
        )
        devices[name] = IoDevice(
            name,
            span,
            _at(spec, "protocol", span),
            _at(spec, "address", span),
            _at(spec, "timeout", span),
            points,
            _optional(spec, "unit", span),
            _optional(spec, "process", span),
            _optional(spec, "poll_period", span),
            str(spec.get("doc", "")),
        )
    return devices


def _at(data: Any, key: str, top: Span) -> Located:
    """`data[key]` with where it is written; a point kind keeps its name: (kind, value)."""
    value = data[key]
    if key in POINT_KINDS:
        value = (key, value)
    return Located(value, value_span(data, key, top))


def build_operators(data: Any, top: Span) -> Operators:
    """The operators model from a schema-valid system document (empty when not declared)."""
    section = data.get("operators") or {}
    roles: dict[str, Role] = {}
    for name, spec in (section.get("roles") or {}).items():
        span = key_span(section["roles"], name, top)
        grants: dict[str, list[Located]] = {}
        for level in ACCESS_LEVELS[1:]:  # monitor is every role's
            if level not in spec:
                continue
            listed = spec[level]
            if listed == "all":
                grants[level] = [Located("all", value_span(spec, level, span))]
            else:
                grants[level] = [
                    Located(m, value_span(listed, i, span)) for i, m in enumerate(listed)
                ]
        members = {
            key: [Located(n, value_span(spec[key], i, span)) for i, n in enumerate(spec[key])]
            for key in ("users", "groups")
            if key in spec
        }
        roles[name] = Role(
            name,
            spec.get("doc", ""),
            span,
            grants,
            members.get("users", []),
            members.get("groups", []),
        )
    requests: dict[str, Request] = {}
    for name, spec in (section.get("requests") or {}).items():
        span = key_span(section["requests"], name, top)
        requests[name] = Request(
            name,
            spec["doc"],
            span,
            Located(spec["by"], value_span(spec, "by", span)),
            Located(spec["while"], value_span(spec, "while", span)),
            Located(spec["answer"], value_span(spec, "answer", span)),
        )
    group = None
    if "segment_group" in section:
        group = Located(section["segment_group"], value_span(section, "segment_group", top))
    return Operators(roles, requests, group)


def _typed(name: str, spec: Any, span: Span) -> Typed:
    initial = value_span(spec, "initial", span) if "initial" in spec else None
    typed = Typed(
        name, declared_type(spec), spec.get("initial", False), spec.get("doc", ""), span, initial
    )
    typed.low, typed.high = (_optional(spec, key, span) for key in ("min", "max"))
    return typed


def _action(raw: Any, span: Span) -> Action:
    if "send" in raw:
        sub, _, command = str(raw["send"]).partition(".")
        args = raw.get("with") or {}
        values = {k: Located(v, value_span(args, k, span)) for k, v in args.items()}
        return Send(sub, command, values, span, {k: key_span(args, k, span) for k in args})
    if "set" in raw:
        values = raw["set"]
        assignments = [
            Assign(Located(k, key_span(values, k, span)), Located(v, value_span(values, k, span)))
            for k, v in values.items()
        ]
        return SetWorld(assignments, span)
    if "report" in raw:
        reason = (
            Located(raw["reason"], value_span(raw, "reason", span)) if "reason" in raw else None
        )
        return Report(raw["report"], value_span(raw, "report", span), reason)
    for verb in PlanVerb:
        if verb.value in raw:
            return PlanAction(verb, str(raw[verb.value]), value_span(raw, verb.value, span))
    return CallHook(raw["call"], value_span(raw, "call", span))


def _allow(raw: Any, span: Span) -> list[Allow]:
    items = raw.get("allow") or []
    found = []
    for index, item in enumerate(items):
        at = value_span(items, index, span)
        found.append(
            Allow(
                Located(item["code"], value_span(item, "code", at)),
                Located(item["reason"], value_span(item, "reason", at)),
                _items(item, "states", at),
                at,
            )
        )
    return found


def _rule(raw: Any, span: Span) -> Rule:
    actions = raw.get("do") or []
    when = Located(raw["when"], value_span(raw, "when", span)) if "when" in raw else None
    nxt = Located(raw["next"], value_span(raw, "next", span)) if "next" in raw else None
    return Rule(
        doc=raw.get("doc", ""),
        when=when,
        actions=[_action(a, value_span(actions, i, span)) for i, a in enumerate(actions)],
        next=nxt,
        span=span,
        allow=_allow(raw, span),
        after=Located(raw["after"], value_span(raw, "after", span)) if "after" in raw else None,
        hold=Located(raw["for"], value_span(raw, "for", span)) if "for" in raw else None,
    )


def _command(name: str, raw: Any, span: Span) -> Command:
    params = raw.get("params") or {}
    results = raw.get("results") or {}
    states = raw.get("states") or {}
    return Command(
        name=name,
        doc=raw.get("doc", ""),
        params={p: _typed(p, spec, key_span(params, p, span)) for p, spec in params.items()},
        states={
            s: State(
                s,
                [_rule(r, value_span(rules, i, span)) for i, r in enumerate(rules)],
                key_span(states, s, span),
            )
            for s, rules in states.items()
        },
        span=span,
        first_match=_items(raw, "first_match", span),
        allow=_allow(raw, span),
        results={r: _typed(r, spec, key_span(results, r, span)) for r, spec in results.items()},
        reasons=_items(raw, "reasons", span),
        lets={
            k: Located(v, value_span(raw["let"], k, span))
            for k, v in (raw.get("let") or {}).items()
        },
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
        hooks_module=_optional(data, "hooks_module", top),
        world_reads=_items(world, "reads", top),
        world_writes=_items(world, "writes", top),
        constants={k: Located(v, key_span(constants, k, top)) for k, v in constants.items()},
        locals={k: _typed(k, v, key_span(local_specs, k, top)) for k, v in local_specs.items()},
        predicates={k: Located(v, value_span(predicates, k, top)) for k, v in predicates.items()},
        hooks={k: _hook(k, v, key_span(hooks, k, top)) for k, v in hooks.items()},
        commands=with_default_tables(
            {k: _command(k, v, key_span(commands, k, top)) for k, v in commands.items()},
            [str(s) for s in data.get("subordinates") or []],
            top,
        ),
        display=display,
        span=top,
        name_span=value_span(data, "controller", top),
        every_cycle=[
            _rule(r, value_span(data["every_cycle"], i, top))
            for i, r in enumerate(data.get("every_cycle") or [])
        ],
        hooks_state=_optional(data, "hooks_state", top),
        hooks_state_on_restart=str(data.get("hooks_state_on_restart", "refuse")),
        functions={
            k: _function(k, v, key_span(data["functions"], k, top))
            for k, v in (data.get("functions") or {}).items()
        },
        echo_timeouts={
            k: Located(v, value_span(data["echo_timeouts"], k, top))
            for k, v in (data.get("echo_timeouts") or {}).items()
        },
        on_lost={
            k: Located(v, value_span(data["on_lost"], k, top))
            for k, v in (data.get("on_lost") or {}).items()
        },
        plans={
            k: _plan(k, v, key_span(data["plans"], k, top))
            for k, v in (data.get("plans") or {}).items()
        },
        properties=build_properties(data, top),
    )


def _optional(data: Any, key: str, top: Span) -> Located | None:
    """`data[key]` with its span, None when it is not given."""
    return Located(data[key], value_span(data, key, top)) if key in data else None


def _hook(name: str, raw: Any, span: Span) -> Hook:
    deadline = (
        Located(raw["deadline"], value_span(raw, "deadline", span)) if "deadline" in raw else None
    )
    return Hook(
        name,
        raw.get("doc", ""),
        _items(raw, "args", span),
        _items(raw, "returns", span),
        span,
        deadline,
    )


def _function(name: str, raw: Any, span: Span) -> Function:
    return Function(
        name,
        raw.get("doc", ""),
        {param: NAMED[kind] for param, kind in (raw.get("params") or {}).items()},
        NAMED[raw["returns"]],
        Located(raw["body"], value_span(raw, "body", span)),
        span,
    )


def _plan(name: str, raw: Any, span: Span) -> Plan:
    return Plan(
        name,
        raw.get("doc", ""),
        Located(raw["planner"], value_span(raw, "planner", span)),
        _items(raw, "args", span),
        {name: NAMED[kind] for name, kind in raw["steps"].items()},
        int(raw["capacity"]),
        int(raw.get("replans", 0)),
        span,
        Located(raw["deadline"], value_span(raw, "deadline", span)) if "deadline" in raw else None,
    )


def build_operator(data: Any, display: str) -> ControllerSpec:
    """The model of a schema-valid operator document: a module with tasks (commands with
    instruction text, parameters and reasons) and no table; INIT and HALT are its own
    (they withdraw a request), kept as commands without states."""
    top = span_of(data, Span(display))
    commands = data["commands"]
    tasks = {}
    for name, raw in commands.items():
        span = key_span(commands, name, top)
        task = _command(name, {k: v for k, v in raw.items() if k != "text"}, span)
        task.text = Located(raw["text"], value_span(raw, "text", span))
        tasks[name] = task
    builtin = {
        "INIT": "Withdraw the client's open request, if any.",
        "HALT": "Withdraw the client's open request, if any.",
    }
    return ControllerSpec(
        name=data["operator"],
        title=data["title"],
        doc=data.get("doc", ""),
        subordinates=[],
        hooks_module=None,
        world_reads=[],
        world_writes=[],
        constants={},
        locals={},
        predicates={},
        hooks={},
        commands={  # a declared INIT or HALT stays, for check's E284
            **{n: Command(n, doc, {}, {}, top, generated=True) for n, doc in builtin.items()},
            **tasks,
        },
        display=display,
        span=top,
        name_span=value_span(data, "operator", top),
        kind=ModuleKind.OPERATOR,
    )


# ---------------------------------------------------------------- QQ1's default tables

ENTRY_STATE = "S0"  # where every new command starts


def with_default_tables(
    declared: dict[str, Command], subordinates: list[str], span: Span
) -> dict[str, Command]:
    """INIT and HALT first (the declared table, or QQ1's default), then the other commands."""
    commands = {
        name: declared.get(name) or default_table(name, subordinates, span)
        for name in BUILTIN_COMMANDS
    }
    commands.update((name, c) for name, c in declared.items() if name not in commands)
    return commands


def default_table(command: str, subordinates: list[str], span: Span) -> Command:
    """QQ1's INIT/HALT table: pass the command to every subordinate, wait for all DONE."""
    done = Rule("", None, [Report("DONE", span)], None, span)
    if not subordinates:
        states = {ENTRY_STATE: State(ENTRY_STATE, [done], span)}
    else:
        sends: list[Action] = [Send(sub, command, {}, span) for sub in subordinates]
        wait = " and ".join(f"{sub}.status == DONE" for sub in subordinates)
        send_all = Rule(
            f"send {command} to every subordinate", None, sends, Located("S1", span), span
        )
        all_done = Rule(
            "every subordinate is done", Located(wait, span), [Report("DONE", span)], None, span
        )
        states = {
            ENTRY_STATE: State(ENTRY_STATE, [send_all], span),
            "S1": State("S1", [all_done], span),
        }
    doc = {"INIT": "Initialise this controller and its subordinates.", "HALT": "Halt all actions."}
    return Command(command, doc[command], {}, states, span, generated=True)


def duration_in_cycles(value: object, period: float) -> int:
    """A schema-valid duration (seconds, `2 s`, `500 ms`, `20 cycles`) as whole cycles of
    `period` seconds, rounded up: a limit is never shorter than asked."""
    if isinstance(value, int | float):
        seconds = float(value)
    else:
        number, unit = _DURATION.fullmatch(str(value).strip()).groups()  # type: ignore[union-attr]
        if unit.startswith("cycle"):
            return int(float(number))
        seconds = float(number) / (1000 if unit == "ms" else 1)
    return max(1, math.ceil(seconds / period - 1e-9))


def duration_seconds(value: object, period: float) -> float:
    """A schema-valid duration in seconds (`20 cycles` of `period` seconds is 20 periods)."""
    if isinstance(value, int | float):
        return float(value)
    number, unit = _DURATION.fullmatch(str(value).strip()).groups()  # type: ignore[union-attr]
    if unit.startswith("cycle"):
        return float(number) * period
    return float(number) / (1000 if unit == "ms" else 1)


def exact_cycles(value: object, period: float) -> tuple[int, bool]:
    """A schema-valid duration as cycles of `period` seconds, rounded up (0 stays 0), and
    whether that is exact: a duration in seconds that is not a whole number of cycles (to
    one part in a million) is rounded up, so a limit is never shorter than asked."""
    if isinstance(value, int | float):
        seconds = float(value)
    else:
        number, unit = _DURATION.fullmatch(str(value).strip()).groups()  # type: ignore[union-attr]
        if unit.startswith("cycle"):
            whole = float(number)
            return math.ceil(whole), whole == int(whole)
        seconds = float(number) / (1000 if unit == "ms" else 1)
    cycles = seconds / period
    nearest = round(cycles)
    if abs(cycles - nearest) <= 1e-6 * max(1.0, cycles):
        return nearest, True
    return math.ceil(cycles), False


_DURATION = re.compile(r"([0-9]+(?:\.[0-9]+)?)\s*(s|ms|cycles?)")
