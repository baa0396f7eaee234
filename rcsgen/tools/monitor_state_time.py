"""The monitor's time-per-state panel: for each controller, the share of its cycles since
start spent in each state, the second paper's "% of execution time per state".

A row per controller that keeps a state clock (the layout's TIME_IN_STATE), in the tree's
order: the cycles counted and its states by share, largest first (NOP, idle, included), the
state it is in now in bold. It reads only the console's snapshot (`time_in_state` and
`state_cycles` of each module, what `ctl status` prints as "time in state"), so it costs the
monitor nothing more on the segment. A module not counted yet (its process not started, or
a stand-in running in its place) shows "-".
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from rich.text import Text

from .monitor_rows import RowsPanel

COLUMNS = (
    ("module", "module"),
    ("cycles", "cycles"),
    ("states", "% of cycles per state since start"),
)
SHOWN = 6  # states shown per row, largest shares first; the rest summed as "others"


def row_of(name: str, row: dict[str, Any]) -> dict[str, Text]:
    """A controller's cells from its line of the snapshot."""
    shares: dict[str, float] = row.get("time_in_state") or {}
    if not shares:
        return {"module": Text(name), "cycles": Text("-"), "states": Text("-")}
    ranked = sorted(shares.items(), key=lambda item: -item[1])
    states = Text()
    for i, (state, share) in enumerate(ranked[:SHOWN]):
        if i:
            states.append("  ")
        states.append(f"{state} {share:g}%", style="bold" if state == row.get("state") else "")
    rest = sum(share for _, share in ranked[SHOWN:])
    if rest:
        states.append(f"  others {rest:.1f}%", style="grey50")
    return {"module": Text(name), "cycles": Text(str(row.get("state_cycles", 0))), "states": states}


class StateTimePanel(RowsPanel):
    """One row per controller with a state clock; `show` redraws from a console snapshot."""

    def __init__(self, layout: ModuleType, order: list[str]) -> None:
        clocks = getattr(layout, "TIME_IN_STATE", {})
        super().__init__("state_time", [m for m in order if m in clocks], COLUMNS)

    def show(self, snapshot: dict[str, Any]) -> None:
        """Each controller's row from its line of the console's snapshot."""
        modules = snapshot.get("modules") or {}
        for name in self.names:
            self.draw(name, row_of(name, modules.get(name) or {}))
