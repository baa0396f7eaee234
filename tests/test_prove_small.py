"""`rcsgen prove` on a two-controller tank, word for word as a person reads it: the findings
(W701, W702, W705, W709 and the validate warnings prove repeats) located at their rules, the
proof's summary (states and transitions per controller, the execution order, the HALT bound
per leaf and when its actuators are safe, how far a leaf's ERROR goes up, the world
conditions a command needs to finish, each property's verdict) and each counter-example cycle
by cycle. Three variants of one system: one process, two processes, two processes with the
tank's loss declared `on_lost: continue`. The solver's times are the only figures masked.
Without `--no-replay` these findings would be replayed in the generated code
(test_prove.py does that); here the model alone decides, in a second."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import test_check_messages as checks
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove.system import prove


def edited(text: str, *edits: tuple[str, str]) -> str:
    for old, new in edits:
        assert old in text
        text = text.replace(old, new, 1)
    return text


# test_check_messages' tank, its actuator declared safe off, with a supervisor above it
SYSTEM = edited(
    checks.SYSTEM,
    ("actuator: true, doc", "actuator: true, safe: false, doc"),
    (
        "  mode: {type: enum, values: [IDLE, RUN], initial: IDLE, actuator: true, safe: IDLE, "
        "doc: A mode.}\n",
        "",
    ),
    ("    modules: [tank]\n", "    modules: [sup, tank]\n"),
)
TWO_PROCESSES = ("    modules: [sup, tank]\n", "    modules: [sup]\n  q:\n    modules: [tank]\n")

SUP = """\
controller: sup
title: Supervisor
subordinates: [tank]

properties:
  - name: filled_when_told
    doc: The tank is told to fill in the cycle the supervisor runs.
    whenever: sup.command == RUN
    within: 0
    then: sent(tank.FILL)

commands:
  RUN:
    doc: Fill the tank.
    states:
      S0:
        - do:
            - send: tank.FILL
          next: S1
      S1:
        - when: tank.status == DONE
          do:
            - report: DONE
        - when: tank.status == ERROR
          do:
            - send: tank.FILL
          next: S1
  HALT:
    doc: Stop.
    states:
      S0:
        - do:
            - send: tank.HALT
            - report: DONE
"""
# the same supervisor, but its property is that an ERROR below goes up, and HALT waits
ERRORS_GO_UP = """\
  - name: errors_go_up
    doc: An ERROR below is reported up.
    whenever: tank.status == ERROR
    within: 1
    then: sup.status == ERROR
"""
HALT_WAITS = """\
            - send: tank.HALT
          next: S1
      S1:
        - when: tank.status == DONE
          do:
            - report: DONE
        - when: tank.status == ERROR
          do:
            - report: ERROR
"""

# ... and the tank leaves its pump on when it is done
TANK = edited(
    checks.TANK,
    (
        "            - set: {world.pump_on: false}\n            - report: DONE\n  HALT",
        "            - report: DONE\n  HALT",
    ),
)
# the tank may fail (a negative level); a property of its own: the pump is off when it is done
FAILS = (
    (
        "        - when: world.level < 2.0\n",
        "        - when: world.level >= 0.0 and world.level < 2.0\n",
    ),
    (
        "        - when: world.level >= 2.0\n",
        "        - when: world.level < 0.0\n          do:\n            - report: ERROR\n"
        "        - when: world.level >= 2.0\n",
    ),
)
PUMP_OFF = """\
properties:
  - name: pump_off_when_done
    doc: The pump is off whenever the tank is done.
    always: tank.status != DONE or safe(world.pump_on)

commands:
"""


# the supervisor tries the tank three times before it gives up: a counter-example that
# needs its local `tries` to have counted up is looked for past the shortest run (z3)
RETRIES = (
    (
        "properties:\n" + ERRORS_GO_UP,
        "locals:\n  tries: {type: int, initial: 0, doc: The fills that failed.}\n\nproperties:\n"
        "  - name: never_gives_up\n    doc: The supervisor never reports ERROR.\n"
        "    always: sup.status != ERROR\n",
    ),
    ("    doc: Fill the tank.\n", "    doc: Fill the tank, three tries.\n"),
    (
        "            - send: tank.FILL\n          next: S1\n      S1:",
        "            - send: tank.FILL\n            - set: {tries: 0}\n"
        "          next: S1\n      S1:",
    ),
    (
        "        - when: tank.status == ERROR\n          do:\n            - send: tank.FILL\n"
        "          next: S1\n",
        "        - when: tank.status == ERROR and tries < 2\n          do:\n"
        "            - send: tank.FILL\n            - set: {tries: tries + 1}\n          next: S1\n"
        "        - when: tank.status == ERROR and tries >= 2\n          do:\n"
        "            - send: tank.HALT\n            - report: ERROR\n          allow:\n"
        "            - code: W505\n              reason: the tank stops its pump in the cycle it "
        "reads HALT.\n",
    ),
)


def proven(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    system: str,
    sup: str,
    tank: str,
    replay: bool = False,
) -> str:
    """What `rcsgen prove` prints and its exit code, the solver's times masked. Replayed in
    the generated code (without --no-replay), a finding the code follows to its last cycle
    is violated: exit 1."""
    for name, text in (("system", system), ("sup", sup), ("tank", tank)):
        (tmp_path / f"{name}.yaml").write_text(text)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["prove", ".", *([] if replay else ["--no-replay"])])
    text = result.output.replace(str(tmp_path) + "/", "")
    return f"exit {result.exit_code}\n" + re.sub(r" +\d+ ms \(\d+ ms CPU\)", " T", text)


def variants() -> dict[str, tuple[str, str, str, bool]]:
    """name -> (system, sup, tank, replayed in the generated code)"""
    two = edited(SYSTEM, TWO_PROCESSES)
    sup = edited(
        SUP,
        (SUP[SUP.index("  - name:") : SUP.index("commands:")], ERRORS_GO_UP + "\n"),
        ("            - send: tank.HALT\n            - report: DONE\n", HALT_WAITS),
    )
    tank = edited(TANK, *FAILS)
    lost = ("subordinates: [tank]\n", "subordinates: [tank]\non_lost: {tank: continue}\n")
    # an ERROR below: HALT it, then report ERROR in the next cycle (one cycle more up)
    fixed = edited(
        sup,
        (
            "          do:\n            - send: tank.FILL\n          next: S1\n",
            "          do:\n            - send: tank.HALT\n          next: S2\n"
            "      S2:\n        - do:\n            - report: ERROR\n",
        ),
    )
    return {
        "one_process": (SYSTEM, SUP, TANK, False),
        "two_processes": (two, sup, tank, False),
        "on_lost_continue": (
            two,
            edited(sup, lost),
            edited(tank, ("commands:\n", PUMP_OFF)),
            True,
        ),
        "retries": (two, edited(sup, *RETRIES), tank, True),
        "errors_reported": (two, fixed, tank, True),
    }


EXPECTED = Path(__file__).parent / "cases" / "prove_small"


@pytest.mark.parametrize("variant", sorted(variants()))
def test_prove_says_what_holds_and_what_breaks_it(tmp_path, monkeypatch, variant: str) -> None:
    said = proven(tmp_path, monkeypatch, *variants()[variant])
    assert said == (EXPECTED / f"{variant}.txt").read_text()


DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"


def test_proving_one_controller_proves_those_below_it_and_their_stand_ins() -> None:
    """system.prove's `only` (the seeded-bug campaign proves one controller): the one
    named, those below it and each one's stand-in (duo's arm_sim stands in for arm), whose
    contracts it needs."""
    front = compile_paths([DUO])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    assert sorted(prove(system, only="top").controllers) == ["arm", "arm_sim", "top"]
    assert sorted(prove(system, only="arm").controllers) == ["arm", "arm_sim"]
    assert sorted(prove(system, only="arm_sim").controllers) == ["arm_sim"]
