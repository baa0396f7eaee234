"""The planner of the plans fixture, taking one argument where the plan passes two (E294)."""

from __future__ import annotations


def plan_legs(wanted: int) -> object:
    if wanted < 0:
        return [(1, 2.0)]  # a step of two fields, not three
    first = 10
    return [(first + i, float(i), i == wanted - 1) for i in range(wanted)]
