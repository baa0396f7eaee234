"""Numbers: is a counter-example's run possible with the values its guards read? (z3)

The explicit engine decides each cycle's guards alone, over the analysis's regions: a
local, a parameter or a world value may take one value in one cycle and another in the
next, whatever the rules set. z3 (the optional extra `rcsgen[prove]`) asks whether the run
is possible as the generated code keeps its values: a local starts at its initial value and
changes only where a rule that fired sets it (in order, as the code assigns it), a
parameter is fixed from the command that brought it to the next, a world value is free in
each cycle but the same for every rule of that cycle, and what the controller writes to it
is what it reads after. Per cycle the rules tried before the one that fired had their
guard false, the one that fired true, each subordinate's status is the one the model read.
What z3 cannot follow exactly - a hook's result, a subordinate's result or reason, a plan,
the time in a state, an integer division, a float compared for equality (rounding) - is a
fresh value, so a run is called impossible only when it is.

An impossible run is looked for again, longer (`search`): the same violating cycle reached
by another path, depth first with z3 pruning each prefix, within a budget.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from fractions import Fraction
from itertools import count
from typing import Any

from .. import expressions as expr
from .. import types
from ..analysis.tables import Atom
from .adapter import RuleView, Skeleton, is_every_cycle, table_rules
from .model import NOP, Edge, Graph, State
from .properties import rule_view

Run = list[tuple[Edge, State]]
EXTRA_CYCLES = 6  # how much longer than the rejected run another may be
BUDGET = 60  # the most cycles the search for another run adds to z3, per finding
_FRESH = (
    expr.RefKind.SUB_RESULT,
    expr.RefKind.SUB_REASON,
    expr.RefKind.SUB_REASON_NAME,
    expr.RefKind.SUB_COMMAND,
    expr.RefKind.SUB_COMMAND_NAME,
    expr.RefKind.PLAN,
    expr.RefKind.TIME,
    expr.RefKind.HELD,
)


def numeric(sk: Skeleton, trace: Run) -> bool:
    """Whether the run's rules read a local, a parameter or a world value (only such a
    run is asked about)."""
    kinds = (expr.RefKind.LOCAL, expr.RefKind.PARAM, expr.RefKind.WORLD)
    for rule in _tried_rules(sk, trace):
        if rule.tree is not None and any(r.kind in kinds for r in expr.refs(rule.tree)):
            return True
    return False


def _tried_rules(sk: Skeleton, trace: Run) -> Iterator[RuleView]:
    yield from sk.every
    for edge, _ in trace:
        for rule_id in edge.rules:
            yield rule_view(sk, rule_id)


class Encoder:
    """The constraints of a run, one cycle at a time (copied for each branch of a search)."""

    def __init__(self, z3: Any, graph: Graph) -> None:
        self.z3, self.sk = z3, graph.skeleton
        self.names = count()
        self.locals: dict[str, Any] = {
            name: self._const(kind, value) for name, (kind, value) in self.sk.locals_init.items()
        }
        self.params: dict[str, Any] = {}
        self.kinds: dict[str, Any] = {}  # each parameter's type, as the rules read it
        self.before: State = graph.initial

    def copy(self) -> Encoder:
        other = Encoder.__new__(Encoder)
        other.z3, other.sk, other.names = self.z3, self.sk, self.names
        other.locals, other.params, other.before = dict(self.locals), dict(self.params), self.before
        other.kinds = self.kinds
        return other

    # ------------------------------------------------------------ one cycle

    def cycle(self, edge: Edge, after: State) -> list[Any]:
        """The constraints of one cycle of the model, from the state before it."""
        sk, before = self.sk, self.before
        self.before = after
        if edge.new is not None:
            self.params = {}  # a new command: its parameters, fixed until the next one
        world: dict[str, Any] = {}
        views = dict(zip(sk.subs, edge.views, strict=True))
        fired = list(edge.rules)
        every = fired.pop(0) if fired and is_every_cycle(fired[0]) else None
        command = edge.new if edge.new is not None else before.command
        state, status = ("S0", "EXECUTING") if edge.new is not None else before[1:3]
        out = self._table(sk.every, every, views, world)
        if every is not None and rule_view(sk, every).report:
            state = NOP
        if edge.safe_state or command is None or state == NOP or status != "EXECUTING":
            return out
        table = sk.tables.get(command, {}).get(state)
        if table:
            out += self._table(table, fired[-1] if fired else None, views, world)
        return out

    def _table(
        self, rules: list[RuleView], fired: str | None, views: dict[str, str], world: dict[str, Any]
    ) -> list[Any]:
        """The rules of a list tried in order: false before the one that fired, it true and
        its writes applied (none fired: every guard false)."""
        out = []
        for rule in rules:
            guard = self.value(rule.tree, views, world) if rule.tree is not None else None
            if rule.id != fired:
                if guard is not None:
                    out.append(self.z3.Not(guard))
                continue
            if guard is not None:
                out.append(guard)
            for target, tree in rule.writes:
                value = self.value(tree, views, world) if tree is not None else None
                if target.startswith("world."):
                    world[target.removeprefix("world.")] = value
                elif target in self.locals:
                    kind = self.sk.locals_init[target][0]
                    self.locals[target] = value if value is not None else self._fresh(kind)
            break
        return out

    # ------------------------------------------------------------ expressions

    def _sort(self, kind: Any) -> Any:
        z3 = self.z3
        if isinstance(kind, types.Bool):
            return z3.BoolSort()
        if isinstance(kind, types.Int | types.Enum):
            return z3.IntSort()
        if isinstance(kind, types.Float):
            return z3.RealSort()
        return z3.StringSort()

    def _fresh(self, kind: Any) -> Any:
        return self.z3.Const(f"v{next(self.names)}", self._sort(kind))

    def _const(self, kind: Any, value: Any) -> Any:
        z3 = self.z3
        if isinstance(value, bool):
            return z3.BoolVal(value)
        if isinstance(value, int) and not isinstance(kind, types.Float):
            return z3.IntVal(value)
        if isinstance(value, int | float):
            f = Fraction(value)
            return z3.Q(f.numerator, f.denominator)
        return z3.StringVal(str(value))

    def value(self, e: expr.Expr | None, views: dict[str, str], world: dict[str, Any]) -> Any:
        """`e` as a z3 term in this cycle (a fresh value where it cannot be followed)."""
        assert e is not None
        found = self._value(e, views, world)
        return found if found is not None else self._fresh(e.type)

    def _value(self, e: expr.Expr, views: dict[str, str], world: dict[str, Any]) -> Any:
        z3 = self.z3
        if isinstance(e, expr.Const):
            return self._const(e.type, e.value)
        if isinstance(e, expr.Ref):
            return self._ref(e, views, world)
        if isinstance(e, expr.Unary):
            inner = self.value(e.operand, views, world)
            return z3.Not(inner) if e.op == "not" else (-inner if e.op == "-" else inner)
        if isinstance(e, expr.BoolOp):
            parts = [self.value(v, views, world) for v in e.values]
            return z3.And(*parts) if e.op == "and" else z3.Or(*parts)
        if isinstance(e, expr.IfExp):
            return self._if(e, views, world)
        if isinstance(e, expr.Binary):
            return self._binary(e, views, world)
        if isinstance(e, expr.Compare):
            return self._compare(e, views, world)
        if isinstance(e, expr.Call) and e.kind == expr.CallKind.BUILTIN:
            return self._builtin(e, views, world)
        return None

    def _ref(self, e: expr.Ref, views: dict[str, str], world: dict[str, Any]) -> Any:
        kind = e.kind
        if kind == expr.RefKind.CONST and e.name in self.sk.constants:
            return self._const(e.type, self.sk.constants[e.name])
        if kind == expr.RefKind.STATUS:
            return self.z3.StringVal(e.name)
        if kind == expr.RefKind.SUB_STATUS and e.owner in views:
            return self.z3.StringVal(views[e.owner])
        if kind == expr.RefKind.LOCAL and e.name in self.locals:
            return self.locals[e.name]
        if kind == expr.RefKind.PARAM:
            self.kinds[e.name] = e.type
            return self.params.setdefault(e.name, self._fresh(e.type))
        if kind == expr.RefKind.WORLD:
            found = world.get(e.name)
            if found is None:
                found = world[e.name] = self._fresh(e.type)
            return found
        if kind in _FRESH:
            return None
        return None

    def _numbers(self, a: Any, b: Any) -> tuple[Any, Any]:
        z3 = self.z3
        if a.sort() == b.sort():
            return a, b
        to_real = z3.ToReal
        return (to_real(a) if a.sort() == z3.IntSort() else a), (
            to_real(b) if b.sort() == z3.IntSort() else b
        )

    def _if(self, e: expr.IfExp, views: dict[str, str], world: dict[str, Any]) -> Any:
        body, orelse = self._numbers(
            self.value(e.body, views, world), self.value(e.orelse, views, world)
        )
        if body.sort() != orelse.sort():
            return None
        return self.z3.If(self.value(e.test, views, world), body, orelse)

    def _binary(self, e: expr.Binary, views: dict[str, str], world: dict[str, Any]) -> Any:
        if e.op not in ("+", "-", "*", "/"):
            return None  # // and %: Python's floor, not z3's
        a, b = self._numbers(self.value(e.left, views, world), self.value(e.right, views, world))
        if e.op == "/":
            a, b = (self.z3.ToReal(x) if x.sort() == self.z3.IntSort() else x for x in (a, b))
            return a / b
        return a + b if e.op == "+" else (a - b if e.op == "-" else a * b)

    def _compare(self, e: expr.Compare, views: dict[str, str], world: dict[str, Any]) -> Any:
        z3 = self.z3
        terms = [e.left, *e.comparators]
        parts = []
        for op, left, right in zip(e.ops, terms, terms[1:], strict=False):
            floats = isinstance(left.type, types.Float) or isinstance(right.type, types.Float)
            if op in ("==", "!=") and floats:
                parts.append(self._fresh(types.BOOL))  # rounding: not decided exactly
                continue
            a, b = self.value(left, views, world), self.value(right, views, world)
            if a.sort() != b.sort():
                if a.sort() == z3.StringSort() or b.sort() == z3.StringSort():
                    parts.append(self._fresh(types.BOOL))
                    continue
                a, b = self._numbers(a, b)
            relation = {
                "==": lambda x, y: x == y,
                "!=": lambda x, y: x != y,
                "<": lambda x, y: x < y,
                "<=": lambda x, y: x <= y,
                ">": lambda x, y: x > y,
                ">=": lambda x, y: x >= y,
            }.get(op)
            parts.append(relation(a, b) if relation else self._fresh(types.BOOL))
        return z3.And(*parts) if len(parts) > 1 else parts[0]

    def _builtin(self, e: expr.Call, views: dict[str, str], world: dict[str, Any]) -> Any:
        z3 = self.z3
        args = [self.value(a, views, world) for a in e.args]
        if e.name == "abs" and len(args) == 1:
            return z3.If(args[0] >= 0, args[0], -args[0])
        if e.name in ("min", "max") and args:
            best = args[0]
            for x in args[1:]:
                best, x = self._numbers(best, x)
                pick = x < best if e.name == "min" else x > best
                best = z3.If(pick, x, best)
            return best
        return None


def witness(z3: Any, graph: Graph, trace: Run) -> Run | None:
    """The run with, on each cycle that brings a command, the parameter values of one
    solution (the explicit engine picks each guard's values alone, so a parameter may take
    one value in one cycle and another later: a replay given those departs); None when no
    values make the run possible."""
    solver = z3.Solver()
    encoder = Encoder(z3, graph)
    brought: list[tuple[int, dict[str, Any]]] = []
    for index, (edge, after) in enumerate(trace):
        solver.add(*encoder.cycle(edge, after))
        if edge.new is not None:
            brought.append((index, encoder.params))  # filled as later cycles read them
    if solver.check() == z3.unsat:
        return None
    model = solver.model()
    out = list(trace)
    for index, params in brought:
        edge, after = out[index]
        chosen = {  # an enumeration's index is no value name: the model's own choice stays
            name: _python(z3, model.eval(term))
            for name, term in params.items()
            if not isinstance(encoder.kinds[name], types.Enum)
        }
        chosen = {name: value for name, value in chosen.items() if value is not None}
        kept = tuple(
            (k, v) for k, v in edge.valuation if not (k[0] == Atom.PARAM and k[1] in chosen)
        )
        given = tuple(((Atom.PARAM, name), value) for name, value in sorted(chosen.items()))
        out[index] = (edge._replace(valuation=kept + given), after)
    return out


def _python(z3: Any, value: Any) -> Any:
    """A z3 value of a solution as the model's valuations hold one (None: left free)."""
    if z3.is_true(value) or z3.is_false(value):
        return z3.is_true(value)
    if z3.is_int_value(value):
        return Fraction(value.as_long())
    if z3.is_rational_value(value):
        return Fraction(value.numerator_as_long(), value.denominator_as_long())
    if z3.is_string_value(value):
        return value.as_string()
    return None


def search(z3: Any, graph: Graph, trace: Run, also: Any = None) -> Run | None:
    """Another run to the same last cycle as `trace` (from the state before it), possible
    with its numbers (and `also(run)`, when given), at most EXTRA_CYCLES longer, shortest
    first; None when there is none within the budget."""
    if not trace:
        return None
    target = trace[-2][1] if len(trace) > 1 else graph.initial
    last = _alike(graph, target, trace[-1])
    last = [c for c in last if _alone(z3, graph, target, c)]
    distance = _distances(graph, target)
    if not last or graph.initial not in distance:
        return None
    budget = [BUDGET]
    for length in range(len(trace) - 1, len(trace) + EXTRA_CYCLES):
        solver = z3.Solver()
        found = _dfs(
            z3,
            solver,
            graph,
            Encoder(z3, graph),
            graph.initial,
            target,
            length,
            distance,
            last,
            [],
            budget,
            also,
        )
        if found is not None or budget[0] <= 0:
            return found
    return None


def _dfs(
    z3: Any,
    solver: Any,
    graph: Graph,
    encoder: Encoder,
    at: State,
    target: State,
    left: int,
    distance: dict[State, int],
    last: list[tuple[Edge, State]],
    run: Run,
    budget: list[int],
    also: Any,
) -> Run | None:
    """Depth first: `left` more cycles to `target`, then one of `last`; each prefix
    possible."""
    if budget[0] <= 0:
        return None
    if left == 0:
        if at != target:
            return None
        for cycle in last:
            found = _close(z3, solver, encoder, cycle, run, also)
            if found is not None:
                return found
        return None
    near = [(e, t) for e, t in graph.edges.get(at, []) if distance.get(t, left) <= left - 1]
    near.sort(key=lambda c: (c[0].new is not None, distance[c[1]]))  # its own cycles first
    for edge, t in near:
        if budget[0] <= 0:
            break
        budget[0] -= 1
        branch = encoder.copy()
        solver.push()
        solver.add(*branch.cycle(edge, t))
        if solver.check() != z3.unsat:
            found = _dfs(
                z3,
                solver,
                graph,
                branch,
                t,
                target,
                left - 1,
                distance,
                last,
                [*run, (edge, t)],
                budget,
                also,
            )
            if found is not None:
                solver.pop()
                return found
        solver.pop()
    return None


def _close(
    z3: Any, solver: Any, encoder: Encoder, last: tuple[Edge, State], run: Run, also: Any
) -> Run | None:
    solver.push()
    solver.add(*encoder.copy().cycle(*last))
    ok = solver.check() != z3.unsat
    solver.pop()
    candidate = [*run, last]
    if ok and (also is None or also(candidate)):
        return candidate
    return None


def _alone(z3: Any, graph: Graph, start: State, cycle: tuple[Edge, State]) -> bool:
    """Whether the cycle is possible from `start` with every local and parameter free: if
    not, no run reaches it (what it reads contradicts itself in that one cycle)."""
    encoder = Encoder(z3, graph)
    encoder.locals = {
        n: encoder._fresh(kind) for n, (kind, _) in graph.skeleton.locals_init.items()
    }
    encoder.before = start
    solver = z3.Solver()
    solver.add(*encoder.cycle(*cycle))
    return bool(solver.check() != z3.unsat)


def _alike(graph: Graph, start: State, cycle: tuple[Edge, State]) -> list[tuple[Edge, State]]:
    """The cycles from `start` that are the violating `cycle` but for the every_cycle rules
    (sensory processing, a hook's bookkeeping): the same events, the same table rule, the
    same state after - the property reads nothing else; `cycle` first."""
    edge, after = cycle

    def key(e: Edge) -> tuple[Any, ...]:
        table = tuple(table_rules(e.rules))
        return (e.new, e.answers, e.lost, e.recovered, e.reset, e.safe_state, table, e.report)

    same = [c for c in graph.edges.get(start, []) if c[1] == after and key(c[0]) == key(edge)]
    return [cycle, *(c for c in same if c != cycle)]


def _distances(graph: Graph, target: State) -> dict[State, int]:
    """Cycles from each state to `target` (breadth first on the reversed graph)."""
    back: dict[State, list[State]] = {}
    for s, edges in graph.edges.items():
        for _, t in edges:
            back.setdefault(t, []).append(s)
    distance = {target: 0}
    todo = deque([target])
    while todo:
        t = todo.popleft()
        for s in back.get(t, []):
            if s not in distance:
                distance[s] = distance[t] + 1
                todo.append(s)
    return distance
