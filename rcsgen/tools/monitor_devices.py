"""The monitor's devices panel: each fieldbus device of a running system, one row each.

A system that declares `io:` (docs/io.md) shows, under the monitor's world table, a row per
device: where it is, its state as an operator reads it (up, stale, lost; connecting,
stopped), its reads, writes, timeouts, retries and errors, the last error it had, and how
long ago it last answered. It reads only what the console's snapshot already holds (each
device's record, `ctl status --format json` under `io`), so it costs the monitor nothing
more on the segment. `stale` is a device still online whose last good answer is older than
two of its polls: its inputs are getting old, it is not lost yet.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from rich.text import Text

from .monitor_rows import RowsPanel

COLUMNS = (
    ("device", "device"),
    ("where", "protocol, address"),
    ("state", "state"),
    ("reads", "reads"),
    ("writes", "writes"),
    ("timeouts", "timeouts"),
    ("retries", "retries"),
    ("errors", "errors"),
    ("last_error", "last error"),
    ("answered", "answered"),
)
STYLES = {"up": "green", "stale": "yellow", "lost": "bold red"}
LATE_POLLS = 2  # polls without a good answer before an online device shows as stale


def seen_as(device: dict[str, Any]) -> str:
    """The state an operator reads: up, stale (online, answers late), lost, connecting,
    stopped (the record's own states otherwise)."""
    state = str(device.get("state", "?"))
    if state == "ONLINE":
        age, poll = device.get("last_answer_age_s"), device.get("poll_period_s") or 0.0
        late = age is None or age > LATE_POLLS * poll
        return "stale" if late else "up"
    return state.lower()


def row_of(name: str, device: dict[str, Any]) -> dict[str, Text]:
    """A device's cells, coloured by the state an operator reads."""
    shown = seen_as(device)
    style = STYLES.get(shown, "grey50")
    age = device.get("last_answer_age_s")
    error = str(device.get("last_error", "?"))
    cells = {
        "device": name,
        "where": f"{device.get('protocol', '?')} {device.get('address', '?')}",
        "state": shown,
        **{key: str(device.get(key, "?")) for key in ("reads", "writes", "timeouts")},
        **{key: str(device.get(key, "?")) for key in ("retries", "errors")},
        "last_error": "-" if error == "none" else error,
        "answered": "never" if age is None else f"{age:.2f}s ago",
    }
    return {
        key: Text(value, style=style if key in ("device", "state") else "")
        for key, value in cells.items()
    }


class DevicesPanel(RowsPanel):
    """One row per device of the layout; `show` redraws from a console snapshot's `io`."""

    def __init__(self, layout: ModuleType) -> None:
        super().__init__("devices", list(getattr(layout, "IO_DEVICES", {})), COLUMNS)

    def show(self, io: dict[str, dict[str, Any]]) -> None:
        """Each device's row from its record as the console read it (a record that stayed
        unreadable shows `?`)."""
        for name in self.names:
            self.draw(name, row_of(name, io.get(name) or {"state": "?"}))
