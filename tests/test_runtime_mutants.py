"""Plausible one-line bugs in the runtime's safety paths, each pinned by a test of what the
runtime promises (issue "Fail safe", "Tests that would catch a broken runtime"): a seqlock
read that accepts a torn record (a tool's read, and a controller's), a cross-process command
read without its seqlock, a watchdog that trips a cycle late, a segment without rcsgen's
header accepted on attach. (A lost process that beats again but stays lost is caught by
tests/test_zenoh.py, where pc2 re-joins; the torn-record stress of tests/test_runtime.py
catches a tool's read that does not look again only by chance, once in ~100,000 reads.)

Every test runs `tests/fixtures/runtime/duo` (a supervisor `top` in process p1 commanding an
`arm` in process p2) through what a user or a tool sees: records, controllers run by the
harness, `loop.run`, blocks. A race is not waited for: the read that overlaps a write is made
to happen, deterministically, by a struct that writes while it is read.
"""

from __future__ import annotations

import importlib
import shutil
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from support.running import segment_names

from rcsgen.tools.harness import Harness, generate, import_package

DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"
MINER = Path(__file__).resolve().parent.parent / "specs" / "miner"


segment_name = segment_names("mut")


@pytest.fixture(scope="module")
def package() -> Iterator[ModuleType]:
    scratch, name = generate(DUO)
    yield import_package(scratch / name, DUO)
    shutil.rmtree(scratch, ignore_errors=True)


def part(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


class WrittenWhileRead:
    """A struct whose first read overlaps a write: the read takes the buffer's sequence word,
    then `write()` changes the buffer (at `offset`), then the read takes the fields. It
    returns what such a read returns: the word from before the write, the fields from after.
    Later reads are plain."""

    def __init__(self, struct: Any, offset: int, write: Any) -> None:
        self.struct, self.offset, self.write, self.reads = struct, offset, write, 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.struct, name)

    def unpack_from(self, buf: memoryview, offset: int = 0) -> tuple[Any, ...]:
        self.reads += 1
        if self.reads > 1:
            return tuple(self.struct.unpack_from(buf, offset))
        word = bytes(buf[self.offset : self.offset + 8])
        self.write()
        image = bytearray(buf)
        image[self.offset : self.offset + 8] = word
        return tuple(self.struct.unpack_from(image, offset))


def dies_mid_write(package: ModuleType, record: Any, buf: memoryview, **values: Any) -> None:
    """What a writer that dies mid-write leaves: the word odd, the fields `values`."""
    contract = part(package, "rcs.contract")
    odd = contract.next_odd(record.seq(buf))
    fields = {**record.read(buf), **values}
    contract.SEQ.pack_into(buf, record.offset, odd)
    record.struct.pack_into(buf, record.offset, odd, *fields.values())


# ---------------------------------------------------------------- consistent reads


def test_a_record_read_that_a_write_overlaps_is_not_taken(package: ModuleType) -> None:
    """A tool's read (ctl, the monitor, the harness) that a write overlaps looks at the
    sequence word again: the half-written fields under the old word are never returned; a
    writer that died there leaves the buffer stale (StaleRead) until a whole write."""
    layout, contract = part(package, "layout"), part(package, "rcs.contract")
    block = part(package, "rcs.block").Block(layout)
    try:
        record = layout.COMMAND_IN["arm"]
        record.write(block.buf, command_num=1, command=1, arg_level=1.0)
        torn = WrittenWhileRead(
            record.struct,
            record.offset,
            lambda: dies_mid_write(package, record, block.buf, command_num=2, arg_level=2.0),
        )
        with pytest.raises(contract.StaleRead):
            contract.Record(torn, record.offset, record.fields).read(block.buf)
        record.write(block.buf, command_num=3, command=1, arg_level=3.0)
        assert record.read(block.buf)["command_num"] == 3
    finally:
        block.close()


def test_a_controller_input_read_that_a_write_overlaps_is_not_taken(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """top (p1) reads arm's status, written by another process, under its seqlock: a read
    that a write overlaps (arm's status starts to say DONE, and its writer dies) is not
    taken. top keeps the inputs of its last whole read (arm EXECUTING) and counts a stale
    read, instead of finishing on a status arm never wrote whole."""
    h = Harness(package, "p1")  # top alone: arm's status comes from another process
    h.command("top", "MOVE")
    h.cycle()  # top sends POWER #1 and waits
    arm = h.layout.STATUS_OUT["arm"]
    done = h.contract.STATUS_NAMES.index("DONE")
    top = part(package, "top")
    torn = WrittenWhileRead(
        top.INPUTS,
        arm.offset,
        lambda: dies_mid_write(package, arm, h.buf, status_num=1, status=done),
    )
    monkeypatch.setattr(top, "INPUTS", torn)
    before = h.performance("top")["stale_reads"]
    h.cycle()
    assert torn.reads > 1, "the overlapped read was read again"
    assert h.performance("top")["stale_reads"] == before + 1
    assert h.status("top").status == "EXECUTING", "not finished on a torn DONE"
    h.reply("arm", "DONE", 1)  # arm's status written whole
    h.cycle()
    assert h.status("top").status == "DONE"


def test_a_command_from_another_process_is_read_under_its_seqlock(package: ModuleType) -> None:
    """arm (p2) gets its commands from top (p1), another OS process: a command buffer left
    odd (its writer died mid-write) is not taken; arm keeps its command, counts a stale read
    each cycle, and takes the command once it is written whole."""
    h = Harness(package, "p2")  # arm alone: its command comes from another process
    layout, contract = h.layout, h.contract
    record = layout.COMMAND_IN["arm"]
    power = layout.COMMAND_NAMES["arm"].index("POWER")
    record.write(h.buf, command_num=1, command=power, arg_level=0.5)
    h.cycle()
    assert (h.status("arm").number, h.world["arm_power"]) == (1, 0.5)
    seq = record.seq(h.buf)
    contract.SEQ.pack_into(h.buf, record.offset, contract.next_odd(seq))  # marked odd ...
    record.struct.pack_into(h.buf, record.offset, contract.next_odd(seq), 2, power, 0.9)
    before = h.performance("arm")["stale_reads"]  # ... written, and the writer died
    h.cycle(3)
    assert h.performance("arm")["stale_reads"] == before + 3
    assert (h.status("arm").number, h.world["arm_power"]) == (1, 0.5), "not the torn command"
    record.write(h.buf, command_num=2, command=power, arg_level=0.9)  # a whole write
    h.cycle()
    assert (h.status("arm").number, h.world["arm_power"]) == (2, 0.9)


class Stepped:
    """A struct whose `pack_into` stores as CPython's may reach another core: it first
    fills its whole span with zeros (glibc's memset stores overlapping vectors, the last
    one first: here the span's 8-byte words from the last to the first), then stores the
    values in address order (8-byte words here: sequence words and floats). After each
    8-byte store the run of world fields at `at` is recorded (each field's sequence word
    and value, as a reader would see them)."""

    def __init__(self, struct: Any, run: Any, buf: memoryview, at: int, seen: list[Any]) -> None:
        self.struct, self.run, self.buf, self.at, self.seen = struct, run, buf, at, seen

    def __getattr__(self, name: str) -> Any:
        return getattr(self.struct, name)

    def pack_into(self, buf: memoryview, offset: int, *values: Any) -> None:
        image = bytearray(self.struct.size)
        self.struct.pack_into(image, 0, *values)
        words = range(0, len(image), 8)
        steps = [(i, bytes(8)) for i in reversed(words)]  # zero-filled, last word first
        steps += [(i, bytes(image[i : i + 8])) for i in words]  # then stored in order
        for i, chunk in steps:
            at = offset + i
            buf[at : at + 8] = chunk
            if self.at <= at < self.at + self.run.size:
                self.seen.append(self.run.unpack_from(self.buf, self.at))


class SteppedWords:
    """The block's word view (rcs.contract.words) whose every store (one aligned 8-byte
    store: no zero fill) records the run of world fields at `at`, as `Stepped` does."""

    def __init__(self, words: Any, run: Any, buf: memoryview, at: int, seen: list[Any]) -> None:
        self.words, self.run, self.buf, self.at, self.seen = words, run, buf, at, seen

    def __getitem__(self, index: int) -> int:
        return int(self.words[index])

    def __setitem__(self, index: int, value: int) -> None:
        self.words[index] = value
        if self.at <= index * 8 < self.at + self.run.size:
            self.seen.append(self.run.unpack_from(self.buf, self.at))


def whole(word: int) -> bool:
    """What a reader's seqlock accepts: an even word, not 0."""
    return word != 0 and word % 2 == 0


def test_a_world_write_of_adjacent_fields_changes_no_value_while_its_word_is_even(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The miner's pss writes three adjacent world fields (pose_x, pose_y, heading), each
    with its sequence word. Its stores are stepped as they may reach another core (a span
    zero-filled from its end, then each 8-byte word in address order): after every step,
    a field whose word is whole (even, not 0) holds the value it held under that word
    before, a value changes only in a step with its word not whole before and after, and
    the values written are pss's. So each word is made odd on its own before any store
    of the run: a store of the whole run with the words odd and the values as they are
    would zero a value before its word. The words are stored through the word view
    (one 8-byte store each), the run with one `pack_into`."""
    with Harness.build(MINER, "pc1") as h:
        pss = importlib.import_module(f"{h.package.__name__}.pss")
        run, at, seen = pss.WORLD_OUT_1, pss.WORLD_OUT_1_AT, []
        monkeypatch.setattr(pss, "WORLD_OUT_1", Stepped(run, run, h.buf, at, seen))
        controller = h.controller("pss")
        words = SteppedWords(controller.words, run, h.buf, at, seen)
        monkeypatch.setattr(controller, "words", words)
        under: dict[tuple[int, int], Any] = {}  # (field, whole word) -> its value
        for cycle in range(5):
            h.world.update(
                {"true_x": 1.0 + cycle, "true_y": 2.0 - cycle, "true_heading": 0.1 * cycle}
            )
            seen[:] = [run.unpack_from(h.buf, at)]
            h.step("pss")
            assert len(seen) > 12, "the run's words and values stored, step by step"
            for before, after in zip(seen, seen[1:], strict=False):
                for field in range(3):
                    word, value = after[2 * field], after[2 * field + 1]
                    if whole(word):
                        assert under.setdefault((field, word), value) == value, (
                            f"cycle {cycle}: field {field} reads {value} under word {word}, "
                            f"which it read as {under[field, word]}"
                        )
                    if value != before[2 * field + 1]:  # changed in this step
                        assert not whole(before[2 * field]) and not whole(word), (
                            f"cycle {cycle}: field {field} changed while its word was "
                            f"{before[2 * field]} -> {word}"
                        )
            last, world = seen[-1], h.world
            assert all(whole(last[2 * f]) for f in range(3)), "every word whole at the end"
            assert (last[1], last[3], last[5]) == (
                world["pose_x"],
                world["pose_y"],
                world["heading"],
            )
            assert abs(world["pose_x"] - (1.0 + cycle)) < 0.01, "the noisy true pose"


# ---------------------------------------------------------------- the watchdog


def slow_plan(package: ModuleType, cycle: float) -> Any:
    """p1's plan with top's every cycle taking `cycle` seconds at least."""
    plan = part(package, "main_p1").PLAN

    class Slow(plan.classes["top"]):  # type: ignore[misc,name-defined]
        def run_cycle(self, began: int = 0) -> int:
            time.sleep(cycle)
            return super().run_cycle(began)

    return plan._replace(classes={**plan.classes, "top": Slow})


@pytest.mark.parametrize(("behind", "trips"), [(1000.0, False), (0.4, True)])
def test_a_watchdog_trip_halts_the_root(package: ModuleType, behind: float, trips: bool) -> None:
    """Every cycle here runs past its period (1.5 periods of work), so each starts at least
    half a period late: with the limit at 0.4 periods of lateness in all the watchdog trips
    and HALT goes to the root; with the limit far away it does not, and the root keeps its
    command. (Where exactly the limit trips, on a scripted clock: test_failsafe's
    test_the_watchdog_trips_when_the_recent_cycles_ran_five_periods_late_in_all.)"""
    layout, loop = part(package, "layout"), part(package, "rcs.loop")
    plan = part(package, "main_p1").PLAN
    dog = loop.Watchdog(behind=behind, period_factor=1000.0)
    process = loop.run(
        slow_plan(package, 1.5 * plan.cycle_period),
        layout,
        cycles=4,
        watchdog=dog,
        heartbeat_timeout=1000.0,
    )
    try:
        assert process.counters["overruns"] >= 3
        assert (process.counters["watchdog_trips"] > 0) == trips
        sent = layout.COMMAND_IN["top"].read(process.block.buf)
        halted = layout.COMMAND_NAMES["top"][sent["command"]] == "HALT"
        assert halted == trips
    finally:
        process.block.close()


# ---------------------------------------------------------------- identity of a segment


def test_a_segment_whose_header_is_not_rcsgens_is_refused_on_attach(package: ModuleType) -> None:
    """A segment of the right size and layout hash, but whose first bytes are not rcsgen's
    magic (something else wrote there): attaching refuses it as not an rcsgen block."""
    layout, contract = part(package, "layout"), part(package, "rcs.contract")
    blocks = part(package, "rcs.block")
    created = blocks.Block(layout, segment_name(), create=True)
    try:
        created.buf[: len(contract.MAGIC)] = b"NOTRCS!!"
        with pytest.raises(blocks.BlockError, match="is not an rcsgen block"):
            blocks.Block(layout, created.name, create=False)
        created.buf[: len(contract.MAGIC)] = contract.MAGIC  # the same segment, its header back
        attached = blocks.Block(layout, created.name, create=False)
        attached.close()
    finally:
        created.close()


# ---------------------------------------------------------------- an echo's time


def test_an_echo_timeout_counts_from_the_command_not_from_the_start(package: ModuleType) -> None:
    """echo_timeouts: arm may take 5 cycles to echo. top idles 3 cycles, then sends arm a
    command (arm never runs here): top still waits 5 cycles after sending it, not 5 after
    its start, before it sees arm in ERROR."""
    h = Harness(package, "p1")
    h.cycle(3)
    h.command("top", "MOVE")
    h.cycle(5)
    assert h.status("top").status == "EXECUTING"
    h.cycle(2)
    assert h.status("top").status == "ERROR"
