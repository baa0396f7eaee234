"""A controller's `fragments:` read for shape (rcsgen/compiler/front_end/fragments.py's read, E269
and E267): a good fragment is kept with its parameters, states and first-match states; each way
of declaring one wrong gets its one error, word for word, and the fragment is kept as None so
that its uses say nothing more. Loaded data in, diagnostics out: no spec is compiled, but
for a shared fragment left unused (W305), which only the front end over a system tells."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span, Subject
from rcsgen.compiler.front_end import fragments
from rcsgen.compiler.front_end.loader import load_text

TINY = Path(__file__).resolve().parent / "cases" / "valid" / "tiny"
WHERE = Span("c.yaml", 7, 3)
RULES = [{"when": "$limit > 0", "do": [{"report": "DONE"}]}]


def read(data: Any) -> tuple[dict[str, Any], list[tuple[str, str, str]]]:
    diags = Diagnostics()
    out = fragments.read(data, WHERE, diags)
    return out, [(d.code, d.message, d.hint) for d in diags.items]


def test_a_good_fragment_is_kept_whole() -> None:
    found, said = read(
        {
            "twice": {
                "doc": "Two steps.",
                "params": ["limit", "next_state"],
                "first_match": ["FIRST"],
                "states": {"FIRST": RULES, "SECOND": [{"next": "$next_state"}]},
            }
        }
    )
    assert said == []
    twice = found["twice"]
    assert (twice.name, twice.params, twice.first_match) == (
        "twice",
        ("limit", "next_state"),
        ("FIRST",),
    )
    assert list(twice.states) == ["FIRST", "SECOND"] and twice.span == WHERE


NEEDS_STATES = "needs `states:`, a mapping of state -> rules"
STATES_RULE = (
    "'s states must be UPPER_CASE names, each with a list of rules or a use of another fragment"
)


@pytest.mark.parametrize(
    ("data", "want"),
    [
        ([1, 2], ("E269", "`fragments` must be a mapping: name -> fragment", "")),
        (
            {"Twice": {"states": {"A": RULES}}},
            ("E269", "fragment name `Twice` is not a lower_case identifier", ""),
        ),
        ({"twice": [1]}, ("E269", f"fragment `twice` {NEEDS_STATES}", "")),
        ({"twice": {"states": [1]}}, ("E269", f"fragment `twice` {NEEDS_STATES}", "")),
        (
            {"twice": {"states": {"A": RULES}, "parms": ["limit"]}},
            ("E269", "fragment `twice` has an unknown key `parms`", "did you mean `params`?"),
        ),
        (
            {"twice": {"states": {"A": RULES}, "params": "limit"}},
            ("E269", "fragment `twice`'s `params` must be a list of lower_case names", ""),
        ),
        (
            {"twice": {"states": {"A": RULES}, "params": ["Limit"]}},
            ("E269", "fragment `twice`'s `params` must be a list of lower_case names", ""),
        ),
        (
            {"twice": {"states": {"A": RULES}, "params": [3]}},
            ("E269", "fragment `twice`'s `params` must be a list of lower_case names", ""),
        ),
        ({"twice": {"states": {}}}, ("E269", f"fragment `twice`{STATES_RULE}", "")),
        (
            {"twice": {"states": {"first": RULES}, "params": ["limit"]}},
            ("E269", f"fragment `twice`{STATES_RULE}", ""),
        ),
        (
            {"twice": {"states": {"FIRST": "rules"}, "params": ["limit"]}},
            ("E269", f"fragment `twice`{STATES_RULE}", ""),
        ),
        (
            {"twice": {"states": {"FIRST": RULES}, "params": ["limit"], "first_match": ["FRST"]}},
            (
                "E269",
                "fragment `twice`'s `first_match` must list its own states",
                "did you mean `FIRST`?",
            ),
        ),
        (
            {"twice": {"states": {"FIRST": RULES}, "params": ["limit"], "first_match": "FIRST"}},
            (
                "E269",
                "fragment `twice`'s `first_match` must list its own states",
                "declared states: `FIRST`",
            ),
        ),
        (
            {"twice": {"states": {"FIRST": RULES}, "params": ["limt"]}},
            ("E267", "`$limit` is not a parameter of fragment `twice`", "did you mean `limt`?"),
        ),
        (
            {"twice": {"states": {"FIRST": [{"when": "${lim} > 0"}]}, "params": ["limit"]}},
            ("E267", "`${lim}` is not a parameter of fragment `twice`", "did you mean `limit`?"),
        ),
    ],
)
def test_each_wrong_fragment_gets_its_one_error(data: Any, want: tuple[str, str, str]) -> None:
    found, said = read(data)
    assert said == [want]
    assert all(value is None for value in found.values())


def test_one_wrong_fragment_leaves_the_others_whole() -> None:
    found, said = read(
        {"bad": {"states": {}}, "good": {"states": {"A": [{"next": "A"}]}}, "Worse": {}}
    )
    assert [code for code, _, _ in said] == ["E269", "E269"]
    assert found["bad"] is None and found["good"] is not None and "Worse" not in found


@pytest.mark.parametrize("value", ["{much: 1}", "~"])
def test_a_use_given_a_mapping_or_nothing_for_a_parameter_is_e269_at_the_value(
    value: str,
) -> None:
    """A use's `with:` gives each parameter a name, an expression, a number or a list of
    actions: a mapping or a null is E269 at that value, and the state is not expanded."""
    text = (
        "controller: c\ntitle: C\nfragments:\n  twice:\n    params: [limit]\n    states:\n"
        "      FIRST:\n        - when: $limit > 0\n          do: [report: DONE]\n"
        f"commands:\n  GO:\n    states:\n      S0: {{use: twice, with: {{limit: {value}}}}}\n"
    )
    diags = Diagnostics()
    uses, whole = fragments.expand(load_text(text, "c.yaml"), {}, diags, Span("c.yaml"))
    assert (uses, whole) == ([], False)
    assert [(str(d.span), d.code, d.message) for d in diags.items] == [
        (
            "c.yaml:13:38",
            "E269",
            "the value of `limit` must be a name, an expression, a number or a list of actions",
        )
    ]


NESTED = """\
controller: top
fragments:
  move_and_wait:
    params: [x, then]
    states:
      SEND:
        - do: [{send: sub.MOVE, with: {x: $x}}]
          next: WAIT
      WAIT:
        - when: sub.status == DONE
          next: $then
  twice:
    params: [then]
    states:
      FIRST: {use: move_and_wait, with: {x: 1.0, then: SECOND}}
      SECOND: {use: move_and_wait, with: {x: 2.0, then: $then}}
commands:
  GO:
    states:
      S0: {use: twice, with: {then: S1}}
      S1: [{do: [report: DONE]}]
  BACK:
    states:
      S0: {use: move_and_wait, with: {x: 0.0, then: S1}}
      S1: [{do: [report: DONE]}]
  AWAY:
    states:
      S0: {use: twice, with: {then: S1}}
      S1: [{do: [report: DONE]}]
"""


def test_each_use_nested_or_not_is_told_with_its_command_and_state() -> None:
    """A use within a fragment is a use of the command that uses the outer one, at the
    state of the outer fragment that holds it, named as expanded (GO's `S0_SECOND`)."""
    diags = Diagnostics()
    uses, whole = fragments.expand(load_text(NESTED, "top.yaml"), {}, diags, Span("top.yaml"))
    assert (whole, diags.items) == (True, [])
    assert [(u.fragment.name, str(u.span), u.controller, u.command, u.state) for u in uses] == [
        ("twice", "top.yaml:20:17", "top", "GO", "S0"),
        ("move_and_wait", "top.yaml:15:20", "top", "GO", "S0"),
        ("move_and_wait", "top.yaml:16:21", "top", "GO", "S0_SECOND"),
        ("move_and_wait", "top.yaml:24:17", "top", "BACK", "S0"),
        ("twice", "top.yaml:28:17", "top", "AWAY", "S0"),
        ("move_and_wait", "top.yaml:15:20", "top", "AWAY", "S0"),
        ("move_and_wait", "top.yaml:16:21", "top", "AWAY", "S0_SECOND"),
    ]
    assert [u.states for u in uses[:3]] == [
        ("S0", "S0_WAIT", "S0_SECOND", "S0_SECOND_WAIT"),
        ("S0", "S0_WAIT"),
        ("S0_SECOND", "S0_SECOND_WAIT"),
    ]


def test_a_finding_in_a_fragment_names_the_uses_of_its_command_and_state() -> None:
    """A later stage's finding in a fragment's text names the uses it came through: only the
    one that made its state when it is about a command's state, the command's when about a
    command, every use (at most three shown) when about neither; acknowledged ones too."""
    uses, _ = fragments.expand(load_text(NESTED, "top.yaml"), {}, Diagnostics(), Span("top.yaml"))
    at = Span("top.yaml", 10, 11)  # in move_and_wait's WAIT
    diags = Diagnostics()
    diags.warning(at, "W301", "a", "hint", Subject("top", "GO", "S0_SECOND_WAIT", 1))
    diags.warning(at, "W301", "b", "", Subject("top", "GO"))
    diags.error(at, "E204", "c")
    diags.error(Span("top.yaml", 20, 1), "E204", "d", "outside every fragment")
    diags.acknowledge(Diagnostic(at, "W301", "e", "", Subject("top", "BACK", "S0_WAIT")), "-")
    fragments.annotate(diags, uses, 0)
    used = "in fragment `move_and_wait`, used at "
    assert [d.hint for d in [*diags.items, *diags.acknowledged]] == [
        f"hint ({used}top.yaml:16:21 (GO.S0_SECOND))",
        f"{used}top.yaml:15:20 (GO.S0), top.yaml:16:21 (GO.S0_SECOND)",
        f"{used}top.yaml:15:20 (GO.S0), top.yaml:16:21 (GO.S0_SECOND), top.yaml:24:17 (BACK.S0)"
        " and 2 more",
        "outside every fragment",
        f"{used}top.yaml:24:17 (BACK.S0)",
    ]


@pytest.mark.parametrize("shared_text", ["{states: 3}", "{states: {A: [{next: A}]}}"])
def test_a_controller_fragment_may_not_hide_a_shared_one(shared_text: str) -> None:
    """E270 at the controller's fragment, naming where the shared one is declared (the file
    alone when the shared one was found wrong, E269 there)."""
    shared_diags = Diagnostics()
    shared_data = load_text(f"move_and_wait: {shared_text}\n", "fragments.yaml")
    shared = fragments.read(shared_data, Span("fragments.yaml"), shared_diags)
    diags = Diagnostics()
    fragments.expand(load_text(NESTED, "top.yaml"), shared, diags, Span("top.yaml"))
    where = "" if shared["move_and_wait"] is None else " (fragments.yaml:1:1)"
    assert [(str(d.span), d.code, d.message, d.hint) for d in diags.items] == [
        (
            "top.yaml:3:3",
            "E270",
            f"fragment `move_and_wait` is declared here and in fragments.yaml{where}",
            "rename one: a controller's fragment may not hide a shared one",
        )
    ]


def test_a_finding_is_placed_in_the_fragment_whose_lines_hold_it() -> None:
    """From a fragment's name to its last line (move_and_wait: lines 3 to 11, twice: 12 to
    16), a finding is that fragment's; beyond three uses, the rest are counted."""
    uses, _ = fragments.expand(load_text(NESTED, "top.yaml"), {}, Diagnostics(), Span("top.yaml"))
    diags = Diagnostics()
    for line in (2, 3, 11, 12):
        diags.error(Span("top.yaml", line, 1), "E204", f"line {line}", "h")
    fragments.annotate(diags, uses, 0)
    mw = "h (in fragment `move_and_wait`, used at top.yaml:15:20 (GO.S0), top.yaml:16:21 "
    assert [d.hint for d in diags.items] == [
        "h",
        mw + "(GO.S0_SECOND), top.yaml:24:17 (BACK.S0) and 2 more)",
        mw + "(GO.S0_SECOND), top.yaml:24:17 (BACK.S0) and 2 more)",
        "h (in fragment `twice`, used at top.yaml:20:17 (GO.S0), top.yaml:28:17 (AWAY.S0))",
    ]
    moves = [u for u in uses if u.fragment.name == "move_and_wait"]
    for n, more in ((3, ""), (4, " and 1 more")):
        diags = Diagnostics()
        diags.error(Span("top.yaml", 10, 1), "E204", "x")
        fragments.annotate(diags, moves[:n], 0)
        assert diags.items[0].hint.endswith(f"(BACK.S0){more}"), diags.items[0].hint


def test_a_nested_use_making_a_state_the_outer_expansion_has_is_e268() -> None:
    """twice's FIRST uses move_and_wait, whose WAIT becomes S0_WAIT: twice's own WAIT is
    S0_WAIT too, so the inner use is refused (E268) and the command is not expanded."""
    text = NESTED.replace(
        "      SECOND: {use: move_and_wait, with: {x: 2.0, then: $then}}\n",
        "      WAIT: [{next: $then}]\n",
    )
    diags = Diagnostics()
    uses, whole = fragments.expand(load_text(text, "top.yaml"), {}, diags, Span("top.yaml"))
    assert [(str(d.span), d.code, d.message, d.hint) for d in diags.items] == [
        (
            "top.yaml:15:20",
            "E268",
            "fragment `move_and_wait` used in `twice`'s `FIRST` makes state `S0_WAIT`, which "
            "the expansion of `twice` already has",
            "rename a state of one of the fragments",
        )
    ] * 2  # GO's use of twice and AWAY's
    assert not whole
    assert [(u.command, u.fragment.name) for u in uses] == [("BACK", "move_and_wait")]


def test_a_shared_fragment_no_controller_uses_is_w305_unless_something_failed(
    tmp_path: Path,
) -> None:
    """Compiled (the tiny system and a fragments.yaml): a shared fragment that no controller
    uses is W305 at its name; after an error elsewhere it is not (a misspelt use would make
    it noise)."""
    from rcsgen.compiler.frontend import compile_paths

    system = tmp_path / "tiny"
    shutil.copytree(TINY, system)
    (system / "fragments.yaml").write_text(
        "fragments:\n  spare:\n    states:\n      A: [{do: [report: DONE]}]\n"
    )
    found = compile_paths([system], analyse=False).diagnostics
    assert [(d.span.line, d.code, d.message) for d in found] == [
        (2, "W305", "fragment `spare` is declared but no command uses it")
    ]
    (system / "top.yaml").write_text((system / "top.yaml").read_text() + "bogus: 1\n")
    found = compile_paths([system], analyse=False).diagnostics
    assert [d.code for d in found] == ["S002"]


def test_a_fragment_with_an_unknown_key_leaves_the_next_one_whole() -> None:
    found, said = read(
        {
            "bad": {"states": {"A": RULES}, "parms": ["limit"]},
            "good": {"states": {"A": RULES}, "params": ["limit"]},
        }
    )
    assert [code for code, _, _ in said] == ["E269"]
    assert found["bad"] is None and found["good"] is not None


def test_a_wrong_first_match_is_e269_at_its_value() -> None:
    text = (
        "twice:\n  params: [limit]\n  first_match: [B]\n  states:\n"
        "    A: [{when: $limit > 0, do: [report: DONE]}]\n"
    )
    diags = Diagnostics()
    found = fragments.read(load_text(text, "c.yaml"), Span("c.yaml"), diags)
    assert found == {"twice": None}
    assert [(str(d.span), d.code, d.message) for d in diags.items] == [
        ("c.yaml:3:16", "E269", "fragment `twice`'s `first_match` must list its own states")
    ]


def test_a_command_without_uses_leaves_the_next_command_s_uses_expanded() -> None:
    text = NESTED.replace(
        "commands:\n", "commands:\n  IDLE:\n    states:\n      S0: [{next: S0}]\n"
    )
    uses, whole = fragments.expand(load_text(text, "top.yaml"), {}, Diagnostics(), Span("top.yaml"))
    assert whole
    assert [u.command for u in uses] == ["GO", "GO", "GO", "BACK", "AWAY", "AWAY", "AWAY"]


def chain(depth: int) -> str:
    """A command whose S0 uses f1, f1's S uses f2, ... down to f<depth>, which reports."""
    lines = ["controller: top", "fragments:"]
    for n in range(1, depth + 1):
        inner = f"{{use: f{n + 1}}}" if n < depth else "[{do: [report: DONE]}]"
        lines += [f"  f{n}:", "    states:", f"      S: {inner}"]
    lines += ["commands:", "  GO:", "    states:", "      S0: {use: f1}", ""]
    return "\n".join(lines)


def test_fragments_nest_eight_deep_and_no_deeper() -> None:
    """Fragments within fragments: eight levels are expanded; a ninth is E298 at its use,
    with the chain that leads to it."""
    diags = Diagnostics()
    uses, whole = fragments.expand(load_text(chain(8), "top.yaml"), {}, diags, Span("top.yaml"))
    assert (whole, diags.items, len(uses)) == (True, [], 8)
    diags = Diagnostics()
    fragments.expand(load_text(chain(9), "top.yaml"), {}, diags, Span("top.yaml"))
    assert [(d.code, d.message) for d in diags.items] == [
        (
            "E298",
            "fragments nested more than 8 deep (f1 -> f2 -> f3 -> f4 -> f5 -> f6 -> f7 -> f8 "
            "-> f9)",
        )
    ]
