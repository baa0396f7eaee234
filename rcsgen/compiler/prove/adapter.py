"""Adapter: the one place `prove` reads the compiler - the IR the generator uses, the shared
rule semantics (`tables`) and the analysis's regions (`analysis.GuardBuilder`, `solver`).

Everything the model needs of a controller is read here into a `Skeleton`: for each command
and state its rules in order, each with its guard as a solver `Guard` (predicates, functions
and `let` values inlined, constants folded, exactly as `rcsgen validate` decides them), what
it sends, reports and sets, and where it goes next. Actions are told apart by their IR class
(`isinstance`), never by a kind string, so a refactoring of the IR's kinds changes nothing
here but this file.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field, replace
from typing import Any

from ...runtime.contract import BUILTIN_COMMANDS
from .. import expressions as expr
from .. import ir
from ..analysis.solver import Guard, Key, solve
from ..analysis.tables import GuardBuilder
from ..diagnostics import Span

NOT_READY, EXECUTING, DONE, ERROR = "NOT_READY", "EXECUTING", "DONE", "ERROR"


def is_every_cycle(rule_id: str) -> bool:
    """Whether a rule id text (RuleId's: `every_cycle/1`, `GO/S1/2`) names an every_cycle
    rule."""
    return rule_id.startswith("every_cycle/")


def table_rules(rules: tuple[str, ...]) -> list[str]:
    """The table's rules among those that fired in one cycle (an edge's rules: the
    every_cycle rules first, then the table rule, if any)."""
    return [r for r in rules if not is_every_cycle(r)]


def safe_value(field_: ir.IRWorldField) -> bool | int | float | str | None:
    """The value an actuator field is safe at, as the IR carries it (`safe:`, or its type's
    zero): the value the runtime latches it at when a process is lost (rcs/override.py)."""
    return field_.safe


@dataclass(frozen=True)
class RuleView:
    """One rule as the model reads it."""

    id: str  # RuleId text: `SUMP_SHEAR_CUSP/S2/3`, `every_cycle/1`
    span: Span
    guard: Guard | None  # None: always fires when tried
    text: str  # the guard as the spec writes it ('' when it has none)
    sends: tuple[tuple[str, str], ...]  # (sub, COMMAND) in order
    report: str | None  # DONE, ERROR or None
    next_state: str | None  # None: stays (NOP after a report)
    # actuator fields it sets: (field, True when set to its safe value, False otherwise or
    # unknown) - a hook returning into an actuator counts as unknown
    actuators: tuple[tuple[str, bool], ...] = ()
    locals_set: tuple[tuple[str, Any], ...] = ()  # tracked locals set to a constant
    # what its guard reads, predicates, functions and `let` values inlined: (RefKind, name)
    reads: frozenset[tuple[str, str]] = frozenset()
    world_sets: frozenset[str] = frozenset()  # world fields it sets (or a hook returns into)
    # what it writes, as a property's `writes(...)` names it: a local, `world.<field>`
    assigns: frozenset[str] = frozenset()
    hold: int | None = None  # `for:` N cycles: it fires once its `when` held more than N
    # its guard's typed tree, predicates, functions and `let` values inlined (None: none),
    # and what its actions write, in order: (local name or `world.<field>`, the value's tree;
    # None where a hook returns it) - what z3 reads of a run's numbers (`numbers.py`)
    tree: expr.Expr | None = None
    writes: tuple[tuple[str, expr.Expr | None], ...] = ()


@dataclass
class Skeleton:
    """A controller's control skeleton: the tables over states, subordinates and time."""

    name: str
    commands: tuple[str, ...]  # in code order (code = index + 1)
    subs: tuple[str, ...]
    tables: dict[str, dict[str, list[RuleView]]]  # command -> state -> rules
    every: list[RuleView]
    generated: frozenset[str]  # commands with rcsgen's default table
    spans: dict[str, Span]  # command -> where it is declared
    state_spans: dict[tuple[str, str], Span]
    # (command, state) -> the time thresholds (cycles) its rules compare `time` with
    timers: dict[tuple[str, str], tuple[int, ...]]
    actuators: tuple[str, ...]  # actuator fields it writes
    operator: bool  # an operator module (a person): every command of its is motion
    tasks_outcomes: dict[str, tuple[str, ...]] = field(default_factory=dict)
    # each local's type and initial value (an enum's as its index), for `numbers.py`
    locals_init: dict[str, tuple[Any, Any]] = field(default_factory=dict)
    constants: dict[str, Any] = field(default_factory=dict)  # name -> value
    _cache: dict[Any, tuple[Choice, ...]] = field(default_factory=dict)
    _read: dict[int, tuple[Key, ...]] = field(default_factory=dict)
    views: dict[str, RuleView] = field(default_factory=dict)  # rule id text -> rule (memo)

    def choices(self, rules: list[RuleView], fixed: dict[Key, Any]) -> tuple[Choice, ...]:
        """Which rule of `rules` can fire with these atoms fixed: its index (None: none
        fires), whether that is certain ("yes") or only possible (the analysis could not
        decide: an opaque comparison, too many valuations), and a valuation that makes it
        so (the values a replay scripts)."""
        read = self._read.get(id(rules))
        if read is None:  # the atoms the rules' guards read, in order (once per list)
            read = self._read[id(rules)] = tuple(
                sorted({k for r in rules if r.guard for k in r.guard.order})
            )
        key = (id(rules), tuple((k, fixed[k]) for k in read if k in fixed))
        found = self._cache.get(key)
        if found is not None:
            return found
        out: list[Choice] = []
        earlier: list[tuple[Guard | None, bool]] = []
        for index, rule in enumerate(rules):
            answer = solve([(rule.guard, True), *earlier], fixed=fixed)
            if answer.kind != "no":
                out.append(Choice(index, answer.kind == "yes", tuple(answer.shown)))
            earlier.append((rule.guard, False))
            if rule.guard is None:
                break
        else:
            if not earlier:
                out.append(Choice(None, True, ()))
            elif (last := solve(earlier, fixed=fixed)).kind != "no":
                out.append(Choice(None, last.kind == "yes", tuple(last.shown)))
        self._cache[key] = tuple(out)
        return self._cache[key]


@dataclass(frozen=True)
class Choice:
    """One way a list of rules can go in a cycle."""

    rule: int | None  # the index of the rule that fires; None: none does
    certain: bool
    valuation: tuple[tuple[Key, Any], ...]


def _world_sets(rule: ir.IRRule) -> list[str]:
    found = []
    for action in rule.actions:
        if isinstance(action, ir.IRSet):
            found += [
                a.target.removeprefix("world.")
                for a in action.assignments
                if a.target.startswith("world.")
            ]
        elif isinstance(action, ir.IRCall):
            found += [
                x.removeprefix("self.world_") for x in action.targets if x.startswith("self.world_")
            ]
    return found


def _assigns(rule: ir.IRRule) -> frozenset[str]:
    """The locals (by name) and world fields (`world.<field>`) a rule's actions write."""
    found: set[str] = set()
    for action in rule.actions:
        if isinstance(action, ir.IRSet):
            found |= {a.target for a in action.assignments}
        elif isinstance(action, ir.IRCall):
            for target in action.targets:
                if target.startswith("self.world_"):
                    found.add("world." + target.removeprefix("self.world_"))
                elif target.startswith("self.var_"):
                    found.add(target.removeprefix("self.var_"))
    return frozenset(found)


def _constant(literal: str) -> Any:
    return ast.literal_eval(literal.split("#", 1)[0].strip())


def _reasons(c: ir.IRController) -> tuple[str, ...]:
    return tuple(dict.fromkeys(r for command in c.commands for r in command.reasons))


def builder_of(system: ir.IRSystem, c: ir.IRController) -> GuardBuilder:
    """The analysis's guard builder for a controller, made from its IR."""
    sub_commands = {
        s.name: tuple(cmd.name for cmd in system.controller(s.name).commands)
        for s in c.subordinates
    }
    builder = GuardBuilder(
        {name: _constant(text) for name, text in c.constants},
        {p.name: p.expr.tree for p in c.predicates},
        sub_commands,
        {s.name: _reasons(system.controller(s.name)) for s in c.subordinates},
    )
    builder.functions = {f.name: (tuple(p for p, _ in f.params), f.body.tree) for f in c.functions}
    builder.plans = {p.name: (p.capacity, p.replans) for p in c.plans}
    return builder


def reads_of(tree: expr.Expr | None, builder: GuardBuilder) -> frozenset[tuple[str, str]]:
    """What an expression reads, (RefKind, name), through predicates, functions and `let`
    values (a subordinate's status, command, reason or result by the subordinate's name)."""
    found: set[tuple[str, str]] = set()
    todo = [tree] if tree is not None else []
    while todo:
        for node in expr.walk(todo.pop()):
            if isinstance(node, expr.Call) and node.kind == expr.CallKind.PREDICATE:
                todo.append(builder.predicates[node.name])
            elif (inlined := builder.inline(node)) is not None:
                todo.append(inlined)
            elif isinstance(node, expr.Ref) and node.kind is not expr.RefKind.ARG:
                found.add((str(node.kind), node.owner or node.name))
    return frozenset(found)


def expanded(tree: expr.Expr, builder: GuardBuilder) -> expr.Expr:
    """`tree` with every predicate, function call and `let` value inlined."""
    if isinstance(tree, expr.Call) and tree.kind == expr.CallKind.PREDICATE:
        return expanded(builder.predicates[tree.name], builder)
    if (inlined := builder.inline(tree)) is not None:
        return expanded(inlined, builder)
    if isinstance(tree, expr.Call):
        return replace(tree, args=tuple(expanded(a, builder) for a in tree.args))
    if isinstance(tree, expr.Unary):
        return replace(tree, operand=expanded(tree.operand, builder))
    if isinstance(tree, expr.Binary):
        return replace(tree, left=expanded(tree.left, builder), right=expanded(tree.right, builder))
    if isinstance(tree, expr.BoolOp):
        return replace(tree, values=tuple(expanded(v, builder) for v in tree.values))
    if isinstance(tree, expr.Compare):
        return replace(
            tree,
            left=expanded(tree.left, builder),
            comparators=tuple(expanded(c, builder) for c in tree.comparators),
        )
    if isinstance(tree, expr.IfExp):
        return replace(
            tree,
            test=expanded(tree.test, builder),
            body=expanded(tree.body, builder),
            orelse=expanded(tree.orelse, builder),
        )
    return tree


def _writes(rule: ir.IRRule, builder: GuardBuilder) -> tuple[tuple[str, expr.Expr | None], ...]:
    """What a rule's actions write, in order: (local or `world.<field>`, value tree or None)."""
    found: list[tuple[str, expr.Expr | None]] = []
    for action in rule.actions:
        if isinstance(action, ir.IRSet):
            found += [
                (a.target, expanded(a.value.tree, builder))
                for a in action.assignments
                if not a.target.startswith("result.")
            ]
        elif isinstance(action, ir.IRCall):
            for target in action.targets:
                if target.startswith("self.world_"):
                    found.append(("world." + target.removeprefix("self.world_"), None))
                elif target.startswith("self.var_"):
                    found.append((target.removeprefix("self.var_"), None))
    return tuple(found)


def _hold(guard: expr.Expr | None) -> int | None:
    """The cycles a `for:` rule's `when` must have held (its guard's `held > N`)."""
    for node in expr.walk(guard) if guard is not None else ():
        if (
            isinstance(node, expr.Compare)
            and isinstance(node.left, expr.Ref)
            and node.left.kind == expr.RefKind.HELD
            and isinstance(node.comparators[0], expr.Const)
        ):
            return int(node.comparators[0].value)
    return None


def _thresholds(guard: expr.Expr | None) -> tuple[int, ...]:
    """The cycle counts a rule's `after:` compares the time in its state with."""
    if guard is None:
        return ()
    found = []
    for node in expr.walk(guard):
        if (
            isinstance(node, expr.Compare)
            and isinstance(node.left, expr.Ref)
            and node.left.kind == "time"
        ):
            for c in node.comparators:
                if isinstance(c, expr.Const) and isinstance(c.value, int):
                    found.append(int(c.value))
    return tuple(found)


def skeleton(system: ir.IRSystem, c: ir.IRController, actuator_names: frozenset[str]) -> Skeleton:
    """The control skeleton of one controller, from its IR; `actuator_names` are the world
    fields declared `actuator: true`."""
    world = {f.name: f for f in system.world}
    builder = builder_of(system, c)

    def view(rule: ir.IRRule) -> RuleView:
        guard = builder.guard(rule.guard.tree) if rule.guard is not None else None
        sends, report, acts = [], None, []
        for action in rule.actions:
            if isinstance(action, ir.IRSend):
                sends.append((action.sub, action.command))
            elif isinstance(action, ir.IRReport):
                report = action.status
            elif isinstance(action, ir.IRSet):
                for assign in action.assignments:
                    name = assign.target.removeprefix("world.")
                    if assign.target.startswith("world.") and name in actuator_names:
                        value = expr.fold(assign.value.tree, builder.constants)
                        acts.append((name, value is not None and value == safe_value(world[name])))
            elif isinstance(action, ir.IRCall):
                for target in action.targets:
                    name = target.removeprefix("self.world_")
                    if target.startswith("self.world_") and name in actuator_names:
                        acts.append((name, False))
        nxt = None if report else rule.next_state
        text = rule.guard.text if rule.guard is not None else ""
        return RuleView(
            str(rule.id),
            rule.span,
            guard,
            text,
            tuple(sends),
            report,
            nxt,
            tuple(acts),
            reads=reads_of(rule.guard.tree if rule.guard else None, builder),
            world_sets=frozenset(_world_sets(rule)),
            assigns=_assigns(rule),
            hold=_hold(rule.guard.tree if rule.guard else None),
            tree=expanded(rule.guard.tree, builder) if rule.guard is not None else None,
            writes=_writes(rule, builder),
        )

    tables: dict[str, dict[str, list[RuleView]]] = {}
    timers: dict[tuple[str, str], tuple[int, ...]] = {}
    state_spans = {}
    for command in c.commands:
        builder.lets = {name: value.tree for name, value in command.lets}
        tables[command.name] = {}
        for state in command.states:
            tables[command.name][state.name] = [view(r) for r in state.rules]
            state_spans[(command.name, state.name)] = state.span
            found = sorted(
                {t for r in state.rules for t in _thresholds(r.guard.tree if r.guard else None)}
            )
            if found:
                timers[(command.name, state.name)] = tuple(found)
    builder.lets = {}
    every = [view(r) for r in c.every_cycle]
    writes = tuple(f.name for f in c.world_writes if f.name in actuator_names)
    return Skeleton(
        c.name,
        tuple(cmd.name for cmd in c.commands),
        tuple(s.name for s in c.subordinates),
        tables,
        every,
        frozenset(cmd.name for cmd in c.commands if cmd.generated),
        {cmd.name: cmd.span for cmd in c.commands},
        state_spans,
        timers,
        writes,
        operator=c.is_operator,
        locals_init={v.name: (v.type, _initial(v.type, v.initial)) for v in c.locals},
        constants=dict(builder.constants),
    )


def _initial(kind: Any, value: Any) -> Any:
    """A local's initial value as an expression's constant holds it (an enum's index)."""
    values = getattr(kind, "values", None)
    if values is not None and isinstance(value, str) and value in values:
        return values.index(value)
    return value


# ---------------------------------------------------------------- the system around it


def placement(system: ir.IRSystem) -> dict[str, tuple[str, int]]:
    """Each module that runs: (its process, its position in the lockstep order)."""
    found: dict[str, tuple[str, int]] = {}
    at = 0
    for process in system.processes:
        for module in process.modules:
            found[module] = (process.name, at)
            at += 1
    return found


def operator_outcomes(c: ir.IRController) -> dict[str, tuple[str, ...]]:
    """An operator module's tasks: a person answers DONE or ERROR; INIT/HALT withdraw: DONE."""
    return {
        cmd.name: (DONE,) if cmd.name in BUILTIN_COMMANDS else (DONE, ERROR) for cmd in c.commands
    }
