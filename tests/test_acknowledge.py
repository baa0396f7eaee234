"""Acknowledgements (`allow:`): a finding that is intended is not reported, with its reason.

Uses test_analysis's small system (`top` over leaves `a` and `b`): each test writes top's
commands, runs the front end and looks at what is reported and what is acknowledged.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import rcsgen
from test_analysis import make

from rcsgen.compiler.diagnostics import Diagnostics
from rcsgen.compiler.frontend import compile_paths

WAITS = """
GO:
{allow}
  states:
    S0:
      - do: [send: a.GO]
        next: S1
    S1:
      - when: a.status == DONE and world.hot
        next: S2
      - when: a.status == ERROR
        do: [report: ERROR]
    S2:
      - when: world.cold
        do: [report: DONE]
"""


@pytest.fixture
def check(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.chdir(tmp_path)

    def run(commands: str, **fields: str) -> Diagnostics:
        text = commands.format(**fields) if fields else commands
        return compile_paths([make(tmp_path, text)]).diagnostics

    return run


def codes(diags: Diagnostics) -> list[tuple[str, str | None]]:
    """(code, state) of each reported warning, by the state its subject names."""
    return sorted((d.code, d.subject.state if d.subject else None) for d in diags)


def test_without_acknowledgement_the_waits_are_reported(check) -> None:
    diags = check(WAITS, allow="")
    assert ("W503", "S1") in codes(diags) and ("W503", "S2") in codes(diags)
    assert diags.acknowledged == []


def test_a_command_acknowledgement_covers_only_its_states(check) -> None:
    allow = "  allow:\n    - {code: W503, states: [S1], reason: waits for the heater}"
    diags = check(WAITS, allow=allow)
    assert ("W503", "S1") not in codes(diags)
    assert ("W503", "S2") in codes(diags)  # not acknowledged: still reported
    [done] = diags.acknowledged
    assert (done.code, done.subject and done.subject.state) == ("W503", "S1")
    assert done.acknowledged == "waits for the heater"


def test_a_command_acknowledgement_covers_only_its_command(check) -> None:
    # AGAIN has GO's table, waits and all: GO's acknowledgement is not AGAIN's
    allow = "  allow:\n    - {code: W503, states: [S1], reason: waits for the heater}"
    diags = check(WAITS.format(allow=allow) + WAITS.format(allow="").replace("GO:", "AGAIN:"))
    waits = sorted(
        (d.subject.command, d.subject.state) for d in diags if d.code == "W503" and d.subject
    )
    assert waits == [("AGAIN", "S1"), ("AGAIN", "S2"), ("GO", "S2")]
    assert [(d.subject and d.subject.command) for d in diags.acknowledged] == ["GO"]


def test_a_command_acknowledgement_without_states_covers_every_state(check) -> None:
    # A folded reason over two lines: shown on one.
    allow = "  allow:\n    - code: W503\n      reason: >-\n        every wait of GO\n"
    allow += "        is for a sensor"
    diags = check(WAITS, allow=allow)
    assert [c for c in codes(diags) if c[0] == "W503"] == []
    assert {d.acknowledged for d in diags.acknowledged} == {"every wait of GO is for a sensor"}


def test_a_rule_acknowledgement_covers_that_rule_only(check) -> None:
    diags = check(
        """
        GO:
          first_match: [S0]
          states:
            S0:
              - when: world.hot
                do: [report: DONE]
              - when: world.hot and world.cold
                do: [report: ERROR]
                allow: [{code: W512, reason: kept to document the cold case}]
              - when: world.hot and world.level > 2.0
                do: [report: ERROR]
              - do: [report: DONE]
        """
    )
    reported = [(d.code, d.subject.rule if d.subject else None) for d in diags]
    assert reported == [("W512", 3)]
    assert [(d.code, d.subject.rule) for d in diags.acknowledged if d.code == "W512"] == [
        ("W512", 2)
    ]


def test_checker_warnings_can_be_acknowledged(check) -> None:
    diags = check(
        """
        GO:
          states:
            S0:
              - do: [report: DONE]
              - do: [report: ERROR]
                allow: [{code: W301, reason: "the old ending, kept for the review"}]
        """
    )
    assert list(diags) == []
    [done] = diags.acknowledged
    assert done.code == "W301" and done.acknowledged == "the old ending, kept for the review"


def test_an_every_cycle_rule_can_be_acknowledged(tmp_path: Path, monkeypatch) -> None:
    # beside GO's own acknowledgement of its wait in S1, which stays
    monkeypatch.chdir(tmp_path)
    every_cycle = """
        every_cycle:
          - when: world.hot
            do: [set: {i: 1}]
          - when: 1 > 2
            do: [set: {i: 2}]
            allow: [{code: W302, reason: kept for the next sensor}]
        """
    allow = "  allow:\n    - {code: W503, states: [S1], reason: waits for the heater}"
    top = make(tmp_path, WAITS.format(allow=allow), top_level=every_cycle)
    diags = compile_paths([top]).diagnostics
    assert [(d.code, d.subject and d.subject.state) for d in diags] == [("W503", "S2")]
    assert [
        (d.code, d.subject and (d.subject.command, d.subject.rule), d.acknowledged)
        for d in diags.acknowledged
    ] == [
        ("W302", (None, 2), "kept for the next sensor"),
        ("W503", ("GO", None), "waits for the heater"),
    ]


def test_acknowledged_warnings_do_not_fail_strict_and_show_on_request(check) -> None:
    allow = (
        "  allow:\n    - {code: W503, states: [S1], reason: waits for the heater}\n"
        "    - {code: W503, states: [S2], reason: waits for the cooler}"
    )
    diags = check(WAITS, allow=allow)
    assert list(diags) == []
    assert rcsgen("validate", "--strict", "sys").exit_code == 0
    shown = rcsgen("validate", "--format", "json", "--show-acknowledged", "sys")
    found = json.loads(shown.stdout)
    assert [(d["code"], d["acknowledged"]) for d in found] == [
        ("W503", "waits for the heater"),
        ("W503", "waits for the cooler"),
    ]
    assert all(d["acknowledged"] for d in found)
    assert json.loads(rcsgen("validate", "--format", "json", "sys").stdout) == []


def test_an_acknowledgement_that_matches_nothing_is_w303(check) -> None:
    allow = "  allow:\n    - {code: W505, states: [S2], reason: never waited for on purpose}"
    diags = check(WAITS, allow=allow)
    [w303] = [d for d in diags if d.code == "W303"]
    assert w303.message == "the acknowledgement of W505 in GO S2 matches no finding"
    assert w303.hint == (
        "remove it if the finding is gone; W505 is about a rule: acknowledge it on the rule, "
        "or on the command with `states:`"
    )
    assert rcsgen("validate", "--strict", "sys").exit_code == 1


def test_a_stale_acknowledgement_of_a_state_finding_says_where_it_goes(check) -> None:
    allow = "  allow:\n    - {code: W508, states: [S2], reason: kept for later}"
    [w303] = [d for d in check(WAITS, allow=allow) if d.code == "W303"]
    assert w303.hint == (
        "remove it if the finding is gone; W508 is about a state: acknowledge it on the "
        "command, with `states:`"
    )


def test_errors_cannot_be_acknowledged(check) -> None:
    diags = check(WAITS, allow="  allow:\n    - {code: E501, reason: order}")
    [e237] = diags.errors
    assert (e237.code, e237.message) == (
        "E237",
        "`E501` cannot be acknowledged: it is an error: fix it",
    )


@pytest.mark.parametrize(
    ("code", "what"),
    [
        ("S004", "an error: fix it"),  # a schema error's code
        ("W501", "not a warning that can be acknowledged"),  # first_match, not allow, takes it
        ("X123", "not a warning"),  # a code of no kind (the schema lets any letter through)
    ],
)
def test_what_cannot_be_acknowledged_says_what_it_is(check, code: str, what: str) -> None:
    diags = check(WAITS, allow=f"  allow:\n    - {{code: {code}, reason: order}}")
    assert [(d.code, d.message) for d in diags.errors] == [
        ("E237", f"`{code}` cannot be acknowledged: it is {what}")
    ]


def test_each_acknowledgement_that_matches_nothing_says_where_it_is(
    tmp_path: Path, monkeypatch
) -> None:
    # after one that is used: on the command without states, on a rule, on an every_cycle rule
    monkeypatch.chdir(tmp_path)
    every_cycle = """
        every_cycle:
          - when: world.hot
            do: [set: {i: 1}]
            allow: [{code: W302, reason: none yet}]
        """
    allow = (
        "  allow:\n    - {code: W503, states: [S1], reason: waits for the heater}\n"
        "    - {code: W512, reason: none yet}"
    )
    done = "        do: [report: DONE]\n"
    commands = WAITS.format(allow=allow).replace(
        done, done + "        allow: [{code: W301, reason: none yet}]\n"
    )
    diags = compile_paths([make(tmp_path, commands, top_level=every_cycle)]).diagnostics
    assert [(str(d.span), d.message) for d in diags if d.code == "W303"] == [
        (
            "sys/top.yaml:18:13",
            "the acknowledgement of W302 on every_cycle rule 1 matches no finding",
        ),
        ("sys/top.yaml:23:9", "the acknowledgement of W512 in GO matches no finding"),
        ("sys/top.yaml:36:19", "the acknowledgement of W301 on rule 1 of GO S2 matches no finding"),
    ]


# What each warning a spec can acknowledge is about (codes.Code.about), as W303 says it
ABOUT = {
    "W301": "a rule",
    "W302": "a rule",
    "W304": "a rule",
    "W306": "a rule",
    "W309": "a rule",
    "W502": "a rule",
    "W503": "a state",
    "W505": "a rule",
    "W506": "a state",
    "W508": "a state",
    "W509": "a state",
    "W511": "a state",
    "W512": "a rule",
}


def test_an_unused_acknowledgement_says_where_its_code_is_acknowledged(check) -> None:
    allows = "".join(f"    - {{code: {code}, reason: none yet}}\n" for code in ABOUT)
    diags = check(f"GO:\n  allow:\n{allows}  states:\n    S0:\n      - do: [report: DONE]\n")
    where = {
        "a rule": "on the rule, or on the command with `states:`",
        "a state": "on the command, with `states:`",
    }
    assert [d.hint for d in diags if d.code == "W303"] == [
        f"remove it if the finding is gone; {code} is about {kind}: acknowledge it {where[kind]}"
        for code, kind in ABOUT.items()
    ]


def test_an_unmatched_acknowledgement_after_others_is_still_w303(tmp_path: Path) -> None:
    """The cell's supervisor acknowledges a finding it has (W505, used) and one that only
    `prove` can find (W708, not checked here); a third after them that matches nothing is
    W303 all the same."""
    import shutil

    root = Path(__file__).resolve().parent.parent
    spec = tmp_path / "cell"
    shutil.copytree(root / "specs" / "cell", spec, ignore=shutil.ignore_patterns("scenarios"))
    sup = spec / "sup.yaml"
    sup.write_text(
        sup.read_text().replace(
            "state, the echo already seen; it sends nothing, so no echo is skipped.\n",
            "state, the echo already seen; it sends nothing, so no echo is skipped.\n"
            "            - code: W509\n              reason: nothing to find\n",
            1,
        )
    )
    out = compile_paths([spec])
    assert [(d.code, d.message) for d in out.diagnostics.items] == [
        ("W303", "the acknowledgement of W509 on rule 4 of RUN MOVING matches no finding")
    ]
    assert [d.code for d in out.diagnostics.acknowledged] == ["W505"]


def test_a_spec_that_does_not_load_reports_no_stale_acknowledgement(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """When the system file does not load, the checks never ran: an acknowledgement that
    matched nothing is not W303 (it may well match once the error is fixed)."""
    monkeypatch.chdir(tmp_path)
    allow = "  allow:\n    - {code: W505, states: [S2], reason: never waited for on purpose}"
    directory = make(tmp_path, WAITS.format(allow=allow))
    system = directory / "system.yaml"
    system.write_text(system.read_text() + "bogus_key: 1\n")
    diags = compile_paths([directory]).diagnostics
    assert diags.errors
    assert [d.code for d in diags if d.code == "W303"] == []
