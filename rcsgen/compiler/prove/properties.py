"""Properties: the explored model of one controller -> what holds, what does not and why.

Each check reads the graph `model.explore` made (never the spec again) and returns
`Finding`s with the shortest run that shows them. The composed figures (HALT reach k per
leaf, ERROR to the root d) are added up in `system.py` from the per-controller bounds here.
"""

from __future__ import annotations

import sys
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass, field

from ..diagnostics import Span, counted
from ..expressions import RefKind
from .adapter import DONE, ERROR, EXECUTING, RuleView, Skeleton, is_every_cycle
from .model import NOP, Edge, Graph, State

INFINITE = sys.maxsize


@dataclass
class Finding:
    """A property that does not hold (or cannot be decided) in one controller."""

    code: str
    controller: str
    command: str | None
    state: str | None
    rule: int | None  # 1-based, as RuleId
    span: Span
    message: str
    hint: str
    trace: list[tuple[Edge, State]] = field(default_factory=list)
    certain: bool = True  # every step of the trace was decided by the analysis
    verdict: str = "violated"  # or "undecided"
    replay: str = ""  # what the replay showed, once replayed
    scenario: str = ""  # the scenario file written for it


# ---------------------------------------------------------------- helpers


def _certain(trace: list[tuple[Edge, State]]) -> bool:
    return all(edge.certain for edge, _ in trace)


def _rule_of(sk: Skeleton, rule_id: str) -> tuple[str | None, str | None, int, Span]:
    """(command, state, index, span) of a rule id text; command and state are None for an
    every_cycle rule."""
    parts = rule_id.split("/")
    if is_every_cycle(rule_id):
        index = int(parts[1])
        return None, None, index, sk.every[index - 1].span
    command, state, index = parts[0], parts[1], int(parts[2])
    return command, state, index, sk.tables[command][state][index - 1].span


def rule_view(sk: Skeleton, rule_id: str) -> RuleView:
    """The rule a rule id text names (remembered: the checks ask for the rules of every
    edge of the model)."""
    found = sk.views.get(rule_id)
    if found is None:
        parts = rule_id.split("/")
        if is_every_cycle(rule_id):
            found = sk.every[int(parts[1]) - 1]
        else:
            found = sk.tables[parts[0]][parts[1]][int(parts[2]) - 1]
        sk.views[rule_id] = found
    return found


def _quiet(edge: Edge) -> bool:
    """A cycle the controller's table runs on its own: no new command from above, no
    process lost or back, no reset of the latches (no property may count on a recovery or
    on the operator)."""
    return edge.new is None and edge.lost is None and edge.recovered is None and not edge.reset


def _executing(graph: Graph) -> list[State]:
    return [s for s in graph.edges if s.status == EXECUTING and s.command is not None]


NEVER_MOTION = ("INIT", "HALT")  # the commands that never move anything


class Motion(dict[tuple[str, str], bool]):
    """(module, command) -> whether it is a motion command (INIT and HALT never are). A
    command it does not know is motion (the safe guess): `moving[sub, command]`."""

    def __missing__(self, key: tuple[str, str]) -> bool:
        return key[1] not in NEVER_MOTION

    def get(self, key: tuple[str, str], default: bool | None = True) -> bool:  # type: ignore[override]
        if key[1] in NEVER_MOTION:
            return False
        return bool(super().get(key, True if default is None else default))


def motion(sk_of: dict[str, Skeleton], idle: bool = True) -> Motion:
    """(module, command) -> whether it is a motion command: anything but INIT, HALT and a
    stopping command (one that sets actuators to their safe values only and sends only
    stopping commands, and does at least one of the two). With `idle` False, a command that
    does neither (a world model's bookkeeping) is not motion either, and one that sets a
    world output that is no actuator (a machine's command register) is: what is left moves
    something, itself or below."""
    memo: dict[tuple[str, str], bool] = {}

    def moving(module: str, command: str, depth: int = 0) -> bool:
        if command in NEVER_MOTION:
            return False
        key = (module, command)
        if key in memo:
            return memo[key]
        sk = sk_of.get(module)
        if sk is None or sk.operator or depth > 50:
            memo[key] = True
            return True
        memo[key] = True  # a cycle through itself is motion
        rules = [r for rules in sk.tables.get(command, {}).values() for r in rules]
        does = False
        moves = False
        for rule in rules:
            for _, safe in rule.actuators:
                does = True
                moves |= not safe
            if not idle:  # an output that is no actuator (a machine's command register)
                moves |= bool(rule.world_sets - {name for name, _ in rule.actuators})
            for sub, cmd in rule.sends:
                does = True
                moves |= moving(sub, cmd, depth + 1)
        memo[key] = moves or (idle and not does)
        return memo[key]

    for module, sk in sk_of.items():
        for command in sk.commands:
            moving(module, command)
    return Motion(memo)


# ---------------------------------------------------------------- outcomes (the contract)


def outcomes(graph: Graph) -> dict[str, tuple[str, ...]]:
    """Per command: the statuses the controller can end it with."""
    found: dict[str, set[str]] = {}
    for edges in graph.edges.values():
        for edge, t in edges:
            if t.command is None:
                continue
            if edge.report:
                found.setdefault(t.command, set()).add(edge.report)
            if edge.safe_state:
                found.setdefault(t.command, set()).add(ERROR)
    return {c: tuple(x for x in (DONE, ERROR) if x in v) for c, v in found.items()}


# ---------------------------------------------------------------- no motion after ERROR


def _motion(edge: Edge, moving: Motion) -> list[str]:
    """What a cycle did that is motion: `sub.COMMAND` sent, `world.field` set unsafe."""
    bad = [f"{sub}.{cmd}" for sub, cmd in edge.sends if moving[sub, cmd]]
    return bad + [f"world.{name}" for name in edge.unsafe]


def _culprit(sk: Skeleton, edge: Edge, bad: list[str]) -> str:
    """The rule of a cycle that did the first of `bad`."""
    for rule_id in edge.rules:
        view = rule_view(sk, rule_id)
        if any(f"{x}.{y}" in bad for x, y in view.sends):
            return rule_id
        if any(not safe for _, safe in view.actuators):
            return rule_id
    return edge.rules[-1]


def _failed(sk: Skeleton, trace: list[tuple[Edge, State]]) -> str:
    """The subordinate whose ERROR a run read first (answered, or its process lost)."""
    for edge, _ in trace:
        for sub, answer in edge.answers:
            if answer == ERROR:
                return sub
        for sub, view in zip(sk.subs, edge.views, strict=True):
            if view == ERROR:
                return sub
    return "a subordinate"


def _did(what: str) -> str:
    return f"sets {what}" if what.startswith("world.") else f"sends {what}"


def motion_after_error(graph: Graph, moving: Motion) -> list[Finding]:
    """Once a subordinate answered ERROR, nothing but a stopping command goes to any
    subordinate and no actuator is set to a value that may not be safe, until a new command
    arrives from above."""
    sk = graph.skeleton
    seen: set[tuple[str, str]] = set()
    findings = []
    for s, edges in graph.edges.items():
        for edge, t in edges:
            if not t.errored or edge.new is not None or edge.safe_state or not edge.rules:
                continue
            bad = _motion(edge, moving)
            if not bad:
                continue
            rule_id = _culprit(sk, edge, bad)
            if (rule_id, bad[0]) in seen:
                continue
            seen.add((rule_id, bad[0]))
            command, state, index, span = _rule_of(sk, rule_id)
            trace = graph.path_to(s) + [(edge, t)]
            failed = _failed(sk, trace)
            findings.append(
                Finding(
                    "W701",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"no motion after ERROR is violated: after {failed} reported ERROR, "
                    f"rule {rule_id} of {sk.name} still {_did(bad[0])}, "
                    f"{counted(len(trace), 'cycle')} into the command",
                    f"handle {failed}.status == ERROR in every state that waits on it "
                    "(send HALT or report ERROR)",
                    trace,
                    _certain(trace),
                )
            )
    return findings


# ---------------------------------------------------------------- latched stop


def latched_stop(graph: Graph, moving: Motion) -> list[Finding]:
    """After HALT from above, no motion command and no unsafe actuator value until a new
    command arrives."""
    sk = graph.skeleton
    findings, seen = [], set()
    for s, edges in graph.edges.items():
        for edge, t in edges:
            if not t.halted or not edge.rules:
                continue
            bad = _motion(edge, moving)
            if not bad or bad[0] in seen:
                continue
            seen.add(bad[0])
            rule_id = _culprit(sk, edge, bad)
            command, state, index, span = _rule_of(sk, rule_id)
            trace = graph.path_to(s) + [(edge, t)]
            findings.append(
                Finding(
                    "W706",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"latched stop is violated: after HALT, rule {rule_id} of {sk.name} "
                    f"{_did(bad[0])} before any new command",
                    "a HALT must stop everything below until the next command: guard the rule "
                    "with the command it belongs to",
                    trace,
                    _certain(trace),
                )
            )
    return findings


# ---------------------------------------------------------------- every command finishes


def _can_report(graph: Graph, states: list[State]) -> set[State]:
    """The states that can reach a report without a new command or a loss."""
    back: dict[State, list[State]] = {}
    good: set[State] = set()
    for s in states:
        for edge, t in graph.edges[s]:
            if (
                edge.new is not None
                or edge.lost is not None
                or edge.recovered is not None
                or edge.reset
            ):
                continue  # not `_quiet` (inline: every edge of the model is asked)
            if edge.report or edge.safe_state:
                good.add(s)
            elif t.status == EXECUTING:
                back.setdefault(t, []).append(s)
    todo = deque(good)
    while todo:
        t = todo.popleft()
        for s in back.get(t, []):
            if s not in good:
                good.add(s)
                todo.append(s)
    return good


def _views(sk: Skeleton, s: State) -> str:
    return ", ".join(
        f"{sub}.status={view}"
        for sub, (_, view, _) in zip(sk.subs, s.subs, strict=True)
        if view != "NOT_READY"
    )


def _stuck(graph: Graph, command: str, where: list[State]) -> Finding:
    """W702 (or W703 when it waits on a subordinate's ERROR) for a command's stuck states."""
    sk = graph.skeleton
    first = min(where, key=lambda s: len(graph.path_to(s)))
    trace = graph.path_to(first)
    span = sk.state_spans.get((command, first.state), sk.spans.get(command, Span("?")))
    waits = any(view in (DONE, ERROR) and sent is not None for sent, view, _ in first.subs)
    deadlock = waits and any(view == ERROR for _, view, _ in first.subs)
    shown = _views(sk, first)
    if deadlock:
        message = (
            f"no handshake deadlock is violated: {sk.name} {command} waits in "
            f"{first.state} for an answer its subordinates will not give ({shown})"
        )
    else:
        lost = f"; process {', '.join(first.lost)} lost" if first.lost else ""
        message = (
            f"every command finishes is violated: {sk.name} {command} can get to "
            f"{first.state} ({shown or 'no subordinate'}{lost}) and then never report DONE "
            "or ERROR without a new command"
        )
    return Finding(
        "W703" if deadlock else "W702",
        sk.name,
        command,
        first.state,
        None,
        span,
        f"{message}; {counted(len(where), 'state')} of the model never "
        + ("finishes" if len(where) == 1 else "finish"),
        "add a rule for that case (for a subordinate's ERROR: send HALT, report ERROR)",
        trace,
        _certain(trace),
    )


def finishing(
    graph: Graph, quiet: Callable[[State], frozenset[str]] | None = None
) -> tuple[list[Finding], dict[str, list[str]], int]:
    """A command can always still finish (report DONE or ERROR) without a new command,
    assuming its subordinates finish theirs; the world conditions it needs are named, and
    a wait on world fields only idle subordinates could change is a deadlock (W703).
    Returns the findings, per command its assumptions, and the number of stuck states."""
    states = _executing(graph)
    good = _can_report(graph, states)
    stuck = [s for s in states if s not in good]
    by_command: dict[str, list[State]] = {}
    for s in stuck:
        by_command.setdefault(s.command or "", []).append(s)
    findings = [_stuck(graph, command, where) for command, where in by_command.items()]
    assumptions: dict[str, list[str]] = {}
    for loop in _loops(graph, states, good):
        needs = assumptions.setdefault(loop.command, [])
        needs += sorted(
            x for x in {_exit_text(graph.skeleton, r) for r in loop.exits} if x and x not in needs
        )
        if quiet is not None:
            found = _world_deadlock(graph, loop, quiet)
            if found is not None and all(
                f.state != found.state for f in findings if f.code == "W703"
            ):
                findings.append(found)
    return findings, {c: n for c, n in assumptions.items() if n}, len(stuck)


@dataclass
class _Loop:
    """States a command can go round in for ever, and the rules that leave them."""

    command: str
    states: list[State]
    exits: set[str]  # rule ids


def _fair(sk: Skeleton, component: list[State], inner: list[tuple[State, Edge, State]]) -> bool:
    """Whether the model can stay in `component` for ever: no subordinate it waits on
    owes it an answer for ever (each is idle somewhere in it, or sent a command in it),
    and time in a timed state does not run out."""
    for i, name in enumerate(sk.subs):
        if all(s.subs[i][1] == EXECUTING for s in component) and not any(
            sub == name for _, e, _ in inner for sub, _ in e.sends
        ):
            return False
    if len({s.state for s in component}) == 1 and any(
        s.ticks < max(sk.timers.get((s.command or "", s.state), (0,))) for s in component
    ):
        return False  # time passes: the `after:` rule fires
    return True


def _loops(graph: Graph, states: list[State], good: set[State]) -> list[_Loop]:
    """The groups of states (strongly connected, fair) a command can go round in for ever
    without a new command, with the rules that leave each."""
    sk = graph.skeleton
    succ = {
        s: [
            (e, t)
            for e, t in graph.edges[s]
            if e.new is None  # `_quiet`, inline: every edge of the model is asked
            and e.lost is None
            and e.recovered is None
            and not e.reset
            and t.status == EXECUTING
            and t in good
        ]
        for s in states
        if s in good
    }
    found = []
    for component in _sccs(succ):
        members = set(component)
        inner = [(s, e, t) for s in component for e, t in succ[s] if t in members]
        if not inner or not _fair(sk, component, inner):
            continue
        exits = {
            rule_id
            for s in component
            for e, t in graph.edges[s]
            if _quiet(e) and (t not in members or e.report)
            for rule_id in e.rules
        }
        found.append(_Loop(component[0].command or "", component, exits))
    return found


# what a guard reads that changes without the world: time, counters, hooks' results, locals
# (a `let` value is never read as such: reads_of inlines it, so its own reads count)
_CHANGING = frozenset({RefKind.TIME, RefKind.HELD, RefKind.LOCAL, RefKind.SUB_RESULT, RefKind.PLAN})


def _exit_text(sk: Skeleton, rule_id: str) -> str:
    """An exit rule's guard as a world condition (`in S2: `world.x``), or '' when it reads
    no world field, local or hook result (only statuses and commands)."""
    rule = rule_view(sk, rule_id)
    reads = rule.guard.order if rule.guard is not None else {}
    if not rule.text or all(k[0] in ("status", "command") for k in reads):
        return ""
    _, state, _, _ = _rule_of(sk, rule_id)
    return f"{f'in {state}' if state else 'every cycle'}: `{rule.text}`"


def _world_deadlock(
    graph: Graph, loop: _Loop, quiet: Callable[[State], frozenset[str]]
) -> Finding | None:
    """W703 when every rule that leaves the loop waits on world fields that cannot change
    there: only subordinates write them, and none is running a command that does."""
    sk = graph.skeleton
    waited: set[str] = set()
    for rule_id in loop.exits:
        rule = rule_view(sk, rule_id)
        world = {name for kind, name in rule.reads if kind == RefKind.WORLD}
        if not world or any(kind in _CHANGING for kind, _ in rule.reads):
            return None
        for s in loop.states:
            if not world <= quiet(s):
                return None
        waited |= world
    if not waited:
        return None
    first = min(loop.states, key=lambda s: len(graph.path_to(s)))
    trace = graph.path_to(first)
    fields = ", ".join(f"world.{n}" for n in sorted(waited))
    return Finding(
        "W703",
        sk.name,
        loop.command,
        first.state,
        None,
        sk.state_spans.get((loop.command, first.state), sk.spans.get(loop.command, Span("?"))),
        f"no handshake deadlock is violated: {sk.name} {loop.command} waits in {first.state} "
        f"for {fields}, which only its subordinates write, and none of them is running a "
        f"command that writes it ({_views(sk, first) or 'no subordinate commanded'})",
        "send the command that makes the condition true before waiting on it, or report "
        "ERROR when it is not",
        trace,
        _certain(trace),
    )


def _sccs(succ: dict[State, list[tuple[Edge, State]]]) -> list[list[State]]:
    """Tarjan's strongly connected components, iteratively."""
    index: dict[State, int] = {}
    low: dict[State, int] = {}
    on: set[State] = set()
    stack: list[State] = []
    out: list[list[State]] = []
    counter = 0
    for root in succ:
        if root in index:
            continue
        work = [(root, iter(succ[root]))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            advanced = False
            for _, w in it:
                if w not in succ:
                    continue
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(succ[w])))
                    advanced = True
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    component.append(w)
                    if w == v:
                        break
                out.append(component)
    return out


# ---------------------------------------------------------------- bounds


def _worst(
    graph: Graph,
    starts: list[tuple[State, Edge, State]],
    goal: Callable[[Edge], bool],
    stop: Callable[[Edge], bool],
) -> tuple[int, list[tuple[Edge, State]]]:
    """The most cycles from a start edge (cycle 1) until an edge satisfies `goal`, along
    edges without a new command or a loss; `stop(edge)` ends a path without the goal
    (INFINITE). INFINITE too when the model can go round without it. Returns the bound and
    a run that shows the worst (or the failure)."""
    memo: dict[State, int] = {}
    on_path: set[State] = set()
    witness: dict[State, tuple[Edge, State] | None] = {}

    # A depth-first walk without recursion: a path can be as long as a wait (`after: 6000
    # cycles` is 6000 states), deeper than Python's stack. Each state's walk is a generator
    # that yields the next state whose bound it needs; `bound` runs them on a stack of its own.
    def cost(edge: Edge, t: State) -> Generator[State, int, int]:
        if goal(edge):
            return 1
        if stop(edge) or t.status != EXECUTING:
            return INFINITE
        inner = memo[t] if t in memo else INFINITE if t in on_path else (yield t)
        return INFINITE if inner == INFINITE else inner + 1

    def worst(s: State) -> Generator[State, int, int]:
        on_path.add(s)
        best, chosen = 0, None
        for edge, t in graph.edges.get(s, []):
            if not _quiet(edge):
                continue
            if t == s and any(v == EXECUTING and f for _, v, f in s.subs):
                continue  # waiting for a subordinate's answer: its time, not this table's
            c = yield from cost(edge, t)
            if c > best or chosen is None:
                best, chosen = c, (edge, t)
            if best == INFINITE:
                break
        on_path.discard(s)
        memo[s] = best if chosen is not None else INFINITE
        witness[s] = chosen
        return memo[s]

    def bound(edge: Edge, t: State) -> int:
        walks = [cost(edge, t)]
        value: int | None = None
        while True:
            try:
                wanted = next(walks[-1]) if value is None else walks[-1].send(value)
            except StopIteration as done:
                walks.pop()
                if not walks:
                    return int(done.value)
                value = done.value
                continue
            walks.append(worst(wanted))
            value = None

    result, run = 0, list[tuple[Edge, State]]()
    for source, edge, t in starts:
        c = bound(edge, t)
        if c > result or not run:
            result, run = c, [*graph.path_to(source), (edge, t)]
        if result == INFINITE:
            break
    if run:
        at, passed = run[-1][1], {t for _, t in run}
        while not goal(run[-1][0]) and at in witness and witness[at] is not None:
            step = witness[at]
            assert step is not None
            run.append(step)
            if step[1] in passed:
                break
            at = step[1]
            passed.add(at)
    return result, run


def halt_latency(graph: Graph) -> dict[str, tuple[int, list[tuple[Edge, State]]]]:
    """Per subordinate: the most cycles from the controller reading HALT (cycle 1) until it
    sends that subordinate HALT, over every state it can be in when HALT comes."""
    starts = [(s, e, t) for s in graph.edges for e, t in graph.edges[s] if e.new == "HALT"]
    return {sub: _worst(graph, starts, _sends(sub, "HALT"), _never) for sub in graph.skeleton.subs}


def _never(edge: Edge) -> bool:
    return False


def _sends(sub: str, command: str) -> Callable[[Edge], bool]:
    def goal(edge: Edge) -> bool:
        return (sub, command) in edge.sends

    return goal


def _sets_safe(name: str) -> Callable[[Edge], bool]:
    def goal(edge: Edge) -> bool:
        return name in edge.safe

    return goal


def actuators_safe(graph: Graph) -> dict[str, tuple[int, list[tuple[Edge, State]]]]:
    """Per actuator field the controller writes: the most cycles from reading HALT until it
    sets the field to its safe value."""
    starts = [(s, e, t) for s in graph.edges for e, t in graph.edges[s] if e.new == "HALT"]
    return {
        name: _worst(graph, starts, _sets_safe(name), _never) for name in graph.skeleton.actuators
    }


def error_latency(graph: Graph) -> dict[str, tuple[int, list[tuple[Edge, State]]]]:
    """Per subordinate: the most cycles from the controller reading its ERROR (cycle 1)
    until it reports ERROR itself; INFINITE when it may not (it handles the ERROR, or
    waits)."""
    found = {}
    for sub in graph.skeleton.subs:
        starts = _error_starts(graph, sub)
        if starts:
            found[sub] = _worst(graph, starts, _reports_error, _reports_done)
    return found


def _error_starts(graph: Graph, sub: str) -> list[tuple[State, Edge, State]]:
    """The cycles in which the controller reads `sub`'s ERROR to a command it sent (found
    for every subordinate in one pass over the model, once: two checks ask for each)."""
    found = graph.derived.get("error_starts")
    if found is None:
        found = graph.derived["error_starts"] = _all_error_starts(graph)
    return list(found[sub])


def _all_error_starts(graph: Graph) -> dict[str, list[tuple[State, Edge, State]]]:
    sk = graph.skeleton
    index = {sub: i for i, sub in enumerate(sk.subs)}
    found: dict[str, list[tuple[State, Edge, State]]] = {sub: [] for sub in sk.subs}
    for s, edges in graph.edges.items():
        if s.status != EXECUTING or s.command in sk.generated:
            continue  # QQ1's INIT/HALT wait for all DONE
        for e, t in edges:
            if not e.answers or not _quiet(e):
                continue
            for sub in {sub for sub, answer in e.answers if answer == ERROR}:
                if s.subs[index[sub]][2]:
                    found[sub].append((s, e, t))
    return found


def _reports_error(edge: Edge) -> bool:
    return edge.report == ERROR or edge.safe_state


def _reports_done(edge: Edge) -> bool:
    return edge.report == DONE


def swallowed(graph: Graph, sub: str) -> list[tuple[str | None, str, list[tuple[Edge, State]]]]:
    """Per state of a command in which `sub`'s ERROR may come and never make the
    controller report ERROR: (command, state, a run that shows it) - one W705 each, so a
    second state that swallows it is not hidden behind the first."""
    groups: dict[tuple[str | None, str], list[tuple[State, Edge, State]]] = {}
    for start in _error_starts(graph, sub):
        groups.setdefault((start[0].command, start[0].state), []).append(start)
    found = []
    for (command, state), starts in sorted(
        groups.items(), key=lambda kv: (kv[0][0] or "", kv[0][1])
    ):
        cycles, run = _worst(graph, starts, _reports_error, _reports_done)
        if cycles == INFINITE:
            found.append((command, state, run))
    return found


def done_while_busy(graph: Graph, moving: Motion) -> list[Finding]:
    """A command reports DONE only once every motion command it sent has been answered:
    the supervisor waited for the echo (W708)."""
    sk = graph.skeleton
    findings, seen = [], set()
    for s, edges in graph.edges.items():
        if s.status != EXECUTING or s.command is None:
            continue
        for edge, t in edges:
            if edge.report != DONE or edge.new is not None or not edge.rules:
                continue
            reads = rule_view(sk, edge.rules[-1]).reads
            busy = [
                f"{sub}.{sent}"
                for sub, (sent, view, fresh) in zip(sk.subs, s.subs, strict=True)
                if edge.views[sk.subs.index(sub)] == EXECUTING
                and sent is not None
                and (moving[sub, sent] or ("sub_status", sub) in reads)
                and fresh
                and (sub, sent) not in edge.sends
            ]
            if not busy or edge.rules[-1] in seen:
                continue
            seen.add(edge.rules[-1])
            command, state, index, span = _rule_of(sk, edge.rules[-1])
            trace = graph.path_to(s) + [(edge, t)]
            findings.append(
                Finding(
                    "W708",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"the handshake is violated: rule {edge.rules[-1]} of {sk.name} reports "
                    f"DONE while {busy[0]} it sent is still executing (its echo with DONE or "
                    "ERROR not seen)",
                    f"wait for `{busy[0].split('.')[0]}.status == DONE` before reporting DONE",
                    trace,
                    _certain(trace),
                )
            )
    return findings


__all__ = ["INFINITE", "NOP", "Finding"]


def _stale(sk: Skeleton, s: State, edge: Edge, moving: Motion) -> str:
    """The subordinate whose stale DONE a rule went on on, when that is a slip: every DONE
    it read was stale (it waited for nothing new), or a stale one answers a motion command
    (a new motion was meant; a stale DONE of HALT or INIT only says it is stopped)."""
    if not edge.stale or edge.new is not None or not edge.rules:
        return ""
    stale = [sub for sub in edge.stale if sub]
    if "" not in edge.stale:
        return stale[0]
    for sub in stale:
        sent = s.subs[sk.subs.index(sub)][0]
        if sent is not None and moving[sub, sent]:
            return sub
    return ""


def stale_done(graph: Graph, moving: Motion) -> list[Finding]:
    """A table rule goes on on a subordinate's DONE only once per command sent: a DONE an
    earlier rule of this command already went on on, or one that answers a command sent
    before this command began, is stale (W707) - the wait did not wait (a send left out)."""
    sk = graph.skeleton
    findings, seen = [], set()
    for s, edges in graph.edges.items():
        for edge, t in edges:
            sub = _stale(sk, s, edge, moving)
            if not sub:
                continue
            rule_id = edge.rules[-1]
            if rule_id in seen:
                continue
            seen.add(rule_id)
            command, state, index, span = _rule_of(sk, rule_id)
            sent = s.subs[sk.subs.index(sub)][0]
            trace = graph.path_to(s) + [(edge, t)]
            findings.append(
                Finding(
                    "W707",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"a stale DONE is believed: rule {rule_id} of {sk.name} goes on on "
                    f"{sub}.status == DONE, the answer to {sub}.{sent} it already went on on "
                    "(or sent before this command began): nothing new was sent to wait for",
                    f"send {sub} its command before waiting for `{sub}.status == DONE`",
                    trace,
                    _certain(trace),
                )
            )
    return findings


def _going_on(sk: Skeleton, s: State, edge: Edge, moving: Motion) -> list[str]:
    """The motion commands a table rule that fired leaves running although its guard reads
    their subordinate's status: it went on before the echo (not to report ERROR, not on
    another subordinate's ERROR, not re-commanding it)."""
    if edge.new is not None or not edge.rules or is_every_cycle(edge.rules[-1]):
        return []
    views = edge.views
    running = [
        (sub, sent)
        for i, (sub, (sent, _, fresh)) in enumerate(zip(sk.subs, s.subs, strict=True))
        if views[i] == EXECUTING and sent is not None and fresh
    ]
    if not running:  # the common case, decided without the rule
        return []
    failing = edge.report == ERROR or ERROR in views
    rule = rule_view(sk, edge.rules[-1])
    moves = any(moving[send] for send in edge.sends)
    return [
        f"{sub}.{sent}"
        for sub, sent in running
        if ("sub_status", sub) in rule.reads
        and _early(sub, sent, [c for x, c in edge.sends if x == sub], failing, moving, moves)
    ]


def _early(
    sub: str,
    sent: str,
    resent: list[str],
    failing: bool,
    moving: Motion,
    moves: bool,
) -> bool:
    """Whether going on while `sub` still runs `sent` (the rule read its status) is too
    early. A stopping command's echo is awaited even on the way to an ERROR: it says
    everything below has stopped, and a rule that reads the status waits for exactly that.
    Replacing the running command by a stopping one is right when the rule only stops
    things (a preemption); by a motion command, or with motion sent anywhere (`moves`), on
    a status read, it is the next step taken before the echo of the last."""
    if failing:
        return not resent and not moving[sub, sent]
    return not resent or moves


def no_echo(graph: Graph, moving: Motion) -> list[Finding]:
    """A rule that reads a subordinate's status goes on (to another state) only once the
    subordinate has answered the motion command it runs: it waited for the echo (W708)."""
    sk = graph.skeleton
    findings, seen = [], set()
    for s, edges in graph.edges.items():
        if s.status != EXECUTING or s.command is None:
            continue
        if not any(sent is not None and fresh for sent, _, fresh in s.subs):
            continue  # nothing sent during this command: no edge of it goes on early
        for edge, t in edges:
            if edge.report == DONE or (edge.rules and edge.rules[-1] in seen):
                continue  # a DONE report is done_while_busy's
            busy = _going_on(sk, s, edge, moving)
            if not busy:
                continue
            seen.add(edge.rules[-1])
            command, state, index, span = _rule_of(sk, edge.rules[-1])
            trace = graph.path_to(s) + [(edge, t)]
            findings.append(
                Finding(
                    "W708",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"the handshake is violated: rule {edge.rules[-1]} of {sk.name} reads "
                    f"{busy[0].split('.')[0]}.status and goes on while {busy[0]} is still "
                    "executing (its echo with DONE or ERROR not seen)",
                    f"wait for `{busy[0].split('.')[0]}.status == DONE` before going on",
                    trace,
                    _certain(trace),
                )
            )
    return findings


# ---------------------------------------------------------------- withdrawn after ERROR


def _running(
    sk: Skeleton,
    s: State,
    moving: Motion,
    loose: frozenset[tuple[str, str]] = frozenset(),
) -> frozenset[str]:
    """The subordinates running a motion command sent during the current command, or that
    ended one with an ERROR that may leave something below them moving (`loose`: their
    own proven contract)."""
    return frozenset(
        sub
        for sub, (sent, view, fresh) in zip(sk.subs, s.subs, strict=True)
        if fresh
        and sent is not None
        and ((view == EXECUTING and moving[sub, sent]) or (view == ERROR and (sub, sent) in loose))
    )


def loose_errors(graph: Graph, moving: Motion, loose: frozenset[tuple[str, str]]) -> set[str]:
    """The commands the controller may end with ERROR while a subordinate still runs a
    motion command of it, or ended one with a loose ERROR and was not sent anything since:
    part of its contract - a supervisor must then withdraw it (HALT) after its ERROR."""
    found = set()
    for edges in graph.edges.values():
        for edge, t in edges:
            if edge.report == ERROR and t.command and not edge.safe_state:
                if _running(graph.skeleton, t, moving, loose):
                    found.add(t.command)
    return found


def not_withdrawn(
    graph: Graph,
    moving: Motion,
    loose: frozenset[tuple[str, str]] = frozenset(),
) -> list[Finding]:
    """After a subordinate's ERROR, every other subordinate still running a motion command
    of this command is withdrawn (sent HALT, or another command) before the controller
    reports ERROR: an error stops the machine, it does not let the rest of the command run
    out (W701, at the rule that read the ERROR); the subordinate that erred too, when its
    ERROR may leave something below it moving. A command that handles the ERROR and
    reports DONE is not concerned, nor the runtime's safe state (it halts everything)."""
    sk = graph.skeleton
    findings: list[Finding] = []
    seen: set[str] = set()
    for s, edges in graph.edges.items():
        if s.errored or s.status != EXECUTING or s.command is None:
            continue
        for edge, t in edges:
            if not t.errored or not _quiet(edge) or edge.safe_state or not edge.rules:
                continue
            pending = _running(sk, t, moving, loose) - {sub for sub, _ in edge.sends}
            if not pending or edge.rules[-1] in seen:
                continue
            run = _left_running(graph, t, pending, edge.report)
            if run is None:
                continue
            seen.add(edge.rules[-1])
            left, tail = run
            command, state, index, span = _rule_of(sk, edge.rules[-1])
            trace = [*graph.path_to(s), (edge, t), *tail]
            failed = _failed(sk, trace)
            sent = t.subs[sk.subs.index(left)][0]
            findings.append(
                Finding(
                    "W701",
                    sk.name,
                    command,
                    state,
                    index,
                    span,
                    f"no motion after ERROR is violated: after {failed} reported ERROR, "
                    f"{sk.name} reports ERROR without withdrawing {left}.{sent}, which goes on "
                    f"running (rule {edge.rules[-1]} read the ERROR)",
                    f"send `{left}.HALT` where {failed}'s ERROR is read",
                    trace,
                    _certain(trace),
                )
            )
    return findings


_Pending = tuple[State, frozenset[str]]  # a state, and the subordinates not yet withdrawn


def _left_running(
    graph: Graph, start: State, pending: frozenset[str], report: str | None
) -> tuple[str, list[tuple[Edge, State]]] | None:
    """A run from `start` (subordinates `pending` still running motion) to an ERROR report
    with one of them never sent anything since: (that subordinate, the run), else None."""
    if report == ERROR:
        return sorted(pending)[0], []
    if report is not None:
        return None
    parent: dict[_Pending, tuple[_Pending, Edge] | None] = {(start, pending): None}
    todo = deque([(start, pending)])
    while todo:
        at = todo.popleft()
        s, left = at
        for edge, t in graph.edges.get(s, []):
            if not _quiet(edge) or edge.safe_state:
                continue
            still = left - {sub for sub, _ in edge.sends}
            if not still:
                continue
            if edge.report == ERROR:
                run = [(edge, t)]
                back = parent[at]
                here = s
                while back is not None:
                    (prev, _), prev_edge = back
                    run.append((prev_edge, here))
                    here = prev
                    back = parent[back[0]]
                return sorted(still)[0], list(reversed(run))
            if edge.report is not None or t.status != EXECUTING:
                continue
            key = (t, still)
            if key not in parent:
                parent[key] = (at, edge)
                todo.append(key)
    return None
