"""Types: the value types of a spec as frozen classes, and what each means downstream.

A type is a value, never a string to take apart: `Enum(("LEFT", "RIGHT"))`, `Str(32)`,
`CommandOf("cc")`. Two declarations of an enumeration with the same values are one type
(equal, hashable), so a parameter passes on to another controller's. `model` makes them
from the spec's declarations (the one place the spec's text is read); every later stage
asks the type itself: how a message words it (`words`), how a reference page labels it
(`label`), its struct code in the block (`code`), its Python annotation (`py`), its letter in
a hook's or a planner's result check (`hook_kind`), a value of it as Python (`literal`).
`str(t)` is the spec's spelling (`enum LEFT|RIGHT`, `str 32`, `command of cc`), for
messages that quote a type as declared.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import ClassVar

STR_DEFAULT_SIZE, STR_MAX_SIZE = 32, 255  # a string's capacity in bytes of UTF-8


@dataclass(frozen=True)
class Type:
    """A spec type. Subclasses: Bool, Int, Float, Status, Enum, Str, CommandOf, ReasonOf."""

    def __str__(self) -> str:
        raise NotImplementedError

    @property
    def words(self) -> str:
        """How a message names it: `a boolean`, `enum LEFT, RIGHT`, `a string of at most 32
        bytes`; a type no spec declares by its own spelling (`status`, `command of cc`)."""
        return str(self)

    @property
    def label(self) -> str:
        """How a reference page or a picture shows it: `enum(LEFT, RIGHT)`, `str[32]`."""
        return str(self)

    @property
    def code(self) -> str:
        """Its `struct` code in the block."""
        raise TypeError(f"a {self} is not stored in the block")

    @property
    def py(self) -> str:
        """Its Python annotation in generated code."""
        raise TypeError(f"a {self} has no Python annotation")

    @property
    def hook_kind(self) -> str:
        """Its token in a hook's or a planner's result check (`rcs.contract.HookError`)."""
        raise TypeError(f"a hook cannot return a {self}")

    @property
    def annotated(self) -> Annotation | None:
        """The annotation a hook gives a value of this type (None: none fits)."""
        return None

    def literal(self, value: object) -> str:
        """`value` (a spec's initial value, or 0 for the type's zero) as Python."""
        raise TypeError(f"a {self} has no literal")

    @property
    def zero(self) -> bool | int | float | str:
        """Its zero as a spec writes a value: an actuator's safe value when it declares none
        (false, 0, 0.0, an enumeration's first value, the empty string)."""
        raise TypeError(f"a {self} has no zero")


@dataclass(frozen=True)
class Scalar(Type):
    """bool, int and float: named by a word, stored as themselves, annotated so in a hook."""

    NAME: ClassVar[str]
    WORDS: ClassVar[str]
    CODE: ClassVar[str]

    def __str__(self) -> str:
        return self.NAME

    @property
    def words(self) -> str:
        return self.WORDS

    @property
    def code(self) -> str:
        return self.CODE

    @property
    def py(self) -> str:
        return self.NAME

    @property
    def hook_kind(self) -> str:
        return self.NAME[0]  # f, i, b

    @property
    def annotated(self) -> Annotation:
        return Annotation(self.NAME)


@dataclass(frozen=True)
class Bool(Scalar):
    NAME, WORDS, CODE = "bool", "a boolean", "?"

    def literal(self, value: object) -> str:
        return "True" if value else "False"

    @property
    def zero(self) -> bool:
        return False


@dataclass(frozen=True)
class Int(Scalar):
    NAME, WORDS, CODE = "int", "an integer", "q"

    def literal(self, value: object) -> str:
        return str(int(value))  # type: ignore[call-overload]

    @property
    def zero(self) -> int:
        return 0


@dataclass(frozen=True)
class Float(Scalar):
    NAME, WORDS, CODE = "float", "a number", "d"

    def literal(self, value: object) -> str:
        return repr(float(value))  # type: ignore[arg-type]

    @property
    def zero(self) -> float:
        return 0.0


@dataclass(frozen=True)
class Status(Type):
    """A status (`NOT_READY`, `EXECUTING`, `DONE`, `ERROR`): its own and its subordinates'."""

    def __str__(self) -> str:
        return "status"


@dataclass(frozen=True)
class Enum(Type):
    """An enumeration of named values, stored as the index of its value."""

    values: tuple[str, ...]

    def __str__(self) -> str:
        return "enum " + "|".join(self.values)

    @property
    def words(self) -> str:
        return f"enum {', '.join(self.values)}"

    @property
    def label(self) -> str:
        return f"enum({', '.join(self.values)})"

    @property
    def code(self) -> str:
        return "q"

    @property
    def py(self) -> str:
        return "int"

    @property
    def hook_kind(self) -> str:
        return f"e{len(self.values)}"

    @property
    def annotated(self) -> Annotation:
        return Annotation.INT  # a hook sees the value's index

    @property
    def zero(self) -> str:
        return self.values[0]

    def literal(self, value: object) -> str:
        """A value name (as a spec gives an initial value) or an index, as its index."""
        return str(self.values.index(value)) if isinstance(value, str) else str(int(value))  # type: ignore[call-overload]


@dataclass(frozen=True)
class Str(Type):
    """A string of at most `size` bytes of UTF-8, stored NUL-padded."""

    size: int = STR_DEFAULT_SIZE

    def __str__(self) -> str:
        return f"str {self.size}"

    @property
    def words(self) -> str:
        return f"a string of at most {self.size} bytes"

    @property
    def label(self) -> str:
        return f"str[{self.size}]"

    @property
    def code(self) -> str:
        return f"{self.size}s"

    @property
    def py(self) -> str:
        return "str"

    @property
    def hook_kind(self) -> str:
        return f"s{self.size}"

    @property
    def annotated(self) -> Annotation:
        return Annotation.STR  # of any size: its length is checked at run time

    @property
    def zero(self) -> str:
        return ""

    def literal(self, value: object) -> str:
        return repr(value if isinstance(value, str) else "")


@dataclass(frozen=True)
class CommandOf(Type):
    """The type of `<sub>.command` and of `<sub>`'s command names."""

    sub: str

    def __str__(self) -> str:
        return f"command of {self.sub}"


@dataclass(frozen=True)
class ReasonOf(Type):
    """The type of `<sub>.reason` and of `<sub>`'s reason names."""

    sub: str

    def __str__(self) -> str:
        return f"reason of {self.sub}"


class Annotation(StrEnum):
    """A Python type a hook's annotation names (`hooks.py` reads them); anything else is not
    checked."""

    BOOL = "bool"
    INT = "int"
    FLOAT = "float"
    STR = "str"

    @property
    def words(self) -> str:
        """`an int`, `a float`, `a bool`, `str`: as a hook message names it."""
        return {"int": "an int", "float": "a float", "bool": "a bool"}.get(self.value, self.value)


BOOL, INT, FLOAT, STATUS = Bool(), Int(), Float(), Status()
NUMERIC: tuple[Type, ...] = (INT, FLOAT)
# The types a spec names by a word alone (a function's parameters and result, a plan's steps).
NAMED: dict[str, Type] = {"bool": BOOL, "int": INT, "float": FLOAT}


def enum_of(values: Sequence[str]) -> Enum:
    """The enumeration of these value names, in order."""
    return Enum(tuple(values))


def hook_words(kind: Type | Annotation) -> str:
    """How a hook message names a spec type (`an int`, `enum A, B`) or an annotation."""
    if isinstance(kind, Scalar):
        return kind.annotated.words
    return kind.words


def annotation_fits(target: Type, value: Annotation) -> bool:
    """Whether a hook value annotated `value` may go into a target of type `target`: a
    string of any size is a `str` (its length is checked at run time), an enumeration's
    value an `int` (its index), an int a float."""
    return target.annotated == value or (target == FLOAT and value is Annotation.INT)


def annotation_accepts(param: Annotation, arg: Type) -> bool:
    """Whether a hook parameter annotated `param` takes an argument of spec type `arg` (a
    string of any size a `str`, an enumeration's value an `int`, an int or an enumeration's
    index a `float`)."""
    return arg.annotated == param or (param is Annotation.FLOAT and arg.annotated is Annotation.INT)


def assignable(target: Type, source: Type) -> bool:
    """Whether a value of type `source` may be stored where `target` is expected: its own
    type, an int as a float, a string that fits the target's size."""
    if isinstance(target, Str) and isinstance(source, Str):
        return source.size <= target.size
    return target == source or (target == FLOAT and source == INT)
