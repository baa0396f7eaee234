"""Resolve: expression text -> a typed tree, over the scope of one controller and command.

A spec's expression text never reaches generated code. It is parsed with `ast` and every
node is checked against an allowlist (literals, `and`/`or`/`not`, comparisons, arithmetic,
declared names, `world.<field>`, `<sub>.status`, `<sub>.command`, calls of declared
predicates and of `abs`/`min`/`max`); anything else is a located error. Names are resolved
against a `Scope` and typed.
"""

from __future__ import annotations

import ast
import functools
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from ...runtime.contract import text_problem
from ..diagnostics import Diagnostics, Span, counted, known_names_hint
from ..front_end.loader import char_span
from ..types import (
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
from .fold import fold
from .nodes import (
    BUILTIN_REASONS,
    BUILTINS,
    INT_RANGE_HINT,
    MAX_DEPTH,
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
    int_range_problem,
)

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
# What a form a spec expression may not use is, in words, with its verb ("are", "is").
_NODE_WORDS = {
    ast.Subscript: "subscripts are",
    ast.Lambda: "lambdas are",
    ast.ListComp: "comprehensions are",
    ast.SetComp: "comprehensions are",
    ast.DictComp: "comprehensions are",
    ast.GeneratorExp: "comprehensions are",
    ast.JoinedStr: "f-strings are",
    ast.NamedExpr: "assignment expressions (:=) are",
    ast.Starred: "starred expressions are",
    ast.Await: "`await` is",
    ast.Yield: "`yield` is",
    ast.YieldFrom: "`yield from` is",
    ast.List: "lists are",
    ast.Tuple: "tuples are",
    ast.Set: "sets are",
    ast.Dict: "dictionaries are",
}


class _Fail(Exception):
    """Internal: stop resolving one expression after its first error."""


class _Resolver:
    def __init__(self, scope: Scope, span: Span, diags: Diagnostics, want: Enum | None = None):
        self.scope, self.span, self.diags = scope, span, diags
        self.want = want  # the enumeration a bare value name is looked up in, if any

    source: object = None  # the expression as loaded: where its characters are written

    def at(self, node: ast.AST) -> Span:
        return char_at(self.source, self.span, getattr(node, "col_offset", 0))

    def fail(self, node: ast.AST, code: str, message: str, hint: str = "") -> _Fail:
        self.diags.error(self.at(node), code, message, hint)
        return _Fail()

    def expr(self, node: ast.AST) -> Expr:
        method: Callable[[ast.AST], Expr] | None = getattr(self, "_" + type(node).__name__, None)
        if method is None:
            what = _NODE_WORDS.get(type(node), "this form of expression is")
            raise self.fail(
                node,
                "E102",
                f"{what} not allowed in a spec expression",
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
                    f"function `{name}` takes {counted(len(params), 'argument')}, not "
                    f"{len(node.args)}",
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


def expression_text(text: str) -> str:
    """The text an expression is parsed from: a multi-line one (a `>-` or `|` block, a
    quoted scalar over several lines) read as one line, its whitespace runs one space."""
    if "\n" in text.strip() or "\r" in text:
        return " ".join(text.split())
    return text.strip()


def char_at(source: object, base: Span, index: int) -> Span:
    """Where character `index` of expression `source`'s text (`expression_text`) is written:
    in a quoted or block scalar, found in the file (`char_span`); else `index` columns
    after `base`, where a plain one-line scalar starts."""
    if isinstance(source, str):
        found = char_span(source, expression_text(source), index)
        if found is not None:
            return found
    return Span(base.file, base.line, base.col + index)


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
        span = char_at(source, span, 0)  # its first character, past a quote or indicator
        tree = _parse(source, span, diags)
        if tree is None:
            return None
        resolver = _Resolver(scope, span, diags, expect if isinstance(expect, Enum) else None)
        resolver.source = source
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


def _parse(source: object, span: Span, diags: Diagnostics) -> ast.Expression | None:
    """Expression text as a Python syntax tree, or None after its problem: a character that
    is not printable ASCII, a `#` (a comment would drop the rest), a syntax error (E101),
    nesting beyond MAX_DEPTH (E102); each at its character (`span`: the first one's)."""
    text = expression_text(str(source))
    found = _NOT_TEXT.search(text)  # (a character loop in Python was slower)
    odd = found.start() if found else None
    if odd is not None:  # Python would accept (and NFKC-fold) non-ASCII identifiers
        char = text[odd]
        diags.error(
            char_at(source, span, odd),
            "E101",
            f"invalid expression: character {char!r} (U+{ord(char):04X}) is not allowed",
            "expressions are ASCII: names, numbers, operators and parentheses",
        )
        return None
    if "#" in text:  # Python would drop the rest of the line as a comment, silently
        comment = text[text.index("#") + 1 :].strip()
        shown = comment if len(comment) <= 40 else comment[:37] + "..."
        diags.error(
            char_at(source, span, text.index("#")),
            "E101",
            f"invalid expression: `#` is not allowed (`# {shown}`)",
            "inside a `>-` or `|` block a YAML comment is part of the expression and would "
            "silently drop the rest of it: put the comment on a line of its own, outside",
        )
        return None
    tree = _parsed(text)
    if tree is not None:
        return tree
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        # the text is one line; no offset (0): the error is at its end
        where = char_at(source, span, (exc.offset or len(text) + 1) - 1)
        shown = text if len(text) <= 80 else text[:77] + "..."
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


@functools.lru_cache(maxsize=8192)
def _parsed(text: str) -> ast.Expression | None:
    """The syntax tree of a well-formed expression text within MAX_DEPTH, else None (then
    `_parse` finds and reports the problem). Cached: a system repeats its guards and values
    (one parse of `x.status == DONE` for all its rules); the trees are only read, never
    changed."""
    try:
        tree = ast.parse(text, mode="eval")
    except (SyntaxError, RecursionError, MemoryError, ValueError):
        return None
    return tree if _depth(tree.body) <= MAX_DEPTH else None


# Anything but printable ASCII or a tab: an expression is written with those only.
_NOT_TEXT = re.compile(r"[^\t -~]")


def _depth(node: ast.AST) -> int:
    """How deeply `node` nests (counted without recursion, so any depth is safe)."""
    deepest, todo = 0, [(node, 1)]
    while todo:
        at, level = todo.pop()
        deepest = max(deepest, level)
        todo.extend((child, level + 1) for child in ast.iter_child_nodes(at))
    return deepest
