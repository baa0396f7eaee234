"""Measurement's planner (the PL of the paper's task-level measurement node, section 5.3.2,
which interprets a DMIS program): an inspection program and a schedule of it -> the
features to measure, each with the band its reading must lie in.

The program is a small DMIS-like file (inspection_hooks/dmis.py reads it): its features in
the order they are measured, each its nominal size, its tolerance band and the setup the
part is fixtured in to measure it. MEASURE_PART's schedule (its first feature and how many,
from the workstation's plan) is planned into one step per feature; the executor, MS's
table, has the CMM inspect each and judges the reading against the step's band.
INSPECT_PART names the program (its `program` argument): `bracket` is programs/bracket.dmi.
The run's `program` setting is read when the run starts, so a bad line stops the run there.
"""

from __future__ import annotations

import re
from pathlib import Path

from .dmis import Feature, Program, ProgramError, read_program as read_dmis

SYSTEM_DIR = Path(__file__).resolve().parent.parent
DEFAULT_PROGRAM = "programs/bracket.dmi"
PROGRAM_NAME = re.compile(r"[a-z0-9_]+")

__all__ = ["Feature", "Program", "ProgramError", "SYSTEM_DIR", "read_program"]


def read_program(path: Path) -> list[Feature]:
    """The features of the program file at `path`, in the order they are measured."""
    return read_dmis(path).features


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ProgramError(f"{where}: `{text}` is not a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise ProgramError(f"{where}: `{text}` is not a finite number")
    return value


def program_path(settings: dict[str, str]) -> Path:
    """The run's `program` setting, relative to the system directory."""
    return SYSTEM_DIR / settings.get("program", DEFAULT_PROGRAM)


def new_program(settings: dict[str, str]) -> Program:
    """Measurement's hook state: the run's inspection program, read when the run starts."""
    return read_dmis(program_path(settings))


def named(name: str) -> Program:
    """The inspection program `name` (programs/<name>.dmi), interpreted."""
    if not PROGRAM_NAME.fullmatch(name):
        raise ProgramError(f"{name!r} is not an inspection program's name (a-z, 0-9, _)")
    return read_dmis(SYSTEM_DIR / "programs" / f"{name}.dmi")


def named_program(name: str) -> list[Feature]:
    """The features of the inspection program `name` (programs/<name>.dmi)."""
    return named(name).features


def feature_schedule(
    program: Program, name: str, first: int, count: int
) -> list[tuple[int, float, float]]:
    """MS's plan of a MEASURE_PART: the steps (feature, low, high) of program `name`'s
    schedule of `count` features from feature `first`, each the feature's index and the band
    its reading must lie in, in mm."""
    features = named_program(name)
    return [(i, features[i].low, features[i].high) for i in range(first, min(first + count, len(features)))]
