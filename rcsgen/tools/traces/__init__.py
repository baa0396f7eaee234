"""Trace tools: a trace `rcsgen run` wrote -> what a person reads in it.

In: trace files (JSON Lines, one line per cycle: a full line now and then, the changes in
between, as `stored` says) and, when at hand, the IR of the system that recorded them.
`read` reads and checks a trace (`TraceError`, one located line) and lays its modules out
in execution order (`lanes`); on top of it, `changes` prints only what
changed (`rcsgen trace changes`), `coverage` counts the table rules that fired (`rcsgen
trace coverage`), `view` writes the HTML timeline (`rcsgen trace show`) and `mine` the
miner's replay in its coal map (`rcsgen trace mine`); `assets/` holds their two pages.

The names below are `read`'s and `stored`'s, the package's entry points.
"""

from .read import (
    CUT,
    TIMING,
    Lane,
    Trace,
    TraceError,
    beside,
    check_against,
    compressed,
    decompressed,
    full_lines,
    is_timing,
    lanes,
    load,
    parse,
    recorded_by,
    select,
    whole_system,
)
from .stored import KEYFRAME, Condenser, condensed, expanded

__all__ = [
    "CUT",
    "KEYFRAME",
    "Condenser",
    "TIMING",
    "Lane",
    "Trace",
    "TraceError",
    "beside",
    "check_against",
    "compressed",
    "condensed",
    "decompressed",
    "expanded",
    "full_lines",
    "is_timing",
    "lanes",
    "load",
    "parse",
    "recorded_by",
    "select",
    "whole_system",
]
