"""`rcsgen prove`: a counter-example's numbers asked of z3 (rcsgen/compiler/prove/numbers.py).

The explicit model leaves a local free in each cycle, so its shortest run may read a count
the code cannot have reached yet. z3 follows the local as the code keeps it: that run is
impossible; a longer one that counts up is found instead and replays as violated; when
none exists the finding is undecided with why, never violated; without z3 prove says so
in one line and leaves the run to the replay.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.analysis.tables import Atom
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove.system import prove

SYSTEM = """system: tiny
title: Tiny system
cycle_period: 0.1

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

locals:
  n:
    type: int
    initial: 0
    doc: Cycles counted while sub moves.

commands:
  GO:
    first_match: [S1]
    allow:
      - code: W503
        states: [S1]
        reason: S1 counts while sub moves.
      - code: W506
        states: [S1]
        reason: a test of the numbers, not of errors.
    states:
      S0:
        - do:
            - send: sub.MOVE
            - set: {n: 0}
          next: S1
      S1:
        - doc: gives up waiting for the echo after two cycles (the bug)
          when: n >= 2
          do:
            - report: DONE
        - when: sub.status == EXECUTING
          do:
            - set: {n: n + 1}
"""
COUNTS = "            - set: {n: n + 1}\n"
# GO given how far it may go: DONE early also needs p > 0, which z3 picks for the replay
TOP_FAR = TOP.replace(
    "  GO:\n", "  GO:\n    params:\n      p: {type: int, doc: How far.}\n"
).replace("when: n >= 2\n", "when: n >= 2 and p > 0\n")


def _system(tmp_path: Path, top: str = TOP) -> Path:
    directory = tmp_path / "tiny"
    directory.mkdir()
    (directory / "system.yaml").write_text(SYSTEM)
    (directory / "sub.yaml").write_text(SUB)
    (directory / "top.yaml").write_text(top)
    return directory


def _done_early(directory: Path):
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    proof = prove(front.systems[0])
    found = [f for f in proof.findings if f.code == "W708" and f.rule == 1]
    assert len(found) == 1, [(f.code, f.rule, f.message) for f in proof.findings]
    return proof, found[0]


def test_an_impossible_count_is_replaced_by_a_longer_run_that_counts_up(tmp_path):
    """The model's shortest run reports DONE in the cycle after GO (n free); z3 knows n is
    0 there, and finds the run that counts twice first: four cycles, with a value of GO's
    parameter p that lets DONE come (p > 0), which the generated code follows to the
    violation."""
    pytest.importorskip("z3")
    directory = _system(tmp_path, TOP_FAR)
    proof, f = _done_early(directory)
    rules = [edge.rules for edge, _ in f.trace]
    assert rules == [("GO/S0/1",), ("GO/S1/2",), ("GO/S1/2",), ("GO/S1/1",)], rules
    assert f.verdict == "violated" and f.replay == ""  # left to the replay
    assert proof.notes == []  # z3 decided it: no note that z3 is missing
    assert f.trace[0][0].valuation == (((Atom.PARAM, "p"), 1),)  # one solution's p, for the replay
    out = CliRunner().invoke(main, ["prove", str(directory), "--select", "W708"])
    assert "rule GO/S1/1 of top reports DONE" in out.output
    line = next(x for x in out.output.splitlines() if "rule GO/S1/1 of top reports DONE" in x)
    assert "is violated" in line and "replayed in the generated code, 4 cycles" in line, line


def test_a_count_no_run_reaches_makes_the_finding_undecided_with_why(tmp_path):
    """Without the counting rule n stays 0: no run of any length reports DONE early, so the
    finding is undecided (z3 says why), never violated, and not replayed."""
    pytest.importorskip("z3")
    top = TOP.replace(COUNTS, "            - set: {n: 0}\n")
    _, f = _done_early(_system(tmp_path, top))
    assert f.verdict == "undecided" and not f.certain
    # the shortest run is 2 cycles: others were looked for up to numbers.EXTRA_CYCLES more
    assert f.replay == (
        "impossible with the values its guards read (z3: locals, parameters, world values); "
        "no possible run to that cycle up to 7 cycles"
    )


def test_without_z3_the_numbers_are_not_checked_and_prove_says_so(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "z3", None)  # `import z3` raises ImportError
    proof, f = _done_early(_system(tmp_path))
    assert len(f.trace) == 2 and f.replay == ""  # the model's shortest run, left to the replay
    assert sum("need z3: install rcsgen[prove]" in n for n in proof.notes) == 1, proof.notes


RETRY_SUB = """controller: sub
title: Sub controller

locals:
  ok:
    type: bool
    initial: true
    doc: The clamp closes.

commands:
  CLAMP:
    reasons: [REFUSED, JAMMED]
    states:
      S0:
        - when: ok
          do:
            - report: DONE
        - when: not ok
          do:
            - {report: ERROR, reason: REFUSED}
"""
RETRY_TOP = """controller: top
title: Top controller
subordinates: [sub]

commands:
  GO:
    first_match: [S1]
    states:
      S0:
        - do:
            - send: sub.CLAMP
          next: S1
      S1:
        - doc: a refusal is retried (the bug W701 names)
          when: sub.status == ERROR and sub.reason == REFUSED
          do:
            - send: sub.CLAMP
        - when: sub.status == ERROR
          do:
            - report: ERROR
        - when: sub.status == DONE
          do:
            - report: DONE
"""


def test_a_replay_scripts_the_reason_the_model_chose_for_an_error(tmp_path):
    """The run retries only on REFUSED: its scenario scripts `ERROR(REFUSED)`, so the
    generated code takes the retry and the finding is violated, not undecided. Written
    where --counterexamples says, in a folder per system (test_prove's are in the default
    <system>/counterexamples/); outside the system's folder, so the scenario names its
    system (`system:`, relative to the file) and `rcsgen run` replays it from there."""
    directory = _system(tmp_path, RETRY_TOP)
    (directory / "sub.yaml").write_text(RETRY_SUB)
    chosen = tmp_path / "elsewhere"
    args = ["prove", str(directory), "--select", "W701", "--counterexamples", str(chosen)]
    out = CliRunner().invoke(main, args)
    line = next(x for x in out.output.splitlines() if "warning[W701]" in x)
    assert "is violated" in line and "replayed in the generated code" in line, out.output
    assert not (directory / "counterexamples").exists()
    written = (chosen / "tiny" / "top_w701_go.yaml").read_text()
    assert "sub: ERROR(REFUSED)" in written, written
    relative = os.path.relpath(directory, chosen / "tiny")
    assert f"\nsystem: {relative}\n" in written, written
    # and `rcsgen run` takes the scenario as written: the reason is one sub can give
    ran = CliRunner().invoke(main, ["run", str(chosen / "tiny" / "top_w701_go.yaml")])
    assert "E408" not in ran.output and "Traceback" not in ran.output, ran.output
    assert "run failed: nothing was run" not in ran.output, ran.output
