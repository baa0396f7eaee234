"""The Python API `rcsgen` exports: check specs, and build their packages as `rcsgen build` does.

    import rcsgen

    result = rcsgen.check(["specs/miner"])  # never raises on bad specs
    for diagnostic in result.diagnostics:
        print(diagnostic.render())
    built = rcsgen.build(["specs/"], "generated")  # all or nothing; SpecError on a problem

`rcsgen.cli`'s `build` command runs the same steps, reporting as it goes.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from .compiler import emit
from .compiler.diagnostics import Diagnostics, SpecError
from .compiler.frontend import Frontend, compile_paths
from .compiler.ir import IRSystem

StrPath = str | os.PathLike[str]


def _as_paths(paths: StrPath | Iterable[StrPath]) -> list[Path]:
    if isinstance(paths, str | os.PathLike):
        return [Path(paths)]
    return [Path(path) for path in paths]


def check(paths: StrPath | Iterable[StrPath]) -> Frontend:
    """Load and check the systems in `paths` (spec directories, searched recursively, or files
    in a system directory): `.systems` holds the checked ones, `.diagnostics` every problem.
    Bad specs never raise."""
    return compile_paths(_as_paths(paths))


def plan_build(systems: list[IRSystem], output: Path) -> tuple[emit.Plan, Diagnostics]:
    """Render every file of `systems` and compare them with `output`: what a build writes and
    deletes, and the errors that stop it (symlinks, paths leaving `output`, files in the way
    that rcsgen did not generate). Nothing is written."""
    files = emit.render_all(systems)
    problems = Diagnostics()
    plan = emit.plan_outputs(files, output, [s.name for s in systems], problems)
    return plan, problems


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
    front = check(paths)
    if front.diagnostics.errors or (strict and len(front.diagnostics)):
        raise SpecError(front.diagnostics)
    out = Path(output)
    plan, problems = plan_build(front.systems, out)
    if problems.errors:
        raise SpecError([*front.diagnostics.items, *problems.items])
    emit.apply(plan)
    return Built(
        output=out,
        systems=tuple(s.name for s in front.systems),
        written=tuple(plan.write),
        deleted=tuple(plan.delete),
        unchanged=plan.unchanged,
        diagnostics=front.diagnostics,
    )
