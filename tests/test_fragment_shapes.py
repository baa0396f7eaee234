"""A controller's `fragments:` read for shape (rcsgen/compiler/front_end/fragments.py's read, E269
and E267): a good fragment is kept with its parameters, states and first-match states; each way
of declaring one wrong gets its one error, word for word, and the fragment is kept as None so
that its uses say nothing more. Loaded data in, diagnostics out: no spec is compiled."""

from __future__ import annotations

from typing import Any

import pytest

from rcsgen.compiler.diagnostics import Diagnostics, Span
from rcsgen.compiler.front_end import fragments
from rcsgen.compiler.front_end.loader import load_text

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
