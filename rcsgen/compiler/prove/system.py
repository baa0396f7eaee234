"""System: every controller of a system proven compositionally, bounds added up.

Controllers are taken bottom-up (subordinates first). Each is explored over its
subordinates' contracts - the statuses each can end each command with, read from its own
explored model (so the cost grows with the widest controller, not the system) - and its
properties checked (`properties.py`). Then the per-controller bounds are composed along the
hierarchy with the execution order and the process split: HALT given to a controller reaches
each leaf below it within k cycles, and an ERROR of a leaf reaches the root within d.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from .. import ir
from ..collector import no_collections
from . import numbers, timers, user
from . import properties as props
from .adapter import DONE, ERROR, Skeleton, operator_outcomes, placement, skeleton
from .handshake import EXTRA, z3_or_none
from .lost import RuntimeReaction
from .model import LIMIT, Contract, Edge, Graph, Model, State, explore
from .properties import INFINITE, Finding
from .world import quiet_fields, writers


@dataclass
class ControllerResult:
    name: str
    states: int
    transitions: int
    seconds: float  # wall clock
    complete: bool
    stuck: int = 0
    assumptions: dict[str, list[str]] = field(default_factory=dict)
    halt: dict[str, int] = field(default_factory=dict)  # sub -> cycle it gets HALT (1-based)
    safe: dict[str, int] = field(default_factory=dict)  # actuator -> cycle it is safe
    error: dict[str, int] = field(default_factory=dict)  # sub -> cycle ERROR is reported
    cpu: float = 0.0  # CPU seconds of this process (the wall clock counts the others' load)


@dataclass
class Bound:
    """A composed bound from one controller to a leaf below it (or from a leaf up)."""

    start: str
    leaf: str
    cycles: int  # INFINITE: not reached
    path: tuple[str, ...]
    safe: int | None = None  # the cycle the leaf's actuators are safe (HALT), if it has any
    blocked: str = ""  # where it stops, when not reached


@dataclass
class SystemProof:
    system: str
    findings: list[Finding] = field(default_factory=list)
    controllers: dict[str, ControllerResult] = field(default_factory=dict)
    halt: list[Bound] = field(default_factory=list)
    error: list[Bound] = field(default_factory=list)
    reaction: str = ""
    notes: list[str] = field(default_factory=list)
    graphs: dict[str, Graph] = field(default_factory=dict)
    # (module, command): it may end that command with ERROR while something below it still
    # moves (its contract; a supervisor must withdraw it after that ERROR)
    loose: set[tuple[str, str]] = field(default_factory=set)
    # the engineer's own properties checked, each with whether it holds in every run (None:
    # undecided, the model with its monitor too large)
    properties: list[tuple[ir.IRProperty, bool | None]] = field(default_factory=list)


def order(system: ir.IRSystem) -> list[ir.IRController]:
    """The controllers with tables, subordinates before their supervisors."""
    children = {c.name: [s.name for s in c.subordinates] for c in system.controllers}
    seen: set[str] = set()
    out: list[ir.IRController] = []

    def visit(name: str) -> None:
        if name in seen:
            return
        seen.add(name)
        for child in children.get(name, []):
            visit(child)
        out.append(system.controller(name))

    for c in system.controllers:
        visit(c.name)
    return out


def hop(place: dict[str, tuple[str, int]], sender: str, reader: str, hosts: dict[str, str]) -> int:
    """Cycles a value written by `sender` in a cycle takes to be read by `reader`: 0 when the
    reader runs after it in the same process, 1 when before it or in another process (its
    next cycle), one more per host crossed where a deployment is given."""
    if sender not in place or reader not in place:
        return 1
    (p1, a), (p2, b) = place[sender], place[reader]
    if p1 == p2:
        return 0 if b > a else 1
    extra = 1 if hosts and hosts.get(p1) != hosts.get(p2) else 0
    return 1 + extra


def prove(
    system: ir.IRSystem,
    hosts: dict[str, str] | None = None,
    limit: int = LIMIT,
    only: str | None = None,
) -> SystemProof:
    """Explore every controller of `system` and check its properties (`only`: the
    controller named and the ones below it, whose contracts it needs)."""
    with no_collections():
        return _prove(system, hosts or {}, limit, only)


def _prove(system: ir.IRSystem, hosts: dict[str, str], limit: int, only: str | None) -> SystemProof:
    """`prove`, with the collector off."""
    wanted = _below(system, only) if only else None
    place = placement(system)
    reaction = RuntimeReaction(system)
    proof = SystemProof(system.name, reaction=reaction.name)
    actuators = frozenset(f.name for f in system.world if f.actuator)
    skeletons = {c.name: skeleton(system, c, actuators) for c in system.controllers}
    moving = props.motion(skeletons)
    actuating = props.motion(skeletons, idle=False)
    written = writers(system, skeletons)
    contracts: dict[str, Contract] = {}
    loose = proof.loose
    for c in order(system):
        if wanted is not None and c.name not in wanted:
            continue
        sk = skeletons[c.name]
        if c.is_operator:
            contracts[c.name] = Contract(operator_outcomes(c))
            continue
        began, began_cpu = time.perf_counter(), time.process_time()
        graph = explore(Model(sk, _contracts_of(system, c, contracts), reaction), limit=limit)
        result = ControllerResult(
            c.name,
            len(graph.parent),
            sum(len(v) for v in graph.edges.values()),
            0.0,
            graph.complete,
        )
        contracts[c.name] = Contract(props.outcomes(graph))
        for cmd in props.loose_errors(graph, actuating, frozenset(loose)):
            loose |= {(c.name, cmd), (c.buffers, cmd)}
        if not graph.complete:
            proof.notes.append(f"{c.name}: more than {limit} states; its properties are undecided")
        else:
            quiet = quiet_fields(system, written, c.name)
            for finding in _check(graph, moving, actuating, frozenset(loose), quiet, result):
                # rcsgen's default INIT/HALT wait for every subordinate's DONE (QQ1): a
                # subordinate's ERROR leaves them waiting by design
                if finding.command in sk.generated and finding.code in ("W702", "W703"):
                    continue
                proof.findings.append(finding)
            for prop in system.properties:
                if prop.controller == c.name:
                    _user(proof, graph, prop, system, limit)
        result.seconds = time.perf_counter() - began
        result.cpu = time.process_time() - began_cpu
        proof.controllers[c.name] = result
        proof.graphs[c.name] = graph
    _compose(system, proof, place, hosts)
    proof.findings += _late_order(system, skeletons, place)
    _hold_times(proof)
    return proof


def _user(
    proof: SystemProof, graph: Graph, prop: ir.IRProperty, system: ir.IRSystem, limit: int
) -> None:
    """One of the spec's own properties checked on the explored model (W709), or a note
    when the model with its monitor is too large to decide it."""
    try:
        found = user.check(graph, prop, system, limit)
    except user.TooLarge:
        proof.notes.append(f"property {prop.name}: more than {limit} states with its monitor")
        proof.properties.append((prop, None))
        return
    proof.findings += [found] if found else []
    proof.properties.append((prop, found is None))


def _hold_times(proof: SystemProof) -> None:
    """Each finding whose run cannot happen - a `for:` rule fired before its `when` can
    have held long enough (`timers.py`), or guards over locals, parameters and world values
    no values make true together (`numbers.py`) - is looked for again, longer; when no
    possible run is found it is undecided, with why (z3). Without z3, one note says so."""
    missing = ""
    for f in proof.findings:
        graph = proof.graphs.get(f.controller)
        if graph is None or not f.trace:
            continue
        why = _impossible(graph, f)
        if why is None:
            missing = f"counter-examples' hold times (`for:`) and numbers need z3: install {EXTRA}"
        elif why:
            f.certain, f.verdict, f.replay = False, "undecided", why
    if missing:
        proof.notes.append(missing)


# The properties whose violation is the last cycle of a run from a state that holds all it
# needs (flags of the state, not of the path): another run to that cycle shows it as well.
# Not the others: W704 and W705 are a bound's worst run (its length is the finding) or the
# execution order (no run); W709, a spec's own property, may read what the path did - an
# obligation opened cycles before (`whenever ... within`), an actuator left unsafe (`safe()`)
# - and even a property of one cycle reads what its every_cycle rules wrote (`writes()`),
# in which the cycles `numbers.search` takes as alike may differ: the run it finds need not
# break the property.
SEARCHED = frozenset({"W701", "W702", "W703", "W706", "W707", "W708"})


def _impossible(graph: Graph, f: Finding) -> str | None:
    """'' when the finding's run is possible (or one found for it instead, put in its
    place); why not when no possible run was found; None without z3 where it was needed."""
    sk = graph.skeleton
    held, why = timers.feasible(sk, f.trace)
    if held is None:
        return None
    counted = numbers.numeric(sk, f.trace)
    if held and not counted:
        return ""
    z3 = z3_or_none()
    if z3 is None:
        return None
    found = numbers.witness(z3, graph, f.trace) if held else None
    if found is not None:  # possible: the run with one solution's parameters, to replay
        f.trace = found
        return ""
    if held:
        why = "impossible with the values its guards read (z3: locals, parameters, world values)"
    if f.code in SEARCHED and _shortest_form(graph, f.trace):
        other = numbers.search(
            z3, graph, f.trace, lambda run: timers.feasible(sk, run)[0] is not False
        )
        if other is not None:  # possible by construction: its parameters, to replay
            f.trace, f.certain = numbers.witness(z3, graph, other) or other, props._certain(other)
            return ""
        longest = len(f.trace) - 1 + numbers.EXTRA_CYCLES
        why += f"; no possible run to that cycle up to {longest} cycles"
    return why


def _shortest_form(graph: Graph, trace: list[tuple[Edge, State]]) -> bool:
    """Whether the run is the model's shortest one to its last cycle's start, then that
    cycle (so the finding is about that cycle, whatever the path to it)."""
    start = trace[-2][1] if len(trace) > 1 else graph.initial
    return graph.path_to(start) == trace[:-1]


def _below(system: ir.IRSystem, top: str) -> set[str]:
    """`top` and every controller below it (stand-ins included)."""
    children = {c.name: [s.name for s in c.subordinates] for c in system.controllers}
    stand_in = {c.buffers: c.name for c in system.controllers if c.buffers != c.name}
    found: set[str] = set()
    todo = [top]
    while todo:
        at = todo.pop()
        if at in found:
            continue
        found.add(at)
        todo += children.get(at, [])
        if at in stand_in:
            todo.append(stand_in[at])
    return found


def _late_order(
    system: ir.IRSystem, skeletons: dict[str, Skeleton], place: dict[str, tuple[str, int]]
) -> list[Finding]:
    """HALT reach as fast as the process split allows: within one process a supervisor
    runs before its subordinates (command-first, docs/semantics.md section 9), so they read
    its HALT in the cycle it sends it. A subordinate placed before it reads the HALT a cycle
    later, and so does every leaf below it: W704 of the supervisor, located where the
    process lists the subordinate (the order to change)."""
    found = []
    listed = {p.name: p.module_spans for p in system.processes}
    for c in system.controllers:
        if c.is_operator or c.name not in place:
            continue
        process, at = place[c.name]
        for s in c.subordinates:
            if s.name not in place or place[s.name] >= (process, at):
                continue
            if place[s.name][0] != process:
                continue
            sk = skeletons[c.name]
            found.append(
                Finding(
                    "W704",
                    c.name,
                    "HALT",
                    None,
                    None,
                    listed[process].get(s.name)
                    or sk.spans.get("HALT", next(iter(sk.spans.values()))),
                    f"HALT reach is violated: {s.name} runs before its supervisor {c.name} in "
                    f"process {process}'s order (system.yaml), so it reads {c.name}'s HALT a "
                    "cycle later than the process split allows, and so does every leaf below it",
                    f"list {c.name} before {s.name} in `processes: {process}: modules:` "
                    "(command-first)",
                )
            )
    return found


def _contracts_of(
    system: ir.IRSystem, c: ir.IRController, contracts: dict[str, Contract]
) -> dict[str, Contract]:
    """What each subordinate of `c` promises: the statuses its own model (and its
    stand-in's, which may run in its place) can end each command with; ERROR too where an
    echo is awaited only so long (`echo_cycles`)."""
    stand_in = {x.buffers: x.name for x in system.controllers if x.buffers != x.name}
    subs = {}
    for s in c.subordinates:
        merged: dict[str, set[str]] = {}
        for name in dict.fromkeys((s.name, stand_in.get(s.name, s.name))):
            for cmd, ends in contracts.get(name, Contract({})).outcomes.items():
                merged.setdefault(cmd, set()).update(ends)
        if s.echo_cycles:  # no echo in time reads as ERROR
            for either in merged.values():
                either.add(ERROR)
        subs[s.name] = Contract(
            {cmd: tuple(x for x in (DONE, ERROR) if x in either) for cmd, either in merged.items()}
        )
    return subs


def _check(
    graph: Graph,
    moving: props.Motion,
    actuating: props.Motion,
    loose: frozenset[tuple[str, str]],
    quiet: Callable[[State], frozenset[str]],
    result: ControllerResult,
) -> list[Finding]:
    """Every property of one explored controller; its bounds into `result`."""
    sk = graph.skeleton
    found = props.motion_after_error(graph, moving)
    found += props.not_withdrawn(graph, actuating, loose)
    found += props.latched_stop(graph, moving)
    finish, result.assumptions, result.stuck = props.finishing(graph, quiet)
    found += finish
    found += props.done_while_busy(graph, moving)
    found += props.no_echo(graph, moving)
    found += props.stale_done(graph, moving)
    for sub, (cycles, run) in props.halt_latency(graph).items():
        result.halt[sub] = cycles
        if cycles == INFINITE:
            found.append(_unbounded_halt(sk, sub, run))
    for field_name, (cycles, run) in props.actuators_safe(graph).items():
        result.safe[field_name] = cycles
        if cycles == INFINITE:
            found.append(_unsafe_halt(sk, field_name, run))
    for sub, (cycles, _) in props.error_latency(graph).items():
        result.error[sub] = cycles
        if cycles == INFINITE:
            where: dict[tuple[str | None, str | None], Finding] = {}
            for command, state, one in props.swallowed(graph, sub):
                where.setdefault((command, state), _error_swallowed(sk, sub, one, command, state))
            found += where.values()
    return found


Run = list[tuple[Edge, State]]


def _unbounded_halt(sk: Skeleton, sub: str, run: Run) -> Finding:
    return Finding(
        "W704",
        sk.name,
        "HALT",
        None,
        None,
        sk.spans.get("HALT", next(iter(sk.spans.values()))),
        f"HALT reach is violated: HALT given to {sk.name} may never reach {sub} "
        "(its HALT table does not send it HALT within any bound)",
        f"send `{sub}.HALT` in S0 of {sk.name}'s HALT table (or use the default table)",
        run,
        props._certain(run),
    )


def _unsafe_halt(sk: Skeleton, name: str, run: Run) -> Finding:
    span = sk.spans.get("HALT", next(iter(sk.spans.values())))
    return Finding(
        "W704",
        sk.name,
        "HALT",
        None,
        None,
        span,
        f"HALT reach is violated: HALT given to {sk.name} never sets actuator world.{name} "
        "to its safe value",
        f"declare HALT on {sk.name} and set world.{name} to its safe value in its S0",
        run,
        props._certain(run),
    )


def _error_swallowed(sk: Skeleton, sub: str, run: Run, command: str | None, state: str) -> Finding:
    """W705 at the state of `command` in which `sub`'s ERROR comes and is swallowed."""
    span = sk.state_spans.get((command or "", state)) or sk.spans.get(
        command or "", next(iter(sk.spans.values()))
    )
    return Finding(
        "W705",
        sk.name,
        command,
        state,
        None,
        span,
        f"ERROR reaches the root is violated: an ERROR from {sub} may never make {sk.name} "
        "report ERROR (it is handled, or waited on for ever)",
        f"report ERROR (after HALT where needed) when {sub}.status == ERROR",
        run,
        props._certain(run),
    )


def _compose(
    system: ir.IRSystem,
    proof: SystemProof,
    place: dict[str, tuple[str, int]],
    hosts: dict[str, str],
) -> None:
    """HALT k from each root to each leaf below it; ERROR d from each leaf to its root."""
    children = {
        c.name: [s.name for s in c.subordinates] for c in system.controllers if not c.is_operator
    }
    roots = [c.name for c in system.controllers if c.supervisor is None and c.name in place]
    for root in roots:
        _halt_down(proof, children, place, hosts, root, root, 1, (root,))
    _errors_up(proof, children, place, hosts)


def _halt_down(
    proof: SystemProof,
    children: dict[str, list[str]],
    place: dict[str, tuple[str, int]],
    hosts: dict[str, str],
    start: str,
    at: str,
    arrive: int,
    path: tuple[str, ...],
) -> None:
    """The cycle HALT, read by `start` in cycle 1, is read by each leaf below `at` (which
    reads it in cycle `arrive`), and the cycle the leaf's actuators are safe."""
    result = proof.controllers.get(at)
    subs = children.get(at, [])
    if not subs:
        safe = None
        if result is not None and result.safe:
            worst = max(result.safe.values())
            safe = INFINITE if INFINITE in (worst, arrive) else arrive + worst - 1
        proof.halt.append(Bound(start, at, arrive, path, safe))
        return
    for sub in subs:
        local = result.halt.get(sub, INFINITE) if result else INFINITE
        if INFINITE in (local, arrive):
            reads = INFINITE
        else:
            reads = arrive + local - 1 + hop(place, at, sub, hosts)
        _halt_down(proof, children, place, hosts, start, sub, reads, (*path, sub))


def _errors_up(
    proof: SystemProof,
    children: dict[str, list[str]],
    place: dict[str, tuple[str, int]],
    hosts: dict[str, str],
) -> None:
    """The cycle an ERROR a leaf reports in cycle 1 is reported by its root, where every
    supervisor on the way reports it (else where it stops)."""
    parent = {s: c for c, subs in children.items() for s in subs}
    for leaf in [c for c in children if not children[c] and c in parent]:
        graph = proof.graphs.get(leaf)
        if graph is not None and not any(ERROR in v for v in props.outcomes(graph).values()):
            continue  # the leaf never reports ERROR: nothing to carry up
        at, d, blocked = leaf, 1, ""
        path: tuple[str, ...] = (leaf,)
        while at in parent:
            up = parent[at]
            result = proof.controllers.get(up)
            local = result.error.get(at, INFINITE) if result else INFINITE
            if local == INFINITE:
                blocked, d = up, INFINITE
                break
            d = d + hop(place, at, up, hosts) + local - 1
            at = up
            path = (*path, at)
        proof.error.append(Bound(leaf, at, d, path, None, blocked))
