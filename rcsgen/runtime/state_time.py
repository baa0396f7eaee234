"""State time: how many cycles each controller has spent in each state since start.

The second paper's support facility reports the percentage of execution time per state; a
state table's cycle is its unit of execution time, so a clock per controller counts, for
each cycle of its process, one cycle for the state the controller ends the cycle in (its
`state`: NOP while idle), whatever its mode (a controller held by `stop` stays in its state,
and its time there goes on). The block holds, per controller and stand-in (`TIME_<NAME>`),
the state it is in, the process cycle it entered it (`since`) and the cycles spent in each
state code before that (NOP first, in STATE_NAMES order): it is written only when a
controller changes state, which a generated controller does only in a cycle that writes its
status record, telling its clock as it does (`on_state`, rcs/loop.py), so a cycle in which
no state changes costs nothing. A reader adds the open interval, the process's heartbeat
(cycles run) less `since` (`totals`). A restarted process closes the interval its
predecessor left open at that one's last heartbeat; a controller whose stand-in runs in its
place (or the stand-in, while it does not) has no open interval. Standard library only:
copied verbatim into every generated package.
"""

from __future__ import annotations

from struct import Struct
from typing import Any

from .contract import SEQ, StaleRead

PAUSED = -1  # `state` of a controller not running now: no open interval


class StateClock:
    """One controller's time in each state, as the block holds it."""

    __slots__ = ("at", "counts", "seq", "shape", "since", "state")

    def __init__(self, record: Any, buf: memoryview, cycles_before: int) -> None:
        self.at, self.shape = record.offset, Struct(record.struct.format)
        try:
            values = list(record.read(buf).values())
        except StaleRead:  # its writer died mid-write: the values as they are
            values = list(self.shape.unpack_from(buf, self.at)[1:])
        state, since, *counts = (int(v) for v in values)
        self.counts = counts
        if 0 <= state < len(counts):  # the interval a previous run of the process left open
            counts[state] += max(0, cycles_before - since)
        seq = record.seq(buf)
        self.seq = seq + (seq & 1)
        self.state, self.since = PAUSED, 0
        self.write(buf)

    def tick(self, buf: memoryview, state: int, cycle: int) -> None:
        """The controller ends process cycle `cycle` (from 0) in `state`."""
        if state != self.state:
            self.enter(buf, state, cycle)

    def enter(self, buf: memoryview, state: int, cycle: int) -> None:
        """The controller is in `state` from process cycle `cycle` (PAUSED: not running; a
        code it does not have is not counted either)."""
        if 0 <= self.state < len(self.counts):
            self.counts[self.state] += cycle - self.since
        self.state = state if 0 <= state < len(self.counts) else PAUSED
        self.since = cycle
        self.write(buf)

    def write(self, buf: memoryview) -> None:
        seq = self.seq + 1
        SEQ.pack_into(buf, self.at, seq)  # odd before any field changes
        self.shape.pack_into(buf, self.at, seq + 1, self.state, self.since, *self.counts)
        self.seq = seq + 1


def clocks(
    layout: Any, buf: memoryview, names: list[str], cycles_before: int
) -> dict[str, StateClock]:
    """The clock of each of `names` that has one (a package built before this runtime, or an
    operator module, has none). `cycles_before`: the cycles the process had run when it
    last beat (its heartbeat in the block), to close what a previous run left open."""
    records = getattr(layout, "TIME_IN_STATE", {})
    return {
        name: StateClock(records[name], buf, cycles_before) for name in names if name in records
    }


def totals(values: dict[str, int], heartbeat: int) -> dict[str, int]:
    """A time record as read (`state`, `since`, then a count per state) -> the cycles spent
    in each state, with the open interval up to the process's `heartbeat` (cycles run)."""
    found = {k: int(v) for k, v in values.items() if k not in ("state", "since")}
    state = int(values["state"])
    if 0 <= state < len(found):
        name = list(found)[state]
        found[name] += max(0, heartbeat - int(values["since"]))
    return found


def shares(counts: dict[str, int]) -> dict[str, float]:
    """Counts of cycles per state as the percentage of all counted cycles spent in each
    state that has any, in state order ({} before the first counted cycle)."""
    total = sum(counts.values())
    if not total:
        return {}
    return {state: round(100.0 * n / total, 1) for state, n in counts.items() if n}
