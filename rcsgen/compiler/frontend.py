"""Front end: spec paths -> IR systems, running load, schema, model, check, analysis, lower.

A system is a directory holding one `system.yaml`; every other `*.yaml` file beside it is
one controller. Sub-directories (scenarios, hook packages) are not read here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from . import model
from .analysis import analyse_system
from .check import check_system
from .diagnostics import Diagnostics, Span, SpecError
from .ir import IRSystem
from .loader import LocDict, load_file
from .lower import lower_system
from .schema import check_document

SYSTEM_FILE = "system.yaml"


@dataclass
class Frontend:
    """What the front end made of some spec paths: systems and every diagnostic."""

    systems: list[IRSystem] = field(default_factory=list)
    diagnostics: Diagnostics = field(default_factory=Diagnostics)


def display_path(path: Path) -> str:
    """A path as diagnostics show it: relative to the working directory when inside it."""
    try:
        return Path(os.path.relpath(path.resolve(), Path.cwd())).as_posix()
    except ValueError:  # another drive
        return path.as_posix()


def source_path(path: Path, system_dir: Path) -> str:
    """A spec's path as generated headers name it: `<system dir>/<file>`, on any machine."""
    return (
        f"{system_dir.resolve().name}/{path.resolve().relative_to(system_dir.resolve()).as_posix()}"
    )


def find_system_dirs(paths: list[Path], diags: Diagnostics) -> list[Path]:
    """The system directories named by `paths` (directories are searched recursively)."""
    found: list[Path] = []
    for path in paths:
        if path.is_dir():
            dirs = sorted({p.parent for p in path.rglob(SYSTEM_FILE)})
            if not dirs:
                diags.error(
                    Span(display_path(path)),
                    "E224",
                    f"no {SYSTEM_FILE} found under `{display_path(path)}`",
                    "a system directory holds system.yaml and one <mnemonic>.yaml per controller",
                )
            found.extend(dirs)
        elif path.is_file():
            if (path.parent / SYSTEM_FILE).is_file():
                found.append(path.parent)
            else:
                diags.error(
                    Span(display_path(path)),
                    "E224",
                    f"`{display_path(path)}` is not in a system directory",
                    f"put it beside a {SYSTEM_FILE}",
                )
        else:
            diags.error(Span(display_path(path)), "E010", f"`{display_path(path)}` does not exist")
    return list(dict.fromkeys(d.resolve() for d in found))


def _load(path: Path, diags: Diagnostics) -> object:
    try:
        return load_file(path, display_path(path))
    except SpecError as error:
        diags.extend(error.diagnostics.items)
        return None


def load_system(directory: Path, diags: Diagnostics) -> IRSystem | None:
    """Load, schema-check, model and check one system directory."""
    start = len(diags.errors)
    system_path = directory / SYSTEM_FILE
    data = _load(system_path, diags)
    system: model.SystemSpec | None = None
    if data is not None:
        shown = display_path(system_path)
        problems = check_document(data, "system", shown)
        diags.extend(problems)
        if not any(p.severity == "error" for p in problems):
            system = model.build_system(data, directory, shown)
    controllers = []
    for path in sorted(directory.glob("*.yaml")):
        if path.name == SYSTEM_FILE:
            continue
        data = _load(path, diags)
        shown = display_path(path)
        if not isinstance(data, dict) or "controller" not in data:
            if data is not None or path.stat().st_size == 0:
                diags.error(
                    getattr(data, "span", Span(shown)),
                    "E225",
                    f"`{path.name}` is not a controller spec (no `controller:` key)",
                    "only system.yaml and controller files belong in a system directory",
                )
            continue
        problems = check_document(data, "controller", shown)
        diags.extend(problems)
        if not any(p.severity == "error" for p in problems):
            controllers.append(model.build_controller(data, shown))
    if system is None or len(diags.errors) > start:
        return None
    checked = check_system(system, controllers, diags)
    if checked is None:
        return None
    analyse_system(checked, diags)  # E5xx/W5xx, with counter-examples
    if len(diags.errors) > start:
        return None
    sources = {
        c.display: source_path(directory / Path(c.display).name, directory) for c in controllers
    }
    sources[system.display] = source_path(system_path, directory)
    return lower_system(checked, sources)


def compile_paths(paths: list[Path]) -> Frontend:
    """Run the front end over every system found in `paths`; never raises on bad input."""
    out = Frontend()
    names: dict[str, Span] = {}
    for directory in find_system_dirs(paths, out.diagnostics):
        system = load_system(directory, out.diagnostics)
        if system is None:
            continue
        out.systems.append(system)
        span = _system_name_span(directory / SYSTEM_FILE)
        if system.name in names:
            out.diagnostics.error(
                span,
                "E231",
                f"two systems are named `{system.name}`",
                f"the other is {names[system.name]}; each system gets its own output directory",
            )
        else:
            names[system.name] = span
    return out


def _system_name_span(path: Path) -> Span:
    """Where a (valid) system file gives its name, as diagnostics show it."""
    shown = display_path(path)
    try:
        data = load_file(path, shown)
    except SpecError:
        return Span(shown)
    if not isinstance(data, LocDict):
        return Span(shown)
    return data.value_spans.get("system", Span(shown))
