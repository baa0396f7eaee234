"""Tables: the checked system's types, and the rule semantics every later stage shares.

`check` builds these from the model: every name resolved, every expression typed, each
controller's scopes kept. `analysis`, `lower` and the tools read them and never type an
expression again. What a rule *means* is decided here once - whether it is unconditional,
which rules of a state can never be tried (shadowed), which states a table can reach - so
the checker's W301, the analysis and the emitted code cannot disagree.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum

from .. import expressions as expr
from ..diagnostics import Span
from ..front_end import model
from ..front_end.model import ENTRY_STATE, Command, ControllerSpec, Hook, Rule, SystemSpec
from ..types import BOOL, Type
from .io import CheckedIo

__all__ = ["ENTRY_STATE"]


@dataclass(frozen=True, order=True)
class RuleId:
    """A rule's stable identity: its command and state (None for an every_cycle rule) and
    its 1-based position there. Printed `SUMP_SHEAR_CUSP/S2/3` or `every_cycle/1`."""

    command: str | None
    state: str | None
    index: int

    def __str__(self) -> str:
        if self.command is None:
            return f"every_cycle/{self.index}"
        return f"{self.command}/{self.state}/{self.index}"


class TargetKind(StrEnum):
    """What an assignment writes (`Target.kind`)."""

    WORLD = "world"
    LOCAL = "local"
    RESULT = "result"  # of the current command


@dataclass(frozen=True)
class Target:
    """An assignable name: a world field, a local or a result of the current command."""

    kind: TargetKind
    name: str
    type: Type

    @property
    def text(self) -> str:
        """As the spec writes it: `world.goal_x`, `ticks`, `result.at_goal`."""
        return self.name if self.kind is TargetKind.LOCAL else f"{self.kind}.{self.name}"


@dataclass(frozen=True)
class Send:
    sub: str
    command: str
    args: tuple[tuple[str, expr.Expr], ...]  # (parameter, typed value) in the spec's order
    source: model.Send

    @property
    def span(self) -> Span:
        return self.source.span

    def text(self, param: str) -> str:
        """The spec text of a parameter's value."""
        return one_line(self.source.args[param].value)


@dataclass(frozen=True)
class Assign:
    assignments: tuple[tuple[Target, expr.Expr], ...]
    source: model.SetWorld

    def text(self, target: Target) -> str:
        """The spec text of the value assigned to `target`."""
        found = (a.value.value for a in self.source.assignments if a.target.value == target.text)
        return one_line(next(found, ""))


@dataclass(frozen=True)
class Report:
    status: str  # DONE or ERROR
    span: Span
    reason: str | None = None  # with ERROR: one of the command's reasons, or `<sub>.reason`
    # `<sub>.reason`: the subordinate's reasons passed on as the same names (LOST too); any
    # other code it reports reads as NONE (docs/semantics.md, "Results and reasons")
    passes: tuple[str, ...] = ()


@dataclass(frozen=True)
class CallHook:
    hook: Hook
    args: tuple[expr.Expr, ...]
    targets: tuple[Target, ...]
    span: Span


@dataclass(frozen=True)
class PlanAction:
    """`plan:`/`replan:` (the planner's arguments typed where the action is) or `advance:`."""

    kind: model.PlanVerb
    plan: model.Plan
    args: tuple[expr.Expr, ...]  # the planner's arguments (none for advance)
    span: Span


Action = Send | Assign | Report | CallHook | PlanAction


@dataclass(frozen=True)
class CheckedRule:
    id: RuleId
    source: Rule  # the rule as written: span, doc, guard text
    guard: expr.Expr | None  # None: the rule has no `when` (or its guard did not check)
    actions: tuple[Action, ...]
    next_state: str | None  # None: stay; NOP after a report
    # The guard's value when it reads only literals, constants and such predicates (folded
    # by the checker), else None: it depends on the inputs.
    always: bool | None = None
    # Time (docs/semantics.md, "Time in a state"): `after:` and `for:` in cycles, None when
    # not given. Both are part of `guard` (cycles in the state, cycles the `when` held).
    after: int | None = None
    hold: int | None = None

    @property
    def span(self) -> Span:
        return self.source.span

    @property
    def unconditional(self) -> bool:
        """Fires whenever it is tried: no `when`, or a guard that is always true."""
        if self.source.when is None and self.after is None:
            return True
        if self.always is not None:
            return self.always
        return isinstance(self.guard, expr.Const) and self.guard.value is True

    @property
    def never(self) -> bool:
        """Never fires: its guard is always false (the checker's W302)."""
        return self.source.when is not None and self.always is False

    @property
    def reports(self) -> str | None:
        return next((a.status for a in self.actions if isinstance(a, Report)), None)

    @property
    def sends(self) -> tuple[Send, ...]:
        return tuple(a for a in self.actions if isinstance(a, Send))

    @property
    def guard_text(self) -> str | None:
        """The guard as the spec writes it, on one line, with its time (`world.ice, for 5 s`,
        `after 30 s`); None when it has none."""
        when, parts = self.source.when, []
        if when is not None:
            parts.append(one_line(when.value))
        if self.source.hold is not None:
            parts.append(f"for {duration_text(self.source.hold.value)}")
        if self.source.after is not None:
            parts.append(f"after {duration_text(self.source.after.value)}")
        return ", ".join(parts) if parts else None

    @property
    def timing(self) -> str:
        """The rule's time as a comment shows it: `after: 5 s = 50 cycles`, '' without."""
        parts = []
        if self.source.hold is not None and self.hold is not None:
            parts.append(f"for: {duration_text(self.source.hold.value)} = {_cycles(self.hold)}")
        if self.source.after is not None and self.after is not None:
            parts.append(f"after: {duration_text(self.source.after.value)} = {_cycles(self.after)}")
        return ", ".join(parts)


def is_timer(e: expr.Expr) -> bool:
    """A comparison of a rule's time counter that `after:`/`for:` added to its guard."""
    return (
        isinstance(e, expr.Compare)
        and isinstance(e.left, expr.Ref)
        and e.left.kind in (expr.RefKind.TIME, expr.RefKind.HELD)
    )


def untimed(guard: expr.Expr) -> tuple[expr.Expr | None, tuple[expr.Expr, ...]]:
    """A timed rule's guard split into its `when` (None: none) and its timer comparisons."""
    parts = guard.values if isinstance(guard, expr.BoolOp) and guard.op == "and" else (guard,)
    timers = tuple(p for p in parts if is_timer(p))
    rest = [p for p in parts if not is_timer(p)]
    if not rest:
        return None, timers
    return (rest[0] if len(rest) == 1 else expr.BoolOp(BOOL, "and", tuple(rest))), timers


def duration_text(value: object) -> str:
    """A duration as written, with its unit: `5` (seconds) -> `5 s`, `2 s`, `10 cycles`."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return f"{value} s"
    return " ".join(str(value).split())


def _cycles(count: int) -> str:
    return f"{count} cycle" if count == 1 else f"{count} cycles"


def one_line(value: object) -> str:
    """Spec text (an expression, a YAML number or boolean) as one line."""
    if value is True or value is False:
        return "true" if value else "false"
    return " ".join(str(value).split())


def live(rules: Iterable[CheckedRule]) -> tuple[list[CheckedRule], list[CheckedRule]]:
    """The rules that can fire, and those that never do: shadowed by an earlier unconditional
    rule (the checker's W301) or with a guard that is always false (W302).

    One rule fires per cycle, the first whose guard holds: nothing after an unconditional
    rule is ever tried. Rules that never fire are not emitted and not analysed."""
    tried: list[CheckedRule] = []
    dropped: list[CheckedRule] = []
    rules = list(rules)
    for index, rule in enumerate(rules):
        if rule.never:
            dropped.append(rule)
            continue
        tried.append(rule)
        if rule.unconditional:
            return tried, dropped + rules[index + 1 :]
    return tried, dropped


def reachable(start: str, successors: Callable[[str], Iterable[str]]) -> set[str]:
    """The states reachable from `start` (included) following `successors`."""
    reached, todo = {start}, [start]
    while todo:
        for target in successors(todo.pop()):
            if target not in reached:
                reached.add(target)
                todo.append(target)
    return reached


@dataclass(frozen=True)
class CheckedState:
    name: str
    span: Span
    rules: tuple[CheckedRule, ...]  # the live rules, in order
    shadowed: tuple[CheckedRule, ...] = ()  # never fire (W301, W302), in order


@dataclass(frozen=True)
class CheckedLet:
    """A named value of a table (`let:`): evaluated once per cycle before its rules."""

    name: str
    tree: expr.Expr
    text: str  # the spec text, on one line
    span: Span


@dataclass(frozen=True)
class CheckedFunction:
    """A pure function (`functions:`): its body reads only its parameters, the constants
    and the functions declared before it."""

    name: str
    params: tuple[tuple[str, Type], ...]  # (name, type) in call order
    returns: Type
    tree: expr.Expr
    text: str
    span: Span
    doc: str = ""  # what the spec says it computes


@dataclass(frozen=True)
class CheckedCommand:
    name: str
    code: int  # INIT = 1, HALT = 2, then the declared commands in order
    source: Command
    states: Mapping[str, CheckedState]
    scope: expr.Scope  # what its guards and values may name
    lets: tuple[CheckedLet, ...] = ()  # in order

    @property
    def generated(self) -> bool:
        """A default INIT/HALT table rcsgen supplies."""
        return self.source.generated


@dataclass(frozen=True)
class CheckedPredicate:
    name: str
    tree: expr.Expr
    text: str  # the spec text, on one line
    span: Span


@dataclass(frozen=True)
class CheckedController:
    spec: ControllerSpec
    supervisor: str | None
    simulator: bool  # a simulator or stand-in (flagged SIMU in its mode buffer)
    buffers: str  # whose command/status buffers it uses: itself, or the controller it replaces
    commands: Mapping[str, CheckedCommand]  # INIT, HALT, then the declared ones
    predicates: Mapping[str, CheckedPredicate]
    every_cycle: tuple[CheckedRule, ...]  # the live every_cycle rules
    sub_commands: Mapping[str, tuple[str, ...]]  # each subordinate's commands, in code order
    scope: expr.Scope  # the controller-wide scope (predicates, every_cycle)
    functions: Mapping[str, CheckedFunction] = field(default_factory=dict)
    clients: tuple[str, ...] = ()  # an operator module's: the controllers it serves

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def subordinates(self) -> list[str]:
        return [s.value for s in self.spec.subordinates]

    def rules(self) -> list[CheckedRule]:
        """Every live rule: every_cycle first, then each table's, state by state."""
        found = list(self.every_cycle)
        for command in self.commands.values():
            for state in command.states.values():
                found += state.rules
        return found


@dataclass(frozen=True)
class CheckedProcess:
    name: str
    cycle_period: float
    doc: str
    modules: tuple[str, ...]  # in execution order
    roots: tuple[str, ...]  # modules with no supervisor
    # controller -> (its stand-in, the modules of this process it replaces: itself + subtree)
    stand_ins: Mapping[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    watchdog: Mapping[str, float] = field(default_factory=dict)  # its declared limits
    realtime: Mapping[str, object] = field(default_factory=dict)  # its real-time settings
    # module -> where the process lists it (`processes: p: modules:`): findings about order
    module_spans: Mapping[str, Span] = field(default_factory=dict)


@dataclass(frozen=True)
class CheckedSystem:
    spec: SystemSpec
    controllers: Mapping[str, CheckedController]  # process order, then the stand-ins
    processes: tuple[CheckedProcess, ...]
    io: CheckedIo = field(default_factory=CheckedIo)  # fieldbus devices, checked

    @property
    def name(self) -> str:
        return self.spec.name
