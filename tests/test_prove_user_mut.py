"""A property of the engineer's own in `rcsgen prove` (rcsgen/compiler/prove/user.py), on
models made by hand, in the unit tier: what each atom reads in a cycle (docs/spec.md section
19), how `and`, `or`, `not` and the constants combine them, how an obligation opened by
`whenever` runs out `within` cycles, and the monitor's state limit. test_prove_properties
reads the same through real specs."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest
from test_prove_graph import edge, skeleton, state, view

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.ir import IRPropAtom, IRProperty, IRPropExpr, PropKind
from rcsgen.compiler.prove import user
from rcsgen.compiler.prove.adapter import DONE, EXECUTING, RuleView
from rcsgen.compiler.prove.model import Graph, State

SPAN = Span("top.yaml", 3, 5)
NO_WORLD = SimpleNamespace(world=())  # the system: no actuator a property tracks


def atom(kind: PropKind, module: str, value: str) -> IRPropExpr:
    return IRPropExpr("atom", IRPropAtom(kind, module, value))


def top() -> Any:
    sk = skeleton("top", {"GO": [view("GO/S0/1")]}, subs=("sub",))
    sk.views["GO/S0/1"] = RuleView(
        "GO/S0/1", SPAN, None, "", (), None, None, assigns=frozenset({"n"})
    )
    return sk


def test_each_atom_reads_its_part_of_the_cycle() -> None:
    """After a cycle that fired GO/S0/1 (it writes n), sent sub MOVE, read sub EXECUTING and
    left top in GO S1 EXECUTING: each atom as the cycle makes it; a module's command before
    any is NONE; an atom about a module that is no subordinate fails when read, naming it."""
    sk = top()
    e = edge(rules=("GO/S0/1",))._replace(sends=(("sub", "MOVE"),), views=(EXECUTING,))
    t = State("GO", "S1", EXECUTING, 0, (("MOVE", EXECUTING, True),))
    idle = State(None, "NOP", "NOT_READY", 0, ((None, "NOT_READY", False),))
    unsafe = frozenset({"drive"})
    # each kind: (the module, a value the cycle makes it, one it does not)
    cases = {
        PropKind.STATE: ("top", "S1", "S0"),
        PropKind.COMMAND: ("top", "GO", "NONE"),
        PropKind.STATUS: ("top", EXECUTING, DONE),
        PropKind.SENT: ("sub", "MOVE", "HALT"),
        PropKind.WRITES: ("", "n", "world.drive"),
        PropKind.SAFE: ("", "world.lamp", "world.drive"),
        PropKind.SUB_STATUS: ("sub", EXECUTING, DONE),
        PropKind.SUB_COMMAND: ("sub", "MOVE", "NONE"),
    }
    read = {
        kind: [user.compiled(sk, atom(kind, m, v))(e, t, unsafe) for v in values]
        for kind, (m, *values) in cases.items()
    }
    assert read == {kind: [True, False] for kind in PropKind}
    before = edge()._replace(views=("NOT_READY",))
    assert [
        user.compiled(sk, atom(kind, m, "NONE"))(before, idle, frozenset())
        for kind, m in ((PropKind.COMMAND, "top"), (PropKind.SUB_COMMAND, "sub"))
    ] == [True, True]
    stranger = user.compiled(sk, atom(PropKind.SUB_STATUS, "arm", DONE))
    with pytest.raises(ValueError, match="^'arm' is not a subordinate of top$"):
        stranger(e, t, unsafe)


def test_not_and_or_and_the_constants_combine_atoms_as_python_does() -> None:
    sk = top()
    e, t = edge(), state("S1")
    yes, no = atom(PropKind.STATE, "top", "S1"), atom(PropKind.STATE, "top", "S0")
    exprs = {
        "not yes": IRPropExpr("not", args=(yes,)),
        "yes and no": IRPropExpr("and", args=(yes, no)),
        "yes and yes and yes": IRPropExpr("and", args=(yes, yes, yes)),
        "no or no or yes": IRPropExpr("or", args=(no, no, yes)),
        "no or no": IRPropExpr("or", args=(no, no)),
        "true": IRPropExpr("true"),
        "false": IRPropExpr("false"),
        "and of nothing": IRPropExpr("and"),
        "or of nothing": IRPropExpr("or"),
    }
    assert {name: user.compiled(sk, x)(e, t, frozenset()) for name, x in exprs.items()} == {
        "not yes": False,
        "yes and no": False,
        "yes and yes and yes": True,
        "no or no or yes": True,
        "no or no": False,
        "true": True,
        "false": False,
        "and of nothing": True,
        "or of nothing": False,
    }


def prop(then: IRPropExpr, whenever: IRPropExpr | None = None, within: int = 0) -> IRProperty:
    return IRProperty("p", "top", SPAN, "p as written", then, whenever, within)


def chain(*names: str) -> tuple[Graph, list[State]]:
    """A model made by hand: the initial state, then one state per name, one after another,
    the last going round to itself."""
    states = [State(None, "NOP", "NOT_READY", 0, ((None, "NOT_READY", False),))]
    states += [State("GO", n, EXECUTING, 0, ((None, "NOT_READY", False),)) for n in names]
    graph = Graph(top(), states[0])
    graph.edges = {s: [(edge(), t)] for s, t in zip(states, states[1:], strict=False)}
    graph.edges[states[-1]] = [(edge(), states[-1])]
    graph.parent = {s: None for s in states}
    return graph, states


def test_an_obligation_runs_out_after_within_cycles_and_a_new_command_closes_it() -> None:
    """`whenever: top.state == S1, within: 2, then: top.state == S4`: S1 opens it in cycle
    1, S2 and S3 do not answer it, so it is violated in cycle 3; with S4 a cycle sooner, or
    within 3, it holds; a new command in between closes it (a new situation)."""
    when, then = atom(PropKind.STATE, "top", "S1"), atom(PropKind.STATE, "top", "S4")
    late, states = chain("S1", "S2", "S3", "S4")
    found = user.search(late, prop(then, when, 2), NO_WORLD)  # type: ignore[arg-type]
    assert found is not None and [t.state for _, t in found.trace] == ["S1", "S2", "S3"]
    assert found.message.endswith(
        "it held in cycle 1 and the response did not follow by cycle 3"
    ), found.message
    assert user.search(late, prop(then, when, 3), NO_WORLD) is None  # type: ignore[arg-type]
    soon, _ = chain("S1", "S2", "S4")
    assert user.search(soon, prop(then, when, 2), NO_WORLD) is None  # type: ignore[arg-type]
    renewed, states = chain("S1", "S2", "S3", "S4")
    renewed.edges[states[2]] = [(edge()._replace(new="GO"), states[3])]
    assert user.search(renewed, prop(then, when, 2), NO_WORLD) is None  # type: ignore[arg-type]


def test_the_monitor_holds_at_most_limit_states() -> None:
    """user.search over model and monitor: a property that holds in a model of five states
    needs five; at five it is decided (holds), at four it is too large (undecided)."""
    graph, states = chain("S1", "S2", "S3", "S4")
    holds = prop(IRPropExpr("true"))
    assert user.search(graph, holds, NO_WORLD, limit=5) is None  # type: ignore[arg-type]
    with pytest.raises(user.TooLarge, match="^p$"):
        user.search(graph, holds, NO_WORLD, limit=4)  # type: ignore[arg-type]
