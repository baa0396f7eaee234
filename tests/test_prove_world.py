"""`rcsgen prove`'s world writers (rcsgen/compiler/prove/world.py): a supervisor that waits on a
world field only its idle subordinates could change is told so (W703), word for word, and
each reason the same wait is *not* a deadlock keeps it quiet: the command sent writes the
field (itself, or through a command it sends further down), a module writes it whatever it
runs (an `every_cycle` rule, a simulator, a hook outside the tables), or a module outside
the supervisor's subtree writes it. A second each: the model alone decides (--no-replay)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import test_prove_catalogue as catalogue
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import prove_front
from rcsgen.compiler.prove.adapter import DONE, ERROR, EXECUTING, NOT_READY, skeleton
from rcsgen.compiler.prove.model import State
from rcsgen.compiler.prove.world import quiet_fields, writers


def edited(text: str, *edits: tuple[str, str]) -> str:
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


# the catalogue's tiny system with a world field `ready`
SYSTEM = edited(
    catalogue.TINY_SYSTEM,
    ("world:\n", "world:\n  ready: {type: bool, initial: false, doc: Set by PREP.}\n"),
)
# the catalogue's tiny sub, which also sets `ready` in PREP
SUB = edited(
    catalogue.TINY_SUB,
    ("  writes: [drive]", "  writes: [drive, ready]"),
    (
        "  HALT:",
        "  PREP:\n    states:\n      S0:\n        - do: [{set: {world.ready: true}}, "
        "{report: DONE}]\n  HALT:",
    ),
)
# GO sends MOVE, which does not write `ready`, then waits for it
TOP = edited(
    catalogue.TOP + catalogue.WAITS,
    ("subordinates: [sub]\n", "subordinates: [sub]\nworld:\n  reads: [ready]\n"),
    ("when: sub.status == DONE\n", "when: sub.status == DONE and world.ready\n"),
)
# a leaf below sub whose PREP sets `ready`; sub's MOVE sends it
LEAF = """\
controller: leaf
title: Leaf
world:
  writes: [ready]
commands:
  PREP:
    states:
      S0:
        - do: [{set: {world.ready: true}}, {report: DONE}]
"""


def write(directory: Path, **files: str) -> Path:
    directory.mkdir(exist_ok=True)
    for name, text in {"system": SYSTEM, "sub": SUB, "top": TOP, **files}.items():
        (directory / f"{name}.yaml").write_text(text)
    return directory


def w703(directory: Path) -> list[str]:
    """The W703 findings of `top`: their state and message."""
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    proof = prove_front(front).proofs[0]
    return [f"{f.state}: {f.message}" for f in proof.findings if f.code == "W703"]


DEADLOCK = (
    "S1: no handshake deadlock is violated: top GO waits in S1 for world.ready, which only its "
    "subordinates write, and none of them is running a command that writes it (sub.status=DONE)"
)


def test_a_wait_on_what_only_an_idle_subordinate_writes_is_w703_word_for_word(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(write(tmp_path / "tiny"))
    result = CliRunner().invoke(main, ["prove", ".", "--no-replay"])
    said = re.sub(r" +\d+ ms \(\d+ ms CPU\)", " T", result.output)
    assert result.exit_code == 0
    start = said.index("top.yaml:12:7: warning[W703]")
    assert said[start:] == (
        "top.yaml:12:7: warning[W703]: no handshake deadlock is undecided: top GO waits in S1 "
        "for world.ready, which only its subordinates write, and none of them is running a "
        "command that writes it (sub.status=DONE) (not replayed)\n"
        "  |       S1:\n"
        "  |       ^\n"
        "  = hint: send the command that makes the condition true before waiting on it, or "
        "report ERROR when it is not\n"
        "tiny: 2 controllers; a lost process: rcs/loop.py reaction: halt_all, or on_lost: "
        "continue where declared\n"
        "  sub              6 states       11 transitions T\n"
        "  top              8 states       34 transitions T\n"
        "  execution order (the HALT bounds below follow it):\n"
        "    p: top > sub\n"
        "  HALT given to top reaches (cycle k; actuators safe by cycle):\n"
        "    sub      k=1      safe=1      via top > sub\n"
        "  sub MOVE finishes if eventually in S1: `world.pos > 1.0`\n"
        "  top GO finishes if eventually in S1: `sub.status == DONE and world.ready`\n"
        "  counter-example of W703 in top (undecided):\n"
        "  cycle 1: top gets GO | top rule GO/S0/1, sends sub.MOVE -> S1 EXECUTING\n"
        "  cycle 2: sub answers DONE | top waits -> S1 EXECUTING  [world.ready=False]\n"
        "  handshake: the handshake invariant holds for unbounded command numbers (z3, by "
        "induction)\n"
        "0 errors, 3 warnings\n"
        "proven: tiny\n"
    )


# each: the files changed from the deadlock above, and why the wait is then no deadlock
NOT_A_DEADLOCK = {
    # the command sent writes it (PREP sets `ready` in the cycle it runs)
    "the_command_sent_writes_it": {"top": edited(TOP, ("send: sub.MOVE", "send: sub.PREP"))},
    # MOVE sends leaf.PREP, which writes it: a command writes what the commands it sends do
    "a_command_it_sends_further_down_writes_it": {
        "system": edited(SYSTEM, ("modules: [top, sub]", "modules: [top, sub, leaf]")),
        "sub": edited(
            SUB,
            (
                "world:\n  reads: [pos]\n  writes: [drive, ready]",
                "subordinates: [leaf]\nworld:\n  reads: [pos]\n  writes: [drive]",
            ),
            # the send after a set of the same rule: what it writes is added, not put instead
            (
                "          do: [{set: {world.drive: 0.0}}, {report: DONE}]\n  PREP:\n    states:\n"
                "      S0:\n        - do: [{set: {world.ready: true}}, {report: DONE}]\n",
                "          do: [{set: {world.drive: 0.0}}, send: leaf.PREP, {report: DONE}]\n",
            ),
        ),
        "leaf": LEAF,
    },
    # an every_cycle rule sets it whatever sub runs
    "an_every_cycle_rule_writes_it": {
        "sub": edited(
            SUB,
            (
                "commands:\n",
                "every_cycle:\n  - when: world.pos > 5.0\n"
                "    do: [{set: {world.ready: true}}]\ncommands:\n",
            ),
        )
    },
    # a simulator is the world itself: what it writes changes whatever the controllers do
    "a_simulator_writes_it": {"system": SYSTEM + "simulators: [sub]\n"},
    # the wait also reads a local, which may change without the world: not decided as one
    "the_wait_also_reads_a_local": {
        "top": edited(
            TOP,
            ("commands:\n", "locals:\n  n: {type: int, initial: 0, doc: A count.}\ncommands:\n"),
            (
                "sub.status == DONE and world.ready\n",
                "sub.status == DONE and (world.ready or n > 3)\n",
            ),
        )
    },
    # top writes it itself (another command): not its subordinates' alone
    "the_supervisor_writes_it_too": {
        "top": edited(
            TOP,
            ("  reads: [ready]\n", "  reads: [ready]\n  writes: [ready]\n"),
            (
                "commands:\n",
                "commands:\n  CLEAR:\n    states:\n      S0:\n"
                "        - do: [{set: {world.ready: false}}, {report: DONE}]\n",
            ),
        )
    },
}


# the field written two levels down: leaf's PREP sets it, sub's FETCH sends that, GO sends
# MOVE and waits (below the supervisor is its whole subtree, not its children alone)
TWO_LEVELS = {
    "system": edited(SYSTEM, ("modules: [top, sub]", "modules: [top, sub, leaf]")),
    "sub": edited(
        SUB,
        (
            "world:\n  reads: [pos]\n  writes: [drive, ready]",
            "subordinates: [leaf]\nworld:\n  reads: [pos]\n  writes: [drive]",
        ),
        (
            "  PREP:\n    states:\n      S0:\n        - do: [{set: {world.ready: true}}, "
            "{report: DONE}]\n",
            "  FETCH:\n    states:\n      S0:\n        - do: [send: leaf.PREP]\n"
            "          next: S1\n"
            "      S1:\n        - when: leaf.status == DONE\n          do: [report: DONE]\n"
            "        - when: leaf.status == ERROR\n          do: [report: ERROR]\n",
        ),
    ),
    "leaf": LEAF,
}


def test_the_deadlock_is_found_by_the_api_too(tmp_path: Path) -> None:
    assert w703(write(tmp_path / "tiny")) == [DEADLOCK]
    assert w703(write(tmp_path / "three", **TWO_LEVELS)) == [DEADLOCK]


@pytest.mark.parametrize("case", sorted(NOT_A_DEADLOCK))
def test_a_wait_on_a_field_something_else_may_write_is_no_deadlock(
    tmp_path: Path, case: str
) -> None:
    assert w703(write(tmp_path / "tiny", **NOT_A_DEADLOCK[case])) == []


def test_who_writes_each_field_and_what_each_command_may_write(tmp_path: Path) -> None:
    """world.writers on the three-level system: the modules that write each field, the
    fields written whatever a module runs, and each command's writes through its sends."""
    files = NOT_A_DEADLOCK["a_command_it_sends_further_down_writes_it"]
    front = compile_paths([write(tmp_path / "tiny", **files)])
    system = front.systems[0]
    actuators = frozenset(f.name for f in system.world if f.actuator)
    skeletons = {c.name: skeleton(system, c, actuators) for c in system.controllers}
    found = writers(system, skeletons)
    assert found.writers == {"drive": frozenset({"sub"}), "ready": frozenset({"leaf"})}
    assert found.anytime == frozenset()
    assert found.stand_in == {}
    assert found.writes("sub", "MOVE") == frozenset({"drive", "ready"})
    assert found.writes("leaf", "PREP") == frozenset({"ready"})
    assert found.writes("sub", "HALT") == frozenset({"drive"})
    assert found.writes("top", "GO") == frozenset({"drive", "ready"})
    assert found.writes("top", "NOPE") == frozenset()
    assert found.writes("nobody", "GO") == frozenset()


def test_the_fields_quiet_in_a_state_by_what_each_subordinate_was_sent_and_answered(
    tmp_path: Path,
) -> None:
    """quiet_fields for top over two subordinates (sub writes `drive` in MOVE, leaf `ready`
    in PREP): a field is quiet unless the command last sent to its writer is running, ended
    in ERROR (work may still run below), or ran during the current command."""
    files = {
        "system": edited(SYSTEM, ("modules: [top, sub]", "modules: [top, sub, leaf]")),
        "sub": edited(
            SUB,
            ("  writes: [drive, ready]", "  writes: [drive]"),
            (
                "  PREP:\n    states:\n      S0:\n        - do: [{set: {world.ready: true}}, "
                "{report: DONE}]\n",
                "",
            ),
        ),
        "top": edited(TOP, ("subordinates: [sub]", "subordinates: [sub, leaf]")),
        "leaf": LEAF,
    }
    front = compile_paths([write(tmp_path / "two", **files)])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    actuators = frozenset(f.name for f in system.world if f.actuator)
    skeletons = {c.name: skeleton(system, c, actuators) for c in system.controllers}
    found = writers(system, skeletons)
    quiet = quiet_fields(system, found, "top")

    def fields(sub: tuple[str | None, str, bool], leaf: tuple[str | None, str, bool]) -> set[str]:
        return set(quiet(State("GO", "S1", EXECUTING, 0, (sub, leaf))))

    nothing = (None, NOT_READY, False)
    assert fields(nothing, nothing) == {"drive", "ready"}
    assert fields(("MOVE", DONE, False), ("PREP", DONE, False)) == {"drive", "ready"}
    assert fields(("MOVE", EXECUTING, False), ("PREP", DONE, False)) == {"ready"}
    assert fields(("MOVE", DONE, False), ("PREP", ERROR, False)) == {"drive"}
    assert fields(("MOVE", DONE, True), ("PREP", DONE, False)) == {"ready"}
    assert fields(("MOVE", EXECUTING, False), ("PREP", EXECUTING, False)) == set()
    assert fields(("HALT", EXECUTING, False), ("PREP", DONE, True)) == set()
    # below leaf nothing: no field is controlled there, whatever the state
    assert quiet_fields(system, found, "leaf")(State("PREP", "S0", EXECUTING, 0, ())) == set()
