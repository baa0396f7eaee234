"""Every Python form a spec expression may not use is refused by name, located at the form
(rcsgen/compiler/expressions/resolve.py): what `validate` says for each, word for word, in
one compile of tests/test_check_messages.py's tank with a state per form."""

from __future__ import annotations

from pathlib import Path

from test_check_messages import SYSTEM, TANK

from rcsgen.compiler.frontend import compile_paths

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
    ("await world.level", 0, "E102", "await are not allowed in a spec expression", HINT),
    ("(yield 1) == 1", 1, "E102", "yield are not allowed in a spec expression", HINT),
    ("[1, 2] == 1", 0, "E102", "`List` expressions are not allowed in a spec expression", HINT),
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
    quote = len("        - when: ")  # a guard's opening quote (0-based); a column counts from it
    found = [
        (d.code, str(d.span), d.message, d.hint)
        for d in compile_paths([Path(".")], analyse=False).diagnostics.items
    ]
    line = {guard: lines.index(f'        - when: "{guard}"') + 1 for guard, *_ in FORMS}
    assert found == [
        (code, f"tank.yaml:{line[guard]}:{quote + col + 1}", message, hint)
        for guard, col, code, message, hint in FORMS
    ]
