"""Hooks: a hooks module's source -> what each hook function promises, read with `ast`.

The module is never imported. From a function's definition this reads what can be known
without running it: whether it is a plain function (not `async def`, not a generator),
the spec types its parameter and return annotations name (`float`, `int`, `bool`, `str`,
`tuple[float, float]`, `None`; anything else is not checked), and the length of each tuple
it returns literally (`return x, y`). The checker compares these with the hook's declared
`args` and `returns` (E240, E241, E242); the generated code checks the result of every
call at run time as well (`rcs.contract.HookError`).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass

from ..types import Annotation

Function = ast.FunctionDef | ast.AsyncFunctionDef


@dataclass(frozen=True)
class Returns:
    """What a return annotation says: how many values (None: any number) of which Python
    types (None: not known)."""

    count: int | None
    types: tuple[Annotation | None, ...]  # one per value; for `tuple[float, ...]`, one for all
    scalar: bool = False  # one value, not a tuple (`-> float`)


def kind_problem(node: Function) -> str:
    """'' for a plain function, else what it is instead."""
    if isinstance(node, ast.AsyncFunctionDef):
        return "an `async def` (a coroutine function): its call returns a coroutine, not values"
    if any(isinstance(n, ast.Yield | ast.YieldFrom) for n in _own_nodes(node)):
        return "a generator (it yields): its call returns a generator, not values"
    return ""


_NESTED = ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda | ast.ClassDef


def _own_nodes(node: Function) -> Iterator[ast.AST]:
    """The nodes of a function's body, not those of functions or classes defined in it (a
    helper defined at the top of the body as well as one inside an `if`)."""
    todo: list[ast.AST] = [n for n in node.body if not isinstance(n, _NESTED)]
    while todo:
        at = todo.pop()
        yield at
        todo.extend(c for c in ast.iter_child_nodes(at) if not isinstance(c, _NESTED))


def _annotation(node: ast.expr | None) -> ast.expr | None:
    """An annotation as a tree (a quoted annotation is parsed)."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        try:
            return ast.parse(node.value, mode="eval").body
        except SyntaxError:
            return None
    return node


def _name(node: ast.expr | None) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):  # typing.Tuple, builtins.float
        return node.attr
    return None


def annotated(node: ast.expr | None) -> Annotation | None:
    """The Python type an annotation names (`bool`, `int`, `float`, `str`), else None."""
    name = _name(_annotation(node))
    return Annotation(name) if name in tuple(Annotation) else None


def returns(node: Function) -> Returns | None:
    """What the return annotation promises, or None when there is none or it is not read."""
    ann = _annotation(node.returns)
    if ann is None:
        return None
    if isinstance(ann, ast.Constant) and ann.value is None:
        return Returns(0, ())
    if annotated(ann) is not None:
        return Returns(1, (annotated(ann),), scalar=True)
    if isinstance(ann, ast.Subscript) and _name(ann.value) in ("tuple", "Tuple"):
        items = ann.slice.elts if isinstance(ann.slice, ast.Tuple) else [ann.slice]
        if len(items) == 2 and isinstance(items[1], ast.Constant) and items[1].value is ...:
            return Returns(None, (annotated(items[0]),))
        return Returns(len(items), tuple(annotated(item) for item in items))
    return None


def literal_return_counts(node: Function) -> list[tuple[int, int | None]]:
    """(line, values) of each `return` in the function's own body: the tuple's length for
    `return a, b`, 1 for any other value, 0 for a bare `return`, None when unknown (a
    starred tuple)."""
    found = []
    for at in _own_nodes(node):
        if isinstance(at, ast.Return):
            value = at.value
            if value is None or (isinstance(value, ast.Constant) and value.value is None):
                count: int | None = 0
            elif isinstance(value, ast.Tuple):
                starred = any(isinstance(e, ast.Starred) for e in value.elts)
                count = None if starred else len(value.elts)
            else:
                count = None  # a call or a name may hold a tuple of any length
            found.append((at.lineno, count))
    return sorted(found)


def param_types(node: Function) -> list[Annotation | None]:
    """The Python type each positional parameter's annotation names (None: not checked)."""
    return [annotated(a.annotation) for a in [*node.args.posonlyargs, *node.args.args]]
