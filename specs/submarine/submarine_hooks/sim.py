"""The ship simulator's kinematics, the sonar simulator's beams against the ice keels, and
the ships its passive sonar hears.

A keel file has one ice keel a line, `X Y RADIUS` in metres (x east, y north): a keel is a
circle in the plan view at the ship's depth. The run's `ice_seed` adds keels generated before
the run along the planned path, random in size and fractal in shape (submarine_hooks/ice.py).
The 14 forward-looking sonars are 14 lines from the ship at fixed angles to its centre line,
out to the sonar's range; the first intercept of each with a keel is its detection
(second paper, section 4.6.2).

A contact file has one other ship a line, `X Y COURSE SPEED` (metres, degrees from north,
m/s): where it is when the run starts, and its steady course and speed. The passive sonar
hears a ship within HEARING metres, except in its baffles, the arc astern (more than
BAFFLES degrees off the bow) that the submarine's own noise masks: a contact there is heard
only once the submarine turns (clearing baffles, section 4.1.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from submarine_hooks.helm import BEAMS
from submarine_hooks.ice import Keel, edge_distance, generate, ray_to
from submarine_hooks.mission import DEFAULT_ROUTE, load_route, numbers

SONAR_RANGE = 900.0  # metres
HEARING = 8000.0  # metres: the passive sonar hears a ship out to this range (8000 = none heard)
BAFFLES = 150.0  # degrees off the bow the passive sonar hears; the arc astern is its baffles
SYSTEM_DIR = Path(__file__).resolve().parent.parent
DEFAULT_KEELS = "maps/bering.keels"


def advance(x: float, y: float, heading: float, distance: float) -> tuple[float, float]:
    """The position after moving `distance` metres on `heading` (degrees from north)."""
    h = math.radians(heading)
    return round(x + distance * math.sin(h), 6), round(y + distance * math.cos(h), 6)


def load_keels(path: Path) -> list[tuple[float, float, float]]:
    """The keels of a keel file."""
    keels = []
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].split()
        if text:
            x, y, radius = numbers(path, number, text, "X Y RADIUS")
            keels.append((x, y, radius))
    return keels


@dataclass
class Sea:
    """What the sonar simulator senses: the ice keels (x, y, radius) of the keel file, the
    generated ones (fractal outlines), and the other ships (x, y, course, speed), which
    move on as the run goes (`listen`)."""

    keels: list[tuple[float, float, float]]
    contacts: list[list[float]] = field(default_factory=list)
    shapes: list[Keel] = field(default_factory=list)


def load_contacts(path: Path) -> list[list[float]]:
    """The ships of a contact file."""
    contacts = []
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].split()
        if text:
            contacts.append(list(numbers(path, number, text, "X Y COURSE SPEED")))
    return contacts


def new_ice(settings: dict[str, str]) -> Sea:
    """The keels of the run's `keels` setting, the keels its `ice_seed` generates along the
    path from where the ship starts (0, 0) through the `route` setting's waypoints (none
    without it), and the ships of its `contacts` setting (none by default); files are
    relative to the system directory."""
    keels = load_keels(SYSTEM_DIR / settings.get("keels", DEFAULT_KEELS))
    contacts = settings.get("contacts")
    seed = settings.get("ice_seed")
    shapes: list[Keel] = []
    if seed is not None:
        if not seed.lstrip("-").isdigit():
            raise ValueError(f"ice_seed must be a whole number, not {seed!r}")
        route = load_route(SYSTEM_DIR / settings.get("route", DEFAULT_ROUTE)).route
        shapes = generate(int(seed), [(0.0, 0.0), *route])
    return Sea(keels, load_contacts(SYSTEM_DIR / contacts) if contacts else [], shapes)


def listen(sea: Sea, x: float, y: float, heading: float, period: float) -> tuple[float, float]:
    """Move every ship on one cycle (`period` seconds); then the nearest the passive sonar
    hears from (x, y) on `heading`: (range in metres, true bearing in degrees), or
    (HEARING, 0.0) when it hears none (none in range, or only in its baffles)."""
    heard = (HEARING, 0.0)
    for ship in sea.contacts:
        course = math.radians(ship[2])
        ship[0] += ship[3] * period * math.sin(course)
        ship[1] += ship[3] * period * math.cos(course)
        distance = math.hypot(ship[0] - x, ship[1] - y)
        bearing = math.degrees(math.atan2(ship[0] - x, ship[1] - y)) % 360.0
        off_bow = abs((bearing - heading + 540.0) % 360.0 - 180.0)
        if distance < heard[0] and off_bow <= BAFFLES:
            heard = (distance, bearing)
    return round(heard[0], 3), round(heard[1], 3)


def _intercept(x: float, y: float, bearing: float, keel: tuple[float, float, float]) -> float:
    """Distance along the ray from (x, y) on `bearing` to the keel's edge; the range if none."""
    kx, ky, r = keel
    ux, uy = math.sin(bearing), math.cos(bearing)
    cx, cy = kx - x, ky - y
    along = cx * ux + cy * uy
    miss2 = cx * cx + cy * cy - along * along
    if miss2 > r * r:
        return SONAR_RANGE
    near = along - math.sqrt(r * r - miss2)
    if near < 0.0 < along + math.sqrt(r * r - miss2):
        return 0.0  # inside the keel
    return near if 0.0 <= near < SONAR_RANGE else SONAR_RANGE


def ping(sea: Sea, x: float, y: float, heading: float) -> tuple[float, ...]:
    """The 14 beams' detection ranges, then the clearance: the distance to the nearest keel's
    edge (the simulator's truth, not a sensor), both in metres."""
    keels = sea.keels
    near = [k for k in sea.shapes if math.hypot(k.x - x, k.y - y) - k.reach < SONAR_RANGE]
    ranges = []
    for offset in BEAMS:
        bearing = math.radians(heading + offset)
        nearest = min([SONAR_RANGE] + [_intercept(x, y, bearing, k) for k in keels])
        for shape in near:
            nearest = ray_to(shape, x, y, math.sin(bearing), math.cos(bearing), nearest)
        ranges.append(nearest)
    clearance = min([SONAR_RANGE] + [math.hypot(kx - x, ky - y) - r for kx, ky, r in keels])
    for shape in near:
        clearance = min(clearance, edge_distance(shape, x, y))
    return tuple(round(v, 3) for v in ranges) + (round(max(clearance, -SONAR_RANGE), 3),)
