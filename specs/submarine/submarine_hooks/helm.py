"""Helm's jobs: the course to a goal, and the ice assessment from the 14 sonar beams.

The paper's Helm evaluates the sonar data with a CMAC that estimates the ice distribution
and recommends an ice-avoiding heading; the ice problem flag is raised when the
recommendation differs from the desired course (second paper, section 4.3.2). This stand-in
does the same job geometrically: a heading is blocked when a sonar detection lies in the
ship's corridor along it within the danger range; the recommendation is the unblocked
heading nearest the course.
"""

from __future__ import annotations

import math

BEAMS = [-39.0 + 6.0 * i for i in range(14)]  # degrees off the centre line, port negative
DANGER_RANGE = 700.0  # metres ahead that count
HALF_WIDTH = 150.0  # metres either side of the track that must be clear
SEARCH_STEP = 2.0  # degrees between the headings tried
SEARCH_LIMIT = 80.0  # degrees either side of the course
PASSAGE_LIMIT = 20.0  # degrees: a clear heading further off the course is no passage to it


LOOKAHEAD = 600.0  # metres along the track ahead of the ship's nearest point on it


def course_to(x: float, y: float, pos_x: float, pos_y: float) -> float:
    """The true bearing from the ship to the goal, degrees clockwise from north, [0, 360)."""
    return round(math.degrees(math.atan2(x - pos_x, y - pos_y)) % 360.0, 6)


def track_course(
    x: float, y: float, start_x: float, start_y: float, pos_x: float, pos_y: float
) -> float:
    """The course along the track from (start_x, start_y) to the goal (x, y): towards the
    point LOOKAHEAD metres on from the ship's nearest point on the track, or towards the
    goal once that point would lie past it. Off the track, the course cuts back onto it,
    more steeply the further off (about 14 degrees at 150 m)."""
    track_x, track_y = x - start_x, y - start_y
    length = math.hypot(track_x, track_y)
    if length == 0.0:
        return course_to(x, y, pos_x, pos_y)
    unit_x, unit_y = track_x / length, track_y / length
    along = (pos_x - start_x) * unit_x + (pos_y - start_y) * unit_y + LOOKAHEAD
    if along >= length:
        return course_to(x, y, pos_x, pos_y)
    return course_to(start_x + along * unit_x, start_y + along * unit_y, pos_x, pos_y)


def _blocked(heading: float, points: list[tuple[float, float]]) -> bool:
    """Whether a detection (east, north offsets from the ship) lies in the corridor."""
    h = math.radians(heading)
    ahead_x, ahead_y = math.sin(h), math.cos(h)
    for dx, dy in points:
        forward = dx * ahead_x + dy * ahead_y
        lateral = dx * ahead_y - dy * ahead_x
        if 0.0 < forward < DANGER_RANGE and abs(lateral) < HALF_WIDTH:
            return True
    return False


def assess_ice(
    course: float,
    heading: float,
    b00: float, b01: float, b02: float, b03: float, b04: float, b05: float, b06: float,
    b07: float, b08: float, b09: float, b10: float, b11: float, b12: float, b13: float,
) -> tuple[int, float]:  # fmt: skip
    """(1 if the course is blocked by ice, 2 if every heading within PASSAGE_LIMIT of it is
    too, else 0; the recommended heading)."""
    ranges = [b00, b01, b02, b03, b04, b05, b06, b07, b08, b09, b10, b11, b12, b13]
    points = []
    for offset, distance in zip(BEAMS, ranges, strict=True):
        if distance < DANGER_RANGE:
            bearing = math.radians(heading + offset)
            points.append((distance * math.sin(bearing), distance * math.cos(bearing)))
    if not _blocked(course, points):
        return 0, course
    step = SEARCH_STEP
    while step <= SEARCH_LIMIT:
        for sign in (1.0, -1.0):  # starboard first on a tie
            candidate = (course + sign * step) % 360.0
            if not _blocked(candidate, points):
                return 1 if step <= PASSAGE_LIMIT else 2, round(candidate, 6)
        step += SEARCH_STEP
    return 2, round((course + SEARCH_LIMIT) % 360.0, 6)
