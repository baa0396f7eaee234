"""Expressions: guard, argument and assignment text -> typed tree -> Python source.

In: an expression as the spec writes it (text, or a YAML number or boolean), its span and
the `Scope` of names it may use. Out: a typed tree (`nodes`) or one located diagnostic
(E101-E111, E258-E263, E274-E277, E290). `resolve` parses and types it against an
allowlist, `fold` computes what reads only literals and constants, `printer` prints a
tree as Python. Every later stage reads the trees, never the text.
"""

from .fold import ARITHMETIC, COMPARISONS, fold
from .nodes import (
    BUILTIN_REASONS,
    BUILTINS,
    INT_MAX,
    INT_MIN,
    INT_RANGE_HINT,
    MAX_DEPTH,
    PLAN_PROPERTIES,
    STATUS_NAMES,
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
    enum_constants,
    int_range_problem,
    refs,
    substitute,
    text_problem_of,
    walk,
)
from .printer import to_python, to_python_and_conjunct, to_python_conjunct
from .resolve import Scope, compile_expr, did_you_mean_attr

__all__ = [
    "ARITHMETIC",
    "BUILTINS",
    "BUILTIN_REASONS",
    "COMPARISONS",
    "INT_MAX",
    "INT_MIN",
    "INT_RANGE_HINT",
    "MAX_DEPTH",
    "PLAN_PROPERTIES",
    "STATUS_NAMES",
    "Binary",
    "BoolOp",
    "Call",
    "CallKind",
    "Compare",
    "Const",
    "Expr",
    "IfExp",
    "Ref",
    "RefKind",
    "Scope",
    "Unary",
    "compile_expr",
    "did_you_mean_attr",
    "enum_constants",
    "fold",
    "int_range_problem",
    "refs",
    "substitute",
    "text_problem_of",
    "to_python",
    "to_python_and_conjunct",
    "to_python_conjunct",
    "walk",
]
