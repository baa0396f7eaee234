"""What a hook's return annotation promises (rcsgen/compiler/checks/hooks.py), read from its
source without importing it: how many values of which Python types, or any number. E241
and the targets' types are checked against it (the corpus's e241 cases); here each form of
annotation a hooks module may write."""

from __future__ import annotations

import ast

import pytest

from rcsgen.compiler.checks import hooks
from rcsgen.compiler.types import Annotation

FLOAT, INT, BOOL = Annotation("float"), Annotation("int"), Annotation("bool")


def promised(annotation: str) -> hooks.Returns | None:
    node = ast.parse(f"def hook(x) -> {annotation}:\n    return x\n").body[0]
    assert isinstance(node, ast.FunctionDef)
    return hooks.returns(node)


@pytest.mark.parametrize(
    ("annotation", "count", "types", "scalar"),
    [
        ("None", 0, (), False),
        ("float", 1, (FLOAT,), True),
        ("'int'", 1, (INT,), True),  # quoted: parsed
        ("builtins.bool", 1, (BOOL,), True),
        ("tuple[float, int]", 2, (FLOAT, INT), False),
        ("tuple[float, bool, int]", 3, (FLOAT, BOOL, INT), False),
        ("tuple[float]", 1, (FLOAT,), False),
        ("typing.Tuple[int, int]", 2, (INT, INT), False),
        ("tuple[float, list]", 2, (FLOAT, None), False),  # a type it does not know: None
        # any number of values, each of one type
        ("tuple[float, ...]", None, (FLOAT,), False),
        ("Tuple[int, ...]", None, (INT,), False),
    ],
)
def test_a_return_annotation_promises_a_count_of_typed_values(
    annotation: str, count: int | None, types: tuple[Annotation | None, ...], scalar: bool
) -> None:
    assert promised(annotation) == hooks.Returns(count, types, scalar)


@pytest.mark.parametrize("annotation", ["list[float]", "dict", "'not ( python'", "Any"])
def test_an_annotation_that_says_nothing_checkable_promises_nothing(annotation: str) -> None:
    assert promised(annotation) is None
