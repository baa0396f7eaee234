"""The state-table analysis (rcsgen/compiler/analysis/tables.py) over what a guard calls and
reads of a subordinate: abs/min/max evaluated as Python does (a guard that can never hold is
W512, one that always can is no finding), and a failed subordinate's reason ranging over
NONE, LOST and its own reasons (a rule for each but LOST leaves a wait, named). Word for
word, on tests/test_lowered.py's pair."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_lowered import DEV, SYSTEM, TOP

from rcsgen.compiler.frontend import compile_paths

DONE_RULE = "        - when: dev.status == DONE\n"
FAILING = (
    "        - when: dev.status == ERROR\n          do: [{report: ERROR, reason: dev.reason}]\n"
)
READS = TOP.replace(
    "subordinates: [dev]\n",
    "subordinates: [dev]\nworld:\n  reads: [level]\nconstants:\n  LOW: 1.0\n",
)
NEVER = (
    "W512",
    "top.yaml:19:11",
    "rule 2 of GO S1 never fires: its guard can never hold",
    "check its comparisons and constants, reorder the rules, or delete it",
)
WAITS = (
    "W503",
    "top.yaml:16:7",
    "GO S1 waits when dev.status=DONE: no rule fires then",
    "waiting is normal in RCS; if this wait is intended, acknowledge it on GO: "
    "`allow: [{code: W503, states: [S1], reason: ...}]`",
)


def said(root: Path, top: str) -> list[tuple[str, str, str, str]]:
    for name, text in (("system", SYSTEM), ("top", top), ("dev", DEV)):
        (root / f"{name}.yaml").write_text(text)
    found = compile_paths([root]).diagnostics.items
    return [(d.code, str(d.span).rsplit("/", 1)[-1], d.message, d.hint) for d in found]


@pytest.mark.parametrize(
    ("guard", "want"),
    [
        ("min(world.level, 1.0) > 2.0", [NEVER, WAITS]),
        ("abs(world.level) < 0.0", [NEVER, WAITS]),
        ("max(world.level, 3.0) > 2.0", []),
        ("min(world.level, 3.0) <= 3.0", []),
        ("world.level < min(LOW, 3.0) and world.level > max(LOW, 0.5)", [NEVER, WAITS]),
        (  # decided with LOW's value: below 1.0, no rule fires
            "world.level < max(LOW, 3.0) and world.level > abs(-LOW)",
            [
                (
                    *WAITS[:2],
                    "GO S1 waits when dev.status=DONE, world.level=-1.0: no rule fires then",
                    WAITS[3],
                )
            ],
        ),
    ],
)
def test_a_guard_calling_abs_min_max_is_decided(tmp_path: Path, guard: str, want) -> None:
    top = READS.replace(DONE_RULE, f"        - when: dev.status == DONE and {guard}\n", 1)
    assert said(tmp_path, top) == want


def test_a_failed_subordinates_reason_can_be_lost(tmp_path: Path) -> None:
    named = "dev.reason == NONE or dev.reason == WORN or dev.reason == BLOCKED"
    top = TOP.replace(
        FAILING,
        f"        - when: dev.status == ERROR and ({named})\n"
        "          do: [{report: ERROR, reason: REFUSED}]\n",
    )
    assert said(tmp_path, top) == [
        (
            "W503",
            "top.yaml:12:7",
            "GO S1 waits when dev.status=ERROR, dev.reason=LOST: no rule fires then",
            "waiting is normal in RCS; if this wait is intended, acknowledge it on GO: "
            "`allow: [{code: W503, states: [S1], reason: ...}]`",
        )
    ]
    with_lost = top.replace(named, f"{named} or dev.reason == LOST")
    assert said(tmp_path, with_lost) == []


@pytest.mark.parametrize(
    ("guard", "want"),
    [
        (  # above 2 and below 1: never (the six lines of `functions:` move the places)
            "between(world.level, 2.0, 1.0)",
            [(NEVER[0], "top.yaml:25:11", *NEVER[2:]), (WAITS[0], "top.yaml:22:7", *WAITS[2:])],
        ),
        ("(between(world.level, 1.0, 2.0) or not between(world.level, 1.0, 2.0))", []),
    ],
)
def test_a_function_whose_body_is_an_and_is_decided_with_its_arguments(
    tmp_path: Path, guard: str, want
) -> None:
    # the body's `and` has the arguments put in for its parameters (expressions.substitute of
    # a BoolOp): left unsubstituted, `lo` and `hi` would be free and the guard could hold
    top = READS.replace(
        "constants:\n",
        "functions:\n  between:\n    doc: x strictly between lo and hi.\n"
        "    params: {x: float, lo: float, hi: float}\n    returns: bool\n"
        "    body: x > lo and x < hi\nconstants:\n",
    ).replace(DONE_RULE, f"        - when: dev.status == DONE and {guard}\n", 1)
    assert said(tmp_path, top) == want
