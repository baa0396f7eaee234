"""Ship maneuver's job: move the moving haven one cycle along the leg.

The moving haven (second paper, section 4.3.2, Figure 19) is "the box around the submarine
... the submarine is allowed to stay anywhere within the given area, but not outside it". It
moves along the planned track at the ordered speed of advance; here its centre moves
straight towards the leg's waypoint and stops there.
"""

from __future__ import annotations

import math


def haven_step(hx: float, hy: float, x: float, y: float, step: float) -> tuple[float, float]:
    """The haven's centre `step` metres on from (hx, hy) towards the waypoint (x, y), not
    past it."""
    dx, dy = x - hx, y - hy
    left = math.hypot(dx, dy)
    if left <= step or left == 0.0:
        return round(x, 6), round(y, 6)
    return round(hx + dx * step / left, 6), round(hy + dy * step / left, 6)
