"""Hooks of the equipment simulators: actuators with seeded random error, tram kinematics,
seeded sensor noise."""

from __future__ import annotations

import math
import random

from .rounding import round6, round9

TREAD_STEP = 0.05  # metres per cycle per speed level
TURN_STEP = 0.03  # radians per cycle per unit of speed difference (a pivot: 3.4 degrees a cycle)


def new_actuator_error(settings: dict[str, str]) -> random.Random:
    """An actuator's source of random error, seeded from the run's `seed` setting apart from
    the sensors' noise (a seed string of its own), so runs are reproducible."""
    return random.Random(f"actuator-{settings.get('seed', '1')}")


def turn_boom(
    rng: random.Random, angle: float, rate: float, error: float, low: float, high: float
) -> float:
    """The boom angle after one cycle at the commanded rate, off by up to `error` of it (the
    hydraulics' flow varies), between the mechanical stops `low` and `high`."""
    moved = angle + rate * (1.0 + rng.uniform(-error, error))
    return round6(max(low, min(high, moved)))


def travel_time(rng: random.Random, nominal: int, spread: int) -> int:
    """Cycles a jack stroke takes this time: `nominal`, give or take up to `spread`."""
    return nominal + rng.randint(-spread, spread)


def advance(
    rng: random.Random, x: float, y: float, heading: float, left: int, right: int, error: float
) -> tuple[float, float, float]:
    """The pose after one cycle of tramming with these tread speed levels, each tread off by
    up to `error` of its speed (slip on the floor, hydraulic flow): the machine wanders."""
    left_speed = left * (1.0 + rng.uniform(-error, error))
    right_speed = right * (1.0 + rng.uniform(-error, error))
    speed = (left_speed + right_speed) / 2 * TREAD_STEP
    heading = heading + (right_speed - left_speed) * TURN_STEP
    return (
        round9(x + speed * math.cos(heading)),
        round9(y + speed * math.sin(heading)),
        round9(heading),
    )


def slide(
    rng: random.Random, x: float, y: float, heading: float, distance: float
) -> tuple[float, float]:
    """The position after sliding `distance` metres backwards along the heading."""
    return round9(x - distance * math.cos(heading)), round9(y - distance * math.sin(heading))


def new_noise(settings: dict[str, str]) -> random.Random:
    """A noise source seeded from the run's `seed` setting, so runs are reproducible."""
    return random.Random(int(settings.get("seed", "1")))


def noisy(rng: random.Random, value: float, amplitude: float) -> float:
    """`value` plus uniform noise in [-amplitude, amplitude]: `rng.uniform(-amplitude,
    amplitude)` written out as the standard library computes it (a + (b - a) * random()),
    the same numbers without a call per sample (the sensors call it every cycle)."""
    return round6(value + (-amplitude + (amplitude + amplitude) * rng.random()))


def noisy_pose(
    rng: random.Random, x: float, y: float, heading: float, noise: float, heading_noise: float
) -> tuple[float, float, float]:
    """The true pose as a pose sensor reports it: `noisy` on x, y and heading, in that order,
    written out (one call instead of seven)."""
    sample = rng.random
    spread = noise + noise
    return (
        round6(x + (-noise + spread * sample())),
        round6(y + (-noise + spread * sample())),
        round6(heading + (-heading_noise + (heading_noise + heading_noise) * sample())),
    )
