"""Helm's jobs: the course to a goal, and the ice assessment from the 14 sonar beams.

The paper's Helm evaluates the sonar data with a CMAC (Cerebellar Model Articulation
Controller) that "receives the data, generalizes for an estimated ice distribution map,
stores the map in the control world model, and computes an ice avoidance recommended
heading by taking into account the desired course"; the ice problem flag is raised when the
recommendation differs from the desired course (second paper, section 4.3.2). `Cmac` is that
map: TILINGS overlapping grids of TILE-metre tiles over the sea, each offset from the last,
whose weights are trained every cycle by the least-mean-squares rule on the sonar's
samples (1 where a beam meets ice, 0 along the water it crossed), so a point's estimate is
the sum of the weights of the tiles that cover it and generalizes over TILE metres. It is
Helm's hook state, kept for the whole run. A heading is blocked when the map's ice lies in
the ship's corridor along it within the danger range; the recommendation is the unblocked
heading nearest the course.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

BEAMS = [-39.0 + 6.0 * i for i in range(14)]  # degrees off the centre line, port negative
DANGER_RANGE = 700.0  # metres ahead that count
HALF_WIDTH = 150.0  # metres either side of the track that must be clear
SEARCH_STEP = 2.0  # degrees between the headings tried
SEARCH_LIMIT = 80.0  # degrees either side of the course
PASSAGE_LIMIT = 20.0  # degrees: a clear heading further off the course is no passage to it


LOOKAHEAD = 600.0  # metres along the track ahead of the ship's nearest point on it
SONAR_RANGE = 900.0  # metres: a beam's range when it detects nothing
TILINGS = 8  # the CMAC's overlapping grids
TILE = 80.0  # metres: a tile's side, the map's generalization width
LEARN = 0.5  # the least-mean-squares rate
WATER_STEP = 60.0  # metres between the open-water samples along a beam
ICE = 0.5  # an estimate above this is ice
GRID = 30.0  # metres between the points the map is read at, in tiles that hold ice
MARK = ICE / TILINGS / 2  # a first-tiling weight above this may be ice: its tile is read
# each tiling's offset east and north, metres (the grids overlap, shifted from each other)
OFFSETS = [(k, k * TILE / TILINGS, (3 * k % TILINGS) * TILE / TILINGS) for k in range(TILINGS)]


@dataclass
class Cmac:
    """The estimated ice map: tile -> weight, per tiling (sparse: the sea has no edge)."""

    weights: dict[tuple[int, int, int], float] = field(default_factory=dict)
    last: tuple[float, ...] = ()  # the ping trained on last (Helm assesses once or twice a cycle)
    marked: set[tuple[int, int, int]] = field(default_factory=set)  # first-tiling tiles > MARK
    near: tuple[tuple[float, float, float], list[tuple[float, float]]] | None = None  # read last

    def tiles(self, x: float, y: float) -> list[tuple[int, int, int]]:
        """The tile of each tiling that covers (x, y)."""
        floor = math.floor
        return [(k, floor((x + dx) / TILE), floor((y + dy) / TILE)) for k, dx, dy in OFFSETS]

    def estimate(self, x: float, y: float) -> float:
        """The map's ice estimate at (x, y): about 1 on ice, about 0 in open water."""
        return sum(self.weights.get(t, 0.0) for t in self.tiles(x, y))

    def train(self, x: float, y: float, target: float) -> None:
        """One least-mean-squares step of the tiles over (x, y) towards `target`."""
        tiles = self.tiles(x, y)
        weights = self.weights
        step = LEARN * (target - sum(weights.get(t, 0.0) for t in tiles)) / TILINGS
        if step != 0.0:
            self.near = None
            for t in tiles:
                weights[t] = weights.get(t, 0.0) + step
            first = tiles[0]
            if weights[first] > MARK:
                self.marked.add(first)
            else:
                self.marked.discard(first)

    def learn(self, x: float, y: float, heading: float, ranges: list[float]) -> None:
        """Train on one ping from (x, y): each beam's open water, then its ice if it met any;
        a ping already trained on (the same cycle's) is not trained on again."""
        ping = (x, y, heading, *ranges)
        if ping == self.last:
            return
        self.last = ping
        for offset, distance in zip(BEAMS, ranges, strict=True):
            bearing = math.radians(heading + offset)
            ux, uy = math.sin(bearing), math.cos(bearing)
            along = WATER_STEP
            while along < distance - TILE / 2:
                self.train(x + along * ux, y + along * uy, 0.0)
                along += WATER_STEP
            if distance < SONAR_RANGE:
                self.train(x + distance * ux, y + distance * uy, 1.0)

    def ice_near(self, x: float, y: float, reach: float) -> list[tuple[float, float]]:
        """The map's ice within `reach` metres of (x, y), as (east, north) offsets from it:
        read on a GRID over the first tiling's tiles that hold weight (the same place read
        again with no training between gives the same points, not read again)."""
        if self.near is not None and self.near[0] == (x, y, reach):
            return self.near[1]
        points = []
        for _, i, j in self.marked:
            if math.hypot((i + 0.5) * TILE - x, (j + 0.5) * TILE - y) > reach + TILE:
                continue  # no point of this tile is within reach
            steps = round(TILE / GRID)
            for a in range(steps):
                for b in range(steps):
                    px, py = (i + (a + 0.5) / steps) * TILE, (j + (b + 0.5) / steps) * TILE
                    if math.hypot(px - x, py - y) <= reach and self.estimate(px, py) > ICE:
                        points.append((px - x, py - y))
        self.near = ((x, y, reach), points)
        return points


def new_cmac(settings: dict[str, str]) -> Cmac:
    """An empty ice map: Helm has seen no ice when the run starts."""
    return Cmac()


def course_to(x: float, y: float, pos_x: float, pos_y: float) -> float:
    """The true bearing from the ship to the goal, degrees clockwise from north, [0, 360)."""
    return round(math.degrees(math.atan2(x - pos_x, y - pos_y)) % 360.0, 6)


def track_course(
    cmac: Cmac, x: float, y: float, start_x: float, start_y: float, pos_x: float, pos_y: float
) -> float:
    """The course along the track from (start_x, start_y) to the goal (x, y): towards the
    point LOOKAHEAD metres on from the ship's nearest point on the track, or towards the
    goal once that point would lie past it. Off the track, the course cuts back onto it,
    more steeply the further off (about 14 degrees at 150 m)."""
    track_x, track_y = x - start_x, y - start_y
    length = math.hypot(track_x, track_y)
    if length == 0.0:
        return course_to(x, y, pos_x, pos_y)
    unit_x, unit_y = track_x / length, track_y / length
    along = (pos_x - start_x) * unit_x + (pos_y - start_y) * unit_y + LOOKAHEAD
    if along >= length:
        return course_to(x, y, pos_x, pos_y)
    return course_to(start_x + along * unit_x, start_y + along * unit_y, pos_x, pos_y)


def _blocked(heading: float, points: list[tuple[float, float]]) -> bool:
    """Whether a detection (east, north offsets from the ship) lies in the corridor."""
    h = math.radians(heading)
    ahead_x, ahead_y = math.sin(h), math.cos(h)
    for dx, dy in points:
        forward = dx * ahead_x + dy * ahead_y
        lateral = dx * ahead_y - dy * ahead_x
        if 0.0 < forward < DANGER_RANGE and abs(lateral) < HALF_WIDTH:
            return True
    return False


def assess_ice(
    cmac: Cmac,
    course: float,
    pos_x: float,
    pos_y: float,
    heading: float,
    b00: float, b01: float, b02: float, b03: float, b04: float, b05: float, b06: float,
    b07: float, b08: float, b09: float, b10: float, b11: float, b12: float, b13: float,
) -> tuple[int, float]:  # fmt: skip
    """Train the ice map on this ping; then, from the map, (1 if the course is blocked by
    ice, 2 if every heading within PASSAGE_LIMIT of it is too, else 0; the recommended
    heading)."""
    ranges = [b00, b01, b02, b03, b04, b05, b06, b07, b08, b09, b10, b11, b12, b13]
    cmac.learn(pos_x, pos_y, heading, ranges)
    points = cmac.ice_near(pos_x, pos_y, math.hypot(DANGER_RANGE, HALF_WIDTH))
    if not _blocked(course, points):
        return 0, course
    step = SEARCH_STEP
    while step <= SEARCH_LIMIT:
        for sign in (1.0, -1.0):  # starboard first on a tie
            candidate = (course + sign * step) % 360.0
            if not _blocked(candidate, points):
                # far off the course: no passage, unless the ship is already on a clear heading
                # (the map remembers a keel alongside, which blocks the course until passed)
                far = step > PASSAGE_LIMIT and _blocked(heading, points)
                return 2 if far else 1, round(candidate, 6)
        step += SEARCH_STEP
    return 2, round((course + SEARCH_LIMIT) % 360.0, 6)
