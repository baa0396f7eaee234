"""Fold: the value of an expression that reads only literals and constants.

The checker folds guards (W302, a rule that never fires; E111, a division by a constant 0;
E110, an int beyond 64 bits) and the analysis computes with the same operators.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping
from typing import Any

from .nodes import (
    MAX_DEPTH,
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

# ---------------------------------------------------------------- constant folding

# What each operator of the grammar computes (constant folding here, the analysis too).
ARITHMETIC: dict[str, Callable[[Any, Any], Any]] = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "//": operator.floordiv,
    "%": operator.mod,
}
COMPARISONS: dict[str, Callable[[Any, Any], bool]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
_FOLD_BUILTIN: dict[str, Callable[..., Any]] = {"abs": abs, "min": min, "max": max}


def fold(
    tree: Expr,
    constants: Mapping[str, bool | int | float],
    predicates: Mapping[str, Expr] | None = None,
) -> bool | int | float | None:
    """The value of an expression that reads only literals and constants (and predicates
    that do, when given), else None. Never raises: a division by 0 or an overflow is None."""
    try:
        value: bool | int | float | None = _fold(tree, constants, predicates or {}, 0)
        return value
    except (ArithmeticError, ValueError, RecursionError):
        return None


def _fold(e: Expr, constants: Mapping[str, Any], predicates: Mapping[str, Expr], depth: int) -> Any:
    if depth > 2 * MAX_DEPTH:  # a predicate chain folded in: bounded like the parser
        return None

    def inner(x: Expr) -> Any:
        return _fold(x, constants, predicates, depth + 1)

    match e:
        case Const():
            return e.value
        case Ref():
            return constants.get(e.name) if e.kind == RefKind.CONST else None
        case Call():
            return _fold_call(e, predicates, inner)
        case Unary():
            return _fold_unary(e.op, inner(e.operand))
        case Binary():
            left, right = inner(e.left), inner(e.right)
            return None if left is None or right is None else ARITHMETIC[e.op](left, right)
        case BoolOp():
            return _fold_bool(e, inner)
        case IfExp():
            test = inner(e.test)
            return None if test is None else inner(e.body if test else e.orelse)
        case Compare():
            return _fold_compare(e.ops, [inner(x) for x in (e.left, *e.comparators)])
    return None


def _fold_unary(op: str, value: Any) -> Any:
    if value is None:
        return None
    return (not value) if op == "not" else (-value if op == "-" else value)


def _fold_compare(ops: tuple[str, ...], operands: list[Any]) -> bool | None:
    """A chain of comparisons (`a < b <= c`): each pair, all of them."""
    if None in operands:
        return None
    pairs = zip(operands, operands[1:], ops, strict=False)
    return all(COMPARISONS[op](a, b) for a, b, op in pairs)


def _fold_call(e: Call, predicates: Mapping[str, Expr], inner: Callable[[Expr], Any]) -> Any:
    """A predicate's body folded where it is called; a builtin of folded arguments; a
    function is folded where it is declared, not here."""
    if e.kind == CallKind.PREDICATE:
        body = predicates.get(e.name)
        return None if body is None else inner(body)
    if e.kind == CallKind.FUNCTION:
        return None
    args = [inner(a) for a in e.args]
    return None if None in args else _FOLD_BUILTIN[e.name](*args)


def _fold_bool(e: BoolOp, inner: Callable[[Expr], Any]) -> bool | None:
    """`and`/`or` short-circuit on a decided operand: `or` is true as soon as one operand
    is, `and` false as soon as one is; unknown when an undecided operand could decide."""
    decided = e.op == "or"
    unknown = False
    for part in e.values:
        value = inner(part)
        if value is None:
            unknown = True
        elif bool(value) == decided:
            return decided
    return None if unknown else not decided
