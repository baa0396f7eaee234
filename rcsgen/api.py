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

from .compiler.back_end import write
from .compiler.diagnostics import Diagnostics, SpecError
from .compiler.frontend import Frontend, compile_paths

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
