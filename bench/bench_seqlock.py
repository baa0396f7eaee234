"""Part 5: consistent reads across two processes, under stress: the seqlock's torn-read test.

A writer process rewrites one multi-field buffer of the generated miner's block as fast as
it can: the control record of process pc1 (its sequence word and its PROCESS_FIELDS),
the way `Process.beat` and the generated post_process write a buffer (the word odd on its
own, then the word and every field in one `pack_into`, then the word even), every field
telling the same number k. A reader process (this one) reads it with the seqlock of
`Record.read` (rcs/contract.py): unpack the buffer, accept if the word was even, not 0 and
unchanged when read again, else retry, `READ_TRIES` tries in all before the read is
stale. The reader counts reads accepted at once and after retries, retries, stale reads,
and accepted reads whose fields tell different numbers or an older write than one read
before (inconsistent: must be 0). For contrast, the first unpack of every try is exactly
what a reader without the seqlock would take: those whose fields disagree are counted as
plain torn reads.

The reader runs the loop of `Record.read` inlined, to count its retries; a second, shorter
pass calls `Record.read` itself (accepted, stale, torn). A third pass runs the generated
code's own read: the writer rewrites the root sec's command buffer (command number k, depth
k, offset k), as an operator's tool does, and the reader runs generated/miner's sec cycle
after cycle, which reads its command with the generated fast path (one look, the test
inline, the retries out of line); its copies must tell one write, never an older one.
Both processes run flat out on the machine's two cores, sharing them with whatever else
runs. Nothing here is timed but the rates; the segment is removed and the writer stopped
(killed at worst) on the way out.

    python bench/bench_seqlock.py [--reads N] [--record-reads N] [--json PATH]
    python bench/bench_seqlock.py [--generated-cycles N]
    python bench/bench_seqlock.py --writer SEGMENT     (the writer process; started by the reader)
    python bench/bench_seqlock.py --command-writer SEGMENT   (the third pass's writer)
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType

from common import ROOT, write_json

PACKAGE = ROOT / "generated" / "miner"
RECORD = "pc1"  # the process control record the writer rewrites
STOP = "pc2"  # the reader stops the writer through this record's first field
READS = 10_000_000
RECORD_READS = 1_000_000
GENERATED_CYCLES = 1_000_000  # cycles of the generated sec reading a command rewritten flat out
I32 = 0xFFFFFFFF


def field_codes(record) -> str:
    """The control record's field codes after its sequence word (PROCESS_FIELDS: 64-bit
    `Q` and 32-bit `I` only, which `expected` fills)."""
    codes = record.struct.format.lstrip("<")[1:]
    if set(codes) - {"Q", "I"}:
        raise SystemExit(f"the control record is now {record.struct.format!r}: Q and I only")
    return codes


def load() -> tuple[ModuleType, ModuleType, ModuleType]:
    """The generated miner's layout, and its runtime's contract and block modules."""
    sys.path.insert(0, str(PACKAGE.parent))
    import miner.layout as layout
    import miner.rcs.block as block
    import miner.rcs.contract as contract

    return layout, contract, block


def expected(k: int, codes: str) -> tuple[int, ...]:
    """The fields of write number k: k in every field (its low 32 bits in a 32-bit one)."""
    return tuple(k & I32 if code == "I" else k for code in codes)


def writer(segment: str) -> int:
    """Rewrite the record until the reader sets the stop word; print how many writes."""
    layout, contract, block_module = load()
    block = block_module.Block(layout, segment, create=False)
    buf = block.buf
    record, stop_at = layout.PROCESSES[RECORD], layout.PROCESSES[STOP].offset + 8
    struct, at, seq_struct = record.struct, record.offset, contract.SEQ
    pack, pack_seq = struct.pack_into, seq_struct.pack_into
    codes = field_codes(record)
    seq = seq_struct.unpack_from(buf, at)[0]
    k = 0
    try:
        while True:
            k += 1
            seq += 1  # odd: being written, stored before any field changes
            pack_seq(buf, at, seq)
            pack(buf, at, seq, *expected(k, codes))
            seq += 1  # even: whole
            pack_seq(buf, at, seq)
            if not k & 1023 and buf[stop_at]:
                break
    finally:
        del buf
        block.close()
    print(k)
    return 0


def command_writer(segment: str) -> int:
    """Rewrite sec's command buffer until the reader sets the stop word, as an operator's
    tool writes it: write k is command number k, BOX_CUT, depth k and offset k."""
    layout, contract, block_module = load()
    block = block_module.Block(layout, segment, create=False)
    buf = block.buf
    stop_at = layout.PROCESSES[STOP].offset + 8
    struct, at, seq_struct = layout.SEC_COMMAND, layout.SEC_COMMAND_AT, contract.SEQ
    box_cut = layout.COMMAND_NAMES["sec"].index("BOX_CUT")
    pack, pack_seq = struct.pack_into, seq_struct.pack_into
    seq = seq_struct.unpack_from(buf, at)[0]
    k = 0
    try:
        while True:
            k += 1
            seq += 1  # odd: being written, stored before any field changes
            pack_seq(buf, at, seq)
            pack(buf, at, seq, k, box_cut, float(k), float(k))
            seq += 1  # even: whole
            pack_seq(buf, at, seq)
            if not k & 1023 and buf[stop_at]:
                break
    finally:
        del buf
        block.close()
    print(k)
    return 0


def read_generated(buf, cycles: int) -> dict[str, int]:
    """`cycles` cycles of the generated sec (generated/miner/sec.py), whose command another
    process writes (so it reads it under the seqlock: the one look inline, the retries out
    of line): after each, its copies of the command number, depth and offset must tell the
    same write, never an older one than a copy before. Until its first whole read (a
    construction whose read stayed torn) it must hold: no new command, the table held."""
    import miner.sec

    sec = miner.sec.SecController(buf)
    run = sec.run_cycle
    stale_before = stale = sec.stale_reads
    whole_seen = stale == 0  # the constructor's read was whole
    echoed = sec.status_num
    inconsistent = went_back = changed = last = held = acted_torn = 0
    for _ in range(cycles):
        run()
        if sec.stale_reads == stale:
            whole_seen = True  # this cycle's read was whole
        stale = sec.stale_reads
        if not whole_seen:  # only torn reads so far: held, the block's command not taken
            held += 1
            if not sec.dont_run or sec.command_num != echoed or sec.rule:
                acted_torn += 1
            continue
        k = sec.command_num
        if not (k == sec.arg_depth == sec.arg_offset):
            inconsistent += 1
        elif k < last:
            went_back += 1
        elif k > last:
            changed += 1
            last = k
    return {
        "cycles": cycles,
        "stale": sec.stale_reads - stale_before,
        "held_before_first_whole_read": held,
        "acted_before_first_whole_read": acted_torn,
        "new_command_seen": changed,
        "inconsistent_accepted": inconsistent,
        "older_accepted": went_back,
    }


def read_counted(buf, record, contract, reads: int) -> dict[str, int]:
    """`reads` reads with Record.read's loop, inlined to count what it does."""
    struct, at, seq_struct, tries = record.struct, record.offset, contract.SEQ, contract.READ_TRIES
    unpack, unpack_seq = struct.unpack_from, seq_struct.unpack_from
    codes = field_codes(record)
    accepted = after_retry = retries = stale = torn_accepted = went_back = last = 0
    attempts = plain_torn = plain_odd = 0
    for _ in range(reads):
        for attempt in range(tries):
            seq, *values = unpack(buf, at)
            attempts += 1
            k = values[0]
            # whole: every field tells the same write (k > 0: the writer never wrote 0)
            whole = k > 0 and tuple(values) == expected(k, codes)
            if not whole:
                plain_torn += 1  # a reader without the seqlock would have taken this
            elif seq & 1:
                plain_odd += 1  # whole, but taken while being written
            if seq and seq % 2 == 0 and unpack_seq(buf, at)[0] == seq:
                if attempt:
                    after_retry += 1
                else:
                    accepted += 1
                if not whole:
                    torn_accepted += 1
                elif k < last:
                    went_back += 1  # an older write than one accepted before
                else:
                    last = k
                break
            retries += 1 if attempt + 1 < tries else 0
        else:
            stale += 1
    return {
        "reads": reads,
        "accepted_first_try": accepted,
        "accepted_after_retry": after_retry,
        "retries": retries,
        "stale": stale,
        "torn_accepted": torn_accepted,
        "older_accepted": went_back,
        "plain_reads": attempts,
        "plain_torn": plain_torn,
        "plain_mid_write": plain_odd,
    }


def read_records(buf, record, contract, reads: int) -> dict[str, int]:
    """`reads` calls of Record.read itself: accepted, stale, torn among the accepted."""
    accepted = stale = torn = 0
    read, stale_error = record.read, contract.StaleRead
    names = record.fields
    codes = record.struct.format.lstrip("<")[1:]
    for _ in range(reads):
        try:
            values = read(buf)
        except stale_error:
            stale += 1
            continue
        accepted += 1
        fields = tuple(values[name] for name in names)
        if not fields[0] or fields != expected(fields[0], codes):
            torn += 1
    return {"reads": reads, "accepted": accepted, "stale": stale, "torn_accepted": torn}


def stress(reads: int, record_reads: int, generated_cycles: int) -> dict[str, object]:
    layout, contract, block_module = load()
    generated: dict[str, int | float] = {}
    segment = f"rcsgen_bench_seqlock_{os.getpid()}"
    block = block_module.Block(layout, segment, create=True)
    record = layout.PROCESSES[RECORD]
    stop_at = layout.PROCESSES[STOP].offset + 8
    buf = block.buf
    child = None
    try:
        child = subprocess.Popen(
            [sys.executable, __file__, "--writer", segment],
            stdout=subprocess.PIPE,
            text=True,
            cwd=Path(__file__).parent,
        )
        deadline = time.monotonic() + 60
        while record.seq(buf) < 10:  # the writer has started writing
            if child.poll() is not None or time.monotonic() > deadline:
                raise SystemExit(f"the writer did not start (exit {child.returncode})")
            time.sleep(0.01)
        started = time.perf_counter()
        writes_before = record.seq(buf) // 2
        counted = read_counted(buf, record, contract, reads)
        middle = time.perf_counter()
        writes_middle = record.seq(buf) // 2
        whole = read_records(buf, record, contract, record_reads)
        ended = time.perf_counter()
        writes_after = record.seq(buf) // 2
        buf[stop_at] = 1
        out, _ = child.communicate(timeout=30)
        writes = int(out.strip() or 0)
        if generated_cycles:
            buf[stop_at] = 0
            child = subprocess.Popen(
                [sys.executable, __file__, "--command-writer", segment],
                stdout=subprocess.PIPE,
                text=True,
                cwd=Path(__file__).parent,
            )
            deadline = time.monotonic() + 60
            while layout.SEC_COMMAND.unpack_from(buf, layout.SEC_COMMAND_AT)[1] < 10:
                if child.poll() is not None or time.monotonic() > deadline:
                    raise SystemExit(f"the command writer did not start (exit {child.returncode})")
                time.sleep(0.01)
            begun = time.perf_counter()
            generated = read_generated(buf, generated_cycles)
            generated["seconds"] = time.perf_counter() - begun
            buf[stop_at] = 1
            out, _ = child.communicate(timeout=30)
            generated["writes"] = int(out.strip() or 0)
            generated["writer_exit"] = child.returncode
    finally:
        if child is not None and child.poll() is None:
            buf[stop_at] = 1
            try:
                child.wait(timeout=10)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        del buf
        block.close()
    return {
        "record": f"PROCESSES[{RECORD!r}] (sequence word and {len(record.fields)} fields, "
        f"{record.struct.size} bytes)",
        "read_tries": contract.READ_TRIES,
        "counted": counted,
        "record_read": whole,
        "writes": writes,
        "counted_seconds": middle - started,
        "record_read_seconds": ended - middle,
        "writes_per_s_while_counted": (writes_middle - writes_before) / (middle - started),
        "writes_per_s_while_record_read": (writes_after - writes_middle) / (ended - middle),
        "writer_exit": child.returncode if child is not None else None,
        "generated": generated,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reads", type=int, default=READS)
    parser.add_argument("--record-reads", type=int, default=RECORD_READS)
    parser.add_argument("--generated-cycles", type=int, default=GENERATED_CYCLES)
    parser.add_argument("--writer", metavar="SEGMENT", help=argparse.SUPPRESS)
    parser.add_argument("--command-writer", metavar="SEGMENT", help=argparse.SUPPRESS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    if args.writer:
        return writer(args.writer)
    if args.command_writer:
        return command_writer(args.command_writer)
    started = time.perf_counter()
    results = stress(args.reads, args.record_reads, args.generated_cycles)
    results["seconds"] = time.perf_counter() - started
    write_json(args.json, results)
    counted, whole = results["counted"], results["record_read"]
    generated = results["generated"]
    ok = counted["torn_accepted"] == 0 and whole["torn_accepted"] == 0
    bad = ("inconsistent_accepted", "older_accepted", "acted_before_first_whole_read")
    ok = ok and not any(generated.get(key) for key in bad)
    ok = ok and generated.get("writer_exit", 0) == 0
    return 0 if ok and results["writer_exit"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
