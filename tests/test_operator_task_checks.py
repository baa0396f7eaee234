"""An operator module's task results and its place in the system (rcsgen/compiler/checks/
operators.py, E910, E283), word for word: a range only on a number, whole bounds on an int,
`min` no greater than `max`; a person's module is never replaced by a stand-in. The
platoon's specs, copied and edited one way a case."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.checks.operators import instruction_fields
from rcsgen.compiler.frontend import compile_paths

PLATOON = Path(__file__).resolve().parent.parent / "specs" / "platoon"
POST = "      post:\n        type: float\n        min: 0.0\n        max: 5000.0\n"
WHERE = "result `post` of `ldr.SPOT_REPORT`"


def errors(tmp_path: Path, file: str, old: str, new: str) -> list[tuple[str, str, str]]:
    copy = tmp_path / "platoon"
    shutil.copytree(PLATOON, copy, ignore=shutil.ignore_patterns("scenarios", "__pycache__"))
    text = (copy / file).read_text(encoding="utf-8")
    assert old in text
    (copy / file).write_text(text.replace(old, new, 1), encoding="utf-8")
    found = compile_paths([copy]).diagnostics.errors
    return [(d.code, d.message, d.hint) for d in found]


@pytest.mark.parametrize(
    ("new", "want"),
    [
        (
            POST.replace("float", "int").replace("min: 0.0", "min: 0.5"),
            (
                "E910",
                f"{WHERE} is an int, but its bound 0.5 is not a whole number",
                "give an int result whole bounds",
            ),
        ),
        (
            POST.replace("min: 0.0", "min: 6000.0"),
            (
                "E910",
                f"{WHERE} has `min` 6000.0 above its `max` 5000.0: no answer fits",
                "swap them",
            ),
        ),
        (
            POST.replace("float", "bool"),
            (
                "E910",
                f"{WHERE} has the type bool: only an int or a float has a range",
                "leave `min`/`max` out: an answer is checked against its type and values",
            ),
        ),
    ],
)
def test_a_task_results_range(tmp_path, new: str, want) -> None:
    found = errors(tmp_path, "ldr.yaml", POST, new)
    assert want in found, found


def test_a_person_is_not_replaced_by_a_stand_in(tmp_path) -> None:
    found = errors(tmp_path, "system.yaml", "\nprocesses:", "\nstand_ins:\n  ldr: pl\n\nprocesses:")
    assert (
        "E283",
        "operator module `ldr` cannot be replaced by a stand-in",
        "a person answers it; script the person in a scenario's `operator:` section",
    ) in found, found


LONG = "9" * 400  # no int64 holds it, nor a float


@pytest.mark.parametrize(
    ("new", "want"),
    [
        (
            POST.replace("float", "int").replace("max: 5000.0", f"max: {LONG}"),
            f"integer {'9' * 27}... is out of range: an int is 64-bit "
            "(-9223372036854775808 to 9223372036854775807)",
        ),
        (
            POST.replace("float", "int").replace("min: 0.0", f"min: -{LONG}"),
            f"integer -{'9' * 26}... is out of range: an int is 64-bit "
            "(-9223372036854775808 to 9223372036854775807)",
        ),
        (
            POST.replace("max: 5000.0", f"max: {LONG}"),
            f"integer {'9' * 27}... is too large for a float",
        ),
    ],
)
def test_a_bound_no_result_can_hold_is_e110_at_the_bound(tmp_path, new: str, want: str) -> None:
    """A task result's `min` or `max` is a number of the result's type, like an initial
    value: an int beyond 64 bits, or too large for a float, is E110 (it raised OverflowError)."""
    found = errors(tmp_path, "ldr.yaml", POST, new)
    assert found == [("E110", want, "use a smaller number, or a float if the value is not a count")]


def test_a_huge_bound_above_the_other_is_quoted_cut_in_e910(tmp_path) -> None:
    """`min` of 400 digits above `max`: E110 for the bound and E910 for the order, each
    quoting the number's first 27 digits (E910 printed all 400)."""
    new = POST.replace("float", "int").replace("min: 0.0", f"min: {LONG}")
    found = errors(tmp_path, "ldr.yaml", POST, new)
    assert (
        "E910",
        f"{WHERE} has `min` {'9' * 27}... above its `max` 5000.0: no answer fits",
        "swap them",
    ) in found, found


@pytest.mark.parametrize(
    ("text", "fields", "refused"),
    [
        ("Load {part} into {fixture}", ["part", "fixture"], None),
        ("Plain text, no field", [], None),
        ("Set {speed:>3} now", None, "`{speed:>3}` is not `{parameter}`"),
        ("Set {speed!r} now", None, "`{speed!r}` is not `{parameter}`"),
        ("Set {speed!r:>3} now", None, "`{speed!r:>3}` is not `{parameter}`"),
        ("Set {0} now", None, "`{0}` is not `{parameter}`"),
    ],
)
def test_an_instruction_texts_fields_or_the_field_it_refuses_word_for_word(
    text: str, fields: list[str] | None, refused: str | None
) -> None:
    """The refused field is quoted as written, its conversion and format spec included."""
    if refused is None:
        assert instruction_fields(text) == fields
    else:
        with pytest.raises(ValueError) as raised:
            instruction_fields(text)
        assert str(raised.value) == refused
