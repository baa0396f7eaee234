"""The mine: a 2-D coal/no-coal map cut by the drum (the environment simulator's hooks).

A map file has one character per 0.25 m square cell: rows run across the entry, columns
run inby along it; `#` is coal, `.` open. Each coal cell keeps how much of the seam height
is still standing (1.0 = the full seam, 0.0 = cut to the floor). The turning drum cuts
every cell it overlaps down to the drum's round bottom edge; the coal cut becomes loose
coal. A shear therefore leaves a wedge of floor coal either side of the drum's lowest point
(the cusp, mining paper section 2.1.2), which the drum takes when the machine trams back
with the drum at the floor. A cell with no more than a cusp's height standing is floor
coal, no longer part of the face.
"""

from __future__ import annotations

import math
import os
import random

from .rounding import round6

CELL = 0.25  # metres
DRUM_RADIUS = 0.5  # metres: the drum reaches this far either side of its centre
RADIUS_SQUARED = DRUM_RADIUS**2
DRUM_HALF_WIDTH = 1.6  # metres: the drum spans the entry
DRUM_HEIGHT = 0.4  # fraction of the seam the drum covers
ROOF_ANGLE, FLOOR_ANGLE = 30.0, -10.0  # degrees: drum top at the roof, bottom on the floor
SEAM_HEIGHT = 2.0  # metres
TONNES_PER_CELL = CELL * CELL * SEAM_HEIGHT * 1.3  # cell area x seam x 1.3 t/m3
FACE_MIN = 0.1  # fraction of the seam: a cell standing no higher is the cusp, not the face
CUT_THROUGH = 0.005  # fraction of the seam (1 cm): less than this left is cut to the floor
# (os.path, not pathlib, and plain classes, not dataclasses: each would add ~5 ms of imports
# to the start of every process that runs the mine or the planner)
SYSTEM_DIR = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
DEFAULT_MAP = "maps/box_cut.map"
SLIP_ERROR = 0.3  # the slide per cycle on a roll varies by this fraction (seeded)


class Mine:
    """The map's cells (standing seam fraction per coal cell) and where the face started."""

    def __init__(self, x0: float, y0: float) -> None:
        self.x0, self.y0 = x0, y0
        self.seam: dict[tuple[int, int], float] = {}  # (row, col) -> height
        self.first_face = 0.0
        self.columns = 0
        # row -> the first column with standing coal in it (rows cut through have none): what
        # `face` looks up instead of scanning the map every cycle; `cut_coal` keeps it current.
        self.first: dict[int, int] = {}
        # `roll X0 X1 SLIP` lines: where the seam floor rolls (slopes down outby) between X0
        # and X1 metres inby, the shear's cutting force slides the machine SLIP metres a cycle
        # outby
        self.rolls: list[tuple[float, float, float]] = []
        self.rng = random.Random(1)
        # What `cut_coal` keeps between calls so that a cycle costs only what changed (its
        # results stay exactly those of the plain walk over `seam`):
        # - grid: `seam` by row, a list indexed by column (-1.0 where there is no coal cell),
        #   made from `seam` with it, and again at a cut if `seam` has been replaced (a trace
        #   replay wraps it); the cut writes both. Rows without coal are not in it.
        self.grid: dict[int, list[float]] = {}
        self.grid_of: object = None
        # - the drum's levels per column for the last (x, boom angle): the same wherever it is
        self.levels_at: tuple[float, float] | None = None
        self.levels: list[tuple[int, float]] = []
        # - each column's wedge under the drum for the last x (what the levels add to the
        #   drum's lowest point; a shear moves only the boom)
        self.wedges_at: float | None = None
        self.wedges: list[tuple[int, float]] = []
        # - the face for the last band of rows (a y that moves less than a cell keeps it),
        #   forgotten when a cut moves a row's first coal
        self.face_at: tuple[range, float, float] | None = None  # rows, face, depth cut
        # - the last call's arguments and result, kept only if it cut nothing: the same drum
        #   in the same place then cuts nothing again, and finds the same face
        self.last_call: tuple[float, float, float, bool] | None = None
        self.last_result: tuple[bool, float, float, float] = (False, 0.0, 0.0, 0.0)
        # - the highest cell of each column across the rows of the drum's band, for the band
        #   `band_at` (None: none kept; a cut or a new grid forgets it)
        self.band_at: range | None = None
        self.band_max: list[float] = []


def load_map(path: str | os.PathLike[str]) -> Mine:
    """Read a map file; the first line `origin X Y` places column 0 and row 0."""
    with open(path, encoding="utf-8") as file:
        lines = [line.rstrip("\n") for line in file.read().splitlines()]
    rows = [line for line in lines if line and not line.startswith(("#!", "origin", "roll"))]
    origin = next((line.split() for line in lines if line.startswith("origin")), None)
    x0, y0 = (float(origin[1]), float(origin[2])) if origin else (0.0, 0.0)
    mine = Mine(x0, y0)
    for line in lines:
        if line.startswith("roll"):
            _, start, end, slip = line.split()
            mine.rolls.append((float(start), float(end), float(slip)))
    for r, row in enumerate(rows):
        for c, char in enumerate(row):
            if char == "#":
                mine.seam[(r, c)] = 1.0
    mine.columns = max((c for _, c in mine.seam), default=-1) + 1
    for r, c in sorted(mine.seam, reverse=True):
        mine.first[r] = c
    mine.first_face = face(mine, 0.0)
    _make_grid(mine)
    return mine


def new_mine(settings: dict[str, str]) -> Mine:
    """The mine of the run's `map` setting (relative to the system directory); the slide on
    a roll is seeded from the run's `seed`."""
    mine = load_map(os.path.join(SYSTEM_DIR, settings.get("map", DEFAULT_MAP)))
    mine.rng = random.Random(int(settings.get("seed", "1")))
    return mine


def slip(mine: Mine, x: float, boom_angle: float, jack_down: bool, cut: float) -> float:
    """How far the shear's cutting force slides the machine outby this cycle: on a roll of
    the seam floor, while the drum cuts below the roof with the jack down, the jack's foot
    and the treads lose their grip on the slope (with seeded error); elsewhere nothing."""
    shearing = jack_down and cut > 0.0 and boom_angle < ROOF_ANGLE - 0.5
    for start, end, amount in mine.rolls:
        if shearing and start <= x <= end:
            return round6(amount * (1.0 + mine.rng.uniform(-SLIP_ERROR, SLIP_ERROR)))
    return 0.0


def _span(low: float, high: float, origin: float) -> range:
    """The cells whose centres lie in [low, high] along one axis."""
    first = math.ceil((low - origin) / CELL - 0.5)
    last = math.floor((high - origin) / CELL - 0.5)
    return range(first, last + 1)


def _wedge(mine: Mine, x: float, column: int) -> float:
    """How far (seam fraction) the drum's round bottom is above its lowest point over the
    centre of `column`, for a drum centred at `x`: the cusp it leaves there."""
    offset = mine.x0 + (column + 0.5) * CELL - x
    rise = DRUM_RADIUS - math.sqrt(max(0.0, DRUM_RADIUS**2 - offset**2))
    return rise / SEAM_HEIGHT


def face(mine: Mine, y: float) -> float:
    """The inby distance of the first standing coal in the drum's band across the entry."""
    rows = _span(y - DRUM_HALF_WIDTH, y + DRUM_HALF_WIDTH, mine.y0)
    first = mine.first
    columns = [first[r] for r in rows if r in first]
    return mine.x0 + min(columns) * CELL if columns else float("inf")


def _cut_to_floor(mine: Mine, r: int, c: int) -> None:
    """Cell (r, c) is no longer face: if it was its row's first, the row's first moves on."""
    if mine.first.get(r) != c:
        return
    mine.face_at = None
    row = mine.grid[r]
    for after in range(c + 1, mine.columns):
        if row[after] > FACE_MIN:
            mine.first[r] = after
            return
    del mine.first[r]


def _make_grid(mine: Mine) -> None:
    """`grid` made again from `seam` (see Mine)."""
    mine.grid = {}
    for (r, c), standing in mine.seam.items():
        row = mine.grid.get(r)
        if row is None:
            row = mine.grid[r] = [-1.0] * mine.columns
        row[c] = standing
    mine.grid_of = mine.seam
    mine.band_at = None


def _levels(mine: Mine, x: float, boom_angle: float) -> list[tuple[int, float]]:
    """(column, the level the drum cuts it down to) for each map column under the drum: the
    level its round bottom reaches over a column is the same in every row, the drum's lowest
    point (from the boom angle) plus the column's wedge (from x alone: kept while x stays,
    as it does through a shear)."""
    height = (boom_angle - FLOOR_ANGLE) / (ROOF_ANGLE - FLOOR_ANGLE)
    bottom = max(0.0, min(1.0, height) * (1.0 - DRUM_HEIGHT))
    if mine.wedges_at != x:
        mine.wedges = _wedges(mine, x)
        mine.wedges_at = x
    levels = []
    for c, wedge in mine.wedges:
        level = bottom + wedge
        if level > 1.0:  # min(1.0, level): neither is ever NaN
            level = 1.0
        levels.append((c, 0.0 if level < CUT_THROUGH else level))
    return levels


def _wedges(mine: Mine, x: float) -> list[tuple[int, float]]:
    """(column, `_wedge` there) for each map column under a drum centred at `x`: `_wedge`
    written out, the same arithmetic."""
    wedges = []
    x0, columns = mine.x0, mine.columns
    for c in _span(x - DRUM_RADIUS, x + DRUM_RADIUS, x0):
        if 0 <= c < columns:  # no coal cell outside the map
            offset = x0 + (c + 0.5) * CELL - x
            wedges.append(
                (c, (DRUM_RADIUS - math.sqrt(max(0.0, RADIUS_SQUARED - offset**2))) / SEAM_HEIGHT)
            )
    return wedges


def _may_touch(mine: Mine, rows: range, levels: list[tuple[int, float]]) -> bool:
    """Whether any cell of `rows` stands above its column's level: False when each column's
    highest cell across the band (kept for the band until a cut) is no higher."""
    if mine.band_at != rows:
        band = [mine.grid[r] for r in rows if r in mine.grid]
        if not band:
            return False
        mine.band_max = list(map(max, *band)) if len(band) > 1 else band[0][:]
        mine.band_at = rows
    highest = mine.band_max
    for c, level in levels:
        if highest[c] > level:
            return True
    return False


def cut_coal(
    mine: Mine, x: float, y: float, boom_angle: float, drum_on: bool
) -> tuple[bool, float, float, float]:
    """Cut what the drum overlaps: (in contact, face position, depth cut, tonnes cut).

    The cells under the drum are visited row by row (the map's own order, so the tonnes
    add up in the same order). Between calls it keeps what has not changed (see Mine):
    the same call after one that cut nothing returns the same result at once."""
    call = (x, y, boom_angle, drum_on)
    if call == mine.last_call:
        return mine.last_result
    seam = mine.seam
    if mine.grid_of is not seam:
        _make_grid(mine)
    if mine.levels_at != (x, boom_angle):
        mine.levels = _levels(mine, x, boom_angle)
        mine.levels_at = (x, boom_angle)
    levels, grid = mine.levels, mine.grid
    rows = _span(y - DRUM_HALF_WIDTH, y + DRUM_HALF_WIDTH, mine.y0)
    contact, cut, tonnes = False, False, 0.0
    if _may_touch(mine, rows, levels):
        first = mine.first
        for r in rows:
            row = grid.get(r)
            if row is None:  # no coal in this row
                continue
            for c, level in levels:
                standing = row[c]  # -1.0: no coal cell there
                if standing > level:
                    contact = True
                    if drum_on:
                        cut = True
                        tonnes += (standing - level) * TONNES_PER_CELL
                        row[c] = level
                        seam[r, c] = level
                        if level <= FACE_MIN and first.get(r) == c:
                            _cut_to_floor(mine, r, c)
        if cut:  # every cell cut stands at its column's level now, none higher
            highest = mine.band_max
            for c, level in levels:
                if highest[c] > level:
                    highest[c] = level
    kept = mine.face_at
    if kept is None or kept[0] != rows:
        now = face(mine, y)  # (its rows are `rows`: the face is theirs alone)
        kept = mine.face_at = (rows, round6(now), round6(now - mine.first_face))
    result = contact, kept[1], kept[2], round6(tonnes)
    mine.last_call, mine.last_result = (None if cut else call), result
    return result
