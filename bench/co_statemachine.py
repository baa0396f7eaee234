"""co's tables as a `python-statemachine` machine (https://github.com/fgmacedo/python-statemachine).

`CoTable` declares co's states and one event per command; the wrapper
(co_library.LibraryCo) is the domain model: guards (`cond`, `unless`) and actions (`on`)
are its methods, and the machine keeps the current state's value, co's state code, in
`model.state`, which the wrapper's post_process writes to the block. Transitions of one
event are tried in declaration order and the first whose guards hold runs. The classic
`StateMachine` flavour (no SCXML error events) is used, with
`allow_event_without_transition` so that a cycle in which no rule holds, or NOP, is not an
error. A rule without `next` is an internal self-transition.
"""

from __future__ import annotations

from co_library import LibraryCo
from statemachine import State, StateMachine


class CoTable(StateMachine):
    """co's INIT, HALT and SUMP_SHEAR_CUSP tables (mining paper, Appendix C)."""

    allow_event_without_transition = True

    nop = State("NOP", value=0, initial=True)
    s0 = State("S0", value=1)
    s1 = State("S1", value=2)
    s2 = State("S2", value=3)
    s3 = State("S3", value=4)
    s4 = State("S4", value=5)

    new_command = s0.from_.any()

    INIT = s0.to(s1, on="send_init") | s1.to(nop, cond="all_done", on="report_done")
    HALT = s0.to(s1, on="send_halt") | s1.to(nop, cond="all_done", on="report_done")
    SUMP_SHEAR_CUSP = (
        s0.to(s1, on="sump")
        | s1.to(s2, cond="vg_and_cc_done", on="shear")
        | s2.to(s1, cond="popped_out", on="correct_shear")
        | s2.to.itself(internal=True, cond="too_much_loose_coal", on="pause_shear")
        | s2.to.itself(
            internal=True, cond="cc_halted", unless="too_much_loose_coal", on="resume_shear"
        )
        | s2.to(s3, cond="all_done", unless="popped_out", on="cusp")
        | s3.to(s4, cond="all_done", on="tram_out")
        | s4.to(nop, cond="all_done", on="report_done")
    )


class StatemachineCo(LibraryCo):
    """co with its tables in a python-statemachine `StateMachine`."""

    def __init__(self, buf: memoryview) -> None:
        super().__init__(buf)
        self.table = CoTable(model=self, state_field="state")

    def restart(self) -> None:
        self.table.send("new_command")

    def fire(self, event: str) -> None:
        self.table.send(event)
