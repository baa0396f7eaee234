"""Analysis: static checks of checked state tables, each finding shown with a counter-example.

Runs on the checked system `check` accepted: each typed guard becomes a solver `Guard`
(`GuardBuilder`, predicates inlined, constants folded), and each question - can two rules
of a state both hold? can none hold? can this rule fire at all? - is decided by the solver
(`solver.py`), enumerating the valuations of the atoms the guards mention:

- `<sub>.status`: EXECUTING, DONE, ERROR (NOT_READY is not observable once the table has
  commanded the subordinate, and testing one it never commands is E507);
- `<sub>.command`: that subordinate's commands; booleans (world, locals, params): both values;
- numbers (world fields, locals, parameters): each comparison is read as a linear form
  compared with a constant - `ticks >= SUMP_CYCLES` as `ticks >= 4`, `x > world.pose_x +
  ARRIVED` as `x - world.pose_x > 0.02` - and the form takes one value per region the
  constants cut the number line into (each constant, one between two, one beyond each end;
  integers only for an int variable). That decides comparisons of one variable exactly, and
  forms of several variables too when they are of floats and independent of each other in
  the question; otherwise a finding that needs them is "cannot prove" (W502);
- `abs`, `min` and `max` are written as conditionals, and conditionals lifted above the
  arithmetic around them, so their comparisons split into linear ones, decided as above
  (`GuardBuilder.lifted`);
- any other comparison of numbers (a product of variables, `//`, `%` of a variable) is an
  opaque atom, free to be true or false: "cannot prove" as well.

More than `LIMIT` valuations is "cannot prove" too, never a hang. Findings are diagnostics
in the E5xx/W5xx range (`codes.Topic.ANALYSIS`), located at the rule, state, send or
command they concern.
The default INIT/HALT tables are analysed like the others, except that they wait for every
subordinate's DONE by design (the QQ1 template): W503 and W506 are not reported for them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import StrEnum
from fractions import Fraction
from itertools import pairwise
from typing import Any

from ...runtime.contract import FINISHED
from .. import expressions as expr
from ..checks.tables import (
    ENTRY_STATE,
    CheckedCommand,
    CheckedController,
    CheckedRule,
    CheckedSystem,
    PlanAction,
    Send,
    reachable,
)
from ..diagnostics import Diagnostic, Diagnostics, Span, Subject, known_names_hint
from ..expressions import BUILTIN_REASONS
from ..front_end.model import PlanVerb
from ..types import BOOL, INT, NUMERIC, Enum, Str, Type
from . import solver
from .solver import (
    BOOL_DOMAIN,
    LIMIT,
    Guard,
    Key,
    Linear,
    Op,
    Part,
    Questions,
    Term,
    Verdict,
    compiled,
    merge_atoms,
)


class Atom(StrEnum):
    """What an atom of a guard is: the first half of its solver `Key`, (Atom, name)."""

    WORLD = "world"
    LOCAL = "local"
    PARAM = "param"
    TIME = "time"  # the cycles in the current state (`after:`)
    HELD = "held"  # the cycles a `for:` rule's `when` held
    STATUS = "status"  # a subordinate's status (name: the subordinate)
    COMMAND = "command"  # a subordinate's command
    REASON = "reason"  # a subordinate's reason
    RESULT = "result"  # `<sub>.<result>`
    PLAN = "plan"  # `<plan>.<name>`
    FORM = "form"  # a linear form of several numeric variables
    OPAQUE = "opaque"  # a comparison no interval reasoning decides


# The statuses a tested subordinate can show (NOT_READY is not observable once the table
# has commanded it).
STATUS_DOMAIN = ("EXECUTING", *FINISHED)

_BUILTIN: dict[str, Callable[..., Any]] = {"abs": abs, "min": min, "max": max}
# The names that are numeric variables of their own (their atom has the kind's name).
_VARIABLES = {
    expr.RefKind.WORLD: Atom.WORLD,
    expr.RefKind.LOCAL: Atom.LOCAL,
    expr.RefKind.PARAM: Atom.PARAM,
    expr.RefKind.TIME: Atom.TIME,
    expr.RefKind.HELD: Atom.HELD,
}
# Time (`after:`, `for:`) grows without bound while a table waits: a wait is one that stays
# when every timer is past every bound, so completeness reads the timers at this value.
_LATE = 2**62
# The most conditionals a numeric operand may become once abs/min/max are written out
# (GuardBuilder.lifted): each splits a comparison in two; past this it stays opaque.
_LIFTED = 16


# ---------------------------------------------------------------- guards


def show_key(key: Key) -> str:
    kind, name = key
    match kind:
        case Atom.WORLD:
            return f"world.{name}"
        case Atom.STATUS | Atom.COMMAND | Atom.REASON:
            return f"{name}.{kind}"
        case Atom.RESULT:
            sub, _, field = name.partition(".")
            return f"{sub}.result.{field}"
        case Atom.OPAQUE | Atom.FORM:
            return f"({name})"
        case Atom.PLAN if name.endswith(".remaining"):  # see GuardBuilder.inline
            plan = name.removesuffix(".remaining")
            return f"({plan}.steps - {plan}.step)"
        case Atom.TIME:
            return "cycles_in_state"
        case Atom.HELD:  # held_<command>_<state>_<rule>: the cycles a `for:` guard held
            return f"cycles_rule_{name.rsplit('_', 1)[-1]}_held"
    return name


def show_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, Fraction):
        if value.denominator == 1 and abs(value) > 2**53:
            return str(value)
        try:
            value = float(value)
        except OverflowError:
            return str(value)
    return value if isinstance(value, str) else repr(value)


def show_valuation(shown: Iterable[tuple[Key, Any]]) -> str:
    """`vg.status=DONE, cc.status=DONE, world.popped_out_of_shear=true`."""
    return ", ".join(f"{show_key(k)}={show_value(v)}" for k, v in shown)


def _spec_name(ref: expr.Ref) -> str:
    if ref.kind == expr.RefKind.WORLD:
        return f"world.{ref.name}"
    if ref.kind in (expr.RefKind.SUB_STATUS, expr.RefKind.SUB_COMMAND):
        return f"{ref.owner}.{ref.name}"
    return ref.name


_FLIP = {"==": "==", "!=": "!=", "<": ">", "<=": ">=", ">": "<", ">=": "<="}


class GuardBuilder:
    """Typed trees of one controller -> solver `Guard`s (predicates inlined, constants folded)."""

    def __init__(
        self,
        constants: dict[str, Any],
        predicates: dict[str, expr.Expr],
        sub_commands: dict[str, tuple[str, ...]],
        sub_reasons: dict[str, tuple[str, ...]] | None = None,
    ):
        self.constants, self.predicates, self.sub_commands = constants, predicates, sub_commands
        self.sub_reasons = sub_reasons or {}
        self.functions: dict[str, tuple[tuple[str, ...], expr.Expr]] = {}  # name -> params, body
        self.lets: dict[str, expr.Expr] = {}  # the `let` values of the table being analysed
        self.plans: dict[str, tuple[int, int]] = {}  # plan -> (capacity, replans)
        self.bounds: dict[Key, tuple[Fraction, Fraction]] = {}  # bounded plan variables

    def inline(self, e: expr.Expr) -> expr.Expr | None:
        """A function call's body with its arguments, a `let` value's tree; else None."""
        if isinstance(e, expr.Call) and e.kind == expr.CallKind.FUNCTION:
            params, body = self.functions[e.name]
            return expr.substitute(
                body, {(expr.RefKind.ARG, p): a for p, a in zip(params, e.args, strict=True)}
            )
        if isinstance(e, expr.Ref) and e.kind == expr.RefKind.LET:
            return self.lets[e.name]
        if isinstance(e, expr.Ref) and e.kind == expr.RefKind.PLAN and e.name in ("done", "steps"):
            # A plan's position is two independent variables, the step and the steps after
            # it (`remaining`, both 0..capacity): `steps` is their sum and `done` is no step
            # remaining, so no counter-example shows a plan done before its last step, or
            # past a last step it does not have.
            step, remaining = (
                expr.Ref(INT, expr.RefKind.PLAN, n, e.owner) for n in ("step", "remaining")
            )
            if e.name == "steps":
                return expr.Binary(INT, "+", step, remaining)
            return expr.Compare(BOOL, remaining, ("<=",), (expr.Const(INT, 0),))
        return None

    def within_capacity(self, plan: str) -> Term:
        """A plan's step and the steps after it add up to at most its capacity."""
        step: Key = (Atom.PLAN, f"{plan}.step")
        remaining: Key = (Atom.PLAN, f"{plan}.remaining")
        return (Op.AT_MOST, (step, remaining), self.plans[plan][0])

    def guard(self, tree: expr.Expr) -> Guard:
        guard = Guard(lambda val: True)
        guard.term = self._term(tree, guard)
        guard.fn = compiled(guard.term)
        return guard

    def _atom(self, guard: Guard, key: Key, domain: tuple[Any, ...] | None = None) -> None:
        guard.order.setdefault(key, None)
        if domain is not None:
            guard.domains[key] = domain

    def opened(self, e: expr.Expr) -> expr.Expr:
        """`e` with the function calls and `let` values at its top inlined."""
        while (inlined := self.inline(e)) is not None:
            e = inlined
        return e

    def lifted(self, e: expr.Expr) -> expr.Expr:
        """A numeric operand with `abs`, `min` and `max` written as the conditionals they are
        (`abs(x)`: `x if x >= 0 else -x`) and every conditional lifted above the arithmetic
        around it (`-(a if c else b)`: `-a if c else -b`), so that a comparison splits into
        linear ones, each decided exactly; past `_LIFTED` conditionals, `e` as it was (an
        opaque comparison)."""
        opened = self.opened(e)
        if opened.type not in NUMERIC:
            return opened
        done = self._lift(opened)
        conditionals = sum(isinstance(n, expr.IfExp) for n in expr.walk(done))
        return done if conditionals <= _LIFTED else opened

    def _lift(self, e: expr.Expr) -> expr.Expr:
        e = self.opened(e)
        if isinstance(e, expr.Call) and e.kind == expr.CallKind.BUILTIN:
            args = [self._lift(a) for a in e.args]
            if e.name == "abs":
                x = args[0]
                zero = expr.Const(x.type, 0)
                test = expr.Compare(BOOL, x, (">=",), (zero,))
                return expr.IfExp(e.type, test, x, self._lift(expr.Unary(x.type, "-", x)))
            chosen = args[0]
            keep = "<=" if e.name == "min" else ">="  # the first of equal values, as Python
            for other in args[1:]:
                test = expr.Compare(BOOL, chosen, (keep,), (other,))
                chosen = expr.IfExp(e.type, test, chosen, other)
            return chosen
        if isinstance(e, expr.Unary) and e.op in ("-", "+"):
            x = self._lift(e.operand)
            if isinstance(x, expr.IfExp):
                body = self._lift(expr.Unary(e.type, e.op, x.body))
                orelse = self._lift(expr.Unary(e.type, e.op, x.orelse))
                return expr.IfExp(e.type, x.test, body, orelse)
            return expr.Unary(e.type, e.op, x)
        if isinstance(e, expr.Binary):
            left, right = self._lift(e.left), self._lift(e.right)
            if isinstance(left, expr.IfExp):
                body = self._lift(expr.Binary(e.type, e.op, left.body, right))
                orelse = self._lift(expr.Binary(e.type, e.op, left.orelse, right))
                return expr.IfExp(e.type, left.test, body, orelse)
            if isinstance(right, expr.IfExp):
                body = self._lift(expr.Binary(e.type, e.op, left, right.body))
                orelse = self._lift(expr.Binary(e.type, e.op, left, right.orelse))
                return expr.IfExp(e.type, right.test, body, orelse)
            return expr.Binary(e.type, e.op, left, right)
        if isinstance(e, expr.IfExp):
            return expr.IfExp(e.type, e.test, self._lift(e.body), self._lift(e.orelse))
        return e

    def _term(self, e: expr.Expr, g: Guard) -> Term:
        inlined = self.inline(e)
        if inlined is not None:  # decided as if the body or value were written here
            return self._term(inlined, g)
        if isinstance(e, expr.Const):
            # an enumeration's value: by name, as its domain
            value = e.type.values[int(e.value)] if isinstance(e.type, Enum) else e.value
            return (Op.CONST, value)
        if isinstance(e, expr.Ref):
            return self._ref(e, g)
        if isinstance(e, expr.Call) and e.kind == expr.CallKind.PREDICATE:
            return self._term(self.predicates[e.name], g)
        if isinstance(e, expr.Unary) and e.op == "not":
            return (Op.NOT, self._term(e.operand, g))
        if isinstance(e, expr.BoolOp):
            parts = tuple(self._term(v, g) for v in e.values)
            return (Op.AND if e.op == "and" else Op.OR, parts)
        if isinstance(e, expr.IfExp):
            return (Op.IF, *(self._term(x, g) for x in (e.test, e.body, e.orelse)))
        if isinstance(e, expr.Compare) and len(e.ops) > 1:  # a <= b <= c: a <= b and b <= c
            chain = tuple(expr.Compare(BOOL, a, (op,), (b,)) for a, op, b in _pairs(e))
            return self._term(expr.BoolOp(BOOL, "and", chain), g)
        if isinstance(e, expr.Compare):
            left, right = self.lifted(e.left), self.lifted(e.comparators[0])
            split = _split_conditional(expr.Compare(BOOL, left, e.ops, (right,)))
            if split is not None:  # `(a if c else b) > k`: `(a > k) if c else (b > k)`
                return self._term(split, g)
        if isinstance(e, expr.Compare):
            scratch = Guard(g.fn)  # the atoms of this comparison, kept only if it is decidable
            pairs = [self._pair(a, op, b, scratch) for a, op, b in _pairs(e)]
            if any(p is None for p in pairs):  # beyond interval reasoning: a free boolean
                key: Key = (Atom.OPAQUE, expr.to_python(e, _spec_name))
                g.opaque.setdefault(key, None)
                g.order.setdefault(key, None)
                return (Op.GET, key)
            merge_atoms(g, scratch)
            if len(pairs) == 1:
                return pairs[0]  # type: ignore[return-value]
            return (Op.AND, tuple(pairs))
        raise TypeError(f"not a boolean expression node: {e!r}")

    def _ref(self, e: expr.Ref, g: Guard) -> Term:
        if e.kind == expr.RefKind.CONST:
            return (Op.CONST, self.constants[e.name])
        if e.kind in (
            expr.RefKind.STATUS,
            expr.RefKind.SUB_COMMAND_NAME,
            expr.RefKind.SUB_REASON_NAME,
        ):
            return (Op.CONST, e.name)
        if e.kind == expr.RefKind.SUB_REASON:
            # A reason comes only with an ERROR for the last command sent: NONE otherwise.
            status: Key = (Atom.STATUS, e.owner)
            reason: Key = (Atom.REASON, e.owner)
            self._atom(g, status, STATUS_DOMAIN)
            self._atom(g, reason, ("NONE", *BUILTIN_REASONS[1:], *self.sub_reasons[e.owner]))
            return (Op.GIVEN, status, "ERROR", reason, "NONE")
        key: Key
        # An enumeration is a finite domain of its value names; anything else read here is
        # a boolean (numbers are read by comparisons, strings never reach here: `_pair`).
        domain = e.type.values if isinstance(e.type, Enum) else BOOL_DOMAIN
        if e.kind == expr.RefKind.SUB_RESULT:
            key = (Atom.RESULT, f"{e.owner}.{e.name}")
            self._atom(g, key, domain)
        elif e.kind == expr.RefKind.SUB_STATUS:
            key = (Atom.STATUS, e.owner)
            self._atom(g, key, STATUS_DOMAIN)
        elif e.kind == expr.RefKind.SUB_COMMAND:
            key = (Atom.COMMAND, e.owner)
            self._atom(g, key, self.sub_commands[e.owner])
        elif e.kind == expr.RefKind.PLAN:  # a boolean step field of the current step
            key = (Atom.PLAN, f"{e.owner}.{e.name}")
            self._atom(g, key, BOOL_DOMAIN)
        else:  # a boolean or enumeration world field, local or parameter
            key = (_VARIABLES[e.kind], e.name)
            self._atom(g, key, domain)
        return (Op.GET, key)

    def _pair(self, a: expr.Expr, op: str, b: expr.Expr, g: Guard) -> Term | None:
        """One comparison `a op b`; None when it is not decidable by interval reasoning."""
        if isinstance(a.type, Str) or isinstance(b.type, Str):
            return None  # a string's values are not enumerated: "cannot prove" (W502)
        if a.type not in NUMERIC:  # statuses, commands, booleans, enumerations: as they are
            return (Op.PAIR, expr.COMPARISONS[op], self._term(a, g), self._term(b, g))
        types: dict[Key, solver.Number] = {}
        la, lb = self._linear(a, types), self._linear(b, types)
        if la is None or lb is None:
            return None
        diff = la.minus(lb)  # diff op 0
        if not diff.coefficients:
            return (Op.CONST, expr.COMPARISONS[op](diff.constant, 0))
        keys = sorted(diff.coefficients)
        lead = diff.coefficients[keys[0]]
        norm = diff.scaled(1 / lead)  # the first variable's coefficient becomes 1
        bound = -norm.constant
        op = op if lead > 0 else _FLIP[op]
        if len(keys) == 1:
            key, kind = keys[0], types[keys[0]]
        else:
            key = (Atom.FORM, _form_text(norm.coefficients, keys))
            kind = solver.FLOAT
            g.forms[key] = norm.coefficients
        g.types.update(types)
        g.bounds.update({k: b for k, b in self.bounds.items() if k == key})
        for plan in {name.rsplit(".", 1)[0] for kind, name in types if kind == Atom.PLAN}:
            g.invariants[f"plan {plan}"] = self.within_capacity(plan)
        self._atom(g, key)
        g.numeric.setdefault(key, (kind, set()))[1].add(bound)
        # A whole bound compared as an int: the same answer, without Fraction's slow
        # comparison for every valuation of an integer variable.
        compare = expr.COMPARISONS[op]
        return (Op.CMP, compare, key, int(bound) if bound.denominator == 1 else bound)

    def _linear(self, e: expr.Expr, types: dict[Key, solver.Number]) -> Linear | None:
        """`e` as a linear form over numeric variables with exact coefficients, else None."""
        inlined = self.inline(e)
        if inlined is not None:
            return self._linear(inlined, types)
        if isinstance(e, expr.Const):
            return Linear({}, Fraction(e.value))
        if isinstance(e, expr.Ref):
            return self._linear_ref(e, types)
        if isinstance(e, expr.Unary):
            inner = self._linear(e.operand, types)
            return inner.scaled(Fraction(-1 if e.op == "-" else 1)) if inner else None
        if isinstance(e, expr.Binary):
            left, right = self._linear(e.left, types), self._linear(e.right, types)
            if left is None or right is None:
                return None
            return _linear_binary(e.op, left, right)
        if isinstance(e, expr.Call) and e.kind == expr.CallKind.BUILTIN:
            args = [self._linear(a, types) for a in e.args]
            constants = [a.constant for a in args if a is not None and not a.coefficients]
            if len(constants) == len(args):
                return Linear({}, Fraction(_BUILTIN[e.name](*constants)))
        return None

    def _linear_ref(self, e: expr.Ref, types: dict[Key, solver.Number]) -> Linear | None:
        """A name as a linear form: a constant's value, or a numeric variable (a plan's step
        and steps within 0..capacity, its replans_left within 0..replans)."""
        key: Key
        if e.kind == expr.RefKind.CONST:
            return Linear({}, Fraction(self.constants[e.name]))
        if e.kind == expr.RefKind.PLAN:
            key = (Atom.PLAN, f"{e.owner}.{e.name}")
            capacity, replans = self.plans[e.owner]
            high = {"step": capacity, "remaining": capacity, "replans_left": replans}
            if e.name in high:
                self.bounds[key] = (Fraction(0), Fraction(high[e.name]))
        elif e.kind == expr.RefKind.SUB_RESULT:
            key = (Atom.RESULT, f"{e.owner}.{e.name}")
        elif e.kind in _VARIABLES:
            key = (_VARIABLES[e.kind], e.name)
        else:
            return None
        types[key] = _number(e.type)
        return Linear({key: Fraction(1)}, Fraction(0))


def _linear_binary(op: str, left: Linear, right: Linear) -> Linear | None:
    """`left op right` as a linear form, when it is one (a product or quotient by a
    constant, a `//` or `%` of constants)."""
    if op == "+":
        return left.minus(right.scaled(Fraction(-1)))
    if op == "-":
        return left.minus(right)
    if op == "*" and not left.coefficients:
        return right.scaled(left.constant)
    if op == "*" and not right.coefficients:
        return left.scaled(right.constant)
    if op == "/" and not right.coefficients and right.constant:
        return left.scaled(1 / right.constant)
    if op in ("//", "%") and not left.coefficients and not right.coefficients:
        if right.constant:
            return Linear({}, Fraction(expr.ARITHMETIC[op](left.constant, right.constant)))
    return None


def _number(kind: Type) -> solver.Number:
    """The solver's kind of a numeric variable of this type."""
    return solver.INT if kind == INT else solver.FLOAT


def _split_conditional(e: expr.Compare) -> expr.Expr | None:
    """A comparison with a conditional operand as a conditional of two comparisons (each
    then decided on its own), else None."""
    left, right = e.left, e.comparators[0]
    if isinstance(left, expr.IfExp):
        then = expr.Compare(BOOL, left.body, e.ops, (right,))
        other = expr.Compare(BOOL, left.orelse, e.ops, (right,))
        return expr.IfExp(BOOL, left.test, then, other)
    if isinstance(right, expr.IfExp):
        then = expr.Compare(BOOL, left, e.ops, (right.body,))
        other = expr.Compare(BOOL, left, e.ops, (right.orelse,))
        return expr.IfExp(BOOL, right.test, then, other)
    return None


def _pairs(e: expr.Compare) -> list[tuple[expr.Expr, str, expr.Expr]]:
    operands = [e.left, *e.comparators]
    return [(a, op, b) for (a, b), op in zip(pairwise(operands), e.ops, strict=True)]


def _form_text(coefficients: dict[Key, Fraction], keys: list[Key]) -> str:
    plans = {name.rsplit(".", 1)[0] for kind, name in keys if kind == Atom.PLAN}
    for plan in plans:  # a plan's step + its steps remaining: its steps, as the spec says
        step, remaining = (Atom.PLAN, f"{plan}.step"), (Atom.PLAN, f"{plan}.remaining")
        if coefficients.get(step) and coefficients.get(step) == coefficients.get(remaining):
            rest = {k: c for k, c in coefficients.items() if k not in (step, remaining)}
            steps: Key = (Atom.PLAN, f"{plan}.steps")
            return _form_text({steps: coefficients[step], **rest}, [steps, *sorted(rest)])
    text = ""
    for key in keys:
        c = coefficients[key]
        size = abs(c)
        factor = "" if size == 1 else f"{show_value(size if size.denominator > 1 else int(size))}*"
        name = show_key(key)
        if not text:
            text = f"{factor}{name}"
        else:
            text += f" {'-' if c < 0 else '+'} {factor}{name}"
    return text


# ---------------------------------------------------------------- tables


@dataclass
class _Rule:
    number: int  # 1-based position in its state
    rule: CheckedRule
    guard: Guard | None  # None: always true
    reports: bool
    target: str | None  # the next state; None: stays (or the command ends, if it reports)
    sends: tuple[Send, ...]
    fires: bool = True  # can fire: its guard can hold while every earlier one is false


def analyse_system(system: CheckedSystem, diags: Diagnostics) -> None:
    """Analyse every state table of a checked system; findings go to `diags`. Its
    controllers ask many questions alike but for names: each kind is solved once."""
    questions = Questions()
    for controller in system.controllers.values():
        if not controller.spec.is_operator:  # a person answers it: no table to analyse
            _Controller(controller, diags, questions).run()


def _exact(tree: expr.Expr) -> tuple[expr.Expr, tuple[str, ...]] | None:
    """A key that is the same for two trees only if they make the same guard: the tree,
    and its constants spelt out (trees compare their constants by value, and -0.0 == 0.0,
    1 == 1.0 == True, but a guard's terms and texts keep what was written); None for a tree
    that reads a `let` (its value is the table's own)."""
    spelt = []
    for node in expr.walk(tree):
        if type(node) is expr.Const:
            spelt.append(repr(node.value))
        elif type(node) is expr.Ref and node.kind == expr.RefKind.LET:
            return None
    return tree, tuple(spelt)


def subs_tested(guard: Guard) -> list[str]:
    """The subordinates whose status a guard tests."""
    return [name for kind, name in guard.order if kind == Atom.STATUS]


class _Controller:
    def __init__(self, checked: CheckedController, diags: Diagnostics, questions: Questions):
        self.checked, self.diags = checked, diags
        self.solve = questions.solve
        self.builder = GuardBuilder(
            {n: c.value for n, c in checked.spec.constants.items()},
            {n: p.tree for n, p in checked.predicates.items()},
            dict(checked.sub_commands),
            dict(checked.scope.sub_reasons),
        )
        self.builder.functions = {
            f.name: (tuple(p for p, _ in f.params), f.tree) for f in checked.functions.values()
        }
        self.builder.plans = {p.name: (p.capacity, p.replans) for p in checked.spec.plans.values()}
        self.built: dict[tuple[expr.Expr, tuple[str, ...]], Guard] = {}  # see `guard`
        # every_cycle rules run whatever the state: what they send or test counts everywhere
        every = checked.every_cycle
        self.every_sent = {send.sub for r in every for send in r.sends}
        self.every_reports = any(r.reports for r in every)
        self.every_guards = [self.guard(rule) for rule in every]
        self.every_tested = {sub for g in self.every_guards if g for sub in subs_tested(g)}
        self.every_handles = {
            sub for sub in self.every_tested if self.fires_on_error(self.every_guards, sub)
        }

    def guard(self, rule: CheckedRule) -> Guard | None:
        """The rule's guard, built once for each tree of the controller (a guard repeated
        in several states or tables, `sub.status == DONE`, is built the first time)."""
        if rule.unconditional or rule.guard is None:
            return None
        key = _exact(rule.guard)
        if key is None:  # (it reads a `let`: the table's own value)
            return self.builder.guard(rule.guard)
        built = self.built.get(key)
        if built is None:
            built = self.built[key] = self.builder.guard(rule.guard)
        return built

    def run(self) -> None:
        spec = self.checked.spec
        self.continued = {k for k, v in spec.on_lost.items() if v.value == "continue"}
        self.handled = set(self.every_handles)  # subordinates some rule handles the ERROR of
        for command in self.checked.commands.values():
            _Table(self, command, self.table(command)).run()
        for sub in sorted(self.continued - self.handled):
            self.diags.error(
                spec.on_lost[sub].span,
                "E802",
                f"`on_lost: continue` for `{sub}`, but no rule of `{spec.name}` handles "
                f"{sub}.status == ERROR: its loss would go unnoticed",
                f"add a rule such as `when: {sub}.status == ERROR` where `{spec.name}` waits "
                "on it, or leave the default `halt_all`",
            )

    def fires_on_error(self, guards: list[Guard | None], sub: str) -> bool:
        """Whether a rule that tests `sub`'s status can fire (first match) when it is ERROR."""
        for index, guard in enumerate(guards):
            if guard is None or sub not in subs_tested(guard):
                continue
            earlier: list[Part] = [(g, False) for g in guards[:index]]
            error: dict[Key, Any] = {(Atom.STATUS, sub): "ERROR"}
            if self.solve([(guard, True), *earlier], error).kind != Verdict.NO:
                return True
        return False

    def table(self, command: CheckedCommand) -> dict[str, list[_Rule]]:
        """The rules that can be tried (the checked states hold only those)."""
        self.builder.lets = {let.name: let.tree for let in command.lets}
        return {
            name: [
                _Rule(
                    rule.id.index,
                    rule,
                    self.guard(rule),
                    rule.reports is not None,
                    None if rule.reports else rule.next_state,
                    rule.sends,
                )
                for rule in state.rules
            ]
            for name, state in command.states.items()
        }


class _Table:
    """The checks of one command's state table."""

    def __init__(self, owner: _Controller, command: CheckedCommand, table: dict[str, list[_Rule]]):
        self.owner, self.command, self.table = owner, command, table
        self.diags, self.solve = owner.diags, owner.solve
        self.name = command.name
        self.states = command.states
        self.tested = {
            state: list(dict.fromkeys(s for r in rules if r.guard for s in subs_tested(r.guard)))
            for state, rules in table.items()
        }

    def about(self, state: str, rule: int | None = None) -> Subject:
        """What a finding about `state` (or one of its rules) is about, for acknowledgements."""
        return Subject(self.owner.checked.name, self.name, state, rule)

    def run(self) -> None:
        first_match = self.first_match()
        for state, rules in self.table.items():
            for index, rule in enumerate(rules):
                earlier = [(r.guard, False) for r in rules[:index]]
                rule.fires = self.solve([(rule.guard, True), *earlier]).kind != Verdict.NO
            self.determinism(state, rules, first_match)
        generated = self.command.generated
        for state, rules in self.table.items():
            span = self.states[state].span
            if not any(r.fires for r in rules):
                self.diags.warning(
                    self.dead_at(rules) or span,
                    "W508",
                    f"{self.name} {state} is dead: none of its rules can ever fire",
                    "its guards can never be true: check their constants and comparisons",
                    self.about(state),
                )
                continue
            if not generated:
                self.never_fires(state, rules)
            leaves = any(r.fires and (r.reports or r.target not in (None, state)) for r in rules)
            if not leaves and not self.owner.every_reports:
                self.diags.warning(
                    span,
                    "W509",
                    f"{self.name} {state} has no way out: no rule leaves it or reports, so "
                    f"`{self.owner.checked.name}` stays in {state} until a new command arrives",
                    "add a rule with `next: <another state>` or `report: DONE` / `report: ERROR`",
                    self.about(state),
                )
            if not generated:  # the default INIT/HALT tables wait for every DONE by design
                self.completeness(state, rules)
                self.errors_handled(state, rules)
        self.finishes()
        self.commanded()
        self.awaited()
        self.replans()

    def replans(self) -> None:
        """W309 for a `replan:` whose rule can fire when its plan has no replans left."""
        for state, rules in self.table.items():
            for rule in rules:
                for action in rule.rule.actions:
                    if not isinstance(action, PlanAction) or action.kind is not PlanVerb.REPLAN:
                        continue
                    plan = action.plan.name
                    left: Key = (Atom.PLAN, f"{plan}.replans_left")
                    answer = self.solve([(rule.guard, True)], fixed={left: 0})
                    tested = rule.guard is not None and left in rule.guard.order
                    if answer.kind == Verdict.NO and tested:
                        continue
                    self.diags.warning(
                        action.span,
                        "W309",
                        f"rule {rule.number} of {self.name} {state} can `replan: {plan}` when "
                        f"no replans are left ({action.plan.replans} declared): the run stops "
                        "with an error",
                        f"add `and {plan}.replans_left > 0` to its `when:`, and a rule for when "
                        "none are left",
                        self.about(state, rule.number),
                    )

    def dead_at(self, rules: list[_Rule]) -> Span | None:
        """Where a dead state's finding belongs: its first guard, which is what to fix (a
        state is dead when no rule of it can hold on its own: a contradiction in each guard,
        `x > 5 and x < 3`); None (the state) when that cannot be shown."""
        guarded = [r for r in rules if r.rule.source.when is not None]
        if len(guarded) != len(rules) or not guarded:
            return None
        if any(self.solve([(r.guard, True)]).kind != Verdict.NO for r in rules):
            return None
        when = guarded[0].rule.source.when
        return when.span if when is not None else None

    def never_fires(self, state: str, rules: list[_Rule]) -> None:
        """W512 for each rule of a live state that can never fire."""
        for index, rule in enumerate(rules):
            if rule.fires:
                continue
            if self.solve([(rule.guard, True)]).kind == Verdict.NO:
                why = "its guard can never hold"
            else:
                earlier = [r.number for r in rules[:index]]
                shown = ", ".join(str(n) for n in earlier)
                why = f"whenever its guard holds, an earlier rule ({shown}) fires first"
            self.diags.warning(
                rule.rule.span,
                "W512",
                f"rule {rule.number} of {self.name} {state} never fires: {why}",
                "check its comparisons and constants, reorder the rules, or delete it",
                self.about(state, rule.number),
            )

    # ------------------------------------------------------------ first_match

    def first_match(self) -> dict[str, Span]:
        declared: dict[str, Span] = {}
        for item in self.command.source.first_match:
            if item.value in self.states:
                declared[item.value] = item.span
            else:
                self.diags.error(
                    item.span,
                    "E510",
                    f"`first_match` names `{item.value}`, which is not a state of {self.name}",
                    known_names_hint(f"states of {self.name}", self.states, item.value),
                )
        return declared

    # ------------------------------------------------------------ determinism

    def determinism(self, state: str, rules: list[_Rule], first_match: dict[str, Span]) -> None:
        ordered = state in first_match
        overlap = False
        for j, later in enumerate(rules):
            for earlier in rules[:j]:
                answer = self.solve([(earlier.guard, True), (later.guard, True)])
                if answer.kind == Verdict.NO:
                    continue
                overlap = True
                pair = f"rules {earlier.number} and {later.number} of {self.name} {state}"
                when = _when(answer.shown)
                if answer.kind == Verdict.YES and ordered:  # first_match acknowledges the overlap
                    finding = Diagnostic(
                        later.rule.span,
                        "W501",
                        f"{pair} both hold {when}; rule {earlier.number} wins (first_match)",
                        subject=self.about(state, later.number),
                    )
                    self.diags.acknowledge(
                        finding, f"`first_match: [{state}]` on {self.name}: the earlier rule wins"
                    )
                elif answer.kind == Verdict.YES:
                    self.diags.error(
                        later.rule.span,
                        "E501",
                        f"{pair} can both fire: both hold {when}",
                        f"make the guards exclusive, or declare `first_match: [{state}]` on "
                        f"{self.name} so that rule {earlier.number} wins on purpose",
                    )
                elif not ordered:
                    if answer.kind == Verdict.MAYBE:
                        atoms = ", ".join(f"`{name}`" for _, name in answer.undecided)
                        why = f"both hold if {_valuation(answer.shown)}; "
                        why += f"interval reasoning cannot decide {atoms}"
                    else:
                        why = f"their guards have {answer.size} valuations, more than {LIMIT}"
                    self.diags.warning(
                        later.rule.span,
                        "W502",
                        f"cannot prove {pair} exclusive: {why}",
                        f"compare a variable with a constant where you can, or declare "
                        f"`first_match: [{state}]` on {self.name} if rule {earlier.number} "
                        "should win",
                        self.about(state, later.number),
                    )
        if ordered and not overlap:
            self.diags.warning(
                first_match[state],
                "W511",
                f"`first_match` on {self.name} {state} is not needed: its rules never overlap",
                "remove it, so that an overlap added later is reported as an error",
                self.about(state),
            )

    # ------------------------------------------------------------ completeness

    def completeness(self, state: str, rules: list[_Rule]) -> None:
        # Waiting while a subordinate is still EXECUTING is the command-number handshake,
        # chosen by sending it a command and testing its status: only a wait that remains
        # once every subordinate this state tests has finished (DONE or ERROR) is reported.
        # An every_cycle rule that fires acts in this state too, so it is not a wait.
        subs = {*self.tested[state], *self.owner.every_tested}
        finished: dict[Key, tuple[Any, ...]] = {(Atom.STATUS, sub): FINISHED for sub in subs}
        quiet = [(r.guard, False) for r in rules] + [(g, False) for g in self.owner.every_guards]
        # Time passes while it waits: `after:` and `for:` are read once their time has come.
        late = {key: _LATE for r in rules if r.guard for key in r.guard.order if _timer(key)}
        answer = self.solve(quiet, fixed=late, allowed=finished)
        if answer.kind == Verdict.YES:
            self.diags.warning(
                self.states[state].span,
                "W503",
                f"{self.name} {state} waits when {_valuation(answer.shown)}: no rule fires then",
                "waiting is normal in RCS; if this wait is intended, acknowledge it on "
                f"{self.name}: `allow: [{{code: W503, states: [{state}], reason: ...}}]`",
                self.about(state),
            )

    def errors_handled(self, state: str, rules: list[_Rule]) -> None:
        controller = self.owner.checked.name
        for sub in self.tested[state]:
            guards = [r.guard for r in rules]
            handled = sub in self.owner.every_handles or self.owner.fires_on_error(guards, sub)
            if handled:
                self.owner.handled.add(sub)
            elif sub in self.owner.continued:  # its loss must be handled here: an error
                self.diags.error(
                    self.states[state].span,
                    "E802",
                    f"{self.name} {state} waits on {sub}, whose loss `on_lost: continue` "
                    f"leaves to these rules, but never handles {sub}.status == ERROR",
                    f"add a rule such as `when: {sub}.status == ERROR`, or leave the default "
                    "`on_lost: halt_all`",
                )
            else:
                self.diags.warning(
                    self.states[state].span,
                    "W506",
                    f"{self.name} {state} waits on {sub} but never handles "
                    f"{sub}.status == ERROR: an ERROR from {sub} leaves {controller} "
                    f"waiting in {state} forever",
                    f"add a rule such as `when: {sub}.status == ERROR` with `do: [report: ERROR]`",
                    self.about(state),
                )

    # ------------------------------------------------------------ RCS rules

    def reach(self, start: str) -> set[str]:
        """The states the table can get to from `start` (included), by rules that can fire."""
        return reachable(
            start,
            lambda state: [r.target for r in self.table[state] if r.fires and r.target is not None],
        )

    def finishes(self) -> None:
        reached = self.reach(ENTRY_STATE)
        if self.owner.every_reports:
            return  # an every_cycle rule can end any command
        if not any(r.fires and r.reports for s in reached for r in self.table[s]):
            self.diags.error(
                self.command.source.span,
                "E504",
                f"{self.name} can never finish: no rule reachable from S0 reports DONE or ERROR",
                "a command ends only with `report: DONE` or `report: ERROR`; add a rule that "
                "reports where the table gets to",
            )

    def commanded(self) -> None:
        sent = {send.sub for rules in self.table.values() for r in rules for send in r.sends}
        sent |= self.owner.every_sent
        for state, rules in self.table.items():
            for rule in rules:
                for sub in subs_tested(rule.guard) if rule.guard else []:
                    if sub not in sent:
                        self.diags.error(
                            rule.rule.span,
                            "E507",
                            f"rule {rule.number} of {self.name} {state} tests {sub}.status, but "
                            f"{self.name} never sends {sub} a command: the status is left over "
                            "from an earlier command",
                            f"send {sub} a command in {self.name} before waiting on it, or "
                            "remove the test",
                        )

    def awaited(self) -> None:
        for state, rules in self.table.items():
            for rule in rules:
                if not rule.fires or not rule.sends:
                    continue
                after = set() if rule.reports else self.reach(rule.target or state)
                waited = {sub for s in after for sub in self.tested[s]} | self.owner.every_tested
                for send in rule.sends:
                    if send.sub in waited:
                        continue
                    why = (
                        "the command ends here"
                        if rule.reports
                        else f"no state reached afterwards tests {send.sub}.status"
                    )
                    self.diags.warning(
                        send.span,
                        "W505",
                        f"{self.name} {state} sends {send.sub}.{send.command} but never waits "
                        f"for it: {why}",
                        f"wait with `when: {send.sub}.status == DONE` in a later state, "
                        "or do not send it",
                        self.about(state, rule.number),
                    )


def _timer(key: Key) -> bool:
    return key[0] in ("time", "held")


def _valuation(shown: list[tuple[Key, Any]]) -> str:
    return show_valuation(shown) or "always"


def _when(shown: list[tuple[Key, Any]]) -> str:
    return f"when {show_valuation(shown)}" if shown else "in every cycle"
