"""Mine view: a miner trace + its coal map -> an HTML replay of the machine in the mine.

The paper's animation, from a recorded run: the coal map with its pillars and the cut so
far (plan view and a section along the entry), the machine at its traced pose with the
boom at its angle, the drum (turning when on), the jack, the conveyor and its tail, the
loose coal, and the controllers' commands and states. The page's shell (play/pause, speed,
the cycle slider, the clock, `#cycle=N`) is the replay views' common part (player.py).

Everything that moves comes from the trace's world fields. The map is the one the run
used: the environment simulator's own hooks (the `mine` controller's hook state and its
`cut_coal`) load it from the system directory with the scenario's settings, and replaying
`cut_coal` over the traced pose, boom angle and drum gives the cut cell by cell; where the
trace also holds `depth_cut`, the replay is checked against it.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from ...compiler.ir import IRController, IRSystem
from . import player
from .read import Lane, Trace
from .view import StringTable, number

REQUIRED = ("true_x", "true_y", "true_heading", "boom_angle_true", "drum_on_cmd")
SHOWN = (
    "loose_coal",
    "coal_mined",
    "depth_cut",
    "jack_down",
    "gather_on_cmd",
    "conveyor_on_cmd",
    "tail_request",
    "tail_in_position",
)
SEAM_HEIGHT = 2.0  # metres, as the mine hooks' tonnage assumes


class MineError(Exception):
    """A trace or system the replay cannot draw; one line."""


def mine_controller(system: IRSystem) -> IRController:
    """The environment simulator that cuts the coal map: keeps hook state, calls cut_coal."""
    for controller in system.controllers:
        if controller.hooks_state and "cut_coal" in controller.hooks and controller.hooks_module:
            return controller
    raise MineError(
        f"system {system.name} has no coal map to draw: the mine replay needs an environment "
        "simulator whose hooks keep the map (hooks_state) and cut it (a cut_coal hook)"
    )


def import_hooks(system_dir: Path, module: str) -> ModuleType:
    """The system's hook module, imported as the generated package imports it."""
    from ..harness import _use_hooks_from  # the harness's rule: this system's hooks first

    _use_hooks_from(system_dir.resolve())
    return importlib.import_module(module)


class _Recorder(dict[Any, Any]):
    """The map's cells, noting every cell the cut writes."""

    def __init__(self, cells: dict[Any, Any]) -> None:
        super().__init__(cells)
        self.written: dict[Any, Any] = {}

    def __setitem__(self, key: Any, value: Any) -> None:
        super().__setitem__(key, value)
        self.written[key] = value


@dataclass
class Replay:
    """The map as the run began and the cells the drum cut, cycle by cycle."""

    x0: float
    y0: float
    cell: float
    rows: int
    columns: int
    seam: dict[tuple[int, int], float]  # the standing coal at the start
    cuts: list[tuple[int, int, float]]  # (cycle index, cell index, standing height after)
    mismatch: str | None  # where the replayed depth of cut first differs from the trace's


def replay(trace: Trace, hooks: ModuleType, factory: str, settings: dict[str, str]) -> Replay:
    """Run the mine's own cut over the traced pose, boom angle and drum, cycle by cycle."""
    missing = [name for name in REQUIRED if name not in trace.world]
    if missing:
        raise MineError(
            f"{trace.name} lacks the world fields the mine replay needs: {', '.join(missing)}; "
            "add them to the scenario's `trace: world:` list and run it again"
        )
    mine = getattr(hooks, factory)(settings)
    start = dict(mine.seam)
    recorder = _Recorder(mine.seam)
    mine.seam = recorder
    rows = max([r for r, _ in start] + [0]) + 1
    columns = max([c for _, c in start] + [0]) + 1
    cuts: list[tuple[int, int, float]] = []
    mismatch = None
    w = trace.world
    traced_depth = w.get("depth_cut")
    previous: tuple[Any, ...] | None = None
    depth = 0.0
    for i in range(len(trace)):
        drum = (w["true_x"][i], w["true_y"][i], w["boom_angle_true"][i], w["drum_on_cmd"][i])
        if drum != previous:  # the same drum in the same place cuts nothing more: skip it
            recorder.written = {}
            _, _, depth, _ = hooks.cut_coal(mine, *drum)
            written = sorted(recorder.written.items())
            cuts += [(i, r * columns + c, round(h, 4)) for (r, c), h in written]
            previous = drum
        if traced_depth is not None and mismatch is None and traced_depth[i] != depth:
            mismatch = (
                f"cycle {trace.cycles[i]}: the replayed depth of cut is {depth} m, the trace's "
                f"{traced_depth[i]} m; was the trace recorded with another map (--scenario)?"
            )
    cell = float(getattr(hooks, "CELL", 0.25))
    return Replay(mine.x0, mine.y0, cell, rows, columns, start, cuts, mismatch)


def payload(
    trace: Trace,
    lanes: list[Lane],
    result: Replay,
    hooks: ModuleType,
    system: IRSystem,
    scenario: str,
) -> dict[str, Any]:
    table = StringTable()
    cells = "".join(
        "#" if (r, c) in result.seam else "."
        for r in range(result.rows)
        for c in range(result.columns)
    )
    shown = tuple(  # the top four levels
        lane.module for lane in lanes if not lane.simulator and lane.level and lane.level <= 4
    )
    controllers = player.panel(trace, shown, table)
    world: dict[str, list[Any]] = {}
    for name in (*REQUIRED, *SHOWN):
        if name in trace.world:
            series = trace.world[name]
            if all(isinstance(v, bool) for v in series):
                world[name] = [int(v) for v in series]
            else:
                world[name] = [number(v) for v in series]
    data = {
        "source": trace.name,
        "system": system.name,
        "title": system.title,
        "scenario": scenario,
        "period": system.cycle_period,
        "speed": 4,
        "n": len(trace),
        "cycles": trace.cycles,
        "map": {
            "x0": result.x0,
            "y0": result.y0,
            "cell": result.cell,
            "rows": result.rows,
            "columns": result.columns,
            "cells": cells,
            "standing": {
                str(r * result.columns + c): h for (r, c), h in result.seam.items() if h != 1.0
            },
            "cuts": [x for cut in result.cuts for x in cut],
        },
        "machine": {
            "drum_radius": float(getattr(hooks, "DRUM_RADIUS", 0.5)),
            "drum_half_width": float(getattr(hooks, "DRUM_HALF_WIDTH", 1.6)),
            "drum_height": float(getattr(hooks, "DRUM_HEIGHT", 0.4)),
            "roof_angle": float(getattr(hooks, "ROOF_ANGLE", 30.0)),
            "floor_angle": float(getattr(hooks, "FLOOR_ANGLE", -10.0)),
            "seam": SEAM_HEIGHT,
        },
        "world": world,
        "controllers": controllers,
        "strings": table.values,
        "mismatch": result.mismatch,
    }
    return data


def render(
    trace: Trace,
    lanes: list[Lane],
    system: IRSystem,
    system_dir: Path,
    settings: dict[str, str],
    scenario: str = "",
) -> tuple[str, Replay]:
    """The page and the replay it shows (its `mismatch` says if the trace disagrees)."""
    controller = mine_controller(system)
    assert controller.hooks_module is not None and controller.hooks_state is not None
    hooks = import_hooks(system_dir, controller.hooks_module)
    result = replay(trace, hooks, controller.hooks_state, settings)
    title = f"{trace.name} · {system.name}: the machine in the mine"
    data = payload(trace, lanes, result, hooks, system, scenario)
    return player.page("mine", title, {}, data), result


def page_for(
    trace: Trace, system: IRSystem, specs: Path, trace_path: Path, scenario: Path | None
) -> tuple[str, Replay]:
    """`rcsgen trace mine`: the page of a trace of `system` (in the specs under `specs`),
    with the map setting of the scenario that recorded it (`scenario`, else the system's
    `scenarios/<trace name>.yaml` when there is one). SpecError: that scenario is bad."""
    from .read import lanes
    from .recording import recording_scenario

    system_dir, settings, name = recording_scenario(system, specs, trace_path, scenario)
    return render(trace, lanes(trace, system), system, system_dir, settings, name)
