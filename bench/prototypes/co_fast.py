"""PROTOTYPE, not generated: the generated co (bench/co_spec/miner/co.yaml) as the two
remaining proposed template changes would emit it; bench_co.py measures it beside the
generated one, and bench/prototypes/ablation.py measures each change on its own.

P1. Predicates are inlined into the guards that use them (no method call per use).
P2. run_cycle holds the four QQ1 steps itself, as commented sections, instead of calling
    four methods (pre_process stays, for __init__).

Written from the generated code of 148c872, which already reads all inputs with one
Struct, writes adjacent world fields with one, and compares instead of max()/min().
"""

from struct import Struct
from time import perf_counter_ns

import miner_hooks.co as hooks
from miner.layout import (
    CC_COMMAND,
    CC_COMMAND_AT,
    CO_PERF_AT,
    CO_STATUS_AT,
    CR_COMMAND,
    CR_COMMAND_AT,
    VG_COMMAND,
    VG_COMMAND_AT,
)
from miner.rcs.contract import DONE, EXECUTING, NO_RULE, NOP, PERF, STATUS

# Commands co accepts (the code written to its command buffer).
INIT = 1
HALT = 2
SUMP_SHEAR_CUSP = 3

# Commands co sends to cr.
CR_INIT = 1
CR_HALT = 2
CR_SUMP = 3
CR_SHEAR = 4
CR_CUSP = 5

# Commands co sends to vg.
VG_INIT = 1
VG_HALT = 2
VG_TRAM_TO_XY = 3

# Commands co sends to cc.
CC_INIT = 1
CC_HALT = 2
CC_SUMP = 3
CC_SHEAR = 4
CC_SHEAR_CORRECT = 5
CC_CUSP = 6

# pre_process copies its inputs (command, mode, subordinates' status, world) in one read;
# the bytes between them belong to other buffers and are skipped.
INPUTS = Struct("<QI28x???1xI56xQI92xQI76xQI60x?7xd8xddddd")
INPUTS_AT = 0
# Adjacent world fields post_process writes back with one write.
WORLD_OUT_1 = Struct("<dd")
WORLD_OUT_1_AT = 416

# States of the state tables (NOP = 0: no command to work on).
S0 = 1
S1 = 2
S2 = 3
S3 = 4
S4 = 5

# Constants.
LOOSE_COAL_LIMIT = 4.0


class CoController:
    """The co controller: its local buffers and the QQ1 cycle."""

    __slots__ = (
        "buf",
        "cc_command",
        "cc_command_num",
        "cc_status",
        "cc_status_num",
        "command",
        "command_num",
        "cr_command",
        "cr_command_num",
        "cr_status",
        "cr_status_num",
        "cycle_start",
        "cycles",
        "dont_run",
        "error_num",
        "last_cycle_ns",
        "max_cycle_ns",
        "min_cycle_ns",
        "perf_single_step_num",
        "simulate",
        "single_step",
        "single_step_num",
        "state",
        "status",
        "status_num",
        "vg_arg_x",
        "vg_arg_y",
        "vg_command",
        "vg_command_num",
        "vg_status",
        "vg_status_num",
        "world_goal_x",
        "world_goal_y",
        "world_heading",
        "world_loose_coal",
        "world_popped_out_of_shear",
        "world_pose_x",
        "world_pose_y",
    )

    def __init__(self, buf: memoryview, settings: dict[str, str] | None = None) -> None:
        self.buf = buf
        self.cycle_start = 0
        # Resume from the block, so a restarted module keeps its command-number handshake.
        self.status_num, self.status, self.error_num, self.state, _ = STATUS.unpack_from(
            buf, CO_STATUS_AT
        )
        (
            self.last_cycle_ns,
            self.min_cycle_ns,
            self.max_cycle_ns,
            self.cycles,
            self.perf_single_step_num,
        ) = PERF.unpack_from(buf, CO_PERF_AT)
        self.cr_command_num, self.cr_command = CR_COMMAND.unpack_from(buf, CR_COMMAND_AT)
        self.vg_command_num, self.vg_command, self.vg_arg_x, self.vg_arg_y = VG_COMMAND.unpack_from(
            buf, VG_COMMAND_AT
        )
        self.cc_command_num, self.cc_command = CC_COMMAND.unpack_from(buf, CC_COMMAND_AT)
        self.pre_process()  # the command, the mode, subordinates' status, the world

    def run_cycle(self) -> None:
        """One cycle: read inputs, detect a new command, run its state table, write outputs."""
        # pre_process: copy the command, the mode, the subordinates' status, the world in.
        self.cycle_start = perf_counter_ns()
        buf = self.buf
        (
            self.command_num,
            self.command,
            self.dont_run,
            self.single_step,
            self.simulate,
            self.single_step_num,
            self.cr_status_num,
            self.cr_status,
            self.vg_status_num,
            self.vg_status,
            self.cc_status_num,
            self.cc_status,
            self.world_popped_out_of_shear,
            self.world_loose_coal,
            self.world_pose_x,
            self.world_pose_y,
            self.world_heading,
            self.world_goal_x,
            self.world_goal_y,
        ) = INPUTS.unpack_from(buf, INPUTS_AT)
        if self.cr_status_num != self.cr_command_num:
            self.cr_status = EXECUTING  # until it echoes the last number sent
        if self.vg_status_num != self.vg_command_num:
            self.vg_status = EXECUTING  # until it echoes the last number sent
        if self.cc_status_num != self.cc_command_num:
            self.cc_status = EXECUTING  # until it echoes the last number sent

        # check_if_new_command: a number that differs from the echoed one is a new command.
        if self.command_num != self.status_num:
            self.status_num = self.command_num
            self.state = S0
            self.status = EXECUTING

        # decision_process: run the current command's table, unless the mode holds co.
        if not self.dont_run and not (
            self.single_step and self.single_step_num == self.perf_single_step_num
        ):
            if self.single_step:
                self.perf_single_step_num = self.single_step_num
            command = self.command
            if command == INIT:
                self.init()
            elif command == HALT:
                self.halt()
            elif command == SUMP_SHEAR_CUSP:
                self.sump_shear_cusp()

        # post_process: write the status, the subordinates' commands, the world, the time.
        STATUS.pack_into(
            buf, CO_STATUS_AT, self.status_num, self.status, self.error_num, self.state, NO_RULE
        )
        CR_COMMAND.pack_into(buf, CR_COMMAND_AT, self.cr_command_num, self.cr_command)
        VG_COMMAND.pack_into(
            buf, VG_COMMAND_AT, self.vg_command_num, self.vg_command, self.vg_arg_x, self.vg_arg_y
        )
        CC_COMMAND.pack_into(buf, CC_COMMAND_AT, self.cc_command_num, self.cc_command)
        WORLD_OUT_1.pack_into(buf, WORLD_OUT_1_AT, self.world_goal_x, self.world_goal_y)
        last = perf_counter_ns() - self.cycle_start
        self.last_cycle_ns = last
        if last > self.max_cycle_ns:  # a new longest cycle (and the first cycle's minimum)
            self.max_cycle_ns = last
            if not self.min_cycle_ns:
                self.min_cycle_ns = last
        elif last < self.min_cycle_ns:
            self.min_cycle_ns = last
        self.cycles += 1
        PERF.pack_into(
            buf,
            CO_PERF_AT,
            self.last_cycle_ns,
            self.min_cycle_ns,
            self.max_cycle_ns,
            self.cycles,
            self.perf_single_step_num,
        )

    def pre_process(self) -> None:
        """Copy the command in, the mode, each subordinate's status and the world in."""
        self.cycle_start = perf_counter_ns()
        buf = self.buf
        (
            self.command_num,
            self.command,
            self.dont_run,
            self.single_step,
            self.simulate,
            self.single_step_num,
            self.cr_status_num,
            self.cr_status,
            self.vg_status_num,
            self.vg_status,
            self.cc_status_num,
            self.cc_status,
            self.world_popped_out_of_shear,
            self.world_loose_coal,
            self.world_pose_x,
            self.world_pose_y,
            self.world_heading,
            self.world_goal_x,
            self.world_goal_y,
        ) = INPUTS.unpack_from(buf, INPUTS_AT)
        if self.cr_status_num != self.cr_command_num:
            self.cr_status = EXECUTING  # until it echoes the last number sent
        if self.vg_status_num != self.vg_command_num:
            self.vg_status = EXECUTING  # until it echoes the last number sent
        if self.cc_status_num != self.cc_command_num:
            self.cc_status = EXECUTING  # until it echoes the last number sent

    def init(self) -> None:
        """INIT: Initialise this controller and its subordinates."""
        state = self.state
        if state == S0:
            # send INIT to every subordinate
            self.state = S1
            self.cr_command = CR_INIT
            self.cr_command_num += 1
            self.vg_command = VG_INIT
            self.vg_command_num += 1
            self.cc_command = CC_INIT
            self.cc_command_num += 1

        elif (
            state == S1
            and self.cr_status == DONE
            and self.vg_status == DONE
            and self.cc_status == DONE
        ):
            # every subordinate is done
            self.state = NOP
            self.status = DONE

    def halt(self) -> None:
        """HALT: Halt all actions."""
        state = self.state
        if state == S0:
            # send HALT to every subordinate
            self.state = S1
            self.cr_command = CR_HALT
            self.cr_command_num += 1
            self.vg_command = VG_HALT
            self.vg_command_num += 1
            self.cc_command = CC_HALT
            self.cc_command_num += 1

        elif (
            state == S1
            and self.cr_status == DONE
            and self.vg_status == DONE
            and self.cc_status == DONE
        ):
            # every subordinate is done
            self.state = NOP
            self.status = DONE

    def sump_shear_cusp(self) -> None:
        """SUMP_SHEAR_CUSP: Sump into the face, shear down to the floor, then clear the cusp."""
        state = self.state
        if state == S0:
            # do a sump operation
            self.state = S1
            self.world_goal_x, self.world_goal_y = hooks.co_position_for_sump(
                self.world_pose_x, self.world_pose_y, self.world_heading
            )
            self.cr_command = CR_SUMP
            self.cr_command_num += 1
            self.vg_arg_x = self.world_goal_x
            self.vg_arg_y = self.world_goal_y
            self.vg_command = VG_TRAM_TO_XY
            self.vg_command_num += 1
            self.cc_command = CC_SUMP
            self.cc_command_num += 1

        elif state == S1 and self.vg_status == DONE and self.cc_status == DONE:
            # do a shear operation
            self.state = S2
            self.cr_command = CR_SHEAR
            self.cr_command_num += 1
            self.vg_command = VG_HALT
            self.vg_command_num += 1
            self.cc_command = CC_SHEAR
            self.cc_command_num += 1

        elif state == S2:
            if self.world_popped_out_of_shear:
                # the drum popped out of the shear
                self.state = S1
                self.world_goal_x, self.world_goal_y = hooks.co_position_for_sump(
                    self.world_pose_x, self.world_pose_y, self.world_heading
                )
                self.cc_command = CC_SHEAR_CORRECT
                self.cc_command_num += 1

            elif self.world_loose_coal > LOOSE_COAL_LIMIT:
                # too much loose coal (conveyor tail not in position) pauses the shear
                self.cc_command = CC_HALT
                self.cc_command_num += 1

            elif not (self.world_loose_coal > LOOSE_COAL_LIMIT) and self.cc_command == CC_HALT:
                # continue with the shear
                self.cc_command = CC_SHEAR
                self.cc_command_num += 1

            elif (
                self.cr_status == DONE
                and self.vg_status == DONE
                and self.cc_status == DONE
                and not self.world_popped_out_of_shear
            ):
                # do a cusp operation
                self.state = S3
                self.cr_command = CR_CUSP
                self.cr_command_num += 1
                self.cc_command = CC_CUSP
                self.cc_command_num += 1

        elif (
            state == S3
            and self.cr_status == DONE
            and self.vg_status == DONE
            and self.cc_status == DONE
        ):
            self.state = S4
            self.world_goal_x, self.world_goal_y = hooks.co_position_for_cusp(
                self.world_pose_x, self.world_pose_y, self.world_heading
            )
            self.vg_arg_x = self.world_goal_x
            self.vg_arg_y = self.world_goal_y
            self.vg_command = VG_TRAM_TO_XY
            self.vg_command_num += 1

        elif (
            state == S4
            and self.cr_status == DONE
            and self.vg_status == DONE
            and self.cc_status == DONE
        ):
            self.state = NOP
            self.status = DONE
