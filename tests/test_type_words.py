"""Each spec type, as every stage spells and stores it (rcsgen/compiler/types.py): the spec's
own spelling (what a message quoting the declaration shows), a message's words, a reference
page's label, its `struct` code in the block, its Python annotation, its token in a hook's
result check, the annotation a hook gives it, its zero and a value as a Python literal; the
types a spec cannot store refuse what they do not have. And which hook annotations a target
takes, and which values may be stored where."""

from __future__ import annotations

import pytest

from rcsgen.compiler.types import (
    BOOL,
    FLOAT,
    INT,
    NAMED,
    STATUS,
    Annotation,
    CommandOf,
    ReasonOf,
    Str,
    Type,
    annotation_accepts,
    annotation_fits,
    assignable,
    enum_of,
    hook_words,
)

SIDE = enum_of(["LEFT", "RIGHT"])


@pytest.mark.parametrize(
    ("kind", "spelled", "words", "label", "code", "py", "hook", "annotated", "zero"),
    [
        (BOOL, "bool", "a boolean", "bool", "?", "bool", "b", Annotation.BOOL, False),
        (INT, "int", "an integer", "int", "q", "int", "i", Annotation.INT, 0),
        (FLOAT, "float", "a number", "float", "d", "float", "f", Annotation.FLOAT, 0.0),
        (
            SIDE,
            "enum LEFT|RIGHT",
            "enum LEFT, RIGHT",
            "enum(LEFT, RIGHT)",
            "q",
            "int",
            "e2",
            Annotation.INT,
            "LEFT",
        ),  # fmt: skip
        (
            Str(8),
            "str 8",
            "a string of at most 8 bytes",
            "str[8]",
            "8s",
            "str",
            "s8",
            Annotation.STR,
            "",
        ),  # fmt: skip
    ],
)
def test_a_stored_type_is_spelled_and_stored_one_way_everywhere(
    kind: Type,
    spelled: str,
    words: str,
    label: str,
    code: str,
    py: str,
    hook: str,
    annotated: Annotation,
    zero: object,
) -> None:
    assert (str(kind), kind.words, kind.label) == (spelled, words, label)
    assert (kind.code, kind.py, kind.hook_kind, kind.annotated) == (code, py, hook, annotated)
    assert kind.zero == zero and type(kind.zero) is type(zero)


def test_a_scalar_is_named_by_its_own_spelling() -> None:
    """A function's parameters and result, a plan's steps: `type: int` names INT."""
    assert {word: NAMED[word] for word in map(str, (BOOL, INT, FLOAT))} == NAMED


def test_a_value_is_written_as_its_python_literal() -> None:
    assert (BOOL.literal(1), BOOL.literal(0)) == ("True", "False")
    assert (INT.literal(3.0), FLOAT.literal(2)) == ("3", "2.0")
    assert (SIDE.literal("RIGHT"), SIDE.literal(0)) == ("1", "0")
    assert (Str().literal("a'b"), Str().literal(None)) == ('"a\'b"', "''")
    assert str(Str()) == "str 32"  # the default size


@pytest.mark.parametrize(
    ("kind", "spelled"),
    [(STATUS, "status"), (CommandOf("cc"), "command of cc"), (ReasonOf("cc"), "reason of cc")],
)
def test_a_type_no_spec_stores_has_only_its_spelling(kind: Type, spelled: str) -> None:
    assert (str(kind), kind.words, kind.label, kind.annotated) == (spelled, spelled, spelled, None)
    for refused in ("code", "py", "hook_kind", "zero"):
        with pytest.raises(TypeError, match=spelled):
            getattr(kind, refused)
    with pytest.raises(TypeError, match=f"a {spelled} has no literal"):
        kind.literal(0)


def test_a_hook_message_names_a_scalar_by_its_annotation() -> None:
    assert [hook_words(k) for k in (INT, FLOAT, BOOL, Str(4), SIDE)] == [
        "an int",
        "a float",
        "a bool",
        "a string of at most 4 bytes",
        "enum LEFT, RIGHT",
    ]
    assert [hook_words(a) for a in Annotation] == ["a bool", "an int", "a float", "str"]


def test_a_hook_value_fits_its_own_type_and_an_int_fits_a_float() -> None:
    assert annotation_fits(FLOAT, Annotation.INT) and annotation_fits(FLOAT, Annotation.FLOAT)
    assert annotation_fits(Str(4), Annotation.STR) and annotation_fits(SIDE, Annotation.INT)
    assert not annotation_fits(INT, Annotation.FLOAT)
    assert not annotation_fits(BOOL, Annotation.INT)
    assert annotation_accepts(Annotation.FLOAT, INT) and annotation_accepts(Annotation.FLOAT, SIDE)
    assert annotation_accepts(Annotation.STR, Str(200))
    assert not annotation_accepts(Annotation.INT, FLOAT)
    assert not annotation_accepts(Annotation.BOOL, INT)


def test_a_value_is_stored_in_its_own_type_an_int_in_a_float_a_short_string_in_a_long() -> None:
    assert (
        assignable(FLOAT, INT) and assignable(INT, INT) and assignable(SIDE, enum_of(SIDE.values))
    )
    assert not assignable(INT, FLOAT)
    assert not assignable(SIDE, enum_of(["LEFT", "UP"]))
    assert assignable(Str(8), Str(8)) and assignable(Str(8), Str(4))
    assert not assignable(Str(4), Str(8))
