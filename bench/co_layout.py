"""What the hand-written versions of co share: codes, and reading several fields at once.

The hand-written controllers use the same block as the generated one: the offsets and
buffer structs come from the generated `miner.layout` (bench_co.py builds the package from
bench/co_spec and puts it on sys.path). The codes below are the ones rcsgen assigns
(NONE=0, INIT=1, HALT=2, then the declared commands; NOP=0, then S0=1...), as a C
programmer would copy them from the shared header.
"""

from __future__ import annotations

from struct import Struct

# Status codes (QQ1.h qq1_responses) and the idle state.
NOT_READY, EXECUTING, DONE, ERROR = 0, 1, 2, 3
NOP = 0
# Commands co accepts.
INIT, HALT, SUMP_SHEAR_CUSP = 1, 2, 3
# Commands co sends: the same codes INIT and HALT for every subordinate, then their own.
CR_SUMP, CR_SHEAR, CR_CUSP = 3, 4, 5
VG_TRAM_TO_XY = 3
CC_SUMP, CC_SHEAR, CC_SHEAR_CORRECT, CC_CUSP = 3, 4, 5, 6
# States of co's tables.
S0, S1, S2, S3, S4 = 1, 2, 3, 4, 5

LOOSE_COAL_LIMIT = 4.0
# The world fields co reads, in block order (tail_in_position, between them, is not one).
WORLD_READS = ("popped_out_of_shear", "loose_coal", "pose_x", "pose_y", "heading")


# A status buffer's head: what a supervisor reads of it (and the plant writes).
STATUS_HEAD = Struct("<QQI")  # seq, status_num, status
SEQ_SIZE = 8  # every buffer starts with its 64-bit sequence word (the seqlock)


def gather(*parts: tuple[int, Struct] | tuple[int, Struct, bool]) -> tuple[Struct, int]:
    """One Struct that reads several buffers (offset, struct), given in block order, in one
    call, skipping the bytes between them; returns it with the offset to read it at.

    Each struct is a whole buffer, its sequence word first. The word is skipped (inputs
    written in the same process need no check) unless the part says (offset, struct, True):
    then it is read too, a value before the buffer's fields (a writer needs the words of
    the buffers it writes)."""
    start = at = parts[0][0]
    fmt = "<"
    for offset, struct, *with_seq in parts:
        seqs = bool(with_seq and with_seq[0])
        if offset < at:
            raise ValueError(f"buffers out of order or overlapping at offset {offset}")
        if offset > at:
            fmt += f"{offset - at}x"
        body = struct.format.lstrip("<")
        if not seqs:
            if not body.startswith("Q"):
                raise ValueError(f"no sequence word at the start of {struct.format!r}")
            body = f"{SEQ_SIZE}x" + body[1:]
        fmt += body
        at = offset + struct.size
    return Struct(fmt), start
