"""Hooks of the operation coordinator (co): geometry the state table should not spell out."""

from __future__ import annotations

import math

DRUM_DIAMETER = 1.0  # metres
CUSP_BACKOFF = 0.5  # metres trammed in reverse to clear the cusp


def co_position_for_sump(
    pose_x: float, pose_y: float, heading: float, step: float
) -> tuple[float, float]:
    """Goal point `step` ahead of the machine along its heading: half a drum diameter,
    or less on the last sump of a box cut (the shift boss's `sump_step`)."""
    step = max(0.0, min(step, DRUM_DIAMETER / 2))
    return pose_x + step * math.cos(heading), pose_y + step * math.sin(heading)


def co_position_for_cusp(pose_x: float, pose_y: float, heading: float) -> tuple[float, float]:
    """Goal point a short reverse tram behind the machine, to clear the cusp."""
    return pose_x - CUSP_BACKOFF * math.cos(heading), pose_y - CUSP_BACKOFF * math.sin(heading)


def co_goal_ahead(
    pose_x: float, pose_y: float, heading: float, distance: float
) -> tuple[float, float]:
    """Goal point `distance` metres ahead of the machine, along its heading."""
    return pose_x + distance * math.cos(heading), pose_y + distance * math.sin(heading)
