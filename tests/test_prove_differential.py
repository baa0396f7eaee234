"""Differential test of `rcsgen prove`: on small random systems, every finding it calls
"violated" is a real violation of its property in the generated code.

The replay (rcsgen/tools/replay.py) calls a finding violated when the generated code follows
the counter-example cycle by cycle. This test does not trust that comparison: it runs the
counter-example's scenario events again in the generated code, records what the code did
(the supervisor's state and status, what it sent, what was answered) and checks the property
on that record with an oracle of its own, per code; the liveness ones (W702, W703, W705) by
running on, 30 cycles with nothing more answered, and seeing the command never report
(W705: never report ERROR). A code without an oracle here must not be reported violated.
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from pathlib import Path

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import Finding, prove_front
from rcsgen.tools.harness import Harness
from rcsgen.tools.replay import Replayer, events, replay_all
from rcsgen.tools.scenario.run import reply

SYSTEM = """system: rnd
title: A random supervisor over one vehicle
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  drive: {type: float, initial: 0.0, actuator: true}
processes:
  p:
    modules: [top, sub]
"""
SUB = """controller: sub
title: Vehicle
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
        - when: world.pos < -1.0
          do: [{set: {world.drive: 0.0}}, {report: ERROR}]
  HALT:
    states:
      S0:
        - do: [{set: {world.drive: 0.0}}, {report: DONE}]
"""
STATES = ("S1", "S2", "S3")


def _rule(rng: random.Random, here: str) -> str:
    """One rule of a waiting state, right or with a seeded handshake slip."""
    other = rng.choice([s for s in STATES if s != here])
    guard = rng.choice(
        ["sub.status == DONE", "sub.status == ERROR", "sub.status != ERROR", "sub.status == DONE"]
    )
    action = rng.choice(
        [
            "do: [report: DONE]",
            "do: [report: ERROR]",
            f"next: {other}",
            f"do: [send: sub.MOVE]\n          next: {other}",
            "do: [send: sub.MOVE]",
        ]
    )
    return f"        - when: {guard}\n          {action}\n"


def _top(rng: random.Random) -> str:
    rules = {state: [_rule(rng, state) for _ in range(rng.randint(1, 2))] for state in STATES}
    reached, todo = set(), ["S1"]  # only the states a `next:` chain reaches (else E207)
    while todo:
        state = todo.pop()
        if state not in reached:
            reached.add(state)
            todo += [s for r in rules[state] for s in STATES if f"next: {s}" in r]
    text = "controller: top\ntitle: Top\nsubordinates: [sub]\ncommands:\n  GO:\n"
    text += f"    first_match: [{', '.join(sorted(reached))}]\n    states:\n"
    text += "      S0:\n        - do: [send: sub.MOVE]\n          next: S1\n"
    for state in STATES:
        if state in reached:
            text += f"      {state}:\n" + "".join(rules[state])
    return text


@dataclass
class Cycle:
    """What the generated code did in one cycle, and what the scenario did before it."""

    new: bool  # a command from above
    replied: str | None  # the status scripted for sub before the cycle
    state: str
    status: str
    sent: tuple[str, int]  # sub's command buffer after the cycle: (command, number)
    echo: int  # sub's status number after the cycle
    answer: str  # sub's status after the cycle (EXECUTING until answered)


def _record(replayer: Replayer, system, finding: Finding, more: int) -> list[Cycle]:
    found, why = events(system, finding)
    assert not why, why
    harness = Harness(replayer.package, "p", send_init=True)
    out = []
    try:
        pending = list(found)
        for index in range(1, len(finding.trace) + 1 + more):
            new, replied = False, None
            while pending and pending[0]["cycle"] == index:
                event = pending.pop(0)
                for m, mode in event.get("mode", {}).items():
                    harness.set_mode(m, **mode)
                harness.world.update(event.get("set", {}))
                for sub, status in event.get("reply", {}).items():
                    reply(harness, sub, status)
                    replied = status
                if "command" in event:
                    harness.command("top", event["command"].split(".")[1])
                    new = True
            harness.cycle()
            top, sent = harness.status("top"), harness.sent("sub")
            out.append(
                Cycle(
                    new,
                    replied,
                    top.state,
                    top.status,
                    (sent.command, sent.number),
                    harness.status("sub").number,
                    harness.status("sub").status,
                )
            )
    finally:
        harness.close()
    return out


def _oracle(code: str, run: list[Cycle], length: int) -> bool:
    """Whether the recorded run violates the property of `code` (its first `length` cycles
    are the counter-example; the rest ran on with nothing answered)."""
    cex = run[:length]
    if code == "W708":  # reported DONE, or went on, while MOVE was unanswered
        for a, b in zip(cex, cex[1:], strict=False):
            busy = a.sent[0] == "MOVE" and a.answer == "EXECUTING" and b.replied is None
            # not re-commanded, or re-commanded with motion (the next step before the echo)
            same = b.sent == a.sent or b.sent[0] == "MOVE"
            if busy and same and not b.new and (b.status == "DONE" or b.state != a.state):
                return True
        return False
    if code == "W701":  # after sub's ERROR, a new MOVE with no new command from above
        for i, c in enumerate(cex):
            if c.replied != "ERROR" or i == 0:
                continue
            for a, b in zip(cex[i - 1 :], cex[i:], strict=False):  # from the ERROR's cycle
                if b.new:
                    break
                if b.sent != a.sent and b.sent[0] == "MOVE":
                    return True
        return False
    if code == "W707":  # went on on a DONE no reply gave since it last went on
        last_reply, last_on = -1, -1
        for i, (a, b) in enumerate(zip(cex, cex[1:], strict=False), start=1):
            if b.replied == "DONE":
                last_reply = i
            if b.state != a.state or b.status == "DONE" != a.status:
                if a.sent[0] == "MOVE" and last_reply <= last_on and b.replied is None:
                    return True
                last_on = i
        return False
    rest = run[length - 1 :]
    if code in ("W702", "W703"):  # never reports, however long it runs on
        return all(c.status == "EXECUTING" for c in rest) and not any(c.new for c in rest)
    if code == "W705":  # never reports ERROR after the ERROR
        return not any(c.status == "ERROR" for c in rest)
    raise AssertionError(f"no oracle for {code}: it must not be reported violated here")


def test_every_violated_finding_is_a_real_violation_in_the_generated_code(tmp_path: Path):
    rng = random.Random(23)
    checked: dict[str, int] = {}
    for n in range(14):
        directory = tmp_path / f"rnd{n}"
        directory.mkdir()
        (directory / "system.yaml").write_text(SYSTEM)
        (directory / "sub.yaml").write_text(SUB)
        (directory / "top.yaml").write_text(_top(rng))
        front = compile_paths([directory])
        if front.diagnostics.errors:  # a random table the build refuses (E5xx): no proof
            continue
        system = front.systems[0]
        proof = prove_front(front).proofs[0]
        replay_all(proof, system, directory, None)
        replayer = Replayer(system, directory)
        try:
            for f in proof.findings:
                if f.verdict != "violated" or f.controller != "top":
                    continue
                run = _record(replayer, system, f, more=30)
                assert _oracle(f.code, run, len(f.trace)), (n, f.code, f.message, run)
                checked[f.code] = checked.get(f.code, 0) + 1
        finally:
            replayer.close()
    # the random systems exercise the handshake properties, each confirmed at least once
    assert {"W708", "W701"} <= set(checked), checked
    assert sum(checked.values()) >= 10, checked
