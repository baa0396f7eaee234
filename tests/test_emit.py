"""The back end, in process: its text helpers, as the generated code shows a spec's own
words (a docstring is triple-quoted when that is plainly safe, a `repr` on one line
otherwise), and what lowering decides for the emitted code (which commands keep time)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from rcsgen.compiler.back_end.emit import comment, docstring
from rcsgen.compiler.frontend import compile_paths

SPECS = Path(__file__).resolve().parent.parent / "specs"


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("A plain line.", '"""A plain line."""'),
        ("Two\nlines", '"""Two\n    lines\n    """'),
        ("A bell\x07 rings", "'A bell\\\\x07 rings'"),  # a control character: escaped
        ('Ends with "', "'Ends with \"'"),
        ("A back\\slash", "'A back\\\\slash'"),
        ("", "''"),
    ],
)
def test_a_docstring_is_triple_quoted_only_when_plainly_safe(text: str, shown: str) -> None:
    assert docstring(text, 4) == shown
    # either way it is one Python string literal, whose value keeps the words
    value = ast.literal_eval(shown)
    assert " ".join(value.split()) == " ".join(text.replace("\x07", "\\x07").split())


def test_a_comment_is_one_line_with_control_characters_escaped() -> None:
    assert comment("two\nlines\x00") == "# two lines\\x00"


def test_a_command_is_timed_just_when_one_of_its_rules_waits() -> None:
    """`after:` or `for:` on any rule makes its command keep the cycles in the state
    (`ticks`), and only then: a command with no such rule pays nothing for time."""
    systems = compile_paths([SPECS / "miner", SPECS / "submarine"]).systems
    commands = [c for s in systems for ctl in s.controllers for c in ctl.commands]
    for command in commands:
        waits = any(r.timing for state in command.states for r in state.rules)
        assert command.timed is waits, command.name
    timed = [c for c in commands if c.timed]
    assert timed and any(  # an `after:` alone is enough (tc's waits)
        all(
            "after" in r.timing and "for" not in r.timing
            for s in c.states
            for r in s.rules
            if r.timing
        )
        for c in timed
    )
