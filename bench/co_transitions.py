"""co's tables as a `transitions` machine (https://github.com/pytransitions/transitions).

The wrapper (co_library.LibraryCo) is the model; the machine writes its state to
`model.state` as an IntEnum member whose value is co's state code, so the wrapper's
post_process writes it to the block unchanged. Rules are added in table order: transitions
tries the transitions of a trigger from the current state in the order they were added and
runs the first whose conditions all hold. Guards are `conditions`/`unless` lists of model
methods, actions are `after` callbacks, a rule without `next` is an internal transition
(`dest=None`). `ignore_invalid_triggers` lets NOP ignore every command's event.
"""

from __future__ import annotations

from enum import IntEnum

from co_library import LibraryCo
from transitions import Machine


class State(IntEnum):
    NOP = 0
    S0 = 1
    S1 = 2
    S2 = 3
    S3 = 4
    S4 = 5


def sends_and_waits(command: str, send: str) -> list[dict]:
    """INIT and HALT: send to every subordinate, then wait until all of them are done."""
    return [
        {"trigger": command, "source": State.S0, "dest": State.S1, "after": send},
        {
            "trigger": command,
            "source": State.S1,
            "dest": State.NOP,
            "conditions": "all_done",
            "after": "report_done",
        },
    ]


SUMP_SHEAR_CUSP = [
    {"source": State.S0, "dest": State.S1, "after": "sump"},
    {"source": State.S1, "dest": State.S2, "conditions": "vg_and_cc_done", "after": "shear"},
    {"source": State.S2, "dest": State.S1, "conditions": "popped_out", "after": "correct_shear"},
    {"source": State.S2, "dest": None, "conditions": "too_much_loose_coal", "after": "pause_shear"},
    {
        "source": State.S2,
        "dest": None,
        "conditions": "cc_halted",
        "unless": "too_much_loose_coal",
        "after": "resume_shear",
    },
    {
        "source": State.S2,
        "dest": State.S3,
        "conditions": "all_done",
        "unless": "popped_out",
        "after": "cusp",
    },
    {"source": State.S3, "dest": State.S4, "conditions": "all_done", "after": "tram_out"},
    {"source": State.S4, "dest": State.NOP, "conditions": "all_done", "after": "report_done"},
]

TRANSITIONS = [
    {"trigger": "new_command", "source": "*", "dest": State.S0},
    *sends_and_waits("INIT", "send_init"),
    *sends_and_waits("HALT", "send_halt"),
    *({"trigger": "SUMP_SHEAR_CUSP", **rule} for rule in SUMP_SHEAR_CUSP),
]


class TransitionsCo(LibraryCo):
    """co with its tables in a `transitions.Machine`."""

    def __init__(self, buf: memoryview) -> None:
        super().__init__(buf)
        self.machine = Machine(
            model=self,
            states=State,
            transitions=TRANSITIONS,
            initial=State(self.state),
            auto_transitions=False,
            ignore_invalid_triggers=True,
        )

    def restart(self) -> None:
        self.new_command()

    def fire(self, event: str) -> None:
        self.trigger(event)
