"""The mission planner: a route file of waypoints -> the command controller's plan.

A route file has one waypoint a line, `X Y` in metres (x east, y north), or `X Y AX AY`: the
waypoint and its alternate, the waypoint to make for instead when the leg to it is blocked;
`#` starts a comment. The paper's planned path is generated off-line and given to the
controller before the transit (second paper, section 4.3.2, Figure 19): here it is the run's
`route` setting, and the plan `route` of `cc` (docs/spec.md section 16).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

SYSTEM_DIR = Path(__file__).resolve().parent.parent
DEFAULT_ROUTE = "maps/bering.route"

Point = tuple[float, float]


@dataclass
class Mission:
    """The route, each waypoint's alternate (if any), and the plan last given to `cc`."""

    route: list[Point]
    alternates: dict[Point, Point] = field(default_factory=dict)
    plan: list[Point] = field(default_factory=list)


def load_route(path: Path) -> Mission:
    """The waypoints of a route file, in order, with their alternates."""
    mission = Mission([])
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].split()
        if not text:
            continue
        shape = "X Y AX AY" if len(text) == 4 else "X Y"
        x, y, *alternate = numbers(path, number, text, shape)
        mission.route.append((x, y))
        if alternate:
            mission.alternates[(x, y)] = (alternate[0], alternate[1])
    return mission


def numbers(path: Path, number: int, text: list[str], shape: str) -> tuple[float, ...]:
    """The numbers of one line of a route or keel file; a located error if it is not `shape`."""
    try:
        values = tuple(float(word) for word in text)
    except ValueError:
        values = ()
    if len(values) != len(shape.split()) or not all(map(math.isfinite, values)):
        raise ValueError(f"{path}:{number}: expected `{shape}` (numbers), got {' '.join(text)!r}")
    return values


def new_mission(settings: dict[str, str]) -> Mission:
    """The mission of the run's `route` setting (relative to the system directory)."""
    return load_route(SYSTEM_DIR / settings.get("route", DEFAULT_ROUTE))


def plan_route(mission: Mission, step: int, steps: int) -> list[Point]:
    """The plan: the route itself when there is none yet (`steps` 0); for a replan, the
    rest of the plan from the blocked step `step`, with the blocked waypoint replaced by its
    alternate (without one, the same waypoint is tried again)."""
    if steps == 0:
        mission.plan = list(mission.route)
    else:
        rest = mission.plan[step:]
        alternate = mission.alternates.get(rest[0]) if rest else None
        mission.plan = [alternate, *rest[1:]] if alternate else rest
    return list(mission.plan)
