"""Ice keels generated before the run (second paper, section 4.3.2: "The ice keels are
generated randomly, in their sizes and shapes, and continuously throughout the paths";
4.6.5: "The ice keel and sea bottom profiles were generated using fractals").

The run's `ice_seed` fixes them: keels are placed one after another along every leg of the
planned path (a random spacing, a random offset either side of the track), each of a
random size, and each outline is fractal: its radius around the keel's centre is made by
midpoint displacement, every level halving the spacing of the points and the roughness.
The same seed gives the same keels, point for point.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

SPACING = (900.0, 1500.0)  # m along the track from one keel to the next
OFFSET = 350.0  # m: the most a keel's centre lies off the track, either side
SIZE = (40.0, 110.0)  # m: a keel's mean radius
CLEAR_START = 800.0  # m: no keel this near where the path starts (the ship is there)
CORNERS = 6  # points of the coarsest outline
LEVELS = 3  # midpoint displacements: 6, 12, 24, 48 points
ROUGHNESS = 0.35  # the first level's displacement, a fraction of the mean radius


@dataclass(frozen=True)
class Keel:
    """An ice keel in plan: its outline's points (x east, y north, metres), and the circle
    around them (centre and reach), which the sonar tests first."""

    points: tuple[tuple[float, float], ...]
    x: float
    y: float
    reach: float


def outline(rng: random.Random, radius: float) -> list[float]:
    """A closed fractal outline: the radius at CORNERS * 2**LEVELS equal angles."""
    radii = [radius * (1.0 + rng.uniform(-0.25, 0.25)) for _ in range(CORNERS)]
    for level in range(1, LEVELS + 1):
        step = ROUGHNESS * radius / 2 ** (level - 1)
        finer: list[float] = []
        for i, r in enumerate(radii):
            following = radii[(i + 1) % len(radii)]
            finer += [r, max(0.3 * radius, (r + following) / 2 + rng.uniform(-step, step))]
        radii = finer
    return radii


def keel_at(rng: random.Random, x: float, y: float) -> Keel:
    """A keel of random size and fractal shape centred at (x, y)."""
    radii = outline(rng, rng.uniform(*SIZE))
    turn = rng.uniform(0.0, 2 * math.pi)
    points = tuple(
        (
            round(x + r * math.sin(turn + 2 * math.pi * i / len(radii)), 2),
            round(y + r * math.cos(turn + 2 * math.pi * i / len(radii)), 2),
        )
        for i, r in enumerate(radii)
    )
    return Keel(points, x, y, max(radii))


def generate(seed: int, path: list[tuple[float, float]]) -> list[Keel]:
    """The keels along `path` (its points in order, the first where the ship starts)."""
    rng = random.Random(seed)
    keels = []
    travelled = 0.0
    mark = rng.uniform(*SPACING)
    for (x0, y0), (x1, y1) in zip(path, path[1:], strict=False):
        length = math.hypot(x1 - x0, y1 - y0)
        if length == 0.0:
            continue
        ux, uy = (x1 - x0) / length, (y1 - y0) / length
        while mark < travelled + length:
            along, side = mark - travelled, rng.uniform(-OFFSET, OFFSET)
            if mark >= CLEAR_START:
                keels.append(keel_at(rng, x0 + along * ux + side * uy, y0 + along * uy - side * ux))
            mark += rng.uniform(*SPACING)
        travelled += length
    return keels


def ray_to(keel: Keel, x: float, y: float, ux: float, uy: float, limit: float) -> float:
    """Distance along the ray from (x, y) in direction (ux, uy) to the keel's outline, if
    nearer than `limit`; else `limit` (0 from inside the keel)."""
    cx, cy = keel.x - x, keel.y - y
    along = cx * ux + cy * uy
    if cx * cx + cy * cy - along * along > keel.reach**2 or along + keel.reach < 0.0:
        return limit
    if inside(keel, x, y):
        return 0.0
    best = limit
    points = keel.points
    for (ax, ay), (bx, by) in zip(points, points[1:] + points[:1], strict=True):
        ex, ey = bx - ax, by - ay
        cross = ux * ey - uy * ex
        if cross == 0.0:
            continue
        t = ((ax - x) * ey - (ay - y) * ex) / cross  # along the ray
        s = ((ax - x) * uy - (ay - y) * ux) / cross  # along the edge
        if 0.0 <= s <= 1.0 and 0.0 <= t < best:
            best = t
    return best


def inside(keel: Keel, x: float, y: float) -> bool:
    """Whether (x, y) lies within the keel's outline (even-odd rule)."""
    hit = False
    points = keel.points
    for (ax, ay), (bx, by) in zip(points, points[1:] + points[:1], strict=True):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            hit = not hit
    return hit


def edge_distance(keel: Keel, x: float, y: float) -> float:
    """Distance from (x, y) to the keel's outline; negative inside it."""
    best = math.inf
    points = keel.points
    for (ax, ay), (bx, by) in zip(points, points[1:] + points[:1], strict=True):
        ex, ey = bx - ax, by - ay
        t = max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)))
        best = min(best, math.hypot(ax + t * ex - x, ay + t * ey - y))
    return -best if inside(keel, x, y) else best
