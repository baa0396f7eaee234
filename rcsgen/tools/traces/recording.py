"""What recorded a trace: the systems worth checking first (`systems_naming`), and the
scenario, for the replay pages (`rcsgen trace mine`, `trace sea`): apart from `read`,
which the scenario runner imports, so that reading a trace never imports the runner."""

from __future__ import annotations

import re
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


# A controller's or operator's file declares its name on a line of its own (`controller: co`).
DECLARES = re.compile(r"""^(?:controller|operator):[ \t]*["']?([A-Za-z_][\w]*)""", re.MULTILINE)


def systems_naming(paths: list[Path], modules: set[str]) -> list[Path]:
    """The system directories under `paths`, in the front end's order, whose files declare a
    controller or operator of every name in `modules`: a text scan of the `*.yaml` files
    beside each system.yaml for their `controller:`/`operator:` line, nothing parsed. Only
    these can have recorded a trace of those modules, so a tool checks them before (and
    instead of) every system (checking one system is a sixth of checking specs/)."""
    from ...compiler.diagnostics import Diagnostics
    from ...compiler.frontend import find_system_dirs

    out = []
    for directory in find_system_dirs(paths, Diagnostics()):
        names: set[str] = set()
        for path in directory.glob("*.yaml"):
            try:
                names.update(DECLARES.findall(path.read_text(encoding="utf-8")))
            except (OSError, UnicodeDecodeError):
                continue  # (the front end says what is wrong with it, if it is checked)
        if modules <= names:
            out.append(directory)
    return out
