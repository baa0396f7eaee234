"""Expressions: guard, argument and assignment text -> typed expression tree -> Python source.

A spec's expression text never reaches generated code. It is parsed with `ast` and every
node is checked against an allowlist (literals, `and`/`or`/`not`, comparisons, arithmetic,
declared names, `world.<field>`, `<sub>.status`, `<sub>.command`, calls of declared
predicates and of `abs`/`min`/`max`); anything else is a located error. Names are resolved
against a `Scope` and typed, and the Python text is printed back from the typed tree.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from ..runtime.contract import text_problem
from .diagnostics import Diagnostics, Span, known_names_hint
from .types import (
    BOOL,
    FLOAT,
    INT,
    NUMERIC,
    STATUS,
    STR_MAX_SIZE,
    CommandOf,
    Enum,
    ReasonOf,
    Str,
    Type,
    assignable,
)


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
    shown = str(value) if len(str(value)) <= 30 else f"{str(value)[:27]}..."
    return f"integer {shown} is out of range: an int is 64-bit ({INT_MIN} to {INT_MAX})"


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


# ---------------------------------------------------------------- scope


@dataclass
class Scope:
    """What an expression may name: everything declared for one controller and command."""

    world: Mapping[str, Type] = field(default_factory=dict)  # every world field -> type
    world_access: frozenset[str] = frozenset()  # fields the controller reads or writes
    params: Mapping[str, Type] = field(default_factory=dict)
    locals: Mapping[str, Type] = field(default_factory=dict)
    constants: Mapping[str, bool | int | float] = field(default_factory=dict)
    predicates: frozenset[str] = frozenset()
    subordinates: Mapping[str, frozenset[str]] = field(default_factory=dict)  # sub -> commands
    used_predicates: set[str] = field(default_factory=set)
    # each subordinate's results (name -> type) and the reasons it declares (none: no reason)
    sub_results: Mapping[str, Mapping[str, Type]] = field(default_factory=dict)
    sub_reasons: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    # pure functions it may call: name -> (parameter types in order, result type)
    functions: Mapping[str, tuple[tuple[Type, ...], Type]] = field(default_factory=dict)
    lets: Mapping[str, Type] = field(default_factory=dict)  # its table's named values -> type
    # constants an expression named (shared by every copy of the controller's scope)
    used_constants: set[str] = field(default_factory=set)
    args: Mapping[str, Type] = field(default_factory=dict)  # a function body's parameters
    # each plan's names (its step fields and PLAN_PROPERTIES) -> type
    plans: Mapping[str, Mapping[str, Type]] = field(default_factory=dict)

    def bare_names(self) -> list[str]:
        return [*self.args, *self.params, *self.lets, *self.locals, *self.constants, *STATUS_NAMES]


_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.FloorDiv: "//"}
_BINOPS[ast.Mod] = "%"
_CMPOPS = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">="}
_UNARY = {ast.Not: "not", ast.USub: "-", ast.UAdd: "+"}
_NODE_WORDS = {
    ast.Subscript: "subscripts",
    ast.Lambda: "lambdas",
    ast.ListComp: "comprehensions",
    ast.SetComp: "comprehensions",
    ast.DictComp: "comprehensions",
    ast.GeneratorExp: "comprehensions",
    ast.JoinedStr: "f-strings",
    ast.NamedExpr: "assignment expressions (:=)",
    ast.Starred: "starred expressions",
    ast.Await: "await",
    ast.Yield: "yield",
}


class _Fail(Exception):
    """Internal: stop resolving one expression after its first error."""


class _Resolver:
    def __init__(self, scope: Scope, span: Span, diags: Diagnostics, want: Enum | None = None):
        self.scope, self.span, self.diags = scope, span, diags
        self.want = want  # the enumeration a bare value name is looked up in, if any

    def at(self, node: ast.AST) -> Span:
        return offset_span(self.span, getattr(node, "lineno", 1), getattr(node, "col_offset", 0))

    def fail(self, node: ast.AST, code: str, message: str, hint: str = "") -> _Fail:
        self.diags.error(self.at(node), code, message, hint)
        return _Fail()

    def expr(self, node: ast.AST) -> Expr:
        method: Callable[[ast.AST], Expr] | None = getattr(self, "_" + type(node).__name__, None)
        if method is None:
            what = _NODE_WORDS.get(type(node), f"`{type(node).__name__}` expressions")
            raise self.fail(
                node,
                "E102",
                f"{what} are not allowed in a spec expression",
                "expressions may use literals, and/or/not, comparisons, arithmetic, `a if c "
                "else b`, declared names, world.<field>, <sub>.status, <sub>.command and "
                "calls of predicates and functions",
            )
        return method(node)

    def _Constant(self, node: ast.Constant) -> Expr:
        value = node.value
        if isinstance(value, str):  # a plain constant, printed back with repr()
            problem = text_problem(value, STR_MAX_SIZE)
            if problem:
                raise self.fail(node, "E276", f"invalid string literal: {problem}")
            return Const(Str(max(1, len(value.encode("utf-8")))), value)
        if isinstance(value, bool):
            return Const(BOOL, value)
        if isinstance(value, int):
            if int_range_problem(value):
                raise self.fail(node, "E110", int_range_problem(value), INT_RANGE_HINT)
            return Const(INT, value)
        if isinstance(value, float) and math.isfinite(value):
            return Const(FLOAT, value)
        raise self.fail(
            node, "E102", f"the literal {value!r} is not allowed", "use a number or a string"
        )

    def _Name(self, node: ast.Name) -> Expr:
        name, scope = node.id, self.scope
        if name in ("True", "False"):  # only reachable on very old parsers
            return Const(BOOL, name == "True")
        if name in STATUS_NAMES:  # reserved: a param or constant cannot shadow a status
            return Ref(STATUS, RefKind.STATUS, name)
        values = self.want.values if self.want else ()
        if self.want and name in values:  # where an enumeration is expected, its values first
            return Const(self.want, values.index(name))
        if name in scope.args:
            return Ref(scope.args[name], RefKind.ARG, name)
        if name in scope.params:
            return Ref(scope.params[name], RefKind.PARAM, name)
        if name in scope.lets:
            return Ref(scope.lets[name], RefKind.LET, name)
        if name in scope.locals:
            return Ref(scope.locals[name], RefKind.LOCAL, name)
        if name in scope.constants:
            scope.used_constants.add(name)
            return Ref(_type_of_value(scope.constants[name]), RefKind.CONST, name)
        if name.startswith("__"):
            raise self.fail(node, "E102", f"dunder name `{name}` is not allowed")
        if name in scope.predicates:
            raise self.fail(node, "E107", f"predicate `{name}` must be called", f"write `{name}()`")
        if name == "world" or name in scope.subordinates or name in scope.plans:
            raise self.fail(node, "E108", f"`{name}` needs a field: `{name}.<field>`")
        if self.want:
            raise self.fail(
                node,
                "E274",
                f"`{name}` is not a value of {self.want.words}",
                known_names_hint("values", values, name),
            )
        raise self.fail(
            node,
            "E103",
            f"unknown name `{name}`",
            known_names_hint("names", scope.bare_names(), name),
        )

    def _Attribute(self, node: ast.Attribute) -> Expr:
        base, attr, scope = node.value, node.attr, self.scope
        if attr.startswith("__"):
            raise self.fail(node, "E102", f"dunder attribute `{attr}` is not allowed")
        if (
            isinstance(base, ast.Attribute)
            and base.attr == "result"
            and isinstance(base.value, ast.Name)
            and base.value.id in scope.subordinates
        ):
            return self.sub_result(node, base.value.id, attr)
        if not isinstance(base, ast.Name):
            raise self.fail(
                node, "E102", "attributes are allowed only on `world`, subordinates and plans"
            )
        if base.id in scope.plans and base.id != "world" and base.id not in scope.subordinates:
            names = scope.plans[base.id]
            if attr not in names:
                raise self.fail(
                    node,
                    "E290",
                    f"plan `{base.id}` has no step field or property `{attr}`",
                    known_names_hint(f"names of plan {base.id}", names, attr),
                )
            return Ref(names[attr], RefKind.PLAN, attr, base.id)
        if base.id == "world":
            return self.world_field(node, attr)
        if base.id in scope.subordinates:
            return self.sub_attribute(node, base.id, attr)
        raise self.fail(
            node,
            "E108",
            f"`{base.id}` is neither `world` nor a subordinate"
            + (" or a plan" if scope.plans else "")
            + " of this controller",
            known_names_hint(
                "subordinates and plans" if scope.plans else "subordinates",
                [*scope.subordinates, *scope.plans],
                base.id,
            ),
        )

    def world_field(self, node: ast.AST, attr: str) -> Expr:
        """`world.<attr>`: a declared field this controller reads or writes."""
        scope = self.scope
        if attr not in scope.world:
            raise self.fail(
                node,
                "E104",
                f"undeclared world field `{attr}`",
                known_names_hint("world fields", scope.world, attr),
            )
        if attr not in scope.world_access:
            raise self.fail(
                node,
                "E105",
                f"world field `{attr}` is not in this controller's world.reads or world.writes",
                f"add `{attr}` to `world: reads:`",
            )
        return Ref(scope.world[attr], RefKind.WORLD, attr)

    def sub_attribute(self, node: ast.AST, sub: str, attr: str) -> Expr:
        """`<sub>.status`, `<sub>.command`, `<sub>.reason` (E259 when it declares none)."""
        if attr == "status":
            return Ref(STATUS, RefKind.SUB_STATUS, attr, sub)
        if attr == "command":
            return Ref(CommandOf(sub), RefKind.SUB_COMMAND, attr, sub)
        if attr == "reason":
            if not self.scope.sub_reasons.get(sub):
                raise self.fail(
                    node,
                    "E259",
                    f"`{sub}` declares no reasons: `{sub}.reason` says nothing",
                    f"declare `reasons:` on the commands of `{sub}` that can fail",
                )
            return Ref(ReasonOf(sub), RefKind.SUB_REASON, attr, sub)
        if attr == "result":
            raise self.fail(node, "E108", f"`{sub}.result` needs a name: `.result.<name>`")
        raise self.fail(
            node,
            "E108",
            f"`{sub}.{attr}`: a subordinate has only `status`, `command`, `reason` "
            "and `result.<name>`",
            did_you_mean_attr(attr),
        )

    def sub_result(self, node: ast.AST, sub: str, name: str) -> Expr:
        results = self.scope.sub_results.get(sub, {})
        if name not in results:
            raise self.fail(
                node,
                "E258",
                f"`{sub}` has no result `{name}`",
                known_names_hint(f"results of {sub}", results, name)
                or f"declare it under `results:` of a command of `{sub}`",
            )
        return Ref(results[name], RefKind.SUB_RESULT, name, sub)

    def _Call(self, node: ast.Call) -> Expr:
        if node.keywords or not isinstance(node.func, ast.Name):
            raise self.fail(
                node, "E102", "only predicates, functions and abs/min/max can be called"
            )
        name = node.func.id
        if name in self.scope.functions:
            params, returns = self.scope.functions[name]
            if len(node.args) != len(params):
                raise self.fail(
                    node,
                    "E263",
                    f"function `{name}` takes {len(params)} argument(s), not {len(node.args)}",
                )
            args = []
            for index, (arg, wanted) in enumerate(zip(node.args, params, strict=True)):
                value = self.expr(arg)
                if not assignable(wanted, value.type):
                    raise self.fail(
                        arg,
                        "E263",
                        f"argument {index + 1} of `{name}` is {value.type.words}, "
                        f"but the function takes {wanted.words}",
                    )
                args.append(value)
            return Call(returns, CallKind.FUNCTION, name, tuple(args))
        if name in self.scope.predicates:
            if node.args:
                raise self.fail(node, "E107", f"predicate `{name}` takes no arguments")
            self.scope.used_predicates.add(name)
            return Call(BOOL, CallKind.PREDICATE, name)
        if name in BUILTINS:
            numbers = tuple(self.numeric(a) for a in node.args)
            if (name == "abs") != (len(numbers) == 1) or not numbers:
                raise self.fail(node, "E107", f"wrong number of arguments to `{name}`")
            kind = FLOAT if any(a.type == FLOAT for a in numbers) else INT
            return Call(kind, CallKind.BUILTIN, name, numbers)
        functions = self.scope.functions
        raise self.fail(
            node,
            "E106",
            f"`{name}` is not a declared predicate" + (" or function" if functions else ""),
            known_names_hint(
                "predicates and functions" if functions else "predicates",
                [*self.scope.predicates, *functions],
                name,
            ),
        )

    def _UnaryOp(self, node: ast.UnaryOp) -> Expr:
        op = _UNARY.get(type(node.op))
        if op is None:
            raise self.fail(node, "E102", "bitwise operators are not allowed")
        if op == "not":
            return Unary(BOOL, op, self.boolean(node.operand))
        operand = self.numeric(node.operand)
        return Unary(operand.type, op, operand)

    def _BinOp(self, node: ast.BinOp) -> Expr:
        op = _BINOPS.get(type(node.op))
        if op is None:
            raise self.fail(node, "E102", "only + - * / // % are allowed")
        left, right = self.numeric(node.left), self.numeric(node.right)
        both_int = left.type == INT and right.type == INT
        if op in ("/", "//", "%") and fold(right, self.scope.constants) == 0:
            raise self.fail(
                node.right,
                "E111",
                f"{'modulo' if op == '%' else 'division'} by zero: "
                f"the right operand of `{op}` is always 0",
                "divide by a value that cannot be 0, or guard the rule so it never divides by 0",
            )
        result = Binary(INT if both_int and op != "/" else FLOAT, op, left, right)
        problem = int_range_problem(fold(result, self.scope.constants))
        if problem:
            raise self.fail(node, "E110", f"this expression is always an {problem}", INT_RANGE_HINT)
        return result

    def _IfExp(self, node: ast.IfExp) -> Expr:
        want, self.want = self.want, None
        try:
            test = self.boolean(node.test)
        finally:
            self.want = want
        body, orelse = self.expr(node.body), self.expr(node.orelse)
        kind: Type
        if body.type in NUMERIC and orelse.type in NUMERIC:
            kind = FLOAT if FLOAT in (body.type, orelse.type) else INT
        elif body.type == orelse.type:
            kind = body.type
        else:
            raise self.fail(
                node,
                "E261",
                f"the two values of `... if ... else ...` differ: {body.type.words} and "
                f"{orelse.type.words}",
                "give both values one type (an int and a float make a float)",
            )
        return IfExp(kind, test, body, orelse)

    def _BoolOp(self, node: ast.BoolOp) -> Expr:
        op = "and" if isinstance(node.op, ast.And) else "or"
        return BoolOp(BOOL, op, tuple(self.boolean(v) for v in node.values))

    def _Compare(self, node: ast.Compare) -> Expr:
        ops = []
        for cmpop in node.ops:
            if type(cmpop) not in _CMPOPS:
                raise self.fail(node, "E102", "only == != < <= > >= comparisons are allowed")
            ops.append(_CMPOPS[type(cmpop)])
        operands = [node.left, *node.comparators]
        # A subordinate's command compares with that subordinate's command names, its
        # reason with its reason names.
        commanded = [_sub_commanded(a, self.scope) for a in operands]
        sub = next((s for s in commanded if s is not None), None)
        if sub is None:
            reasoned = [_sub_reasoned(a, self.scope) for a in operands]
            reason_of = next((s for s in reasoned if s is not None), None)
            if reason_of is not None:
                typed = [self.reason_name(a, reason_of) for a in operands]
                for left, right, op, raw in zip(typed, typed[1:], ops, operands[1:], strict=False):
                    self.comparable(left, right, op, raw)
                return Compare(BOOL, typed[0], tuple(ops), tuple(typed[1:]))
        typed = [self.command_name(a, sub) for a in operands] if sub else self.operands(operands)
        for left, right, op, raw in zip(typed, typed[1:], ops, operands[1:], strict=False):
            self.comparable(left, right, op, raw)
        return Compare(BOOL, typed[0], tuple(ops), tuple(typed[1:]))

    def operands(self, operands: list[ast.expr]) -> list[Expr]:
        """The operands of a comparison, typed; a bare UPPER name that is not a parameter,
        local, let or status is typed last, as a value of the first enumeration among the
        others (`side == LEFT`), and otherwise as a constant."""
        scope = self.scope
        lower = (*scope.args, *scope.params, *scope.lets, *scope.locals, *STATUS_NAMES)
        deferred = [isinstance(a, ast.Name) and a.id not in lower for a in operands]
        want, self.want = self.want, None
        typed: list[Expr | None] = [
            None if wait else self.expr(a) for a, wait in zip(operands, deferred, strict=True)
        ]
        self.want = next(
            (t.type for t in typed if t is not None and isinstance(t.type, Enum)), None
        )
        try:
            return [
                t if t is not None else self.expr(a) for a, t in zip(operands, typed, strict=True)
            ]
        finally:
            self.want = want

    def command_name(self, node: ast.AST, sub: str) -> Expr:
        if _is_sub_command(node, self.scope):
            return self.expr(node)
        if isinstance(node, ast.Name):
            commands = self.scope.subordinates[sub]
            if node.id in commands:
                return Ref(CommandOf(sub), RefKind.SUB_COMMAND_NAME, node.id, sub)
            raise self.fail(
                node,
                "E109",
                f"`{sub}` has no command `{node.id}`",
                known_names_hint(f"commands of {sub}", commands, node.id),
            )
        raise self.fail(node, "E107", f"`{sub}.command` compares only with a command name")

    def reason_name(self, node: ast.AST, sub: str) -> Expr:
        if _sub_reasoned(node, self.scope) is not None:
            return self.expr(node)
        if isinstance(node, ast.Name):
            names = (*BUILTIN_REASONS, *self.scope.sub_reasons.get(sub, ()))
            if node.id in names:
                return Ref(ReasonOf(sub), RefKind.SUB_REASON_NAME, node.id, sub)
            raise self.fail(
                node,
                "E260",
                f"`{sub}` has no reason `{node.id}`",
                known_names_hint(f"reasons of {sub}", names, node.id),
            )
        raise self.fail(node, "E107", f"`{sub}.reason` compares only with a reason name")

    def comparable(self, left: Expr, right: Expr, op: str, node: ast.AST) -> None:
        kinds = {left.type, right.type}
        if kinds <= set(NUMERIC):
            return
        texts = all(isinstance(k, Str) for k in kinds)
        if (len(kinds) == 1 or texts) and op in ("==", "!="):
            return
        if any(isinstance(k, Enum | Str) for k in kinds):
            code = "E275" if len(kinds) == 1 or texts else "E277"
            raise self.fail(
                node,
                code,
                f"cannot compare {left.type.words} with {right.type.words} using `{op}`",
                "an enumeration compares with == and != against its own values, a string "
                "against a string"
                if code == "E277"
                else "an enumeration or a string has no order: compare it with == or !=",
            )
        raise self.fail(node, "E107", f"cannot compare {left.type} with {right.type} using `{op}`")

    def typed(self, node: ast.AST, wanted: tuple[Type, ...], words: str) -> Expr:
        result = self.expr(node)
        if result.type not in wanted:
            if isinstance(result.type, Enum | Str):
                raise self.fail(
                    node,
                    "E275",
                    f"expected {words}, got {result.type.words}",
                    "an enumeration or a string only compares with == and != (and a string "
                    "passes to hooks): no arithmetic, ordering or logic",
                )
            raise self.fail(node, "E107", f"expected {words}, got {result.type}")
        return result

    def boolean(self, node: ast.AST) -> Expr:
        return self.typed(node, (BOOL,), "a boolean")

    def numeric(self, node: ast.AST) -> Expr:
        return self.typed(node, NUMERIC, "a number")


def _is_sub_command(node: ast.AST, scope: Scope) -> bool:
    return _sub_commanded(node, scope) is not None


def _sub_attribute(node: ast.AST, scope: Scope, attr: str) -> str | None:
    """The subordinate whose `attr` `node` reads (`<sub>.command`, `<sub>.reason`), else None."""
    if (
        isinstance(node, ast.Attribute)
        and node.attr == attr
        and isinstance(node.value, ast.Name)
        and node.value.id in scope.subordinates
    ):
        return node.value.id
    return None


def _sub_commanded(node: ast.AST, scope: Scope) -> str | None:
    return _sub_attribute(node, scope, "command")


def _sub_reasoned(node: ast.AST, scope: Scope) -> str | None:
    return _sub_attribute(node, scope, "reason")


def did_you_mean_attr(attr: str) -> str:
    return known_names_hint("fields", ("status", "command", "reason", "result"), attr)


def _type_of_value(value: object) -> Type:
    if isinstance(value, bool):
        return BOOL
    return INT if isinstance(value, int) else FLOAT


def offset_span(base: Span, lineno: int, col_offset: int) -> Span:
    """The span of a node `col_offset` into line `lineno` of an expression found at `base`."""
    if lineno <= 1:
        return Span(base.file, base.line, base.col + col_offset)
    return Span(base.file, base.line + lineno - 1, col_offset + 1)


def compile_expr(
    source: object, span: Span, scope: Scope, diags: Diagnostics, expect: Type | None = None
) -> Expr | None:
    """Parse, check and type `source` (expression text, or a YAML number/boolean).

    `expect` is BOOL for guards or a world/param/local type for values; None accepts any.
    Returns None after reporting the first problem of this expression.
    """
    if isinstance(source, bool | int | float) and not isinstance(source, str):
        if isinstance(source, float) and not math.isfinite(source):
            diags.error(span, "E102", "NaN and infinity are not allowed")
            return None
        if int_range_problem(source):
            diags.error(span, "E110", int_range_problem(source), INT_RANGE_HINT)
            return None
        result: Expr = Const(_type_of_value(source), source)
    else:
        tree = _parse(str(source), span, diags)
        if tree is None:
            return None
        resolver = _Resolver(scope, span, diags, expect if isinstance(expect, Enum) else None)
        try:
            result = resolver.expr(tree.body)
        except _Fail:
            return None
        except RecursionError:
            diags.error(span, "E102", "expression is nested too deeply")
            return None
    if expect is not None and not assignable(expect, result.type):
        special = any(isinstance(k, Enum | Str) for k in (expect, result.type))
        diags.error(
            span,
            "E277" if special else "E107",
            f"expected {expect.words}, got {result.type.words}",
            "a string longer than its target could not be stored whole: give the target a "
            "larger `size`"
            if isinstance(expect, Str) and isinstance(result.type, Str)
            else "",
        )
        return None
    return result


def _parse(text: str, span: Span, diags: Diagnostics) -> ast.Expression | None:
    """Expression text as a Python syntax tree, or None after its problem: a character that
    is not printable ASCII, a `#` (a comment would drop the rest), a syntax error (E101),
    nesting beyond MAX_DEPTH (E102)."""
    if "\n" in text.strip() or "\r" in text:
        text = " ".join(text.split())
    odd = next((i for i, ch in enumerate(text.strip()) if not _ascii_text(ch)), None)
    if odd is not None:  # Python would accept (and NFKC-fold) non-ASCII identifiers
        char = text.strip()[odd]
        diags.error(
            offset_span(span, 1, odd),
            "E101",
            f"invalid expression: character {char!r} (U+{ord(char):04X}) is not allowed",
            "expressions are ASCII: names, numbers, operators and parentheses",
        )
        return None
    if "#" in text:  # Python would drop the rest of the line as a comment, silently
        comment = text[text.index("#") + 1 :].strip()
        shown = comment if len(comment) <= 40 else comment[:37] + "..."
        diags.error(
            span,  # the expression's start: in a block scalar, columns do not map
            "E101",
            f"invalid expression: `#` is not allowed (`# {shown}`)",
            "inside a `>-` or `|` block a YAML comment is part of the expression and would "
            "silently drop the rest of it: put the comment on a line of its own, outside",
        )
        return None
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        where = offset_span(span, exc.lineno or 1, max((exc.offset or 1) - 1, 0))
        shown = text.strip() if len(text.strip()) <= 80 else text.strip()[:77] + "..."
        diags.error(where, "E101", f"invalid expression: {exc.msg}", f"in `{shown}`")
        return None
    except (RecursionError, MemoryError, ValueError):  # the parser's own limits
        diags.error(span, "E102", "expression is nested too deeply")
        return None
    if _depth(tree.body) > MAX_DEPTH:
        diags.error(
            span,
            "E102",
            "expression is nested too deeply",
            f"at most {MAX_DEPTH} levels; split it into predicates",
        )
        return None
    return tree


def _ascii_text(char: str) -> bool:
    """Printable ASCII or a tab: everything an expression is written with."""
    return " " <= char <= "~" or char == "\t"


def _depth(node: ast.AST) -> int:
    """How deeply `node` nests (counted without recursion, so any depth is safe)."""
    deepest, todo = 0, [(node, 1)]
    while todo:
        at, level = todo.pop()
        deepest = max(deepest, level)
        todo.extend((child, level + 1) for child in ast.iter_child_nodes(at))
    return deepest


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


# ---------------------------------------------------------------- printing

_PRECEDENCE = {"if": 0, "or": 1, "and": 2, "not": 3, "cmp": 4, "+": 5, "-": 5}
_PRECEDENCE.update({"*": 6, "/": 6, "//": 6, "%": 6, "neg": 7, "atom": 9})


def to_python(expr: Expr, name_of: Callable[[Ref], str]) -> str:
    """Python source for a typed tree; `name_of` maps each resolved name to its target text."""
    return _Printer(name_of).text(expr)[0]


def to_python_conjunct(expr: Expr, name_of: Callable[[Ref], str]) -> str:
    """Python source for `expr` as one operand of `and` (parenthesised only if it needs it)."""
    return _Printer(name_of).wrap(expr, _PRECEDENCE["and"])


class _Printer:
    def __init__(self, name_of: Callable[[Ref], str]):
        self.name_of = name_of

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
            return f" {expr.op} ".join(self.wrap(v, level + 1) for v in expr.values), level
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


def walk(expr: Expr) -> Iterator[Expr]:
    """Every node of `expr`, each before its operands, in reading order."""
    stack = [expr]
    while stack:
        node = stack.pop()
        yield node
        if isinstance(node, Call):
            stack.extend(reversed(node.args))
        elif isinstance(node, Unary):
            stack.append(node.operand)
        elif isinstance(node, Binary):
            stack.extend((node.right, node.left))
        elif isinstance(node, BoolOp):
            stack.extend(reversed(node.values))
        elif isinstance(node, Compare):
            stack.extend(reversed((node.left, *node.comparators)))
        elif isinstance(node, IfExp):
            stack.extend((node.orelse, node.body, node.test))


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
