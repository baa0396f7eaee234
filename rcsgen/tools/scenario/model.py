"""Scenario model: what a checked scenario file says, for the runner and its checker.

`check` makes a `Scenario` from a file (located diagnostics otherwise) and
`run` runs it; both read these types, neither the other's code.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...compiler.diagnostics import Span, SpecError
from ...compiler.front_end.loader import LocDict, load_file
from ...compiler.frontend import SYSTEM_FILE, real_path


@dataclass
class Event:
    """What happens before cycle `cycle` runs: a command to a module, world or mode changes."""

    cycle: int
    command: tuple[str, str] | None = None  # (module, COMMAND)
    args: dict[str, Any] = field(default_factory=dict)
    world: dict[str, Any] = field(default_factory=dict)
    mode: dict[str, dict[str, Any]] = field(default_factory=dict)
    doc: str = ""
    overrides: str | None = None  # the supervisor it is written under (`overrides: true`)
    answer: tuple[str, str, str] | None = None  # (channel, DONE|ERROR, reason): `ctl answer`
    answer_results: dict[str, Any] = field(default_factory=dict)  # with DONE: what is recorded
    force: dict[str, Any] = field(default_factory=dict)  # world fields forced: `ctl force`
    unforce: list[str] = field(default_factory=list)  # world fields released: `ctl unforce`
    replies: dict[str, str] = field(default_factory=dict)  # module -> DONE|ERROR, scripted
    device: DeviceFault | None = None  # a fault done to (or undone on) a soft PLC


# What a device event does to the soft PLC serving the device (docs/io.md, "Scenarios"):
# the plug pulled (the PLC killed: connections reset, none taken), put back (a PLC started
# again on the same port), frozen (it accepts and answers nothing), thawed.
UNPLUG, REPLUG, FREEZE, THAW = "unplug", "replug", "freeze", "thaw"
DEVICE_ACTIONS = (UNPLUG, REPLUG, FREEZE, THAW)
TAKES_DOWN = (UNPLUG, FREEZE)  # the actions after which the device must be lost in time


@dataclass(frozen=True)
class DeviceFault:
    """`device: {name, do}` of an event, and where it is written (the fail-safe check that
    follows a fault that takes the device down is reported there)."""

    name: str
    do: str  # one of DEVICE_ACTIONS
    span: Span


@dataclass(frozen=True)
class SoftPlc:
    """A device the run serves with a soft PLC (`devices:` of a scenario): the spec
    directory of the plant whose simulators run in it (None: a PLC whose inputs hold the
    initial values), and where it is declared."""

    name: str
    plant: Path | None
    span: Span


@dataclass(frozen=True)
class Expected:
    """One expected outcome (`expect:`): a final value, or bounds; where it is written."""

    what: str  # "status", "cycles", a world field, `<module>.reason` or `<module>.result.<name>`
    span: Span
    value: Any = None  # an exact value (status name, number, bool), or None
    low: float | None = None
    high: float | None = None

    def met(self, actual: Any) -> bool:
        if self.value is not None:
            if isinstance(self.value, bool) or isinstance(actual, bool):
                return isinstance(actual, bool) and actual is bool(self.value)
            if isinstance(self.value, str):
                return str(actual) == str(self.value)
            return isinstance(actual, int | float) and actual == self.value
        if isinstance(actual, bool) or not isinstance(actual, int | float):
            return False
        return (self.low is None or actual >= self.low) and (
            self.high is None or actual <= self.high
        )

    def wanted(self) -> str:
        if self.value is not None:
            shown = str(self.value).lower() if isinstance(self.value, bool) else self.value
            return f"{shown}"
        if self.low is not None and self.high is not None:
            return f"between {self.low:g} and {self.high:g}"
        return f"at least {self.low:g}" if self.low is not None else f"at most {self.high:g}"


@dataclass(frozen=True)
class ScriptedAnswer:
    """How the scripted person answers the requests it matches (`operator:` of a scenario)."""

    after: int  # cycles from taking the request up to the answer
    answer: str  # DONE, ERROR or never
    reason: str = ""  # with ERROR: one of the task's reasons ("": NONE)
    operator: str | None = None  # None: any
    task: str | None = None
    client: str | None = None
    results: tuple[tuple[str, Any], ...] = ()  # with DONE: what the person records

    def matches(self, request: dict[str, Any]) -> bool:
        return (
            self.operator in (None, request["operator"])
            and self.task in (None, request["task"])
            and self.client in (None, request["by"])
        )


@dataclass(frozen=True)
class OperatorScript:
    """The scripted person at the screen: answers by task and/or client, and a default."""

    answers: tuple[ScriptedAnswer, ...] = ()
    default: ScriptedAnswer | None = None  # None: unmatched requests are left to the console

    def how(self, request: dict[str, Any]) -> ScriptedAnswer | None:
        """How the person answers `request`; None: never (the console does)."""
        found = next((a for a in self.answers if a.matches(request)), self.default)
        return None if found is None or found.answer == "never" else found


@dataclass
class Scenario:
    name: str
    title: str
    path: Path
    system_dir: Path
    process: str | None
    max_cycles: int
    stop_when_done: str | None
    trace_world: list[str]
    events: list[Event]
    settings: dict[str, str] = field(default_factory=dict)  # for the hook-state factories
    simulate: tuple[str, ...] = ()  # controllers replaced by their stand-ins
    phases_of: str | None = None  # the module whose commands are the run's phases
    figures: list[str] = field(default_factory=list)  # world fields (or module.reason ...) shown
    expect: list[Expected] = field(default_factory=list)  # empty: stop module DONE, if any
    operator: OperatorScript | None = None  # the scripted person at the screen, if any
    devices: dict[str, SoftPlc] = field(default_factory=dict)  # served by soft PLCs, paced


def find_system_dir(path: Path, declared: object = None) -> Path | None:
    """The system a scenario file runs: the directory its `system:` names (`declared`,
    relative to the file), else the nearest directory above it holding a system.yaml; None
    when that directory holds none."""
    if isinstance(declared, str):
        named = real_path(path).parent / declared
        return named.resolve() if (named / SYSTEM_FILE).is_file() else None
    for parent in real_path(path).parents:
        if (parent / SYSTEM_FILE).is_file():
            return parent
    return None


def declared_system(path: Path) -> object:
    """The `system:` a scenario file declares (None without one, or when the file cannot be
    read: the scenario check then says why)."""
    try:
        data = load_file(path, str(path))
    except SpecError:
        return None
    return data.get("system") if isinstance(data, LocDict) else None
