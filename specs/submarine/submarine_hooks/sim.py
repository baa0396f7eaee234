"""The ship simulator's kinematics and the sonar simulator's beams against the ice keels.

A keel file has one ice keel a line, `X Y RADIUS` in metres (x east, y north): a keel is a
circle in the plan view at the ship's depth. The 14 forward-looking sonars are 14 lines from
the ship at fixed angles to its centre line, out to the sonar's range; the first intercept
of each with a keel is its detection (second paper, section 4.6.2).
"""

from __future__ import annotations

import math
from pathlib import Path

from submarine_hooks.helm import BEAMS
from submarine_hooks.mission import numbers

SONAR_RANGE = 900.0  # metres
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


def new_ice(settings: dict[str, str]) -> list[tuple[float, float, float]]:
    """The keels of the run's `keels` setting (relative to the system directory)."""
    return load_keels(SYSTEM_DIR / settings.get("keels", DEFAULT_KEELS))


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


def ping(
    keels: list[tuple[float, float, float]], x: float, y: float, heading: float
) -> tuple[float, ...]:
    """The 14 beams' detection ranges, then the clearance: the distance to the nearest keel's
    edge (the simulator's truth, not a sensor), both in metres."""
    ranges = []
    for offset in BEAMS:
        bearing = math.radians(heading + offset)
        ranges.append(min([SONAR_RANGE] + [_intercept(x, y, bearing, k) for k in keels]))
    clearance = min([SONAR_RANGE] + [math.hypot(kx - x, ky - y) - r for kx, ky, r in keels])
    return tuple(round(v, 3) for v in ranges) + (round(max(clearance, -SONAR_RANGE), 3),)
