"""Sea view: a submarine trace + its keel map and route -> an HTML replay of the transit.

The second paper's animation (section 4.9) and Figure 19, from a recorded run: the ice
keels, the planned route (each waypoint, and its alternate), the track the submarine sailed
among the keels, and, cycle by cycle, the submarine at its traced position and heading with
its moving haven around it, the command controller's, ship maneuver's and the helm's
commands and states, and the announcement; play/pause, a cycle slider. Beside the plan view
(the ice map), Figure 33's other displays, each drawn from the trace when it holds their
fields: the bubble angle, the speed and heading, the current sonar detection (each beam out
to its range, at its angle off the bow), the digital maneuvering data and the depth (the
ship's, the ordered, and the sea bottom's).

The scene is drawn on the server, as SVG in the page, so that what a person sees (where the
track runs, whether it crosses a keel) is in the file itself; the script only moves the
submarine and its haven and fills the panel. The page's shell (player, slider, clock) is
the replay views' common part (player.py). The keels and the route are the run's: the
simulators' and the mission planner's own hooks (their hook state factories) load them from
the system directory with the scenario's settings.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

from ...compiler.ir import IRCall, IRController, IRSystem
from . import player
from .mine import import_hooks
from .read import Trace
from .view import StringTable, number, runs

REQUIRED = ("pos_x", "pos_y")
SHOWN = (
    *("heading", "course", "haven_x", "haven_y", "clearance", "speed", "speed_cmd"),
    *("depth", "depth_cmd", "bottom_depth", "bubble", "rudder_angle", "announcement"),
)
PANEL = ("cc", "sm", "helm", "prop")  # the controllers whose commands the panel shows
WIDTH = 760  # pixels of the plan view's larger side
MARGIN = 400.0  # metres around everything drawn


class SeaError(Exception):
    """A trace or system the sea view cannot draw; one line."""


def _factory_of(system: IRSystem, hook: str) -> IRController:
    for controller in system.controllers:
        if controller.hooks_state and hook in controller.hooks and controller.hooks_module:
            return controller
    raise SeaError(
        f"system {system.name} has no ice keels to draw: the sea view needs a simulator whose "
        f"hooks keep the keels (hooks_state) and ping them (a `{hook}` hook)"
    )


DIAL = 150  # pixels: each of Figure 33's displays beside the plan view is a square this wide


@dataclass
class Sonar:
    """The beams the sonar simulator's `ping` returns first: their world fields, their angles
    off the centre line (degrees, port negative: the hooks' `BEAMS`) and the range a beam
    reports when it meets no ice (the hooks' `SONAR_RANGE`)."""

    fields: list[str]
    angles: list[float]
    reach: float

    @property
    def pixels(self) -> float:
        """How long a beam at its full range is drawn: DIAL - 20 px, shorter where the widest
        beam would otherwise leave the display (its end kept 10 px inside the sides; the
        submarine's ±39° beams are drawn 103 px long)."""
        widest = max((abs(math.sin(math.radians(a))) for a in self.angles), default=0.0)
        return DIAL - 20 if widest == 0 else round(min(DIAL - 20, (DIAL / 2 - 10) / widest), 1)


def _sonar(simulator: IRController, hooks: ModuleType) -> Sonar | None:
    angles, reach = getattr(hooks, "BEAMS", None), getattr(hooks, "SONAR_RANGE", None)
    if angles is None or reach is None:
        return None
    targets = next(
        action.targets
        for rule in simulator.every_cycle
        for action in rule.actions
        if isinstance(action, IRCall) and action.hook == "ping"
    )
    fields = [target.removeprefix("self.world_") for target in targets[: len(angles)]]
    return Sonar(fields, [float(a) for a in angles], float(reach))


@dataclass
class Scene:
    """What the run sailed among, in metres (x east, y north)."""

    keels: list[tuple[float, float, float]]  # (x, y, radius)
    route: list[tuple[float, float]]
    alternates: list[tuple[float, float]]
    haven: float | None  # half the side of the moving haven, if the system declares one
    outlines: list[list[tuple[float, float]]] = field(default_factory=list)  # other keels
    sonar: Sonar | None = None  # the forward-looking sonar's beams, if its hooks name them


def scene(system: IRSystem, system_dir: Path, settings: dict[str, str]) -> Scene:
    """The keels (the sonar simulator's hook state) and the route (the mission planner's)."""
    sonar = _factory_of(system, "ping")
    assert sonar.hooks_module is not None and sonar.hooks_state is not None
    hooks: ModuleType = import_hooks(system_dir, sonar.hooks_module)
    state = getattr(hooks, sonar.hooks_state)(settings)
    # the keels are the state, or its `keels` (a state that also keeps other ships)
    keels = [(float(x), float(y), float(r)) for x, y, r in getattr(state, "keels", state)]
    # and keels of any shape, by their outline (`points`)
    outlines = [
        [(float(x), float(y)) for x, y in shape.points] for shape in getattr(state, "shapes", [])
    ]
    route: list[tuple[float, float]] = []
    alternates: list[tuple[float, float]] = []
    for controller in system.controllers:
        if controller.plans and controller.hooks_state and controller.hooks_module:
            planner = import_hooks(system_dir, controller.hooks_module)
            mission = getattr(planner, controller.hooks_state)(settings)
            route = [(float(x), float(y)) for x, y in getattr(mission, "route", [])]
            alternates = [
                (float(x), float(y)) for x, y in getattr(mission, "alternates", {}).values()
            ]
    haven = next(
        (
            float(ast.literal_eval(literal))
            for controller in system.controllers
            for name, literal in controller.constants
            if name == "HAVEN"
        ),
        None,
    )
    return Scene(keels, route, alternates, haven, outlines, _sonar(sonar, hooks))


@dataclass
class Frame:
    """Metres to pixels: x east to the right, y north up."""

    x0: float
    y1: float
    scale: float
    width: int
    height: int

    def px(self, x: float, y: float) -> tuple[float, float]:
        return round((x - self.x0) * self.scale, 1), round((self.y1 - y) * self.scale, 1)


def frame(trace: Trace, found: Scene) -> Frame:
    drawn = [p for outline in found.outlines for p in outline]
    xs = [*trace.world["pos_x"], *(k[0] for k in found.keels), *(p[0] for p in found.route)]
    ys = [*trace.world["pos_y"], *(k[1] for k in found.keels), *(p[1] for p in found.route)]
    xs += [p[0] for p in drawn]
    ys += [p[1] for p in drawn]
    reach = max([k[2] for k in found.keels] + [0.0])
    x0, x1 = min(xs) - MARGIN - reach, max(xs) + MARGIN + reach
    y0, y1 = min(ys) - MARGIN - reach, max(ys) + MARGIN + reach
    scale = WIDTH / max(x1 - x0, y1 - y0)
    return Frame(x0, y1, scale, math.ceil((x1 - x0) * scale), math.ceil((y1 - y0) * scale))


def svg(trace: Trace, found: Scene, f: Frame) -> str:
    """The plan view: keels, route, track; the submarine and its haven, moved by the script."""
    out = [
        f'<svg id="sea" width="{f.width}" height="{f.height}" viewBox="0 0 {f.width} {f.height}">'
    ]
    out.append(f'<rect class="water" width="{f.width}" height="{f.height}"/>')
    out.append('<g id="keels">')
    for x, y, r in found.keels:
        cx, cy = f.px(x, y)
        out.append(f'<circle class="keel" cx="{cx}" cy="{cy}" r="{round(r * f.scale, 1)}"/>')
    for outline in found.outlines:
        points = " ".join(f"{px},{py}" for px, py in (f.px(*p) for p in outline))
        out.append(f'<polygon class="keel" points="{points}"/>')
    out.append("</g>")
    points = " ".join(f"{px},{py}" for px, py in (f.px(*p) for p in found.route))
    out.append(f'<polyline id="route" points="{points}"/>')
    for x, y in found.route:
        cx, cy = f.px(x, y)
        out.append(f'<circle class="waypoint" cx="{cx}" cy="{cy}" r="4"/>')
    for x, y in found.alternates:
        cx, cy = f.px(x, y)
        out.append(f'<circle class="alternate" cx="{cx}" cy="{cy}" r="4"/>')
    track = " ".join(
        f"{px},{py}"
        for px, py in (
            f.px(x, y) for x, y in zip(trace.world["pos_x"], trace.world["pos_y"], strict=True)
        )
    )
    out.append(f'<polyline id="track" points="{track}"/>')
    side = round(2 * (found.haven or 0.0) * f.scale, 1)
    out.append(f'<rect id="haven" width="{side}" height="{side}"/>')
    out.append('<g id="ship"><path d="M 0 -9 L 5 6 L 0 3 L -5 6 Z"/></g>')
    out.append("</svg>")
    return "".join(out)


def _beam_end(angle: float, reach: float) -> tuple[float, float]:
    """Where a beam of `reach` pixels at `angle` degrees off the bow ends, from the sonar
    display's origin (the bow, at the bottom's middle, the bow up)."""
    a = math.radians(angle)
    return round(DIAL / 2 + reach * math.sin(a), 1), round(DIAL - 10 - reach * math.cos(a), 1)


def displays(found: Scene) -> str:
    """Figure 33's displays beside the ice map, as SVG the script turns and fills: the
    bubble angle (the hull in profile, bow right), the heading and speed (a compass card,
    north up), the current sonar detection (every beam at its angle, drawn out to its
    range), the depth (the surface at the top, the ship, its order and the bottom)."""
    c, r = DIAL / 2, DIAL / 2 - 12
    out = [f'<svg id="bubble" class="display" width="{DIAL}" height="{DIAL}">']
    out.append(f'<line class="level" x1="8" y1="{c}" x2="{DIAL - 8}" y2="{c}"/>')
    out.append(f'<g id="hull" transform="translate({c} {c})">')
    out.append('<path d="M -55 0 Q -50 -9 -20 -9 L 35 -9 Q 58 -8 60 0 Q 58 8 35 9 L -20 9 ')
    out.append('Q -50 9 -55 0 Z"/><rect x="-2" y="-20" width="14" height="11"/></g>')
    out.append(f'<text id="bubble-text" x="{c}" y="{DIAL - 8}"></text></svg>')
    out.append(f'<svg id="compass" class="display" width="{DIAL}" height="{DIAL}">')
    out.append(f'<circle class="card" cx="{c}" cy="{c}" r="{r}"/>')
    out.append(f'<text x="{c}" y="18">N</text>')
    out.append(f'<line id="course-mark" x1="{c}" y1="{c - r}" x2="{c}" y2="{c - r + 10}"/>')
    out.append(f'<line id="heading-needle" x1="{c}" y1="{c}" x2="{c}" y2="{c - r + 6}"/>')
    out.append(f'<text id="speed-text" x="{c}" y="{c + 28}"></text></svg>')
    out.append(f'<svg id="sonar" class="display" width="{DIAL}" height="{DIAL}">')
    if found.sonar is not None:
        pixels = found.sonar.pixels
        for n, angle in enumerate(found.sonar.angles):
            x, y = _beam_end(angle, pixels)
            out.append(f'<line class="beam" id="beam-{n}" data-angle="{angle}" ')
            out.append(f'x1="{c}" y1="{DIAL - 10}" x2="{x}" y2="{y}"/>')
    out.append("</svg>")
    out.append(f'<svg id="depth-gauge" class="display" width="{DIAL}" height="{DIAL}">')
    out.append(f'<line class="surface" x1="20" y1="10" x2="{DIAL - 20}" y2="10"/>')
    out.append(f'<line id="depth-bottom" x1="20" x2="{DIAL - 20}" y1="0" y2="0"/>')
    out.append(f'<line id="depth-order" x1="20" x2="{DIAL - 20}" y1="0" y2="0"/>')
    out.append(f'<path id="depth-ship" d="M {c - 20} 0 l 40 0 l -6 -5 l -28 0 Z"/>')
    out.append(f'<text id="depth-text" x="{c}" y="{DIAL - 4}"></text></svg>')
    return "".join(out)


def payload(
    trace: Trace, system: IRSystem, found: Scene, f: Frame, scenario: str
) -> dict[str, Any]:
    table = StringTable()
    world: dict[str, list[Any]] = {}
    for name in (*REQUIRED, *SHOWN):
        if name in trace.world:
            series = trace.world[name]
            if name == "announcement":
                world[name] = runs(series, None, table)
            else:
                world[name] = [number(v) for v in series]
    sonar: dict[str, Any] | None = None
    if found.sonar is not None and all(n in trace.world for n in found.sonar.fields):
        beams = found.sonar.fields
        sonar = {"reach": found.sonar.reach, "angles": found.sonar.angles}
        sonar["pixels"] = found.sonar.pixels
        sonar["ranges"] = [[number(v) for v in trace.world[n]] for n in beams]
    # the depth display's scale: the deepest it has to show, ship, order or bottom
    depths = [v for n in ("depth", "depth_cmd", "bottom_depth") for v in trace.world.get(n, [])]
    controllers = player.panel(trace, PANEL, table)
    data = {
        "source": trace.name,
        "system": system.name,
        "scenario": scenario,
        "period": system.cycle_period,
        "speed": 50,  # times real time: the whole run in about half a minute
        "n": len(trace),
        "cycles": trace.cycles,
        "frame": {"x0": f.x0, "y1": f.y1, "scale": f.scale},
        "haven": found.haven,
        "sonar": sonar,
        "deepest": max([float(v) for v in depths if v is not None], default=None),
        "world": world,
        "controllers": controllers,
        "strings": table.values,
    }
    return data


def render(
    trace: Trace, system: IRSystem, system_dir: Path, settings: dict[str, str], scenario: str = ""
) -> str:
    """The page of a submarine trace."""
    missing = [name for name in REQUIRED if name not in trace.world]
    if missing:
        raise SeaError(
            f"{trace.name} lacks the world fields the sea view needs: {', '.join(missing)}; "
            "add them to the scenario's `trace: world:` list and run it again"
        )
    found = scene(system, system_dir, settings)
    f = frame(trace, found)
    title = f"{trace.name} · {system.name}: the transit among the ice"
    data = payload(trace, system, found, f, scenario)
    return player.page(
        "sea", title, {"SVG": svg(trace, found, f), "DISPLAYS": displays(found)}, data
    )


def page_for(
    trace: Trace, system: IRSystem, specs: Path, trace_path: Path, scenario: Path | None
) -> str:
    """`rcsgen trace sea`: the page of a trace of `system`, with the keel map and route
    settings of the scenario that recorded it (`scenario`, else the system's
    `scenarios/<trace name>.yaml` when there is one). SpecError: that scenario is bad."""
    from .recording import recording_scenario

    system_dir, settings, name = recording_scenario(system, specs, trace_path, scenario)
    return render(trace, system, system_dir, settings, name)
