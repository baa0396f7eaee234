"""SMV export: a controller's explored model -> a NuSMV/nuXmv model (`rcsgen prove --export smv`).

For users who own nuXmv: the model `prove` explored for one controller (over its
subordinates' proven contracts) written as an explicit-state SMV module, one step per
cycle. The variable `c` names the cycle just taken (a transition of the model; 0 before
the first), so every atom a property reads - the controller's state, command and status
after the cycle, a subordinate's status as read and its last command, what was sent and
written - is a DEFINE over `c`. The spec's own properties are LTLSPECs with `prove`'s
meaning (docs/spec.md section 19.1); one reading `safe(...)` is left out, with why (its
monitor is not part of the export).
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

from ..compiler.ir import IRPropAtom, IRProperty, IRPropExpr, PropKind
from ..compiler.prove.model import Edge, Graph, State
from ..compiler.prove.properties import rule_view
from ..compiler.prove.system import SystemProof

Cycle = tuple[Edge, State]


def _name(*parts: str) -> str:
    return re.sub(r"\W", "_", "_".join(parts))


def _atoms(graph: Graph, cycle: Cycle) -> set[str]:
    """The DEFINEs that hold in a cycle."""
    edge, t = cycle
    sk = graph.skeleton
    found = {
        _name("state", t.state),
        _name("command", t.command or "NONE"),
        _name("status", t.status),
    }
    for i, sub in enumerate(sk.subs):
        found.add(_name(sub, "status", edge.views[i]))
        found.add(_name(sub, "command", t.subs[i][0] or "NONE"))
    found |= {_name("sent", sub, cmd) for sub, cmd in edge.sends}
    for rule in edge.rules:
        found |= {_name("writes", w) for w in rule_view(sk, rule).assigns}
    if edge.new is not None:
        found.add("new_command")
    if edge.lost or edge.recovered or edge.reset or edge.safe_state:
        found.add("runtime")  # a loss, a recovery, a reset, the safe state
    if edge.safe_state:
        found.add("safe_state")
    return found


def _atom(a: IRPropAtom) -> str:
    kind = {PropKind.SUB_STATUS: "status", PropKind.SUB_COMMAND: "command"}
    if a.kind in (PropKind.STATE, PropKind.COMMAND, PropKind.STATUS):
        return _name(str(a.kind), a.value)
    if a.kind in kind:
        return _name(a.module, kind[a.kind], a.value)
    if a.kind is PropKind.SENT:
        return _name("sent", a.module, a.value)
    return _name("writes", a.value)  # WRITES (SAFE is not exported)


def _expr(e: IRPropExpr) -> str:
    if e.op == "atom":
        assert e.atom is not None
        return _atom(e.atom)
    if e.op == "not":
        return f"!({_expr(e.args[0])})"
    if e.op in ("and", "or"):
        return "(" + (" & " if e.op == "and" else " | ").join(_expr(x) for x in e.args) + ")"
    return "TRUE" if e.op == "true" else "FALSE"


def ltl(prop: IRProperty) -> str:
    """The property with `prove`'s meaning: an invariant after every cycle but the safe
    state's; a response started by a cycle that is not the runtime's, ended (met or not)
    by the runtime's cycles and by a new command."""
    then = _expr(prop.then)
    if prop.whenever is None:
        return f"G ((c != 0 & !safe_state) -> {then})"
    due = f"(runtime | new_command | {then})"
    for _ in range(prop.within - 1):
        due = f"(runtime | new_command | {then} | X {due})"
    response = then if prop.within == 0 else f"({then} | X {due})"
    return f"G ((c != 0 & !runtime & {_expr(prop.whenever)}) -> {response})"


def smv_text(proof: SystemProof, controller: str, properties: tuple[IRProperty, ...]) -> str:
    """The SMV module of one controller's explored model, with its properties."""
    graph = proof.graphs[controller]
    cycles: list[Cycle] = [c for s in graph.edges for c in graph.edges[s]]
    index = {id(c): i + 1 for i, c in enumerate(cycles)}
    after: dict[State, list[int]] = defaultdict(list)  # state -> the cycles leaving it
    for s, edges in graph.edges.items():
        after[s] = [index[id(c)] for c in edges]
    holds: dict[str, list[int]] = defaultdict(list)
    for i, cycle in enumerate(cycles, start=1):
        for atom in _atoms(graph, cycle):
            holds[atom].append(i)
    for name in ("new_command", "runtime", "safe_state"):
        holds.setdefault(name, [])
    for prop in properties:  # an atom no cycle makes true is FALSE, not undeclared
        for a in [*prop.then.atoms(), *(prop.whenever.atoms() if prop.whenever else [])]:
            if a.kind is not PropKind.SAFE:
                holds.setdefault(_atom(a), [])
    lines = [
        f"-- Written by `rcsgen prove --export smv`: {controller} of system {proof.system},",
        f"-- its explored model ({len(graph.parent)} states, {len(cycles)} cycles) over its",
        "-- subordinates' proven contracts. c: the cycle just taken (0: none yet).",
        "MODULE main",
        "VAR",
        f"  c : 0..{len(cycles)};",
        "ASSIGN",
        "  init(c) := 0;",
        "  next(c) := case",
        f"    c = 0 : {_set(after[graph.initial])};",
    ]
    by_target: dict[tuple[int, ...], list[int]] = defaultdict(list)
    for i, (_, t) in enumerate(cycles, start=1):
        by_target[tuple(after[t])].append(i)
    for targets, sources in by_target.items():
        lines.append(f"    c in {_set(sources)} : {_set(list(targets))};")
    lines += ["    TRUE : c;", "  esac;", "DEFINE"]
    for atom in sorted(holds):
        lines.append(f"  {atom} := {('c in ' + _set(holds[atom])) if holds[atom] else 'FALSE'};")
    for prop in properties:
        if any(a.kind is PropKind.SAFE for a in prop.then.atoms()) or (
            prop.whenever and any(a.kind is PropKind.SAFE for a in prop.whenever.atoms())
        ):
            lines.append(f"-- {prop.name}: reads safe(...), whose monitor is not exported")
            continue
        lines += [f"-- {prop.name}: {prop.text}", f"LTLSPEC NAME {prop.name} := {ltl(prop)};"]
    return "\n".join(lines) + "\n"


def write_smv(proof: SystemProof, properties: tuple[IRProperty, ...], target: Path) -> list[Path]:
    """One `<controller>.smv` per controller explored, into `target`."""
    target.mkdir(parents=True, exist_ok=True)
    written = []
    for name in proof.graphs:
        path = target / f"{name}.smv"
        mine = tuple(p for p in properties if p.controller == name)
        path.write_text(smv_text(proof, name, mine), encoding="utf-8")
        written.append(path)
    return written


def _set(values: list[int]) -> str:
    return "{" + ", ".join(map(str, values)) + "}" if values else "{0}"
