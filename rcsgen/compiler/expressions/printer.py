"""Printer: a typed tree -> its Python text, parenthesised only where Python needs it.

`name_of` says what each resolved name is in the generated module (`naming.attribute`);
`predicates` (name -> tree), when given, are printed where they are called, as their
expression, instead of as a method call: a guard is tried every cycle, and a call costs
more than the comparison it makes (about 5 % of co's cycle; bench/prototypes/ablation.py).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from ..types import BOOL, Enum
from .nodes import Binary, BoolOp, Call, CallKind, Compare, Const, Expr, IfExp, Ref, RefKind, Unary

# ---------------------------------------------------------------- printing

_PRECEDENCE = {"if": 0, "or": 1, "and": 2, "not": 3, "cmp": 4, "+": 5, "-": 5}
_PRECEDENCE.update({"*": 6, "/": 6, "//": 6, "%": 6, "neg": 7, "atom": 9})


def to_python(
    expr: Expr, name_of: Callable[[Ref], str], predicates: Mapping[str, Expr] | None = None
) -> str:
    """Python source for a typed tree; `name_of` maps each resolved name to its target text,
    `predicates` are printed inline where they are called."""
    return _Printer(name_of, predicates).text(expr)[0]


def to_python_conjunct(
    expr: Expr, name_of: Callable[[Ref], str], predicates: Mapping[str, Expr] | None = None
) -> str:
    """Python source for `expr` as one operand of `and` (parenthesised only if it needs it)."""
    return _Printer(name_of, predicates).wrap(expr, _PRECEDENCE["and"])


def to_python_and_conjunct(
    expr: Expr, name_of: Callable[[Ref], str], predicates: Mapping[str, Expr] | None = None
) -> tuple[str, str]:
    """`to_python` and `to_python_conjunct` of `expr`, printed once."""
    text, level = _Printer(name_of, predicates).text(expr)
    return text, f"({text})" if level < _PRECEDENCE["and"] else text


class _Printer:
    def __init__(self, name_of: Callable[[Ref], str], predicates: Mapping[str, Expr] | None):
        self.name_of = name_of
        self.predicates = predicates or {}

    def wrap(self, expr: Expr, minimum: int) -> str:
        text, level = self.text(expr)
        return f"({text})" if level < minimum else text

    def text(self, expr: Expr) -> tuple[str, int]:
        atom = _PRECEDENCE["atom"]
        if isinstance(expr, Const):
            if isinstance(expr.type, Enum):  # a module constant of the value's index
                return expr.type.values[int(expr.value)], atom
            return repr(expr.value), atom
        if isinstance(expr, Ref):
            return self.name_of(expr), atom
        if isinstance(expr, Call):
            if expr.kind == CallKind.PREDICATE and expr.name in self.predicates:
                # a unit, in parentheses, as its call was (no cycle of predicates: E229)
                return f"({self.text(self.predicates[expr.name])[0]})", atom
            args = ", ".join(self.wrap(a, 0) for a in expr.args)
            callee = expr.name
            if expr.kind == CallKind.PREDICATE:
                callee = self.name_of(Ref(BOOL, RefKind.PREDICATE, expr.name))
            elif expr.kind == CallKind.FUNCTION:
                callee = self.name_of(Ref(expr.type, RefKind.FUNCTION, expr.name))
            return f"{callee}({args})", atom
        if isinstance(expr, Unary):
            if expr.op == "not":
                return f"not {self.wrap(expr.operand, _PRECEDENCE['not'])}", _PRECEDENCE["not"]
            return f"{expr.op}{self.wrap(expr.operand, _PRECEDENCE['neg'])}", _PRECEDENCE["neg"]
        if isinstance(expr, Binary):
            level = _PRECEDENCE[expr.op]
            left = self.wrap(expr.left, level)
            right = self.wrap(expr.right, level + 1)  # left-associative
            return f"{left} {expr.op} {right}", level
        if isinstance(expr, BoolOp):
            level = _PRECEDENCE[expr.op]
            # an `and` inside an `or` in parentheses, though Python does not need them: a
            # reviewer should not have to recall which binds tighter
            least = _PRECEDENCE["not"] if expr.op == "or" else level + 1
            return f" {expr.op} ".join(self.wrap(v, least) for v in expr.values), level
        if isinstance(expr, IfExp):  # right-associative: `a if c else b if d else e`
            body, test = self.wrap(expr.body, 1), self.wrap(expr.test, 1)
            return f"{body} if {test} else {self.wrap(expr.orelse, 0)}", _PRECEDENCE["if"]
        if isinstance(expr, Compare):
            level = _PRECEDENCE["cmp"]
            parts = [self.wrap(expr.left, level + 1)]
            for op, comparator in zip(expr.ops, expr.comparators, strict=True):
                parts += [op, self.wrap(comparator, level + 1)]
            return " ".join(parts), level
        raise TypeError(f"unknown expression node {expr!r}")
