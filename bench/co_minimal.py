"""co as one function with no redundant copies: the floor for any Python version of co.

Same block, same behaviour, same duties as the QQ1 controllers (status echo, dont_run and
single-step, the performance buffer) and the same protocol (every buffer it writes has its
sequence word stored odd on its own, then the buffer written, then the word even; its
inputs, all written in this process, are read without checking their sequence words), but
nothing kept between cycles: one `unpack_from` reads every input of a cycle (co's own
buffers, the commands it last sent, the subordinates' status, the world, and the sequence
word of the performance buffer) into locals, the table runs on the locals, and only what
changed is written back (the sequence words of the buffers it writes now and then read
when it writes them): a subordinate's command buffer when co sends to it, the goal when a
hook computes one, the status when it changed, and the performance buffer as the generated
code writes it (docs/semantics.md section 7: at once on the longest cycle yet and in
single-step mode; otherwise its process publishes it every 0.1 s, which this bench does not
run: its figures, kept in the closure, the only state it keeps).

It is not a design to copy: it keeps no local state but those figures, so nothing here
survives a layout change without editing. It shows how much of a cycle is the interpreter's
floor.
"""

from __future__ import annotations

from collections.abc import Callable
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

# Every input of a cycle in one read, in block order, with the sequence word of the one
# buffer co writes every cycle (True); the words of its inputs are skipped (all written in
# this process), those of the buffers it writes now and then are read when it writes them.
INPUTS, INPUTS_AT = gather(
    (CO_COMMAND_AT, CO_COMMAND),
    (CO_STATUS_AT, STATUS),
    (CO_MODE_AT, MODE),
    (CO_PERF_AT, PERF, True),
    (CR_COMMAND_AT, CR_COMMAND),
    (CR_STATUS_AT, STATUS_HEAD),
    (VG_COMMAND_AT, VG_COMMAND),
    (VG_STATUS_AT, STATUS_HEAD),
    (CC_COMMAND_AT, CC_COMMAND),
    (CC_STATUS_AT, STATUS_HEAD),
    *((WORLD[name].offset, WORLD[name].struct) for name in WORLD_READS),
)
GOAL_AT = WORLD["goal_x"].offset
GOAL = Struct("<QdQd")  # goal_x's and goal_y's buffers, adjacent: each its word and value
GOAL_SEQS = Struct("<Q8xQ")
GOAL_Y_AT = WORLD["goal_y"].offset
if GOAL_Y_AT != GOAL_AT + GOAL.size // 2:
    raise ValueError("goal_x and goal_y are not adjacent buffers")


def write(buf: memoryview, struct: Struct, at: int, *values: object) -> None:
    """Write a buffer whole, its sequence word odd meanwhile, then even."""
    seq = SEQ.unpack_from(buf, at)[0] | 1
    SEQ.pack_into(buf, at, seq)  # odd before any field changes
    struct.pack_into(buf, at, seq, *values)
    SEQ.pack_into(buf, at, seq + 1)


def write_goal(buf: memoryview, x: float, y: float) -> None:
    x_seq, y_seq = GOAL_SEQS.unpack_from(buf, GOAL_AT)
    x_seq |= 1
    y_seq |= 1
    SEQ.pack_into(buf, GOAL_AT, x_seq)
    SEQ.pack_into(buf, GOAL_Y_AT, y_seq)
    GOAL.pack_into(buf, GOAL_AT, x_seq, x, y_seq, y)
    SEQ.pack_into(buf, GOAL_AT, x_seq + 1)
    SEQ.pack_into(buf, GOAL_Y_AT, y_seq + 1)


def minimal_co(buf: memoryview) -> Callable[[], None]:
    """co's cycle on `buf`, as a function of no arguments."""
    _, _, min_ns, max_ns, cycles, _, _ = PERF.unpack_from(buf, CO_PERF_AT)

    def run_cycle() -> None:
        nonlocal min_ns, max_ns, cycles  # its figures: kept, published as the generated's
        start = perf_counter_ns()
        (
            command_num, command,
            status_num, status, error_num, state, _,
            dont_run, single_step, _, single_step_num,
            perf_seq, _, _, _, _, stepped_num, stale_reads,
            cr_num, cr_command, cr_echo, cr_status,
            vg_num, vg_command, vg_x, vg_y, vg_echo, vg_status,
            cc_num, cc_command, cc_echo, cc_status,
            popped_out_of_shear, loose_coal, pose_x, pose_y, heading,
        ) = INPUTS.unpack_from(buf, INPUTS_AT)  # fmt: skip
        before = (status_num, status, state)
        if command_num != status_num:  # a new command
            status_num, status, state = command_num, EXECUTING, S0
        if dont_run or (single_step and single_step_num == stepped_num):
            command = 0  # held: no table runs
        elif single_step:
            stepped_num = single_step_num
        if command and state != NOP:
            # A subordinate is done when it echoes the last number sent with DONE.
            cr_done = cr_echo == cr_num and cr_status == DONE
            vg_done = vg_echo == vg_num and vg_status == DONE
            cc_done = cc_echo == cc_num and cc_status == DONE
            if command == SUMP_SHEAR_CUSP:
                if state == S0:
                    state = S1
                    x, y = hooks.co_position_for_sump(pose_x, pose_y, heading)
                    write_goal(buf, x, y)
                    write(buf, CR_COMMAND, CR_COMMAND_AT, cr_num + 1, CR_SUMP)
                    write(buf, VG_COMMAND, VG_COMMAND_AT, vg_num + 1, VG_TRAM_TO_XY, x, y)
                    write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, CC_SUMP)
                elif state == S1:
                    if vg_done and cc_done:
                        state = S2
                        write(buf, CR_COMMAND, CR_COMMAND_AT, cr_num + 1, CR_SHEAR)
                        write(buf, VG_COMMAND, VG_COMMAND_AT, vg_num + 1, HALT, vg_x, vg_y)
                        write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, CC_SHEAR)
                elif state == S2:
                    if popped_out_of_shear:
                        state = S1
                        x, y = hooks.co_position_for_sump(pose_x, pose_y, heading)
                        write_goal(buf, x, y)
                        write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, CC_SHEAR_CORRECT)
                    elif loose_coal > LOOSE_COAL_LIMIT:
                        write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, HALT)
                    elif cc_command == HALT:
                        write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, CC_SHEAR)
                    elif cr_done and vg_done and cc_done:
                        state = S3
                        write(buf, CR_COMMAND, CR_COMMAND_AT, cr_num + 1, CR_CUSP)
                        write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, CC_CUSP)
                elif cr_done and vg_done and cc_done:
                    if state == S3:
                        state = S4
                        x, y = hooks.co_position_for_cusp(pose_x, pose_y, heading)
                        write_goal(buf, x, y)
                        write(buf, VG_COMMAND, VG_COMMAND_AT, vg_num + 1, VG_TRAM_TO_XY, x, y)
                    else:  # S4
                        state, status = NOP, DONE
            elif command == INIT or command == HALT:
                if state == S0:
                    state = S1
                    write(buf, CR_COMMAND, CR_COMMAND_AT, cr_num + 1, command)
                    write(buf, VG_COMMAND, VG_COMMAND_AT, vg_num + 1, command, vg_x, vg_y)
                    write(buf, CC_COMMAND, CC_COMMAND_AT, cc_num + 1, command)
                elif state == S1 and cr_done and vg_done and cc_done:
                    state, status = NOP, DONE
        if (status_num, status, state) != before:
            status_seq = SEQ.unpack_from(buf, CO_STATUS_AT)[0] | 1
            SEQ.pack_into(buf, CO_STATUS_AT, status_seq)  # odd before any field changes
            STATUS.pack_into(
                buf, CO_STATUS_AT, status_seq, status_num, status, error_num, state, NO_RULE
            )
            SEQ.pack_into(buf, CO_STATUS_AT, status_seq + 1)
        last = perf_counter_ns() - start
        cycles += 1
        if last < min_ns or not min_ns:
            min_ns = last
        if last > max_ns or single_step:  # the longest yet, or a step: published at once
            max_ns = max(max_ns, last)
            perf_seq |= 1
            SEQ.pack_into(buf, CO_PERF_AT, perf_seq)
            PERF.pack_into(
                buf, CO_PERF_AT, perf_seq, last, min_ns, max_ns, cycles, stepped_num, stale_reads
            )
            SEQ.pack_into(buf, CO_PERF_AT, perf_seq + 1)

    return run_cycle
