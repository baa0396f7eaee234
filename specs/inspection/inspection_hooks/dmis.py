"""The task-level planners' interpreter: a small DMIS-like inspection program -> its setups,
features and tolerances (the paper's section 5.3.2: the measurement and fixturing nodes'
"PLs employ interpreters to interpret pre-generated plans which are coded in an industrial
standard language called DMIS (Dimensional Measuring Interface Standard)").

The program is a subset of DMIS's statements, one a line, `$$` starting a comment:

    DMISMN/'bracket B-7',05.0                  the program's name and DMIS version: first
    UNITS/MM,ANGDEC                            millimetres (the only length unit read)
    FIXTID/'SETUP 1',CLAMPS,2                  a setup: the part fixtured anew, with 2 clamps
    F(BORE_DIAMETER)=FEAT/CIRCLE,12.000        a feature and its nominal size, mm
    T(BORE_DIAMETER)=TOL/DIAM,-0.020,0.020     its tolerance band about the nominal, mm
    MEAS/CIRCLE,F(BORE_DIAMETER)               measure it, in the current setup
    ENDFIL                                     the end: last

A feature is measured (MEAS) after its F and T, in the setup of the FIXTID before it, in
the order of the MEAS statements; setups are numbered from 1 in `'SETUP n'`. Anything else
- a statement outside the subset, a number that is not one, a feature measured twice or
never defined, a band that does not hold its nominal - is refused with its file:line.
Feature labels are read in lower case (`bore_diameter`), as part files name them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path


class ProgramError(ValueError):
    """A line of an inspection program (or a part file) that cannot be read."""


@dataclass(frozen=True)
class Feature:
    """A MEAS of the program: what to measure, its nominal size and band, and its setup."""

    name: str
    nominal: float
    low: float
    high: float
    setup: int

    def accepts(self, reading: float) -> bool:
        return self.low <= reading <= self.high


@dataclass(frozen=True)
class Setup:
    """A FIXTID of the program: the setup the part is fixtured in, with its clamps."""

    number: int
    clamps: int


@dataclass
class Program:
    """An interpreted inspection program: its setups and its measurements, in order."""

    setups: list[Setup] = field(default_factory=list)
    features: list[Feature] = field(default_factory=list)


LABEL = r"\(([A-Z][A-Z0-9_]*)\)"
NUMBER = r"([-+]?[0-9]*\.?[0-9]+)"
STATEMENTS = {
    "DMISMN": re.compile(r"DMISMN/'[^']*',[0-9.]+"),
    "UNITS": re.compile(r"UNITS/(\w+)(,\w+)?"),
    "FIXTID": re.compile(r"FIXTID/'SETUP ([0-9]+)',CLAMPS,([0-9]+)"),
    "F": re.compile(rf"F{LABEL}=FEAT/(\w+),{NUMBER}"),
    "T": re.compile(rf"T{LABEL}=TOL/(\w+),{NUMBER},{NUMBER}"),
    "MEAS": re.compile(rf"MEAS/(\w+),F{LABEL}"),
    "ENDFIL": re.compile(r"ENDFIL"),
}


class _Reader:
    """The interpreter's state while it reads a program, line by line."""

    def __init__(self) -> None:
        self.program = Program()
        self.nominal: dict[str, float] = {}
        self.band: dict[str, tuple[float, float]] = {}
        self.started = self.ended = False

    def statement(self, text: str, where: str) -> None:
        head = re.match(r"[A-Z]+", text)
        kind = head.group(0) if head else ""
        pattern = STATEMENTS.get(kind)
        match = pattern.fullmatch(text) if pattern else None
        if match is None:
            known = ", ".join(STATEMENTS)
            raise ProgramError(f"{where}: {text!r} is not a statement of the subset ({known})")
        if self.ended:
            raise ProgramError(f"{where}: {kind} after ENDFIL")
        if not self.started and kind != "DMISMN":
            raise ProgramError(f"{where}: the program must begin with DMISMN, not {kind}")
        getattr(self, f"_{kind.lower()}")(match, where)

    def _dmismn(self, match: re.Match[str], where: str) -> None:
        if self.started:
            raise ProgramError(f"{where}: a second DMISMN")
        self.started = True

    def _units(self, match: re.Match[str], where: str) -> None:
        if match[1] != "MM":
            raise ProgramError(f"{where}: lengths must be in MM, not {match[1]}")

    def _fixtid(self, match: re.Match[str], where: str) -> None:
        number, clamps = int(match[1]), int(match[2])
        if number < 1 or clamps < 1:
            raise ProgramError(f"{where}: a setup is numbered from 1 and has a clamp at least")
        self.program.setups.append(Setup(number, clamps))

    def _f(self, match: re.Match[str], where: str) -> None:
        name = match[1].lower()
        if name in self.nominal:
            raise ProgramError(f"{where}: feature `{name}` is defined twice")
        self.nominal[name] = float(match[3])

    def _t(self, match: re.Match[str], where: str) -> None:
        name, low, high = match[1].lower(), float(match[3]), float(match[4])
        if name not in self.nominal:
            raise ProgramError(f"{where}: tolerance for `{name}`, which no F(...) defines")
        if not low < 0.0 < high:
            raise ProgramError(
                f"{where}: the band of `{name}` must hold its nominal (lower < 0 < upper)"
            )
        self.band[name] = (low, high)

    def _meas(self, match: re.Match[str], where: str) -> None:
        name = match[2].lower()
        if not self.program.setups:
            raise ProgramError(f"{where}: `{name}` measured before any FIXTID (no setup)")
        if name not in self.band:
            raise ProgramError(f"{where}: `{name}` measured with no F(...) and T(...) for it")
        if any(f.name == name for f in self.program.features):
            raise ProgramError(f"{where}: feature `{name}` is measured twice")
        nominal, (low, high) = self.nominal[name], self.band[name]
        setup = self.program.setups[-1].number
        self.program.features.append(Feature(name, nominal, nominal + low, nominal + high, setup))

    def _endfil(self, match: re.Match[str], where: str) -> None:
        self.ended = True


def read_program(path: Path) -> Program:
    """The program at `path`, interpreted; a bad line raises naming file:line."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise ProgramError(
            f"{path}: cannot read the inspection program ({error.strerror})"
        ) from None
    reader = _Reader()
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("$$", 1)[0].strip()
        if line:
            reader.statement(line, f"{path}:{number}")
    if not reader.ended:
        raise ProgramError(f"{path}: the inspection program has no ENDFIL")
    if not reader.program.features:
        raise ProgramError(f"{path}: the inspection program measures no feature")
    return reader.program
