"""Hooks of world modelling (wm): the sensed pose, boom angle and cutter current -> the
estimates the controllers decide on (face position, depth cut, pop-out)."""

from __future__ import annotations

from .rounding import round6

DRUM_RADIUS = 0.5  # metres: the drum's front edge is this far inby of the sensed drum centre
ROOF_ANGLE, FLOOR_ANGLE = 30.0, -10.0  # degrees
ANGLE_TOLERANCE = 0.5  # degrees: as the boom controller's
CUTTER_THRESHOLD = 60.0  # amperes: the drum is cutting coal
# metres: how far the drum's front edge is into the face when the sensed current first
# passes the threshold at the slow tram speed (0.05 m a cycle: half a cell to reach the
# first coal cell's centre, then the motor's and the sensor's response)
CONTACT_LAG = 0.15
# metres: the drum's round bottom is a cusp's height (a tenth of the 2 m seam, as the
# mine counts the face) above the floor this far from the drum's centre
FLOOR_REACH = 0.4
POP_DISTANCE = 0.1  # metres: the machine moved this far since the drum left the roof
NOWHERE = -1.0e9  # "not seen yet" for a position


def wm_estimate(
    pose_x: float,
    boom_angle: float,
    cutter_current: float,
    jack_down: bool,
    face0: float,
    floor_x: float,
    shear_x: float,
    popped: bool,
) -> tuple[float, float, float, bool, float, float]:
    """One cycle of world modelling: (face0, floor_x, shear_x, popped, depth, reach).

    - face0: where the face stood, from the first rise of the cutter current: the drum's
      front edge at the sensed pose, less CONTACT_LAG (kept once known);
    - floor_x: the furthest inby the sensed drum centre has been with the boom at the floor;
      everything up to its front edge is cut to the floor;
    - shear_x: the sensed pose when the drum last left the roof (the shear's start);
    - popped: the jack is down, the boom below the roof, and the machine has moved more than
      POP_DISTANCE from the shear's start: the cutting force pushed the drum out of the cut.
      Cleared once the boom is back at the roof (what SHEAR_CORRECT does);
    - depth: how far the face is cut back to the floor (floor_x + FLOOR_REACH past face0);
    - reach: the depth a shear from the sensed pose now would give (the next sump adds to it).
    """
    if face0 <= NOWHERE and cutter_current > CUTTER_THRESHOLD:
        face0 = pose_x + DRUM_RADIUS - CONTACT_LAG
    at_roof = boom_angle >= ROOF_ANGLE - ANGLE_TOLERANCE
    if boom_angle <= FLOOR_ANGLE + ANGLE_TOLERANCE:
        floor_x = max(floor_x, pose_x)
    if at_roof:
        shear_x, popped = pose_x, False
    elif jack_down and abs(pose_x - shear_x) > POP_DISTANCE:
        popped = True
    depth = reach = 0.0
    if face0 > NOWHERE:
        reach = round6(max(0.0, pose_x + FLOOR_REACH - face0))
        if floor_x > NOWHERE:
            depth = round6(max(0.0, floor_x + FLOOR_REACH - face0))
    return face0, floor_x, shear_x, popped, depth, reach
