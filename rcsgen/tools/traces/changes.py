"""Changes: a trace -> a terminal timeline of only what changed, cycle by cycle.

The first cycle shows every module as it is; after that a cycle appears only when something
changed in it: a module's command (with its number), status (with its number and, in
ERROR, its reason: `ERROR(REFUSED) #4`), state or results,
a rule that fired (a rule re-firing every cycle shows every cycle: it sends every cycle),
or a world field. Floating-point world fields drift with sensor noise every cycle, so by
default only bool and int fields are shown (`world="all"` shows every one). Consecutive
cycles that change the same way (a HALT re-sent every cycle, a rule counting ticks) are
shown once, with the cycle they last through, unless `merge` is False.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from typing import Any

from .read import Lane, Trace, status_text

WORLD_CHOICES = ("discrete", "all", "none")


def _value(value: Any) -> str:
    return json.dumps(value) if isinstance(value, bool) or value is None else str(value)


def _pair(name: str, number: int) -> str:
    return f"{name} #{number}"


def module_line(trace: Trace, module: str, i: int) -> list[str]:
    """What changed in `module` at cycle index `i` (everything at the first cycle)."""
    col = trace.columns[module]
    parts = []
    for name, num in (("command", "command_num"), ("status", "status_num")):
        text = status_text if name == "status" else lambda c, k: str(c["command"][k])
        now = _pair(text(col, i), col[num][i])
        if i == 0:
            parts.append(f"{name} {now}")
        else:
            before = _pair(text(col, i - 1), col[num][i - 1])
            if before != now:
                parts.append(f"{name} {before} -> {now}")
    if i == 0:
        parts.append(f"state {col['state'][i]}")
    elif col["state"][i] != col["state"][i - 1]:
        parts.append(f"state {col['state'][i - 1]} -> {col['state'][i]}")
    for name, value in (col["result"][i] if "result" in col else {}).items():
        if i == 0:
            parts.append(f"result.{name} {_value(value)}")
        elif col["result"][i - 1].get(name) != value:
            was = _value(col["result"][i - 1].get(name))
            parts.append(f"result.{name} {was} -> {_value(value)}")
    if col["rule"][i] is not None:
        parts.append(f"fired {col['rule'][i]}")
    return parts


def world_fields(trace: Trace, world: str) -> list[str]:
    """The world fields shown: the bool and int ones, every one, or none (WORLD_CHOICES)."""
    if world not in WORLD_CHOICES:
        raise ValueError(f"world fields: `{world}` is not one of {', '.join(WORLD_CHOICES)}")
    if world == "none":
        return []
    if world == "all":
        return list(trace.world)
    return [
        name
        for name, series in trace.world.items()
        if not any(isinstance(v, float) for v in series)
    ]


NUMBER = re.compile(r"#\d+")


def timeline(
    trace: Trace,
    lanes: list[Lane],
    modules: list[str],
    world: str = "discrete",
    first: int | None = None,
    last: int | None = None,
    merge: bool = True,
) -> Iterator[str]:
    """The lines of the changes-only timeline (no colour), in the lanes' order."""
    if not merge:
        yield from _cycles(trace, lanes, modules, world, first, last)
        return
    group: list[tuple[int, list[str]]] = []  # cycles that changed alike, one after another

    def flush() -> Iterator[str]:
        if group:
            yield f"cycle {group[0][0]}"
            yield from group[0][1]
            if len(group) > 1:
                yield (
                    f"  ... the same each cycle through cycle {group[-1][0]} ({len(group)} cycles)"
                )

    def same(rows: list[str]) -> bool:
        return [NUMBER.sub("#", r) for r in rows] == [NUMBER.sub("#", r) for r in group[0][1]]

    current: list[str] = []
    cycle = None
    for line in [*_cycles(trace, lanes, modules, world, first, last), "cycle end"]:
        if not line.startswith("cycle "):
            current.append(line)
            continue
        if cycle is not None:
            follows = bool(group) and cycle == group[-1][0] + 1 and same(current)
            if not follows:
                yield from flush()
                group = []
            group.append((cycle, current))
        cycle = int(line.split()[1]) if line != "cycle end" else None
        current = []
    yield from flush()


def _cycles(
    trace: Trace,
    lanes: list[Lane],
    modules: list[str],
    world: str,
    first: int | None,
    last: int | None,
) -> Iterator[str]:
    shown = [lane.module for lane in lanes if lane.module in modules]
    fields = world_fields(trace, world)
    width = max([len(m) for m in shown] + [5 if fields else 0])
    for i, cycle in enumerate(trace.cycles):
        if (first is not None and cycle < first) or (last is not None and cycle > last):
            continue
        rows = []
        for module in shown:
            parts = module_line(trace, module, i)
            if parts:
                rows.append(f"  {module:<{width}}  " + "  ".join(parts))
        changed = [
            f"{name} {_value(trace.world[name][i - 1])} -> {_value(trace.world[name][i])}"
            if i
            else f"{name} {_value(trace.world[name][i])}"
            for name in fields
            if i == 0 or trace.world[name][i] != trace.world[name][i - 1]
        ]
        if changed:
            rows.append(f"  {'world':<{width}}  " + "  ".join(changed))
        if rows:
            yield f"cycle {cycle}"
            yield from rows
