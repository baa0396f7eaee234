"""Front end: spec paths -> IR systems, running load, schema, model, check, analysis, lower.

A system is a directory holding one `system.yaml`; every other `*.yaml` file beside it is
one controller. Sub-directories (scenarios, hook packages) are not read here.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from .analysis.tables import analyse_system
from .back_end.lower import lower_system
from .checks import acknowledge
from .checks.check import check_system
from .checks.properties import check_properties
from .codes import Severity
from .collector import no_collections
from .diagnostics import Diagnostics, Span, SpecError
from .front_end import fragments, instances, model
from .front_end.loader import LocDict, PathProblem, load_file, path_problem, span_of
from .front_end.schema import check_document
from .ir import IRSystem

SYSTEM_FILE = "system.yaml"


@dataclass
class Frontend:
    """What the front end made of some spec paths: systems and every diagnostic."""

    systems: list[IRSystem] = field(default_factory=list)
    diagnostics: Diagnostics = field(default_factory=Diagnostics)
    directories: dict[str, Path] = field(default_factory=dict)  # system name -> its directory
    # system name -> its model (system and controller specs): `prove` reads `allow:`,
    # `actuator:` and `properties:` there, which the IR does not carry
    models: dict[str, tuple[model.SystemSpec, list[model.ControllerSpec]]] = field(
        default_factory=dict
    )


def real_path(path: Path) -> Path:
    """`path` absolute with its symbolic links resolved as far as they go (a link loop or a
    dangling link is left as it is: reading it reports the problem)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symlink loop (Python 3.11)
        return path.absolute()


def display_path(path: Path) -> str:
    """A path as diagnostics show it: relative to the working directory when inside it,
    whole (absolute) when not (`../../etc/x.yaml` says less than `/etc/x.yaml`)."""
    # The file's own name as given (a symlink's problems are the link's), its directory real.
    shown = real_path(path.parent) / path.name if path.name else real_path(path)
    here = real_path(Path.cwd())
    return (shown.relative_to(here) if shown.is_relative_to(here) else shown).as_posix()


def source_path(path: Path, system_dir: Path) -> str:
    """A spec's path as generated headers name it: `<system dir>/<file>`, on any machine. A
    spec file that is a symbolic link (a variant system sharing another's controllers) is
    named where it is linked, not where it points."""
    root = real_path(system_dir)
    return f"{root.name}/{(real_path(path.parent) / path.name).relative_to(root).as_posix()}"


# Directories deeper than this below a path given on the command line are not searched.
MAX_DIR_DEPTH = 32


def _entries(directory: Path, diags: Diagnostics) -> list[os.DirEntry[str]]:
    """The entries of a directory by name; an unreadable one is an error (E010)."""
    try:
        with os.scandir(directory) as found:
            return sorted(found, key=lambda entry: entry.name)
    except OSError as exc:
        problem = path_problem(directory, "dir") or _unreadable(exc)
        diags.error(Span(display_path(directory)), problem.code, problem.message, problem.hint)
        return []


def _unreadable(exc: OSError) -> PathProblem:
    reason = "permission denied" if isinstance(exc, PermissionError) else exc.strerror
    return PathProblem("E010", f"cannot read directory: {reason or exc}", "check its permissions")


def _systems_under(root: Path, diags: Diagnostics) -> list[Path]:
    """Every directory holding a system.yaml at or below `root` (symlinked directories are not
    followed, as `rglob` does not); unreadable directories are errors, depth is bounded."""
    found, todo = [], [(root, 0)]
    while todo:
        directory, depth = todo.pop()
        subdirectories = []
        for entry in _entries(directory, diags):
            if entry.name == SYSTEM_FILE:
                found.append(directory)
            elif _is_real_dir(entry):
                subdirectories.append(Path(entry.path))
        if subdirectories and depth >= MAX_DIR_DEPTH:
            diags.error(
                Span(display_path(directory)),
                "E014",
                f"directories nest more than {MAX_DIR_DEPTH} levels below "
                f"`{display_path(root)}`; not searched further",
                "point rcsgen at the system directory itself",
            )
            continue
        todo.extend((sub, depth + 1) for sub in reversed(subdirectories))
    return sorted(set(found))


def _is_real_dir(entry: os.DirEntry[str]) -> bool:
    try:
        return entry.is_dir(follow_symlinks=False)
    except OSError:
        return False


def find_system_dirs(paths: list[Path], diags: Diagnostics) -> list[Path]:
    """The system directories named by `paths` (directories are searched recursively)."""
    found: list[Path] = []
    for path in paths:
        shown = display_path(path)
        problem = path_problem(path, "any")
        if problem is not None and problem.message.endswith("no such file or directory"):
            diags.error(Span(shown), "E010", f"`{shown}` does not exist")
        elif problem is not None:
            diags.error(Span(shown), problem.code, f"`{shown}`: {problem.message}", problem.hint)
        elif path.is_dir():
            before = len(diags.errors)
            dirs = _systems_under(path, diags)
            if not dirs and len(diags.errors) == before:  # else: an unreadable directory
                diags.error(
                    Span(shown),
                    "E224",
                    f"no {SYSTEM_FILE} found under `{shown}`",
                    "a system directory holds system.yaml and one <mnemonic>.yaml per controller",
                )
            found.extend(dirs)
        elif (path.parent / SYSTEM_FILE).is_file():
            found.append(path.parent)
        else:
            diags.error(
                Span(shown),
                "E224",
                f"`{shown}` is not in a system directory",
                f"put it beside a {SYSTEM_FILE}",
            )
    return list(dict.fromkeys(real_path(d) for d in found))


def _load(path: Path, diags: Diagnostics) -> object:
    try:
        return load_file(path, display_path(path))
    except SpecError as error:
        diags.extend(error.diagnostics.items)
        return None


def _empty(path: Path, what: str, diags: Diagnostics) -> None:
    diags.error(
        Span(display_path(path)),
        "E013",
        f"`{path.name}` is empty: it holds no YAML, only blank lines or comments",
        f"write the {what} here, or delete the file",
    )


Progress = Callable[[str], None]  # told what a long stage is doing, for a progress line


def _quiet(_: str) -> None:
    pass


def load_system(
    directory: Path,
    diags: Diagnostics,
    progress: Progress = _quiet,
    models: dict[str, tuple[model.SystemSpec, list[model.ControllerSpec]]] | None = None,
    analyse: bool = True,
) -> IRSystem | None:
    """Load, schema-check, model and check one system directory (its model kept in
    `models`, when given, for the system that builds); without `analyse`, the state tables'
    analysis (E5xx/W5xx) is left out: for a tool that reads the system's structure only."""
    first = len(diags.items)
    uses: list[fragments.Use] = []
    made: list[instances.Instance] = []
    try:
        return _load_system(directory, diags, progress, uses, made, models, analyse)
    finally:
        fragments.annotate(diags, uses, first)
        instances.annotate(diags, made, first)


def _shared_fragments(directory: Path, diags: Diagnostics) -> dict[str, fragments.Fragment | None]:
    """The fragments of the directory's `fragments.yaml` (none without one)."""
    path = directory / fragments.FILE
    if not path.is_file():
        return {}
    shown = display_path(path)
    loaded = len(diags.errors)
    data = _load(path, diags)
    if len(diags.errors) > loaded:
        return {}
    if not isinstance(data, LocDict) or set(data) != {"fragments"}:
        where: Span = getattr(data, "span", Span(shown))
        other = [key for key in data if key != "fragments"] if isinstance(data, LocDict) else []
        diags.error(  # at the first key besides `fragments:`, if that is what is wrong
            span_of(other[0], where) if other else where,
            "E269",
            f"`{fragments.FILE}` must hold one key, `fragments:`",
            "a shared fragment file declares fragments only",
        )
        return {}
    return fragments.read(data["fragments"], Span(shown), diags)


def _load_system(
    directory: Path,
    diags: Diagnostics,
    progress: Progress,
    uses: list[fragments.Use],
    made: list[instances.Instance],
    models: dict[str, tuple[model.SystemSpec, list[model.ControllerSpec]]] | None = None,
    analyse: bool = True,
) -> IRSystem | None:
    progress(f"loading {display_path(directory)}")
    start, first = len(diags.errors), len(diags.items)
    system_path = directory / SYSTEM_FILE
    system = _system_spec(system_path, diags, made)
    controllers = _controller_specs(directory, diags, uses, made)
    if system is None or len(diags.errors) > start:
        acknowledge.apply(controllers, diags, first, complete=False)
        return None
    progress(f"checking {system.name}: {len(controllers)} controllers")
    checked = check_system(system, controllers, diags)
    if checked is None:
        acknowledge.apply(controllers, diags, first, complete=False)
        return None
    if analyse:
        progress(f"analysing the state tables of {system.name}")
        analyse_system(checked, diags)  # E5xx/W5xx, with counter-examples
    properties = check_properties(system, controllers, diags)  # E710-E714
    acknowledge.apply(controllers, diags, first, complete=analyse)  # allow: and first_match
    if len(diags.errors) > start:
        return None
    sources = {
        c.display: c.instance.source
        if c.instance
        else source_path(directory / Path(c.display).name, directory)
        for c in controllers
    }
    sources[system.display] = source_path(system_path, directory)
    if models is not None:
        models[system.name] = (system, controllers)
    lowered = lower_system(checked, sources)
    return replace(lowered, properties=properties) if properties else lowered


def _system_spec(
    system_path: Path, diags: Diagnostics, made: list[instances.Instance]
) -> model.SystemSpec | None:
    """The system's spec, read once (its name's span travels with it to the IR), or None
    after its problems; its instances (checked, their own world fields, simulators and
    stand-ins added to the system's data) are appended to `made`."""
    loaded = len(diags.errors)
    data = _load(system_path, diags)
    if data is None and len(diags.errors) == loaded:
        _empty(system_path, "system spec", diags)
    if data is None:
        return None
    shown = display_path(system_path)
    problems = check_document(data, "system", shown)
    diags.extend(problems)
    if any(p.severity is Severity.ERROR for p in problems):
        return None
    before = len(diags.errors)
    if isinstance(data, LocDict):  # always, once schema-valid
        made += instances.expand_system(data, system_path.parent, display_path, diags)
    if len(diags.errors) > before:
        return None
    return model.build_system(data, system_path.parent, shown)


def _controller_specs(
    directory: Path,
    diags: Diagnostics,
    uses: list[fragments.Use],
    made: list[instances.Instance],
) -> list[model.ControllerSpec]:
    """Every controller and operator spec of the directory, then of each instance, fragments
    expanded (each use appended to `uses`), schema-checked; W305 for a shared fragment
    nobody uses."""
    start = len(diags.errors)
    controllers = []
    shared = _shared_fragments(directory, diags)
    used: set[str] = set()  # fragment names the controllers use
    for entry in _entries(directory, diags):
        path = Path(entry.path)
        if not entry.name.endswith(".yaml") or entry.name in (SYSTEM_FILE, fragments.FILE):
            continue
        loaded = len(diags.errors)
        data = _load(path, diags)
        if data is None:
            if len(diags.errors) == loaded:
                _empty(path, "controller spec", diags)
            continue
        spec = _controller_spec(path, data, shared, diags, uses, used)
        if spec is not None:
            controllers.append(spec)
    for instance, member, path, data in instances.copies(made):
        origin = model.InstanceOf(
            instance.name, instance.template.name, member, source_path(path, directory)
        )
        spec = _controller_spec(
            path,
            data,
            shared,
            diags,
            uses,
            used,
            functools.partial(_renamed, instance=instance, member=member),
        )
        if spec is not None:
            spec.display = f"{spec.display} (instance {instance.name})"  # (one key per module)
            spec.instance = origin
            controllers.append(spec)
    if len(diags.errors) == start:  # (a misspelt use would make it noise)
        fragments.report_unused(shared, used, diags)
    return controllers


def _renamed(data: LocDict, instance: instances.Instance, member: str) -> LocDict:
    return instances.rename(data, instance, member)


def _controller_spec(
    path: Path,
    data: object,
    shared: dict[str, fragments.Fragment | None],
    diags: Diagnostics,
    uses: list[fragments.Use],
    used: set[str],
    instance: Callable[[LocDict], LocDict] | None = None,
) -> model.ControllerSpec | None:
    """One controller's (or operator module's) spec from its loaded data, or None after its
    problems (E225 for a file that is neither); `instance` renames a template controller's
    data, fragments expanded, as an instance's."""
    shown = display_path(path)
    if isinstance(data, LocDict) and "operator" in data and "controller" not in data:
        data = instance(data) if instance else data
        problems = check_document(data, "operator", shown)
        diags.extend(problems)
        if any(p.severity is Severity.ERROR for p in problems):
            return None
        return model.build_operator(data, shown)
    if not isinstance(data, dict) or "controller" not in data:
        diags.error(
            getattr(data, "span", Span(shown)),
            "E225",
            f"`{path.name}` is not a controller spec (no `controller:` or `operator:` key)",
            "only system.yaml, fragments.yaml and controller or operator files belong "
            "in a system directory",
        )
        return None
    before = len(diags.errors)
    used |= fragments.named(data)
    made, whole = fragments.expand(data, shared, diags, Span(shown))
    used |= {use.fragment.name for use in made}  # (also those used within fragments)
    uses += made
    if not whole or len(diags.errors) > before:
        return None  # a use that failed leaves a table with a hole: no more about it
    if instance is not None and isinstance(data, LocDict):
        data = instance(data)
    problems = check_document(data, "controller", shown)
    diags.extend(problems)
    if any(p.severity is Severity.ERROR for p in problems):
        return None
    return model.build_controller(data, shown)


def compile_paths(paths: list[Path], progress: Progress = _quiet, analyse: bool = True) -> Frontend:
    """Run the front end over every system found in `paths`; never raises on bad input.
    `progress` is told what each long stage is doing; `analyse` as for `load_system`."""
    with no_collections():
        return _compile_paths(paths, progress, analyse)


def _compile_paths(paths: list[Path], progress: Progress, analyse: bool) -> Frontend:
    out = Frontend()
    names: dict[str, Span] = {}
    for directory in find_system_dirs(paths, out.diagnostics):
        system = load_system(directory, out.diagnostics, progress, out.models, analyse)
        if system is None:
            continue
        out.systems.append(system)
        out.directories.setdefault(system.name, directory)
        span = system.name_span
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
