"""IR: the emit-ready form of a checked system, and its shared-memory layout.

Every name is resolved, every order and numeric code is fixed and every expression is
already printed as Python from its typed tree, so templates only place text. The layout
gives each module's command, status, mode and performance buffer and each world field a
fixed offset in one little-endian block (`struct` formats, no implicit padding).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from functools import cached_property

from ..runtime.contract import (
    COMMAND_HEAD_FIELDS,
    FORMAT_OF_TYPE,
    MODE_FIELDS,
    PERF_FIELDS,
    STATUS_FIELDS,
)

PY_TYPE = {"bool": "bool", "int": "int", "float": "float"}


# ---------------------------------------------------------------- layout


@dataclass(frozen=True)
class Slot:
    """One field of a buffer: name, struct code, offset in the whole block."""

    name: str
    code: str
    offset: int


@dataclass(frozen=True)
class Buffer:
    """A contiguous record in the block, read and written with one `struct.Struct`."""

    const: str  # the layout module's name for it, e.g. CO_COMMAND
    offset: int
    slots: tuple[Slot, ...]
    doc: str

    @cached_property
    def format(self) -> str:
        return "<" + "".join(slot.code for slot in self.slots)

    @cached_property
    def size(self) -> int:
        return struct.calcsize(self.format)


def _buffer(const: str, offset: int, fields: list[tuple[str, str]], doc: str) -> Buffer:
    slots, at = [], offset
    for name, code in fields:
        slots.append(Slot(name, code, at))
        at += struct.calcsize("<" + code)
    return Buffer(const, offset, tuple(slots), doc)


def align(offset: int, to: int = 8) -> int:
    """`offset` rounded up to a multiple of `to`."""
    return -(-offset // to) * to


@dataclass
class ModuleBuffers:
    command: Buffer
    status: Buffer
    mode: Buffer
    perf: Buffer


@dataclass
class Layout:
    modules: dict[str, ModuleBuffers]
    world: list[Buffer]
    size: int

    def all_buffers(self) -> list[Buffer]:
        found = [b for m in self.modules.values() for b in (m.command, m.status, m.mode, m.perf)]
        return sorted([*found, *self.world], key=lambda b: b.offset)


def attribute_of(field: str, buffer_fields: tuple[tuple[str, str], ...]) -> str:
    """The controller attribute a buffer field is copied to (the performance buffer's
    single_step_num is kept apart from the mode buffer's)."""
    return (
        "perf_single_step_num"
        if buffer_fields is PERF_FIELDS and field == "single_step_num"
        else field
    )


# Every attribute a generated controller keeps its own buffers in.
BUFFER_ATTRIBUTES = tuple(
    attribute_of(name, fields)
    for fields in (COMMAND_HEAD_FIELDS, STATUS_FIELDS, MODE_FIELDS, PERF_FIELDS)
    for name, _ in fields
    if name != "pad"
)


def plan_layout(controllers: list[IRController], world: list[IRWorldField]) -> Layout:
    """Place every module's buffers, then the world fields, each buffer on 8 bytes.

    A stand-in (controller simulator) has no buffers of its own: it uses its controller's.
    """
    at, modules = 0, {}
    for c in controllers:
        if c.buffers != c.name:
            continue
        prefix = c.name.upper()
        params = [(f"arg_{p.name}", FORMAT_OF_TYPE[p.type]) for p in c.params]
        parts = {
            "command": ([*COMMAND_HEAD_FIELDS, *params], "command in"),
            "status": (list(STATUS_FIELDS), "status out"),
            "mode": (list(MODE_FIELDS), "execution mode"),
            "perf": (list(PERF_FIELDS), "performance"),
        }
        made = {}
        for part, (fields, doc) in parts.items():
            made[part] = _buffer(f"{prefix}_{part.upper()}", at, fields, f"{c.name} {doc}")
            at = align(at + made[part].size)
        modules[c.name] = ModuleBuffers(**made)
    world_buffers = []
    for f in world:
        buffer = _buffer(f"WORLD_{f.name.upper()}", at, [(f.name, FORMAT_OF_TYPE[f.type])], f.doc)
        world_buffers.append(buffer)
        at = align(at + buffer.size)
    return Layout(modules, world_buffers, at)


# ---------------------------------------------------------------- system IR


@dataclass
class IRWorldField:
    name: str
    type: str
    initial: bool | int | float
    doc: str


@dataclass
class IRParam:
    name: str
    type: str
    doc: str = ""


@dataclass
class IRLocal:
    name: str
    type: str
    initial: bool | int | float
    doc: str


@dataclass
class IRSend:
    sub: str
    command_const: str  # e.g. CR_SUMP
    args: list[tuple[str, str]]  # (attribute, python expression)
    kind: str = "send"


@dataclass
class IRSet:
    assignments: list[tuple[str, str]]  # (attribute, python expression)
    kind: str = "set"


@dataclass
class IRReport:
    status: str  # DONE or ERROR
    kind: str = "report"


@dataclass
class IRCall:
    hook: str
    args: list[str]
    targets: list[str]  # attributes assigned from the hook's result
    kind: str = "call"


IRAction = IRSend | IRSet | IRReport | IRCall


@dataclass
class IRRule:
    doc: str
    guard: str | None  # None: always fires
    guard_operand: str | None  # the guard as an operand of `and`: `state == S1 and <guard>`
    actions: list[IRAction]
    next_state: str | None  # None: stay (NOP after a report)


@dataclass
class IRState:
    name: str
    rules: list[IRRule]


@dataclass
class IRCommand:
    name: str
    code: int
    doc: str
    method: str  # the state-table method, e.g. sump_shear_cusp
    params: list[IRParam]
    states: list[IRState]
    generated: bool


@dataclass
class IRSub:
    """A subordinate as its supervisor sees it: its command codes and parameter slots."""

    name: str
    commands: list[tuple[str, int]]  # (constant, code), e.g. ("CC_SUMP", 3)
    params: list[IRParam]


@dataclass
class IRController:
    name: str
    title: str
    doc: str
    source: str  # spec path relative to the specs root
    supervisor: str | None
    simulator: bool
    subordinates: list[IRSub]
    commands: list[IRCommand]
    params: list[IRParam]  # every command's parameters, one slot per name
    locals: list[IRLocal]
    constants: list[tuple[str, str]]  # (name, python literal)
    predicates: list[tuple[str, str, str]]  # (name, python expression, spec text)
    hooks_module: str | None
    hooks: list[str]
    world_reads: list[IRWorldField]  # copied in by pre_process
    world_writes: list[IRWorldField]  # copied out by post_process
    states: list[str] = field(default_factory=list)  # state names; code = index + 1
    every_cycle: list[IRRule] = field(default_factory=list)  # tried first, every cycle
    hooks_state: str | None = None  # hook-module factory of the state hooks receive first
    buffers: str = ""  # whose command/status buffers it uses: itself, or the replaced one


@dataclass
class IRProcess:
    name: str
    doc: str
    modules: list[str]
    roots: list[str]  # modules of this process with no supervisor: INIT is sent to them
    # controller -> (its stand-in, the modules of this process it replaces: itself + subtree)
    stand_ins: dict[str, tuple[str, list[str]]] = field(default_factory=dict)


@dataclass
class IRSystem:
    name: str
    title: str
    doc: str
    source: str
    cycle_period: float
    world: list[IRWorldField]
    controllers: list[IRController]
    processes: list[IRProcess]
    layout: Layout
    hook_modules: list[str]
    sources: list[str]  # every spec file the system was built from

    def controller(self, name: str) -> IRController:
        return next(c for c in self.controllers if c.name == name)
