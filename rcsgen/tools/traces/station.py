"""Station view: an inspection-workstation trace -> an HTML replay of the part on the CMM.

The second paper's inspection workstation (sections 3.4, 5.3) replayed from a recorded run:
the station as a person at it would see it (the fixture plate, the part on it, the probe
in the CMM's head, what the operator is asked), cycle by cycle, and under it the time line
of who worked when: the job planner, the fixturing and tooling tasks, the operator's
requests and each CMM operation (homing, calibrations, one bar per feature inspected), with
a cursor at the cycle shown; the controllers' commands and states and the measurement's
results in the panel. The shell (play, slider, clock) is the replay views' (player.py).

What is on the station is read from the controllers' commands as they complete: the plate
is mounted once fixturing's EQUIP_SETUP is DONE, the part is on the fixture from PLACE_PART's
DONE to UNLOAD_PART's, re-seated while REFIXTURE_PART runs, and the probe is in the head
once tooling's LOAD_PROBE is DONE. The time line is SVG drawn here, so what a person sees is
in the file itself; the script moves the cursor and sets what the station shows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ...compiler.ir import IRSystem
from . import player
from .read import Trace
from .view import StringTable, runs

# the controllers the panel shows
PANEL = ("shop", "jp", "wc", "ws", "ms", "fx", "tl", "cmm", "prim", "servo")
REQUIRED = ("fx", "tl", "cmm")  # the modules the station is read from
LANES = (  # (label, the module row whose work the lane shows; op/*: every operator channel)
    ("planner", "jp"),
    ("fixturing", "fx"),
    ("tooling", "tl"),
    ("operator", "op/*"),
    ("CMM", "cmm"),
    ("probe", "prim"),  # each Go_to_point of the probe controller
)
WIDTH = 720  # pixels of the time line
LANE = 18  # pixels a lane
LABEL = 70  # pixels of the lanes' labels


class StationError(Exception):
    """A trace the station view cannot draw; one line."""


@dataclass(frozen=True)
class Bar:
    """A run of cycles a lane's module worked: [first, last] indices, and on what."""

    lane: int
    first: int
    last: int
    what: str


def done_at(trace: Trace, module: str, command: str) -> list[bool]:
    """Per cycle: `module`'s command `command` has finished DONE (this cycle or before,
    until the module is given another command)."""
    column = trace.columns[module]
    return [
        c == command and s == "DONE"
        for c, s in zip(column["command"], column["status"], strict=True)
    ]


def station(trace: Trace) -> dict[str, list[str]]:
    """Per cycle: the plate (mounted or not), the part (none, on the fixture, re-seated,
    unloaded) and the probe (in the head or not), from the commands as they complete."""
    plate_done = done_at(trace, "fx", "EQUIP_SETUP")
    placed, unloaded = done_at(trace, "fx", "PLACE_PART"), done_at(trace, "fx", "UNLOAD_PART")
    loaded = done_at(trace, "tl", "LOAD_PROBE")
    fx = trace.columns["fx"]
    plate, part, probe = [], [], []
    mounted, on, in_head = False, "none", False
    for i in range(len(trace)):
        mounted = mounted or plate_done[i]
        if placed[i]:
            on = "on the fixture"
        elif fx["command"][i] == "REFIXTURE_PART" and fx["status"][i] == "EXECUTING":
            on = "re-seated"
        elif fx["command"][i] == "REFIXTURE_PART" and fx["status"][i] == "DONE":
            on = "on the fixture"
        elif unloaded[i]:
            on = "unloaded"
        in_head = in_head or loaded[i]
        plate.append("mounted" if mounted else "none")
        part.append(on)
        probe.append("loaded" if in_head else "none")
    return {"plate": plate, "part": part, "probe": probe}


def bars(trace: Trace) -> list[Bar]:
    """Each lane's runs of work: a module EXECUTING a command other than INIT and HALT (for
    the operator, any of its channels asking)."""
    out: list[Bar] = []
    for lane, (_, row) in enumerate(LANES):
        rows = [m for m in trace.modules if m.startswith("op/")] if row == "op/*" else [row]
        for module in (m for m in rows if m in trace.columns):
            column = trace.columns[module]
            start: int | None = None
            for i in range(len(trace) + 1):
                busy = (
                    i < len(trace)
                    and column["status"][i] == "EXECUTING"
                    and column["command"][i] not in ("INIT", "HALT")
                )
                what = column["command"][i] if busy else None
                if start is not None and (not busy or what != column["command"][start]):
                    out.append(Bar(lane, start, i - 1, str(column["command"][start])))
                    start = None
                if busy and start is None:
                    start = i
    return out


def timeline(trace: Trace, found: list[Bar]) -> str:
    """The time line: a lane per worker, a bar per run of work (its command in its title),
    a cursor the script moves."""
    n = max(len(trace), 1)
    scale = WIDTH / n
    height = LANE * len(LANES) + 14
    out = [
        f'<svg id="timeline" width="{LABEL + WIDTH}" height="{height}" '
        f'viewBox="0 0 {LABEL + WIDTH} {height}">'
    ]
    for lane, (label, _) in enumerate(LANES):
        y = lane * LANE
        out.append(f'<text class="label" x="0" y="{y + 13}">{label}</text>')
        out.append(
            f'<line class="lane" x1="{LABEL}" y1="{y + LANE}" '
            f'x2="{LABEL + WIDTH}" y2="{y + LANE}"/>'
        )
    for bar in found:
        x = round(LABEL + bar.first * scale, 1)
        w = round(max((bar.last - bar.first + 1) * scale, 1.0), 1)
        out.append(
            f'<rect class="bar {bar.what}" data-lane="{LANES[bar.lane][0]}" '
            f'data-first="{trace.cycles[bar.first]}" data-last="{trace.cycles[bar.last]}" '
            f'x="{x}" y="{bar.lane * LANE + 3}" width="{w}" height="{LANE - 6}">'
            f"<title>{bar.what} {trace.cycles[bar.first]}–{trace.cycles[bar.last]}</title></rect>"
        )
    out.append(f'<text class="axis" x="{LABEL}" y="{height - 2}">cycle {trace.cycles[0]}</text>')
    out.append(
        f'<text class="axis end" x="{LABEL + WIDTH}" y="{height - 2}">{trace.cycles[-1]}</text>'
    )
    out.append(f'<line id="cursor" x1="{LABEL}" y1="0" x2="{LABEL}" y2="{height - 14}"/>')
    out.append("</svg>")
    return "".join(out)


def payload(trace: Trace, system: IRSystem) -> dict[str, Any]:
    table = StringTable()
    found = station(trace)
    controllers = player.panel(trace, PANEL, table)
    results = {
        f"{module}.{name}": runs(
            [(r or {}).get(name) for r in trace.columns[module]["result"]], None, table
        )
        for module, names in (("ms", ("measured", "failed")), ("ws", ("accepted",)))
        if module in trace.columns and "result" in trace.columns[module]
        for name in names
    }
    requests = []
    for i in range(len(trace)):
        open_now = [
            f"{trace.columns[row]['command'][i]} (for {row.split('/')[1]})"
            for row in sorted(m for m in trace.modules if m.startswith("op/"))
            if trace.columns[row]["state"][i] == "ASKING"
        ]
        requests.append(", ".join(open_now))
    return {
        "source": trace.name,
        "system": system.name,
        "period": system.cycle_period,
        "speed": 10,  # times real time: the whole run in about half a minute
        "n": len(trace),
        "cycles": trace.cycles,
        "lanes": {"label": LABEL, "width": WIDTH},
        "station": {key: runs(series, None, table) for key, series in found.items()},
        "requests": runs(requests, None, table),
        "controllers": controllers,
        "results": results,
        "strings": table.values,
    }


STATION = (
    '<svg id="station" width="300" height="230" viewBox="0 0 300 230">'
    '<rect class="table" x="10" y="190" width="280" height="20"/>'
    '<path class="gantry" d="M 30 190 L 30 20 L 270 20 L 270 190"/>'
    '<rect class="head" x="135" y="20" width="30" height="40"/>'
    '<line id="probe" class="probe" x1="150" y1="60" x2="150" y2="100"/>'
    '<circle id="stylus" class="probe" cx="150" cy="102" r="3"/>'
    '<rect id="plate" class="plate" x="70" y="176" width="160" height="14"/>'
    '<rect id="part" class="part" x="110" y="126" width="80" height="50"/>'
    '<text id="part-label" x="150" y="156" text-anchor="middle"></text>'
    "</svg>"
)


def render(trace: Trace, system: IRSystem) -> str:
    """The page of an inspection-workstation trace."""
    missing = [name for name in REQUIRED if name not in trace.columns]
    if missing:
        raise StationError(
            f"{trace.name} is not a trace of an inspection workstation: it has no "
            f"{', '.join(missing)} (the station view reads fixturing, tooling and the CMM)"
        )
    title = f"{trace.name} · {system.name}: the part on the CMM"
    fills = {"STATION": STATION, "TIMELINE": timeline(trace, bars(trace))}
    return player.page("station", title, fills, payload(trace, system))
