"""co written by hand, the QQ1 way: the baseline the generated controller is measured against.

This is what a careful engineer writes from the paper's QQ1.c template and Appendix C
without a generator: local copies of the buffers, four steps per cycle (pre_process,
check_if_new_command, decision_process, post_process), the command-number handshake,
dont_run and single-step modes, and the performance buffer. It shares the block with the
generated controllers (offsets and buffer structs from the generated layout) and reads
what can be read together in one call: its command and mode, and the five world fields
it reads. It behaves exactly as docs/semantics.md describes, so its trace is the
generated controller's.

It follows the block's protocol as the generated code does (rcs/contract.py): every
buffer it writes has its sequence word stored odd on its own first, then the buffer
written, then the word even; it
writes its status only when a new command arrives or a rule changes it, a subordinate's
command buffer only when it sends one (reading the number back from the block, in case an
operator wrote one meanwhile), the goal only when a hook computed a new one, and its
performance buffer as the generated code does (docs/semantics.md section 7: at once on the
longest cycle yet and in single-step mode; otherwise its process publishes it every 0.1 s,
which this bench does not run). Its inputs are all written in its own process, so it reads
them without checking their sequence words, as the generated code does then. It does not
record which table rule fired (the status's `rule` stays NO_RULE): that is the generated
code's own feature, not QQ1's.
"""

from __future__ import annotations

from struct import Struct
from time import perf_counter_ns

import miner_hooks.co as hooks
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
    NOP,
    NOT_READY,
    S0,
    S1,
    S2,
    S3,
    S4,
    STATUS_HEAD,
    SUMP_SHEAR_CUSP,
    VG_TRAM_TO_XY,
    WORLD_READS,
    gather,
)
from miner.layout import (
    CC_COMMAND,
    CC_COMMAND_AT,
    CC_STATUS_AT,
    CO_COMMAND,
    CO_COMMAND_AT,
    CO_MODE_AT,
    CO_PERF_AT,
    CO_STATUS_AT,
    CR_COMMAND,
    CR_COMMAND_AT,
    CR_STATUS_AT,
    VG_COMMAND,
    VG_COMMAND_AT,
    VG_STATUS_AT,
    WORLD,
)
from miner.rcs.contract import MODE, NO_RULE, PERF, SEQ, STATUS

# co's command and mode buffers in one read; the world fields co reads in another.
COMMAND_MODE, COMMAND_MODE_AT = gather((CO_COMMAND_AT, CO_COMMAND), (CO_MODE_AT, MODE))
WORLD_IN, WORLD_IN_AT = gather(*((WORLD[name].offset, WORLD[name].struct) for name in WORLD_READS))
# The sequence words of the goal's two buffers (adjacent), and the two buffers whole.
GOAL_SEQS, GOAL_AT = Struct("<Q8xQ"), WORLD["goal_x"].offset
GOAL = Struct("<QdQd")
GOAL_X_AT, GOAL_Y_AT = GOAL_AT, WORLD["goal_y"].offset
if GOAL_Y_AT != GOAL_AT + GOAL.size // 2:
    raise ValueError("goal_x and goal_y are not adjacent buffers")
STATUS_HEAD_AT = SEQ.size  # a status head after its sequence word
COMMAND_HEAD = Struct("<QQ")  # a command buffer's sequence word and command number
SUB_STATUS = Struct("<" + STATUS_HEAD.format.lstrip("<")[1:])  # status_num, status


class HandwrittenCo:
    """co's buffers as local copies, and its QQ1 cycle."""

    __slots__ = (
        "buf",
        "cycle_start",
        # the command in, the status out, the mode and performance (QQ1_BUFFER)
        "command_num",
        "command",
        "status_num",
        "status",
        "error_num",
        "state",
        "dont_run",
        "single_step",
        "simulate",
        "single_step_num",
        "last_cycle_ns",
        "min_cycle_ns",
        "max_cycle_ns",
        "cycles",
        "perf_single_step_num",
        "stale_reads",
        # the protocol: the sequence words it writes, what it has to write this cycle
        "status_seq",
        "perf_seq",
        "status_dirty",
        "goal_dirty",
        "cr_written",
        "vg_written",
        "cc_written",
        # the command out to and status in from each subordinate (qq2_co, qq2_si)
        "cr_command_num",
        "cr_command",
        "cr_status_num",
        "cr_status",
        "vg_command_num",
        "vg_command",
        "vg_x",
        "vg_y",
        "vg_status_num",
        "vg_status",
        "cc_command_num",
        "cc_command",
        "cc_status_num",
        "cc_status",
        # the world model, as co sees it this cycle
        "popped_out_of_shear",
        "loose_coal",
        "pose_x",
        "pose_y",
        "heading",
        "goal_x",
        "goal_y",
    )

    def __init__(self, buf: memoryview) -> None:
        self.buf = buf
        self.cycle_start = 0
        # Start from what the block holds, so a restarted co keeps its handshakes and its
        # sequence words go on from the block's (odd: its writer died mid-write).
        (
            self.command_num,
            self.command,
            self.dont_run,
            self.single_step,
            self.simulate,
            self.single_step_num,
        ) = COMMAND_MODE.unpack_from(buf, COMMAND_MODE_AT)
        self.status_seq, self.status_num, self.status, self.error_num, self.state, _ = (
            STATUS.unpack_from(buf, CO_STATUS_AT)
        )
        (
            self.perf_seq,
            self.last_cycle_ns,
            self.min_cycle_ns,
            self.max_cycle_ns,
            self.cycles,
            self.perf_single_step_num,
            self.stale_reads,
        ) = PERF.unpack_from(buf, CO_PERF_AT)
        self.status_seq += self.status_seq & 1
        self.perf_seq += self.perf_seq & 1
        self.status_dirty = self.goal_dirty = False
        _, self.cr_command_num, self.cr_command = CR_COMMAND.unpack_from(buf, CR_COMMAND_AT)
        _, self.vg_command_num, self.vg_command, self.vg_x, self.vg_y = VG_COMMAND.unpack_from(
            buf, VG_COMMAND_AT
        )
        _, self.cc_command_num, self.cc_command = CC_COMMAND.unpack_from(buf, CC_COMMAND_AT)
        self.cr_written = self.cr_command_num
        self.vg_written = self.vg_command_num
        self.cc_written = self.cc_command_num
        self.cr_status_num = self.vg_status_num = self.cc_status_num = 0
        self.cr_status = self.vg_status = self.cc_status = NOT_READY
        self.popped_out_of_shear, self.loose_coal, self.pose_x, self.pose_y, self.heading = (
            WORLD_IN.unpack_from(buf, WORLD_IN_AT)
        )
        _, self.goal_x, _, self.goal_y = GOAL.unpack_from(buf, GOAL_AT)

    def run_cycle(self) -> None:
        self.pre_process()
        self.check_if_new_command()
        self.decision_process()
        self.post_process()

    def pre_process(self) -> None:
        """Read the command, the mode, the subordinates' status and the world (all written
        in this process: no sequence word to check)."""
        self.cycle_start = perf_counter_ns()
        buf = self.buf
        (
            self.command_num,
            self.command,
            self.dont_run,
            self.single_step,
            self.simulate,
            self.single_step_num,
        ) = COMMAND_MODE.unpack_from(buf, COMMAND_MODE_AT)
        # A subordinate is executing until it echoes the number of the last command sent.
        self.cr_status_num, self.cr_status = SUB_STATUS.unpack_from(
            buf, CR_STATUS_AT + STATUS_HEAD_AT
        )
        if self.cr_status_num != self.cr_command_num:
            self.cr_status = EXECUTING
        self.vg_status_num, self.vg_status = SUB_STATUS.unpack_from(
            buf, VG_STATUS_AT + STATUS_HEAD_AT
        )
        if self.vg_status_num != self.vg_command_num:
            self.vg_status = EXECUTING
        self.cc_status_num, self.cc_status = SUB_STATUS.unpack_from(
            buf, CC_STATUS_AT + STATUS_HEAD_AT
        )
        if self.cc_status_num != self.cc_command_num:
            self.cc_status = EXECUTING
        self.popped_out_of_shear, self.loose_coal, self.pose_x, self.pose_y, self.heading = (
            WORLD_IN.unpack_from(buf, WORLD_IN_AT)
        )

    def check_if_new_command(self) -> None:
        if self.command_num != self.status_num:
            self.status_num = self.command_num
            self.state = S0
            self.status = EXECUTING
            self.status_dirty = True

    def decision_process(self) -> None:
        if self.dont_run:
            return
        if self.single_step:
            if self.single_step_num == self.perf_single_step_num:
                return
            self.perf_single_step_num = self.single_step_num
        command = self.command
        if command == SUMP_SHEAR_CUSP:
            self.sump_shear_cusp()
        elif command == INIT:
            self.init()
        elif command == HALT:
            self.halt()

    def post_process(self) -> None:
        """Write what changed, each buffer odd while it is written: the status, the
        subordinates' commands, the goal; and the cycle time."""
        buf = self.buf
        if self.status_dirty:
            seq = self.status_seq + 1
            SEQ.pack_into(buf, CO_STATUS_AT, seq)  # odd before any field changes
            STATUS.pack_into(
                buf, CO_STATUS_AT, seq, self.status_num, self.status, self.error_num, self.state,
                NO_RULE,
            )  # fmt: skip
            SEQ.pack_into(buf, CO_STATUS_AT, seq + 1)
            self.status_seq = seq + 1
            self.status_dirty = False
        if self.cr_command_num != self.cr_written:  # sent this cycle
            seq, number = COMMAND_HEAD.unpack_from(buf, CR_COMMAND_AT)
            if number != self.cr_written:  # an operator's command came meanwhile
                self.cr_command_num = number + 1
            seq |= 1
            SEQ.pack_into(buf, CR_COMMAND_AT, seq)
            CR_COMMAND.pack_into(buf, CR_COMMAND_AT, seq, self.cr_command_num, self.cr_command)
            SEQ.pack_into(buf, CR_COMMAND_AT, seq + 1)
            self.cr_written = self.cr_command_num
        if self.vg_command_num != self.vg_written:
            seq, number = COMMAND_HEAD.unpack_from(buf, VG_COMMAND_AT)
            if number != self.vg_written:
                self.vg_command_num = number + 1
            seq |= 1
            SEQ.pack_into(buf, VG_COMMAND_AT, seq)
            VG_COMMAND.pack_into(
                buf, VG_COMMAND_AT, seq, self.vg_command_num, self.vg_command, self.vg_x, self.vg_y
            )
            SEQ.pack_into(buf, VG_COMMAND_AT, seq + 1)
            self.vg_written = self.vg_command_num
        if self.cc_command_num != self.cc_written:
            seq, number = COMMAND_HEAD.unpack_from(buf, CC_COMMAND_AT)
            if number != self.cc_written:
                self.cc_command_num = number + 1
            seq |= 1
            SEQ.pack_into(buf, CC_COMMAND_AT, seq)
            CC_COMMAND.pack_into(buf, CC_COMMAND_AT, seq, self.cc_command_num, self.cc_command)
            SEQ.pack_into(buf, CC_COMMAND_AT, seq + 1)
            self.cc_written = self.cc_command_num
        if self.goal_dirty:  # a hook computed a new goal
            x_seq, y_seq = GOAL_SEQS.unpack_from(buf, GOAL_AT)
            x_seq |= 1
            y_seq |= 1
            SEQ.pack_into(buf, GOAL_X_AT, x_seq)
            SEQ.pack_into(buf, GOAL_Y_AT, y_seq)
            GOAL.pack_into(buf, GOAL_AT, x_seq, self.goal_x, y_seq, self.goal_y)
            SEQ.pack_into(buf, GOAL_X_AT, x_seq + 1)
            SEQ.pack_into(buf, GOAL_Y_AT, y_seq + 1)
            self.goal_dirty = False
        last = perf_counter_ns() - self.cycle_start
        self.last_cycle_ns = last
        self.cycles += 1
        if last > self.max_cycle_ns or self.single_step:  # the longest yet, or a step
            self.write_performance()  # at once; else its process does, every 0.1 s
        elif last < self.min_cycle_ns:
            self.min_cycle_ns = last

    def write_performance(self) -> None:
        last, buf = self.last_cycle_ns, self.buf
        if last > self.max_cycle_ns:
            self.max_cycle_ns = last
        if last < self.min_cycle_ns or not self.min_cycle_ns:
            self.min_cycle_ns = last
        seq = self.perf_seq + 1
        SEQ.pack_into(buf, CO_PERF_AT, seq)
        PERF.pack_into(
            buf, CO_PERF_AT, seq, last, self.min_cycle_ns, self.max_cycle_ns, self.cycles,
            self.perf_single_step_num, self.stale_reads,
        )  # fmt: skip
        SEQ.pack_into(buf, CO_PERF_AT, seq + 1)
        self.perf_seq = seq + 1

    # ------------------------------------------------------------ sending

    def send_all(self, code: int) -> None:
        self.cr_command = code
        self.cr_command_num += 1
        self.vg_command = code
        self.vg_command_num += 1
        self.cc_command = code
        self.cc_command_num += 1

    def all_done(self) -> bool:
        return self.cr_status == DONE and self.vg_status == DONE and self.cc_status == DONE

    # ------------------------------------------------------------ state tables

    def init(self) -> None:
        state = self.state
        if state == S0:
            self.state = S1
            self.status_dirty = True
            self.send_all(INIT)
        elif state == S1 and self.all_done():
            self.state = NOP
            self.status = DONE
            self.status_dirty = True

    def halt(self) -> None:
        state = self.state
        if state == S0:
            self.state = S1
            self.status_dirty = True
            self.send_all(HALT)
        elif state == S1 and self.all_done():
            self.state = NOP
            self.status = DONE
            self.status_dirty = True

    def sump_shear_cusp(self) -> None:
        """Appendix C, co_sump_shear_cusp, branch for branch."""
        state = self.state
        if state == S0:  # do a sump operation
            self.state = S1
            self.status_dirty = True
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
        elif state == S1:
            if self.vg_status == DONE and self.cc_status == DONE:  # do a shear operation
                self.state = S2
                self.status_dirty = True
                self.cr_command = CR_SHEAR
                self.cr_command_num += 1
                self.vg_command = HALT
                self.vg_command_num += 1
                self.cc_command = CC_SHEAR
                self.cc_command_num += 1
        elif state == S2:
            too_much_loose_coal = self.loose_coal > LOOSE_COAL_LIMIT
            if self.popped_out_of_shear:  # the drum popped out of the shear
                self.state = S1
                self.status_dirty = True
                self.goal_x, self.goal_y = hooks.co_position_for_sump(
                    self.pose_x, self.pose_y, self.heading
                )
                self.goal_dirty = True
                self.cc_command = CC_SHEAR_CORRECT
                self.cc_command_num += 1
            elif too_much_loose_coal:  # pause the shear
                self.cc_command = HALT
                self.cc_command_num += 1
            elif self.cc_command == HALT:  # continue with the shear
                self.cc_command = CC_SHEAR
                self.cc_command_num += 1
            elif self.all_done():  # do a cusp operation (not popped out: tested above)
                self.state = S3
                self.status_dirty = True
                self.cr_command = CR_CUSP
                self.cr_command_num += 1
                self.cc_command = CC_CUSP
                self.cc_command_num += 1
        elif state == S3:
            if self.all_done():
                self.state = S4
                self.status_dirty = True
                self.goal_x, self.goal_y = hooks.co_position_for_cusp(
                    self.pose_x, self.pose_y, self.heading
                )
                self.goal_dirty = True
                self.vg_x, self.vg_y = self.goal_x, self.goal_y
                self.vg_command = VG_TRAM_TO_XY
                self.vg_command_num += 1
        elif state == S4:
            if self.all_done():
                self.state = NOP
                self.status = DONE
                self.status_dirty = True
