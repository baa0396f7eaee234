"""The closed loop around co: a seeded operator, three simulated subordinates and the world.

Every version of co is driven by the same `Plant`: before each cycle it writes co's inputs
into the block (the operator's command and modes, each subordinate's status, the world);
after the cycle it reads co's outputs (co's status, the commands co sent) and reacts to
them. The plant reacts only to what co wrote, so two versions of co that behave the same
see the same inputs, cycle for cycle, and must produce the same trace.

What happens, all drawn from one `random.Random(seed)`:

- The operator starts with INIT, then after co reports DONE waits 1-8 cycles and sends
  SUMP_SHEAR_CUSP (80 %), INIT (10 %) or HALT (10 %). Now and then (0.2 % a cycle) it
  interrupts a running command with a new one, and after 400 cycles without DONE it sends
  HALT. Rarely it holds co with `dont_run` or single-steps it for a few cycles.
- Each subordinate (cr, vg, cc) sees a new command number after the cycle that sent it,
  keeps showing its old echo for 0-2 cycles, then echoes the number with EXECUTING and
  reports DONE after 0-3 cycles (INIT, HALT) or 1-15 cycles (the work commands). vg's
  TRAM_TO_XY moves the machine (pose_x, pose_y) to its goal when it is done.
- While co is shearing (S2), the drum pops out of the shear (2 % a cycle, for 1-2 cycles)
  and loose coal piles up (3 % a cycle, 2.5-8 t); gathering removes it 1.5 t at a time.
  The heading changes now and then.

`Plant.record()` keeps, per cycle, the bytes the plant wrote since co's previous cycle:
the timing runs replay exactly those inputs without the plant's own cost (bench_co.py).
"""

from __future__ import annotations

import math
import random
from struct import Struct
from types import ModuleType

from co_layout import STATUS_HEAD

SUBORDINATES = ("cr", "vg", "cc")
WORK_DELAY = (1, 15)  # cycles from echo to DONE for a work command
QUICK_DELAY = (0, 3)  # ... for INIT and HALT
STALE_ECHO = (0, 2)  # cycles a subordinate still shows its previous echo
OPERATOR_PAUSE = (1, 8)  # cycles between co's DONE and the operator's next command
P_INTERRUPT = 0.002
WATCHDOG = 400
P_POP, POP_CYCLES = 0.02, (1, 2)
P_COAL, COAL_HALF_TONNES = 0.03, (5, 16)
P_GATHER, GATHER = 0.25, 1.5
P_HEADING = 0.002
P_HOLD, HOLD_CYCLES = 0.001, (1, 20)

EXECUTING, DONE = 1, 2
BOOL = Struct("<Q?")  # a world field's buffer: its sequence word, its value
FLOAT = Struct("<Qd")
SEQ = Struct("<Q")


class Subordinate:
    """One simulated subordinate: it answers the last command co sent it, late."""

    __slots__ = ("name", "command", "command_at", "status_at", "quick", "tram")
    __slots__ += ("number", "code", "args", "echo_at", "done_at", "shown")

    def __init__(self, layout: ModuleType, name: str) -> None:
        record = layout.COMMAND_IN[name]
        self.name = name
        self.command, self.command_at = record.struct, record.offset
        self.status_at = layout.STATUS_OUT[name].offset
        names = layout.COMMAND_NAMES[name]
        self.quick = {names.index("INIT"), names.index("HALT")}
        self.tram = names.index("TRAM_TO_XY") if "TRAM_TO_XY" in names else -1  # vg only
        self.number = self.code = 0
        self.args: tuple = ()
        self.echo_at = self.done_at = 0
        self.shown = (0, 0)  # what the status buffer holds: (status_num, status)


class Plant:
    """Everything around co, seeded: call `before(buf)`, run co, then `after(buf)`."""

    def __init__(self, layout: ModuleType, seed: int) -> None:
        self.layout = layout
        self.rng = random.Random(seed)
        self.frames: list[tuple[tuple[slice, bytes], ...]] | None = None
        self.frame: list[tuple[slice, bytes]] = []
        self.cycle = 0
        codes = layout.COMMAND_NAMES["co"]
        self.INIT, self.HALT = codes.index("INIT"), codes.index("HALT")
        self.SUMP_SHEAR_CUSP = codes.index("SUMP_SHEAR_CUSP")
        self.S2 = layout.STATE_NAMES["co"].index("S2")
        self.co_command = layout.COMMAND_IN["co"]
        self.co_status = layout.STATUS_OUT["co"]
        self.co_mode = layout.MODE_IN["co"]
        self.world = {name: layout.WORLD[name].offset for name in layout.WORLD}
        self.subs = [Subordinate(layout, name) for name in SUBORDINATES]
        # The operator.
        self.co_number = 0
        self.next_command: tuple[int, int] | None = (0, self.INIT)  # (cycle, code)
        self.sent_at = 0
        self.hold_until = -1
        self.stepping = False
        self.single_step_num = 0
        # The world, as the plant last wrote it.
        self.popped_until = -1
        self.popped = False
        self.loose_coal = 0.0
        self.pose = (0.0, 0.0)

    def record(self) -> None:
        """Keep the bytes written before every cycle from now on (see `frames`)."""
        self.frames = []

    # ------------------------------------------------------------ writing

    def _write(self, buf: memoryview, struct: Struct, at: int, *values: object) -> None:
        """Write a buffer's leading fields whole: its sequence word goes to the next even
        value (nothing reads while the plant writes, so one write does)."""
        seq = SEQ.unpack_from(buf, at)[0]
        struct.pack_into(buf, at, (seq | 1) + 1, *values)
        if self.frames is not None:
            self.frame.append((slice(at, at + struct.size), bytes(buf[at : at + struct.size])))

    def before(self, buf: memoryview) -> None:
        """Write co's inputs for this cycle."""
        now = self.cycle
        if self.next_command is not None and self.next_command[0] <= now:
            self.co_number += 1
            code = self.next_command[1]
            self._write(buf, self.co_command.struct, self.co_command.offset, self.co_number, code)
            self.next_command = None
            self.sent_at = now
        for sub in self.subs:
            if now < sub.echo_at:
                continue
            status = DONE if now >= sub.done_at else EXECUTING
            if sub.shown != (sub.number, status):
                sub.shown = (sub.number, status)
                self._write(buf, STATUS_HEAD, sub.status_at, sub.number, status)
            if status == DONE and sub.code == sub.tram and self.pose != sub.args:
                self.pose = sub.args
                self._write(buf, FLOAT, self.world["pose_x"], sub.args[0])
                self._write(buf, FLOAT, self.world["pose_y"], sub.args[1])
        if self.popped and now >= self.popped_until:
            self.popped = False
            self._write(buf, BOOL, self.world["popped_out_of_shear"], False)
        if self.frames is not None:  # what co will see: written since its last cycle
            self.frames.append(tuple(self.frame))
            self.frame = []

    def after(self, buf: memoryview) -> tuple:
        """Read co's outputs, react to them and return this cycle's trace row."""
        rng, now = self.rng, self.cycle
        _, status_num, status, _, state, _ = self.co_status.struct.unpack_from(
            buf, self.co_status.offset
        )
        row = [status_num, status, state]
        for sub in self.subs:
            _, number, code, *args = sub.command.unpack_from(buf, sub.command_at)
            row += (number, code, *args)
            if number != sub.number:
                sub.number, sub.code, sub.args = number, code, tuple(args)
                sub.echo_at = now + 1 + rng.randint(*STALE_ECHO)
                delay = QUICK_DELAY if code in sub.quick else WORK_DELAY
                sub.done_at = sub.echo_at + rng.randint(*delay)
        self._operator(buf, rng, now, status_num, status)
        if state == self.S2:
            self._shearing(buf, rng, now)
        if self.loose_coal > 0.0 and rng.random() < P_GATHER:
            self._set_loose_coal(buf, max(0.0, self.loose_coal - GATHER))
        if rng.random() < P_HEADING:
            heading = rng.randrange(-180, 180, 15) * math.pi / 180
            self._write(buf, FLOAT, self.world["heading"], heading)
        self.cycle += 1
        return tuple(row)

    def _operator(self, buf: memoryview, rng: random.Random, now: int, number, status) -> None:
        if self.next_command is None:
            finished = number == self.co_number and status == DONE
            if finished:
                pick = rng.random()
                code = (
                    self.SUMP_SHEAR_CUSP if pick < 0.8 else self.INIT if pick < 0.9 else self.HALT
                )
                self.next_command = (now + rng.randint(*OPERATOR_PAUSE), code)
            elif rng.random() < P_INTERRUPT:
                code = rng.choice((self.SUMP_SHEAR_CUSP, self.INIT, self.HALT))
                self.next_command = (now + 1, code)
            elif now - self.sent_at > WATCHDOG:
                self.next_command = (now + 1, self.HALT)
        mode = self.co_mode
        if now == self.hold_until:
            self._write(buf, mode.struct, mode.offset, False, False, False, self.single_step_num)
        elif now > self.hold_until and rng.random() < P_HOLD:
            self.hold_until = now + rng.randint(*HOLD_CYCLES)
            self.stepping = rng.random() < 0.5  # single-step co, else stop it (dont_run)
            held = (not self.stepping, self.stepping, False, self.single_step_num)
            self._write(buf, mode.struct, mode.offset, *held)
        elif now < self.hold_until and self.stepping and rng.random() < 0.3:
            self.single_step_num += 1  # the operator presses "step"
            self._write(buf, mode.struct, mode.offset, False, True, False, self.single_step_num)

    def _shearing(self, buf: memoryview, rng: random.Random, now: int) -> None:
        if not self.popped and rng.random() < P_POP:
            self.popped = True
            self.popped_until = now + 1 + rng.randint(*POP_CYCLES)
            self._write(buf, BOOL, self.world["popped_out_of_shear"], True)
        if rng.random() < P_COAL:
            self._set_loose_coal(buf, rng.randint(*COAL_HALF_TONNES) / 2)

    def _set_loose_coal(self, buf: memoryview, tonnes: float) -> None:
        self.loose_coal = tonnes
        self._write(buf, FLOAT, self.world["loose_coal"], tonnes)
