"""What the three state-machine-library versions of co share: the QQ1 wrapper around them.

A state-machine library replaces only the state tables. Everything QQ1 does around them
(reading and writing the block, the command-number handshake, subordinates counting as
EXECUTING until they echo, dont_run and single-step, the performance buffer) stays plain
Python: it is the hand-written baseline's (`HandwrittenCo`), inherited unchanged.

How the table maps onto a library, the same for all three:

- co's states NOP and S0..S4 are the machine's states; their values are co's state codes.
- Each command (INIT, HALT, SUMP_SHEAR_CUSP) is an event. `decision_process` fires the
  event of the current command once per cycle; the transitions of that event out of the
  current state are that command's rules, tried in the table's order, the first whose
  guard holds fires. A cycle in which no guard holds fires nothing (the library must
  allow an event without a transition). NOP has no transitions.
- A new command number restarts the table: the event `new_command` takes any state to S0,
  in the same cycle, before the command's event.
- Guards and actions are the methods below, named after what the table's rules say.
  A rule without `next` is an internal transition (no exit or entry).
"""

from __future__ import annotations

import miner_hooks.co as hooks
from co_handwritten import HandwrittenCo
from co_layout import (
    CC_CUSP,
    CC_SHEAR,
    CC_SHEAR_CORRECT,
    CC_SUMP,
    CR_CUSP,
    CR_SHEAR,
    CR_SUMP,
    DONE,
    EXECUTING,
    HALT,
    INIT,
    LOOSE_COAL_LIMIT,
    SUMP_SHEAR_CUSP,
    VG_TRAM_TO_XY,
)

# The event each command code fires (NONE, code 0, fires nothing).
EVENTS = {INIT: "INIT", HALT: "HALT", SUMP_SHEAR_CUSP: "SUMP_SHEAR_CUSP"}


class LibraryCo(HandwrittenCo):
    """The QQ1 wrapper for a library machine: subclasses define `restart` and `fire`."""

    # No __slots__: libraries attach their own attributes to the model.

    def restart(self) -> None:
        """Put the machine in S0 (a new command arrived)."""
        raise NotImplementedError

    def fire(self, event: str) -> None:
        """Run the machine for one cycle on `event`."""
        raise NotImplementedError

    def check_if_new_command(self) -> None:
        if self.command_num != self.status_num:
            self.status_num = self.command_num
            self.status = EXECUTING
            self.restart()
            self.status_dirty = True

    def decision_process(self) -> None:
        if self.dont_run:
            return
        if self.single_step:
            if self.single_step_num == self.perf_single_step_num:
                return
            self.perf_single_step_num = self.single_step_num
        event = EVENTS.get(self.command)
        if event is not None:
            before = (self.state, self.status)
            self.fire(event)
            if (self.state, self.status) != before:  # the status is written when it changed
                self.status_dirty = True

    # ------------------------------------------------------------ guards

    def vg_and_cc_done(self) -> bool:
        return self.vg_status == DONE and self.cc_status == DONE

    def popped_out(self) -> bool:
        return self.popped_out_of_shear

    def too_much_loose_coal(self) -> bool:
        return self.loose_coal > LOOSE_COAL_LIMIT

    def cc_halted(self) -> bool:
        return self.cc_command == HALT

    # all_done() is the baseline's.

    # ------------------------------------------------------------ actions

    def send_init(self) -> None:
        self.send_all(INIT)

    def send_halt(self) -> None:
        self.send_all(HALT)

    def report_done(self) -> None:
        self.status = DONE

    def sump(self) -> None:
        self.goal_x, self.goal_y = hooks.co_position_for_sump(
            self.pose_x, self.pose_y, self.heading
        )
        self.goal_dirty = True
        self.cr_command = CR_SUMP
        self.cr_command_num += 1
        self.vg_x, self.vg_y = self.goal_x, self.goal_y
        self.vg_command = VG_TRAM_TO_XY
        self.vg_command_num += 1
        self.cc_command = CC_SUMP
        self.cc_command_num += 1

    def shear(self) -> None:
        self.cr_command = CR_SHEAR
        self.cr_command_num += 1
        self.vg_command = HALT
        self.vg_command_num += 1
        self.cc_command = CC_SHEAR
        self.cc_command_num += 1

    def correct_shear(self) -> None:
        self.goal_x, self.goal_y = hooks.co_position_for_sump(
            self.pose_x, self.pose_y, self.heading
        )
        self.goal_dirty = True
        self.cc_command = CC_SHEAR_CORRECT
        self.cc_command_num += 1

    def pause_shear(self) -> None:
        self.cc_command = HALT
        self.cc_command_num += 1

    def resume_shear(self) -> None:
        self.cc_command = CC_SHEAR
        self.cc_command_num += 1

    def cusp(self) -> None:
        self.cr_command = CR_CUSP
        self.cr_command_num += 1
        self.cc_command = CC_CUSP
        self.cc_command_num += 1

    def tram_out(self) -> None:
        self.goal_x, self.goal_y = hooks.co_position_for_cusp(
            self.pose_x, self.pose_y, self.heading
        )
        self.goal_dirty = True
        self.vg_x, self.vg_y = self.goal_x, self.goal_y
        self.vg_command = VG_TRAM_TO_XY
        self.vg_command_num += 1
