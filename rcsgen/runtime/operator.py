"""Operator: an operator module's channels in the block -> each client's status, every cycle.

An operator module is a person at a screen (docs/semantics.md section 21). It serves every
controller that lists it in `subordinates`, each through a channel of its own: the client
writes the channel's command buffer, as it would any subordinate's; the operator module
writes the channel's status buffer; the answering side (the console's `ctl answer`, or a
scenario's scripted operator) writes the channel's answer record, and nobody else does.
Each cycle, for each channel: a new command number opens a request (INIT and HALT instead
close whatever was open, and are DONE at once); an answer to the open request's command
number becomes the channel's status, DONE or ERROR with its reason; an answer to an older
command is ignored. A task may declare results (what the person records: a measured value, a
choice): a DONE answer carries them in the answer record, and the operator module copies
them into the channel's status buffer with the DONE, so the client reads both in one cycle
under one sequence word; an answer whose values do not fit the task (a type's value it
cannot hold, out of its range) is refused, one line on stderr, and the request stays open.
A generated `<operator>.py` names its channels' offsets and subclasses `OperatorModule`.
Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from struct import Struct
from time import perf_counter_ns
from typing import ClassVar

from .contract import (
    ANSWER,
    ASKING,
    BUILTIN_COMMANDS,
    COMMAND_HEAD_FIELDS,
    DONE,
    ERROR,
    EXECUTING,
    MODE,
    NO_RULE,
    NOP,
    PERF,
    READ_TRIES,
    SEQ,
    STATUS,
    field_codes,
    performance,
    range_problem,
    struct_format,
    words,
)

COMMAND_HEAD = Struct(struct_format(COMMAND_HEAD_FIELDS))  # seq, command_num, command
# A task's results as the generated module declares them: each one's name, its slot (from
# 0, in the answer record and the status buffer after their standard fields), its range
# (None: open) and, for an enumeration, how many values it has (0: none).
ResultCheck = tuple[str, int, float | None, float | None, int]
WITHDRAW = tuple(range(1, len(BUILTIN_COMMANDS) + 1))  # INIT and HALT close a request
_STALE = None


def read_whole(buf: memoryview, shape: Struct, at: int) -> tuple[int, ...] | None:
    """A buffer's fields after its sequence word, read whole under its seqlock (a word that
    is even, not 0 and unchanged around the read), or None after READ_TRIES tries."""
    for _ in range(READ_TRIES):
        seq, *values = shape.unpack_from(buf, at)
        if seq and not seq & 1 and SEQ.unpack_from(buf, at)[0] == seq:
            return tuple(values)
    return _STALE


class Channel:
    """One client's channel: where its buffers are, and the status last written back."""

    __slots__ = (
        "answer",
        "answer_at",
        "client",
        "command_at",
        "error_num",
        "name",
        "refused",
        "results",
        "shape",
        "state",
        "status",
        "status_at",
        "status_num",
        "status_seq",
        "task",
        "zero",
    )

    def __init__(
        self,
        client: str,
        command_at: int,
        status_at: int,
        answer_at: int,
        shape: Struct = STATUS,
        answer: Struct = ANSWER,
        name: str = "",
    ) -> None:
        self.client, self.name = client, name or client
        self.command_at, self.status_at, self.answer_at = command_at, status_at, answer_at
        self.shape, self.answer = shape, answer  # with its results' slots, if it has any
        self.status_seq = self.status_num = self.status = self.error_num = self.state = 0
        self.task = self.refused = 0
        codes = field_codes(shape.format)[len(field_codes(STATUS.format)) :]
        self.zero = tuple(_zero(code) for code in codes)  # a result before its answer
        self.results = self.zero

    def resume(self, buf: memoryview) -> None:
        """Take up the status from the block (a restarted module keeps its handshake)."""
        seq, self.status_num, self.status, self.error_num, self.state, _, *results = (
            self.shape.unpack_from(buf, self.status_at)
        )
        self.results = tuple(results)
        self.status_seq = seq + (seq & 1)  # odd: its writer died mid-write
        command = read_whole(buf, COMMAND_HEAD, self.command_at)
        self.task = command[1] if command is not None and command[0] == self.status_num else 0

    def step(self, buf: memoryview, checks: Mapping[int, tuple[ResultCheck, ...]]) -> bool | None:
        """One cycle of this channel: whether the status changed (None: its command or
        answer could not be read whole this cycle; nothing changed). `checks`: each task's
        results, by its code."""
        command = read_whole(buf, COMMAND_HEAD, self.command_at)
        if command is None:
            return None
        number, code = command
        changed = False
        if number != self.status_num:  # a new command: a new request, or a withdrawal
            self.status_num, self.error_num, self.task = number, 0, code
            self.results = self.zero
            if code in WITHDRAW:
                self.status, self.state = DONE, NOP
            else:
                self.status, self.state = EXECUTING, ASKING
            changed = True
        if self.state == ASKING:
            answer = read_whole(buf, self.answer, self.answer_at)
            if answer is None:
                return True if changed else None
            answered, status, reason, *values = answer
            if answered == self.status_num and status in (DONE, ERROR):
                recorded = self.results
                if status == DONE:
                    problem = _answer_problem(values, checks.get(self.task, ()))
                    if problem:  # never reaches the client: the request stays open
                        self.refuse(answered, problem)
                        return changed
                    kept = {check[1] for check in checks.get(self.task, ())}
                    recorded = tuple(
                        v if i in kept else z
                        for i, (v, z) in enumerate(zip(values, self.zero, strict=True))
                    )
                self.status, self.state, self.results = status, NOP, recorded
                self.error_num = reason if status == ERROR else 0
                changed = True
        return changed

    def refuse(self, answered: int, problem: str) -> None:
        """An answer whose results do not fit its task: one line, once per answer."""
        if self.refused != answered:
            self.refused = answered
            print(
                f"{self.name}: the answer to #{answered} is refused: {problem}; the request "
                "stays open",
                file=sys.stderr,
                flush=True,
            )

    def write(self, buf: memoryview) -> None:
        """Write the channel's status (and results) back, odd while it is written."""
        seq = self.status_seq + 1
        SEQ.pack_into(buf, self.status_at, seq)  # odd before any field changes
        values = (self.status_num, self.status, self.error_num, self.state, NO_RULE)
        self.shape.pack_into(buf, self.status_at, seq, *values, *self.results)
        SEQ.pack_into(buf, self.status_at, seq + 1)
        self.status_seq = seq + 1


def _zero(code: str) -> object:
    """A result slot's value before any answer: false, 0, 0.0, the empty text."""
    if code == "?":
        return False
    if code == "q":
        return 0
    return 0.0 if code == "d" else b""


def _answer_problem(values: Sequence[object], checks: tuple[ResultCheck, ...]) -> str:
    """'' when an answer's result values fit its task, else what is wrong with the first
    that does not (a value read from the answer record: of its slot's struct type)."""
    for name, slot, low, high, count in checks:
        value = values[slot]
        if isinstance(value, bytes):
            try:
                value.decode("utf-8")
            except UnicodeDecodeError:
                return f"result {name} is not UTF-8 text"
            continue
        if isinstance(value, float) and not math.isfinite(value):
            return f"result {name} is {value}, not a finite number"
        if count and not (isinstance(value, int) and 0 <= value < count):
            return f"result {name} is {value}, not one of its {count} values"
        problem = range_problem(value, low, high)
        if problem:
            return f"result {name} {problem}"
    return ""


class OperatorModule:
    """The cycle of an operator module: every channel in turn, under the module's mode.

    A generated subclass sets `NAME`, `MODE_AT`, `PERF_AT` and `CHANNELS` (client, command,
    status and answer offsets, in the clients' execution order)."""

    NAME = ""
    MODE_AT = 0
    PERF_AT = 0
    # client, command, status and answer offsets (and, with results, the status and answer
    # structs)
    CHANNELS: tuple[tuple[str, int, int, int] | tuple[str, int, int, int, Struct, Struct], ...] = ()
    RESULTS: ClassVar[dict[int, tuple[ResultCheck, ...]]] = {}  # each task's results, by code

    def __init__(self, buf: memoryview, settings: dict[str, str] | None = None) -> None:
        self.buf = buf
        self.words = words(buf)  # its performance buffer's sequence word, one 8-byte store
        self._publish = performance(self.PERF_AT)
        self.channels = tuple(
            Channel(*where, name=f"{self.NAME}/{where[0]}")  # type: ignore[misc]
            for where in self.CHANNELS
        )
        self.dont_run = self.single_step = False
        self.single_step_num = 0
        self.resume()

    def resume(self) -> None:
        """Take up the channels' statuses and the performance counters from the block."""
        buf = self.buf
        for channel in self.channels:
            channel.resume(buf)
        (
            seq,
            self.last_cycle_ns,
            self.min_cycle_ns,
            self.max_cycle_ns,
            self.cycles,
            self.perf_single_step_num,
            self.stale_reads,
        ) = PERF.unpack_from(buf, self.PERF_AT)
        self.perf_seq = seq + (seq & 1)

    def run_cycle(self, began: int = 0) -> int:
        """One cycle: the mode, then each channel (unless the mode holds the module), then
        the cycle time: from `began` (the clock read before it in its process's cycle; 0:
        none) to the read it returns, as a generated controller's."""
        start = began or perf_counter_ns()
        buf = self.buf
        mode = read_whole(buf, MODE, self.MODE_AT)
        if mode is None:
            self.stale_reads += 1
        else:
            dont_run, single_step, _, self.single_step_num = mode
            self.dont_run, self.single_step = bool(dont_run), bool(single_step)
        if not self.dont_run and (
            not self.single_step or self.single_step_num != self.perf_single_step_num
        ):
            if self.single_step:
                self.perf_single_step_num = self.single_step_num  # this step is taken
            for channel in self.channels:
                changed = channel.step(buf, self.RESULTS)
                if changed is None:
                    self.stale_reads += 1
                elif changed:
                    channel.write(buf)
        end = perf_counter_ns()
        self.last_cycle_ns = last = end - start  # published every PERF_INTERVAL, as a
        self.cycles += 1  # controller's: at once when the longest yet, or a step
        if last > self.max_cycle_ns or self.single_step:
            self.publish()
        elif last < self.min_cycle_ns:
            self.min_cycle_ns = last
        return end

    def publish(self) -> None:
        """Its performance buffer written (rcs.contract.performance), as a controller's."""
        self._publish(self)
