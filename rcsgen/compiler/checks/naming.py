"""Naming: spec names -> their Python names, and every name-collision diagnostic (E228, E6xx).

Kept in one place so a collision is found before emission, never by a failing import.

Identifier policy (`check_spec`, run by `check.check_system` before anything else):

- every name is a plain ASCII identifier that matches its pattern in full (E601). The JSON
  Schema patterns (`^[a-z][a-z0-9_]*$`) are searched with Python's `re`, where `$` also
  matches before a final line break, so a quoted `"S1\\n"` passes the schema; it fails here;
- a name that becomes a Python name may not be a keyword or shadow a standard-library
  module or an expression builtin, and no two spec names may become the same Python name
  in one namespace of the generated package: the layout module, a controller class, the
  package's files (E228, the code `check` uses for the collisions it finds itself);
- one-line text (titles, rule docs) may not contain a line break (E602). Every other text
  reaches generated code only through `emit`'s `docstring` and `comment` filters.

Spec names never become bare local or module-level lower-case names of generated code:
lower-case names are printed as attributes (`self.var_x`, `self.world_x`, `self.cc_status`,
`self.<predicate>()`, `hooks.<hook>`), upper-case names as module constants. So `abs`,
`min`, `max`, `self`, `hooks`, `buf`, `state` or `command` cannot be shadowed as variables;
they are reserved here only where they would collide with an attribute or method.
"""

from __future__ import annotations

import keyword
import re
import sys
from collections import ChainMap
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache

from ...runtime.contract import (
    BUILTIN_COMMANDS,
    COMMAND_HEAD_FIELDS,
    MODE_FIELDS,
    PERF_FIELDS,
    STATUS_FIELDS,
    field_names,
)
from ..diagnostics import Diagnostics, Span
from ..expressions import BUILTIN_REASONS, BUILTINS, PLAN_PROPERTIES, STATUS_NAMES, Ref, RefKind
from ..front_end.loader import span_of
from ..front_end.model import (
    Action,
    CallHook,
    Command,
    ControllerSpec,
    PlanAction,
    Send,
    SetWorld,
    SystemSpec,
    Typed,
)
from ..types import Enum, Type
from .tables import TargetKind

# Names an expression gives a meaning of their own, which no controller can take (as a
# subordinate, `world.status` would read a world field).
RESERVED_MODULE_NAMES = {
    "world": "`world.<field>` names a world field in every expression and assignment",
}
# Methods every generated controller class has: the QQ1 cycle, its four steps written out
# in one method (Appendix D's pre_process ... post_process are comments in it, not methods).
FIXED_METHODS = frozenset({"run_cycle"})
# Modules every generated package has besides one per controller.
FIXED_MODULES = frozenset({"layout", "rcs", "__init__", "__main__", "hooks"})
# Module-level names a generated controller module has, whatever its spec names, exactly
# (tests/test_module_names.py compares them with every committed generated module):
RUNTIME_NAMES = frozenset(
    # what it imports from the contract (rcs/contract.py): statuses its rules compare with
    # or report (NOT_READY only where a guard names it), the block's word view, the
    # seqlock's tries, a string field's codec, an error's cause, a plan's problem
    {"NOT_READY", "EXECUTING", "DONE", "ERROR", "NOP", "NO_RULE", "STATUS", "PERF", "words"}
    | {"performance", "untimed"}
    | {"READ_TRIES", "decode_text", "encode_text", "caused", "HookError", "plan_problem"}
    # what it defines: its inputs' one read and the sequence words read again after it
    | {"INPUTS", "INPUTS_AT", "SEQ_WORDS"}
    # the standard library's, and its hooks module
    | {"Struct", "perf_counter_ns", "hooks"}
    # the hook calls: the helper that makes each a method, the factory's deadline
    | {"hook", "within", "FACTORY_DEADLINE"}
    # a world writer's overrides (rcs/override.py): the layout's table and flag offset
    | {"OVERRIDE", "OVERRIDDEN_AT", "held"}
)
# Prefixes of the attributes generated from spec names (world fields, params, locals).
ATTRIBUTE_PREFIXES = ("world_", "arg_", "var_", "perf_", "result_")


def attribute_of(field: str, buffer_fields: tuple[tuple[str, str], ...]) -> str:
    """The controller attribute a buffer field is copied to (the performance buffer's
    single_step_num is kept apart from the mode buffer's)."""
    if buffer_fields is PERF_FIELDS and field == "single_step_num":
        return "perf_single_step_num"
    return field


# Every attribute a generated controller keeps its own buffers in.
BUFFER_ATTRIBUTES = tuple(
    attribute_of(name, fields)
    for fields in (COMMAND_HEAD_FIELDS, STATUS_FIELDS, MODE_FIELDS, PERF_FIELDS)
    for name in field_names(fields)
)

# Attributes and methods of every generated controller class that no spec name produces,
# exactly (tests/test_module_names.py compares them with every committed generated class).
CLASS_NAMES = frozenset(
    {
        *FIXED_METHODS,
        "__init__",
        "__slots__",
        "every_cycle",  # method of the `every_cycle` rules
        "resume",
        "publish",  # its performance buffer written (rcs.contract.performance)
        "on_state",  # told its state as it writes its status (rcs/state_time.py)
        "read_inputs",  # pre_process's read again, when another process was writing
        "world_set",  # an every_cycle rule set a world output
        "HOOK_STATE_ON_RESTART",
        "safe_state",
        "status_seq",
        "status_dirty",
        "perf_seq",
        "buf",
        "hook_state",
        "ticks",  # cycles in the current state (`after:`)
        "words",  # its sequence words (rcs.contract.words over its buffer)
        "cause",  # the chain of causes its status reports with an ERROR
        "inputs",  # the inputs of its last cycle (an idle cycle with nothing new stops short)
        *BUFFER_ATTRIBUTES,
    }
)
# Module-level names of the generated layout module that no spec name produces, exactly
# (tests/test_module_names.py compares them with every committed layout).
LAYOUT_NAMES = frozenset(
    {
        "annotations",
        "Struct",
        "SIZE",
        "STATUS",
        "MODE",
        "PERF",
        "Record",
        "MODULES",
        "COMMAND_IN",
        "STATUS_OUT",
        "MODE_IN",
        "PERFORMANCE",
        "WORLD",
        "WORLD_INITIAL",
        "COMMAND_NAMES",
        "STATE_NAMES",
        "SIMULATORS",
        "RULES",
        "initialise",
        "HEADER",
        "MAGIC",
        "PROCESS",
        "PROCESS_FIELDS",
        "SEQ",
        "FIRST_SEQ",
        "MODE_FIELDS",
        "PERF_FIELDS",
        "STATUS_FIELDS",
        "NO_COMMAND_NAME",
        "field_names",
        "SYSTEM",
        "SOURCE",
        "HEARTBEAT_TIMEOUT",
        "STARTUP_TIMEOUT",
        "SUBORDINATES",
        "LAYOUT_HASH",
        "PROCESSES",
        "PLACEMENT",
        "PACE",
        "PACE_FIELDS",
        "PACING",
        "STAND_INS",
        "PARAMS",
        "SETTINGS",
        "READS_SETTINGS",
        "ROLES",
        "ROLE_HOLDERS",
        "SEGMENT_GROUP",
        "WORLD_WRITERS",
        "GROUND_TRUTH",
        "ACTUATED_BY",
        "WRITES",
        "SAFE_VALUES",
        "OVERRIDE",
        "OVERRIDES",
        "OVERRIDES_AT",
        "OVERRIDDEN_AT",
        "CAUSE_MODULES",
        "REASON_NAMES",
        "ON_LOST_CONTINUE",
        "REQUESTS",
        "TIME_IN_STATE",
        "ENUMS",
        # a system with operator modules
        "ANSWER",
        "ANSWERS",
        "ANSWER_FIELDS",
        "OPERATORS",
        "OPERATOR_STATES",
        "INSTRUCTIONS",
        "TASK_RESULTS",
        # a system with fieldbus devices
        "Device",
        "Point",
        "DEVICE_FIELDS",
        "IO_DEVICES",
        "IO_RECORDS",
        "IO_DEPENDENTS",
    }
)
# Suffixes of the attributes a controller keeps for each subordinate (`cc_status`, ...).
SUB_SUFFIXES = ("_command_num", "_command", "_status_num", "_status", "_written", "_sent_at")
# Suffixes of the layout names of each controller's buffers: CO_COMMAND, CO_COMMAND_AT, ...
BUFFER_SUFFIXES = ("_COMMAND", "_COMMAND_AT", "_STATUS_AT", "_MODE_AT", "_PERF_AT")
CHANNEL_SUFFIXES = ("_COMMAND", "_COMMAND_AT", "_STATUS_AT", "_ANSWER_AT")


def channel_prefix(operator: str, client: str) -> str:
    """The layout's prefix of an operator module's channel to a client: `OP_FX`."""
    return f"{operator}_{client}".upper()


# The full-match patterns of the spec's names (the schema's, anchored with \Z in effect).
LOWER = re.compile(r"[a-z][a-z0-9_]*", re.ASCII)
UPPER = re.compile(r"[A-Z][A-Z0-9_]*", re.ASCII)
DOTTED = re.compile(r"[a-z_][a-z0-9_]*(\.[a-z_][a-z0-9_]*)*", re.ASCII)
TARGET = re.compile(r"((world|result)\.)?[a-z][a-z0-9_]*", re.ASCII)
_PATTERN_WORDS = {
    LOWER: "a lower_case identifier (a-z, then a-z, 0-9, _)",
    UPPER: "an UPPER_CASE identifier (A-Z, then A-Z, 0-9, _)",
    DOTTED: "a dotted lower_case Python module name",
    TARGET: "`world.<field>`, `result.<name>` or a lower_case local name",
}
# Every character `str.splitlines` breaks a line at (Python's tokenizer knows \n and \r;
# editors and other tools also break at the rest).
LINE_BREAKS = frozenset("\n\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029")


def command_method(command: str) -> str:
    """The state-table method of a command: SUMP_SHEAR_CUSP -> sump_shear_cusp, RAISE ->
    raise_ (a keyword gets a trailing underscore, so every command name can be used)."""
    method = command.lower()
    return f"{method}_" if keyword.iskeyword(method) else method


def held_attribute(command: str | None, state: str | None, index: int) -> str:
    """The counter of a `for:` rule: cycles its `when` has held, without a break, in its
    state (HOLD_ICE, S1, rule 2 -> held_hold_ice_s1_2), or for an every_cycle rule (no
    command: rule 1 -> held_every_cycle_1)."""
    if command is None or state is None:
        return f"held_every_cycle_{index}"
    return f"held_{command.lower()}_{state.lower()}_{index}"


def plan_attribute(plan: str, name: str) -> str:
    """The attribute a plan's step field or property is kept in: route, x -> plan_route_x,
    route, step -> plan_route_step (the plan's own list of steps is `plan_route`)."""
    return f"plan_{plan}_{name}"


def plan_method(plan: str, name: str) -> str:
    """A method a plan makes: route, load -> plan_route_load (its steps checked and loaded),
    route, go -> plan_route_go (a step made current)."""
    return f"plan_{plan}_{name}"


def plan_attributes(plan: str, fields: Iterable[str]) -> list[str]:
    """Every attribute and method a plan makes in its controller's class."""
    names = [f"plan_{plan}", plan_method(plan, "load"), plan_method(plan, "go")]
    return names + [plan_attribute(plan, n) for n in [*fields, *PLAN_PROPERTIES]]


def sub_attribute(sub: str, suffix: str) -> str:
    """An attribute its supervisor keeps for a subordinate (a suffix of SUB_SUFFIXES, or
    `_error_num`, `_result_<name>`): cc, _status -> self.cc_status."""
    return f"self.{sub}{suffix}"


def sub_arg_attribute(sub: str, param: str) -> str:
    """The attribute a parameter of a command sent to a subordinate is kept in: cr, x ->
    self.cr_arg_x (copied into its command buffer)."""
    return f"self.{sub}_arg_{param}"


def sub_command_const(sub: str, command: str) -> str:
    """A subordinate's command code as its supervisor names it: cc, SUMP -> CC_SUMP."""
    return f"{sub.upper()}_{command}"


def process_module(process: str) -> str:
    return f"main_{process}"


def class_name(mnemonic: str) -> str:
    return "".join(part.capitalize() for part in mnemonic.split("_")) + "Controller"


def attribute(ref: Ref) -> str:
    """The Python text a resolved name is printed as inside a controller method."""
    name, owner = ref.name, ref.owner
    match ref.kind:
        case RefKind.WORLD:
            return f"self.world_{name}"
        case RefKind.PARAM:
            return f"self.arg_{name}"
        case RefKind.LOCAL:
            return f"self.var_{name}"
        case RefKind.CONST | RefKind.STATUS:
            return name
        case RefKind.TIME:  # cycles in the current state (`after:`)
            return "self.ticks"
        case RefKind.HELD:  # cycles a `for:` rule's guard has held
            return f"self.{name}"
        case RefKind.PLAN:  # a plan's current step field or property: route.x
            return f"self.{plan_attribute(owner, name)}"
        case RefKind.SUB_STATUS:
            return f"self.{owner}_status"
        case RefKind.SUB_COMMAND:
            return f"self.{owner}_command"
        case RefKind.SUB_COMMAND_NAME:
            return sub_command_const(owner, name)
        case RefKind.SUB_RESULT:
            return f"self.{owner}_result_{name}"
        case RefKind.SUB_REASON:
            return f"self.{owner}_error_num"
        case RefKind.SUB_REASON_NAME:
            return sub_reason_const(owner, name)
        case RefKind.PREDICATE:
            return f"self.{name}"
        case RefKind.LET | RefKind.ARG | RefKind.FUNCTION:  # a method's local, a parameter
            return name
    raise ValueError(f"no Python name for {ref!r}")


def target_attribute(kind: TargetKind, name: str) -> str:
    """Where an assignment's target is kept: world.goal_x -> self.world_goal_x, a local
    ticks -> self.var_ticks, result.at_goal -> self.result_at_goal."""
    return f"self.{_TARGET_PREFIXES[kind]}{name}"


_TARGET_PREFIXES = {
    TargetKind.WORLD: "world_",
    TargetKind.LOCAL: "var_",
    TargetKind.RESULT: "result_",
}


def reason_const(reason: str) -> str:
    """A controller's own reason code as its module names it: REFUSED -> REASON_REFUSED."""
    return f"REASON_{reason}"


def sub_reason_const(sub: str, reason: str) -> str:
    """A subordinate's reason code as its supervisor names it: fx, REFUSED -> FX_REASON_REFUSED."""
    return f"{sub.upper()}_REASON_{reason}"


def import_order(name: str) -> tuple[int, str]:
    """The key ruff's isort sorts imported names by: constants, then classes, then the rest
    (`order-by-type`), each case-insensitively (`C_AT` < `CC_AT`)."""
    kind = 0 if name.isupper() else 1 if name[:1].isupper() else 2
    return kind, name.lower()


def is_keyword(name: str) -> bool:
    return keyword.iskeyword(name) or keyword.issoftkeyword(name)


def is_identifier(name: object, pattern: re.Pattern[str] = LOWER) -> bool:
    """Whether `name` is a string matching `pattern` in full (ASCII only, no line break)."""
    return isinstance(name, str) and pattern.fullmatch(name) is not None


def shown(text: object, limit: int = 40) -> str:
    """Text for a message: control characters escaped, cut to `limit` characters."""
    flat = repr(str(text))[1:-1]
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def line_break(text: object) -> str | None:
    """The first line-break character in `text`, or None."""
    return next((ch for ch in str(text) if ch in LINE_BREAKS), None)


# ---------------------------------------------------------------- the policy check


@dataclass(frozen=True)
class _Claim:
    what: str  # words for the message: "local `x`", "a generated attribute"
    span: Span | None  # None: a name the generated code always has
    origin: object  # the same origin claiming a name twice is no collision


class _Namespace:
    """One namespace of the generated code: reports the second spec name of a Python name."""

    def __init__(self, where: str, diags: Diagnostics, fold: bool = False) -> None:
        self.where, self.diags, self.fold = where, diags, fold
        self.names: dict[str, _Claim] = {}
        self.reported: set[tuple[object, object]] = set()  # one error per pair of claims

    def fixed(self, names: Iterable[str], what: str) -> None:
        for name in names:
            self.names.setdefault(name, _Claim(what, None, ("fixed", name)))

    def claim(self, name: str, what: str, span: Span, origin: object = None) -> None:
        key = name.casefold() if self.fold else name
        first = self.names.get(key)
        origin = origin if origin is not None else (what, span)
        if first is None:
            self.names[key] = _Claim(what, span, origin)
        elif first.origin != origin and (first.origin, origin) not in self.reported:
            self.reported.add((first.origin, origin))
            where = f" ({first.span})" if first.span is not None else ""
            self.diags.error(
                span,
                "E228",
                f"{what} becomes `{name}` {self.where}, which is already {first.what}{where}",
                "rename one of them",
            )


def check_spec(system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics) -> None:
    """Report every name or text of the specs that generated code could not hold safely."""
    bad = Diagnostics()
    _check_identifiers(system, controllers, bad)
    _check_texts(system, controllers, bad)
    diags.extend(bad.items)
    if bad.errors:
        return  # collisions of malformed names would only repeat the problem
    by_name = {c.name: c for c in controllers}
    _check_package(system, controllers, diags)
    _check_layout(system, controllers, diags)
    for spec in controllers:
        _check_controller(spec, by_name, diags)


NameUse = tuple[object, re.Pattern[str], str, Span]  # (name, pattern, kind, where written)


def _names(system: SystemSpec, controllers: list[ControllerSpec]) -> Iterator[NameUse]:
    """(name, pattern, kind, span) of every name written in the specs."""
    top = system.span
    yield system.name, LOWER, "system name", span_of(system.name, top)
    for field_name, f in system.world.items():
        yield field_name, LOWER, "world field name", span_of(field_name, f.span)
    for process in system.processes:
        yield process.name, LOWER, "process name", span_of(process.name, process.span)
        for module in process.modules:
            yield module.value, LOWER, "controller mnemonic", module.span
    for sim in system.simulators:
        yield sim.value, LOWER, "controller mnemonic", sim.span
    for name, stand_in in system.stand_ins.items():
        yield name, LOWER, "controller mnemonic", span_of(name, stand_in.span)
        yield stand_in.value, LOWER, "controller mnemonic", stand_in.span
    for spec in controllers:
        yield from _controller_names(spec)


def _controller_names(spec: ControllerSpec) -> Iterator[NameUse]:
    top = spec.span
    yield spec.name, LOWER, "controller mnemonic", spec.name_span
    for sub in spec.subordinates:
        yield sub.value, LOWER, "controller mnemonic", sub.span
    if spec.hooks_module is not None:
        yield spec.hooks_module.value, DOTTED, "module name", spec.hooks_module.span
    hooks_state = spec.hooks_state
    if hooks_state is not None:
        yield hooks_state.value, LOWER, "hook name", hooks_state.span
    for item in [*spec.world_reads, *spec.world_writes]:
        yield item.value, LOWER, "world field name", item.span
    for name, item in spec.constants.items():
        yield name, UPPER, "constant name", item.span
    for name, local in spec.locals.items():
        yield name, LOWER, "local name", local.span
    for name, item in spec.predicates.items():
        yield name, LOWER, "predicate name", span_of(name, item.span)
    for name, hook in spec.hooks.items():
        yield name, LOWER, "hook name", hook.span
        for target in hook.returns:
            yield target.value, TARGET, "assignment target", target.span
    rules = list(spec.every_cycle)
    for name, command in _written(spec):
        yield name, UPPER, "command name", command.span
        for param_name, param in command.params.items():
            yield param_name, LOWER, "parameter name", param.span
        for state_name, state in command.states.items():
            yield state_name, UPPER, "state name", state.span
            rules += state.rules
        for item in command.first_match:
            yield item.value, UPPER, "state name", item.span
    for rule in rules:
        if rule.next is not None:
            yield rule.next.value, UPPER, "state name", rule.next.span
        for action in rule.actions:
            yield from _action_names(action, top)


def _written(spec: ControllerSpec) -> list[tuple[str, Command]]:
    """The commands a spec writes out (not the default INIT/HALT tables rcsgen supplies)."""
    return [(name, c) for name, c in spec.commands.items() if not c.generated]


def _action_names(action: Action, top: Span) -> Iterator[NameUse]:
    match action:
        case Send():
            yield action.sub, LOWER, "controller mnemonic", action.span
            yield action.command, UPPER, "command name", action.span
            for name in action.args:
                yield name, LOWER, "parameter name", action.arg_spans.get(name, action.span)
        case SetWorld():
            for assign in action.assignments:
                yield assign.target.value, TARGET, "assignment target", assign.target.span
        case CallHook():
            yield action.hook, LOWER, "hook name", action.span
        case PlanAction():
            yield action.plan, LOWER, "plan name", action.span


# The longest name (each part of a dotted one): it becomes part of file names such as
# `main_<process>.py` and `<mnemonic>.yaml`, which most file systems limit to 255 bytes.
MAX_NAME = 100


def _check_identifiers(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    for name, pattern, kind, span in _names(system, controllers):
        if not is_identifier(name, pattern):
            diags.error(
                span,
                "E601",
                f"`{shown(name)}` is not a valid {kind}: expected {_PATTERN_WORDS[pattern]}",
                "names are plain ASCII identifiers; remove the line break or other character",
            )
        elif any(len(part) > MAX_NAME for part in str(name).split(".")):
            diags.error(
                span,
                "E601",
                f"`{shown(name)}` is too long for a {kind}: {len(str(name))} characters, "
                f"at most {MAX_NAME}",
                "names become file and Python names (a file name is limited to 255 bytes); "
                "shorten it",
            )


def _check_texts(system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics) -> None:
    """Titles and rule docs are one line: a line break in them is an error, located."""
    texts = [("title", system.title, system.span)]
    for spec in controllers:
        texts.append(("title", spec.title, spec.span))
        rules = list(spec.every_cycle)
        for _, command in _written(spec):
            for state in command.states.values():
                rules += state.rules
        texts += [("rule doc", rule.doc, rule.span) for rule in rules if rule.doc]
        texts += [
            ("task's instruction text", c.text.value, c.text.span)
            for c in spec.commands.values()
            if c.text is not None
        ]
    for kind, text, fallback in texts:
        found = line_break(text)
        if found is not None:
            diags.error(
                span_of(text, fallback),
                "E602",
                f"a {kind} is one line, but this one has a line break ({found!r})",
                f"write the {kind} on one line; a `doc:` of a command or controller may have "
                "several",
            )


def _check_package(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    """The package, its files and the controller classes: one Python name each."""
    name_span = span_of(system.name, system.span)
    if keyword.iskeyword(system.name):
        diags.error(name_span, "E228", f"system name `{system.name}` is a Python keyword")
    elif system.name in sys.stdlib_module_names:
        diags.error(
            name_span,
            "E228",
            f"system name `{system.name}` shadows the standard-library module `{system.name}`",
            "the system is a top-level package: give it a name of its own",
        )
    files = _Namespace("as a file of the generated package", diags, fold=True)
    files.fixed((f"{m}.py" for m in FIXED_MODULES), "a generated module")
    for spec in controllers:
        if not is_keyword(spec.name) and spec.name not in FIXED_MODULES:  # else check's E228
            what = f"controller `{spec.name}`"
            files.claim(f"{spec.name}.py", what, spec.name_span, ("controller", spec.name))
    for process in system.processes:
        span = span_of(process.name, process.span)
        files.claim(f"{process_module(process.name)}.py", f"process `{process.name}`", span)
    classes = _Namespace("as a class name", diags)
    for spec in controllers:
        what = f"controller `{spec.name}`"
        classes.claim(class_name(spec.name), what, spec.name_span, ("controller", spec.name))
    for spec in controllers:
        module = spec.hooks_module
        if module is None:
            continue
        parts = str(module.value).split(".")
        if any(keyword.iskeyword(p) for p in parts):
            word = next(p for p in parts if keyword.iskeyword(p))
            diags.error(
                module.span,
                "E228",
                f"hooks module `{module.value}`: `{word}` is a Python keyword",
                "the generated code imports this module: rename it",
            )
        elif parts[0] in sys.stdlib_module_names or parts[0] == system.name:
            what = "a standard-library module" if parts[0] != system.name else "the system"
            diags.error(
                module.span,
                "E228",
                f"hooks package `{parts[0]}` has the name of {what}",
                "name the hooks package after the system, e.g. `<system>_hooks`",
            )


def _check_layout(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    """The module-level names of the generated layout module."""
    names = _Namespace("in the generated layout module", diags)
    names.fixed(LAYOUT_NAMES, "a name the layout module always has")
    by_name = {spec.name: spec for spec in controllers}
    for spec in controllers:
        up = spec.name.upper()
        for suffix in BUFFER_SUFFIXES:
            names.claim(up + suffix, f"controller `{spec.name}`", spec.name_span, spec.name)
        for sub in spec.subordinates:
            if sub.value in by_name and by_name[sub.value].is_operator:
                what = f"`{sub.value}`'s channel to `{spec.name}`"
                for suffix in CHANNEL_SUFFIXES:
                    names.claim(channel_prefix(sub.value, spec.name) + suffix, what, sub.span)
    for process in system.processes:  # its control record and its pacing record
        span = span_of(process.name, process.span)
        for name in (f"PROCESS_{process.name.upper()}_AT", f"PACE_{process.name.upper()}_AT"):
            names.claim(name, f"process `{process.name}`", span, ("process", process.name))
    for field_name, f in system.world.items():
        span = span_of(field_name, f.span)
        up = f"WORLD_{field_name.upper()}"
        for name in (up, up + "_AT"):
            names.claim(name, f"world field `{field_name}`", span, ("world", field_name))


def _check_controller(
    spec: ControllerSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> None:
    """The attributes and methods of one generated controller class."""
    names = _Namespace(f"in the generated class of `{spec.name}`", diags)
    names.fixed(CLASS_NAMES, "an attribute or method every controller has")
    _claim_attributes(spec, by_name, names)
    _claim_counters(spec, names)
    _check_constants(spec, diags)
    subs = {s.value for s in spec.subordinates}
    methods = {command_method(c) for c in spec.commands} | {"init", "halt"}
    for name, item in spec.predicates.items():
        span = span_of(name, item.span)
        if name in BUILTINS:
            diags.error(
                span,
                "E228",
                f"predicate `{name}` would hide the expression builtin `{name}()`",
                "rename the predicate",
            )
        elif not _reported_by_check(name, methods, subs):
            names.claim(name, f"predicate `{name}`", span)
    for name, command in spec.commands.items():
        method = command_method(name)
        if method not in FIXED_METHODS:  # those are check's E228
            names.claim(method, f"command `{name}`", command.span)
    # each hook and planner is called through a method of its own, hook_<name>
    for name, hook in spec.hooks.items():
        names.claim(f"hook_{name}", f"hook `{name}`", hook.span, ("hook", name))
    for plan in spec.plans.values():
        planner = plan.planner
        what = f"planner `{planner.value}`"
        names.claim(f"hook_{planner.value}", what, planner.span, ("hook", planner.value))


def _claim_attributes(
    spec: ControllerSpec, by_name: dict[str, ControllerSpec], names: _Namespace
) -> None:
    """The attributes a controller keeps for its subordinates, world fields, locals and
    parameters."""
    for sub in spec.subordinates:
        origin = ("sub", sub.value)
        what = f"subordinate `{sub.value}`"
        for suffix in SUB_SUFFIXES:
            names.claim(sub.value + suffix, what, sub.span, origin)
        other = by_name.get(sub.value)
        for command in other.commands.values() if other else ():
            for param in command.params:
                names.claim(f"{sub.value}_arg_{param}", what, sub.span, origin)
    for item in [*spec.world_reads, *spec.world_writes]:
        field_name = item.value
        names.claim(f"world_{field_name}", f"world field `{field_name}`", item.span, field_name)
    for local_name, local in spec.locals.items():
        names.claim(f"var_{local_name}", f"local `{local_name}`", local.span, ("local", local_name))
    for command in spec.commands.values():
        for param_name, typed in command.params.items():
            names.claim(
                f"arg_{param_name}", f"parameter `{param_name}`", typed.span, ("param", param_name)
            )


def _claim_counters(spec: ControllerSpec, names: _Namespace) -> None:
    """The counters of its `for:` rules."""
    for index, rule in enumerate(spec.every_cycle, start=1):
        if rule.hold is not None:
            counter = held_attribute(None, None, index)
            names.claim(counter, "the `for:` counter of an every_cycle rule", rule.span)
    for command in spec.commands.values():
        for state in command.states.values():
            for index, rule in enumerate(state.rules, start=1):
                if rule.hold is not None:
                    counter = held_attribute(command.name, state.name, index)
                    names.claim(
                        counter, f"the `for:` counter of {command.name} {state.name}", rule.span
                    )


# The constant the system gives every controller's expressions: seconds per cycle.
CYCLE_PERIOD = "CYCLE_PERIOD"


def _check_constants(spec: ControllerSpec, diags: Diagnostics) -> None:
    """A constant may not have the name of a command or state: all are module constants.

    Reported at the constant (the lowering's own check would point at the first table with
    that state, which may be a default INIT/HALT table the user never wrote)."""
    states = {state for command in spec.commands.values() for state in command.states}
    given = [(item.span, "constant") for n, item in spec.constants.items() if n == CYCLE_PERIOD]
    given += [(c.span, "command") for n, c in spec.commands.items() if n == CYCLE_PERIOD]
    given += [
        (s.span, "state")
        for c in spec.commands.values()
        for n, s in c.states.items()
        if n == CYCLE_PERIOD
    ]
    for span, what in given:
        diags.error(
            span,
            "E297",
            f"`{CYCLE_PERIOD}` is the system's: the seconds per cycle of the controller's "
            f"process, which expressions read; a {what} cannot have its name",
            "rename it; to use the cycle period, write CYCLE_PERIOD in an expression",
        )
    for name, item in spec.constants.items():
        kind = "command" if name in spec.commands else None
        kind = kind or ("state" if name in states else None)
        if kind is not None:
            diags.error(
                span_of(name, item.span),
                "E228",
                f"constant `{name}` has the name of a {kind}: both become module constants",
                "rename the constant",
            )


def _reported_by_check(name: str, methods: set[str], subs: set[str]) -> bool:
    """Whether `check_controller_names` reports predicate `name` (no second error)."""
    return (
        is_keyword(name)
        or name in FIXED_METHODS
        or name in methods
        or name.startswith(ATTRIBUTE_PREFIXES)
        or any(name.startswith(f"{sub}_") for sub in subs)
    )


def check_controller_names(spec: ControllerSpec, diags: Diagnostics) -> None:
    """A controller's names that would collide in its generated module or class."""
    if is_keyword(spec.name) or spec.name in FIXED_MODULES:
        diags.error(spec.name_span, "E228", f"`{spec.name}` cannot name a controller module")
    elif spec.name in RESERVED_MODULE_NAMES:
        diags.error(
            spec.name_span,
            "E228",
            f"`{spec.name}` cannot name a controller: {RESERVED_MODULE_NAMES[spec.name]}",
            "rename the controller (and its file)",
        )
    _check_member_names(spec, diags)
    _check_slot_names(spec, diags)


def _check_member_names(spec: ControllerSpec, diags: Diagnostics) -> None:
    """Commands that would be QQ1 methods; predicates that would be generated names; hooks
    named like keywords."""
    for command in spec.commands.values():
        if command_method(command.name) in FIXED_METHODS:
            diags.error(
                command.span, "E228", f"command `{command.name}` collides with a QQ1 method"
            )
    methods = {command_method(c) for c in spec.commands}
    subs = {s.value for s in spec.subordinates}
    for name, item in spec.predicates.items():
        if _reported_by_check(name, methods, subs):
            diags.error(
                item.span, "E228", f"predicate name `{name}` collides with a generated name"
            )
    for name, hook in spec.hooks.items():
        if is_keyword(name):
            diags.error(hook.span, "E228", f"hook name `{name}` is a Python keyword")


def _check_slot_names(spec: ControllerSpec, diags: Diagnostics) -> None:
    """Parameters named like locals (E228); one type per parameter or result slot (E230,
    E253); no built-in reason declared (E254)."""
    commands = list(spec.commands.values())
    for name in spec.locals:
        for command in commands:
            if name in command.params:
                diags.error(
                    command.params[name].span,
                    "E228",
                    f"parameter `{name}` of {command.name} has the name of a local",
                    "rename one of them",
                )
    _one_type_per_slot(
        [(c.name, p) for c in commands for p in c.params.values()], "E230", "parameter", diags
    )
    _one_type_per_slot(
        [(c.name, r) for c in commands for r in c.results.values()], "E253", "result", diags
    )
    for reason in (r for command in commands for r in command.reasons):
        if reason.value in BUILTIN_REASONS:
            diags.error(
                reason.span,
                "E254",
                f"reason `{reason.value}` is built in: "
                + ("no reason given" if reason.value == "NONE" else "a subordinate was lost"),
                "declare only the reasons of your own errors",
            )


def _one_type_per_slot(
    named: list[tuple[str, Typed]], code: str, kind: str, diags: Diagnostics
) -> None:
    """Commands of one controller share a buffer slot per parameter (or result) name, so
    every declaration of a name has the first one's type."""
    first: dict[str, tuple[Type, str]] = {}
    for command, item in named:
        if item.name in first and first[item.name][0] != item.type:
            first_type, first_command = first[item.name]
            diags.error(
                item.span,
                code,
                f"{kind} `{item.name}` is {item.type} here but {first_type} in {first_command}",
                f"commands of one controller share a {kind} slot per name: use one type",
            )
        first.setdefault(item.name, (item.type, command))


def declared_reasons(spec: ControllerSpec) -> list[str]:
    """A controller's reasons in order of first declaration (codes from 2, after the
    built-in NONE = 0 and LOST = 1)."""
    found: dict[str, None] = {}
    for command in spec.commands.values():
        found.update((r.value, None) for r in command.reasons if r.value not in BUILTIN_REASONS)
    return list(found)


def check_module_names(
    spec: ControllerSpec,
    by_name: dict[str, ControllerSpec],
    system: SystemSpec,
    diags: Diagnostics,
    buffers: str | None = None,
) -> None:
    """Every module-level name of a generated controller module must be unique (`buffers`:
    whose buffers it runs in, a stand-in's those of the controller it replaces)."""
    taken = _generated_module_names(spec, by_name, system, buffers or spec.name)
    named: list[tuple[str, str, Span]] = [
        (c.name, "command", c.span) for c in spec.commands.values() if not c.generated
    ]
    named += [(n, "constant", c.span) for n, c in spec.constants.items()]
    states: dict[str, Span] = {}  # the same state in several tables is one constant
    for state in (s for command in spec.commands.values() for s in command.states.values()):
        states.setdefault(state.name, state.span)
    named += [(name, "state", span) for name, span in states.items()]
    named += _enum_value_names(spec, by_name, system, diags)
    for name, kind, span in named:
        if name in taken and not (kind == "command" and name in BUILTIN_COMMANDS):
            diags.error(
                span,
                "E228",
                f"{kind} `{name}` collides with {taken[name]} in the generated module",
                "rename it",
            )
        taken.setdefault(name, f"a {kind}")


def _generated_module_names(
    spec: ControllerSpec, by_name: dict[str, ControllerSpec], system: SystemSpec, buffers: str
) -> ChainMap[str, str]:
    """The module-level names a controller's generated module has whatever its spec names:
    the runtime's and the layout's, its subordinates' codes, its reasons', its world
    runs', the built-in commands; each with what it is (where two are named alike, the
    later of these). The world's layout names, the same in every module, are looked up
    where they were made once, not copied into every controller's names."""
    taken: dict[str, str] = {n: "a status or runtime name" for n in RUNTIME_NAMES}
    for sub in (s.value for s in spec.subordinates):
        taken.update(_subordinate_names(sub, spec.name, by_name[sub]))
    for reason in (*BUILTIN_REASONS, *declared_reasons(spec)):
        taken[reason_const(reason)] = f"the code of the reason {reason}"
    for suffix in (*_MODULE_BUFFER_SUFFIXES, "_STATUS"):  # _STATUS: its results' struct
        taken[buffers.upper() + suffix] = "a layout name"
    runs: dict[str, str] = {}
    for index in range(1, len(spec.world_writes) + 1):
        for name in (
            f"WORLD_OUT_{index}",
            f"WORLD_OUT_{index}_AT",
            f"WORLD_VALUES_{index}",
            f"WORLD_SEQS_{index}",
            f"WORLD_HELD_{index}",
        ):
            runs[name] = "a generated name"
    builtins = dict.fromkeys(BUILTIN_COMMANDS, "a command")
    return ChainMap(runs, _world_layout_names(tuple(system.world)), taken, builtins)


def _subordinate_names(sub: str, module: str, spec: ControllerSpec) -> dict[str, str]:
    """The names a supervisor's module has for a subordinate: its layout names (an operator
    module's: its channel to the supervisor), its command and reason codes, its echo
    timeout."""
    taken = {sub.upper() + suffix: "a layout name" for suffix in _MODULE_BUFFER_SUFFIXES}
    if spec.is_operator:  # its channel to this module
        for suffix in ("_COMMAND", "_COMMAND_AT", "_COMMAND_WORD"):
            taken[channel_prefix(sub, module) + suffix] = "a layout name"
    for sent in spec.commands:
        taken[sub_command_const(sub, sent)] = f"the code of {sub}'s {sent}"
    taken[f"{sub.upper()}_ECHO_CYCLES"] = f"{sub}'s echo timeout"
    taken[f"{sub.upper()}_LINK"] = f"{sub}'s number in the causes' chain"
    for reason in (*BUILTIN_REASONS, *declared_reasons(spec)):
        taken[sub_reason_const(sub, reason)] = f"the code of {sub}'s reason {reason}"
    return taken


def _enum_value_names(
    spec: ControllerSpec,
    by_name: dict[str, ControllerSpec],
    system: SystemSpec,
    diags: Diagnostics,
) -> list[tuple[str, str, Span]]:
    """The value names of every enumeration the controller's tables can name (its commands'
    parameters and results, its locals, its world fields, its subordinates' parameters and
    results), each once: they become module constants of their index. A name that is one
    index in one of them and another in another is E228."""
    seen = _typed_names(spec, by_name, system)
    found: dict[str, tuple[int, Typed]] = {}
    named = []
    for item in seen:
        for index, value in enumerate(item.type.values if isinstance(item.type, Enum) else ()):
            if value in STATUS_NAMES:
                continue  # E278 says so
            if value not in found:
                found[value] = (index, item)
                named.append((value, "enum value", item.span))
            elif found[value][0] != index and item.span != found[value][1].span:
                before, other = found[value]
                assert isinstance(item.type, Enum)
                found.update((v, (i, item)) for i, v in enumerate(item.type.values))
                diags.error(
                    item.span,
                    "E228",
                    f"enum value `{value}` is {index} in `{item.name}` but {before} in "
                    f"`{other.name}` ({other.span}): both name the constant `{value}` of "
                    f"`{spec.name}`'s module",
                    "give the enumerations their values in the same order, or rename one",
                )
    return named


def _typed_names(
    spec: ControllerSpec, by_name: dict[str, ControllerSpec], system: SystemSpec
) -> list[Typed]:
    """What a controller's tables can name that has a type: its world fields, its locals,
    its and its subordinates' commands' parameters and results."""
    access = [str(a.value) for a in [*spec.world_reads, *spec.world_writes]]
    seen: list[Typed] = [system.world[name] for name in access if name in system.world]
    seen += list(spec.locals.values())
    owners = [spec, *(by_name[str(s.value)] for s in spec.subordinates if s.value in by_name)]
    for command in (c for owner in owners for c in owner.commands.values()):
        seen += [*command.params.values(), *command.results.values()]
    return seen


# Suffixes of the layout names a controller module imports for itself and its subordinates,
# and of the indices of the sequence words it stores (`<buffer>_WORD`, made from them).
_MODULE_BUFFER_SUFFIXES = ("_COMMAND", "_COMMAND_AT", "_STATUS_AT", "_MODE_AT", "_PERF_AT") + (
    "_COMMAND_WORD",
    "_STATUS_WORD",
    "_PERF_WORD",
)


@lru_cache(maxsize=8)
def _world_layout_names(fields: tuple[str, ...]) -> dict[str, str]:
    """The layout's names of the world fields: the same for every controller, made once."""
    names = {}
    for name in fields:
        names[f"WORLD_{name.upper()}"] = names[f"WORLD_{name.upper()}_AT"] = "a layout name"
        names[f"WORLD_{name.upper()}_WORD"] = "a generated name"
    return names


def result_types(spec: ControllerSpec) -> dict[str, Type]:
    """A controller's results (one slot per name, in order of first declaration) -> type."""
    found: dict[str, Type] = {}
    for command in spec.commands.values():
        for name, result in command.results.items():
            found.setdefault(name, result.type)
    return found
