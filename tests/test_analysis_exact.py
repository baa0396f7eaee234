"""The analysis is exact through `abs`, `min`, `max` and negation (issue 26, item 4).

Before, `abs(world.a) > C` and `abs(world.a) <= C` were two opaque atoms, free to be true
at once: W502 showed a counter-example that cannot happen. Now each builtin is written as
the conditional it is and split into linear comparisons (GuardBuilder.lifted). The property:
every counter-example the analysis finds for "both guards hold" makes both guards true when
they are evaluated as the generated code evaluates them (the Python text the back end
prints, run by Python); and when it answers "no", no value makes both true.
"""

from __future__ import annotations

import re
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from test_analysis import make

from rcsgen.compiler import expressions as X
from rcsgen.compiler.analysis import solver
from rcsgen.compiler.analysis import tables as analysis
from rcsgen.compiler.checks import naming
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.types import BOOL, FLOAT, INT

A = X.Ref(FLOAT, X.RefKind.WORLD, "a")  # a float world field
B = X.Ref(INT, X.RefKind.LOCAL, "b")  # an int local
KEYS = {(analysis.Atom.WORLD, "a"): "world_a", (analysis.Atom.LOCAL, "b"): "var_b"}


def numbers(depth: int) -> st.SearchStrategy[X.Expr]:
    """Numeric trees over one float and one int variable: constants, negation, abs, min,
    max, a constant added or multiplied."""
    leaves = st.one_of(
        st.just(A),
        st.just(B),
        st.integers(-4, 4).map(lambda v: X.Const(INT, v)),
        st.sampled_from([-2.5, -0.5, 0.0, 1.5, 3.0]).map(lambda v: X.Const(FLOAT, v)),
    )
    if depth == 0:
        return leaves

    def typed(*args: X.Expr) -> Any:
        return FLOAT if any(a.type == FLOAT for a in args) else INT

    inner = numbers(depth - 1)
    return st.one_of(
        leaves,
        inner.map(lambda x: X.Unary(x.type, "-", x)),
        inner.map(lambda x: X.Call(x.type, X.CallKind.BUILTIN, "abs", (x,))),
        st.tuples(st.sampled_from(["min", "max"]), inner, inner).map(
            lambda t: X.Call(typed(t[1], t[2]), X.CallKind.BUILTIN, t[0], (t[1], t[2]))
        ),
        st.tuples(inner, st.integers(-3, 3)).map(
            lambda t: X.Binary(typed(t[0]), "+", t[0], X.Const(INT, t[1]))
        ),
        st.tuples(inner, st.sampled_from([-2, 2])).map(
            lambda t: X.Binary(typed(t[0]), "*", X.Const(INT, t[1]), t[0])
        ),
    )


def comparisons() -> st.SearchStrategy[X.Expr]:
    """A comparison of a numeric tree with a constant or with another tree (over `a` only:
    a form of `a` and `b` together is an int form, "maybe" by design)."""
    const = st.sampled_from([-3, -1, 0, 1, 2, 3]).map(lambda v: X.Const(INT, v))
    op = st.sampled_from(["<", "<=", ">", ">=", "==", "!="])
    return st.tuples(numbers(2), op, st.one_of(const, numbers(1))).map(
        lambda t: X.Compare(BOOL, t[0], (t[1],), (t[2],))
    )


def evaluate(tree: X.Expr, values: dict[str, Any]) -> bool:
    """The guard as generated code evaluates it: the printed Python, run by Python."""
    text = X.to_python(tree, naming.attribute)

    class Self:
        pass

    me = Self()
    for name, value in values.items():
        setattr(me, name, value)
    return bool(eval(text, {"__builtins__": {"abs": abs, "min": min, "max": max}}, {"self": me}))  # noqa: S307


def concrete(shown: list[tuple[solver.Key, Any]]) -> dict[str, Any]:
    """A valuation's values as the generated code holds them (atoms not shown are free:
    any value does; 0)."""
    values: dict[str, Any] = {"world_a": 0.0, "var_b": 0}
    for key, value in shown:
        assert key in KEYS, f"an atom the analysis cannot show possible: {key}"
        values[KEYS[key]] = float(value) if key[0] == analysis.Atom.WORLD else int(value)
    return values


def probes(trees: list[X.Expr]) -> list[dict[str, Any]]:
    """Values of a and b around every constant the guards name (and halfway between)."""
    found = {Fraction(0)}
    for tree in trees:
        for node in X.walk(tree):
            if isinstance(node, X.Const) and not isinstance(node.value, bool):
                found.add(Fraction(node.value))
    points = set()
    for c in found:  # scaled by 1/2 and 2 too: the constants reach a through * and +
        for base in (c, c / 2, c * 2, -c, -c / 2):
            points.update({base, base + Fraction(1, 4), base - Fraction(1, 4)})
            points.update({base + k for k in range(-7, 8)})
    floats = sorted({float(p) for p in points})
    ints = sorted({int(p) for p in points if p.denominator == 1})
    return [{"world_a": a, "var_b": b} for a in floats for b in ints[:: max(1, len(ints) // 12)]]


# Found by this test: `-2 * a + 1 <= a` holds from a = 1/3 exactly, which no float holds; the
# nearest float, 0.3333333333333333, is below it and makes the guard false in Python. A float
# variable now takes only values a float holds, strictly inside each region.
ONE_THIRD = X.Compare(
    BOOL,
    X.Binary(FLOAT, "+", X.Binary(FLOAT, "*", X.Const(INT, -2), A), X.Const(INT, 1)),
    ("<=",),
    (A,),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(comparisons(), comparisons())
@example(X.Compare(BOOL, B, ("<",), (X.Const(INT, -3),)), ONE_THIRD)
@example(
    ONE_THIRD, X.Compare(BOOL, X.Binary(FLOAT, "*", X.Const(INT, 2), A), ("<",), (X.Const(INT, 1),))
)
def test_every_counter_example_makes_both_guards_true(first: X.Expr, second: X.Expr) -> None:
    builder = analysis.GuardBuilder({}, {}, {})
    answer = solver.solve([(builder.guard(first), True), (builder.guard(second), True)])
    if answer.kind == solver.Verdict.UNKNOWN:
        return  # too many valuations: "cannot prove", no counter-example shown
    opaque = [k for k, _ in answer.shown if k[0] == analysis.Atom.OPAQUE]
    assert not opaque, f"abs/min/max/negation left opaque: {opaque}"
    if answer.kind == solver.Verdict.YES:
        values = concrete(answer.shown)
        assert evaluate(first, values) and evaluate(second, values), (answer.shown, values)
    elif answer.kind == solver.Verdict.NO:
        for values in probes([first, second]):
            assert not (evaluate(first, values) and evaluate(second, values)), values


def test_the_issues_complement_is_exclusive_and_an_overlap_is_shown_truly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """W502's false counter-example: both `abs(a) > C` and `abs(a) <= C` shown true at once.
    Now the pair is exclusive (no finding) and together complete (no wait); a real
    overlap through min and negation is E501 with a valuation that fires both."""
    monkeypatch.chdir(tmp_path)
    directory = make(
        tmp_path,
        """
        GO:
          states:
            S0:
              - when: abs(world.x) > LIMIT
                do: [report: DONE]
              - when: abs(world.x) <= LIMIT
                next: S1
            S1:
              - when: -min(world.x, 1.0) > 1.0
                do: [report: DONE]
              - when: max(-world.x, 0.0) < 3.0
                do: [report: ERROR]
        """,
    )
    front = compile_paths([directory])
    found = [(d.code, d.message) for d in front.diagnostics if d.code.startswith(("E5", "W5"))]
    assert [f for f in found if "GO S0" in f[1]] == [], found
    overlap = [m for code, m in found if code == "E501"]
    assert len(overlap) == 1 and "rules 1 and 2 of GO S1" in overlap[0], found
    assert not [f for f in found if f[0] == "W502"], found
    valuation = dict(
        (name, float(value))
        for name, value in re.findall(r"(world\.\w+)=(-?[\d.e-]+)", overlap[0].split("when ")[1])
    )
    x = valuation["world.x"]
    assert -min(x, 1.0) > 1.0 and max(-x, 0.0) < 3.0, (overlap[0], valuation)
