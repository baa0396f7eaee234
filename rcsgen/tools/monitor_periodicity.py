"""The monitor's periodicity panel: how well each process holds its period, one row each.

Under the modules (and the devices), a row per process: its period, the paced wake-ups it
measured, the period error (mean and max of |time between two wake-ups - the period|), the
wake-up lateness (p99 of the last 4096 and max), the throttled lateness warnings it wrote,
its cycle time (last, max) and its slowest module by longest cycle (each module's own
cycle times are in the modules table). A process that is not paced (lockstep, flat out)
says so. It reads only the console's snapshot (the control records, `ctl status --format
json` under `processes.*.periodicity`), so it costs the monitor nothing more on the segment.
A p99 lateness over half the period is shown in red: the process wakes up late often
enough that its period does not hold.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from rich.text import Text

from ..runtime.operate.ctl import slowest_modules
from .monitor_rows import RowsPanel

COLUMNS = (
    ("process", "process"),
    ("period", "period"),
    ("wakeups", "wake-ups"),
    ("error", "period error mean/max us"),
    ("lateness", "lateness p99/max us"),
    ("warnings", "warnings"),
    ("cycle", "cycle last/max us"),
    ("slowest", "slowest module (max us)"),
)
LATE_SHARE = 0.5  # a p99 lateness over this share of the period is shown in red


def row_of(name: str, proc: dict[str, Any], slowest: tuple[str, float] | None) -> dict[str, Text]:
    """A process's cells; the lateness red when its p99 passes LATE_SHARE of the period."""
    figures = proc.get("periodicity")
    module = "-" if slowest is None else f"{slowest[0]} ({slowest[1]:g})"
    cycle = f"{proc.get('last_cycle_us', '?')}/{proc.get('max_cycle_us', '?')}"
    if proc.get("state") == "?":
        cells = dict.fromkeys((key for key, _ in COLUMNS), "?")
        cells["process"] = name
        return {key: Text(value, style="grey50") for key, value in cells.items()}
    if figures is None:
        cells = {"process": name, "period": "not paced", "wakeups": "-", "error": "-"}
        cells |= {"lateness": "-", "warnings": "-", "cycle": cycle, "slowest": module}
        return {key: Text(value) for key, value in cells.items()}
    late = figures["lateness_p99_us"] > LATE_SHARE * figures["period_ms"] * 1e3
    cells = {
        "process": name,
        "period": f"{figures['period_ms']:g} ms",
        "wakeups": str(figures["wakeups"]),
        "error": f"{figures['period_error_mean_us']:g}/{figures['period_error_max_us']:g}",
        "lateness": f"{figures['lateness_p99_us']:g}/{figures['lateness_max_us']:g}",
        "warnings": str(figures["lateness_warnings"]),
        "cycle": cycle,
        "slowest": module,
    }
    return {
        key: Text(value, style="bold red" if late and key in ("process", "lateness") else "")
        for key, value in cells.items()
    }


class PeriodicityPanel(RowsPanel):
    """One row per process of the layout; `show` redraws from a console snapshot."""

    def __init__(self, layout: ModuleType) -> None:
        super().__init__("periodicity", list(layout.PROCESSES), COLUMNS)

    def show(self, snapshot: dict[str, Any]) -> None:
        """Each process's row from its control record as the console read it."""
        slowest = slowest_modules(snapshot.get("modules") or {})
        processes = snapshot.get("processes") or {}
        for name in self.names:
            self.draw(name, row_of(name, processes.get(name) or {"state": "?"}, slowest.get(name)))
