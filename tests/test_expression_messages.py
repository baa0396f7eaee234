"""What `validate` says about a value of the wrong type set into a local, word for word
(E107 between numbers, E277 where an enum or a string is involved, and the hint to give a
string target a larger `size` only when a string is too long for a string), how it prints
an expression with `//` and `%` in a finding, and that a guard written over several lines
(a YAML string with a line break, `\\n`, `\\r\\n` or a lone `\\r`) reads as one line. One
small system, edited (tests/test_check_messages.py's tank)."""

from __future__ import annotations

import pytest
from test_check_messages import SYSTEM, TANK, said

LOCALS = """\
locals:
  n: {type: int, initial: 0, doc: A count.}
  s: {type: str, size: 4, initial: '', doc: A text.}
  e: {type: enum, values: [A, B], initial: A, doc: An enum.}

commands:
"""
TANK_WITH_LOCALS = TANK.replace("commands:\n", LOCALS, 1)
SET = "            - set: {world.pump_on: true}\n"
FOUR = "a string of at most 4 bytes"


@pytest.mark.parametrize(
    ("setting", "want"),
    [
        ("{n: 1.5}", ("E107", "expected an integer, got a number", "")),
        ("{n: e}", ("E277", "expected an integer, got enum A, B", "")),
        ("{e: n}", ("E277", "expected enum A, B, got an integer", "")),
        ("{s: e}", ("E277", f"expected {FOUR}, got enum A, B", "")),
        ("{e: s}", ("E277", f"expected enum A, B, got {FOUR}", "")),
        ("{s: n}", ("E277", f"expected {FOUR}, got an integer", "")),
        ("{n: \"'abc'\"}", ("E277", "expected an integer, got a string of at most 3 bytes", "")),
        (
            "{s: \"'abcdefgh'\"}",
            (
                "E277",
                f"expected {FOUR}, got a string of at most 8 bytes",
                "a string longer than its target could not be stored whole: give the target a "
                "larger `size`",
            ),
        ),
    ],
)
def test_a_value_of_the_wrong_type_is_named_with_both_types(
    tmp_path, monkeypatch, setting: str, want
) -> None:
    tank = TANK_WITH_LOCALS.replace(SET, f"            - set: {setting}\n", 1)
    found = [f for f in said(tmp_path, monkeypatch, SYSTEM, tank) if f[0].startswith("E")]
    assert found == [want]


def test_a_string_that_fits_is_no_finding(tmp_path, monkeypatch) -> None:
    tank = TANK_WITH_LOCALS.replace(SET, "            - set: {s: \"'abcd'\"}\n", 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == []


@pytest.mark.parametrize("size", [255, 256])
def test_a_string_literal_holds_at_most_255_bytes(tmp_path, monkeypatch, size: int) -> None:
    literal = "x" * size
    guard = f"world.level < 2.0 and s != '{literal}'"
    tank = TANK_WITH_LOCALS.replace("world.level < 2.0", guard, 1)
    found = [f for f in said(tmp_path, monkeypatch, SYSTEM, tank) if f[0].startswith("E")]
    too_long = (
        f"invalid string literal: '{literal[:20]}'... is 256 bytes: more than the 255 it holds"
    )
    assert found == ([] if size == 255 else [("E276", too_long, "")])


def test_a_finding_prints_floor_division_and_remainder(tmp_path, monkeypatch) -> None:
    guard = "world.level // 1.0 < 2.0 and world.level % 2.0 > -1.0"
    tank = TANK.replace("- when: world.level < 2.0", f"- when: {guard}", 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == [
        (
            "W502",
            "cannot prove rules 1 and 2 of FILL S0 exclusive: both hold if world.level=2.0, "
            "(world.level // 1.0 < 2.0)=true, (world.level % 2.0 > -1.0)=true; interval "
            "reasoning cannot decide `world.level // 1.0 < 2.0`, `world.level % 2.0 > -1.0`",
            "compare a variable with a constant where you can, or declare `first_match: [S0]` "
            "on FILL if rule 1 should win",
        )
    ]


@pytest.mark.parametrize("newline", ["\\n", "\\r\\n", "\\r"])
def test_a_guard_over_two_lines_reads_as_one(tmp_path, monkeypatch, newline: str) -> None:
    guard = f'"world.level < 2.0{newline}  and world.level > -1.0"'
    tank = TANK.replace("- when: world.level < 2.0", f"- when: {guard}", 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == [
        (
            "W503",
            "FILL S0 waits when world.level=-1.0: no rule fires then",
            "waiting is normal in RCS; if this wait is intended, acknowledge it on FILL: "
            "`allow: [{code: W503, states: [S0], reason: ...}]`",
        )
    ]


def test_the_generated_code_keeps_a_guards_grouping(tmp_path) -> None:
    """The guard as Python in the generated controller: parentheses where the spec's grouping
    needs them (a sum under a product on either side, a sum subtracted, a difference divided,
    an `or` under `not`, a conditional expression as an operand) and nowhere else."""
    from rcsgen import api

    guard = (
        "world.level * (world.level + 1.0) < 2.0 and -(world.level - 1.0) / (2.0 - world.level)"
        " > -1.0 and not (world.level > 3.0 or world.level < -3.0) and world.level // 2.0 - "
        "world.level % 3.0 <= (world.level if world.level > 0.0 else -world.level) * 2.0 and "
        "(world.level + 1.0) * world.level - (world.level + 2.0) > 0.0"
    )
    specs = tmp_path / "specs"
    specs.mkdir()
    (specs / "system.yaml").write_text(SYSTEM)
    (specs / "tank.yaml").write_text(TANK.replace("- when: world.level < 2.0", f"- when: {guard}"))
    api.build([specs], tmp_path / "out")
    code = (tmp_path / "out" / "tank" / "tank.py").read_text()
    assert (
        "            if (\n"
        "                self.world_level * (self.world_level + 1.0) < 2.0\n"
        "                and -(self.world_level - 1.0) / (2.0 - self.world_level) > -1.0\n"
        "                and not (self.world_level > 3.0 or self.world_level < -3.0)\n"
        "                and self.world_level // 2.0 - self.world_level % 3.0\n"
        "                <= (self.world_level if self.world_level > 0.0 else -self.world_level)"
        " * 2.0\n"
        "                and (self.world_level + 1.0) * self.world_level - (self.world_level + 2.0)"
        " > 0.0\n"
        "            ):\n"
    ) in code


@pytest.mark.parametrize("length", [40, 41])
def test_a_comment_in_an_expression_is_quoted_whole_up_to_40_characters(
    tmp_path, monkeypatch, length: int
) -> None:
    """A `#` in a quoted guard would drop the rest of it: E101 quotes the comment, whole when
    it is at most 40 characters, else its first 37 and `...`."""
    comment = "c" * length
    tank = TANK.replace("- when: world.level < 2.0", f'- when: "world.level < 2.0 # {comment}"', 1)
    shown = comment if length <= 40 else comment[:37] + "..."
    found = [f for f in said(tmp_path, monkeypatch, SYSTEM, tank) if f[0].startswith("E")]
    assert [(code, message) for code, message, _ in found] == [
        ("E101", f"invalid expression: `#` is not allowed (`# {shown}`)")
    ]


@pytest.mark.parametrize("length", [80, 81])
def test_a_guard_with_a_syntax_error_is_quoted_whole_up_to_80_characters(
    tmp_path, monkeypatch, length: int
) -> None:
    guard = "world.level < 2.0 and " + "1" * (length - len("world.level < 2.0 and  +")) + " +"
    assert len(guard) == length
    tank = TANK.replace("- when: world.level < 2.0", f"- when: {guard}", 1)
    shown = guard if length <= 80 else guard[:77] + "..."
    found = [f for f in said(tmp_path, monkeypatch, SYSTEM, tank) if f[0].startswith("E")]
    assert [(code, hint) for code, _, hint in found] == [("E101", f"in `{shown}`")]
