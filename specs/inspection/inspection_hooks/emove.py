"""The CMM equipment controller's planner: a feature of the inspection program -> the points
the probe touches on it (the series of Go_to_point of the paper's section 5.3.1).

The simulated part lies on the table with its features side by side along x, FEATURE_PITCH
apart from FIRST_X, on the line y = LINE_Y, their top surface TOP_Z above the table; the
probe touches each feature on either side of its centre, SPAN apart. The geometry stands in
for the part's CAD model, which the paper leaves to the world model (section 5.2.4, (3)).
"""

from __future__ import annotations

FIRST_X = 30.0  # mm, the first feature's centre
FEATURE_PITCH = 40.0  # mm between features' centres
LINE_Y = 50.0  # mm
TOP_Z = 20.0  # mm above the table
SPAN = 6.0  # mm between a feature's two touch points


def touch_points(number: int) -> list[tuple[float, float, float]]:
    """The points (x, y, z), in mm, the probe touches to measure feature `number`."""
    centre = FIRST_X + FEATURE_PITCH * number
    return [(centre - SPAN / 2, LINE_Y, TOP_Z), (centre + SPAN / 2, LINE_Y, TOP_Z)]
