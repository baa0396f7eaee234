"""How `rcsgen prove` hands a run's numbers to z3 (rcsgen/compiler/prove/numbers.py
`Encoder`): each expression of a guard or a value as a z3 term that means what the
generated code computes - checked by putting numbers in and comparing with Python's own
result - and, where z3 cannot follow Python (`//` and `%` floor, a float compared for
equality), a fresh value that is free both ways, so no run is called impossible wrongly."""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction
from types import SimpleNamespace
from typing import Any

import pytest
from test_prove_adapter import arm  # noqa: F401  (the fixture: arm's skeleton)

from rcsgen.compiler.analysis.tables import Atom
from rcsgen.compiler.expressions.nodes import (
    Binary,
    BoolOp,
    Call,
    CallKind,
    Compare,
    Const,
    Expr,
    IfExp,
    Ref,
    RefKind,
    Unary,
)
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove.adapter import Skeleton, skeleton
from rcsgen.compiler.prove.lost import RuntimeReaction
from rcsgen.compiler.prove.model import Graph, Model, explore
from rcsgen.compiler.prove.numbers import numeric, witness
from rcsgen.compiler.prove.system import _shortest_form
from rcsgen.compiler.types import BOOL, FLOAT, INT, STATUS, Str, enum_of

z3 = pytest.importorskip("z3")

X = Ref(FLOAT, RefKind.WORLD, "x")
X_ = z3.RealVal(1.5)
N = Ref(INT, RefKind.WORLD, "n")


def c(value: Any) -> Const:
    kind = BOOL if isinstance(value, bool) else INT if isinstance(value, int) else FLOAT
    return Const(kind, value)


def binary(op: str, a: Expr, b: Expr) -> Binary:
    kind = FLOAT if FLOAT in (a.type, b.type) or op == "/" else INT
    return Binary(kind, op, a, b)


def compare(a: Expr, *rest: Any) -> Compare:
    ops, terms = rest[::2], rest[1::2]
    return Compare(BOOL, a, tuple(ops), tuple(terms))


def call(name: str, *args: Expr) -> Call:
    kind = FLOAT if any(a.type == FLOAT for a in args) else INT
    return Call(kind, CallKind.BUILTIN, name, args)


# (an expression over world.x (float) and world.n (int), what Python makes of it)
EXACT = [
    (binary("+", X, N), lambda x, n: x + n),
    (binary("-", N, X), lambda x, n: n - x),
    (binary("*", X, c(2)), lambda x, n: x * 2),
    (binary("/", N, c(4)), lambda x, n: n / 4),  # true division, ints as reals
    (binary("-", binary("*", N, N), c(1)), lambda x, n: n * n - 1),
    (Unary(FLOAT, "-", X), lambda x, n: -x),
    (Unary(INT, "+", N), lambda x, n: +n),
    (compare(N, "<", c(3)), lambda x, n: n < 3),
    (compare(N, "<=", c(3)), lambda x, n: n <= 3),
    (compare(N, ">", c(3)), lambda x, n: n > 3),
    (compare(N, ">=", c(3)), lambda x, n: n >= 3),
    (compare(N, "==", c(3)), lambda x, n: n == 3),
    (compare(N, "!=", c(3)), lambda x, n: n != 3),
    (compare(X, ">", N), lambda x, n: x > n),  # int against float
    (compare(c(1), "<", N, "<=", c(3)), lambda x, n: 1 < n <= 3),  # a chain: both
    (
        BoolOp(BOOL, "and", (compare(N, ">", c(0)), compare(X, "<", c(1.5)))),
        lambda x, n: n > 0 and x < 1.5,
    ),
    (
        BoolOp(BOOL, "or", (compare(N, ">", c(0)), compare(X, "<", c(1.5)))),
        lambda x, n: n > 0 or x < 1.5,
    ),
    (Unary(BOOL, "not", compare(N, ">", c(0))), lambda x, n: not n > 0),
    (IfExp(FLOAT, compare(N, ">", c(0)), X, c(0)), lambda x, n: x if n > 0 else 0),
    (call("abs", binary("-", X, c(2.5))), lambda x, n: abs(x - 2.5)),
    (call("min", X, N, c(1)), lambda x, n: min(x, n, 1)),
    (call("max", X, N, c(1)), lambda x, n: max(x, n, 1)),
    (compare(X, ">", Ref(FLOAT, RefKind.CONST, "LIMIT")), lambda x, n: x > 2.0),
    (compare(Ref(INT, RefKind.LOCAL, "count"), "==", c(0)), lambda x, n: True),  # initial
    (compare(Ref(INT, RefKind.LOCAL, "mode"), "==", c(1)), lambda x, n: True),  # BUSY
]
GRID = [(x, n) for x in (-3.5, 0.0, 1.25, 2.0, 4.5) for n in (-2, 0, 1, 3, 7)]


def encoder(sk: Skeleton) -> Any:
    from rcsgen.compiler.prove.numbers import Encoder

    return Encoder(z3, SimpleNamespace(skeleton=sk, initial=None))


def at(term: Any, world: dict[str, Any], x: float, n: int) -> Any:
    pairs = [(world["x"], z3.RealVal(x)), (world["n"], z3.IntVal(n))]
    found = z3.simplify(z3.substitute(term, *pairs))
    if z3.is_bool(found):
        assert z3.is_true(found) or z3.is_false(found), found
        return z3.is_true(found)
    return float(found.as_fraction()) if z3.is_rational_value(found) else found.as_long()


@pytest.mark.parametrize("case", range(len(EXACT)))
def test_each_expression_means_what_python_computes(arm: Skeleton, case: int) -> None:  # noqa: F811
    tree, python = EXACT[case]
    world = {"x": z3.Real("x"), "n": z3.Int("n")}
    term = encoder(arm).value(tree, {}, world)
    for x, n in GRID:
        assert at(term, world, x, n) == python(x, n), (x, n)


def free(term: Any) -> bool:
    """Whether the term can be true and can be false."""
    return all(z3.Solver().check(t) == z3.sat for t in (term, z3.Not(term)))


def test_what_z3_cannot_follow_is_free_and_the_rest_is_decided(arm: Skeleton) -> None:  # noqa: F811
    world = {"x": X_, "n": z3.IntVal(7)}
    enc = encoder(arm)
    # floor division and modulo, and a float compared for equality: a fresh value each
    assert free(enc.value(compare(binary("//", N, c(2)), "==", c(3)), {}, world))
    assert free(enc.value(compare(binary("%", N, c(2)), "==", c(1)), {}, world))
    assert free(enc.value(compare(X, "==", c(1.5)), {}, world))
    assert free(enc.value(compare(X, "!=", c(1.5)), {}, world))
    assert free(enc.value(compare(X, "==", N), {}, world))  # one side a float is enough
    # a chain: the float equality free, the comparison after it still decided (n=0: false)
    chain = compare(X, "==", c(1.5), "<", N)
    assert free(enc.value(chain, {}, world))
    assert z3.Solver().check(enc.value(chain, {}, {"x": X_, "n": z3.IntVal(0)})) == z3.unsat
    # a subordinate's result, even of a subordinate read this cycle: fresh
    assert free(enc.value(Ref(BOOL, RefKind.SUB_RESULT, "ok", "sub"), {"sub": "DONE"}, world))
    # a world field named like a local is the world's, not the local's (count starts at 0)
    assert free(enc.value(compare(Ref(INT, RefKind.WORLD, "count"), "==", c(0)), {}, {}))
    # decided: an int compared for equality, a status against the one read this cycle
    assert z3.is_true(z3.simplify(enc.value(compare(N, "==", c(7)), {}, world)))
    sub = Ref(STATUS, RefKind.SUB_STATUS, "status", "sub")
    done = Ref(STATUS, RefKind.STATUS, "DONE")
    read = enc.value(compare(sub, "==", done), {"sub": "DONE"}, world)
    assert z3.is_true(z3.simplify(read))
    read = enc.value(compare(sub, "==", done), {"sub": "ERROR"}, world)
    assert z3.is_false(z3.simplify(read))
    # a parameter is one value for the whole command: read twice, the same term
    p = Ref(INT, RefKind.PARAM, "p")
    assert z3.is_true(z3.simplify(enc.value(compare(p, "==", p), {}, world)))
    assert enc.kinds == {"p": INT}
    # a world field read in a cycle is one value for every rule of it
    fresh: dict[str, Any] = {}
    first = enc.value(X, {}, fresh)
    assert enc.value(X, {}, fresh) is first and set(fresh) == {"x"}


DIAL = """\
controller: dial
title: Dial
world:
  reads: [pos]
  writes: [lamp]
commands:
  SET:
    params:
      n: {type: int, doc: A count.}
      x: {type: float, doc: A level.}
      on: {type: bool, doc: A switch.}
      name: {type: str, doc: A name.}
      mode: {type: enum, values: [SLOW, FAST], doc: A speed.}
    states:
      S0:
        - when: on and mode == FAST and world.pos > 1.0
          next: S1
        - when: not on or mode == SLOW or world.pos <= 1.0
          do: [{report: ERROR}]
      S1:
        - when: n == 3 and x > 0.25 and x < 0.5 and on and name == "b"
          do: [{set: {world.lamp: true}}, {report: DONE}]
        - when: not on
          do: [{report: ERROR}]
        - when: on and (n != 3 or x <= 0.25 or x >= 0.5 or name != "b")
          do: [{report: ERROR}]
"""
DIAL_SYSTEM = """\
system: dial
title: One dial
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  lamp: {type: bool, initial: false, actuator: true, safe: false}
processes:
  p:
    modules: [dial]
"""


@pytest.fixture(scope="module")
def dial_model(tmp_path_factory: pytest.TempPathFactory) -> Callable[[], Model]:
    """DIAL's model, a new one each call (a Model lists a new command's edges once: one
    exploration each)."""
    directory = tmp_path_factory.mktemp("dial")
    (directory / "system.yaml").write_text(DIAL_SYSTEM)
    (directory / "dial.yaml").write_text(DIAL)
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    sk = skeleton(system, system.controllers[0], frozenset({"lamp"}))
    return lambda: Model(sk, {}, RuntimeReaction(system))


@pytest.fixture(scope="module")
def dial(dial_model: Callable[[], Model]) -> Graph:
    """DIAL's explored model."""
    return explore(dial_model())


def test_a_witness_gives_the_parameters_read_later_on_the_cycle_that_brings_the_command(
    dial: Graph,
) -> None:
    """numbers.witness: SET's cycle reads `on`, `mode` and world.pos; S1, a cycle later,
    reads every parameter but `mode`. The run to its DONE carries one solution's values on
    SET's own cycle, as the model's valuations hold them (an int and a float as fractions,
    a bool, a text), for the replay; the model's own world value and enumeration choice
    stay (an enumeration's index is no value name), each atom once."""
    graph = dial
    s, edge, done = next(
        (s, e, t)
        for s, edges in graph.edges.items()
        for e, t in edges
        if e.report == "DONE" and t.command == "SET"
    )
    run = [*graph.path_to(s), (edge, done)]
    assert [e.new for e, _ in run] == ["SET", None]
    found = witness(z3, graph, run)
    assert found is not None and found[1] == run[1]  # the later cycle as the model found it
    valuation = found[0][0].valuation
    param, world = Atom.PARAM, Atom.WORLD
    assert [k for k, _ in valuation] == [
        (param, "mode"),  # the model's, kept in its order
        (world, "pos"),
        (param, "n"),  # z3's, by name
        (param, "name"),
        (param, "on"),
        (param, "x"),
    ]
    given = dict(valuation)
    x = given.pop((param, "x"))
    assert type(x) is Fraction and Fraction(1, 4) < x < Fraction(1, 2)
    assert given == {
        (param, "mode"): "FAST",
        (world, "pos"): dict(run[0][0].valuation)[(world, "pos")],
        (param, "n"): Fraction(3),
        (param, "name"): "b",
        (param, "on"): True,
    }
    assert type(given[(param, "n")]) is Fraction and given[(param, "on")] is True


def test_a_run_is_in_shortest_form_when_the_model_reaches_its_last_cycle_the_shortest_way(
    dial: Graph,
) -> None:
    """system._shortest_form, which says whether numbers.search may look for another run to
    a finding's cycle: the model's shortest way to the last cycle's start, then that cycle
    (a run of one cycle starts at the initial state); not when an earlier cycle differs."""
    graph = dial
    init, first = (
        next((e, t) for e, t in graph.edges[graph.initial] if t.command == c and t.state == s)
        for c, s in (("INIT", "NOP"), ("SET", "S1"))
    )
    assert _shortest_form(graph, [first]) and _shortest_form(graph, [init])
    done = next((e, t) for e, t in graph.edges[first[1]] if e.report == "DONE")
    run = [first, done, graph.edges[done[1]][0]]
    assert _shortest_form(graph, run)
    # the same cycles after another first cycle: not the model's way to the last one
    assert not _shortest_form(graph, [init, *run[1:]])


def test_exploring_stops_at_the_state_limit_and_marks_the_model_incomplete(
    dial_model: Callable[[], Model], dial: Graph
) -> None:
    """model.explore's `limit` is the most states a model may have (prove's `limit`, LIMIT):
    at it exploration stops with exactly that many, breadth first, and the graph is marked
    incomplete (what prove then calls undecided); a limit the model fits in keeps it whole."""
    full = len(dial.parent)
    assert dial.complete and full > 3
    cut = explore(dial_model(), limit=3)
    assert not cut.complete
    assert list(cut.parent) == list(dial.parent)[:3]
    whole = explore(dial_model(), limit=full)
    assert whole.complete and list(whole.parent) == list(dial.parent)


def test_a_cycle_with_no_rule_to_try_is_certain(dial: Graph) -> None:
    """DIAL has no every_cycle rule and no table in NOP (before its first command, after a
    report): that no rule fires there is certain, not only possible, so a finding whose run
    passes such cycles stays certain (violated when acknowledged, not undecided)."""
    idle = [e for s, edges in dial.edges.items() for e, _ in edges if s.state == "NOP"]
    assert len([e for e in idle if not e.rules]) >= 3
    assert all(e.certain for e in idle if not e.rules)


def test_each_value_has_its_types_sort_whatever_way_its_number_is_written(arm: Skeleton) -> None:  # noqa: F811
    """Encoder: a literal or a constant of a float type is a z3 real even written as a whole
    number (`2`), one of an int type an integer; a value read fresh (a world field) has its
    type's sort too (an enumeration's is its index, an integer; a str a string)."""
    enc, world = encoder(arm), {}
    sorts = {
        "float 2": enc.value(Const(FLOAT, 2), {}, world),
        "float 2.5": enc.value(Const(FLOAT, 2.5), {}, world),
        "int 3": enc.value(c(3), {}, world),
        "bool": enc.value(c(True), {}, world),
        "str": enc.value(Const(Str(), "b"), {}, world),
        "LIMIT": enc.value(Ref(FLOAT, RefKind.CONST, "LIMIT"), {}, world),
    }
    for kind, name in ((FLOAT, "x"), (INT, "n"), (BOOL, "b"), (Str(), "s"), (enum_of("AB"), "e")):
        sorts[f"world {name}"] = enc.value(Ref(kind, RefKind.WORLD, name), {}, world)
    assert {name: str(term.sort()) for name, term in sorts.items()} == {
        "float 2": "Real",
        "float 2.5": "Real",
        "int 3": "Int",
        "bool": "Bool",
        "str": "String",
        "LIMIT": "Real",
        "world x": "Real",
        "world n": "Int",
        "world b": "Bool",
        "world s": "String",
        "world e": "Int",
    }
    assert str(sorts["float 2"]) == "2" and str(sorts["float 2.5"]) == "5/2"


def test_the_cycle_that_brings_a_command_constrains_its_parameters(dial: Graph) -> None:
    """numbers.witness: SET's first cycle (S0, EXECUTING from the new command) fires rule 1
    only with `on`; S1's rule 2 then needs `not on`: no values make that run, whereas rule 3
    (`n != 3` and the like) is possible. A run that reads no number is not asked about."""
    graph = dial
    s1 = next(s for s in graph.edges if s.command == "SET" and s.state == "S1")
    by_rule = {e.rules[-1]: (e, t) for e, t in graph.edges[s1] if e.rules and e.new is None}
    assert [e.rules for e, _ in graph.path_to(s1)] == [("SET/S0/1",)]
    assert witness(z3, graph, [*graph.path_to(s1), by_rule["SET/S1/2"]]) is None
    assert witness(z3, graph, [*graph.path_to(s1), by_rule["SET/S1/3"]]) is not None
    assert numeric(graph.skeleton, graph.path_to(s1)) is True
    init = next((e, t) for e, t in graph.edges[graph.initial] if e.new == "INIT")
    assert numeric(graph.skeleton, [init]) is False
