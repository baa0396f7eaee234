"""Hooks of vehicle guidance (vg): the sensed pose and a waypoint -> which tram command moves
the machine towards it, and how far it still has to go or turn."""

from __future__ import annotations

import math

from .rounding import round6

ARRIVED = 0.1  # metres: a waypoint this close is reached (a slow tram moves 0.05 m a cycle)
HEADING_TOLERANCE = 0.05  # radians
STOP, FORWARD, REVERSE, PIVOT_LEFT, PIVOT_RIGHT = 0, 1, 2, 3, 4


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def steer(x: float, y: float, heading: float, wx: float, wy: float) -> tuple[int, float, float]:
    """(move, ahead, turn) towards the waypoint (wx, wy):

    - move: STOP (there), FORWARD or REVERSE (facing it, or with it behind), or a pivot
      towards whichever of the two facings is nearer;
    - ahead: the distance to the waypoint along the heading (negative: behind);
    - turn: the heading change still needed (+ left), for the pivots.
    """
    dx, dy = wx - x, wy - y
    ahead = round6(dx * math.cos(heading) + dy * math.sin(heading))
    if math.hypot(dx, dy) <= ARRIVED:
        return STOP, ahead, 0.0
    error = _wrap(math.atan2(dy, dx) - heading)
    backwards = _wrap(error - math.pi)
    turn = error if abs(error) <= abs(backwards) else backwards
    if abs(turn) <= HEADING_TOLERANCE:
        return (FORWARD if turn == error else REVERSE), ahead, round6(turn)
    return (PIVOT_LEFT if turn > 0 else PIVOT_RIGHT), ahead, round6(turn)


def align(heading: float) -> tuple[int, float]:
    """(move, turn) to face inby again (heading 0) at the goal: STOP or a pivot."""
    turn = round6(_wrap(-heading))
    if abs(turn) <= HEADING_TOLERANCE:
        return STOP, turn
    return (PIVOT_LEFT if turn > 0 else PIVOT_RIGHT), turn
