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


def gather(*parts: tuple[int, Struct]) -> tuple[Struct, int]:
    """One Struct that reads several buffers (offset, struct), given in block order, in one
    call, skipping the bytes between them; returns it with the offset to read it at."""
    start = at = parts[0][0]
    fmt = "<"
    for offset, struct in parts:
        if offset < at:
            raise ValueError(f"buffers out of order or overlapping at offset {offset}")
        if offset > at:
            fmt += f"{offset - at}x"
        fmt += struct.format.lstrip("<")
        at = offset + struct.size
    return Struct(fmt), start
