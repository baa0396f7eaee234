"""A counter-example as `rcsgen prove` prints it (rcsgen/compiler/prove/__init__.py's
cycle_text): one line a cycle, what happened before it (a process lost or back, the latches
reset, a new command, the subordinates' answers), then what the controller did (the safe
state, the rules that fired, what it sent, the actuators it left unsafe, what it reported),
the state it ended in and the values that made its choices. No solver runs here."""

from __future__ import annotations

from rcsgen.compiler.prove import cycle_text
from rcsgen.compiler.prove.model import Edge, State


def edge(**given: object) -> Edge:
    quiet: dict[str, object] = {
        "new": None,
        "answers": (),
        "lost": None,
        "safe_state": False,
        "rules": (),
        "sends": (),
        "report": None,
        "unsafe": (),
        "safe": (),
        "certain": True,
        "valuation": (),
        "views": (),
    }
    return Edge(**(quiet | given))  # type: ignore[arg-type]


def state(name: str = "S1", status: str = "EXECUTING") -> State:
    return State("MINE", name, status, 0, ())


def test_a_cycle_where_nothing_happens_says_the_controller_waits() -> None:
    assert cycle_text(1, edge(), state("S0", "DONE"), (), "co") == "  cycle 1: co waits -> S0 DONE"


def test_a_cycle_names_what_came_before_and_what_the_controller_did() -> None:
    line = cycle_text(
        7,
        edge(
            new="MINE",
            answers=(("cc", "DONE"), ("vg", "ERROR")),
            lost="p2",
            recovered="p3",
            reset=True,
            rules=("S0/1", "S1/2"),
            sends=(("cc", "SHEAR"), ("vg", "HALT")),
            unsafe=("drum_on", "shearer_on"),
            report="ERROR",
            valuation=(
                (("world", "true_x"), 3),
                (("local", "n"), 2),
                (("status", "cc"), "DONE"),  # the answers say these: not repeated
                (("command", "co"), "MINE"),
                (("time", "S1"), 4),
                (("param", "depth"), 1.5),
            ),
        ),
        state("S2", "ERROR"),
        ("cc", "vg"),
        "co",
    )
    assert line == (
        "  cycle 7: process p2 lost; process p3 back; the operator resets the latches; "
        "co gets MINE; cc answers DONE; vg answers ERROR | "
        "co rule S0/1, rule S1/2, sends cc.SHEAR, sends vg.HALT, sets world.drum_on unsafe, "
        "sets world.shearer_on unsafe, reports ERROR -> S2 ERROR  [world.true_x=3, n=2, depth=1.5]"
    )


def test_in_the_runtimes_safe_state_what_the_table_would_send_is_not_sent() -> None:
    line = cycle_text(
        2,
        edge(lost="p1", safe_state=True, sends=(("cc", "SHEAR"),), rules=("S1/1",)),
        state(),
        ("cc",),
        "sb",
    )
    assert line == (
        "  cycle 2: process p1 lost | sb the runtime's safe state, rule S1/1 -> S1 EXECUTING"
    )


def test_only_an_answer_before_the_cycle_is_a_part_of_its_own() -> None:
    line = cycle_text(3, edge(answers=(("cr", "DONE"),)), state(), ("cr",), "cc")
    assert line == "  cycle 3: cr answers DONE | cc waits -> S1 EXECUTING"
    line = cycle_text(3, edge(new="HALT"), state("S0", "DONE"), (), "cc")
    assert line == "  cycle 3: cc gets HALT | cc waits -> S0 DONE"


def test_the_halt_and_error_bounds_as_a_person_reads_them() -> None:
    """`rcsgen prove`'s bounds: for each controller that has subordinates, the cycle HALT
    reaches each leaf below it and the cycle its actuators are safe; for each leaf, how long
    its ERROR takes to reach the root, or where it stops."""
    from rcsgen.compiler.prove import INFINITE
    from rcsgen.compiler.prove.system import Bound, SystemProof
    from rcsgen.tools.prove_report import bounds_text

    proof = SystemProof(
        "mine",
        halt=[
            Bound("sec", "sec", 1, ("sec",)),  # a root alone: no line
            Bound("sb", "cc", 2, ("sb", "co", "cc"), safe=3),
            Bound("sb", "vg", INFINITE, ("sb", "vg"), safe=None),
            Bound("co", "cr", 12, ("co", "cr"), safe=12),
        ],
        error=[
            Bound("cc", "sb", 2, ("cc", "co", "sb")),
            Bound("vg", "sb", INFINITE, ("vg", "sb"), blocked="sb"),
        ],
    )
    assert bounds_text(proof) == [
        "  HALT given to co reaches (cycle k; actuators safe by cycle):",
        "    cr       k=12     safe=12     via co > cr",
        "  HALT given to sb reaches (cycle k; actuators safe by cycle):",
        "    cc       k=2      safe=3      via sb > co > cc",
        "    vg       k=never  safe=-      via sb > vg",
        "  ERROR of a leaf reaches its root (cycle d):",
        "    cc       d=2      via cc > co > sb",
        "    vg       d=never  via vg > sb (stops at sb)",
    ]
    assert bounds_text(SystemProof("none")) == []
