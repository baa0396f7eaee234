"""`rcsgen prove` word for word on small systems made for one finding each (W702 a command
that goes round for ever, W706 motion after HALT, W707 a stale DONE believed (after a wait
left, beside a new DONE), W708 going on before the echo, W704 a subordinate run before its
supervisor (the second of two too) or never sent HALT, W701 an ERROR reported without
withdrawing another subordinate, W303 prove's acknowledgements that match nothing) and for
the runtime's reaction to a lost process (halt_all and `on_lost: continue`): the findings
located at their rules, the summary (states, execution order, HALT and ERROR bounds, the
world conditions a command finishes under) and each counter-example cycle by cycle. The
model alone decides (--no-replay): a second each. test_prove.py reads the same systems through
the API and replays them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main

TINY_SYSTEM = """system: tiny
title: Tiny system
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  drive: {type: float, initial: 0.0, actuator: true}
processes:
  p:
    modules: [top, sub]
"""
TINY_SUB = """controller: sub
title: Sub
world:
  reads: [pos]
  writes: [drive]
commands:
  MOVE:
    states:
      S0:
        - do: [{set: {world.drive: 1.0}}]
          next: S1
      S1:
        - when: world.pos > 1.0
          do: [{set: {world.drive: 0.0}}, {report: DONE}]
  HALT:
    states:
      S0:
        - do: [{set: {world.drive: 0.0}}, {report: DONE}]
"""
LATCH_SYSTEM = """system: latch
title: A supervisor that drives a lamp over a subordinate in another process
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  drive: {type: float, initial: 0.0, actuator: true}
  lamp: {type: bool, initial: false, actuator: true}
processes:
  a:
    modules: [top]
  b:
    modules: [sub]
"""
LATCH_TOP = """controller: top
title: Top
subordinates: [sub]
world:
  writes: [lamp]
commands:
  GO:
    states:
      S0:
        - do: [{set: {world.lamp: true}}, send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [{set: {world.lamp: false}}, report: DONE]
        - when: sub.status == ERROR
          do: [{set: {world.lamp: false}}, report: ERROR]
  HALT:
    states:
      S0:
        - do: [{set: {world.lamp: false}}, send: sub.HALT]
          next: S1
      S1:
        - when: sub.status == DONE or sub.status == ERROR
          do: [report: DONE]
"""
GOES_ROUND = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          next: S2
        - when: sub.status == ERROR
          do: [report: ERROR]
      S2:
        - do: [send: sub.MOVE]
          next: S3
      S3:
        - when: sub.status == DONE
          next: S2
"""
MOTION_AFTER_HALT = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [report: DONE]
  HALT:
    states:
      S0:
        - do: [send: sub.HALT]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [send: sub.MOVE, report: DONE]
"""
STALE_DONE = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          next: S2
        - when: sub.status == ERROR
          do: [report: ERROR]
      S2:
        - when: sub.status == DONE
          do: [report: DONE]
        - when: sub.status == ERROR
          do: [report: ERROR]
"""
# as STALE_DONE, but S2 goes on to another state on the stale DONE rather than reporting
STALE_DONE_NEXT = (
    STALE_DONE.replace(
        "      S2:\n        - when: sub.status == DONE\n          do: [report: DONE]\n",
        "      S2:\n        - when: sub.status == DONE\n          next: S3\n",
    )
    + "      S3:\n        - do: [report: DONE]\n"
)
NO_ECHO = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status != ERROR
          next: S2
        - when: sub.status == ERROR
          do: [report: ERROR]
      S2:
        - when: sub.status == DONE
          do: [report: DONE]
        - when: sub.status == ERROR
          do: [report: ERROR]
"""
WAITS = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [report: DONE]
        - when: sub.status == ERROR
          do: [report: ERROR]
"""
# S1 is left on a world condition while MOVE runs: the DONE that S2 then reads answers the
# wait S1 abandoned (model._leave), not anything S2 waits for: W707
LEFT_WAIT = (
    WAITS.replace("    states:", "    first_match: [S1]\n    states:").replace(
        "ERROR]\n", "ERROR]\n        - when: world.pos < -1.0\n          next: S2\n"
    )
    + "      S2:\n"
    + WAITS.split("      S1:\n")[1]  # S1's rules again
)
# top runs sub and sub2 together; when one fails, it reports ERROR without halting the
# other: at once (S1/1) and two states later (S1/3, S2, S3): W701 "not withdrawn", both rules
FAILING_SUB = TINY_SUB.replace(
    "          do: [{set: {world.drive: 0.0}}, {report: DONE}]\n",
    "          do: [{set: {world.drive: 0.0}}, {report: DONE}]\n"
    "        - when: world.pos < -1.0\n"
    "          do: [{set: {world.drive: 0.0}}, {report: ERROR}]\n",
)
PAIR_SYSTEM = TINY_SYSTEM.replace("modules: [top, sub]", "modules: [top, sub, sub2]")
NOT_WITHDRAWN = """controller: top
title: Top
subordinates: [sub, sub2]
commands:
  GO:
    first_match: [S1]
    states:
      S0:
        - do: [send: sub.MOVE, send: sub2.MOVE]
          next: S1
      S1:
        - when: sub.status == ERROR
          do: [report: ERROR]
        - when: sub.status == DONE and sub2.status == DONE
          do: [report: DONE]
        - when: sub2.status == ERROR
          next: S2
      S2:
        - next: S3
      S3:
        - do: [report: ERROR]
"""
# S2 reads sub's DONE again beside sub2's new one: stale, but the answer to HALT, which only
# says sub is stopped (no W707); were it MOVE's, a new motion would have been meant (W707)
STALE_BESIDE_NEW = """controller: top
title: Top
subordinates: [sub, sub2]
commands:
  GO:
    states:
      S0:
        - do: [send: sub.HALT, send: sub2.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          next: S2
      S2:
        - when: sub.status == DONE and sub2.status == DONE
          do: [report: DONE]
"""

# top -> mid -> sub: mid's GO may report ERROR on a world condition while sub's MOVE still
# runs (a loose ERROR: its contract); top reads it and reports ERROR without withdrawing mid:
# W701 at top. mid's TRY reports ERROR only on sub's own, sub stopped: top's TRY is fine
LOOSE_SYSTEM = TINY_SYSTEM.replace("modules: [top, sub]", "modules: [top, mid, sub]")
LOOSE_MID = """controller: mid
title: Mid
subordinates: [sub]
world:
  reads: [pos]
commands:
  GO:
    first_match: [S1]
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [report: DONE]
        - when: sub.status == ERROR or world.pos < -2.0
          do: [report: ERROR]
"""
LOOSE_MID += WAITS.replace("GO:", "TRY:")
LOOSE_TOP = """controller: top
title: Top
subordinates: [mid]
commands:
"""
LOOSE_TOP += "".join(
    WAITS.replace("GO:", f"{c}:").replace("sub.", "mid.").replace("mid.MOVE", f"mid.{c}")
    for c in ("GO", "TRY")
)


def _two_subs(processes: str) -> tuple[str, ...]:
    """top over sub and sub2 (an actuator each), its processes as `processes` says."""
    system = TINY_SYSTEM.replace("  p:\n    modules: [top, sub]", processes).replace(
        "processes:", "  drive2: {type: float, initial: 0.0, actuator: true}\nprocesses:"
    )
    sub2 = TINY_SUB.replace("controller: sub", "controller: sub2").replace("drive", "drive2")
    return system, TINY_SUB, TOP.replace("[sub]", "[sub, sub2]") + WAITS, sub2


TOP = "controller: top\ntitle: Top\nsubordinates: [sub]\ncommands:\n"
CONTINUE = ("subordinates: [sub]\n", "subordinates: [sub]\non_lost:\n  sub: continue\n")
# LATCH_TOP's HALT without the lamp: HALT sub, wait for it
HALTS = "  HALT:" + LATCH_TOP.split("  HALT:")[1].replace("{set: {world.lamp: false}}, ", "")
READS_POS = "world:\n  reads: [pos]\ncommands:"
SWAPPED = ("modules: [top, sub]", "modules: [sub, top]")
# top's own properties (W709): an invariant with safe(), same-cycle and later responses over
# writes(), sent(), states, commands and statuses; one does not hold
PROPERTIES = """\
properties:
  - name: lamp_off_when_done
    doc: The lamp is off whenever top is done.
    always: top.status != DONE or safe(world.lamp)
  - name: lamp_and_move_together
    doc: GO lights the lamp in the cycle it sends sub MOVE.
    whenever: writes(world.lamp) and top.command == GO and top.state == S1
    then: sent(sub.MOVE)
  - name: done_follows_the_move
    doc: sub's DONE to MOVE is passed up within two cycles.
    whenever: sub.status == DONE and sub.command == MOVE
    within: 2
    then: top.status == DONE
  - name: never_an_error
    doc: top never reports ERROR.
    always: not (top.status == ERROR)
commands:
"""
# case -> (system.yaml, then the controllers' files: sub.yaml, top.yaml[, sub2.yaml or mid.yaml])
CASES = {
    "goes_round": (TINY_SYSTEM, TINY_SUB, TOP + GOES_ROUND),
    "motion_after_halt": (TINY_SYSTEM, TINY_SUB, TOP + MOTION_AFTER_HALT),
    "stale_done": (TINY_SYSTEM, TINY_SUB, TOP + STALE_DONE),
    "stale_done_next": (TINY_SYSTEM, TINY_SUB, TOP + STALE_DONE_NEXT),
    # stale_done on the second of two subordinates, the first never commanded: W707 still
    "stale_done_second_sub": (
        PAIR_SYSTEM,
        TINY_SUB,
        TOP.replace("[sub]", "[sub, sub2]") + STALE_DONE.replace("sub.", "sub2."),
        TINY_SUB.replace("controller: sub", "controller: sub2"),
    ),
    "no_echo": (TINY_SYSTEM, TINY_SUB, TOP + NO_ECHO),
    "left_wait": (TINY_SYSTEM, TINY_SUB, TOP.replace("commands:", READS_POS) + LEFT_WAIT),
    "sub_before_top": (TINY_SYSTEM.replace(*SWAPPED), TINY_SUB, TOP + WAITS),
    # top declares its HALT: W704 is located there (not at the file's start)
    "sub_before_top_halt": (TINY_SYSTEM.replace(*SWAPPED), TINY_SUB, TOP + WAITS + HALTS),
    "lost_halt_all": (LATCH_SYSTEM, TINY_SUB, LATCH_TOP),
    "lost_continue": (LATCH_SYSTEM, TINY_SUB, LATCH_TOP.replace(*CONTINUE)),
    # GO goes on on sub's DONE only when MOVE is what it sent last: read from the model
    "reads_sub_command": (
        TINY_SYSTEM,
        TINY_SUB,
        TOP + WAITS.replace("sub.status == DONE", "sub.status == DONE and sub.command == MOVE"),
    ),
    "properties": (LATCH_SYSTEM, TINY_SUB, LATCH_TOP.replace("commands:\n", PROPERTIES, 1)),
    "stale_beside_new": (
        PAIR_SYSTEM,
        TINY_SUB,
        STALE_BESIDE_NEW,
        TINY_SUB.replace("controller: sub", "controller: sub2"),
    ),
    "stale_motion_beside_new": (
        PAIR_SYSTEM,
        TINY_SUB,
        STALE_BESIDE_NEW.replace("send: sub.HALT", "send: sub.MOVE"),
        TINY_SUB.replace("controller: sub", "controller: sub2"),
    ),
    # GO acknowledges every finding of prove's, none of which it has: W303 says for each
    # where its code is acknowledged (codes.Code.about)
    "unused_allows": (
        TINY_SYSTEM,
        TINY_SUB,
        TOP
        + WAITS.replace(
            "    states:",
            "    allow:\n"
            + "".join(f"      - {{code: W70{n}, reason: none yet}}\n" for n in range(1, 10))
            + "    states:",
        ),
    ),
    "loose_error": (LOOSE_SYSTEM, FAILING_SUB, LOOSE_TOP, LOOSE_MID),
    "not_withdrawn": (
        PAIR_SYSTEM,
        FAILING_SUB,
        NOT_WITHDRAWN,
        FAILING_SUB.replace("controller: sub", "controller: sub2"),
    ),
    # top's HALT reports DONE without sending sub HALT: W704 at top's HALT
    "halt_forgets_sub": (
        TINY_SYSTEM,
        TINY_SUB,
        TOP + WAITS + "  HALT:\n    states:\n      S0:\n        - do: [report: DONE]\n",
    ),
    # top's first subordinate runs in another process, its second before it in top's own:
    # W704 for the second
    "second_sub_before_top": _two_subs("  a:\n    modules: [sub]\n  p:\n    modules: [sub2, top]"),
    # top's first subordinate runs after it in its process, its second before it: W704 for
    # the second
    "first_sub_after_top": _two_subs("  p:\n    modules: [sub2, top, sub]"),
}
EXPECTED = Path(__file__).parent / "cases" / "prove_catalogue"


def proven(case: str) -> str:
    """What `rcsgen prove --no-replay` prints in the current directory, with the case's
    specs written there, and its exit code; the solver's times masked."""
    for text in CASES[case]:  # system.yaml, then each controller's file by its mnemonic
        kind, name = text.split("\n", 1)[0].split(": ")
        Path(f"{'system' if kind == 'system' else name}.yaml").write_text(text)
    result = CliRunner().invoke(main, ["prove", ".", "--no-replay"])
    return f"exit {result.exit_code}\n" + re.sub(r" +\d+ ms \(\d+ ms CPU\)", " T", result.output)


@pytest.mark.parametrize("case", sorted(CASES))
def test_prove_says_each_finding_where_and_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, case: str
) -> None:
    monkeypatch.chdir(tmp_path)
    assert proven(case) == (EXPECTED / f"{case}.txt").read_text()


def test_a_state_left_on_an_interrupt_marks_the_wait_on_a_subordinate_still_executing_left(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """left_wait's model (model._leave): GO leaves S1 on world.pos while sub runs the MOVE
    S1 waits on, and that wait is marked LEFT in S2 (its DONE will answer the abandoned
    wait, W707)."""
    from rcsgen.compiler.frontend import compile_paths
    from rcsgen.compiler.prove.adapter import EXECUTING, skeleton
    from rcsgen.compiler.prove.lost import RuntimeReaction
    from rcsgen.compiler.prove.model import LEFT, Contract, Model, explore

    monkeypatch.chdir(tmp_path)
    for text in CASES["left_wait"]:
        kind, name = text.split("\n", 1)[0].split(": ")
        Path(f"{'system' if kind == 'system' else name}.yaml").write_text(text)
    (system,) = compile_paths([tmp_path]).systems
    top = next(c for c in system.controllers if c.name == "top")
    sk = skeleton(system, top, frozenset())
    graph = explore(Model(sk, {"sub": Contract({})}, RuntimeReaction(system)))
    left = {
        (s.subs[0][1], t.subs[0])
        for s, edges in graph.edges.items()
        for e, t in edges
        if s.state == "S1" and t.state == "S2" and e.new is None
    }
    assert left == {(EXECUTING, ("MOVE", EXECUTING, LEFT))}
