"""The cyclic garbage collector held off while the compiler works.

The front end and the render make millions of small objects, most of which live until the
build ends, and (since the solver's closures no longer form cycles) almost none of them is
cyclic garbage: the collector's passes over an ever larger heap cost a build of 1,000
controllers ~15 % of its time and freed nothing that reference counting did not. Measured
with `gc.callbacks` and `gc.DEBUG_SAVEALL` on bench/synthetic.py's systems: no cyclic garbage
left by the front end, a few objects per file by Jinja's macros in the render. `rcsgen prove`
holds it off too: its models are tens of thousands of small tuples, all alive until the end,
which every collection walked again (nearly half the time of an exploration). Whatever cyclic
garbage is made meanwhile is collected once it is back on.
"""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator


@contextlib.contextmanager
def no_collections() -> Iterator[None]:
    """Run no cyclic collection inside (the collector's state restored on the way out)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()
