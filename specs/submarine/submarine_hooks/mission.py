"""The mission plan: a route file of waypoints -> the command controller's next waypoint.

A route file has one waypoint a line, `X Y` in metres (x east, y north); `#` starts a
comment. The paper's planned path is generated off-line and given to the controller before
the transit (second paper, section 4.3.2, Figure 19): here it is the run's `route` setting.
"""

from __future__ import annotations

import math
from pathlib import Path

SYSTEM_DIR = Path(__file__).resolve().parent.parent
DEFAULT_ROUTE = "maps/bering.route"


def load_route(path: Path) -> list[tuple[float, ...]]:
    """The waypoints of a route file, in order."""
    points = []
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].split()
        if text:
            points.append(numbers(path, number, text, "X Y"))
    return points


def numbers(path: Path, number: int, text: list[str], shape: str) -> tuple[float, ...]:
    """The numbers of one line of a route or keel file; a located error if it is not `shape`."""
    try:
        values = tuple(float(word) for word in text)
    except ValueError:
        values = ()
    if len(values) != len(shape.split()) or not all(map(math.isfinite, values)):
        raise ValueError(f"{path}:{number}: expected `{shape}` (numbers), got {' '.join(text)!r}")
    return values


def new_mission(settings: dict[str, str]) -> list[tuple[float, ...]]:
    """The route of the run's `route` setting (relative to the system directory)."""
    return load_route(SYSTEM_DIR / settings.get("route", DEFAULT_ROUTE))


def waypoint(route: list[tuple[float, ...]], leg: int) -> tuple[float, float, bool]:
    """Waypoint number `leg` (from 0) and whether there is one; past the end: (0, 0, False)."""
    if 0 <= leg < len(route):
        x, y = route[leg]
        return x, y, True
    return 0.0, 0.0, False
