"""The cyclic garbage collector held off while the compiler works.

The front end and the render make millions of small objects, most of which live until the
build ends, and (since the solver's closures no longer form cycles) almost none of them is
cyclic garbage: the collector's passes over an ever larger heap cost a build of 1,000
controllers ~15 % of its time and freed nothing that reference counting did not. Measured
with `gc.callbacks` and `gc.DEBUG_SAVEALL` on bench/synthetic.py's systems: no cyclic garbage
left by the front end, a few objects per file by Jinja's macros in the render. `rcsgen prove`
holds it off too: its models are tens of thousands of small tuples, all alive until the end,
which every collection walked again (nearly half the time of an exploration).

On the way out the heap is frozen (`gc.freeze`) before the collector is back on: otherwise
the first allocation after the front end of 1,000 controllers walked its ~700,000 objects
(~0.35 s CPU), and later collections walked them again, to free nothing. The next
`no_collections` unfreezes them first (into the oldest generation). Freezing takes the
process's uncollected cyclic garbage along (the run's, and whatever the caller left in the
young generations), and the oldest generation is seldom collected in full: a process that
compiles again and again (the test suite, `make mutate-sample`'s one long coverage run, a
tool built on the API) grew without bound — the coverage run to 24 GiB, killed by the
kernel. So an unfreeze also collects in full once the heap (the allocator's blocks, cheap
to count: `gc.get_freeze_count` walks the frozen list, 8 ms a run in a test worker) has
doubled since the first freeze or the last such collection (as a growing array doubles): a
build (the front end, then the render) or a prove pays nothing, a long process a few
collections in all, and its garbage stays within what it keeps alive.
"""

from __future__ import annotations

import contextlib
import gc
import sys
from collections.abc import Iterator

GROWTH = 2  # a full collection once the heap is this many times what the last one left
_last = 0  # the heap (memory blocks) at the first freeze, or what the last collection left


@contextlib.contextmanager
def no_collections() -> Iterator[None]:
    """Run no cyclic collection inside (the collector's state restored on the way out, what
    is alive then frozen out of its way until the next `no_collections`)."""
    global _last
    enabled = gc.isenabled()
    gc.disable()
    if enabled and _last:
        gc.unfreeze()  # (what an earlier run froze: collectable again, in the oldest generation)
        if sys.getallocatedblocks() > GROWTH * _last:
            gc.collect()  # (the garbage frozen with it: see above)
            _last = sys.getallocatedblocks()  # (what survived: all alive)
    try:
        yield
    finally:
        if enabled:
            gc.freeze()
            gc.enable()
            _last = _last or sys.getallocatedblocks()
