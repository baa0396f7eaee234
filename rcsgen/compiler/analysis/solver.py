"""Solver: conjunctions of guards over finite domains -> a valuation that satisfies them, or no.

Knows nothing of RCS: a `Guard` is a function of a valuation (a dict from atom keys to
values) in Kleene's three-valued logic, with the domain of each atom it reads. Discrete
atoms take the values of their domain; a numeric atom (a variable, or a linear form of
several, compared with constants) takes one value per region its constants cut the number
line into; an opaque atom is a free boolean. `solve` searches depth first in reading order
and minimises the counter-example it finds; more than `LIMIT` valuations is "unknown".

A guard is written as a `Term` (a small tree of `Op` nodes over atom keys and values) and
evaluated by the closure `compiled` makes of it. Questions that differ only in the names of
their atoms get the same answer with the names swapped: `Questions` answers each shape of
question once (the atoms renamed in the order they are met) and maps the answer back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum
from fractions import Fraction
from itertools import pairwise, product
from typing import Any

LIMIT = 4096  # the most valuations one question may enumerate
BOOL_DOMAIN = (False, True)


class Number(StrEnum):
    """The kinds of a numeric atom: whole numbers only, or any."""

    INT = "int"
    FLOAT = "float"


INT, FLOAT = Number.INT, Number.FLOAT


class Verdict(StrEnum):
    """Whether a conjunction of guards can hold (`Answer.kind`)."""

    YES = "yes"  # a valuation that can happen makes it hold, whatever the opaque atoms
    MAYBE = "maybe"  # only for values rcsgen cannot show possible
    NO = "no"
    UNKNOWN = "unknown"  # more than LIMIT valuations


Key = tuple[str, str]  # (kind, name): what an atom is, for the caller to interpret
Valuation = dict[Key, Any]


class Op(StrEnum):
    """The nodes of a `Term`: `(Op.X, operand, ...)`, each evaluated in Kleene's logic."""

    CONST = "const"  # (CONST, value)
    GET = "get"  # (GET, key): the atom's value
    GIVEN = "given"  # (GIVEN, key, value, read, otherwise): `read`'s value where key == value
    NOT = "not"  # (NOT, term)
    AND = "and"  # (AND, (term, ...))
    OR = "or"  # (OR, (term, ...))
    IF = "if"  # (IF, test, body, orelse)
    PAIR = "pair"  # (PAIR, compare, term, term): compare(a, b) a function of two values
    CMP = "cmp"  # (CMP, compare, key, constant): a numeric atom against a constant
    AT_MOST = "at_most"  # (AT_MOST, (key, ...), constant): their sum is at most it


Term = tuple[Any, ...]


@dataclass
class Guard:
    """A guard ready to evaluate on a valuation, with the atoms it reads in reading order.

    A numeric atom is a variable or a linear form of several (`("form", "x - y")`)
    compared with constants; `numeric` holds its type and those constants, `forms` the
    coefficients of each form. `opaque` atoms are comparisons no interval reasoning decides.
    `term` is what `fn` evaluates (None: a function of its own, whose questions `Questions`
    does not share).
    """

    fn: Callable[[Valuation], Any]
    domains: dict[Key, tuple[Any, ...]] = field(default_factory=dict)  # discrete atoms
    numeric: dict[Key, tuple[Number, set[Fraction]]] = field(default_factory=dict)
    forms: dict[Key, dict[Key, Fraction]] = field(default_factory=dict)
    types: dict[Key, Number] = field(default_factory=dict)  # numeric variable -> its kind
    opaque: dict[Key, None] = field(default_factory=dict)
    order: dict[Key, None] = field(default_factory=dict)
    # the least and greatest value a numeric variable can take, where it has bounds
    bounds: dict[Key, tuple[Fraction, Fraction]] = field(default_factory=dict)
    # relations between atoms that every possible valuation keeps, by name, as terms: False
    # rules a valuation out, None is "not known yet" (an atom it reads is not set)
    invariants: dict[str, Term] = field(default_factory=dict)
    term: Term | None = None
    # the guard with its atoms numbered in the order they are met (`Questions`), once made
    shape: tuple[Pattern, tuple[Key, ...]] | None = field(default=None, repr=False)


@dataclass
class Linear:
    """sum(coefficient * variable) + constant, exactly."""

    coefficients: dict[Key, Fraction]
    constant: Fraction

    def minus(self, other: Linear) -> Linear:
        out = dict(self.coefficients)
        for key, c in other.coefficients.items():
            out[key] = out.get(key, Fraction(0)) - c
        return Linear({k: c for k, c in out.items() if c}, self.constant - other.constant)

    def scaled(self, factor: Fraction) -> Linear:
        return Linear(
            {k: c * factor for k, c in self.coefficients.items() if c * factor},
            self.constant * factor,
        )


# Guards are evaluated in Kleene's three-valued logic: an atom missing from a partial
# valuation is None (unknown), and so is everything that depends on it.


def kleene_not(value: Any) -> Any:
    return None if value is None else not value


def kleene_and(parts: list[Callable[[Valuation], Any]]) -> Callable[[Valuation], Any]:
    return _kleene(parts, False)


def kleene_or(parts: list[Callable[[Valuation], Any]]) -> Callable[[Valuation], Any]:
    return _kleene(parts, True)


def _kleene(parts: list[Callable[[Valuation], Any]], decides: bool) -> Callable[[Valuation], Any]:
    """A conjunction (`decides` False: one false part decides) or a disjunction (True)."""

    def combined(val: Valuation) -> bool | None:
        unknown = False
        for part in parts:
            value = part(val)
            if value is None:
                unknown = True
            elif bool(value) is decides:
                return decides
        return None if unknown else not decides

    return combined


def compiled(term: Term) -> Callable[[Valuation], Any]:
    """The function of a valuation that `term` is (None where it is not known yet)."""
    op = term[0]
    if op is Op.CONST:
        value = term[1]
        return lambda val: value
    if op is Op.GET:
        key = term[1]
        return lambda val: val.get(key)
    if op is Op.CMP:
        compare, key, limit = term[1:]
        return lambda val: None if (v := val.get(key)) is None else compare(v, limit)
    if op is Op.NOT:
        inner = compiled(term[1])
        return lambda val: kleene_not(inner(val))
    if op is Op.AND or op is Op.OR:
        parts = [compiled(t) for t in term[1]]
        return kleene_and(parts) if op is Op.AND else kleene_or(parts)
    if op is Op.PAIR:
        return _pair(term[1], compiled(term[2]), compiled(term[3]))
    if op is Op.IF:
        return _choose(compiled(term[1]), compiled(term[2]), compiled(term[3]))
    if op is Op.GIVEN:
        return _given(*term[1:])
    if op is Op.AT_MOST:
        return _at_most(term[1], term[2])
    raise ValueError(f"not a term: {term!r}")


def _pair(
    compare: Callable[[Any, Any], bool],
    left: Callable[[Valuation], Any],
    right: Callable[[Valuation], Any],
) -> Callable[[Valuation], Any]:
    def pair(val: Valuation) -> bool | None:
        lv, rv = left(val), right(val)
        return None if lv is None or rv is None else compare(lv, rv)

    return pair


def _choose(
    test: Callable[[Valuation], Any],
    body: Callable[[Valuation], Any],
    orelse: Callable[[Valuation], Any],
) -> Callable[[Valuation], Any]:
    def choose(val: Valuation) -> Any:
        decided = test(val)
        if decided is None:  # both values agree, or it is not known yet
            first, second = body(val), orelse(val)
            return first if first == second else None
        return body(val) if decided else orelse(val)

    return choose


def _given(key: Key, value: Any, read: Key, otherwise: Any) -> Callable[[Valuation], Any]:
    def given(val: Valuation) -> Any:
        seen = val.get(key)
        if seen is None or seen != value:
            return None if seen is None else otherwise
        return val.get(read)

    return given


def _at_most(keys: tuple[Key, ...], limit: Any) -> Callable[[Valuation], bool | None]:
    def keeps(val: Valuation) -> bool | None:
        if any(key not in val for key in keys):
            return None
        return bool(sum(val[key] for key in keys) <= limit)

    return keeps


def merge_atoms(into: Guard, atoms: Guard) -> None:
    """Add the atoms `atoms` read to `into`, keeping reading order."""
    into.order.update(atoms.order)
    into.domains.update(atoms.domains)
    into.forms.update(atoms.forms)
    into.types.update(atoms.types)
    into.opaque.update(atoms.opaque)
    into.bounds.update(atoms.bounds)
    into.invariants.update(atoms.invariants)
    for key, (kind, constants) in atoms.numeric.items():
        into.numeric.setdefault(key, (kind, set()))[1].update(constants)


def samples(kind: Number, constants: Iterable[Fraction], held: bool) -> tuple[Any, ...]:
    """One value per region the constants cut the number line into: the constants first.

    `held`: the values are a float variable's, so only values a float holds exactly. A
    constant no float holds (`1/3`, from `3 * x <= 1`) is then no sample: no float equals
    it, and the float next to it may fall either side once the generated code rounds its
    arithmetic. A value between two constants is the float nearest their middle, strictly
    inside the region, and shown as the generated code would hold it."""
    cs = sorted(set(constants))
    if kind == INT:
        points = [int(c) for c in cs if c.denominator == 1]
        between = [math.ceil(cs[0]) - 1]
        for index, c in enumerate(cs):
            above = math.floor(c) + 1
            if index + 1 == len(cs) or above < cs[index + 1]:
                between.append(above)
        return tuple(dict.fromkeys([*points, *between]))
    middles: list[Fraction] = [cs[0] - 1, *((a + b) / 2 for a, b in pairwise(cs)), cs[-1] + 1]
    if held:
        edges: list[Fraction | None] = [None, *cs, None]  # each middle's region: its neighbours
        regions = zip(middles, edges[:-1], edges[1:], strict=True)
        middles = [_inside(m, low, high) for m, low, high in regions]
        cs = [c for c in cs if _held(c)]
    return tuple(dict.fromkeys([*cs, *middles]))


def _held(value: Fraction) -> bool:
    """Whether a float holds `value` exactly."""
    try:
        return Fraction(float(value)) == value
    except OverflowError:
        return False


def _inside(middle: Fraction, low: Fraction | None, high: Fraction | None) -> Fraction:
    """The float nearest `middle`, if it is still strictly between `low` and `high`."""
    try:
        near = Fraction(float(middle))
    except OverflowError:
        return middle
    inside = (low is None or low < near) and (high is None or near < high)
    return near if inside else middle


def independent(vectors: list[dict[Key, Fraction]]) -> bool:
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

    kind: Verdict
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
        return Answer(Verdict.NO)
    guards = [(g, wanted) for g, wanted in parts if g is not None]
    domains: dict[Key, tuple[Any, ...]] = {}
    numeric: dict[Key, tuple[Number, set[Fraction]]] = {}
    forms: dict[Key, dict[Key, Fraction]] = {}
    types: dict[Key, Number] = {}
    opaque: dict[Key, None] = {}
    bounds: dict[Key, tuple[Fraction, Fraction]] = {}
    invariants: dict[str, Term] = {}
    for g, _ in guards:
        for key in g.order:
            if key in g.opaque:
                opaque.setdefault(key, None)
            else:
                domains.setdefault(key, ())
        domains.update(g.domains)
        forms.update(g.forms)
        types.update(g.types)
        bounds.update(g.bounds)
        invariants.update(g.invariants)
        for key, (kind, constants) in g.numeric.items():
            numeric.setdefault(key, (kind, set()))[1].update(constants)
    for key, (kind, constants) in numeric.items():
        held = kind == FLOAT and key not in forms  # a float variable's values (not a form's)
        if key in bounds:  # only values within them, the bounds themselves included
            low, high = bounds[key]
            values = samples(kind, {*constants, low, high}, held)
            domains[key] = tuple(v for v in values if low <= v <= high)
        else:
            domains[key] = samples(kind, constants, held)
    for key, value in (fixed or {}).items():
        if key in domains:
            domains[key] = (value,)
    for key, values in (allowed or {}).items():
        if key in domains:
            domains[key] = tuple(v for v in domains[key] if v in values)
    size = math.prod(len(d) for d in domains.values()) * 2 ** len(opaque)
    if size > LIMIT:
        return Answer(Verdict.UNKNOWN, size=size)
    keys, okeys = list(domains), list(opaque)
    keeping = tuple(compiled(t) for t in invariants.values())  # (most questions have none)

    def truth(val: dict[Key, Any]) -> bool | None:
        """Whether every guard has its wanted value: True, False or None (not known yet).
        A valuation no invariant allows is False: it cannot happen."""
        if keeping and any(keeps(val) is False for keeps in keeping):
            return False
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
        integer = any(types.get(v) == INT for k in used for v in forms[k])
        return used if integer or not independent(vectors) else []

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
                return Answer(Verdict.YES, shown, size)
            maybe.append(Answer(Verdict.MAYBE, shown, size, unsure))
            return None
        if index == len(keys):  # only opaque atoms are left undecided
            for ov in product(BOOL_DOMAIN, repeat=len(okeys)):
                at = {**val, **dict(zip(okeys, ov, strict=True))}
                if truth(at):
                    shown = [(k, at[k]) for k in [*keys, *okeys]]
                    maybe.append(Answer(Verdict.MAYBE, shown, size, okeys))
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

    try:
        return search(0, {}) or (maybe[0] if maybe else Answer(Verdict.NO, size=size))
    finally:
        # `search` calls itself through its closure: a reference cycle that would keep this
        # question's domains and guards alive until the cyclic collector ran. Broken here,
        # they are freed at once (and a build can run without that collector).
        search = None  # type: ignore[assignment]


# ---------------------------------------------------------------- questions asked again


class Pattern:
    """A guard with its atoms numbered in the order they are met, its values with their
    types: equal for guards that differ only in the names of their atoms. Hashed once."""

    __slots__ = ("_hash", "parts")

    def __init__(self, parts: tuple[Any, ...]):
        self.parts = parts
        self._hash = hash(parts)

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Pattern):
            return False
        return self._hash == other._hash and self.parts == other.parts


def _typed(value: Any) -> tuple[type, Any]:
    """A value with its type: `True`, `1` and `Fraction(1)` are equal in Python, but a
    counter-example shows them differently (`true`, `1`, `1.0`)."""
    return (type(value), value)


def _values(values: Iterable[Any]) -> tuple[tuple[type, Any], ...]:
    return tuple(_typed(v) for v in values)


def _renamed(term: Term, number: Callable[[Key], int]) -> Term:
    """`term` with each atom's key replaced by its number, each value typed."""
    op = term[0]
    if op is Op.CONST:
        return (op, _typed(term[1]))
    if op is Op.GET:
        return (op, number(term[1]))
    if op is Op.CMP:
        return (op, term[1], number(term[2]), _typed(term[3]))
    if op is Op.NOT:
        return (op, _renamed(term[1], number))
    if op is Op.AND or op is Op.OR:
        return (op, tuple(_renamed(t, number) for t in term[1]))
    if op is Op.PAIR:
        return (op, term[1], _renamed(term[2], number), _renamed(term[3], number))
    if op is Op.IF:
        return (op, *(_renamed(t, number) for t in term[1:]))
    if op is Op.GIVEN:
        key, value, read, otherwise = term[1:]
        return (op, number(key), _typed(value), number(read), _typed(otherwise))
    if op is Op.AT_MOST:
        return (op, tuple(number(k) for k in term[1]), _typed(term[2]))
    raise ValueError(f"not a term: {term!r}")


def _shape(guard: Guard, term: Term) -> tuple[Pattern, tuple[Key, ...]]:
    """Everything `solve` reads of a guard with its atoms numbered in the order they are met
    (reading order first), and the atoms in that order."""
    numbers: dict[Key, int] = {}

    def number(key: Key) -> int:
        return numbers.setdefault(key, len(numbers))

    parts = (
        tuple(number(k) for k in guard.order),
        _renamed(term, number),
        tuple(number(k) for k in guard.opaque),
        tuple((number(k), _values(d)) for k, d in guard.domains.items()),
        tuple((number(k), kind, frozenset(_values(cs))) for k, (kind, cs) in guard.numeric.items()),
        tuple(
            (number(k), tuple((number(v), _typed(c)) for v, c in coefficients.items()))
            for k, coefficients in guard.forms.items()
        ),
        tuple((number(k), kind) for k, kind in guard.types.items()),
        tuple((number(k), _typed(low), _typed(high)) for k, (low, high) in guard.bounds.items()),
        tuple(_renamed(t, number) for t in guard.invariants.values()),
    )
    return Pattern(parts), tuple(numbers)


@dataclass
class Questions:
    """`solve`, each kind of question answered once: questions whose guards are the same but
    for the names of their atoms (met in the same places, wanted the same, the same atoms
    fixed to the same values or allowed the same values) have the same answer with the names
    swapped, so the answer to the first is kept with its atoms numbered and given back to
    the others in their own names. 1,000 controllers are a few kinds of table."""

    answers: dict[Hashable, tuple[Verdict, tuple[tuple[int, Any], ...], int, tuple[int, ...]]] = (
        field(default_factory=dict)
    )
    # one Pattern object for equal patterns: a question's key then compares them by identity
    patterns: dict[Pattern, Pattern] = field(default_factory=dict)
    asked: int = 0

    def solve(
        self,
        parts: list[Part],
        fixed: dict[Key, Any] | None = None,
        allowed: dict[Key, tuple[Any, ...]] | None = None,
    ) -> Answer:
        """As `solve`; a guard with no term is asked of `solve` every time."""
        self.asked += 1
        numbers: dict[Key, int] = {}
        asked: list[Hashable] = []
        for guard, wanted in parts:
            if guard is None:
                asked.append(wanted)
                continue
            if guard.shape is None:
                if guard.term is None:
                    return solve(parts, fixed, allowed)
                pattern, keys = _shape(guard, guard.term)
                guard.shape = self.patterns.setdefault(pattern, pattern), keys
            pattern, keys = guard.shape
            atoms = tuple([numbers.setdefault(k, len(numbers)) for k in keys])
            asked.append((pattern, wanted, atoms))
        pinned = sorted((numbers[k], _typed(v)) for k, v in (fixed or {}).items() if k in numbers)
        narrowed = sorted(
            (numbers[k], _values(vs)) for k, vs in (allowed or {}).items() if k in numbers
        )
        question = (tuple(asked), tuple(pinned), tuple(narrowed))
        known = self.answers.get(question)
        if known is None:
            answer = solve(parts, fixed, allowed)
            shown = tuple((numbers[k], v) for k, v in answer.shown)
            undecided = tuple(numbers[k] for k in answer.undecided)
            known = self.answers[question] = (answer.kind, shown, answer.size, undecided)
        kind, shown, size, undecided = known
        atom = list(numbers)
        return Answer(kind, [(atom[i], v) for i, v in shown], size, [atom[i] for i in undecided])
