"""Hooks of the equipment simulators: tram kinematics and seeded sensor noise."""

from __future__ import annotations

import math
import random

TREAD_STEP = 0.05  # metres per cycle per speed level
TURN_STEP = 0.03  # radians per cycle per unit of speed difference (a pivot: 3.4 degrees a cycle)


def advance(
    x: float, y: float, heading: float, left: int, right: int
) -> tuple[float, float, float]:
    """The pose after one cycle of tramming with these tread speed levels."""
    speed = (left + right) / 2 * TREAD_STEP
    heading = heading + (right - left) * TURN_STEP
    return (
        round(x + speed * math.cos(heading), 9),
        round(y + speed * math.sin(heading), 9),
        round(heading, 9),
    )


def slide(x: float, y: float, heading: float, distance: float) -> tuple[float, float]:
    """The position after sliding `distance` metres backwards along the heading."""
    return round(x - distance * math.cos(heading), 9), round(y - distance * math.sin(heading), 9)


def new_noise(settings: dict[str, str]) -> random.Random:
    """A noise source seeded from the run's `seed` setting, so runs are reproducible."""
    return random.Random(int(settings.get("seed", "1")))


def noisy(rng: random.Random, value: float, amplitude: float) -> float:
    """`value` plus uniform noise in [-amplitude, amplitude]."""
    return round(value + rng.uniform(-amplitude, amplitude), 6)


def noisy_pose(
    rng: random.Random, x: float, y: float, heading: float, noise: float, heading_noise: float
) -> tuple[float, float, float]:
    """The true pose as a pose sensor reports it."""
    return noisy(rng, x, noise), noisy(rng, y, noise), noisy(rng, heading, heading_noise)
