"""`rcsgen prove`: the engineer's own properties (`properties:`, docs/spec.md section 19).

A violated property yields its counter-example, written as a scenario that `rcsgen run`
replays to the violation; one that holds yields nothing; the monitor behind `safe(...)`
follows what the supervisor set; the paper's properties shipped with helm and cr catch the
seeds prove used to miss. The bad inputs (E710-E714) have a corpus case each
(tests/cases/invalid/e71*).
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import prove_front
from rcsgen.compiler.prove.system import prove
from rcsgen.tools.scenario import read_trace

SPECS = Path(__file__).resolve().parents[1] / "specs"

SYSTEM = """system: tiny
title: Tiny system
cycle_period: 0.1

world:
  valve:
    type: bool
    initial: false
    actuator: true

processes:
  p:
    modules: [top, sub]
"""
SUB = """controller: sub
title: Sub controller

commands:
  MOVE:
    states:
      S0:
        - next: S1
      S1:
        - do:
            - report: DONE
"""
TOP = """controller: top
title: Top controller
subordinates: [sub]

world:
  writes: [valve]

commands:
  INIT:
    states:
      S0:
        - do:
            - send: sub.INIT
            - set: {world.valve: false}
          next: S1
      S1:
        - when: sub.status == DONE or sub.status == ERROR
          do:
            - report: DONE
  HALT:
    states:
      S0:
        - do:
            - send: sub.HALT
            - set: {world.valve: false}
          next: S1
      S1:
        - when: sub.status == DONE or sub.status == ERROR
          do:
            - report: DONE
  GO:
    states:
      S0:
        - do:
            - send: sub.MOVE
            - set: {world.valve: true}
          next: S1
      S1:
        - when: sub.status == DONE
          do:
            - set: {world.valve: false}
            - report: DONE
        - when: sub.status == ERROR
          do:
            - set: {world.valve: false}
            - report: ERROR
"""


def _system(tmp_path: Path, properties: str, top: str = TOP) -> Path:
    directory = tmp_path / "tiny"
    directory.mkdir()
    (directory / "system.yaml").write_text(SYSTEM)
    (directory / "sub.yaml").write_text(SUB)
    (directory / "top.yaml").write_text(top + "\nproperties:\n" + properties)
    return directory


def _findings(directory: Path):
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    proof = prove_front(front).proofs[0]
    return proof, [f for f in proof.findings if f.code == "W709"]


def test_a_violated_response_is_a_counter_example_that_rcsgen_run_replays(tmp_path):
    """sub takes two cycles to finish MOVE and may take any number more: `within: 1`
    cannot be promised. The shortest run is printed and written, and `rcsgen run` follows
    it to the cycle the response was due."""
    directory = _system(
        tmp_path,
        """  - name: quick
    doc: top is done at most one cycle after it sends MOVE (it is not).
    whenever: sent(sub.MOVE)
    within: 1
    then: top.status == DONE
""",
    )
    runner = CliRunner()
    proved = runner.invoke(main, ["prove", str(directory), "--format", "json"])
    assert proved.exit_code == 1, proved.output
    found = [d for d in json.loads(proved.stdout) if d["code"] == "W709"]
    assert len(found) == 1, proved.stdout
    assert "property `quick` is violated" in found[0]["message"]
    assert "held in cycle 1" in found[0]["message"] and "by cycle 2" in found[0]["message"]
    assert found[0]["file"].endswith("top.yaml")
    scenario = next((directory / "counterexamples").glob("top_w709_*.yaml"))
    trace = tmp_path / "t.jsonl"
    ran = runner.invoke(main, ["run", str(scenario), "--trace", str(trace)])
    assert ran.exit_code == 0, ran.output
    cycles = [json.loads(line) for line in read_trace(trace)]
    top = [c for c in cycles if "top" in json.dumps(c)]
    assert len(top) >= 2
    assert '"status": "EXECUTING"' in json.dumps(top[-1]).split('"top"')[1][:400]


def test_a_property_that_holds_yields_no_finding_and_is_reported_held(tmp_path):
    """(Without its own INIT table, top's default INIT reports DONE with the valve GO
    opened: the first property found that.)"""
    directory = _system(
        tmp_path,
        """  - name: valve_closed_when_done
    doc: Whenever top reports, its valve is closed.
    always: top.status != DONE or safe(world.valve)
  - name: move_follows_go
    whenever: top.command == GO and top.state == S1
    then: sub.command == MOVE
""",
    )
    proof, found = _findings(directory)
    assert found == []
    assert [(p.name, holds) for p, holds in proof.properties] == [
        ("valve_closed_when_done", True),
        ("move_follows_go", True),
    ]


def test_safe_follows_what_the_supervisor_set(tmp_path):
    """The same invariant over a table that reports DONE with the valve left open: the
    monitor carries the value set two cycles before to the report."""
    top = TOP.replace(
        """        - when: sub.status == DONE
          do:
            - set: {world.valve: false}
            - report: DONE""",
        """        - when: sub.status == DONE
          do:
            - report: DONE""",
    )
    directory = _system(
        tmp_path,
        """  - name: valve_closed_when_done
    always: top.status != DONE or safe(world.valve)
""",
        top,
    )
    proof, found = _findings(directory)
    assert len(found) == 1
    f = found[0]
    assert (f.command, f.state, f.rule) == ("GO", "S1", 1)  # at the rule that reports
    assert f.trace[0][0].new == "GO" and f.trace[-1][0].report == "DONE"
    assert [(p.name, holds) for p, holds in proof.properties] == [("valve_closed_when_done", False)]


def test_a_new_command_from_above_ends_an_open_obligation(tmp_path):
    """`whenever ... within` counts the supervisor's own cycles: a new command from above
    is a new decision, so a response interrupted by one is not owed (here every run that
    does not answer within 3 cycles is one where sub is still moving: still violated)."""
    directory = _system(
        tmp_path,
        """  - name: answered
    whenever: sent(sub.MOVE)
    within: 3
    then: top.status != EXECUTING
""",
    )
    _, found = _findings(directory)
    assert len(found) == 1
    trace = found[0].trace
    assert len(trace) == 4  # the cycle MOVE is sent and three more
    assert all(edge.new is None for edge, _ in trace[1:])


# The seeds prove_seeds plants that the handshake properties let through: (file, the rule
# as prove_seeds names it, the occurrence of the send it leaves out)
SEND = re.compile(r"\n +- send: (rudder\.GOTO_ANGLE|ct\.POSITION_TAIL)\n( +with: .*\n)?")
SEEDS = {
    "submarine": [
        ("helm.yaml", f"helm ICE_MANEUVER/{r}", n)
        for n, r in enumerate(["S1/1", "S1/2", "S1/3", "S2/3"])
    ],
    "miner": [("cr.yaml", "cr SUMP/S0/1", 0)],
}


@pytest.mark.parametrize("system", sorted(SEEDS))
def test_the_papers_properties_catch_the_seeds_handshake_properties_missed(tmp_path, system):
    """helm's steering orders and cr's tail request, each `send:` left out in turn: the
    property its file states (W709) is broken at that rule, which the unchanged system's
    is not."""
    clean = [f for f in _findings_of(SPECS / system) if f.code == "W709"]
    assert clean == []
    for file, rule, n in SEEDS[system]:
        directory = tmp_path / f"{system}{n}"
        shutil.copytree(SPECS / system, directory, ignore=shutil.ignore_patterns("scenarios"))
        text = (directory / file).read_text()
        found = list(SEND.finditer(text))[n]
        (directory / file).write_text(text[: found.start()] + "\n" + text[found.end() :])
        findings = [f for f in _findings_of(directory, file[:-5]) if f.code == "W709"]
        command, at = rule.split()[1].split("/", 1)
        assert [(f.command, f"{f.state}/{f.rule}") for f in findings] == [(command, at)], rule


def _findings_of(directory: Path, only: str | None = None):
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    name = only or ("helm" if directory.name.startswith("submarine") else "cr")
    return prove(front.systems[0], only=name).findings


TIMED = TOP.replace(
    """      S1:
        - when: sub.status == DONE
          do:
            - set: {world.valve: false}
            - report: DONE""",
    """      S1:
        - doc: the valve opened too long ago; count it
          when: sub.status == EXECUTING
          for: 3 cycles
          do:
            - set: {n: 1}
        - when: sub.status == DONE
          do:
            - set: {world.valve: false}
            - report: DONE""",
).replace("commands:\n", "locals:\n  n:\n    type: int\n    initial: 0\n\ncommands:\n", 1)
NEVER_COUNTED = """  - name: never_counted
    always: not writes(n)
"""


def test_a_run_that_fires_a_for_rule_too_early_is_undecided_by_z3(tmp_path):
    """The model lets a `for: 3 cycles` rule fire in the first cycle of its state (its
    counter is free there): z3 finds that run impossible, so the finding is undecided with
    why, never violated - before any replay."""
    pytest.importorskip("z3")
    proof, found = _findings(_system(tmp_path, NEVER_COUNTED, TIMED))
    assert len(found) == 1
    f = found[0]
    assert len(f.trace) < 5  # the shortest run: too short for the counter to pass 3
    assert f.verdict == "undecided" and not f.certain
    assert "impossible under its hold times (z3)" in f.replay
    assert "GO/S1/1 (for: 3 cycles)" in f.replay
    assert not any("z3" in n for n in proof.notes)


def test_without_z3_the_hold_times_are_not_checked_and_prove_says_so(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "z3", None)  # `import z3` raises ImportError
    proof, found = _findings(_system(tmp_path, NEVER_COUNTED, TIMED))
    assert len(found) == 1 and found[0].replay == ""  # left to the replay
    assert any("need z3: install rcsgen[prove]" in n for n in proof.notes), proof.notes


def test_the_hold_time_is_counted_as_the_generated_code_counts_it(tmp_path):
    """`for: 3 cycles` fires once its `when` held more than 3 cycles in a row: the same run
    with waiting cycles in S1 put before the firing is possible with 3 of them (S1 runs 4
    cycles) and impossible with 1 (2 cycles)."""
    pytest.importorskip("z3")
    from rcsgen.compiler.prove import timers

    proof, found = _findings(_system(tmp_path, NEVER_COUNTED, TIMED))
    graph = proof.graphs["top"]
    trace = found[0].trace
    wait = next(
        (e, t)
        for edges in graph.edges.values()
        for e, t in edges
        if t.command == "GO" and t.state == "S1" and not e.rules and e.new is None
    )
    assert trace[-1][0].rules == ("GO/S1/1",) and trace[-2][1].state == "S1"
    longer = [*trace[:-1], wait, wait, wait, trace[-1]]
    assert timers.feasible(graph.skeleton, longer) == (True, "")
    shorter = [*trace[:-1], wait, trace[-1]]
    assert timers.feasible(graph.skeleton, shorter)[0] is False


def test_a_property_too_large_to_decide_is_undecided_never_held(tmp_path):
    """The monitor multiplies the model's states (a response due within 50 cycles keeps up
    to 50 more per state): past the limit the property is undecided, with a note."""
    directory = _system(
        tmp_path,
        """  - name: slow
    whenever: sent(sub.MOVE)
    within: 50
    then: top.status == DONE
""",
    )
    front = compile_paths([directory])
    full = prove(front.systems[0])
    states = sum(r.states for r in full.controllers.values())
    small = prove(front.systems[0], limit=states + 5)
    assert [(p.name, held) for p, held in small.properties] == [("slow", None)]
    assert any("property slow: more than" in n for n in small.notes)
    assert [(p.name, held) for p, held in full.properties] == [("slow", False)]


def test_export_smv_writes_the_explored_model_and_the_properties(tmp_path):
    """`--export smv`: one module per controller; its transition relation is the explored
    model's (every cycle leads to the cycles leaving its target), each atom holds in the
    cycles that make it true, and the spec's own property is an LTLSPEC with prove's
    meaning (here: started by sending MOVE, due by the next cycle unless a new command)."""
    directory = _system(
        tmp_path,
        """  - name: quick
    whenever: sent(sub.MOVE)
    within: 1
    then: top.status == DONE
""",
    )
    out = tmp_path / "smv"
    ran = CliRunner().invoke(
        main, ["prove", str(directory), "--no-replay", "--export", "smv", "--export-dir", str(out)]
    )
    assert ran.exit_code == 0, ran.output  # not replayed: undecided
    text = (out / "tiny" / "top.smv").read_text()
    assert sorted(p.name for p in (out / "tiny").iterdir()) == ["sub.smv", "top.smv"]
    proof, _ = _findings(directory)
    graph = proof.graphs["top"]
    cycles = [c for s in graph.edges for c in graph.edges[s]]
    assert f"  c : 0..{len(cycles)};" in text
    nexts = {}
    for line in text.splitlines():
        if match := re.fullmatch(r"    c (?:=|in) \{?([\d, ]+)\}? : \{([\d, ]+)\};", line):
            for source in map(int, match.group(1).split(", ")):
                nexts[source] = {int(x) for x in match.group(2).split(", ")}
    number = {id(c): i for i, c in enumerate(cycles, start=1)}  # equal cycles leave apart
    for i, (_, target) in enumerate(cycles, start=1):
        assert nexts[i] == {number[id(c)] for c in graph.edges[target]}
    sent = re.search(r"  sent_sub_MOVE := c in \{([\d, ]+)\};", text)
    assert sent is not None
    assert {int(x) for x in sent.group(1).split(", ")} == {
        i for i, (e, _) in enumerate(cycles, start=1) if ("sub", "MOVE") in e.sends
    }
    assert (
        "LTLSPEC NAME quick := G ((c != 0 & !runtime & sent_sub_MOVE) -> "
        "(status_DONE | X (runtime | new_command | status_DONE)));" in text
    )


def test_a_template_property_names_the_instance_that_states_it():
    """loco's properties, written in the vehicle template as `loco.status ...`, read for
    alpha's locomotion as `alpha_loco.status ...`: a report names the controller that broke
    it, not the template (its subordinates were already the instance's)."""
    front = compile_paths([SPECS / "platoon"])
    assert not front.diagnostics.errors
    texts = {
        (p.name, p.controller): p.text
        for system in front.systems
        for p in system.properties
        if p.name == "giving_up_closes_the_throttle"
    }
    assert set(texts) == {
        ("giving_up_closes_the_throttle", "alpha_loco"),
        ("giving_up_closes_the_throttle", "bravo_loco"),
    }
    for (_, instance), text in texts.items():
        vehicle = instance.removesuffix("_loco")
        assert text == (
            f"always {instance}.status != ERROR or {vehicle}_drive.command != SPEED "
            f"or {vehicle}_drive.status == ERROR"
        ), text
