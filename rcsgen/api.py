"""The Python API `rcsgen` exports: check specs, and build their packages as `rcsgen build` does.

    import rcsgen

    result = rcsgen.check(["specs/miner"])  # never raises on bad specs
    for diagnostic in result.diagnostics:
        print(diagnostic.render())
    built = rcsgen.build(["specs/"], "generated")  # all or nothing; SpecError on a problem

`rcsgen.cli`'s commands run the same steps, reporting as they go: `validate` (the specs and
their scenarios), `build`, and what `up` checks before it starts a package (`stale`).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from .compiler.diagnostics import Diagnostic, Diagnostics, SpecError
from .compiler.front_end.loader import load_file
from .compiler.frontend import SYSTEM_FILE, Frontend, Progress, compile_paths

StrPath = str | os.PathLike[str]


def _as_paths(paths: StrPath | Iterable[StrPath]) -> list[Path]:
    if isinstance(paths, str | os.PathLike):
        return [Path(paths)]
    return [Path(path) for path in paths]


def check(
    paths: StrPath | Iterable[StrPath], progress: Progress | None = None, analyse: bool = True
) -> Frontend:
    """Load and check the systems in `paths` (spec directories, searched recursively, or files
    in a system directory): `.systems` holds the checked ones, `.diagnostics` every problem.
    Bad specs never raise. `progress` hears what is being done, in a few words. Without
    `analyse` the state tables are not analysed (E5xx/W5xx): for a tool that only reads the
    systems' structure (the trace views), a fifth of the front end saved."""
    if progress is None:
        return compile_paths(_as_paths(paths), analyse=analyse)
    return compile_paths(_as_paths(paths), progress, analyse)


def validate(
    paths: StrPath | Iterable[StrPath], progress: Progress | None = None, connect: bool = False
) -> Frontend:
    """As `check`, and the scenarios of each system that builds checked against it: their
    diagnostics follow the specs' in `.diagnostics`. With `connect`, each declared I/O
    device is asked whether every bound point is there (E458)."""
    from .tools.scenario.check import check_system_scenarios

    front = check(paths, progress)
    diags = front.diagnostics
    for system in front.systems:
        found = check_system_scenarios(front.directories[system.name], system)
        diags = Diagnostics([*diags.items, *found.items], diags.acknowledged)
        if connect and system.io:  # issue 27: the devices themselves
            from .tools.io_connect import check_devices

            diags = Diagnostics([*diags.items, *check_devices(system).items], diags.acknowledged)
    front.diagnostics = diags
    return front


def system_name(system_dir: StrPath) -> str:
    """The name a system directory's `system.yaml` gives (its package's name); the
    directory's name when that file does not say."""
    data = load_file(Path(system_dir) / SYSTEM_FILE, SYSTEM_FILE)
    return str(data["system"]) if isinstance(data, dict) else Path(system_dir).name


def stale(system_dir: StrPath, generated: StrPath) -> tuple[Diagnostics, list[Diagnostic]]:
    """What stands between a built package and a start: the errors of the specs in
    `system_dir` (when they do not build), else E418 for a package in `generated` that is
    not exactly what they make (and the output directory's problems)."""
    from .compiler.back_end import write
    from .tools.scenario import runs

    front = check(system_dir)
    errors = Diagnostics(front.diagnostics.errors)
    if errors.items:
        return errors, []
    out = Path(generated)
    plan, problems = write.plan_build(front.systems, out)
    other = "--generated DIR where the package of these specs is"
    found = [runs.stale_package(plan, out, s.name, other) for s in front.systems]
    return errors, [*problems.errors, *(d for d in found if d is not None)]


@dataclass(frozen=True)
class Built:
    """What `build` did: the systems it built into `output`, and the files it changed."""

    output: Path
    systems: tuple[str, ...]
    written: tuple[Path, ...]  # new or changed files
    deleted: tuple[Path, ...]  # files rcsgen generated earlier that are no longer produced
    unchanged: int
    diagnostics: Diagnostics  # the warnings (with an error, `build` raises instead)


def build(
    paths: StrPath | Iterable[StrPath], output: StrPath = "generated", *, strict: bool = False
) -> Built:
    """Generate the packages of the systems in `paths` into `output` (`<output>/<system>/`).

    All or nothing, like `rcsgen build`: on any error (or any warning, with `strict`) it
    raises SpecError carrying every diagnostic and writes nothing.
    """
    from .compiler.back_end import write  # (rendering: not needed to check)

    front = check(paths)
    if front.diagnostics.errors or (strict and len(front.diagnostics)):
        raise SpecError(front.diagnostics)
    out = Path(output)
    plan, problems = write.plan_build(front.systems, out)
    if problems.errors:
        raise SpecError([*front.diagnostics.items, *problems.items])
    write.apply(plan)
    return Built(
        output=out,
        systems=tuple(s.name for s in front.systems),
        written=tuple(plan.write),
        deleted=tuple(plan.delete),
        unchanged=plan.unchanged,
        diagnostics=front.diagnostics,
    )
