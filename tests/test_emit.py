"""The back end, in process: its text helpers, as the generated code shows a spec's own
words (a docstring is triple-quoted when that is plainly safe, a `repr` on one line
otherwise), and what lowering decides for the emitted code (which commands keep time)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from rcsgen.compiler.back_end.emit import comment, docstring, safe_source
from rcsgen.compiler.frontend import compile_paths

SPECS = Path(__file__).resolve().parent.parent / "specs"
REPO = SPECS.parent


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


def test_a_spec_path_keeps_printable_ascii_but_quotes_and_backslashes() -> None:
    """A spec's path reaches a comment line and a "..." literal: every printable ASCII
    character from the space to `~` stays, a quote, a backslash or anything else is `?`."""
    printable = "".join(map(chr, range(0x20, 0x7F)))
    kept = printable.replace('"', "?").replace("'", "?").replace("\\", "?")
    assert safe_source(printable) == kept
    assert safe_source("specs/x\u00e9\n\x7f\x1f/top.yaml") == "specs/x????/top.yaml"


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


def test_the_block_words_a_module_stores_are_named_in_lowering() -> None:
    """Each sequence word a controller stores (its status, each subordinate's command, each
    world field it writes) is named once, by the back end, from the layout offset it is the
    index of; the template renders the names and composes none (co commands three
    subordinates; pss writes three world fields). Its performance buffer's word is not
    among them: rcs.contract.performance stores it."""
    system = next(s for s in compile_paths([SPECS / "miner"]).systems if s.name == "miner")
    io = {c.name: c.io for c in system.controllers}
    co, pss = io["co"], io["pss"]
    assert co is not None and pss is not None
    assert co.status_word == "CO_STATUS_WORD"
    assert co.sub_words == {s: f"{s.upper()}_COMMAND_WORD" for s in co.sub_words}
    assert sorted(co.sub_words) == ["cc", "cr", "vg"]
    assert pss.world_seq_words == (
        ("WORLD_POSE_X_WORD", "WORLD_POSE_Y_WORD", "WORLD_HEADING_WORD"),
    )
    for each in (co, pss):
        names = [name for name, _ in each.stored_words]
        worlds = [w for run in each.world_seq_words for w in run]
        assert names == [each.status_word, *each.sub_words.values(), *worlds]
        assert all(at.removesuffix("_AT") + "_WORD" == w for w, at in each.stored_words)
    template = (REPO / "templates" / "controller.py.j2").read_text(encoding="utf-8")
    assert "_WORD" not in template.replace("SEQ_WORDS", "")


def test_the_layout_lists_every_enumeration_field_of_every_module_and_the_world(
    tmp_path: Path,
) -> None:
    """The layout module's table of enumeration fields (what a trace and the console show
    by name): each module's enumeration parameters and results, then the world's, in the
    system's order - every module's, not only the last one's."""
    from test_lowered import DEV, SYSTEM, TOP, compiled_systems

    from rcsgen.compiler.back_end.emit import _enum_fields

    system = SYSTEM.replace(
        "  level: {type: float, initial: 0.0, doc: Sensed level.}\n",
        "  level: {type: float, initial: 0.0, doc: Sensed level.}\n"
        "  gate: {type: enum, values: [SHUT, OPEN], initial: SHUT, doc: The gate.}\n",
    )
    top = TOP.replace(
        "    reasons: [REFUSED, WORN, BLOCKED]\n",
        "    reasons: [REFUSED, WORN, BLOCKED]\n"
        "    results:\n      grade: {type: enum, values: [LOW, HIGH], doc: How it went.}\n",
    )
    (lowered,) = compiled_systems(tmp_path, system=system, top=top, dev=DEV)
    assert _enum_fields(lowered) == [
        ("top", "result_grade", ("LOW", "HIGH")),
        ("dev", "arg_how", ("IDLE", "SLOW", "FAST", "JAMMED")),
        ("", "gate", ("SHUT", "OPEN")),
    ]
