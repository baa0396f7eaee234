"""The planner of the plans fixture: `wanted` steps (n, size, last), n counted from 10 on a
first plan and from 20 on a replan; a negative `wanted` returns a wrong shape."""

from __future__ import annotations


async def plan_legs(wanted: int, steps: int) -> object:
    if wanted < 0:
        return [(1, 2.0)]  # a step of two fields, not three
    first = 10 if steps == 0 else 20
    return [(first + i, float(i), i == wanted - 1) for i in range(wanted)]
