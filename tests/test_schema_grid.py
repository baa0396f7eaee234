"""The compiled schema check (rcsgen/compiler/front_end/schema_fast.py) gives jsonschema's
verdict for every keyword it implements, on a grid of values of every JSON type: at, below
and above each bound, each type's look-alikes (YAML's `true` is no integer, `1.0` equals
`1`), empty and non-empty containers, and a value of another type, which a keyword about
numbers, strings, arrays or objects lets through. A spec that the fast check waves through
but jsonschema refuses would build with no diagnostic; one it refuses wrongly would get
jsonschema's "valid" after a slow detour (schema.check_document asks the fast check first)."""

from __future__ import annotations

import pytest

from rcsgen.compiler.front_end.schema import validator_class
from rcsgen.compiler.front_end.schema_fast import compile_schema

VALUES = [
    None,
    True,
    False,
    0,
    1,
    2,
    3,
    -1,
    1.5,
    2.0,
    2.5,
    "",
    "a",
    "ab",
    "abc",
    "B",
    [],
    [1],
    [1, 2],
    [1, "a"],
    [1, 1.0],
    [True, 1],
    {},
    {"a": 1},
    {"a": "x"},
    {"a": 1, "b": "x"},
    {"b": 2},
    {"A": 1},
]
SCHEMAS = [
    {"type": kind} for kind in ("null", "boolean", "integer", "number", "string", "array", "object")
] + [
    {"type": ["integer", "string"]},
    {"minimum": 2},
    {"maximum": 2},
    {"exclusiveMinimum": 2},
    {"exclusiveMaximum": 2},
    {"minimum": 1.5, "maximum": 2.5},
    {"minLength": 2},
    {"pattern": "^[a-z]+$"},
    {"pattern": "b"},
    {"minItems": 1},
    {"minItems": 2},
    {"uniqueItems": True},
    {"items": {"type": "integer"}},
    {"minProperties": 1},
    {"required": ["a"]},
    {"required": ["a", "b"]},
    {"properties": {"a": {"type": "integer"}}},
    {"properties": {"a": {"type": "integer"}}, "additionalProperties": False},
    {"properties": {"a": True}, "additionalProperties": {"type": "integer"}},
    {"propertyNames": {"pattern": "^[a-z]$"}},
    {"dependentRequired": {"a": ["b"]}},
    {"const": 1},
    {"const": "a"},
    {"const": [1]},
    {"enum": [1, "a", None]},
    {"enum": [False]},
    {"allOf": [{"type": "integer"}, {"minimum": 2}]},
    {"anyOf": [{"type": "string"}, {"minimum": 2}]},
    {"oneOf": [{"type": "integer"}, {"minimum": 2}]},
    {"not": {"type": "integer"}},
    {"if": {"type": "integer"}, "then": {"minimum": 2}, "else": {"type": "string"}},
    {"if": {"required": ["a"]}, "then": {"required": ["b"]}},
]


@pytest.mark.parametrize("schema", SCHEMAS, ids=[str(s) for s in SCHEMAS])
def test_the_fast_check_agrees_with_jsonschema_on_every_value(schema) -> None:
    slow, fast = validator_class()(schema), compile_schema(schema)
    disagree = [v for v in VALUES if fast(v) is not slow.is_valid(v)]
    assert disagree == []
    # and the grid tells valid from invalid for this keyword (a check that cannot fail
    # would agree on values it all lets through)
    assert {slow.is_valid(v) for v in VALUES} == {True, False}


def test_the_grid_covers_every_keyword_the_fast_check_implements() -> None:
    """Each keyword of the compiled check's table is on the grid (a keyword added there is
    tried against jsonschema too), and the whole grid, in one go, compiles and agrees: the
    table gives each keyword its own check, under its own name."""
    from rcsgen.compiler.front_end.schema_fast import _KEYWORDS

    used = {key for schema in SCHEMAS for key in _keys(schema)}
    assert set(_KEYWORDS) - {"$ref"} <= used  # ($ref: the edge cases and the shipped schemas)
    for schema in SCHEMAS:
        slow, fast = validator_class()(schema), compile_schema(schema)
        assert [fast(v) for v in VALUES] == [slow.is_valid(v) for v in VALUES], schema


def _keys(schema: object) -> set[str]:
    """The keywords a schema uses, at any depth (`properties`' names are not keywords)."""
    if not isinstance(schema, dict):
        return set()
    found = set(schema)
    for key, value in schema.items():
        inner = value.values() if key == "properties" else value
        for sub in inner if isinstance(inner, list) or key == "properties" else [inner]:
            found |= _keys(sub)
    return found
