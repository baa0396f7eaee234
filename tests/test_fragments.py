"""Fragments (issue 14, item 4): parameterised sub-tables expanded at build time.

What a use expands to (names, parameters, first_match), where each mistake is reported (at
the use, at the definition, and a later stage's finding in a fragment with its uses), that
the generated code of a table written with a fragment is the hand-written table's, and a
differential run: random tables of tests/test_differential.py, factored into a fragment with
a parameter, built, and run against the reference interpreter on the tables written out.
"""

from __future__ import annotations

import copy
import random
import re
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_differential import DERANDOMIZE, Draw, drive, system_files, write_system

from rcsgen.compiler.back_end import emit
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness

EXAMPLES = 10

SYSTEM = """\
system: tiny
title: Tiny system
cycle_period: 0.5
world:
  level: {type: float, initial: 0.0}
  done_flag: {type: bool, initial: false}
processes:
  p: {modules: [top, sub]}
"""

SUB = """\
controller: sub
title: Sub controller
commands:
  MOVE:
    params: {x: {type: float}}
    states:
      S0:
        - do: [report: DONE]
"""

FRAGMENT = """\
  move_and_wait:
    doc: Move the subordinate to $x and wait for it, at most $limit.
    params: [x, limit, then]
    first_match: [WAIT]
    states:
      SEND:
        - do:
            - send: sub.MOVE
              with: {x: $x}
          next: WAIT
      WAIT:
        - when: sub.status == DONE
          next: $then
        - when: sub.status == ERROR
          do: [report: ERROR]
        - after: $limit
          do: [report: ERROR]
"""

TOP = """\
controller: top
title: Top controller
subordinates: [sub]
world:
  reads: [done_flag]
{fragments}commands:
  GO:
    doc: Go to 1, then to 2.
    states:
{states}"""

USES = """\
      S0: {use: move_and_wait, with: {x: 1.0, limit: 3 s, then: ARRIVED}}
      ARRIVED:
        - do: [report: DONE]
"""

# What the uses above stand for, written out: the first state keeps the using state's name.
BY_HAND = """\
    first_match: [S0_WAIT]
    states:
      S0:
        - do:
            - send: sub.MOVE
              with: {x: 1.0}
          next: S0_WAIT
      S0_WAIT:
        - when: sub.status == DONE
          next: ARRIVED
        - when: sub.status == ERROR
          do: [report: ERROR]
        - after: 3 s
          do: [report: ERROR]
      ARRIVED:
        - do: [report: DONE]
"""


def system(tmp_path: Path, top: str, shared: str | None = None, name: str = "tiny") -> Path:
    directory = tmp_path / name / "tiny"  # the generated header names the directory
    directory.mkdir(parents=True)
    (directory / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    (directory / "sub.yaml").write_text(SUB, encoding="utf-8")
    (directory / "top.yaml").write_text(top, encoding="utf-8")
    if shared is not None:
        (directory / "fragments.yaml").write_text(shared, encoding="utf-8")
    return directory


def with_fragment(uses: str = USES, fragment: str = FRAGMENT) -> str:
    return TOP.format(fragments=f"fragments:\n{fragment}", states=uses)


def diagnostics(directory: Path) -> list[str]:
    out = compile_paths([directory])
    return [f"{d.span.line}:{d.code}:{d.message} | {d.hint}" for d in out.diagnostics]


def generated(directory: Path) -> str:
    out = compile_paths([directory])
    assert not out.diagnostics.errors, [d.render() for d in out.diagnostics]
    return emit.render_all(out.systems)["tiny/top.py"]


def test_a_use_generates_the_hand_written_table(tmp_path: Path) -> None:
    used = generated(system(tmp_path, with_fragment()))
    by_hand = TOP.format(fragments="", states="").replace("    states:\n", BY_HAND)
    written = generated(system(tmp_path, by_hand, name="hand"))
    assert "elif state == S0_WAIT:" in used and "self.ticks >= 6:  # after: 3 s = 6 cycles" in used
    assert used == written


def test_a_shared_fragment_serves_two_commands_with_their_own_values(tmp_path: Path) -> None:
    back = USES.replace("x: 1.0, limit: 3 s", "x: -2.5, limit: 2 cycles")
    top = TOP.format(fragments="", states=USES) + "  BACK:\n    states:\n" + back
    directory = system(tmp_path, top, shared=f"fragments:\n{FRAGMENT}")
    with Harness.build(directory) as h:
        h.command("top", "BACK")
        h.step("top")
        assert h.sent("sub").command == "MOVE" and h.sent("sub").args == {"x": -2.5}
        assert h.status("top").state == "S0_WAIT"
        for _ in range(3):  # no answer: the time-out of this use, 2 cycles
            h.step("top")
        assert h.status("top").status == "ERROR"


def test_an_unknown_fragment_is_named_at_the_use_with_a_suggestion(tmp_path: Path) -> None:
    uses = USES.replace("use: move_and_wait", "use: move_and_wiat")
    found = diagnostics(system(tmp_path, with_fragment(uses)))
    assert found == [
        "28:E265:no fragment `move_and_wiat` is declared | did you mean `move_and_wait`?"
    ]


def test_a_wrong_argument_names_the_use_and_the_definition(tmp_path: Path) -> None:
    uses = USES.replace("limit: 3 s", "limt: 3 s")
    [found] = diagnostics(system(tmp_path, with_fragment(uses)))
    assert found.startswith("28:E266:`limt` is not a parameter of fragment `move_and_wait`")
    assert "declared at " in found and "top.yaml:7:3" in found
    assert found.endswith("did you mean `limit`?")


def test_an_undeclared_placeholder_is_named_in_the_fragment(tmp_path: Path) -> None:
    fragment = FRAGMENT.replace("with: {x: $x}", "with: {x: $y}")
    found = diagnostics(system(tmp_path, with_fragment(fragment=fragment)))
    assert found == [
        "15:E267:`$y` is not a parameter of fragment `move_and_wait` | "
        "declared parameters: `limit`, `then`, `x`"
    ]


def test_a_later_stage_s_finding_in_a_fragment_names_its_uses(tmp_path: Path) -> None:
    fragment = FRAGMENT.replace("send: sub.MOVE", "send: sub.MOVEE")
    uses = USES + "  BACK:\n    states:\n" + USES
    [found] = diagnostics(system(tmp_path, with_fragment(uses, fragment)))
    line, code, rest = found.split(":", 2)
    assert (line, code) == ("14", "E204"), found  # the definition's line
    assert "did you mean `MOVE`?" in rest
    # ... and both places it is used, by file, line and command
    assert re.search(
        r"used at \S*top\.yaml:28:17 \(GO\.S0\), \S*top\.yaml:33:17 \(BACK\.S0\)", rest
    )


def test_a_state_name_the_command_has_is_refused(tmp_path: Path) -> None:
    uses = USES + "      S0_WAIT:\n        - do: [report: DONE]\n"
    found = diagnostics(system(tmp_path, with_fragment(uses)))
    assert [f.split(":")[:2] for f in found] == [["28", "E268"]]


def test_a_controller_fragment_may_not_hide_a_shared_one(tmp_path: Path) -> None:
    found = diagnostics(system(tmp_path, with_fragment(), shared=f"fragments:\n{FRAGMENT}"))
    assert [f.split(":")[:2] for f in found] == [["7", "E270"]]


# ---------------------------------------------------------------- differential


def factored(files: dict[str, dict]) -> tuple[dict[str, dict], dict[str, dict]]:
    """(files whose GO table is a fragment used in S0 with the first subordinate a
    parameter, the same tables written out as the expansion names them)."""
    used, reference = copy.deepcopy(files), copy.deepcopy(files)
    top = used["top"]
    command = top["commands"]["GO"]
    sub = top["subordinates"][0]
    text = yaml.safe_dump(command["states"], sort_keys=False, width=1000)
    text = re.sub(rf"\b{sub}\.", "${sub}.", text)
    top["fragments"] = {
        "table": {
            "params": ["sub"],
            "first_match": command.pop("first_match"),
            "states": yaml.safe_load(text),
        }
    }
    command["states"] = {"S0": {"use": "table", "with": {"sub": sub}}}
    rename = {
        s: (s if s == "S0" else f"S0_{s}") for s in reference["top"]["commands"]["GO"]["states"]
    }
    go = reference["top"]["commands"]["GO"]
    go["states"] = {
        rename[s]: [
            {**r, "next": rename[r["next"]]} if r.get("next") in rename else r for r in rules
        ]
        for s, rules in go["states"].items()
    }
    go["first_match"] = [rename[s] for s in go["first_match"]]
    return used, reference


def test_fragments_match_the_reference_on_the_tables_written_out(tmp_path_factory) -> None:
    runs = {"examples": 0}

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=DERANDOMIZE,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(data=st.data(), seed=st.integers(0, 2**32))
    def one(data: st.DataObject, seed: int) -> None:
        used, reference = factored(system_files(Draw(data)))
        directory = tmp_path_factory.mktemp("frag") / "diff"
        write_system(directory, used)
        with Harness.build(directory) as h:
            drive(h, reference, random.Random(seed))
        runs["examples"] += 1

    one()
    assert runs["examples"] >= EXAMPLES


def test_a_fragment_no_command_uses_is_a_warning(tmp_path: Path) -> None:
    states = "      S0:\n        - do: [report: DONE]\n"
    found = diagnostics(system(tmp_path, with_fragment(states)))
    assert found == [
        "7:W305:fragment `move_and_wait` is declared but no command uses it | "
        "use it in a state (`{use: NAME, with: {...}}`) or remove it"
    ]
    shared = diagnostics(
        system(tmp_path, TOP.format(fragments="", states=states), f"fragments:\n{FRAGMENT}", "b")
    )
    assert [f.split(":")[:2] for f in shared] == [["2", "W305"]]


# ---------------------------------------------------------------- fragments within fragments

TWICE = """\
  twice:
    doc: Move the subordinate to $x1, then to $x2, each at most 3 s.
    params: [x1, x2, then]
    states:
      FIRST: {use: move_and_wait, with: {x: $x1, limit: 3 s, then: SECOND}}
      SECOND: {use: move_and_wait, with: {x: $x2, limit: 3 s, then: $then}}
"""

# `twice` written out: each inner use is named after the state of `twice` that holds it, and
# a value naming one of twice's states (SECOND) means that state as expanded (S0_SECOND).
TWICE_BY_HAND = """\
    first_match: [S0_WAIT, S0_SECOND_WAIT]
    states:
      S0:
        - do:
            - send: sub.MOVE
              with: {x: 1.0}
          next: S0_WAIT
      S0_WAIT:
        - when: sub.status == DONE
          next: S0_SECOND
        - when: sub.status == ERROR
          do: [report: ERROR]
        - after: 3 s
          do: [report: ERROR]
      S0_SECOND:
        - do:
            - send: sub.MOVE
              with: {x: 2.0}
          next: S0_SECOND_WAIT
      S0_SECOND_WAIT:
        - when: sub.status == DONE
          next: ARRIVED
        - when: sub.status == ERROR
          do: [report: ERROR]
        - after: 3 s
          do: [report: ERROR]
      ARRIVED:
        - do: [report: DONE]
"""

TWICE_USE = """\
      S0: {use: twice, with: {x1: 1.0, x2: 2.0, then: ARRIVED}}
      ARRIVED:
        - do: [report: DONE]
"""


def test_a_fragment_using_a_fragment_generates_the_hand_written_table(tmp_path: Path) -> None:
    """`twice` uses `move_and_wait` twice; only `twice` is used by a command, and neither
    is reported unused (W305)."""
    directory = system(tmp_path, with_fragment(TWICE_USE, FRAGMENT + TWICE))
    assert diagnostics(directory) == []
    by_hand = TOP.format(fragments="", states="").replace("    states:\n", TWICE_BY_HAND)
    assert generated(directory) == generated(system(tmp_path, by_hand, name="hand"))


def test_fragments_that_use_each_other_are_refused_where_the_cycle_closes(tmp_path: Path) -> None:
    again = "      AGAIN: {use: twice, with: {x1: $x, x2: $x, then: WAIT}}\n"
    looped = FRAGMENT.replace("      WAIT:\n", again + "      WAIT:\n")
    found = diagnostics(system(tmp_path, with_fragment(TWICE_USE, looped + TWICE)))
    assert any(
        ":E298:fragment `twice` is used within itself (twice -> move_and_wait -> twice)" in d
        for d in found
    ), found
    line = int(next(d for d in found if ":E298:" in d).split(":")[0])
    top = with_fragment(TWICE_USE, looped + TWICE).splitlines()
    assert "AGAIN: {use: twice" in top[line - 1]  # at the use that closes the cycle


# ---------------------------------------------------------------- lists of actions

CASES = Path(__file__).resolve().parent / "cases" / "valid"


def _fx_trace(system: Path) -> list[dict]:
    import json

    from rcsgen.tools.scenario import load_scenario, run

    scenario = load_scenario(system / "scenarios" / "go.yaml")
    with Harness.build(system, send_init=True) as harness:
        result = run(scenario, harness)
    return [json.loads(line)["modules"]["fx"] for line in result.trace]


def test_a_fragment_that_takes_lists_of_actions_runs_as_the_table_written_out():
    """tests/cases/valid/fragment-actions writes the operator-results desk's CHECK through a
    fragment whose `on_rework` is spliced into a `do:` list and `on_keep` is a whole `do:`:
    cycle for cycle it runs as the hand-written table, but for its states' names."""
    written = _fx_trace(CASES / "operator-results")
    factored = _fx_trace(CASES / "fragment-actions")
    renamed = {"S0_WAIT": "S1"}
    for row in factored:
        row["state"] = renamed.get(row["state"], row["state"])
        row["rule"] = row["rule"] and row["rule"].replace("S0_WAIT", "S1")
    assert factored == written and written[-1]["status"] == "DONE"
    assert written[-1]["result"] == {"gap": 1.5, "reworked": True}


def test_an_action_given_in_a_list_is_checked_where_it_is_written(tmp_path):
    """A malformed action inside a list of actions is reported at the use, where it is
    written, not at the fragment that splices it."""
    system = tmp_path / "desk"
    system.mkdir()
    source = CASES / "fragment-actions"
    for name in ("system.yaml", "op.yaml"):
        (system / name).write_text((source / name).read_text())
    text = (source / "fx.yaml").read_text()
    bad = text.replace("on_rework: [{set: {result.reworked: true}}]", "on_rework: [{sett: 1}]")
    assert bad != text
    (system / "fx.yaml").write_text(bad)
    diags = compile_paths([system]).diagnostics
    line = bad.splitlines().index(next(x for x in bad.splitlines() if "sett" in x)) + 1
    assert [(d.code, d.span.line) for d in diags.errors] == [("S006", line)]
