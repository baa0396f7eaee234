"""Every Python form a spec expression may not use is refused by name, located at the form
(rcsgen/compiler/expressions/resolve.py): what `validate` says for each, word for word, in
one compile of tests/test_check_messages.py's tank with a state per form."""

from __future__ import annotations

from pathlib import Path

from test_check_messages import SYSTEM, TANK

from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span
from rcsgen.compiler.expressions import Scope, compile_expr
from rcsgen.compiler.expressions.resolve import expression_text
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.types import FLOAT

HINT = (
    "expressions may use literals, and/or/not, comparisons, arithmetic, `a if c else b`, "
    "declared names, world.<field>, <sub>.status, <sub>.command and calls of predicates and "
    "functions"
)
LITERAL = "use a number or a string"
# (guard, column of the refused form in the guard (0-based), code, message, hint)
FORMS = [
    ("world.level[0] > 1", 0, "E102", "subscripts are not allowed in a spec expression", HINT),
    ("[x for x in y] == 1", 0, "E102", "comprehensions are not allowed in a spec expression", HINT),
    ("{x for x in y} == 1", 0, "E102", "comprehensions are not allowed in a spec expression", HINT),
    (
        "{x: 1 for x in y} == 1",
        0,
        "E102",
        "comprehensions are not allowed in a spec expression",
        HINT,
    ),
    ("f'{world.level}' == 'a'", 0, "E102", "f-strings are not allowed in a spec expression", HINT),
    (
        "(n := 1) > 0",
        1,
        "E102",
        "assignment expressions (:=) are not allowed in a spec expression",
        HINT,
    ),
    (
        "max(*world.level) > 1",
        4,
        "E102",
        "starred expressions are not allowed in a spec expression",
        HINT,
    ),
    ("await world.level", 0, "E102", "`await` is not allowed in a spec expression", HINT),
    ("(yield 1) == 1", 1, "E102", "`yield` is not allowed in a spec expression", HINT),
    ("[1, 2] == 1", 0, "E102", "lists are not allowed in a spec expression", HINT),
    ("(1, 2) == 1", 0, "E102", "tuples are not allowed in a spec expression", HINT),
    ("{1: 2} == 1", 0, "E102", "dictionaries are not allowed in a spec expression", HINT),
    ("{1} == 1", 0, "E102", "sets are not allowed in a spec expression", HINT),
    ("world.level @ 2 > 1", 0, "E102", "only + - * / // % are allowed", ""),
    ("world.level << 1 > 1", 0, "E102", "only + - * / // % are allowed", ""),
    ("~world.level > 1", 0, "E102", "bitwise operators are not allowed", ""),
    ("world.level is 1", 0, "E102", "only == != < <= > >= comparisons are allowed", ""),
    ("world.level in 1", 0, "E102", "only == != < <= > >= comparisons are allowed", ""),
    ("b'x' == 1", 0, "E102", "the literal b'x' is not allowed", LITERAL),
    ("None == 1", 0, "E102", "the literal None is not allowed", LITERAL),
    (
        "world.level.real > 1",
        0,
        "E102",
        "attributes are allowed only on `world`, subordinates and plans",
        "",
    ),
    (
        "(lambda: 1)() > 0",
        0,
        "E102",
        "only predicates, functions and abs/min/max can be called",
        "",
    ),
    ("abs(x=1) > 1", 0, "E102", "only predicates, functions and abs/min/max can be called", ""),
    ("world.__class__ == 1", 0, "E102", "dunder attribute `__class__` is not allowed", ""),
    ("__debug__ == 1", 0, "E102", "dunder name `__debug__` is not allowed", ""),
    ("abs(1, 2) > 1", 0, "E107", "wrong number of arguments to `abs`", ""),
    ("(x for x in y) == 1", 0, "E102", "comprehensions are not allowed in a spec expression", HINT),
    ("(lambda: 1) == 1", 1, "E102", "lambdas are not allowed in a spec expression", HINT),
    ("(yield from y) == 1", 1, "E102", "`yield from` is not allowed in a spec expression", HINT),
]


def test_each_form_is_refused_by_name_at_its_place(tmp_path: Path, monkeypatch) -> None:
    probes = "".join(
        f"  P{i}:\n    doc: A form.\n    states:\n      S0:\n"
        f'        - when: "{guard}"\n          do: [report: DONE]\n'
        for i, (guard, *_) in enumerate(FORMS)
    )
    tank = TANK.replace("  HALT:\n", probes + "  HALT:\n", 1)
    (tmp_path / "system.yaml").write_text(SYSTEM)
    (tmp_path / "tank.yaml").write_text(tank)
    monkeypatch.chdir(tmp_path)
    lines = tank.splitlines()
    first = len("        - when: ") + 2  # a guard's first character (1-based), past its quote
    found = [
        (d.code, str(d.span), d.message, d.hint)
        for d in compile_paths([Path(".")], analyse=False).diagnostics.items
    ]
    line = {guard: lines.index(f'        - when: "{guard}"') + 1 for guard, *_ in FORMS}
    assert found == [
        (code, f"tank.yaml:{line[guard]}:{first + col}", message, hint)
        for guard, col, code, message, hint in FORMS
    ]


def test_each_form_is_refused_by_name_by_the_resolver_word_for_word() -> None:
    """The same forms given to the resolver alone (no spec compiled): its one finding each,
    with its code, message, hint and column."""
    scope = Scope(world={"level": FLOAT}, world_access=frozenset({"level"}))
    for guard, *want in FORMS:
        assert refused(guard, scope) == [tuple(want)], guard


def refused(guard: str, scope: Scope) -> list[tuple[int, str, str, str]]:
    """What the resolver alone says of `guard`: (column, 0-based, code, message, hint)."""
    diags = Diagnostics()
    assert compile_expr(guard, Span("x.yaml", 1, 1), scope, diags) is None, guard
    return [(d.span.col - 1, d.code, d.message, d.hint) for d in diags.items]


# One guard, `world.level + nope > 1`, written in each form YAML has for a scalar: an error
# in it is located at `nope` itself, not at the opening quote or the block's indicator.
SCALARS = [
    '"world.level + nope > 1"',
    "'world.level + nope > 1'",
    "world.level + nope > 1",
    ">-\n            world.level + nope > 1",
    "|\n            world.level + nope > 1",
    '"world.level\n            + nope > 1"',
    "world.level\n            + nope > 1",
    ">\n            world.level\n              + nope > 1\n",
    '"world.level + \\\n            nope > 1"',
    "'world.level > 1 and ''a'' == nope'",
]


def guarded(tmp_path: Path, monkeypatch, guards: list[str]) -> tuple[str, list[Diagnostic]]:
    """The tank with a rule per guard, each as written (before FILL's first), and what
    compiling it says."""
    probes = "".join(f"        - when: {guard}\n          do: []\n" for guard in guards)
    first = "        - when: world.level < 2.0\n"
    tank = TANK.replace(first, probes + first)
    (tmp_path / "system.yaml").write_text(SYSTEM)
    (tmp_path / "tank.yaml").write_text(tank)
    monkeypatch.chdir(tmp_path)
    return tank, compile_paths([Path(".")], analyse=False).diagnostics.items


def test_an_error_in_any_form_of_scalar_is_located_at_its_character(
    tmp_path: Path, monkeypatch
) -> None:
    tank, found = guarded(tmp_path, monkeypatch, SCALARS)
    written = [
        f"tank.yaml:{number}:{line.index('nope') + 1}"
        for number, line in enumerate(tank.splitlines(), start=1)
        if "nope" in line
    ]
    assert [(d.code, str(d.span)) for d in found] == [("E103", at) for at in written]


def test_an_expression_error_of_a_quoted_scalar_is_located_past_the_quote(
    tmp_path: Path, monkeypatch
) -> None:
    """A syntax error at the end (`world.level +`) just after its last character; a type
    error of the whole expression at its first one; in a quoted and a block scalar alike."""
    guards = [
        '"world.level +"',
        "'world.level'",
        ">-\n            world.level +",
        "|\n            world.level",
    ]
    tank, found = guarded(tmp_path, monkeypatch, guards)
    line = tank.splitlines().index('        - when: "world.level +"') + 1
    assert [(d.code, d.span.line, d.span.col) for d in found] == [
        ("E101", line, 31),  # after `+`: 17 is the quote, 18 the `w`
        ("E107", line + 2, 18),
        ("E101", line + 5, 26),
        ("E107", line + 8, 13),
    ]


# A name the resolver cannot find, with what `validate` says of it word for word: the close
# name when there is one, else every name declared of that kind.
NAMES = [
    ("world.levle > 1", 0, "E104", "undeclared world field `levle`", "did you mean `level`?"),
    (
        "world.zzz > 1",
        0,
        "E104",
        "undeclared world field `zzz`",
        "declared world fields: `flow`, `level`",
    ),
    (
        "world.flow > 1",
        0,
        "E105",
        "world field `flow` is not in this controller's world.reads or world.writes",
        "add `flow` to `world: reads:`",
    ),
    ("pump.result > 1", 0, "E108", "`pump.result` needs a name: `.result.<name>`", ""),
    ("pump.reason == 3", 15, "E107", "`pump.reason` compares only with a reason name", ""),
    ("pump.reason == JAMMD", 15, "E260", "`pump` has no reason `JAMMD`", "did you mean `JAMMED`?"),
    (
        "pump.statsu == DONE",
        0,
        "E108",
        "`pump.statsu`: a subordinate has only `status`, `command`, `reason` and `result.<name>`",
        "did you mean `status`?",
    ),
    (
        "pump.zzz == 1",
        0,
        "E108",
        "`pump.zzz`: a subordinate has only `status`, `command`, `reason` and `result.<name>`",
        "declared fields: `command`, `reason`, `result`, `status`",
    ),
]


def test_each_name_the_resolver_cannot_find_is_said_with_the_names_it_knows() -> None:
    scope = Scope(
        world={"level": FLOAT, "flow": FLOAT},
        world_access=frozenset({"level"}),
        subordinates={"pump": frozenset({"INIT", "FILL"})},
        sub_reasons={"pump": ("JAMMED",)},
    )
    for guard, *want in NAMES:
        assert refused(guard, scope) == [tuple(want)], guard


def test_an_expression_over_several_lines_reads_as_one_line() -> None:
    """A line break of any kind (`\\n`, `\\r\\n`, a lone `\\r`) and the runs of blanks
    around it are one space; a one-line expression is only stripped."""
    assert expression_text("world.level\r> 1") == "world.level > 1"
    assert expression_text(" world.level\r\n   > 1 ") == "world.level > 1"
    assert expression_text("\n  world.level  > 1\n") == "world.level  > 1"
