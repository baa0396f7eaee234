"""What a hook function's definition promises, read from its source with `ast` and never
imported (rcsgen/compiler/checks/hooks.py): whether it is a plain function (E240), the Python
type of each positional parameter (E242) and how many values each of its own `return`s gives
(E241). Only the function's own body counts: a generator, a `return` or a `yield` inside a
function, lambda or class defined in it is not the hook's."""

from __future__ import annotations

import ast
import textwrap

import pytest

from rcsgen.compiler.checks import hooks
from rcsgen.compiler.types import Annotation

FLOAT, INT, BOOL, STR = (Annotation(n) for n in ("float", "int", "bool", "str"))


def function(source: str) -> hooks.Function:
    node = ast.parse(textwrap.dedent(source)).body[0]
    assert isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
    return node


@pytest.mark.parametrize(
    ("source", "problem"),
    [
        ("def hook(x):\n    return x\n", ""),
        (
            "async def hook(x):\n    return x\n",
            "an `async def` (a coroutine function): its call returns a coroutine, not values",
        ),
        (
            "def hook(x):\n    yield x\n",
            "a generator (it yields): its call returns a generator, not values",
        ),
        (
            "def hook(x):\n    if x:\n        y = yield from range(3)\n    return x\n",
            "a generator (it yields): its call returns a generator, not values",
        ),
        # a yield of a function, lambda or class defined inside is not the hook's own
        ("def hook(x):\n    def inner():\n        yield x\n    return inner\n", ""),
        ("def hook(x):\n    g = lambda: (yield)\n    return x\n", ""),
        (
            "def hook(x):\n    class C:\n        def m(self):\n            yield 1\n    return x\n",
            "",
        ),
        ("def hook(x):\n    async def inner():\n        yield x\n    return x\n", ""),
    ],
)
def test_a_hook_is_a_plain_function_or_says_what_it_is_instead(source: str, problem: str) -> None:
    assert hooks.kind_problem(function(source)) == problem


def test_the_returns_counted_are_the_functions_own_in_line_order() -> None:
    node = function(
        """
        def hook(x, y):
            if x:
                return x, y, 1
            def helper():
                return 1, 2, 3, 4
            class Inner:
                def m(self):
                    return 5, 6
            if y:
                return
            if x > y:
                return None
            if x < y:
                return (*x, y)
            for item in x:
                while item:
                    return item
            return x, y
        """
    )
    assert hooks.literal_return_counts(node) == [
        (4, 3),  # a tuple of three
        (11, 0),  # bare return
        (13, 0),  # return None
        (15, None),  # starred: any length
        (18, None),  # a name may hold a tuple of any length
        (19, 2),
    ]


def test_a_function_without_a_return_has_none_counted() -> None:
    assert hooks.literal_return_counts(function("def hook(x):\n    x.append(1)\n")) == []


@pytest.mark.parametrize(
    ("signature", "types"),
    [
        ("(a: float, b: int, c: bool, d: str)", [FLOAT, INT, BOOL, STR]),
        ("(a, b: 'float', c: list[int], d: builtins.int)", [None, FLOAT, None, INT]),
        ("(a: int, /, b: float, *rest: int, c: bool = True, **kw: str)", [INT, FLOAT]),
        ("(state, x: 'not ( python')", [None, None]),
        ("()", []),
    ],
)
def test_each_positional_parameter_names_the_type_it_takes(
    signature: str, types: list[Annotation | None]
) -> None:
    node = function(f"def hook{signature}:\n    return 0\n")
    assert hooks.param_types(node) == types


@pytest.mark.parametrize(
    ("annotation", "named"),
    [
        ("float", FLOAT),
        ("typing.Text", None),  # an attribute names its last part, which is not a spec type
        ("builtins.str", STR),
        ("'bool'", BOOL),
        ("'tuple['", None),  # a quoted annotation that is not Python
        ("list[int]", None),
        ("None", None),
        ("3", None),
    ],
)
def test_an_annotation_names_a_python_type_of_the_spec_or_nothing(
    annotation: str, named: Annotation | None
) -> None:
    expression = ast.parse(annotation, mode="eval").body
    assert hooks.annotated(expression) == named


def test_no_annotation_names_nothing() -> None:
    assert hooks.annotated(None) is None
    assert hooks.returns(function("def hook(x):\n    return x\n")) is None
