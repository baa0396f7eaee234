"""Analysis: static checks of checked state tables, each finding shown with a counter-example.

Runs after `check` accepted a system. Every guard is typed again (`expr`, with the scope the
checker used), predicates are inlined, and each question - can two rules of a state both
hold? can none hold? can this rule fire at all? - is decided by enumerating the valuations
of the atoms the guards mention:

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
- any other comparison of numbers (a product of variables, `//`, `%`, abs/min/max of a
  variable) is an opaque atom, free to be true or false: "cannot prove" as well.

More than `LIMIT` valuations is "cannot prove" too, never a hang. Findings are diagnostics
in the E5xx/W5xx range (`CODES`), located at the rule, state, send or command they concern.
The default INIT/HALT tables are analysed like the others, except that they wait for every
subordinate's DONE by design (the QQ1 template): W503 and W506 are not reported for them.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from fractions import Fraction
from itertools import pairwise, product
from typing import Any

from ..runtime import contract
from . import expr as X
from .check import ENTRY_STATE, Scopes, default_table
from .diagnostics import Diagnostics, Span, known_names_hint
from .model import Command, ControllerSpec, Report, Rule, Send, SystemSpec

# Every code this module reports, with its meaning (docs/diagnostics.md documents them).
CODES = {
    "E501": "two rules of one state can both fire in the same cycle (nondeterministic table)",
    "W501": "two rules of a `first_match` state can both fire: the earlier one wins",
    "W502": "cannot prove two rules of a state exclusive (a numeric comparison beyond interval "
    "reasoning, or too many valuations)",
    "W503": "a state where no rule fires for some valuation: the table waits there",
    "E504": "a command that can never finish: no rule reachable from S0 reports DONE or ERROR",
    "W505": "a command sent to a subordinate whose status no later state tests",
    "W506": "a state waits on a subordinate but no rule fires on its ERROR",
    "E507": "a guard tests the status of a subordinate the table never commands",
    "W508": "a dead state: none of its rules can ever fire",
    "W509": "a state with no way out: no rule leaves it or reports",
    "E510": "`first_match` names a state the command does not have",
    "W511": "`first_match` on a state whose rules never overlap",
}

LIMIT = 4096  # the most valuations one question may enumerate
STATUS_DOMAIN = ("EXECUTING", "DONE", "ERROR")
FINISHED = ("DONE", "ERROR")  # the statuses of a subordinate that has finished
BOOL_DOMAIN = (False, True)

Key = tuple[str, str]  # (world|local|param|status|command|form|opaque, name or text)

_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
_ARITH: dict[str, Callable[[Any, Any], Any]] = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "//": operator.floordiv,
    "%": operator.mod,
}
_BUILTIN: dict[str, Callable[..., Any]] = {"abs": abs, "min": min, "max": max}
_VARIABLES = ("world", "local", "param")


# ---------------------------------------------------------------- guards


@dataclass
class Guard:
    """A guard ready to evaluate on a valuation, with the atoms it reads in reading order.

    A numeric atom is a variable or a linear form of several (`("form", "x - world.pose_x")`)
    compared with constants; `numeric` holds its type and those constants, `forms` the
    coefficients of each form. `opaque` atoms are comparisons no interval reasoning decides.
    """

    fn: Callable[[dict[Key, Any]], Any]
    domains: dict[Key, tuple[Any, ...]] = field(default_factory=dict)  # discrete atoms
    numeric: dict[Key, tuple[str, set[Fraction]]] = field(default_factory=dict)
    forms: dict[Key, dict[Key, Fraction]] = field(default_factory=dict)
    types: dict[Key, str] = field(default_factory=dict)  # numeric variable -> int or float
    opaque: dict[Key, None] = field(default_factory=dict)
    order: dict[Key, None] = field(default_factory=dict)

    def subs_tested(self) -> list[str]:
        """The subordinates whose status this guard tests."""
        return [name for kind, name in self.order if kind == "status"]


def show_key(key: Key) -> str:
    kind, name = key
    if kind == "world":
        return f"world.{name}"
    if kind in ("status", "command"):
        return f"{name}.{kind}"
    if kind in ("opaque", "form"):
        return f"({name})"
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


def _spec_name(ref: X.Ref) -> str:
    if ref.kind == "world":
        return f"world.{ref.name}"
    if ref.kind in ("sub_status", "sub_command"):
        return f"{ref.owner}.{ref.name}"
    return ref.name


_FLIP = {"==": "==", "!=": "!=", "<": ">", "<=": ">=", ">": "<", ">=": "<="}


@dataclass
class _Linear:
    """sum(coefficient * variable) + constant, exactly."""

    coefficients: dict[Key, Fraction]
    constant: Fraction

    def minus(self, other: _Linear) -> _Linear:
        out = dict(self.coefficients)
        for key, c in other.coefficients.items():
            out[key] = out.get(key, Fraction(0)) - c
        return _Linear({k: c for k, c in out.items() if c}, self.constant - other.constant)

    def scaled(self, factor: Fraction) -> _Linear:
        return _Linear(
            {k: c * factor for k, c in self.coefficients.items() if c * factor},
            self.constant * factor,
        )


class Compiler:
    """Typed trees of one controller -> `Guard`s (predicates inlined, constants folded)."""

    def __init__(
        self,
        constants: dict[str, Any],
        predicates: dict[str, X.Expr],
        sub_commands: dict[str, tuple[str, ...]],
    ):
        self.constants, self.predicates, self.sub_commands = constants, predicates, sub_commands

    def guard(self, tree: X.Expr) -> Guard:
        guard = Guard(lambda val: True)
        guard.fn = self._fn(tree, guard)
        return guard

    def _atom(self, guard: Guard, key: Key, domain: tuple[Any, ...] | None = None) -> None:
        guard.order.setdefault(key, None)
        if domain is not None:
            guard.domains[key] = domain

    def _fn(self, e: X.Expr, g: Guard) -> Callable[[dict[Key, Any]], Any]:
        if isinstance(e, X.Const):
            value = e.value
            return lambda val: value
        if isinstance(e, X.Ref):
            return self._ref(e, g)
        if isinstance(e, X.Call) and e.kind == "predicate":
            return self._fn(self.predicates[e.name], g)
        if isinstance(e, X.Unary) and e.op == "not":
            inner = self._fn(e.operand, g)
            return lambda val: _not(inner(val))
        if isinstance(e, X.BoolOp):
            parts = [self._fn(v, g) for v in e.values]
            return _and(parts) if e.op == "and" else _or(parts)
        if isinstance(e, X.Compare):
            scratch = Guard(g.fn)  # the atoms of this comparison, kept only if it is decidable
            pairs = [self._pair(a, op, b, scratch) for a, op, b in _pairs(e)]
            if any(p is None for p in pairs):  # beyond interval reasoning: a free boolean
                key: Key = ("opaque", X.to_python(e, _spec_name))
                g.opaque.setdefault(key, None)
                g.order.setdefault(key, None)
                return lambda val: val.get(key)
            _merge(g, scratch)
            if len(pairs) == 1:
                return pairs[0]  # type: ignore[return-value]
            return _and(pairs)  # type: ignore[arg-type]
        raise TypeError(f"not a boolean expression node: {e!r}")

    def _ref(self, e: X.Ref, g: Guard) -> Callable[[dict[Key, Any]], Any]:
        if e.kind == "const":
            value = self.constants[e.name]
            return lambda val: value
        if e.kind in ("status", "sub_command_name"):
            name = e.name
            return lambda val: name
        if e.kind == "sub_status":
            key: Key = ("status", e.owner)
            self._atom(g, key, STATUS_DOMAIN)
        elif e.kind == "sub_command":
            key = ("command", e.owner)
            self._atom(g, key, self.sub_commands[e.owner])
        else:  # a boolean world field, local or parameter (numbers are read by comparisons)
            key = (e.kind, e.name)
            self._atom(g, key, BOOL_DOMAIN)
        return lambda val: val.get(key)

    def _pair(
        self, a: X.Expr, op: str, b: X.Expr, g: Guard
    ) -> Callable[[dict[Key, Any]], Any] | None:
        """One comparison `a op b`; None when it is not decidable by interval reasoning."""
        compare = _COMPARE[op]
        if a.type not in X.NUMERIC:  # statuses, commands, booleans: evaluated as they are
            left, right = self._fn(a, g), self._fn(b, g)

            def pair(val: dict[Key, Any]) -> bool | None:
                lv, rv = left(val), right(val)
                return None if lv is None or rv is None else compare(lv, rv)

            return pair
        types: dict[Key, str] = {}
        la, lb = self._linear(a, types), self._linear(b, types)
        if la is None or lb is None:
            return None
        diff = la.minus(lb)  # diff op 0
        if not diff.coefficients:
            truth = compare(diff.constant, 0)
            return lambda val: truth
        keys = sorted(diff.coefficients)
        lead = diff.coefficients[keys[0]]
        norm = diff.scaled(1 / lead)  # the first variable's coefficient becomes 1
        bound = -norm.constant
        op = op if lead > 0 else _FLIP[op]
        compare = _COMPARE[op]
        if len(keys) == 1:
            key, kind = keys[0], types[keys[0]]
        else:
            key = ("form", _form_text(norm.coefficients, keys))
            kind = X.FLOAT
            g.forms[key] = norm.coefficients
        g.types.update(types)
        self._atom(g, key)
        g.numeric.setdefault(key, (kind, set()))[1].add(bound)
        return lambda val: None if (v := val.get(key)) is None else compare(v, bound)

    def _linear(self, e: X.Expr, types: dict[Key, str]) -> _Linear | None:
        """`e` as a linear form over numeric variables with exact coefficients, else None."""
        if isinstance(e, X.Const):
            return _Linear({}, Fraction(e.value))
        if isinstance(e, X.Ref):
            if e.kind == "const":
                return _Linear({}, Fraction(self.constants[e.name]))
            if e.kind in _VARIABLES:
                key = (e.kind, e.name)
                types[key] = e.type
                return _Linear({key: Fraction(1)}, Fraction(0))
            return None
        if isinstance(e, X.Unary):
            inner = self._linear(e.operand, types)
            return inner.scaled(Fraction(-1 if e.op == "-" else 1)) if inner else None
        if isinstance(e, X.Binary):
            left, right = self._linear(e.left, types), self._linear(e.right, types)
            if left is None or right is None:
                return None
            if e.op == "+":
                return left.minus(right.scaled(Fraction(-1)))
            if e.op == "-":
                return left.minus(right)
            if e.op == "*" and not left.coefficients:
                return right.scaled(left.constant)
            if e.op == "*" and not right.coefficients:
                return left.scaled(right.constant)
            if e.op == "/" and not right.coefficients and right.constant:
                return left.scaled(1 / right.constant)
            if e.op in ("//", "%") and not left.coefficients and not right.coefficients:
                if right.constant:
                    return _Linear({}, Fraction(_ARITH[e.op](left.constant, right.constant)))
            return None
        if isinstance(e, X.Call) and e.kind == "builtin":
            args = [self._linear(a, types) for a in e.args]
            if all(a is not None and not a.coefficients for a in args):
                return _Linear({}, Fraction(_BUILTIN[e.name](*(a.constant for a in args))))
        return None


# Guards are evaluated in Kleene's three-valued logic: an atom missing from a partial
# valuation is None (unknown), and so is everything that depends on it.


def _not(value: Any) -> Any:
    return None if value is None else not value


def _and(parts: list[Callable[[dict[Key, Any]], Any]]) -> Callable[[dict[Key, Any]], Any]:
    def conjunction(val: dict[Key, Any]) -> bool | None:
        unknown = False
        for part in parts:
            value = part(val)
            if value is None:
                unknown = True
            elif not value:
                return False
        return None if unknown else True

    return conjunction


def _or(parts: list[Callable[[dict[Key, Any]], Any]]) -> Callable[[dict[Key, Any]], Any]:
    def disjunction(val: dict[Key, Any]) -> bool | None:
        unknown = False
        for part in parts:
            value = part(val)
            if value is None:
                unknown = True
            elif value:
                return True
        return None if unknown else False

    return disjunction


def _merge(into: Guard, atoms: Guard) -> None:
    """Add the atoms `atoms` read to `into`, keeping reading order."""
    into.order.update(atoms.order)
    into.domains.update(atoms.domains)
    into.forms.update(atoms.forms)
    into.types.update(atoms.types)
    into.opaque.update(atoms.opaque)
    for key, (kind, constants) in atoms.numeric.items():
        into.numeric.setdefault(key, (kind, set()))[1].update(constants)


def _pairs(e: X.Compare) -> list[tuple[X.Expr, str, X.Expr]]:
    operands = [e.left, *e.comparators]
    return [(a, op, b) for (a, b), op in zip(pairwise(operands), e.ops, strict=True)]


def _form_text(coefficients: dict[Key, Fraction], keys: list[Key]) -> str:
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


def samples(kind: str, constants: Iterable[Fraction]) -> tuple[Any, ...]:
    """One value per region the constants cut the number line into: the constants first."""
    cs = sorted(set(constants))
    if kind == X.INT:
        points = [int(c) for c in cs if c.denominator == 1]
        between = [math.ceil(cs[0]) - 1]
        for index, c in enumerate(cs):
            above = math.floor(c) + 1
            if index + 1 == len(cs) or above < cs[index + 1]:
                between.append(above)
        return tuple(dict.fromkeys([*points, *between]))
    between = [cs[0] - 1, *((a + b) / 2 for a, b in pairwise(cs)), cs[-1] + 1]
    return tuple(dict.fromkeys([*cs, *between]))


def _independent(vectors: list[dict[Key, Fraction]]) -> bool:
    """Whether the vectors are linearly independent (exact Gaussian elimination)."""
    rows = [dict(v) for v in vectors]
    for index, row in enumerate(rows):
        if not row:
            return False
        pivot = min(row)
        for other in rows[index + 1 :]:
            if pivot in other:
                factor = other[pivot] / row[pivot]
                for key, c in row.items():
                    value = other.get(key, Fraction(0)) - factor * c
                    if value:
                        other[key] = value
                    else:
                        other.pop(key, None)
    return True


# ---------------------------------------------------------------- deciding


@dataclass
class Answer:
    """Whether a conjunction of guards (each wanted true or false) can hold.

    kind: "yes" (a valuation that can happen makes it hold, whatever the opaque atoms),
    "maybe" (it holds only for values rcsgen cannot show possible: opaque atoms, or linear
    forms of integers or of related variables), "no", or "unknown" (more than LIMIT
    valuations). `shown` is the counter-example without the atoms whose value does not
    matter; `undecided` names the atoms a "maybe" depends on.
    """

    kind: str
    shown: list[tuple[Key, Any]] = field(default_factory=list)
    size: int = 0
    undecided: list[Key] = field(default_factory=list)


Part = tuple[Guard | None, bool]  # a guard (None: no `when`, always true) that must be so
_MINIMISE = 8  # the most candidate counter-examples minimised per question


def solve(
    parts: list[Part],
    fixed: dict[Key, Any] | None = None,
    allowed: dict[Key, tuple[Any, ...]] | None = None,
) -> Answer:
    """Search a valuation under which every guard of `parts` has the wanted truth value;
    `fixed` pins atoms to one value, `allowed` narrows them to some values."""
    if any(g is None and not wanted for g, wanted in parts):
        return Answer("no")
    guards = [(g, wanted) for g, wanted in parts if g is not None]
    domains: dict[Key, tuple[Any, ...]] = {}
    numeric: dict[Key, tuple[str, set[Fraction]]] = {}
    forms: dict[Key, dict[Key, Fraction]] = {}
    types: dict[Key, str] = {}
    opaque: dict[Key, None] = {}
    for g, _ in guards:
        for key in g.order:
            if key in g.opaque:
                opaque.setdefault(key, None)
            else:
                domains.setdefault(key, ())
        domains.update(g.domains)
        forms.update(g.forms)
        types.update(g.types)
        for key, (kind, constants) in g.numeric.items():
            numeric.setdefault(key, (kind, set()))[1].update(constants)
    for key, (kind, constants) in numeric.items():
        domains[key] = samples(kind, constants)
    for key, value in (fixed or {}).items():
        if key in domains:
            domains[key] = (value,)
    for key, values in (allowed or {}).items():
        if key in domains:
            domains[key] = tuple(v for v in domains[key] if v in values)
    size = math.prod(len(d) for d in domains.values()) * 2 ** len(opaque)
    if size > LIMIT:
        return Answer("unknown", size=size)
    keys, okeys = list(domains), list(opaque)

    def truth(val: dict[Key, Any]) -> bool | None:
        """Whether every guard has its wanted value: True, False or None (not known yet)."""
        unknown = False
        for g, wanted in guards:
            value = g.fn(val)
            if value is None:
                unknown = True
            elif bool(value) != wanted:
                return False
        return None if unknown else True

    def always(val: dict[Key, Any], free: list[Key]) -> bool:
        """Holds for every value of the `free` atoms and of the opaque atoms."""
        rest = {k: v for k, v in val.items() if k not in free}
        known = truth(rest)
        if known is not None:
            return known
        for values in product(*(domains[k] for k in free)):
            at = {**rest, **dict(zip(free, values, strict=True))}
            for ov in product(BOOL_DOMAIN, repeat=len(okeys)):
                if not truth({**at, **dict(zip(okeys, ov, strict=True))}):
                    return False
        return True

    def uncertain(shown: Iterable[Key]) -> list[Key]:
        """The forms that keep these numeric atoms from being set independently, if any."""
        numeric_keys = [k for k in shown if k in numeric]
        used = [k for k in numeric_keys if k in forms]
        if not used:
            return []
        vectors = [forms.get(k, {k: Fraction(1)}) for k in numeric_keys]
        integer = any(types.get(v) == X.INT for k in used for v in forms[k])
        return used if integer or not _independent(vectors) else []

    maybe: list[Answer] = []
    tries = 0

    def search(index: int, val: dict[Key, Any]) -> Answer | None:
        """Depth first over the atoms in reading order, pruning as soon as a guard is known."""
        nonlocal tries
        known = truth(val)
        if known is False:
            return None
        if known is True:  # holds for every value of the atoms not set yet
            if tries >= _MINIMISE:
                return None
            tries += 1
            free: list[Key] = []
            for key in reversed([k for k in keys if k in val]):  # keep the first mentioned
                if always(val, [key, *free]):
                    free.insert(0, key)
            shown = [(k, val[k]) for k in keys if k in val and k not in free]
            unsure = uncertain(k for k, _ in shown)
            if not unsure:
                return Answer("yes", shown, size)
            maybe.append(Answer("maybe", shown, size, unsure))
            return None
        if index == len(keys):  # only opaque atoms are left undecided
            for ov in product(BOOL_DOMAIN, repeat=len(okeys)):
                at = {**val, **dict(zip(okeys, ov, strict=True))}
                if truth(at):
                    shown = [(k, at[k]) for k in [*keys, *okeys]]
                    maybe.append(Answer("maybe", shown, size, okeys))
                    break
            return None
        key = keys[index]
        for value in domains[key]:
            val[key] = value
            answer = search(index + 1, val)
            del val[key]
            if answer is not None:
                return answer
        return None

    return search(0, {}) or (maybe[0] if maybe else Answer("no", size=size))


# ---------------------------------------------------------------- tables


@dataclass
class _Rule:
    number: int  # 1-based position in its state
    rule: Rule
    guard: Guard | None  # None: always true
    reports: bool
    target: str | None  # the next state; None: stays (or the command ends, if it reports)
    sends: list[Send]
    fires: bool = True  # can fire: its guard can hold while every earlier one is false


def _commands(spec: ControllerSpec) -> dict[str, Command]:
    """The controller's commands, with the default INIT/HALT tables (as the checker has them)."""
    subs = [s.value for s in spec.subordinates]
    commands = {
        name: spec.commands.get(name) or default_table(name, subs, spec.span)
        for name in contract.BUILTIN_COMMANDS
    }
    commands.update((n, c) for n, c in spec.commands.items() if n not in commands)
    return commands


def _unconditional(rule: Rule) -> bool:
    return rule.when is None or rule.when.value is True


def analyse_system(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> None:
    """Analyse every state table of a checked system; findings go to `diags`."""
    scopes = Scopes(system, controllers)
    for spec in controllers:
        _Controller(scopes, spec, diags).run()


class _Controller:
    def __init__(self, scopes: Scopes, spec: ControllerSpec, diags: Diagnostics):
        self.scopes, self.spec, self.diags = scopes, spec, diags
        by_name = scopes.by_name
        scope = scopes.scope(spec.name, None)
        quiet = Diagnostics()
        predicates = {
            name: X.compile_expr(item.value, item.span, scope, quiet, X.BOOL)
            for name, item in spec.predicates.items()
        }
        sub_commands = {s.value: tuple(_commands(by_name[s.value])) for s in spec.subordinates}
        self.compiler = Compiler(
            {n: c.value for n, c in spec.constants.items()},
            {n: t for n, t in predicates.items() if t is not None},
            sub_commands,
        )
        self.ok = not quiet.errors
        # every_cycle rules run whatever the state: what they send or test counts everywhere
        self.every_sent = {
            a.sub for r in spec.every_cycle for a in r.actions if isinstance(a, Send)
        }
        self.every_reports = any(isinstance(a, Report) for r in spec.every_cycle for a in r.actions)
        every: list[Guard | None] = []
        for rule in spec.every_cycle:
            every.append(self.guard(rule, scope))
            if _unconditional(rule):
                break
        self.every_guards = every
        self.every_tested = {sub for g in every if g for sub in g.subs_tested()}
        self.every_handles = {sub for sub in self.every_tested if _fires_on_error(every, sub)}

    def guard(self, rule: Rule, scope: X.Scope) -> Guard | None:
        if _unconditional(rule):
            return None
        quiet = Diagnostics()
        tree = X.compile_expr(rule.when.value, rule.when.span, scope, quiet, X.BOOL)
        if tree is None:
            self.ok = False
            return None
        return self.compiler.guard(tree)

    def run(self) -> None:
        if not self.ok:
            return
        for command in _commands(self.spec).values():
            table = self.table(command)
            if self.ok:
                _Table(self, command, table).run()

    def table(self, command: Command) -> dict[str, list[_Rule]]:
        """The rules that can be tried: none after one without a guard (W301)."""
        scope = self.scopes.scope(self.spec.name, command)
        table: dict[str, list[_Rule]] = {}
        for name, state in command.states.items():
            rules = table[name] = []
            for number, rule in enumerate(state.rules, start=1):
                rules.append(
                    _Rule(
                        number,
                        rule,
                        self.guard(rule, scope),
                        any(isinstance(a, Report) for a in rule.actions),
                        rule.next.value if rule.next is not None else None,
                        [a for a in rule.actions if isinstance(a, Send)],
                    )
                )
                if _unconditional(rule):
                    break
        return table


class _Table:
    """The checks of one command's state table."""

    def __init__(self, owner: _Controller, command: Command, table: dict[str, list[_Rule]]):
        self.owner, self.command, self.table = owner, command, table
        self.diags = owner.diags
        self.name = command.name
        self.states = command.states
        self.tested = {
            state: list(dict.fromkeys(s for r in rules if r.guard for s in r.guard.subs_tested()))
            for state, rules in table.items()
        }

    def run(self) -> None:
        first_match = self.first_match()
        for state, rules in self.table.items():
            for index, rule in enumerate(rules):
                earlier = [(r.guard, False) for r in rules[:index]]
                rule.fires = solve([(rule.guard, True), *earlier]).kind != "no"
            self.determinism(state, rules, first_match)
        generated = self.command.generated
        for state, rules in self.table.items():
            span = self.states[state].span
            if not any(r.fires for r in rules):
                self.diags.warning(
                    span,
                    "W508",
                    f"{self.name} {state} is dead: none of its rules can ever fire",
                    "its guards can never be true: check their constants and comparisons",
                )
                continue
            leaves = any(r.fires and (r.reports or r.target not in (None, state)) for r in rules)
            if not leaves and not self.owner.every_reports:
                self.diags.warning(
                    span,
                    "W509",
                    f"{self.name} {state} has no way out: no rule leaves it or reports, so "
                    f"`{self.owner.spec.name}` stays in {state} until a new command arrives",
                    "add a rule with `next: <another state>` or `report: DONE` / `report: ERROR`",
                )
            if not generated:  # the default INIT/HALT tables wait for every DONE by design
                self.completeness(state, rules)
                self.errors_handled(state, rules)
        self.finishes()
        self.commanded()
        self.awaited()

    # ------------------------------------------------------------ first_match

    def first_match(self) -> dict[str, Span]:
        declared: dict[str, Span] = {}
        for item in self.command.first_match:
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
                answer = solve([(earlier.guard, True), (later.guard, True)])
                if answer.kind == "no":
                    continue
                overlap = True
                pair = f"rules {earlier.number} and {later.number} of {self.name} {state}"
                when = _when(answer.shown)
                if answer.kind == "yes" and ordered:
                    self.diags.warning(
                        later.rule.span,
                        "W501",
                        f"{pair} both hold {when}; rule {earlier.number} wins (first_match)",
                    )
                elif answer.kind == "yes":
                    self.diags.error(
                        later.rule.span,
                        "E501",
                        f"{pair} can both fire: both hold {when}",
                        f"make the guards exclusive, or declare `first_match: [{state}]` on "
                        f"{self.name} so that rule {earlier.number} wins on purpose",
                    )
                elif not ordered:
                    if answer.kind == "maybe":
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
                    )
        if ordered and not overlap:
            self.diags.warning(
                first_match[state],
                "W511",
                f"`first_match` on {self.name} {state} is not needed: its rules never overlap",
                "remove it, so that an overlap added later is reported as an error",
            )

    # ------------------------------------------------------------ completeness

    def completeness(self, state: str, rules: list[_Rule]) -> None:
        # Waiting while a subordinate is still EXECUTING is the command-number handshake,
        # chosen by sending it a command and testing its status: only a wait that remains
        # once every subordinate this state tests has finished (DONE or ERROR) is reported.
        # An every_cycle rule that fires acts in this state too, so it is not a wait.
        subs = {*self.tested[state], *self.owner.every_tested}
        finished = {("status", sub): FINISHED for sub in subs}
        quiet = [(r.guard, False) for r in rules] + [(g, False) for g in self.owner.every_guards]
        answer = solve(quiet, allowed=finished)
        if answer.kind == "yes":
            self.diags.warning(
                self.states[state].span,
                "W503",
                f"{self.name} {state} waits when {_valuation(answer.shown)}: no rule fires then",
                "waiting is normal in RCS; make sure this state should wait here "
                "(warnings fail only a --strict build)",
            )

    def errors_handled(self, state: str, rules: list[_Rule]) -> None:
        controller = self.owner.spec.name
        for sub in self.tested[state]:
            guards = [r.guard for r in rules]
            if sub not in self.owner.every_handles and not _fires_on_error(guards, sub):
                self.diags.warning(
                    self.states[state].span,
                    "W506",
                    f"{self.name} {state} waits on {sub} but never handles "
                    f"{sub}.status == ERROR: an ERROR from {sub} leaves {controller} "
                    f"waiting in {state} forever",
                    f"add a rule such as `when: {sub}.status == ERROR` with `do: [report: ERROR]`",
                )

    # ------------------------------------------------------------ RCS rules

    def reach(self, start: str) -> set[str]:
        """The states the table can get to from `start` (included), by rules that can fire."""
        reached, todo = {start}, [start]
        while todo:
            for rule in self.table[todo.pop()]:
                if rule.fires and rule.target is not None and rule.target not in reached:
                    reached.add(rule.target)
                    todo.append(rule.target)
        return reached

    def finishes(self) -> None:
        reached = self.reach(ENTRY_STATE)
        if self.owner.every_reports:
            return  # an every_cycle rule can end any command
        if not any(r.fires and r.reports for s in reached for r in self.table[s]):
            self.diags.error(
                self.command.span,
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
                for sub in rule.guard.subs_tested() if rule.guard else []:
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
                    )


def _fires_on_error(guards: list[Guard | None], sub: str) -> bool:
    """Whether a rule that tests `sub`'s status can fire (first match) when it is ERROR."""
    for index, guard in enumerate(guards):
        if guard is None or sub not in guard.subs_tested():
            continue
        earlier: list[Part] = [(g, False) for g in guards[:index]]
        if solve([(guard, True), *earlier], {("status", sub): "ERROR"}).kind != "no":
            return True
    return False


def _valuation(shown: list[tuple[Key, Any]]) -> str:
    return show_valuation(shown) or "always"


def _when(shown: list[tuple[Key, Any]]) -> str:
    return f"when {show_valuation(shown)}" if shown else "in every cycle"
