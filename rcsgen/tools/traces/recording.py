"""The scenario that recorded a trace, for the replay pages (`rcsgen trace mine`, `trace
sea`): apart from `read`, which the scenario runner imports, so that reading a trace never
imports the runner."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...compiler.ir import IRSystem


def recording_scenario(
    system: IRSystem, specs: Path, trace_path: Path, scenario: Path | None
) -> tuple[Path, dict[str, Any], str]:
    """For a replay page of a trace of `system` (in the specs under `specs`): the system's
    directory, and the settings and name of the scenario that recorded the trace
    (`scenario`, else the system's `scenarios/<trace name>.yaml` when there is one; none:
    `{}` and `""`). SpecError: that scenario is bad."""
    from ...compiler.diagnostics import Diagnostics
    from ...compiler.frontend import find_system_dirs
    from ..scenario.run import load_scenario

    system_dir = next(
        d for d in find_system_dirs([specs], Diagnostics()) if d.name == system.source.split("/")[0]
    )
    if scenario is None:
        guess = system_dir / "scenarios" / f"{trace_path.stem}.yaml"
        scenario = guess if guess.is_file() else None
    settings = load_scenario(scenario).settings if scenario is not None else {}
    return system_dir, settings, scenario.stem if scenario is not None else ""
