"""Expression nodes: the typed tree every stage after the checker reads, and the walks over it.

An expression is a frozen tree of typed nodes (`Const`, `Ref`, `Call`, `Unary`, `Binary`,
`BoolOp`, `Compare`, `IfExp`); a resolved name says what it is (`RefKind`), a call what it
calls (`CallKind`). Built by `resolve`, folded by `fold`, printed as Python by `printer`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from ...runtime.contract import text_problem
from ..diagnostics import number_shown
from ..types import BOOL, INT, Enum, Str, Type


class RefKind(StrEnum):
    """What a resolved name is (`Ref.kind`); `owner` is the subordinate for the SUB_* kinds
    and the plan for PLAN. TIME and HELD are named by no spec text: the checker makes them
    from a rule's `after:` and `for:`. PREDICATE and FUNCTION name a callee when printed."""

    WORLD = "world"
    PARAM = "param"
    LOCAL = "local"
    CONST = "const"
    STATUS = "status"  # a status name: NOT_READY, EXECUTING, DONE, ERROR
    SUB_STATUS = "sub_status"
    SUB_COMMAND = "sub_command"
    SUB_COMMAND_NAME = "sub_command_name"
    SUB_RESULT = "sub_result"  # `<sub>.result.<name>`
    SUB_REASON = "sub_reason"  # `<sub>.reason`
    SUB_REASON_NAME = "sub_reason_name"
    PLAN = "plan"  # `<plan>.<name>`: a step field or one of PLAN_PROPERTIES
    TIME = "time"  # the cycles spent in the current state, an int
    HELD = "held"  # the cycles a `for:` rule's `when` has held, an int; `name` its counter
    ARG = "arg"  # a parameter of a function's body
    LET = "let"
    PREDICATE = "predicate"
    FUNCTION = "function"


class CallKind(StrEnum):
    """What a call calls (`Call.kind`)."""

    PREDICATE = "predicate"
    BUILTIN = "builtin"
    FUNCTION = "function"


STATUS_NAMES = ("NOT_READY", "EXECUTING", "DONE", "ERROR")
BUILTINS = ("abs", "min", "max")
MAX_DEPTH = 100  # nesting levels of an expression tree (each operator, call, name, ...)
INT_MIN, INT_MAX = -(2**63), 2**63 - 1  # an int is stored in 8 bytes (struct code `q`)


def int_range_problem(value: object) -> str:
    """'' when `value` is not an int beyond int64, else the message of E110."""
    if isinstance(value, bool) or not isinstance(value, int) or INT_MIN <= value <= INT_MAX:
        return ""
    return (
        f"integer {number_shown(value)} is out of range: an int is 64-bit ({INT_MIN} to {INT_MAX})"
    )


INT_RANGE_HINT = "use a smaller number, or a float if the value is not a count"


def text_problem_of(value: object, kind: Str) -> str:
    """'' when `value` is a text that fits string type `kind`, else what is wrong with it."""
    return text_problem(value, kind.size)


# The reasons every controller that declares some has: none given, and a subordinate's
# process lost (the runtime's safe state, `error_num` 1: rcs/loop.py LOST_SUBORDINATE).
BUILTIN_REASONS = ("NONE", "LOST")

# What every plan has besides its step fields (`route.step`, ...), and their types: the
# current step (from 0), the number of steps, past the last step, the replans left.
PLAN_PROPERTIES: dict[str, Type] = {"step": INT, "steps": INT, "done": BOOL, "replans_left": INT}


# ---------------------------------------------------------------- typed tree


@dataclass(frozen=True)
class Expr:
    """A typed expression node."""

    type: Type


@dataclass(frozen=True)
class Const(Expr):
    """A literal: a bool, an int, a float, a string, or an enumeration's value (its index,
    `type` naming the enumeration)."""

    value: bool | int | float | str


@dataclass(frozen=True)
class Ref(Expr):
    """A resolved name, of a kind (RefKind)."""

    kind: RefKind
    name: str
    owner: str = ""


@dataclass(frozen=True)
class Call(Expr):
    """A call of a declared predicate, a function or a builtin."""

    kind: CallKind
    name: str
    args: tuple[Expr, ...] = ()


@dataclass(frozen=True)
class Unary(Expr):
    op: str  # "not", "-", "+"
    operand: Expr


@dataclass(frozen=True)
class Binary(Expr):
    op: str  # + - * / // %
    left: Expr
    right: Expr


@dataclass(frozen=True)
class BoolOp(Expr):
    op: str  # "and", "or"
    values: tuple[Expr, ...]


@dataclass(frozen=True)
class Compare(Expr):
    left: Expr
    ops: tuple[str, ...]
    comparators: tuple[Expr, ...]


@dataclass(frozen=True)
class IfExp(Expr):
    """`body if test else orelse`: both values of one type (int and float make a float)."""

    test: Expr
    body: Expr
    orelse: Expr


def walk(expr: Expr) -> Iterator[Expr]:
    """Every node of `expr`, each before its operands, in reading order."""
    stack = [expr]
    pop, extend, operands = stack.pop, stack.extend, _OPERANDS.get
    while stack:
        node = pop()
        yield node
        reversed_operands = operands(type(node))  # (the trees' node classes have no subclasses)
        if reversed_operands is not None:
            extend(reversed_operands(node))


# Each node class with operands -> its operands, last first (a stack pops them in order);
# looked up by exact class (walk was ~10 % of the front end's profile with a chain of
# isinstance tests for every node).
_OPERANDS: dict[type[Expr], Callable[[Any], tuple[Expr, ...]]] = {
    Call: lambda n: n.args[::-1],
    Unary: lambda n: (n.operand,),
    Binary: lambda n: (n.right, n.left),
    BoolOp: lambda n: n.values[::-1],
    Compare: lambda n: (*n.comparators[::-1], n.left),
    IfExp: lambda n: (n.orelse, n.body, n.test),
}


def refs(expr: Expr) -> list[Ref]:
    """Every resolved name in `expr`, in reading order."""
    return [node for node in walk(expr) if isinstance(node, Ref)]


def enum_constants(expr: Expr) -> list[tuple[str, int]]:
    """Every enumeration value `expr` names, as (value name, index), in reading order."""
    return [
        (node.type.values[int(node.value)], int(node.value))
        for node in walk(expr)
        if isinstance(node, Const) and isinstance(node.type, Enum)
    ]


def substitute(tree: Expr, values: Mapping[tuple[RefKind, str], Expr]) -> Expr:
    """`tree` with each name `(kind, name)` in `values` replaced by its tree: a function's
    body with its arguments, a guard with its table's `let` values (for the analysis)."""
    if isinstance(tree, Ref):
        return values.get((tree.kind, tree.name), tree)
    if isinstance(tree, Call):
        args = tuple(substitute(a, values) for a in tree.args)
        return Call(tree.type, tree.kind, tree.name, args)
    if isinstance(tree, Unary):
        return Unary(tree.type, tree.op, substitute(tree.operand, values))
    if isinstance(tree, Binary):
        return Binary(
            tree.type, tree.op, substitute(tree.left, values), substitute(tree.right, values)
        )
    if isinstance(tree, BoolOp):
        return BoolOp(tree.type, tree.op, tuple(substitute(v, values) for v in tree.values))
    if isinstance(tree, Compare):
        comparators = tuple(substitute(c, values) for c in tree.comparators)
        return Compare(tree.type, substitute(tree.left, values), tree.ops, comparators)
    if isinstance(tree, IfExp):
        return IfExp(
            tree.type,
            substitute(tree.test, values),
            substitute(tree.body, values),
            substitute(tree.orelse, values),
        )
    return tree
