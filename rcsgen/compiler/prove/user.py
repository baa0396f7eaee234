"""User properties: the engineer's own `properties:` -> checked in their supervisor's model.

A property (`ir.IRProperty`, resolved by `checks/properties.py`) is read on the cycles of
the explored model of the supervisor it is stated over, with a small monitor beside each
model state: which actuators it names are not at their safe value (the last value the
supervisor set, or the field's initial value; a latched field is safe), and how many more
cycles an open `whenever` may wait for its `then`. The search is breadth first over model
state and monitor, so a counter-example is a shortest run, replayed like every other.

The meaning of one cycle (docs/spec.md section 19): a module's state, command and status
are the ones after the cycle; a subordinate's status is what the supervisor read in it, its
command the last one sent to it; `sent` and `writes` are what the rules that fired did. An
invariant is checked on every cycle but the runtime's safe state (the runtime acts there,
not the table). An obligation is started by any cycle but one where a process is lost or
back, or the operator resets the latches, and ends, met or not, at such a cycle or at a new
command from above (a new decision): no property counts on a recovery or on the operator.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from ...runtime.contract import NO_COMMAND_NAME
from .. import ir
from ..ir import IRPropAtom, IRProperty, IRPropExpr, PropKind
from .adapter import Skeleton, table_rules
from .model import LIMIT, Edge, Graph, State
from .properties import Finding, _certain, _rule_of, rule_view

Monitor = tuple[frozenset[str], int]  # (actuators named not at their safe value, cycles left)
OPEN = 0  # cycles left when no obligation is open


# A property's expression, compiled once into a test of one cycle: (the cycle's edge, the
# state after it, the tracked actuators not at their safe value after it) -> whether it holds.
# The search reads it on every edge of the model (tens of thousands per supervisor).
Test = Callable[[Edge, State, frozenset[str]], bool]


def _atom(sk: Skeleton, a: IRPropAtom) -> Test:
    """One atom's test (docs/spec.md section 19: a module's state, command and status after
    the cycle; a subordinate's status as read in it, its command the last one sent)."""
    value = a.value
    if a.kind is PropKind.STATE:
        return lambda edge, t, unsafe: t.state == value
    if a.kind is PropKind.COMMAND:
        return lambda edge, t, unsafe: (t.command or NO_COMMAND_NAME) == value
    if a.kind is PropKind.STATUS:
        return lambda edge, t, unsafe: t.status == value
    if a.kind is PropKind.SENT:
        sent = (a.module, value)
        return lambda edge, t, unsafe: sent in edge.sends
    if a.kind is PropKind.WRITES:
        return lambda edge, t, unsafe: any(value in rule_view(sk, r).assigns for r in edge.rules)
    if a.kind is PropKind.SAFE:
        name = value.removeprefix("world.")
        return lambda edge, t, unsafe: name not in unsafe
    if a.module not in sk.subs:  # as `sk.subs.index` fails when read

        def missing(edge: Edge, t: State, unsafe: frozenset[str]) -> bool:
            raise ValueError(f"{a.module!r} is not a subordinate of {sk.name}")

        return missing
    index = sk.subs.index(a.module)
    if a.kind is PropKind.SUB_STATUS:
        return lambda edge, t, unsafe: edge.views[index] == value
    return lambda edge, t, unsafe: (t.subs[index][0] or NO_COMMAND_NAME) == value  # SUB_COMMAND


def _joined(op: str, parts: list[Test]) -> Test:
    """`and`/`or` of tests, left to right and short-circuit, as nested pairs (no generator
    per cycle)."""
    first = parts[0]
    if len(parts) == 1:
        return first
    rest = _joined(op, parts[1:])
    if op == "and":
        return lambda edge, t, unsafe: first(edge, t, unsafe) and rest(edge, t, unsafe)
    return lambda edge, t, unsafe: first(edge, t, unsafe) or rest(edge, t, unsafe)


def compiled(sk: Skeleton, e: IRPropExpr) -> Test:
    """A property expression's test of one cycle."""
    if e.op == "atom":
        assert e.atom is not None
        return _atom(sk, e.atom)
    if e.op == "not":
        inner = compiled(sk, e.args[0])
        return lambda edge, t, unsafe: not inner(edge, t, unsafe)
    if e.op in ("and", "or") and e.args:
        return _joined(e.op, [compiled(sk, x) for x in e.args])
    truth = e.op == "true" or (e.op == "and" and not e.args)
    return lambda edge, t, unsafe: truth


def _tracked(prop: IRProperty) -> frozenset[str]:
    atoms = [*prop.then.atoms(), *(prop.whenever.atoms() if prop.whenever else [])]
    return frozenset(a.value.removeprefix("world.") for a in atoms if a.kind is PropKind.SAFE)


def _unsafe_after(
    unsafe: frozenset[str], edge: Edge, t: State, tracked: frozenset[str]
) -> frozenset[str]:
    """The tracked actuators not at their safe value after a cycle: set unsafe by a rule
    that fired (unsafe wins over safe in one cycle), else as before unless set safe or
    latched by the runtime."""
    if not tracked:
        return unsafe
    now = (unsafe - set(edge.safe) - t.latched) | (set(edge.unsafe) & tracked)
    return frozenset(now - t.latched)


def _quiet(edge: Edge) -> bool:
    return edge.lost is None and edge.recovered is None and not edge.reset and not edge.safe_state


def _step(
    prop: IRProperty,
    then: Test,
    whenever: Test | None,
    cycle: tuple[Edge, State, frozenset[str]],
    left: int,
) -> tuple[bool, int]:
    """(violated in this cycle, cycles left of the open obligation after it)."""
    edge = cycle[0]
    if whenever is None:
        return (not edge.safe_state and not then(*cycle)), OPEN
    if left and (not _quiet(edge) or edge.new is not None):
        left = OPEN  # a loss, a recovery, a reset, a new command: a new situation
    if left:
        if then(*cycle):
            left = OPEN
        elif left == 1:
            return True, OPEN
        else:
            left -= 1
    if not left and _quiet(edge) and whenever(*cycle) and not then(*cycle):
        if prop.within == 0:
            return True, OPEN
        left = prop.within
    return False, left


def _initial_unsafe(system: ir.IRSystem, tracked: frozenset[str]) -> frozenset[str]:
    return frozenset(f.name for f in system.world if f.name in tracked and f.initial != f.safe)


class TooLarge(Exception):
    """The model with the property's monitor has more than LIMIT states: undecided."""


def check(
    graph: Graph, prop: IRProperty, system: ir.IRSystem, limit: int = LIMIT
) -> Finding | None:
    """The shortest run of the model that breaks `prop`, as a W709 finding; None when it
    holds in every run; TooLarge when the model and its monitor are too large to say."""
    tracked = _tracked(prop)
    then = compiled(graph.skeleton, prop.then)
    whenever = compiled(graph.skeleton, prop.whenever) if prop.whenever is not None else None
    if not tracked and (whenever is None or prop.within == 0) and graph.complete:
        return _stateless(graph, prop, then, whenever)
    return search(graph, prop, system, limit)


def search(
    graph: Graph, prop: IRProperty, system: ir.IRSystem, limit: int = LIMIT
) -> Finding | None:
    """`check` by breadth-first search over model state and monitor (any property)."""
    tracked = _tracked(prop)
    then = compiled(graph.skeleton, prop.then)
    whenever = compiled(graph.skeleton, prop.whenever) if prop.whenever is not None else None
    start = (graph.initial, (_initial_unsafe(system, tracked), OPEN))
    parent: dict[tuple[State, Monitor], tuple[tuple[State, Monitor], Edge] | None] = {start: None}
    todo = deque([start])
    while todo:
        at = todo.popleft()
        s, (unsafe, left) = at
        for edge, t in graph.edges.get(s, []):
            after = _unsafe_after(unsafe, edge, t, tracked)
            bad, still = _step(prop, then, whenever, (edge, t, after), left)
            if bad:
                return _finding(graph, prop, _path(parent, at) + [(edge, t)])
            key = (t, (after, still))
            if key not in parent:
                if len(parent) >= limit:
                    raise TooLarge(prop.name)
                parent[key] = (at, edge)
                todo.append(key)
    return None


def _stateless(graph: Graph, prop: IRProperty, then: Test, whenever: Test | None) -> Finding | None:
    """`check` of a property whose monitor never changes (no actuator's safety named, no
    obligation left open past its cycle): the search over model and monitor is the model's
    own breadth-first search, so its first violation is the first edge that breaks it in
    the order the model was explored, and its run the model's shortest one there."""
    none: frozenset[str] = frozenset()
    if whenever is None:  # an invariant: `_step`'s first line, inline
        for s, edges in graph.edges.items():
            for edge, t in edges:
                if not edge.safe_state and not then(edge, t, none):
                    return _finding(graph, prop, graph.path_to(s) + [(edge, t)])
        return None
    for s, edges in graph.edges.items():
        for edge, t in edges:
            if _step(prop, then, whenever, (edge, t, none), OPEN)[0]:
                return _finding(graph, prop, graph.path_to(s) + [(edge, t)])
    return None


def _path(parent: dict, at: tuple[State, Monitor]) -> list[tuple[Edge, State]]:  # type: ignore[type-arg]
    run: list[tuple[Edge, State]] = []
    while (back := parent[at]) is not None:
        previous, edge = back
        run.append((edge, at[0]))
        at = previous
    return list(reversed(run))


def _trigger(graph: Graph, prop: IRProperty, trace: list[tuple[Edge, State]]) -> int:
    """The cycle (1-based) whose `whenever` the violation leaves unanswered."""
    if prop.whenever is None:
        return len(trace)
    return len(trace) - prop.within


def _finding(graph: Graph, prop: IRProperty, trace: list[tuple[Edge, State]]) -> Finding:
    sk = graph.skeleton
    edge, last = trace[-1]
    table = table_rules(edge.rules) or list(edge.rules)
    if (prop.whenever is None or prop.within == 0) and table:
        command, state, index, span = _rule_of(sk, table[-1])
        rule = f"rule {table[-1]} of {sk.name}"
        if command in sk.generated:  # written nowhere: at the property it breaks
            span, rule = prop.span, f"{rule}, in rcsgen's default {command} table,"
        detail = f"in cycle {len(trace)} {rule} breaks it"
    else:
        at = _trigger(graph, prop, trace)
        command, state, index, span = trace[at - 1][1].command, None, None, prop.span
        detail = (
            f"it held in cycle {at} and the response did not follow by cycle {len(trace)}"
            if prop.whenever is not None
            else f"it fails in cycle {len(trace)}"
        )
    return Finding(
        "W709",
        sk.name,
        command,
        state,
        index,
        span,
        f"property `{prop.name}` is violated: {prop.text}; {detail}",
        "the counter-example shows the cycles: fix the rule, or the property if it says more "
        "than the paper does",
        trace,
        _certain(trace),
    )
