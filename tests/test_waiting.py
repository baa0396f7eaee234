"""The suite's own ways of waiting on a running system (tests/conftest.py): `read_whole`, a
record read that outlasts a writer descheduled mid-write, as happens on a busy host.
"""

from __future__ import annotations

import threading
from struct import Struct

import pytest
from conftest import read_whole

from rcsgen.runtime.contract import SEQ, Record, StaleRead, next_odd

RECORD = Record(Struct("<Qqd"), 8, ("n", "x"))


def mid_write(buf: memoryview) -> int:
    """A fake writer's first store: the sequence word odd, the fields half written."""
    seq = next_odd(RECORD.seq(buf))
    SEQ.pack_into(buf, RECORD.offset, seq)
    RECORD.struct.pack_into(buf, RECORD.offset, seq, 2, 0.0)
    return seq


def test_a_record_held_mid_write_is_read_once_its_writer_finishes() -> None:
    """A writer stops between its two stores (descheduled): a bare read gives up at once,
    `read_whole` reads again until the writer's second store, and returns that write."""
    buf = memoryview(bytearray(32))
    RECORD.write(buf, n=1, x=0.5)
    seq = mid_write(buf)
    with pytest.raises(StaleRead):
        RECORD.read(buf)
    held = threading.Event()

    def finish() -> None:  # the writer scheduled again, a moment later
        held.wait(0.1)
        RECORD.struct.pack_into(buf, RECORD.offset, seq, 2, 2.5)
        SEQ.pack_into(buf, RECORD.offset, seq + 1)

    writer = threading.Thread(target=finish)
    writer.start()
    try:
        assert read_whole(RECORD, buf) == {"n": 2, "x": 2.5}
    finally:
        held.set()
        writer.join()


def test_a_record_whose_writer_died_mid_write_fails_naming_it() -> None:
    buf = memoryview(bytearray(32))
    RECORD.write(buf, n=1, x=0.5)
    mid_write(buf)
    with pytest.raises(AssertionError, match="the record at offset 8 whole.*being written"):
        read_whole(RECORD, buf, deadline=0.05)
