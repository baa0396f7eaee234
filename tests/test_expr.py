"""Expressions (compiler/expressions/): print, re-parse and evaluate random typed trees.

Hypothesis generates typed trees over the whole expression grammar - literals, `and`/`or`/
`not`, comparisons (chains included) of numbers, booleans, statuses and subordinate
commands, `+ - * / // %`, unary `-`/`+`, `abs`/`min`/`max`, predicate calls, and names of
every kind (world fields, parameters, locals, constants, status names, `<sub>.status`,
`<sub>.command`, a subordinate's command names) - each typed by the rules written here.
Every tree is printed with `to_python`, and:

- re-parsing the spec form with `compile_expr` gives the same tree back, types included
  (a printer that drops parentheses, or a parser that types `int / int` as int, fails);
- the printed Python (the form generated code uses, `naming.attribute`) evaluates to what
  `evaluate` below - an evaluator of the tree written here - gives, ZeroDivisionError
  included, and to a value of the type the compiler claims;
- `to_python_conjunct` is one operand of `and`, as the single-rule fast path uses it.

EXPR_EXAMPLES (default 400) trees per property, the same ones every run; `make fuzz` runs
more, freshly random (FUZZ_RANDOM=1).
"""

from __future__ import annotations

import operator
import os
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from rcsgen.compiler.checks import naming
from rcsgen.compiler.diagnostics import Diagnostics, Span
from rcsgen.compiler.expressions import (
    Binary,
    BoolOp,
    Call,
    Compare,
    Const,
    Expr,
    Ref,
    RefKind,
    Scope,
    Unary,
    compile_expr,
    to_python,
    to_python_conjunct,
)
from rcsgen.compiler.types import BOOL, FLOAT, INT, STATUS, CommandOf, Type

EXAMPLES = int(os.environ.get("EXPR_EXAMPLES", "400"))
DERANDOMIZE = os.environ.get("FUZZ_RANDOM", "") == ""
SPAN = Span("expr.yaml", 1, 1)

STATUSES = ("NOT_READY", "EXECUTING", "DONE", "ERROR")
SUB_COMMANDS = {"s1": ("INIT", "HALT", "MOVE"), "s2": ("INIT", "HALT", "STOP", "PARK")}
CONSTANTS: dict[str, Any] = {"CB": True, "CI": 3, "CF": 2.5}
PREDICATES = ("ready", "busy")


def scope() -> Scope:
    return Scope(
        world={"wb": BOOL, "wi": INT, "wf": FLOAT, "unread": INT},
        world_access=frozenset({"wb", "wi", "wf"}),
        params={"pb": BOOL, "pi": INT, "pf": FLOAT},
        locals={"lb": BOOL, "li": INT, "lf": FLOAT},
        constants=CONSTANTS,
        predicates=frozenset(PREDICATES),
        subordinates={sub: frozenset(names) for sub, names in SUB_COMMANDS.items()},
    )


# Every name an expression can use, by type (the tree nodes `compile_expr` resolves them to).
NAMES: dict[Type, list[Ref]] = {
    kind: [
        Ref(kind, "world", f"w{str(kind)[0]}"),
        Ref(kind, "param", f"p{str(kind)[0]}"),
        Ref(kind, "local", f"l{str(kind)[0]}"),
        Ref(kind, "const", f"C{str(kind)[0].upper()}"),
    ]
    for kind in (BOOL, INT, FLOAT)
}
STATUS_TYPE = STATUS


def command_type(sub: str) -> Type:
    return CommandOf(sub)


# ---------------------------------------------------------------- typing rules (written here)


def binary_type(op: str, left: Type, right: Type) -> Type:
    """`int op int` is an int except for `/`; anything with a float (or `/`) is a float."""
    return INT if (left, right) == (INT, INT) and op != "/" else FLOAT


def call_type(args: tuple[Expr, ...]) -> Type:
    return FLOAT if any(a.type == FLOAT for a in args) else INT


# ---------------------------------------------------------------- random typed trees

NUMERIC = (INT, FLOAT)
ARITHMETIC = ("+", "-", "*", "/", "//", "%")
ORDERINGS = ("<", "<=", ">", ">=", "==", "!=")
EQUALITIES = ("==", "!=")

# Literals as the parser sees them: never negative (`-1` is unary minus applied to 1).
SMALL_INTS = st.integers(0, 3)
LITERALS = {
    BOOL: st.booleans(),
    INT: st.one_of(SMALL_INTS, SMALL_INTS, st.integers(0, 2**40)),
    FLOAT: st.one_of(
        st.sampled_from([0.0, 0.5, 1.0, 2.0, 2.5, 3.0]),
        st.floats(0.0, 1e6, allow_nan=False, allow_infinity=False),
    ),
}
LEAF_NAMES = {
    BOOL: st.sampled_from([*NAMES[BOOL], *(Call(BOOL, "predicate", p) for p in PREDICATES)]),
    INT: st.sampled_from(NAMES[INT]),
    FLOAT: st.sampled_from(NAMES[FLOAT]),
}
STATUS_OPERANDS = st.sampled_from(
    [Ref(STATUS_TYPE, "sub_status", "status", s) for s in SUB_COMMANDS]
    + [Ref(STATUS_TYPE, "status", name) for name in STATUSES]
)
COMMAND_OPERANDS = {
    sub: st.sampled_from(
        [Ref(command_type(sub), "sub_command", "command", sub)]
        + [Ref(command_type(sub), "sub_command_name", n, sub) for n in names]
    )
    for sub, names in SUB_COMMANDS.items()
}
BOOL_SHAPES = st.sampled_from(["not", "and", "or", "numbers", "booleans", "status", "command"])
NUMBER_SHAPES = st.sampled_from(["unary", "binary", "binary", "abs", "minmax"])
MIXED = st.sampled_from([(INT, FLOAT), (FLOAT, INT), (FLOAT, FLOAT)])
SIGNS = st.sampled_from(["-", "+"])
TYPES = st.sampled_from([BOOL, INT, FLOAT])
STOP = st.integers(0, 2)
COUNT = {n: st.integers(2, n) for n in (3, 4)}
POSITION = {n: st.integers(0, n) for n in range(4)}
COIN = st.booleans()
NUMBER_TYPES = st.sampled_from(NUMERIC)
SUBS = st.sampled_from(sorted(SUB_COMMANDS))
ORDER_OPS = st.sampled_from(ORDERINGS)
EQUALITY_OPS = st.sampled_from(EQUALITIES)
INT_OPS = st.sampled_from([o for o in ARITHMETIC if o != "/"])
FLOAT_OPS = st.sampled_from([*ARITHMETIC, "/", "/"])  # `/` of ints is a float
MIN_MAX = st.sampled_from(["min", "max"])


def build(draw: st.DrawFn, kind: Type, depth: int) -> Expr:
    """A random tree of type `kind` (BOOL, INT or FLOAT), at most `depth` operators deep.

    Draws only from the strategies above (built once): a tree costs one draw per choice."""
    if depth <= 0 or draw(STOP) == 0:
        if draw(COIN):
            return Const(kind, draw(LITERALS[kind]))
        return draw(LEAF_NAMES[kind])
    below = depth - 1

    def number() -> Expr:
        return build(draw, draw(NUMBER_TYPES), below)

    if kind == BOOL:
        shape = draw(BOOL_SHAPES)
        if shape == "not":
            return Unary(BOOL, "not", build(draw, BOOL, below))
        if shape in ("and", "or"):
            values = [build(draw, BOOL, below) for _ in range(draw(COUNT[3]))]
            return BoolOp(BOOL, shape, tuple(values))
        if shape == "numbers":
            operands = [number() for _ in range(draw(COUNT[4]))]
            ops = [draw(ORDER_OPS) for _ in operands[1:]]
            return Compare(BOOL, operands[0], tuple(ops), tuple(operands[1:]))
        if shape == "booleans":
            operands = [build(draw, BOOL, below) for _ in range(draw(COUNT[3]))]
        elif shape == "status":
            operands = [draw(STATUS_OPERANDS) for _ in range(draw(COUNT[3]))]
        else:  # a subordinate's command, its command names (or itself), at least one itself
            sub = draw(SUBS)
            operands = [draw(COMMAND_OPERANDS[sub]) for _ in range(draw(COUNT[3]) - 1)]
            mine = Ref(command_type(sub), "sub_command", "command", sub)
            operands.insert(draw(POSITION[len(operands)]), mine)
        ops = [draw(EQUALITY_OPS) for _ in operands[1:]]
        return Compare(BOOL, operands[0], tuple(ops), tuple(operands[1:]))
    shape = draw(NUMBER_SHAPES)
    if shape == "unary":
        return Unary(kind, draw(SIGNS), build(draw, kind, below))
    if shape == "binary":
        if kind == INT:
            op = draw(INT_OPS)
            types = (INT, INT)
        else:
            op = draw(FLOAT_OPS)
            types = draw(MIXED)
            if op == "/" and draw(COIN):
                types = (INT, INT)
        left, right = build(draw, types[0], below), build(draw, types[1], below)
        assert binary_type(op, left.type, right.type) == kind
        return Binary(kind, op, left, right)
    if shape == "abs":
        return Call(kind, "builtin", "abs", (build(draw, kind, below),))
    count = draw(COUNT[3])
    args = [build(draw, INT, below) if kind == INT else number() for _ in range(count)]
    if call_type(tuple(args)) != kind:
        args[draw(POSITION[count - 1])] = build(draw, kind, below)
    return Call(kind, "builtin", draw(MIN_MAX), tuple(args))


@st.composite
def trees(draw: st.DrawFn, kind: Type | None = None, depth: int = 4) -> Expr:
    return build(draw, kind or draw(TYPES), depth)


def comparison(draw: st.DrawFn) -> Expr:
    """A chain comparing small numeric trees: operands are often equal, so that `<` and `<=`
    (or `>` and `>=`) differ in value, not only in text."""
    operands = [build(draw, draw(NUMBER_TYPES), 1) for _ in range(draw(COUNT[3]))]
    ops = [draw(ORDER_OPS) for _ in operands[1:]]
    return Compare(BOOL, operands[0], tuple(ops), tuple(operands[1:]))


@st.composite
def any_trees(draw: st.DrawFn) -> Expr:
    """Trees of any type; one in six a comparison chain of small trees."""
    if draw(STOP) == 0 and draw(COIN):
        return comparison(draw)
    return build(draw, draw(TYPES), 4)


@st.composite
def guards(draw: st.DrawFn) -> Expr:
    """Boolean trees, half with `or` at the top: the operand `and` must parenthesise."""
    if draw(COIN):
        return BoolOp(BOOL, "or", tuple(build(draw, BOOL, 3) for _ in range(draw(COUNT[3]))))
    return build(draw, BOOL, 4)


# ---------------------------------------------------------------- valuations and evaluation

Key = tuple[str, str, str]  # (kind, name, owner) of a Ref


def key(ref: Ref) -> Key:
    return (ref.kind, ref.name, ref.owner)


# Values chosen so that operands are often equal (an `<` printed as `<=` shows) and
# divisors often zero (ZeroDivisionError must agree too).
int_values = st.integers(-1, 3)
float_values = st.sampled_from([-1.0, 0.0, 0.5, 1.0, 2.0, 2.5])
status_values = st.sampled_from(STATUSES)
command_values = {sub: st.sampled_from(names) for sub, names in SUB_COMMANDS.items()}


@st.composite
def valuations(draw: st.DrawFn) -> dict[Key, Any]:
    """A value for every variable name: world fields, parameters, locals, predicates,
    subordinates' statuses and last commands (statuses and commands by name)."""
    values: dict[Key, Any] = {}
    for kind, refs in NAMES.items():
        strategy = {BOOL: COIN, INT: int_values, FLOAT: float_values}[kind]
        for ref in refs:
            if ref.kind != "const":
                values[key(ref)] = draw(strategy)
    for name in PREDICATES:
        values[("predicate", name, "")] = draw(COIN)
    for sub in SUB_COMMANDS:
        values[("sub_status", "status", sub)] = draw(status_values)
        values[("sub_command", "command", sub)] = draw(command_values[sub])
    return values


_ARITH: dict[str, Callable[[Any, Any], Any]] = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "//": operator.floordiv,
    "%": operator.mod,
}
_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}


def evaluate(e: Expr, values: dict[Key, Any]) -> Any:
    """The value of a tree, as Python's evaluation order defines it: `and`, `or` and
    comparison chains stop at the first operand that decides them; a zero divisor raises."""
    if isinstance(e, Const):
        return e.value
    if isinstance(e, Ref):
        if e.kind == "const":
            return CONSTANTS[e.name]
        if e.kind in ("status", "sub_command_name"):
            return e.name  # a status or command name stands for itself
        return values[key(e)]
    if isinstance(e, Call):
        if e.kind == "predicate":
            return values[("predicate", e.name, "")]
        args = [evaluate(a, values) for a in e.args]
        return {"abs": abs, "min": min, "max": max}[e.name](*args)
    if isinstance(e, Unary):
        value = evaluate(e.operand, values)
        return {"not": operator.not_, "-": operator.neg, "+": operator.pos}[e.op](value)
    if isinstance(e, Binary):
        left, right = evaluate(e.left, values), evaluate(e.right, values)
        if e.op in ("/", "//", "%") and right == 0:
            raise ZeroDivisionError(e.op)
        return _ARITH[e.op](left, right)
    if isinstance(e, BoolOp):
        for value in e.values:
            if evaluate(value, values) != (e.op == "and"):
                return e.op == "or"
        return e.op == "and"
    if isinstance(e, Compare):
        left = evaluate(e.left, values)
        for op, operand in zip(e.ops, e.comparators, strict=True):
            right = evaluate(operand, values)
            if not _COMPARE[op](left, right):
                return False
            left = right
        return True
    raise TypeError(e)


def outcome(compute: Callable[[], Any]) -> tuple[str, Any]:
    try:
        return ("value", compute())
    except ZeroDivisionError:
        return ("raises", "ZeroDivisionError")


def spec_name(ref: Ref) -> str:
    """How a spec writes a resolved name."""
    if ref.kind == "world":
        return f"world.{ref.name}"
    if ref.kind in ("sub_status", "sub_command"):
        return f"{ref.owner}.{ref.name}"
    return ref.name


def controller(values: dict[Key, Any]) -> tuple[dict[str, Any], SimpleNamespace]:
    """The names generated code evaluates a guard with: module globals and `self`."""
    module: dict[str, Any] = {"__builtins__": {}, "abs": abs, "min": min, "max": max}
    module.update(CONSTANTS)
    module.update({name: code for code, name in enumerate(STATUSES)})
    me = SimpleNamespace()
    for sub, names in SUB_COMMANDS.items():
        for code, name in enumerate(names, start=1):
            module[naming.sub_command_const(sub, name)] = code
        status = values[("sub_status", "status", sub)]
        setattr(me, f"{sub}_status", STATUSES.index(status))
        setattr(me, f"{sub}_command", names.index(values[("sub_command", "command", sub)]) + 1)
    for (kind, name, owner), value in values.items():
        if kind in ("world", "param", "local"):
            attr = naming.attribute(Ref("", kind, name, owner))
            setattr(me, attr.removeprefix("self."), value)
        elif kind == "predicate":
            attr = naming.attribute(Ref(BOOL, "predicate", name))
            setattr(me, attr.removeprefix("self."), lambda value=value: value)
    module["self"] = me
    return module, me


def has_claimed_type(value: Any, kind: Type) -> bool:
    if kind == BOOL:
        return type(value) is bool
    if kind == INT:
        return type(value) is int
    return type(value) in (int, float)  # min(1, 2.5) is the int 1: still a number


# ---------------------------------------------------------------- the properties

PROPERTY = settings(max_examples=EXAMPLES, derandomize=DERANDOMIZE, database=None, deadline=None)

WI, LI, PI = NAMES[INT][0], NAMES[INT][2], NAMES[INT][1]
WF, LB, WB = NAMES[FLOAT][0], NAMES[BOOL][2], NAMES[BOOL][0]
READY = Call(BOOL, "predicate", "ready")
DEFAULTS: dict[Key, Any] = {
    **{
        key(ref): {BOOL: False, INT: 0, FLOAT: 0.0}[kind]
        for kind, refs in NAMES.items()
        for ref in refs
        if ref.kind != "const"
    },
    **{("predicate", name, ""): False for name in PREDICATES},
    **{("sub_status", "status", sub): "DONE" for sub in SUB_COMMANDS},
    **{("sub_command", "command", sub): "INIT" for sub in SUB_COMMANDS},
}


def given_values(changes: dict[Key, Any]) -> dict[Key, Any]:
    return {**DEFAULTS, **changes}


def refused_constant(diags: Diagnostics) -> bool:
    """The checker refused the tree for a constant it can see: a divisor that is always 0
    (E111) or an int beyond int64 (E110). Such a tree is never emitted."""
    return bool(diags.items) and all(d.code in ("E110", "E111") for d in diags.items)


EQUAL = given_values({("world", "wi", ""): 2, ("local", "li", ""): 2, ("param", "pi", ""): 2})


@PROPERTY
@given(tree=any_trees())
# `wi - (li - pi)`: the right operand keeps its parentheses.
@example(tree=Binary(INT, "-", WI, Binary(INT, "-", LI, PI)))
@example(tree=Binary(FLOAT, "/", WI, Binary(FLOAT, "*", LI, WF)))
@example(tree=Binary(FLOAT, "/", WI, LI))  # `int / int` is a float
@example(tree=Compare(BOOL, WI, ("<",), (LI,)))  # `<` is not `<=`
def test_printed_tree_parses_back_to_itself(tree: Expr) -> None:
    """to_python, then compile_expr, gives the same typed tree; nothing is reported (but
    for a constant divisor of 0 or a constant beyond int64, which the checker refuses)."""
    text = to_python(tree, spec_name)
    diags = Diagnostics()
    back = compile_expr(text, SPAN, scope(), diags)
    assume(not refused_constant(diags))
    assert [d.render() for d in diags] == [], text
    assert back == tree, f"`{text}` parsed back as\n  {back}\nnot\n  {tree}"


@PROPERTY
@given(tree=any_trees(), values=valuations())
@example(tree=Binary(INT, "-", WI, Binary(INT, "-", LI, PI)), values=EQUAL)
@example(tree=Compare(BOOL, WI, ("<",), (LI,)), values=EQUAL)
@example(tree=Compare(BOOL, WI, ("<", "<="), (LI, PI)), values=EQUAL)
@example(tree=Binary(FLOAT, "/", WI, LI), values={**EQUAL, ("world", "wi", ""): 3})
def test_printed_python_evaluates_like_the_tree(tree: Expr, values: dict[Key, Any]) -> None:
    """Generated code's form of the tree computes what the tree means, of the claimed type."""
    refused = Diagnostics()
    compile_expr(to_python(tree, spec_name), SPAN, scope(), refused)
    assume(not refused_constant(refused))
    text = to_python(tree, naming.attribute)
    module, _ = controller(values)
    code = compile(text, "<guard>", "eval")
    got = outcome(lambda: eval(code, module))
    want = outcome(lambda: evaluate(tree, values))
    assert got == want, f"`{text}`"
    claimed = compile_expr(to_python(tree, spec_name), SPAN, scope(), Diagnostics())
    assert claimed is not None
    if got[0] == "value":
        assert has_claimed_type(got[1], claimed.type), f"`{text}` is {got[1]!r}, not {claimed.type}"


@PROPERTY
@given(tree=guards(), values=valuations(), gate=COIN)
@example(
    tree=BoolOp(BOOL, "or", (READY, LB)),
    values=given_values({("predicate", "ready", ""): True}),
    gate=False,
)
@example(
    tree=BoolOp(BOOL, "or", (WB, LB)), values=given_values({("local", "lb", ""): True}), gate=False
)
def test_conjunct_is_one_operand_of_and(tree: Expr, values: dict[Key, Any], gate: bool) -> None:
    """`gate and <conjunct>` is `gate and (tree)`: the single-rule fast path's guard form."""
    conjunct = to_python_conjunct(tree, naming.attribute)
    module, me = controller(values)
    me.gate = gate
    code = compile(f"self.gate and {conjunct}", "<guard>", "eval")
    got = outcome(lambda: eval(code, module))
    want = outcome(lambda: gate and evaluate(tree, values))
    assert got == want, f"`self.gate and {conjunct}`"


# ---------------------------------------------------------------- the printer's text


@pytest.mark.parametrize(
    "source",
    [
        "world.wi - (li - pi)",
        "world.wi - li - pi",
        "world.wi / (li * pi)",
        "-(world.wi + li)",
        "-world.wi * li",
        "not (world.wb and lb)",
        "(world.wb or lb) and pb",
        "world.wb or (lb and pb) or not pb",
        "world.wb == (lb == pb)",
        "(li < pi) == world.wb",
        "li < pi <= world.wi",
        "world.wi + li < pi * 2",
        "s1.command == MOVE",
        "abs(li - 2) > min(pi, world.wf, 2.5)",
    ],
)
def test_canonical_source_prints_as_written(source: str) -> None:
    """Text already in the printer's form comes back unchanged (only needed parentheses,
    and those around an `and` inside an `or`)."""
    tree = compile_expr(source, SPAN, scope(), Diagnostics())
    assert tree is not None
    assert to_python(tree, spec_name) == source


@pytest.mark.parametrize(
    ("source", "printed"),
    [
        ("world.wb and lb or pb", "(world.wb and lb) or pb"),
        ("world.wb or lb and not pb", "world.wb or (lb and not pb)"),
        ("not world.wb or li < 2 or pb", "not world.wb or li < 2 or pb"),
    ],
)
def test_an_and_inside_an_or_is_printed_in_parentheses(source: str, printed: str) -> None:
    """Python binds `and` tighter than `or`; the generated code shows it rather than asking
    a reviewer to recall it (ruff's RUF021); a `not` or a comparison needs none."""
    tree = compile_expr(source, SPAN, scope(), Diagnostics())
    assert tree is not None
    assert to_python(tree, spec_name) == printed


@pytest.mark.parametrize(
    ("source", "kind"),
    [
        ("li / pi", FLOAT),
        ("li // pi", INT),
        ("li % pi", INT),
        ("li * pi", INT),
        ("li + world.wf", FLOAT),
        ("li // world.wf", FLOAT),
        ("abs(li)", INT),
        ("max(li, 2.0)", FLOAT),
        ("-li", INT),
    ],
)
def test_arithmetic_types(source: str, kind: Type) -> None:
    tree = compile_expr(source, SPAN, scope(), Diagnostics())
    assert tree is not None and tree.type == kind


def test_an_integer_division_cannot_be_stored_in_an_integer() -> None:
    """`int / int` is a float: assigning it to an int is a type error, not a run-time crash."""
    diags = Diagnostics()
    assert compile_expr("li / pi", SPAN, scope(), diags, INT) is None
    assert [(d.code, d.message) for d in diags] == [("E107", "expected an integer, got a number")]
    assert compile_expr("li // pi", SPAN, scope(), Diagnostics(), INT) is not None


@pytest.mark.parametrize(
    ("source", "col", "code", "message"),
    [
        ("pb and ~li > 0", 8, "E102", "bitwise operators are not allowed"),
        ("pb and li ** 2 > 0", 8, "E102", "only + - * / // % are allowed"),
        ("pb and li is pi", 8, "E102", "only == != < <= > >= comparisons are allowed"),
        ("pb and pb < lb", 13, "E107", "cannot compare bool with bool using `<`"),  # at `lb`
        ("pb and print(li)", 8, "E106", "`print` is not a declared predicate"),
        ("pb and ready(1)", 8, "E107", "predicate `ready` takes no arguments"),
        ("pb and abs(li, pi) > 0", 8, "E107", "wrong number of arguments to `abs`"),
    ],
)
def test_a_rejected_operation_is_reported_where_it_is(
    source: str, col: int, code: str, message: str
) -> None:
    """The diagnostic names the offending operation and its column, not the expression's."""
    diags = Diagnostics()
    assert compile_expr(source, Span("expr.yaml", 3, 1), scope(), diags) is None
    assert [(d.span, d.code, d.message) for d in diags] == [
        (Span("expr.yaml", 3, col), code, message)
    ]


# ---------------------------------------------------------------- folding and/or (mutants)


@pytest.mark.parametrize(
    ("op", "first", "want"),
    [
        ("and", False, False),  # decided by a false operand, whatever the other
        ("and", True, None),  # true and unknown: unknown
        ("or", True, True),  # decided by a true operand
        ("or", False, None),  # false or unknown: unknown
    ],
)
def test_and_or_fold_short_circuit_on_the_deciding_operand(op: str, first: bool, want: object):
    """`and` is decided by a false operand, `or` by a true one, in either position: swapping
    the two (a seeded one-line bug) or ignoring an unknown operand is caught here."""
    from rcsgen.compiler.expressions import fold

    unknown = Ref(BOOL, RefKind.WORLD, "wb")
    for values in ((Const(BOOL, first), unknown), (unknown, Const(BOOL, first))):
        assert fold(BoolOp(BOOL, op, values), {}) is want, (op, values)
    both = (Const(BOOL, first), Const(BOOL, not first))
    assert fold(BoolOp(BOOL, op, both), {}) is (op == "or")


# ---------------------------------------------------------------- folding (mutants)


@pytest.mark.parametrize(
    ("source", "want"),
    [
        ("CI < 4 <= CI + 1", True),  # a chain: every pair holds
        ("CI < 4 < CI", False),  # the second pair fails
        ("1 <= CI == 3 != 2 > 1 >= 1", True),
        ("CI > 3", False),
        ("not CB", False),
        ("-CI", -3),
        ("+CF", 2.5),
        ("CI // 2 + CI % 2 * 10 - 1 / 4", 10.75),
        ("abs(-CI) + min(CI, 1) + max(CF, 0.5)", 6.5),
        ("CI if CB else 0", 3),
        ("CI if not CB else 0", 0),
        ("ready() and CB", True),  # a predicate's folded body stands for its call
        ("busy() or CB", True),  # no body: `or` is decided by its true operand
        ("busy() and CB", None),
        ("CI < world.wi", None),  # a world field is not known before the run
        ("CI > 0 if world.wb else CI < 0", None),
        ("-world.wi", None),
        ("world.wi + 1 > 0", None),
        ("abs(world.wi) > 0", None),
    ],
)
def test_fold_gives_the_value_of_what_reads_only_constants(source: str, want: object) -> None:
    from rcsgen.compiler.expressions import fold

    diags = Diagnostics()
    tree = compile_expr(source, Span("expr.yaml", 1, 1), scope(), diags)
    assert tree is not None, list(diags)
    ready = Compare(BOOL, Const(INT, 1), ("<",), (Const(INT, 2),))
    value = fold(tree, CONSTANTS, {"ready": ready})
    assert value == want and type(value) is type(want), (source, value)


def test_fold_reads_a_const_ref_from_the_constants_not_a_field_of_its_name() -> None:
    from rcsgen.compiler.expressions import fold

    for kind in (RefKind.WORLD, RefKind.PARAM, RefKind.LOCAL):
        assert fold(Ref(INT, kind, "CI"), CONSTANTS) is None, kind  # `world.CI`, not `CI`
    assert fold(Ref(INT, RefKind.CONST, "CI"), CONSTANTS) == 3


@pytest.mark.parametrize("op", ["/", "//", "%"])
def test_fold_of_a_division_by_zero_is_no_value_not_an_error(op: str) -> None:
    from rcsgen.compiler.expressions import fold

    zero = Binary(INT, "-", Ref(INT, RefKind.CONST, "CI"), Const(INT, 3))
    assert fold(Binary(FLOAT, op, Const(INT, 1), zero), CONSTANTS) is None
    assert (
        fold(Binary(FLOAT, op, Const(INT, 7), Const(INT, 2)), CONSTANTS)
        == {"/": 3.5, "//": 3, "%": 1}[op]
    )


def test_fold_follows_a_chain_of_predicates_and_gives_up_on_a_too_deep_one() -> None:
    """Not at the exact bound: how deep Python lets it go depends on the stack it runs on
    (mutmut's trampolines double it); beyond the bound it is no value, never an error."""
    from rcsgen.compiler.expressions import MAX_DEPTH, CallKind, fold

    def chain(links: int) -> dict[str, Expr]:
        bodies: dict[str, Expr] = {
            f"p{n}": Call(BOOL, CallKind.PREDICATE, f"p{n + 1}") for n in range(links)
        }
        bodies[f"p{links}"] = Const(BOOL, True)
        return bodies

    top = Call(BOOL, CallKind.PREDICATE, "p0")
    assert fold(top, {}, chain(MAX_DEPTH // 2)) is True
    assert fold(top, {}, chain(3 * MAX_DEPTH)) is None


def test_predicates_given_to_the_printer_are_printed_where_they_are_called() -> None:
    """A guard calling a predicate is printed with the predicate's expression in its place
    (a unit in parentheses, as the call was; predicates it calls likewise); a predicate the
    printer was not given stays a method call."""
    from rcsgen.compiler.expressions import CallKind

    loose = Compare(BOOL, Ref(FLOAT, RefKind.WORLD, "loose_coal"), (">",), (Const(FLOAT, 4.0),))
    halted = Ref(BOOL, RefKind.WORLD, "halted")
    bodies: dict[str, Expr] = {
        "too_much": loose,
        "stop": BoolOp(BOOL, "or", (Call(BOOL, CallKind.PREDICATE, "too_much"), halted)),
    }
    guard = BoolOp(
        BOOL,
        "and",
        (
            Unary(BOOL, "not", Call(BOOL, CallKind.PREDICATE, "stop")),
            Ref(BOOL, RefKind.WORLD, "on"),
        ),
    )
    assert to_python(guard, naming.attribute, bodies) == (
        "not ((self.world_loose_coal > 4.0) or self.world_halted) and self.world_on"
    )
    assert to_python(guard, naming.attribute) == "not self.stop() and self.world_on"
    assert to_python_conjunct(
        Call(BOOL, CallKind.PREDICATE, "too_much"), naming.attribute, bodies
    ) == ("(self.world_loose_coal > 4.0)")


# ---------------------------------------------------------------- the printer's parentheses


def test_printer_keeps_only_the_parentheses_python_needs() -> None:
    """Each operator's precedence, from `if` (lowest) to a unary minus: parentheses that
    change nothing are dropped, those that do are kept, so the generated code reads as a
    person would write it and means what the spec said."""
    printed = {
        "(world.wi + li) < (pi * 2)": "world.wi + li < pi * 2",
        "(world.wi - li) >= (pi / 2)": "world.wi - li >= pi / 2",
        "((world.wb and lb) or pb)": "(world.wb and lb) or pb",  # kept for the reader
        "not (lb and pb)": "not (lb and pb)",
        "not (li < pi)": "not li < pi",
        "(not lb) and (li < pi)": "not lb and li < pi",
        "(li if lb else pi) + 1 > 0": "(li if lb else pi) + 1 > 0",
        "li if (lb if pb else lb) else pi": "li if (lb if pb else lb) else pi",
        "li + (pi * 2) > li - (pi * 2)": "li + pi * 2 > li - pi * 2",
        "(li * (-pi)) + (li // (-pi)) + (li % (-pi)) > li / (-pi)": (
            "li * -pi + li // -pi + li % -pi > li / -pi"
        ),
        "(-li) * pi > -(li * pi)": "-li * pi > -(li * pi)",
        "abs((li - 2)) > 0": "abs(li - 2) > 0",
        "(lb == pb) != (li <= pi)": "(lb == pb) != (li <= pi)",
        "(+li) > 0": "+li > 0",
    }
    for source, want in printed.items():
        tree = compile_expr(source, SPAN, scope(), Diagnostics())
        assert tree is not None, source
        assert to_python(tree, spec_name) == want, source


@pytest.mark.parametrize(
    ("value", "fits"),
    [(-(2**63), True), (2**63 - 1, True), (-(2**63) - 1, False), (2**63, False), (True, True)],
)
def test_an_int_fits_when_eight_bytes_hold_it_and_not_one_past(value: int, fits: bool) -> None:
    """The int64 bounds themselves are values (`q` packs them); one past either is E110."""
    from rcsgen.compiler.expressions.nodes import int_range_problem

    assert (int_range_problem(value) == "") is fits
