"""Measurement's hooks: an inspection-program file -> its features, and each reading judged.

An inspection program (the paper's measurement planner interprets DMIS; this is a small
stand-in) is a text file, one feature per line: a name, the nominal size and the
tolerance either side, in millimetres, and the setup the part is fixtured in to measure
it (a whole number from 1: the workstation's plan, section 5.3.2, fixtures the part for
each run of features of one setup, then has them measured); `#` starts a comment:

    # feature       nominal   tolerance  setup
    bore_diameter   12.000    0.020      1

The features are measured in the file's order; MEASURE_PART's `feature` indexes them.
INSPECT_PART names the program (its `program` argument, passed on to MEASURE_PART):
`bracket` is programs/bracket.ipg. The run's `program` setting is read when the run starts.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

SYSTEM_DIR = Path(__file__).resolve().parent.parent
DEFAULT_PROGRAM = "programs/bracket.ipg"


@dataclass(frozen=True)
class Feature:
    """One line of the program: what to measure and the size it must have."""

    name: str
    nominal: float
    tolerance: float
    setup: int

    def accepts(self, reading: float) -> bool:
        return abs(reading - self.nominal) <= self.tolerance


@dataclass
class Program:
    """The run's inspection program and the readings judged so far (name, reading, ok)."""

    features: list[Feature]
    readings: list[tuple[str, float, bool]] = field(default_factory=list)


class ProgramError(ValueError):
    """A line of an inspection program (or a part file) that cannot be read."""


def read_program(path: Path) -> list[Feature]:
    """The features of the program file at `path`; a bad line raises naming file:line."""
    features: list[Feature] = []
    names: set[str] = set()
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ProgramError(f"{path}: cannot read the inspection program ({error.strerror})") from None
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        where = f"{path}:{number}"
        if len(line) != 4:
            raise ProgramError(
                f"{where}: expected `name nominal tolerance setup`, got {raw.strip()!r}"
            )
        name, nominal, tolerance = line[0], _number(line[1], where), _number(line[2], where)
        if tolerance <= 0:
            raise ProgramError(f"{where}: the tolerance of `{name}` must be positive")
        if not line[3].isdigit() or int(line[3]) < 1:
            raise ProgramError(f"{where}: the setup of `{name}` must be a whole number from 1")
        if name in names:
            raise ProgramError(f"{where}: feature `{name}` is measured twice")
        names.add(name)
        features.append(Feature(name, nominal, tolerance, int(line[3])))
    if not features:
        raise ProgramError(f"{path}: the inspection program measures no feature")
    return features


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
    """Measurement's hook state: the run's inspection program."""
    return Program(read_program(program_path(settings)))


PROGRAM_NAME = re.compile(r"[a-z0-9_]+")


def named_program(name: str) -> list[Feature]:
    """The features of the inspection program `name` (programs/<name>.ipg)."""
    if not PROGRAM_NAME.fullmatch(name):
        raise ProgramError(f"{name!r} is not an inspection program's name (a-z, 0-9, _)")
    return read_program(SYSTEM_DIR / "programs" / f"{name}.ipg")


def program_features(program: Program, name: str) -> int:
    """Read the inspection program `name` (programs/<name>.ipg) for this MEASURE_PART; how
    many features it measures."""
    program.features = named_program(name)
    return len(program.features)


def judge(program: Program, feature: int, reading: float) -> bool:
    """Whether `reading` of the program's `feature` lies within its tolerance (recorded)."""
    spec = program.features[feature]
    ok = spec.accepts(reading)
    program.readings.append((spec.name, reading, ok))
    return ok
