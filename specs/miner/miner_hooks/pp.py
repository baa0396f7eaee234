"""Hooks of the path planner (pp): the coal map and the sensed pose -> the next waypoint.

The planner knows the mine as surveyed (the map file of the run's `map` setting, before any
cut): coal cells are obstacles, grown by the machine's half width so the path keeps the
machine clear of the ribs. A goal straight ahead or behind along the machine's heading is
reached directly (the moves in and out of the cut, which the survey does not know is open);
any other goal is searched for on the grid (A*, 8-connected), the path is reduced to its
corners, and the first corner is the next waypoint, no further than MAX_LEG away (so one
slow tram reaches it before the tram's time-out). Vehicle guidance trams there and asks
again from where it is: the plan is closed on the sensed pose at every waypoint.
"""

from __future__ import annotations

import heapq
import math
import os

from . import mine
from .rounding import round6

CLEARANCE = 1.3  # metres: free cells are this far from any coal cell (machine half width)
IN_LINE = 0.1  # metres: a goal this close to the line of the heading is reached directly
MAX_LEG = 2.5  # metres: the furthest waypoint of one tram


class Planner:
    """The surveyed map as a grid of free cells."""

    def __init__(self, x0: float, y0: float, free: set[tuple[int, int]]) -> None:
        self.x0, self.y0, self.free = x0, y0, free


def new_planner(settings: dict[str, str]) -> Planner:
    """The planner's grid, from the run's map (as the mine simulator loads it)."""
    surveyed = mine.load_map(os.path.join(mine.SYSTEM_DIR, settings.get("map", mine.DEFAULT_MAP)))
    rows = 1 + max((r for r, _ in surveyed.seam), default=0)
    columns = surveyed.columns
    reach = math.ceil(CLEARANCE / mine.CELL)
    # The offsets of the cells within the clearance of a cell: a cell is free when none of
    # them is coal. Each row of coal is one integer, bit c + reach for column c, so a row's
    # blocked cells are the OR of its neighbour rows shifted by each offset: a few thousand
    # integer operations. (Testing every cell's offsets in sets took 40-50 ms of every start
    # of the planner's process; growing every coal cell by them, a million set insertions.)
    disc = [
        (dr, dc)
        for dr in range(-reach, reach + 1)
        for dc in range(-reach, reach + 1)
        if math.hypot(dr, dc) * mine.CELL < CLEARANCE
    ]
    coal: dict[int, int] = {}
    for r, c in surveyed.seam:
        if c >= -reach:  # (a cell further left is no cell's neighbour)
            coal[r] = coal.get(r, 0) | 1 << (c + reach)
    everything = (1 << columns) - 1
    free = set()
    for r in range(rows):
        blocked = 0
        for dr, dc in disc:
            blocked |= coal.get(r + dr, 0) >> (dc + reach)
        open_cells = ~blocked & everything
        free.update((r, c) for c in range(columns) if open_cells >> c & 1)
    return Planner(surveyed.x0, surveyed.y0, free)


def _cell(p: Planner, x: float, y: float) -> tuple[int, int]:
    return math.floor((y - p.y0) / mine.CELL), math.floor((x - p.x0) / mine.CELL)


def _centre(p: Planner, cell: tuple[int, int]) -> tuple[float, float]:
    r, c = cell
    return p.x0 + (c + 0.5) * mine.CELL, p.y0 + (r + 0.5) * mine.CELL


def _search(p: Planner, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]]:
    """A* over the free cells (start and goal are taken as free); [] when there is no path."""
    free = p.free | {start, goal}
    todo = [(0.0, 0.0, start)]
    came: dict[tuple[int, int], tuple[int, int]] = {}
    cost = {start: 0.0}
    while todo:
        _, spent, at = heapq.heappop(todo)
        if at == goal:
            path = [at]
            while path[-1] in came:
                path.append(came[path[-1]])
            return path[::-1]
        if spent > cost.get(at, math.inf):
            continue
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                step = (at[0] + dr, at[1] + dc)
                if (dr or dc) and step in free:
                    new = spent + math.hypot(dr, dc)
                    if new < cost.get(step, math.inf):
                        cost[step], came[step] = new, at
                        guess = new + math.hypot(goal[0] - step[0], goal[1] - step[1])
                        heapq.heappush(todo, (guess, new, step))
    return []


def _corners(path: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The cells where the path changes direction, and its end."""
    out = []
    for i in range(1, len(path)):
        if i == len(path) - 1:
            out.append(path[i])
        else:
            before = (path[i][0] - path[i - 1][0], path[i][1] - path[i - 1][1])
            after = (path[i + 1][0] - path[i][0], path[i + 1][1] - path[i][1])
            if before != after:
                out.append(path[i])
    return out


def _clear(p: Planner, x: float, y: float, tx: float, ty: float) -> bool:
    """Whether the straight line from (x, y) to (tx, ty) keeps to free cells (the cells of
    both ends are taken as free)."""
    ends = {_cell(p, x, y), _cell(p, tx, ty)}
    steps = max(1, math.ceil(math.hypot(tx - x, ty - y) / (mine.CELL / 2)))
    for i in range(steps + 1):
        at = _cell(p, x + (tx - x) * i / steps, y + (ty - y) * i / steps)
        if at not in p.free and at not in ends:
            return False
    return True


def _towards(x: float, y: float, tx: float, ty: float) -> tuple[float, float, bool]:
    """(tx, ty), or the point MAX_LEG along the way to it; whether it is (tx, ty)."""
    d = math.hypot(tx - x, ty - y)
    if d <= MAX_LEG:
        return tx, ty, True
    k = MAX_LEG / d
    return round6(x + k * (tx - x)), round6(y + k * (ty - y)), False


def plan(
    p: Planner, x: float, y: float, heading: float, gx: float, gy: float
) -> tuple[bool, float, float, bool]:
    """(found, waypoint x, waypoint y, the waypoint is the goal) from the pose to the goal."""
    lateral = -(gx - x) * math.sin(heading) + (gy - y) * math.cos(heading)
    if abs(lateral) <= IN_LINE:
        wx, wy, reached = _towards(x, y, gx, gy)
        return True, wx, wy, reached
    start, goal = _cell(p, x, y), _cell(p, gx, gy)
    corners = _corners(_search(p, start, goal))
    if not corners:
        return False, x, y, False
    points = [_centre(p, c) for c in corners[:-1]] + [(gx, gy)]
    # the furthest corner in plain sight: fewer, longer trams than cell by cell
    seen = max(i for i, (cx, cy) in enumerate(points) if i == 0 or _clear(p, x, y, cx, cy))
    cx, cy = points[seen]
    wx, wy, reached = _towards(x, y, cx, cy)
    return True, wx, wy, reached and seen == len(points) - 1
