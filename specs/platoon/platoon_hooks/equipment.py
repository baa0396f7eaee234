"""The vehicles' simulated equipment and the RSTA package's geometry.

Positions are metres: x along the axis of advance (towards Dogwood Hill), y across it,
positive right. A bearing is degrees left of the axis of advance, as the sensor head turns.
"""

from __future__ import annotations

import math

FIELD_OF_VIEW = 60.0  # degrees: the sensor head sees 30 degrees either side of its bearing
STILL = 1.0  # m/s: the crew makes out an enemy only from a vehicle (nearly) at rest


def bearing_to(x: float, y: float, to_x: float, to_y: float) -> float:
    """The bearing from (x, y) to (to_x, to_y), degrees left of the axis of advance."""
    return round(math.degrees(math.atan2(-(to_y - y), to_x - x)), 6)


def look(
    x: float,
    y: float,
    speed: float,
    pan: float,
    present: bool,
    enemy_x: float,
    enemy_y: float,
    sensor_range: float,
) -> tuple[bool, float]:
    """Whether the sensors make out the enemy, and where along the axis: present, within
    range, within the field of view of the head's bearing, the vehicle at rest."""
    if not present or abs(speed) > STILL:
        return False, 0.0
    if math.hypot(enemy_x - x, enemy_y - y) > sensor_range:
        return False, 0.0
    off = (bearing_to(x, y, enemy_x, enemy_y) - pan + 180.0) % 360.0 - 180.0
    if abs(off) > FIELD_OF_VIEW / 2:
        return False, 0.0
    return True, enemy_x
