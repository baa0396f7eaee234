"""Trace view: a trace (and its lanes) -> one self-contained HTML page that opens offline.

A swim-lane per module (command, state and status over the cycles, an error with its reason:
`ERROR(REFUSED)`; a marker where a rule fired, its id on hover), the world fields as plots,
zoom and pan, and a cursor that shows every module at one cycle. The page is the template
`assets/trace_view.html` (hand-written JavaScript, CSS and SVG; nothing loaded from the
network) with the trace inlined as run-length encoded JSON, so a 20,000-cycle trace stays a
few megabytes.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Callable, Sequence
from importlib import resources
from typing import Any, overload

from ...runtime import contract
from .read import Lane, Trace

TEMPLATE = "trace_view.html"


class StringTable:
    """One string table for the whole page: every value is an index into it."""

    def __init__(self) -> None:
        self.values: list[str] = []
        self.index: dict[str, int] = {}

    def __call__(self, value: str) -> int:
        if value not in self.index:
            self.index[value] = len(self.values)
            self.values.append(value)
        return self.index[value]


def runs(
    values: Sequence[Any],
    numbers: list[int] | None,
    table: StringTable,
    text: Callable[[Any], str] = str,
    starts: list[int] | None = None,
) -> list[int]:
    """Run-length encoding, flat: start index, string index (and number) of each run; a
    value is made text (`text`) once per run, not once per cycle. `starts`: the only cycles
    where the values may change (`Trace.starts`), so the others are not looked at."""
    out: list[int] = []
    previous: tuple[Any, int | None] | None = None
    for i in starts if starts else range(len(values)):
        now = (values[i], numbers[i] if numbers is not None else None)
        if now != previous:
            out += [i, table(text(now[0]))]
            if now[1] is not None:
                out.append(now[1])
            previous = now
    return out


def _fired(rules: list[Any], starts: list[int] | None, table: StringTable) -> list[list[int]]:
    """[cycle index, rule] where a rule fired; `starts`: the only indices where the values
    may change (`Trace.starts`), so a run of cycles is looked at once."""
    if not starts:
        return [[i, table(r)] for i, r in enumerate(rules) if r is not None]
    out = []
    for at, end in zip(starts, [*starts[1:], len(rules)], strict=True):
        rule = rules[at]
        if rule is not None:
            out += [[i, table(rule)] for i in range(at, end)]
    return out


class _StatusRows(Sequence[tuple[Any, Any, Any]]):
    """A module's (status, reason, cause) at each cycle, made when asked for: `runs` looks
    at the cycles where they may change only."""

    def __init__(self, col: dict[str, list[Any]]) -> None:
        self.status = col["status"]
        self.reason, self.cause = col.get("reason"), col.get("cause")

    def __len__(self) -> int:
        return len(self.status)

    @overload
    def __getitem__(self, i: int) -> tuple[Any, Any, Any]: ...
    @overload
    def __getitem__(self, i: slice) -> Sequence[tuple[Any, Any, Any]]: ...
    def __getitem__(self, i: int | slice) -> Any:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        return (
            self.status[i],
            self.reason[i] if self.reason else None,
            self.cause[i] if self.cause else "",
        )


def number(value: Any) -> float | None:
    """A plotted value: NaN, infinities and anything not a number are gaps."""
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    return None


def _plot(name: str, series: list[Any]) -> dict[str, Any]:
    """One world field's plot: bool, int, text (an enumeration's names, a string's text, as
    indices into `names`) or float."""
    values: list[Any]
    types = set(map(type, series))  # (one pass in C: what the series holds)
    if types <= {bool}:
        kind, values = "bool", [int(v) for v in series]
    elif types == {int}:
        kind, values = "int", list(series)
    elif types == {str}:
        names = sorted(set(series))
        index = {v: i for i, v in enumerate(names)}
        return {"name": name, "type": "text", "values": [index[v] for v in series]} | {
            "names": names
        }
    elif types == {float} and _finite(series):  # (the usual float: every value as it is)
        kind, values = "float", list(series)
    else:  # (number() inline: a plot has a value per cycle)
        finite = math.isfinite
        kind = "float"
        values = [float(v) if isinstance(v, int | float) and finite(v) else None for v in series]
    return {"name": name, "type": kind, "values": values}


def _finite(series: list[float]) -> bool:
    """Whether every float of `series` is finite (no NaN, no infinity)."""
    try:
        return math.isfinite(math.fsum(series))
    except (OverflowError, ValueError):  # (an infinity, or a sum too large: look one by one)
        return all(map(math.isfinite, series))


def payload(trace: Trace, lanes: list[Lane], system: str | None, period: float | None) -> str:
    """The JSON the page draws, canonical (sorted keys), safe inside a <script> element."""
    table = StringTable()
    consecutive = all(b == a + 1 for a, b in zip(trace.cycles, trace.cycles[1:], strict=False))
    lane_data = []
    for lane in lanes:
        col, starts = trace.columns[lane.module], trace.starts.get(lane.module)
        fired = _fired(col["rule"], starts, table)
        lane_data.append(
            {
                "module": lane.module,
                "title": lane.title,
                "level": lane.level,
                "simulator": lane.simulator,
                "runs_as": lane.runs_as if lane.runs_as != lane.module else "",
                "command": runs(col["command"], col["command_num"], table, str, starts),
                "status": runs(
                    _StatusRows(col),
                    col["status_num"],
                    table,
                    lambda row: contract.status_text(str(row[0]), row[1], str(row[2])),
                    starts,
                ),
                "state": runs(col["state"], None, table, str, starts),
                "rules": [x for pair in fired for x in pair],
            }
        )
    world = [_plot(name, series) for name, series in trace.world.items()]
    data: dict[str, Any] = {
        "source": trace.name,
        "system": system,
        "period": period,
        "n": len(trace),
        "cycle0": trace.cycles[0],
        "cycles": None if consecutive else trace.cycles,
        "strings": table.values,
        "lanes": lane_data,
        "world": world,
    }
    if trace.periodicity is not None:  # a paced run: how well it held its period
        data["periodicity"] = trace.periodicity
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return text.replace("</", "<\\/")


def render(
    trace: Trace, lanes: list[Lane], system: str | None = None, period: float | None = None
) -> str:
    """The page: the template with the trace's title and data filled in."""
    template = resources.files(__package__).joinpath("assets", TEMPLATE).read_text("utf-8")
    title = f"{trace.name} · {len(trace):,} cycles" + (f" · {system}" if system else "")
    if trace.periodicity is not None:  # a paced run: the figures `ctl status` shows
        title += " · " + contract.periodicity_line("paced", trace.periodicity)
    page = template.replace("{{TITLE}}", html.escape(title))
    return page.replace("{{DATA}}", payload(trace, lanes, system, period))
