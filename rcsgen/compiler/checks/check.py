"""Check: the input model -> semantic diagnostics and, when clean, the checked system.

Resolves every name (subordinates, commands, states, world fields, params, locals,
predicates, hooks), checks the hierarchy (one supervisor each, no cycles, every module
in exactly one process) and each state table (S0 present, targets defined, every state
reachable), and types every expression, keeping the typed trees and scopes for the later
stages (`tables` holds the checked system's types). All problems are collected first.
"""

from __future__ import annotations

import ast
import builtins
import keyword
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from ...runtime.contract import BUILTIN_COMMANDS
from .. import expressions as expr
from ..diagnostics import Diagnostics, Span, Subject, known_names_hint, listed, number_shown
from ..front_end import model
from ..front_end.model import Command, ControllerSpec, Located, PlanVerb, Rule, SystemSpec
from ..types import BOOL, FLOAT, INT, Enum, Str, Type, annotation_accepts, hook_words
from . import acknowledge, hook_checks, io, naming, operators
from .tables import (
    ENTRY_STATE,
    Action,
    Assign,
    CallHook,
    CheckedCommand,
    CheckedController,
    CheckedFunction,
    CheckedLet,
    CheckedPredicate,
    CheckedProcess,
    CheckedRule,
    CheckedState,
    CheckedSystem,
    PlanAction,
    Report,
    RuleId,
    Send,
    Target,
    TargetKind,
    duration_text,
    live,
    one_line,
    reachable,
)


def check_system(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> CheckedSystem | None:
    """Check a system and its controllers; the checked system, or None after errors."""
    naming.check_spec(system, controllers, diags)  # identifier and text policy (E228, E6xx)
    by_name = _index_controllers(controllers, diags)
    valid = _valid_stand_ins(system, diags)  # E299: of itself, of a stand-in
    stand_ins = {k: a.value for k, a in valid.items()}
    named = {a.value for a in system.stand_ins.values()}  # valid or not: no more errors
    _check_processes(system, by_name, set(stand_ins.values()), named, diags)
    supervisors = _check_hierarchy(by_name, set(stand_ins.values()), diags)
    simulators = _check_simulators(system, by_name, diags)
    _check_stand_ins(valid, by_name, diags)
    _check_builtin_commands(by_name, diags)  # E284: INIT and HALT take no parameters
    _check_world_writers(system, stand_ins, by_name, diags)
    _check_sensing(system, by_name, simulators | named, diags)
    _check_safe_values(system, diags)  # E801
    checked_io = io.check(system, by_name, diags)  # E450-E457
    world = {name: f.type for name, f in system.world.items()}
    operators.check(system.operators, by_name, supervisors, world, diags)  # E245-E249
    clients = operators.check_modules(system, by_name, diags)  # E281-E284, W308
    _check_numbers(system, controllers, diags)
    _check_enums_and_strings(system, controllers, diags)  # E274, E276, E278, W307
    acknowledge.check_allows(controllers, diags)  # E237-E239
    contracts = {spec.name: _check_module(spec, system, world, diags) for spec in by_name.values()}
    before = len(diags.errors)
    if before:  # names must resolve before tables can be checked meaningfully
        return None
    order = [m for p in system.processes for m in (a.value for a in p.modules)]
    replaced_by = {stand_in: name for name, stand_in in stand_ins.items()}
    checked: dict[str, CheckedController] = {}
    periods = process_periods(system)  # (once: a lookup per module, not a scan)
    for name in [*order, *sorted(replaced_by)]:
        buffers = replaced_by.get(name, name)  # a stand-in runs in its controller's buffers
        checker = _ControllerChecker(
            by_name[name], by_name, system, diags, contracts[name], periods
        )
        checked[name] = checker.check(
            supervisors.get(buffers),
            name in simulators or name in replaced_by,
            buffers,
            clients.get(name, ()),
        )
        naming.check_module_names(by_name[name], by_name, system, diags, buffers)
    if len(diags.errors) > before:
        return None
    ruled = set(supervisors) | set(clients)  # modules commanded by another
    processes = tuple(_process(p, system, by_name, stand_ins, ruled) for p in system.processes)
    return CheckedSystem(system, checked, processes, checked_io)


def _process(
    p: model.Process,
    system: SystemSpec,
    by_name: dict[str, ControllerSpec],
    stand_ins: dict[str, str],
    ruled: set[str],
) -> CheckedProcess:
    """A process: its modules in order, its roots (commanded by nobody), and for each of its
    controllers that has a stand-in, the stand-in and the modules it replaces."""
    modules = tuple(a.value for a in p.modules)
    replaces = {
        name: (stand_in, tuple(m for m in modules if m in _subtree(name, by_name)))
        for name, stand_in in sorted(stand_ins.items())
        if name in modules
    }
    roots = tuple(m for m in modules if m not in ruled)
    period = p.cycle_period or system.cycle_period
    spans = {a.value: a.span for a in p.modules}
    return CheckedProcess(
        p.name, period, p.doc, modules, roots, replaces, dict(p.watchdog), dict(p.realtime), spans
    )


# ---------------------------------------------------------------- system-wide checks


def _check_module(
    spec: ControllerSpec, system: SystemSpec, world: dict[str, Type], diags: Diagnostics
) -> hook_checks.HookContracts:
    """One module's own declarations (echo timeouts, on_lost, world access, names) and its hooks
    module; the hooks' contracts."""
    _check_echo_timeouts(spec, diags)
    _check_on_lost(spec, diags)  # E802 (its rules: analysis/tables.py)
    _check_world_access(spec, world, diags)
    naming.check_controller_names(spec, diags)
    return hook_checks.check_hooks_module(spec, system.directory, world, diags)


def process_periods(system: SystemSpec) -> dict[str, float]:
    """The cycle period of each module a process runs (the first process that names it); a
    module no process runs has the system's."""
    periods: dict[str, float] = {}
    for process in system.processes:
        period = process.cycle_period or system.cycle_period
        for m in process.modules:
            periods.setdefault(m.value, period)
    return periods


def _index_controllers(
    controllers: list[ControllerSpec], diags: Diagnostics
) -> dict[str, ControllerSpec]:
    by_name: dict[str, ControllerSpec] = {}
    for spec in controllers:
        stem = Path(spec.display).stem
        if stem != spec.name and spec.instance is None:  # (an instance's: front_end/instances)
            diags.error(
                spec.name_span,
                "E222",
                f"controller `{spec.name}` is declared in `{Path(spec.display).name}`",
                f"name the file `{spec.name}.yaml` so each controller is found by its mnemonic",
            )
        if spec.name in by_name:
            diags.error(
                spec.name_span,
                "E221",
                f"controller `{spec.name}` is declared twice",
                f"first declared in {by_name[spec.name].display}",
            )
            continue
        by_name[spec.name] = spec
    return by_name


def _check_processes(
    system: SystemSpec,
    by_name: dict[str, ControllerSpec],
    stand_ins: set[str],
    named: set[str],
    diags: Diagnostics,
) -> dict[str, str]:
    """Each module runs in one process (E209-E211), a stand-in in none (E233); `named`:
    every module `stand_ins:` names, which E209 leaves to E299 when its entry is wrong."""
    placement: dict[str, str] = {}
    for process in system.processes:
        for module in process.modules:
            if module.value in stand_ins:
                diags.error(
                    module.span,
                    "E233",
                    f"stand-in `{module.value}` cannot be listed in a process",
                    "a stand-in runs in its controller's place when a run simulates it",
                )
            elif module.value not in by_name:
                diags.error(
                    module.span,
                    "E211",
                    f"process `{process.name}` runs `{module.value}`, which has no controller spec",
                    known_names_hint("controllers", by_name, module.value),
                )
            elif module.value in placement:
                diags.error(
                    module.span,
                    "E210",
                    f"module `{module.value}` is mapped to more than one process "
                    f"(`{placement[module.value]}` and `{process.name}`)",
                    "each module runs in exactly one process",
                )
            else:
                placement[module.value] = process.name
    for name, spec in sorted(by_name.items()):
        if name not in placement and name not in named:
            diags.error(
                spec.name_span,
                "E209",
                f"module `{name}` is not mapped to any process",
                f"add `{name}` to a process's `modules:` in {system.display}",
            )
    return placement


def _check_hierarchy(
    by_name: dict[str, ControllerSpec], stand_ins: set[str], diags: Diagnostics
) -> dict[str, str]:
    """Each controller's supervisor; reports unknown subordinates, a stand-in commanded,
    two supervisors, cycles."""
    supervisor: dict[str, str] = {}
    for name, spec in by_name.items():
        for sub in spec.subordinates:
            if sub.value in stand_ins:
                diags.error(
                    sub.span,
                    "E233",
                    f"stand-in `{sub.value}` cannot be a subordinate of `{name}`",
                    "a stand-in runs in its controller's place when a run simulates it: command "
                    "the controller it stands in for",
                )
            elif sub.value not in by_name:
                diags.error(
                    sub.span,
                    "E201",
                    f"unknown subordinate `{sub.value}` of `{name}`",
                    known_names_hint("controllers", by_name, sub.value),
                )
            elif by_name[sub.value].is_operator:
                continue  # a person at a screen serves every client that lists it
            elif sub.value in supervisor:
                diags.error(
                    sub.span,
                    "E202",
                    f"`{sub.value}` has two supervisors: `{supervisor[sub.value]}` and `{name}`",
                    "in RCS each controller has exactly one supervisor",
                )
            else:
                supervisor[sub.value] = name
    for name in sorted(by_name):  # walk up from each module; meeting itself is a cycle
        seen, at = [name], supervisor.get(name)
        while at is not None and at not in seen:
            seen.append(at)
            at = supervisor.get(at)
        if at == name:
            chain = " -> ".join(reversed([*seen, name]))
            spec = by_name[name]
            span = next(s.span for s in by_name[supervisor[name]].subordinates if s.value == name)
            diags.error(
                span, "E203", f"cycle in the hierarchy: {chain}", f"{spec.name} commands itself"
            )
    return supervisor


def _check_simulators(
    system: SystemSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> set[str]:
    for sim in system.simulators:
        if sim.value not in by_name:
            diags.error(
                sim.span,
                "E223",
                f"simulator `{sim.value}` has no module spec",
                known_names_hint("controllers", by_name, sim.value),
            )
    return {s.value for s in system.simulators}


def _subtree(name: str, by_name: dict[str, ControllerSpec]) -> set[str]:
    """A controller and everything below it in the hierarchy."""
    found, todo = set(), [name]
    while todo:
        at = todo.pop()
        if at in found or at not in by_name:
            continue
        found.add(at)
        # an operator module serves other clients too: no stand-in replaces it
        todo.extend(
            s.value
            for s in by_name[at].subordinates
            if s.value not in by_name or not by_name[s.value].is_operator
        )
    return found


def _command_signature(spec: ControllerSpec) -> dict[str, dict[str, Type | None]]:
    """Each command's parameters, results and reasons (None: a reason has no type): what
    shares its buffers' shape."""
    return {
        n: {
            **{p: t.type for p, t in c.params.items()},
            **{f"result {r}": t.type for r, t in c.results.items()},
            **{f"reason {r.value}": None for r in c.reasons},
        }
        for n, c in spec.commands.items()
    }


def _valid_stand_ins(system: SystemSpec, diags: Diagnostics) -> dict[str, Located]:
    """The `stand_ins:` entries that name another controller than their own, which has no
    stand-in itself and stands in for nobody else (E299 at each other one, and it is left
    out of every later check: one error, where it is written)."""
    valid: dict[str, Located] = {}
    replaced = {s.value: name for name, s in system.stand_ins.items()}
    for name, stand_in in system.stand_ins.items():
        if stand_in.value == name:
            problem = f"`{name}` cannot stand in for itself"
        elif name in replaced:
            problem = (
                f"`{name}` stands in for `{replaced[name]}`: a stand-in cannot have one of its own"
            )
        else:
            valid[name] = stand_in
            continue
        diags.error(
            stand_in.span,
            "E299",
            problem,
            "a stand-in is a controller simulator that replaces one controller and its subtree "
            "in a run: name a controller and its simulator, one pair per line",
        )
    return valid


def _check_builtin_commands(by_name: dict[str, ControllerSpec], diags: Diagnostics) -> None:
    """INIT and HALT take no parameters: the launcher, the supervisors' default tables and
    a lost subordinate's safe state send them with none (E284, at the parameter)."""
    for spec in by_name.values():
        for name in BUILTIN_COMMANDS:
            command = spec.commands.get(name)
            if command is None or not command.params:
                continue
            first = next(iter(command.params.values()))
            diags.error(
                first.span,
                "E284",
                f"{name} of `{spec.name}` cannot take parameters: it is sent with none",
                f"the launcher, a supervisor's default tables and the safe state send {name} "
                "alone: take the values from the world, a local or a constant instead",
            )


def _check_stand_ins(
    stand_ins: dict[str, Located], by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> None:
    """A stand-in replaces a controller and its subtree: same commands, no subordinates."""
    for name, stand_in in stand_ins.items():
        if name not in by_name:
            diags.error(
                stand_in.span,
                "E234",
                f"`{name}` has a stand-in but no controller spec",
                known_names_hint("controllers", by_name, name),
            )
            continue
        sim = by_name.get(stand_in.value)
        if sim is None:
            diags.error(
                stand_in.span,
                "E234",
                f"stand-in `{stand_in.value}` has no controller spec",
                known_names_hint("controllers", by_name, stand_in.value),
            )
            continue
        if sim.subordinates:
            diags.error(
                sim.subordinates[0].span,
                "E235",
                f"stand-in `{sim.name}` has subordinates",
                f"it replaces `{name}` and everything below it, so it commands nobody",
            )
        wanted, got = _command_signature(by_name[name]), _command_signature(sim)
        for command in sorted(set(wanted) ^ set(got)):
            diags.error(
                sim.name_span,
                "E236",
                f"stand-in `{sim.name}` and `{name}` differ in command {command}",
                "a stand-in accepts exactly its controller's commands and parameters",
            )
        for command in sorted(set(wanted) & set(got)):
            if wanted[command] != got[command]:
                diags.error(
                    sim.commands[command].span,
                    "E236",
                    f"{command} of stand-in `{sim.name}` has other parameters, results or "
                    f"reasons than `{name}`'s",
                    f"`{name}` takes {_signature_text(wanted[command])}",
                )
        if sorted(by_name[name].plans) != sorted(sim.plans):  # their slots: one status buffer
            diags.error(
                sim.name_span,
                "E236",
                f"stand-in `{sim.name}` and `{name}` declare different plans",
                "a stand-in writes its controller's status buffer, which holds each plan's "
                f"step: declare the plans of `{name}` ({', '.join(by_name[name].plans) or 'none'})",
            )


def _signature_text(signature: dict[str, Type | None]) -> str:
    """A command's signature as E236 shows it: `{'x': 'float', 'reason R': ''}`."""
    if not signature:
        return "no parameters"
    return repr({name: "" if kind is None else str(kind) for name, kind in signature.items()})


def _check_echo_timeouts(spec: ControllerSpec, diags: Diagnostics) -> None:
    subordinates = [s.value for s in spec.subordinates]
    for name, duration in spec.echo_timeouts.items():
        if name not in subordinates:
            diags.error(
                duration.span,
                "E244",
                f"`echo_timeouts` names `{name}`, which is not a subordinate of `{spec.name}`",
                known_names_hint("subordinates", subordinates, name),
            )


def _check_on_lost(spec: ControllerSpec, diags: Diagnostics) -> None:
    subordinates = [s.value for s in spec.subordinates]
    for name, policy in spec.on_lost.items():
        if name not in subordinates:
            diags.error(
                policy.span,
                "E802",
                f"`on_lost` names `{name}`, which is not a subordinate of `{spec.name}`",
                known_names_hint("subordinates", subordinates, name),
            )


def _check_world_writers(
    system: SystemSpec,
    stand_ins: dict[str, str],
    by_name: dict[str, ControllerSpec],
    diags: Diagnostics,
) -> None:
    """A world field is written in one process at most: its buffer has one writer."""
    process_of = {m.value: p.name for p in system.processes for m in p.modules}
    for name, stand_in in stand_ins.items():  # a stand-in runs in its place
        if name in process_of:
            process_of.setdefault(stand_in, process_of[name])
    writers: dict[str, list[tuple[str, str, Span]]] = {}
    for spec in by_name.values():
        process = process_of.get(spec.name)
        if process is None:
            continue
        for item in spec.world_writes:
            writers.setdefault(item.value, []).append((process, spec.name, item.span))
    for field, found in sorted(writers.items()):
        for process, module, span in found:
            other = next(((p, m, s) for p, m, s in found if p != process), None)
            if other is not None:
                diags.error(
                    span,
                    "E243",
                    f"world field `{field}` is written by `{module}` in process `{process}` "
                    f"and by `{other[1]}` in process `{other[0]}` ({other[2]})",
                    "a buffer has one writer: let one process own the field",
                )


def _check_sensing(
    system: SystemSpec, by_name: dict[str, ControllerSpec], simulated: set[str], diags: Diagnostics
) -> None:
    """Controllers decide on what is sensed, never on the simulation's ground truth (E280);
    a leaf controller that commands an actuator stops it on HALT (W520)."""
    for spec in by_name.values():
        if spec.name in simulated:
            continue
        for item in [*spec.world_reads, *spec.world_writes]:
            field = system.world.get(item.value)
            if field is not None and field.ground_truth:
                diags.error(
                    item.span,
                    "E280",
                    f"controller `{spec.name}` uses ground-truth world field `{item.value}`",
                    "only simulators and stand-ins see the simulation's truth; "
                    "read a sensed or estimated field instead",
                )
        halt = spec.commands.get("HALT")
        if spec.subordinates or halt is None or not halt.generated:
            continue
        driven = [
            item
            for item in spec.world_writes
            if item.value in system.world and system.world[item.value].actuator
        ]
        if driven:
            diags.warning(
                driven[0].span,
                "W520",
                f"`{spec.name}` commands actuator `{driven[0].value}` but keeps the default "
                "HALT, which stops nothing",
                "declare HALT and set every actuator it writes to its stopped value",
                Subject(spec.name, "HALT"),
            )


def _check_safe_values(system: SystemSpec, diags: Diagnostics) -> None:
    """A `safe:` value belongs to an actuator, and is one its field can hold (E801); an
    actuator starts at its safe value (W803: the block holds `initial` until its writer's
    first cycle, so the machine would be commanded that before any controller ran)."""
    for f in system.world.values():
        if f.safe is not None and not _safe_value_fits(f, diags):
            continue
        if f.actuator and f.initial != (safe := f.type.zero if f.safe is None else f.safe):
            said = "its type's zero, the default" if f.safe is None else "declared"
            diags.warning(
                f.initial_span or f.span,
                "W803",
                f"actuator `{f.name}` starts at {_spelt(f.initial)}, not at its safe value "
                f"{_spelt(safe)} ({said}): until its writer's first cycle the machine is "
                f"commanded {_spelt(f.initial)}",
                f"start it safe (`initial: {_spelt(safe)}`), or declare the value it starts "
                "at as its safe value (`safe:`)",
            )


def _safe_value_fits(f: model.Typed, diags: Diagnostics) -> bool:
    """A declared `safe:` is an actuator's and one its field can hold; else E801, False."""
    at = f.safe_span or f.span
    if not f.actuator:
        diags.error(
            at,
            "E801",
            f"world field `{f.name}` declares a safe value but is not an actuator",
            "add `actuator: true` (the runtime then drives it to this value when its "
            "writer is lost), or remove `safe:`",
        )
        return False
    if isinstance(f.type, Enum) and f.safe not in f.type.values:
        diags.error(
            at,
            "E801",
            f"safe value `{f.safe}` of `{f.name}` is not a value of {f.type.words}",
            known_names_hint("values", f.type.values, str(f.safe)),
        )
        return False
    if isinstance(f.type, Str) and (problem := expr.text_problem_of(f.safe, f.type)):
        diags.error(at, "E801", f"safe value of `{f.name}`: {problem}")
        return False
    return True


def _spelt(value: object) -> str:
    """A world field's value as a spec spells it (`tables.one_line`), the empty string `""`."""
    return '""' if value == "" else one_line(value)


def _check_numbers(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    """Every integer constant, initial or safe value and task result's bound fits in 64 bits
    (E110); an int given for a float fits in a float."""
    values: list[tuple[Type | None, object, Span]] = [  # None: a constant, of any type
        (f.type, f.initial, f.initial_span or f.span) for f in system.world.values()
    ]
    values += [
        (f.type, f.safe, f.safe_span or f.span) for f in system.world.values() if f.safe is not None
    ]
    for spec in controllers:
        values += [(v.type, v.initial, v.initial_span or v.span) for v in spec.locals.values()]
        values += [(None, c.value, c.span) for c in spec.constants.values()]
        values += _result_bounds(spec)
    for kind, value, span in values:
        problem = expr.int_range_problem(value) if kind in (INT, None) else ""
        if not problem and kind == FLOAT and isinstance(value, int):
            try:
                float(value)
            except OverflowError:
                problem = f"integer {number_shown(value)} is too large for a float"
        if problem:
            diags.error(span, "E110", problem, expr.INT_RANGE_HINT)


def _result_bounds(spec: ControllerSpec) -> list[tuple[Type | None, object, Span]]:
    """Each task result's `min` and `max`, with the result's type, for E110."""
    return [
        (result.type, bound.value, bound.span)
        for command in spec.commands.values()
        for result in command.results.values()
        for bound in (result.low, result.high)
        if bound is not None
    ]


def _check_enums_and_strings(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    """An enumeration's initial value is one of its names (E274) and no value is named like
    a status (E278); a string's initial value fits its size (E276); an enumeration of one
    value is warning W307."""
    declared: list[tuple[model.Typed, bool]] = [(f, True) for f in system.world.values()]
    for spec in controllers:
        declared += [(v, True) for v in spec.locals.values()]
        for command in spec.commands.values():
            declared += [(p, False) for p in command.params.values()]
            declared += [(r, False) for r in command.results.values()]
    for item, has_initial in declared:
        at = item.initial_span or item.span
        if isinstance(item.type, Enum):
            values = item.type.values
            shadowed = [v for v in values if v in expr.STATUS_NAMES]
            if shadowed:
                diags.error(
                    item.span,
                    "E278",
                    f"enum value `{shadowed[0]}` of `{item.name}` is a status name",
                    f"the status names {', '.join(expr.STATUS_NAMES)} are reserved: rename it",
                )
            if len(values) == 1:
                diags.warning(
                    item.span,
                    "W307",
                    f"enum `{item.name}` has one value, `{values[0]}`: it can never change",
                    "add the other values, or drop the field",
                )
            if has_initial and item.initial not in values:
                diags.error(
                    at,
                    "E274",
                    f"initial value `{item.initial}` of `{item.name}` is not a value of "
                    f"{item.type.words}",
                    known_names_hint("values", values, str(item.initial)),
                )
        elif isinstance(item.type, Str) and has_initial:
            problem = expr.text_problem_of(item.initial, item.type)
            if problem:
                diags.error(at, "E276", f"initial value of `{item.name}`: {problem}")


def _check_world_access(spec: ControllerSpec, world: dict[str, Type], diags: Diagnostics) -> None:
    for item in [*spec.world_reads, *spec.world_writes]:
        if item.value not in world:
            diags.error(
                item.span,
                "E104",
                f"undeclared world field `{item.value}`",
                known_names_hint("world fields", world, item.value),
            )


# Names a function or a `let` value cannot take: they are Python names of the generated
# method or module (a `let` is a local of its table's method beside `self` and `state`, a
# function a module-level function beside the module's runtime names).
_PYTHON_NAMES = frozenset({"self", "state", *naming.RUNTIME_NAMES, *expr.BUILTINS})


def _reserved(name: str) -> str:
    """What `name` already is in generated code, or ''."""
    if keyword.iskeyword(name) or keyword.issoftkeyword(name):
        return "a Python keyword"
    if name in _PYTHON_NAMES or name in dir(builtins):
        return "a name the generated code uses"
    return ""


def _calls_later(
    body: object, name: str, declared: list[str], before: dict[str, CheckedFunction]
) -> str:
    """The first function `body` calls that is not declared before `name` (itself
    included), or ''."""
    try:
        tree = ast.parse(" ".join(str(body).split()), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return ""  # typing the body reports it
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            callee = node.func.id
            if callee in declared and callee not in before:
                return callee
    return ""


def _timed_guard(
    rule_id: RuleId, guard: expr.Expr | None, after: int | None, hold: int | None
) -> expr.Expr | None:
    """The guard with the rule's time: `when and held > FOR and ticks >= AFTER` (the counters
    are ints no spec text names; docs/semantics.md, "Time in a state")."""
    parts = [] if guard is None else [guard]
    if isinstance(guard, expr.BoolOp) and guard.op == "and" and (after or hold):
        parts = list(guard.values)  # `a and b and ticks >= 20`, not `(a and b) and ...`
    if hold is not None and guard is not None:
        counter = naming.held_attribute(rule_id.command, rule_id.state, rule_id.index)
        parts.append(_at_least(expr.Ref(INT, expr.RefKind.HELD, counter), ">", hold))
    if after is not None:
        parts.append(_at_least(expr.Ref(INT, expr.RefKind.TIME, "ticks"), ">=", after))
    if len(parts) <= 1:
        return parts[0] if parts else None
    return expr.BoolOp(BOOL, "and", tuple(parts))


def _at_least(counter: expr.Ref, op: str, cycles: int) -> expr.Expr:
    return expr.Compare(BOOL, counter, (op,), (expr.Const(INT, cycles),))


# ---------------------------------------------------------------- one controller

_ALWAYS_FALSE_HINT = (
    "it reads only literals and constants, and they make it false: check the constants, "
    "or delete the rule"
)


class _ControllerChecker:
    """Checks one controller's tables and expressions and builds its checked form."""

    def __init__(
        self,
        spec: ControllerSpec,
        by_name: dict[str, ControllerSpec],
        system: SystemSpec,
        diags: Diagnostics,
        contracts: hook_checks.HookContracts,
        periods: Mapping[str, float],
    ):
        self.spec, self.by_name, self.system, self.diags = spec, by_name, system, diags
        self.periods = periods  # each process's cycle period (process_periods)
        self.contracts = contracts  # hook -> its parameters' annotated types
        self.checked_calls: set[str] = set()  # hooks whose arguments were compared
        self.subs = [s.value for s in spec.subordinates]
        self.predicate_trees: dict[str, expr.Expr] = {}  # for folding guards (set by check)
        self.writable = {w.value for w in spec.world_writes}
        self.period = self.process_period(spec.name)  # a stand-in's: check() sets it
        self.base_scope = expr.Scope(
            world=system.world_types,
            world_access=frozenset(a.value for a in [*spec.world_reads, *spec.world_writes]),
            locals={n: v.type for n, v in spec.locals.items()},
            constants={n: c.value for n, c in spec.constants.items()},
            predicates=frozenset(spec.predicates),
            subordinates={sub: frozenset(by_name[sub].commands) for sub in self.subs},
            sub_results={sub: naming.result_types(by_name[sub]) for sub in self.subs},
            sub_reasons={sub: tuple(naming.declared_reasons(by_name[sub])) for sub in self.subs},
            functions={
                f.name: (tuple(f.params.values()), f.returns) for f in spec.functions.values()
            },
            plans={
                name: {**plan.steps, **expr.PLAN_PROPERTIES} for name, plan in spec.plans.items()
            },
        )
        self.command: Command | None = None  # the command whose table is being checked

    def process_period(self, module: str) -> float:
        """The cycle period of the process that runs `module` (the system's if none does)."""
        return self.periods.get(module, self.system.cycle_period)

    def subject(self, rule: CheckedRule) -> Subject:
        """What a finding about `rule` is about, for acknowledgements."""
        return Subject(self.spec.name, rule.id.command, rule.id.state, rule.id.index)

    def given_constants(self) -> dict[str, float]:
        """The constants the system gives every controller: CYCLE_PERIOD, the seconds per
        cycle of its process (a constant the spec declares itself is E297)."""
        if naming.CYCLE_PERIOD in self.spec.constants:
            return {}
        return {naming.CYCLE_PERIOD: self.period}

    def scope_for(self, command: Command | None) -> expr.Scope:
        """The names a guard or value of `command` (None: a predicate, every_cycle) may use."""
        params = {p.name: p.type for p in command.params.values()} if command else {}
        return replace(self.base_scope, params=params, used_predicates=set())

    def typed(self, item: Located, scope: expr.Scope, expect: Type | None) -> expr.Expr | None:
        return expr.compile_expr(item.value, item.span, scope, self.diags, expect)

    def check(
        self,
        supervisor: str | None,
        simulator: bool,
        buffers: str,
        clients: tuple[str, ...] = (),
    ) -> CheckedController:
        spec = self.spec
        self.period = self.process_period(buffers)
        self.base_scope = replace(
            self.base_scope, constants={**self.base_scope.constants, **self.given_constants()}
        )
        self.check_plans()
        functions = self.check_functions()
        predicates = self.check_predicates()
        self.predicate_trees = {name: p.tree for name, p in predicates.items()}
        commands = {
            command.name: self.check_command(command, code)
            if not spec.is_operator  # a task has no table: the person answers it
            else CheckedCommand(command.name, code, command, {}, self.scope_for(command))
            for code, command in enumerate(spec.commands.values(), start=1)
        }
        return CheckedController(
            spec=spec,
            supervisor=supervisor,
            simulator=simulator,
            buffers=buffers,
            commands=commands,
            predicates=predicates,
            every_cycle=self.check_every_cycle(),
            sub_commands={sub: tuple(self.by_name[sub].commands) for sub in self.subs},
            scope=self.scope_for(None),
            functions=functions,
            clients=clients,
        )

    def check_plans(self) -> None:
        """Each plan's name and step fields can be read as `<plan>.<name>` and become
        attributes of their own in the generated class (E291)."""
        spec = self.spec
        attributes: dict[str, str] = {}
        methods = {naming.command_method(c) for c in spec.commands} | set(spec.predicates)
        for name, plan in spec.plans.items():
            taken = (
                ("`world`" if name == "world" else "")
                or ("a subordinate" if name in self.subs else "")
                or ("what `result.<name>` assigns" if name == "result" else "")
            )
            if taken:
                self.diags.error(
                    plan.span,
                    "E291",
                    f"plan `{name}` cannot be named so: it is {taken}",
                    "rename the plan: `<plan>.<name>` must say which one it reads",
                )
                continue
            for field_name in plan.steps:
                if field_name in expr.PLAN_PROPERTIES:
                    self.diags.error(
                        plan.span,
                        "E291",
                        f"step field `{field_name}` of plan `{name}` has the name of a property "
                        f"every plan has (`{name}.{field_name}`)",
                        "rename the field; every plan has "
                        + ", ".join(f"`{p}`" for p in expr.PLAN_PROPERTIES),
                    )
            for attribute in naming.plan_attributes(name, plan.steps):
                other = attributes.setdefault(attribute, name)
                owner = f"plan `{other}`" if other != name else "a command or predicate"
                if other != name or attribute in methods:
                    self.diags.error(
                        plan.span,
                        "E291",
                        f"plan `{name}` makes the name `{attribute}` in the generated class, "
                        f"which {owner} makes too",
                        "rename the plan or the field",
                    )
                    break

    def check_functions(self) -> dict[str, CheckedFunction]:
        """Each pure function's body, typed over its parameters, the constants and the
        functions declared before it (E262-E264)."""
        checked: dict[str, CheckedFunction] = {}
        spec = self.spec
        taken = {
            **{name: "a predicate" for name in spec.predicates},
            **{name: "a hook" for name in spec.hooks},
        }
        for name, function in spec.functions.items():
            problem = _reserved(name) or taken.get(name)
            if problem:
                self.diags.error(
                    function.span,
                    "E262",
                    f"function `{name}` cannot be named so: it is {problem}",
                    "rename the function",
                )
                continue
            later = _calls_later(function.body.value, name, list(spec.functions), checked)
            if later:
                self.diags.error(
                    function.body.span,
                    "E264",
                    f"function `{name}` calls `{later}`, which is not declared before it",
                    "a function calls only the functions above it, so none can recurse",
                )
                continue
            scope = expr.Scope(
                constants=self.base_scope.constants,
                functions={
                    f.name: (tuple(t for _, t in f.params), f.returns) for f in checked.values()
                },
                args=dict(function.params),
            )
            tree = self.typed(function.body, scope, function.returns)
            if tree is not None:
                checked[name] = CheckedFunction(
                    name,
                    tuple(function.params.items()),
                    function.returns,
                    tree,
                    one_line(function.body.value),
                    function.span,
                    function.doc,
                )
        return checked

    def check_lets(self, command: Command, scope: expr.Scope) -> tuple[CheckedLet, ...]:
        """A table's named values, in order, each typed over what the table sees and the
        values before it; `scope` gains each (E262 for a name already used)."""
        lets: list[CheckedLet] = []
        known: dict[str, Type] = {}
        spec = self.spec
        for name, item in command.lets.items():
            used = (
                _reserved(name)
                or ("a parameter" if name in command.params else "")
                or ("a local" if name in spec.locals else "")
                or ("a predicate" if name in spec.predicates else "")
                or ("a function" if name in spec.functions else "")
                or ("a hook" if name in spec.hooks else "")
            )
            if used:
                self.diags.error(
                    item.span,
                    "E262",
                    f"`let` value `{name}` cannot be named so: it is {used}",
                    "rename it",
                )
                continue
            tree = self.typed(item, replace(scope, lets=dict(known)), None)
            if tree is not None:
                known[name] = tree.type
                lets.append(CheckedLet(name, tree, one_line(item.value), item.span))
        scope.lets = known
        return tuple(lets)

    def check_every_cycle(self) -> tuple[CheckedRule, ...]:
        scope = self.scope_for(None)
        self.command = None
        rules = []
        for index, written in enumerate(self.spec.every_cycle, start=1):
            if written.next is not None:
                self.diags.error(
                    written.next.span,
                    "E232",
                    "an every_cycle rule cannot change state",
                    "every_cycle rules run whatever the command; move `next` into a table",
                )
            for report in (a for a in written.actions if isinstance(a, model.Report)):
                self.diags.error(
                    report.span,
                    "E232",
                    f"an every_cycle rule cannot report {report.status}: it has no command to end",
                    "every_cycle rules run whatever the command (and when there is none); "
                    "report from the command's table, which may test what every_cycle set",
                )
            rules.append(self.check_rule(RuleId(None, None, index), written, scope))
        tried, shadowed = live(rules)
        for rule in shadowed:
            if rule.never:
                self.diags.warning(
                    rule.source.when.span if rule.source.when else rule.span,
                    "W302",
                    "this every_cycle rule never fires: its guard is always false",
                    _ALWAYS_FALSE_HINT,
                    self.subject(rule),
                )
            else:
                self.diags.warning(
                    rule.span,
                    "W301",
                    "this every_cycle rule never fires",
                    subject=self.subject(rule),
                )
        return tuple(tried)

    def check_predicates(self) -> dict[str, CheckedPredicate]:
        checked, calls = {}, {}
        for name, item in self.spec.predicates.items():
            scope = self.scope_for(None)
            tree = self.typed(item, scope, BOOL)
            if tree is not None:
                checked[name] = CheckedPredicate(name, tree, one_line(item.value), item.span)
            calls[name] = set(scope.used_predicates)
        for name in calls:  # a predicate that reaches itself would recurse forever at run time
            callees = calls[name]
            if any(name in reachable(callee, lambda at: calls.get(at, ())) for callee in callees):
                self.diags.error(
                    self.spec.predicates[name].span, "E229", f"predicate `{name}` calls itself"
                )
        return checked

    def check_command(self, command: Command, code: int) -> CheckedCommand:
        scope = self.scope_for(command)
        self.command = command
        lets = self.check_lets(command, scope)
        self.check_states(command)
        states = {}
        for state in command.states.values():
            rules = [
                self.check_rule(RuleId(command.name, state.name, index), rule, scope)
                for index, rule in enumerate(state.rules, start=1)
            ]
            tried, shadowed = live(rules)
            if not command.generated:
                for rule in shadowed:
                    if rule.never:
                        self.diags.warning(
                            rule.source.when.span if rule.source.when else rule.span,
                            "W302",
                            f"this rule of {command.name} {state.name} never fires: "
                            "its guard is always false",
                            _ALWAYS_FALSE_HINT,
                            self.subject(rule),
                        )
                        continue
                    self.diags.warning(
                        rule.span,
                        "W301",
                        f"this rule of {command.name} {state.name} never fires",
                        "the rule before it always fires first (it has no `when`, or its "
                        "guard is always true)",
                        self.subject(rule),
                    )
            states[state.name] = CheckedState(state.name, state.span, tuple(tried), tuple(shadowed))
        return CheckedCommand(command.name, code, command, states, scope, lets)

    def check_states(self, command: Command) -> None:
        states = command.states
        if "NOP" in states:
            self.diags.error(states["NOP"].span, "E227", "`NOP` is reserved for the idle state")
        if ENTRY_STATE not in states:
            self.diags.error(
                command.span,
                "E216",
                f"command {command.name} has no `S0` state",
                "S0 is where every new command starts",
            )
            return
        edges: dict[str, list[str]] = {s: [] for s in states}
        for state in states.values():
            for rule in state.rules:
                if rule.next is None:
                    continue
                if rule.next.value not in states:
                    self.diags.error(
                        rule.next.span,
                        "E206",
                        f"transition to undefined state `{rule.next.value}` in {command.name}",
                        known_names_hint(f"states of {command.name}", states, rule.next.value),
                    )
                else:
                    edges[state.name].append(rule.next.value)
        reached = reachable(ENTRY_STATE, edges.__getitem__)
        for name, state in states.items():
            if name not in reached:
                self.diags.error(
                    state.span,
                    "E207",
                    f"state `{name}` of {command.name} is unreachable from S0",
                    "add a rule with `next: " + name + "` or remove the state",
                )

    def check_rule(self, rule_id: RuleId, rule: Rule, scope: expr.Scope) -> CheckedRule:
        """A rule's guard, actions and next state, checked and typed."""
        guard = None
        if rule.when is not None:
            guard = self.typed(rule.when, scope, BOOL)
        after, hold = self.timing(rule_id, rule)
        guard = _timed_guard(rule_id, guard, after, hold)
        actions = [self.check_action(a, scope) for a in rule.actions]
        reports = [a for a in rule.actions if isinstance(a, model.Report)]
        self.check_one_each(rule)
        if reports and rule.next is not None:
            self.diags.error(
                rule.next.span,
                "E226",
                "a rule that reports DONE or ERROR cannot name a next state",
                "reporting ends the command: the state becomes NOP",
            )
        next_state = "NOP" if reports else (rule.next.value if rule.next else None)
        for report in reports:
            self.check_passed_in_error(rule_id, report, guard)
        always = None
        if guard is not None:
            folded = expr.fold(guard, scope.constants, self.predicate_trees)
            always = folded if isinstance(folded, bool) else None
        return CheckedRule(
            rule_id,
            rule,
            guard,
            tuple(a for a in actions if a is not None),
            next_state,
            always,
            after,
            hold,
        )

    def check_one_each(self, rule: Rule) -> None:
        """A rule reports once (E226) and sends each subordinate one command (E279): the
        second would silently replace the first."""
        reports = [a for a in rule.actions if isinstance(a, model.Report)]
        for extra in reports[1:]:
            self.diags.error(
                extra.span,
                "E226",
                f"this rule already reports {reports[0].status}: a rule reports once",
                "reporting ends the command: keep the one report the rule means",
            )
        sent: dict[str, model.Send] = {}
        for send in (a for a in rule.actions if isinstance(a, model.Send)):
            first = sent.setdefault(send.sub, send)
            if first is not send:
                self.diags.error(
                    send.span,
                    "E279",
                    f"this rule already sends `{send.sub}` {first.command}: a subordinate takes "
                    f"one command at a time, and {send.command} would replace it unseen",
                    f"send {send.command} from a later state, once `{send.sub}.status` says the "
                    "first is DONE",
                )

    def timing(self, rule_id: RuleId, rule: Rule) -> tuple[int | None, int | None]:
        """A rule's `after:` and `for:` in cycles of this controller's process (None: not
        given, or wrong: E250-E252, W304 when rounded up)."""
        found: list[int | None] = []
        for key, item in (("after", rule.after), ("for", rule.hold)):
            if item is None:
                found.append(None)
                continue
            if rule_id.command is None and key == "after":
                self.diags.error(
                    item.span,
                    "E251",
                    "an every_cycle rule cannot wait `after:`: it counts the time in a state",
                    "every_cycle rules run whatever the state: put the timed rule in a table, "
                    "or use `for:`, how long its `when` has held",
                )
                found.append(None)
                continue
            if key == "for" and rule.when is None:
                self.diags.error(
                    item.span,
                    "E250",
                    "`for:` needs a `when:`: it is how long the guard must have held",
                    "add the condition as `when:`, or write `after:` to wait in the state",
                )
                found.append(None)
                continue
            found.append(self.cycles(key, item, rule_id))
        return found[0], found[1]

    def cycles(self, key: str, item: Located, rule_id: RuleId) -> int | None:
        """A duration in whole cycles of this controller's period (rounded up: W304)."""
        count, exact = model.exact_cycles(item.value, self.period)
        text = duration_text(item.value)
        if count < 1:
            self.diags.error(
                item.span,
                "E252",
                f"`{key}: {text}` is less than one cycle ({self.period:g} s)",
                "give at least one cycle; a rule that need not wait has no `after:` or `for:`",
            )
            return None
        if not exact:
            self.diags.warning(
                item.span,
                "W304",
                f"`{key}: {text}` is not a whole number of cycles of {self.period:g} s: "
                f"it is rounded up to {count} cycles ({count * self.period:g} s)",
                "write the duration in cycles, or as a multiple of the cycle period",
                Subject(self.spec.name, rule_id.command, rule_id.state, rule_id.index),
            )
        return count

    def check_action(self, action: model.Action, scope: expr.Scope) -> Action | None:
        match action:
            case model.Send():
                return self.check_send(action, scope)
            case model.SetWorld():
                return self.check_set(action, scope)
            case model.Report():
                return self.check_report(action)
            case model.PlanAction():
                return self.check_plan_action(action, scope)
            case model.CallHook():
                return self.check_call(action, scope)
        raise TypeError(f"unknown action {action!r}")

    def check_set(self, action: model.SetWorld, scope: expr.Scope) -> Assign:
        pairs = []
        for assign in action.assignments:
            target = self.target(assign.target)
            value = self.typed(assign.value, scope, target.type) if target else None
            if target is not None and value is not None:
                pairs.append((target, value))
        return Assign(tuple(pairs), action)

    def check_report(self, action: model.Report) -> Report:
        reason = self.reason(action)
        if reason is None or not reason.endswith(".reason") or self.command is None:
            return Report(action.status, action.span, reason)
        own = {r.value for r in self.command.reasons}
        sub_reasons = naming.declared_reasons(self.by_name[reason.removesuffix(".reason")])
        passes = ("LOST", *(r for r in sub_reasons if r in own))
        return Report(action.status, action.span, reason, passes)

    def check_call(self, action: model.CallHook, scope: expr.Scope) -> CallHook | None:
        hook = self.spec.hooks.get(action.hook)
        if hook is None:
            self.diags.error(
                action.span,
                "E208",
                f"call of undeclared hook `{action.hook}`",
                known_names_hint("hooks", self.spec.hooks, action.hook),
            )
            return None
        args = [self.typed(a, scope, None) for a in hook.args]
        self.check_hook_arguments(hook, args)
        targets = [self.target(t) for t in hook.returns]
        return CallHook(
            hook,
            tuple(a for a in args if a is not None),
            tuple(t for t in targets if t is not None),
            action.span,
        )

    def check_plan_action(self, action: model.PlanAction, scope: expr.Scope) -> Action | None:
        """`plan:`, `replan:` or `advance:` of a declared plan, in a command's table (E292,
        E295); the planner's arguments typed where the action runs."""
        plan = self.spec.plans.get(action.plan)
        if plan is None:
            self.diags.error(
                action.span,
                "E292",
                f"`{action.kind}: {action.plan}`: `{self.spec.name}` declares no plan "
                f"`{action.plan}`",
                known_names_hint("plans", self.spec.plans, action.plan)
                or "declare it under `plans:`",
            )
            return None
        if self.command is None:
            self.diags.error(
                action.span,
                "E295",
                f"`{action.kind}: {action.plan}` in an every_cycle rule: a plan is stepped "
                "through by a command's table",
                "move the action into the table of the command that plans",
            )
            return None
        args: tuple[expr.Expr, ...] = ()
        if action.kind is not PlanVerb.ADVANCE:
            typed = [self.typed(a, scope, None) for a in plan.args]
            if any(t is None for t in typed):
                return None
            args = tuple(t for t in typed if t is not None)
            self.check_planner_arguments(plan, args)
        return PlanAction(action.kind, plan, args, action.span)

    def check_planner_arguments(self, plan: model.Plan, args: tuple[expr.Expr, ...]) -> None:
        """E293 once per plan: an argument whose type its planner parameter's annotation
        excludes."""
        key = f"plan:{plan.name}"
        if key in self.checked_calls or key not in self.contracts:
            return
        self.checked_calls.add(key)
        params, where = self.contracts[key]
        for index, (arg, param) in enumerate(zip(args, params, strict=False)):
            if param is None or annotation_accepts(param, arg.type):
                continue
            self.diags.error(
                plan.args[index].span,
                "E293",
                f"argument {index + 1} of planner `{plan.planner.value}` is "
                f"{hook_words(arg.type)}, but the function's parameter is annotated `{param}`",
                f"convert it in the spec, or change the annotation ({where})",
            )

    def check_hook_arguments(self, hook: model.Hook, args: list[expr.Expr | None]) -> None:
        """E242 once per hook: an argument whose type its parameter's annotation excludes."""
        if hook.name in self.checked_calls or hook.name not in self.contracts:
            return
        self.checked_calls.add(hook.name)
        params, where = self.contracts[hook.name]
        for index, (arg, param) in enumerate(zip(args, params, strict=False)):
            if arg is None or param is None or annotation_accepts(param, arg.type):
                continue
            self.diags.error(
                hook.args[index].span,
                "E242",
                f"argument {index + 1} of hook `{hook.name}` is {hook_words(arg.type)}, but the "
                f"function's parameter is annotated `{param}`",
                f"convert it in the spec, or change the annotation ({where})",
            )

    def reason(self, report: model.Report) -> str | None:
        """The reason a report gives, checked against its command's `reasons` (E255, E256)."""
        if report.reason is None:
            return None
        reason = str(report.reason.value)
        if report.status != "ERROR":
            self.diags.error(
                report.reason.span,
                "E255",
                f"`report: {report.status}` cannot give a reason",
                "a reason says why a command failed: give it with `report: ERROR`",
            )
            return None
        declared = [r.value for r in self.command.reasons] if self.command else []
        if reason.endswith(".reason"):  # passed up from a subordinate, by name
            return self.passed_reason(report, reason.removesuffix(".reason"), declared)
        if reason not in declared:
            where = f"{self.command.name}'s `reasons`" if self.command else "an every_cycle rule"
            self.diags.error(
                report.reason.span,
                "E256",
                f"reason `{reason}` is not one of {where}",
                known_names_hint("reasons", declared, reason)
                or "declare it in the command's `reasons:` list",
            )
            return None
        return reason

    def check_passed_in_error(
        self, rule_id: RuleId, report: model.Report, guard: expr.Expr | None
    ) -> None:
        """W306: `reason: <sub>.reason` in a rule whose guard does not say the subordinate
        is in ERROR (a conjunct `<sub>.status == ERROR`, or a test of its reason against
        one that is not NONE): its reason reads NONE otherwise."""
        reason = str(report.reason.value) if report.reason is not None else ""
        sub = reason.removesuffix(".reason")
        if report.status != "ERROR" or not reason.endswith(".reason") or sub not in self.subs:
            return
        if any(_says_in_error(term, sub) for term in _conjuncts(guard)):
            return
        assert report.reason is not None
        self.diags.warning(
            report.reason.span,
            "W306",
            f"`reason: {reason}` in a rule whose guard does not require "
            f"`{sub}.status == ERROR`: when it fires otherwise, it passes up NONE",
            f"add `{sub}.status == ERROR and` to the guard, or acknowledge it on the rule "
            "if the state is entered only once it is in ERROR",
            Subject(self.spec.name, rule_id.command, rule_id.state, rule_id.index),
        )

    def passed_reason(self, report: model.Report, sub: str, declared: list[str]) -> str | None:
        """`reason: <sub>.reason`: the subordinate's reason, passed up by name. Every reason
        the subordinate can give for the commands this table sends it must be one of this
        command's (E271 not a subordinate, E259 it declares none, E273 never sent a command,
        E272 a reason this command does not declare)."""
        assert report.reason is not None
        span, where = report.reason.span, f"`reason: {sub}.reason`"
        if sub not in self.subs:
            self.diags.error(
                span,
                "E271",
                f"{where}: `{sub}` is not a subordinate of `{self.spec.name}`",
                known_names_hint("subordinates", self.subs, sub),
            )
            return None
        sub_spec = self.by_name[sub]
        if not naming.declared_reasons(sub_spec):
            self.diags.error(
                span,
                "E259",
                f"`{sub}` declares no reasons: `{sub}.reason` says nothing",
                f"declare `reasons:` on the commands of `{sub}` that can fail",
            )
            return None
        if self.command is None:  # every_cycle: no command of its own to pass a reason for
            self.diags.error(
                span,
                "E256",
                f"{where}: an every_cycle rule has no command whose reason it could be",
                "pass the reason in a command's table",
            )
            return None
        if not declared:
            self.diags.error(
                span,
                "E272",
                f"{where}: {self.command.name} declares no reasons to pass `{sub}`'s on as",
                f"declare the reasons `{sub}` can give in {self.command.name}'s `reasons:`",
            )
            return None
        sent = [
            action.command
            for state in self.command.states.values()
            for rule in state.rules
            for action in rule.actions
            if isinstance(action, model.Send) and action.sub == sub
        ]
        if not sent:
            self.diags.error(
                span,
                "E273",
                f"{where}: {self.command.name} never sends `{sub}` a command, so `{sub}`'s "
                "reason is never its answer to this command",
                f"send `{sub}` the command whose failure this passes on, or give a reason of "
                f"{self.command.name}'s own",
            )
            return None
        for name in dict.fromkeys(
            r.value
            for command in dict.fromkeys(sent)
            if command in sub_spec.commands
            for r in sub_spec.commands[command].reasons
        ):
            if name not in declared:
                self.diags.error(
                    span,
                    "E272",
                    f"{where} passes `{name}`, a reason `{sub}` can give, which is not one of "
                    f"{self.command.name}'s `reasons`",
                    f"add `{name}` to {self.command.name}'s `reasons:` (a reason is passed by "
                    "name), or report a reason of its own in a rule that tells them apart",
                )
                return None
        return f"{sub}.reason"

    def target(self, target: Located) -> Target | None:
        """An assignable name (`world.<field>`, a local or `result.<name>` of the current
        command), or None after an error."""
        text = str(target.value)
        if text.startswith("result."):
            name = text.removeprefix("result.")
            results = self.command.results if self.command else {}
            if name not in results:
                where = f"{self.command.name}" if self.command else "an every_cycle rule"
                self.diags.error(
                    target.span,
                    "E257",
                    f"`{name}` is not a result of {where}",
                    known_names_hint("results", results, name)
                    or "declare it under the command's `results:`",
                )
                return None
            return Target(TargetKind.RESULT, name, results[name].type)
        if text.startswith("world."):
            name = text.removeprefix("world.")
            if name not in self.system.world:
                self.diags.error(
                    target.span,
                    "E104",
                    f"undeclared world field `{name}`",
                    known_names_hint("world fields", self.system.world, name),
                )
                return None
            if name not in self.writable:
                self.diags.error(
                    target.span,
                    "E219",
                    f"`{self.spec.name}` writes world field `{name}` without declaring it",
                    f"add `{name}` to `world: writes:`",
                )
                return None
            return Target(TargetKind.WORLD, name, self.system.world[name].type)
        if text in self.spec.locals:
            return Target(TargetKind.LOCAL, text, self.spec.locals[text].type)
        self.diags.error(
            target.span,
            "E220",
            f"cannot assign `{text}`: not a local or `world.<field>`",
            known_names_hint("locals", self.spec.locals, text),
        )
        return None

    def check_send(self, send: model.Send, scope: expr.Scope) -> Send | None:
        if send.sub not in self.subs:
            self.diags.error(
                send.span,
                "E205",
                f"`{self.spec.name}` sends to `{send.sub}`, which is not one of its subordinates",
                known_names_hint("subordinates", self.subs, send.sub),
            )
            return None
        commands = self.by_name[send.sub].commands
        command = commands.get(send.command)
        if command is None:
            self.diags.error(
                send.span,
                "E204",
                f"`{send.sub}` does not declare command `{send.command}`",
                known_names_hint(f"commands of {send.sub}", commands, send.command),
            )
            return None
        args = []
        for name, value in send.args.items():
            param = command.params.get(name)
            if param is None:
                self.diags.error(
                    send.arg_spans.get(name, value.span),
                    "E218",
                    f"`{send.sub}.{send.command}` has no parameter `{name}`",
                    known_names_hint("parameters", command.params, name),
                )
                continue
            tree = self.typed(value, scope, param.type)
            if tree is not None:
                args.append((name, tree))
        missing = [p for p in command.params if p not in send.args]
        if missing:
            self.diags.error(
                send.span,
                "E217",
                f"`{send.sub}.{send.command}` needs {listed('parameter', missing)}",
                f"give {'it' if len(missing) == 1 else 'them'} under `with:`",
            )
        return Send(send.sub, send.command, tuple(args), send)


def _conjuncts(guard: expr.Expr | None) -> list[expr.Expr]:
    """The terms a guard requires all of: its top-level `and`'s, or itself."""
    if guard is None:
        return []
    if isinstance(guard, expr.BoolOp) and guard.op == "and":
        return [t for value in guard.values for t in _conjuncts(value)]
    return [guard]


def _says_in_error(term: expr.Expr, sub: str) -> bool:
    """`<sub>.status == ERROR` (either way round), or `<sub>.reason == R` for R not NONE, or
    `<sub>.reason != NONE`: a term that holds only while `sub` is in ERROR."""
    if not isinstance(term, expr.Compare) or len(term.ops) != 1:
        return False
    pair = (term.left, term.comparators[0])
    for a, b in (pair, pair[::-1]):
        if not (isinstance(a, expr.Ref) and isinstance(b, expr.Ref) and a.owner == sub):
            continue
        if a.kind == expr.RefKind.SUB_STATUS and b.kind == expr.RefKind.STATUS:
            return term.ops[0] == "==" and b.name == "ERROR"
        if a.kind == expr.RefKind.SUB_REASON and b.kind == expr.RefKind.SUB_REASON_NAME:
            return (term.ops[0] == "==") != (b.name == "NONE")
    return False
