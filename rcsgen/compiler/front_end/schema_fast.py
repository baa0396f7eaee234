"""Compiled schema checks: a JSON schema -> one `valid(document) -> bool` function.

`jsonschema` walks a schema anew for every document (its `iter_errors` over the controller
schema costs ~10 ms a file, a third of a build); almost every document is valid, and the
question asked of it first is only "is anything wrong?". This module answers that question
fast: it turns each schema node once into a closure that tests exactly what the node says,
for the keywords the spec schemas use (Draft 2020-12 semantics, with YAML's integer: an `int`
and not a `bool`). `schema.check_document` asks it first and hands a document to
`jsonschema` for located diagnostics only when it says invalid, so the diagnostics stay
jsonschema's and a valid document costs a fraction of a millisecond.

A schema using a keyword not understood here is refused (`Unsupported`) rather than
half-checked: the caller then validates with `jsonschema` alone. Annotations (`title`,
`description`, ...) are ignored, as a validator does.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any

Check = Callable[[object], bool]

# Keywords that only annotate; they never make a document invalid.
_ANNOTATIONS = frozenset(
    ("$schema", "$id", "$defs", "$comment", "title", "description", "default", "examples")
)


class Unsupported(ValueError):
    """The schema uses a keyword (or a form of one) these checks do not implement."""


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


_TYPES: dict[str, Check] = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    "number": _is_number,
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
}


def equal(one: object, two: object) -> bool:
    """JSON equality: `true` is not `1`, `1` is `1.0`, containers compared item by item."""
    if isinstance(one, bool) or isinstance(two, bool):
        return isinstance(one, bool) and isinstance(two, bool) and one == two
    if isinstance(one, str) or isinstance(two, str):
        return one == two
    if isinstance(one, dict) and isinstance(two, dict):
        return one.keys() == two.keys() and all(equal(one[k], two[k]) for k in one)
    if isinstance(one, list) and isinstance(two, list):
        return len(one) == len(two) and all(equal(a, b) for a, b in zip(one, two, strict=True))
    if isinstance(one, dict | list) or isinstance(two, dict | list):
        return False
    return one == two


def _unique(items: list[object]) -> bool:
    """No two items `equal`: by their hashable keys (linear: a system's module list grows
    with the system); pairwise when a NaN (equal to nothing, itself too) or a value Python
    cannot hash makes keys unfit."""
    try:
        return len({_key(item) for item in items}) == len(items)
    except (_NotANumber, TypeError):  # TypeError: a value Python cannot hash
        return all(not equal(a, b) for i, a in enumerate(items) for b in items[i + 1 :])


class _NotANumber(Exception):
    pass


def _key(value: object) -> object:
    """A hashable key equal for two values just when they are `equal`."""
    if isinstance(value, bool):
        return ("bool", value)
    if isinstance(value, str):
        return ("str", value)
    if isinstance(value, dict):
        return ("object", frozenset((k, _key(v)) for k, v in value.items()))
    if isinstance(value, list):
        return ("array", tuple(_key(v) for v in value))
    if isinstance(value, float) and value != value:
        raise _NotANumber
    return ("other", value)  # numbers (1 and 1.0 alike), None


class _Compiler:
    def __init__(self, root: Mapping[str, Any]) -> None:
        self.root = root
        self.refs: dict[str, Check] = {}

    def ref(self, pointer: str) -> Check:
        if not pointer.startswith("#/$defs/") or "/" in pointer[len("#/$defs/") :]:
            raise Unsupported(f"$ref {pointer!r}: only local `#/$defs/<name>` references")
        if pointer not in self.refs:
            name = pointer[len("#/$defs/") :]
            target = self.root.get("$defs", {}).get(name)
            if target is None:
                raise Unsupported(f"$ref {pointer!r} names no definition")
            cell: list[Check] = []
            self.refs[pointer] = lambda value: cell[0](value)  # recursion-safe forward
            cell.append(self.compile(target))
        return self.refs[pointer]

    def compile(self, schema: object) -> Check:
        if schema is True:
            return lambda _value: True
        if schema is False:
            return lambda _value: False
        if not isinstance(schema, Mapping):
            raise Unsupported(f"schema {schema!r} is neither a mapping nor a boolean")
        checks: list[Check] = []
        keys = set(schema) - _ANNOTATIONS
        for keyword in ("then", "else"):  # they act only through `if`
            keys.discard(keyword)
        for keyword in sorted(keys):
            build = _KEYWORDS.get(keyword)
            if build is None:
                raise Unsupported(f"keyword {keyword!r}")
            check = build(self, schema[keyword], schema)
            if check is not None:
                checks.append(check)
        if not checks:
            return lambda _value: True
        if len(checks) == 1:
            return checks[0]
        ordered = tuple(checks)

        def every(value: object) -> bool:  # (a loop: all() over a generator costs more)
            for check in ordered:
                if not check(value):
                    return False
            return True

        return every


Builder = Callable[[_Compiler, Any, Mapping[str, Any]], Check | None]


def _type(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    names = [arg] if isinstance(arg, str) else list(arg)
    if any(name not in _TYPES for name in names):
        raise Unsupported(f"type {arg!r}")
    tests = tuple(_TYPES[name] for name in names)
    if len(tests) == 1:
        return tests[0]
    return lambda value: any(test(value) for test in tests)


def _properties(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    subs = {name: c.compile(sub) for name, sub in arg.items()}

    def check(value: object) -> bool:
        if not isinstance(value, dict):
            return True
        for name, sub in subs.items():
            if name in value and not sub(value[name]):
                return False
        return True

    return check


def _additional(c: _Compiler, arg: Any, schema: Mapping[str, Any]) -> Check:
    if "patternProperties" in schema:
        raise Unsupported("additionalProperties with patternProperties")
    known = frozenset(schema.get("properties", {}))
    if arg is False:
        return lambda value: not isinstance(value, dict) or known.issuperset(value)
    sub = c.compile(arg)
    return lambda value: (
        not isinstance(value, dict)
        or all(sub(item) for key, item in value.items() if key not in known)
    )


def _property_names(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    sub = c.compile(arg)
    return lambda value: not isinstance(value, dict) or all(sub(key) for key in value)


def _required(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    names = tuple(arg)
    return lambda value: not isinstance(value, dict) or all(name in value for name in names)


def _dependent_required(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    pairs = tuple((key, tuple(needed)) for key, needed in arg.items())
    return lambda value: (
        not isinstance(value, dict)
        or all(all(name in value for name in needed) for key, needed in pairs if key in value)
    )


def _min_properties(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not isinstance(value, dict) or len(value) >= arg


def _items(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    if not isinstance(arg, Mapping | bool):
        raise Unsupported("items as a list (use prefixItems)")
    sub = c.compile(arg)
    return lambda value: not isinstance(value, list) or all(sub(item) for item in value)


def _min_items(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not isinstance(value, list) or len(value) >= arg


def _unique_items(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check | None:
    if not arg:
        return None
    return lambda value: not isinstance(value, list) or _unique(value)


def _pattern(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    search = re.compile(arg).search
    return lambda value: not isinstance(value, str) or search(value) is not None


def _min_length(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not isinstance(value, str) or len(value) >= arg


def _minimum(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not _is_number(value) or value >= arg


def _maximum(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not _is_number(value) or value <= arg


def _exclusive_minimum(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not _is_number(value) or value > arg


def _exclusive_maximum(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: not _is_number(value) or value < arg


def _const(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return lambda value: equal(value, arg)


def _enum(_c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    options = tuple(arg)
    return lambda value: any(equal(value, option) for option in options)


def _all_of(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    subs = tuple(c.compile(sub) for sub in arg)
    return lambda value: all(sub(value) for sub in subs)


def _any_of(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    subs = tuple(c.compile(sub) for sub in arg)
    return lambda value: any(sub(value) for sub in subs)


def _one_of(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    subs = tuple(c.compile(sub) for sub in arg)
    return lambda value: sum(1 for sub in subs if sub(value)) == 1


def _not(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    sub = c.compile(arg)
    return lambda value: not sub(value)


def _if(c: _Compiler, arg: Any, schema: Mapping[str, Any]) -> Check | None:
    test = c.compile(arg)
    then = c.compile(schema.get("then", True))
    otherwise = c.compile(schema.get("else", True))
    return lambda value: then(value) if test(value) else otherwise(value)


def _ref(c: _Compiler, arg: Any, _s: Mapping[str, Any]) -> Check:
    return c.ref(arg)


_KEYWORDS: dict[str, Builder] = {
    "type": _type,
    "properties": _properties,
    "additionalProperties": _additional,
    "propertyNames": _property_names,
    "required": _required,
    "dependentRequired": _dependent_required,
    "minProperties": _min_properties,
    "items": _items,
    "minItems": _min_items,
    "uniqueItems": _unique_items,
    "pattern": _pattern,
    "minLength": _min_length,
    "minimum": _minimum,
    "maximum": _maximum,
    "exclusiveMinimum": _exclusive_minimum,
    "exclusiveMaximum": _exclusive_maximum,
    "const": _const,
    "enum": _enum,
    "allOf": _all_of,
    "anyOf": _any_of,
    "oneOf": _one_of,
    "not": _not,
    "if": _if,
    "$ref": _ref,
}


def compile_schema(schema: Mapping[str, Any]) -> Check:
    """One function telling whether a document is valid against `schema` (raises
    `Unsupported` for a keyword not implemented here)."""
    return _Compiler(schema).compile(schema)
