"""What `rcsgen validate`'s reports say, byte for byte (rcsgen/tools/report.py): the SARIF log a
code-scanning service reads, GitHub's annotations, the coloured text, `--statistics`, the
summary line and the refusals of `--select`/`--ignore`. A service parses the bytes and a person
reads the words: a changed key, level, escape or indentation is a changed report."""

from __future__ import annotations

import json

import pytest

from rcsgen.compiler.diagnostics import (
    Diagnostic,
    Diagnostics,
    Span,
    _edit_distance,
    did_you_mean,
    known_names_hint,
    to_json,
)
from rcsgen.tools import report
from rcsgen.tools.report import Options, Outcome

ERROR = Diagnostic(
    Span("sys/a b.yaml", 3, 4), "E204", "unknown command `MOVEE`", "did you mean `MOVE`?"
)
WARNING = Diagnostic(Span("sys/a b.yaml", 9, 1), "W503", "state S2 can wait", "add a timeout")
ACKNOWLEDGED = Diagnostic(
    Span("/abs/x.yaml", 2, 7),
    "W503",
    "state S1 can wait",
    "add a timeout",
    acknowledged="the operator ends it",
)


def _rule(code: str, title: str, level: str) -> dict[str, object]:
    return {
        "id": code,
        "shortDescription": {"text": title},
        "defaultConfiguration": {"level": level},
        "help": {"text": f"rcsgen's docs/diagnostics.md, section {code}"},
    }


def _result(code: str, index: int, level: str, text: str, uri: str, line: int, col: int):
    return {
        "ruleId": code,
        "ruleIndex": index,
        "level": level,
        "message": {"text": text},
        "locations": [
            {
                "physicalLocation": {
                    "artifactLocation": {"uri": uri},
                    "region": {"startLine": line, "startColumn": col},
                }
            }
        ],
    }


def test_sarif_is_the_whole_log_sorted_once_each_indented_by_two() -> None:
    suppressed = _result("W503", 1, "warning", "state S1 can wait", "file:///abs/x.yaml", 2, 7)
    suppressed["suppressions"] = [{"kind": "inSource", "justification": "the operator ends it"}]
    expected = {
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "rcsgen",
                        "version": "1.2.3",
                        "rules": [
                            _rule("E204", "undeclared command", "error"),
                            _rule("W503", "state that can wait", "warning"),
                        ],
                    }
                },
                "columnKind": "unicodeCodePoints",
                "results": [
                    suppressed,  # an acknowledged warning: its reason, never its hint
                    _result(
                        "E204",
                        0,
                        "error",
                        "unknown command `MOVEE`\nhint: did you mean `MOVE`?",
                        "sys/a%20b.yaml",
                        3,
                        4,
                    ),
                    _result(
                        "W503",
                        1,
                        "warning",
                        "state S2 can wait\nhint: add a timeout",
                        "sys/a%20b.yaml",
                        9,
                        1,
                    ),
                ],
            }
        ],
    }
    text = report.to_sarif([WARNING, ERROR, ACKNOWLEDGED, ERROR], "1.2.3")
    assert text == json.dumps(expected, indent=2)


def test_github_notices_an_acknowledged_warning_with_its_reason() -> None:
    assert report.to_github([ERROR, ACKNOWLEDGED]).splitlines() == [
        "::notice file=/abs/x.yaml,line=2,col=7,title=rcsgen W503::"
        "state S1 can wait%0Aacknowledged: the operator ends it",
        "::error file=sys/a b.yaml,line=3,col=4,title=rcsgen E204::"
        "unknown command `MOVEE`%0Adid you mean `MOVE`?",
    ]


def _style(text: str, **how: object) -> str:
    """A stand-in for click.style that shows the style it was asked for."""
    return "<" + ",".join(f"{k}={v}" for k, v in sorted(how.items())) + ">" + text + "</>"


def test_coloured_text_styles_each_part_and_puts_the_caret_under_the_column() -> None:
    assert report.render_text(ERROR, "  x: sub.MOVEE  ", _style).splitlines() == [
        "<bold=True>sys/a b.yaml:3:4</>: <bold=True,fg=red>error[E204]</>: unknown command `MOVEE`",
        "  <fg=blue>|</>   x: sub.MOVEE",
        "  <fg=blue>|</>    <bold=True,fg=green>^</>",
        "  <fg=cyan>= hint:</> did you mean `MOVE`?",
    ]
    at_first = report.render_text(WARNING, "S2:", _style).splitlines()  # column 1: no indent
    assert at_first[1:3] == ["  <fg=blue>|</> S2:", "  <fg=blue>|</> <bold=True,fg=green>^</>"]
    assert report.render_text(ACKNOWLEDGED, None, _style).splitlines() == [
        "<bold=True>/abs/x.yaml:2:7</>: <fg=cyan>acknowledged[W503]</>: state S1 can wait",
        "  <fg=cyan>= reason:</> the operator ends it",
    ]
    assert report.render_text(WARNING, None, _style).startswith(
        "<bold=True>sys/a b.yaml:9:1</>: <bold=True,fg=yellow>warning[W503]</>: "
    )
    assert report.render_text(ERROR, None) == ERROR.render(None)  # no colour: the plain text


def test_statistics_count_per_code_most_frequent_first_right_aligned() -> None:
    many = [ERROR] * 10
    lines = report.statistics([*many, WARNING, ACKNOWLEDGED, WARNING])
    assert lines == [
        "10  E204  error         e.g. sys/a b.yaml:3:4",
        " 2  W503  warning       e.g. sys/a b.yaml:9:1",
        " 1  W503  acknowledged  e.g. /abs/x.yaml:2:7",
    ]
    assert report.statistics([]) == []


@pytest.mark.parametrize(
    ("outcome", "said"),
    [
        (Outcome(2, 1, 3, True), "2 errors, 1 warning (3 acknowledged)"),
        (Outcome(0, 4, 0, False), "0 errors, 4 warnings"),
        (Outcome(1, 0, 0, True), "1 error, 0 warnings"),
        (Outcome(0, 0, 3, False), ""),  # nothing found: nothing said, acknowledged or not
    ],
)
def test_the_summary_line(outcome: Outcome, said: str) -> None:
    assert report.summary(outcome) == said


@pytest.mark.parametrize(
    ("prefix", "said"),
    [
        ("E2", "`E2` names errors: errors are always reported and cannot be ignored"),
        ("S1", "`S1` names errors: errors are always reported and cannot be ignored"),
        ("X5", "`X5` is not a warning code or prefix (such as W5 or W503)"),
        ("W50a", "`W50a` is not a warning code or prefix (such as W5 or W503)"),
        ("W5", ""),
        ("W", ""),
        ("W503", ""),
    ],
)
def test_which_prefixes_select_warnings(prefix: str, said: str) -> None:
    assert report.code_prefix_problem(prefix) == said


def test_a_prefix_no_warning_has_lists_the_warnings() -> None:
    said = report.code_prefix_problem("W9")
    assert said.startswith("no warning code starts with `W9`; the warnings are W301, W302, ")
    assert said.endswith(", W709, W803, W811")


def test_select_ignore_and_strict_decide_what_is_shown_and_what_fails() -> None:
    diags = Diagnostics([ERROR, WARNING], [ACKNOWLEDGED])
    assert report.outcome(diags, Options()) == Outcome(1, 1, 1, True)
    quiet = Options(ignore=("W5",))
    assert report.shown(diags, quiet) == ([ERROR], [])
    assert report.outcome(Diagnostics([WARNING]), Options()) == Outcome(0, 1, 0, False)
    assert report.outcome(Diagnostics([WARNING]), Options(strict=True)).fails
    assert not report.outcome(Diagnostics([WARNING]), Options(strict=True, ignore=("W503",))).fails
    assert report.shown(Diagnostics([WARNING]), Options(select=("W3",))) == ([], [])
    assert report.shown(Diagnostics([WARNING]), Options(select=("W3", "W50"))) == ([WARNING], [])
    shown = report.shown(diags, Options(show_acknowledged=True, select=("E",)))
    assert shown == ([ERROR], [ACKNOWLEDGED])  # errors shown whatever is selected


def test_json_names_every_field_and_an_acknowledged_warnings_reason() -> None:
    """`--format json`: each distinct finding once, by position, each field by its name;
    the reason only for an acknowledged warning."""
    assert json.loads(to_json([WARNING, ERROR, ERROR, ACKNOWLEDGED])) == [
        {
            "file": "/abs/x.yaml",
            "line": 2,
            "col": 7,
            "severity": "warning",
            "code": "W503",
            "message": "state S1 can wait",
            "hint": "add a timeout",
            "acknowledged": "the operator ends it",
        },
        {
            "file": "sys/a b.yaml",
            "line": 3,
            "col": 4,
            "severity": "error",
            "code": "E204",
            "message": "unknown command `MOVEE`",
            "hint": "did you mean `MOVE`?",
        },
        {
            "file": "sys/a b.yaml",
            "line": 9,
            "col": 1,
            "severity": "warning",
            "code": "W503",
            "message": "state S2 can wait",
            "hint": "add a timeout",
        },
    ]


def test_a_span_of_a_whole_file_is_its_first_line_and_column() -> None:
    assert str(Span("out")) == "out:1:1"


@pytest.mark.parametrize(
    ("name", "names", "said"),
    [
        ("cx", ["cc", "zz"], "did you mean `cc`?"),  # two letters, one substituted
        ("CX", ["cc"], "did you mean `cc`?"),  # whatever the case
        ("ab", ["ba"], ""),  # swapped: two edits
        ("ab", ["azzz"], ""),  # its start is one edit away, the whole three
        ("ab", ["wxyz"], ""),
        ("x", ["y"], ""),  # one letter: too short to guess
        ("MOVEE", ["MOVE", "HALT"], "did you mean `MOVE`?"),
    ],
)
def test_did_you_mean_names_a_close_name_or_none(name: str, names: list[str], said: str) -> None:
    assert did_you_mean(name, names) == said


@pytest.mark.parametrize(
    ("a", "b", "distance"),
    [("", "ab", 2), ("ab", "", 2), ("ab", "ab", 0), ("ab", "abc", 1), ("abc", "ab", 1),
     ("abc", "axc", 1), ("kitten", "sitting", 3), ("ab", "ba", 2)],
)  # fmt: skip
def test_the_edit_distance_counts_insertions_deletions_and_substitutions(
    a: str, b: str, distance: int
) -> None:
    assert _edit_distance(a, b) == distance


def test_a_hint_lists_the_declared_names_eight_at_most() -> None:
    eight = [f"p{i}" for i in range(8)]
    listed = ", ".join(f"`{n}`" for n in eight)
    assert known_names_hint("predicates", reversed(eight)) == f"declared predicates: {listed}"
    assert known_names_hint("predicates", [*eight, "q"]) == (
        f"declared predicates: {listed} and 1 more"
    )
    assert known_names_hint("predicates", [], "x") == "no predicates are declared"
    assert known_names_hint("predicates", ["ready"], "raedy") == "did you mean `ready`?"


def test_an_acknowledged_warning_is_rendered_with_its_reason_not_its_hint() -> None:
    assert ACKNOWLEDGED.render("  S1:") == (
        "/abs/x.yaml:2:7: acknowledged[W503]: state S1 can wait\n"
        "  |   S1:\n"
        "  |       ^\n"
        "  = reason: the operator ends it"
    )
