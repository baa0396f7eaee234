"""IR: the frozen, emit-ready form of a checked system, and its shared-memory layout.

Every name is resolved, every order and numeric code is fixed. Each expression carries its
typed tree, its spec text and its Python text; each rule its stable id and source span, so
templates only place text, and tools (diagrams, monitors, coverage) read rules without
re-deriving them. The layout gives each module's command, status, mode and performance
buffer and each world field a fixed offset in one little-endian block.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property

from ..runtime.contract import STARTUP_TIMEOUT
from ..runtime.io_points import Device
from . import expressions as expr
from .checks.tables import RuleId
from .diagnostics import Span
from .front_end.model import ModuleKind, PlanVerb
from .types import Type

# ---------------------------------------------------------------- layout


@dataclass(frozen=True)
class Slot:
    """One field of a buffer: name, struct code, offset in the whole block, and the capacity
    of the string it holds (0: not a string)."""

    name: str
    code: str
    offset: int
    text: int = 0


@dataclass(frozen=True)
class Buffer:
    """A contiguous record in the block, read and written with one `struct.Struct`."""

    const: str  # the layout module's name for it, e.g. CO_COMMAND
    offset: int
    slots: tuple[Slot, ...]

    @cached_property
    def format(self) -> str:
        return "<" + "".join(slot.code for slot in self.slots)

    @property
    def fields(self) -> tuple[Slot, ...]:
        """The buffer's fields after its sequence word."""
        return self.slots[1:]

    @cached_property
    def size(self) -> int:
        return struct.calcsize(self.format)


@dataclass(frozen=True)
class ModuleBuffers:
    command: Buffer
    status: Buffer
    mode: Buffer
    perf: Buffer


@dataclass(frozen=True)
class Channel:
    """An operator module's channel to one client: the command buffer the client writes,
    the status buffer the operator module writes, the answer record the answering side
    (the console, a scenario's scripted operator) writes."""

    command: Buffer
    status: Buffer
    answer: Buffer


@dataclass(frozen=True)
class OperatorBuffers:
    """An operator module's own mode and performance buffers, and a channel per client."""

    mode: Buffer
    perf: Buffer
    channels: dict[str, Channel]  # client -> its channel, in execution order


def channel_key(operator: str, client: str) -> str:
    """How the layout, traces and the console name a channel: `op/fx`."""
    return f"{operator}/{client}"


@dataclass(frozen=True)
class Layout:
    """The block: the header at 0, each process's control record, each module's buffers, the
    world fields. `hash` identifies it (a process refuses to attach to another layout)."""

    processes: dict[str, Buffer]
    modules: dict[str, ModuleBuffers]
    world: tuple[Buffer, ...]
    size: int
    hash: str
    pacing: dict[str, Buffer] = field(default_factory=dict)  # each process's pacing record
    operators: dict[str, OperatorBuffers] = field(default_factory=dict)
    # Overrides (rcs/override.py): the flag "some world field is under an override", then
    # per world field its override record (state and value), after the world fields.
    overrides: Buffer | None = None
    override_fields: tuple[Buffer, ...] = ()
    io: dict[str, Buffer] = field(default_factory=dict)  # each I/O device's record
    # Each controller's (and stand-in's) time in each state: a cycle count per state code,
    # counted by the runtime's loop (rcs/state_time.py), last in the block
    state_time: dict[str, Buffer] = field(default_factory=dict)

    @cached_property
    def world_by_name(self) -> dict[str, Buffer]:
        """Each world field's buffer by the field's name (made once: every module asks)."""
        return {b.fields[0].name: b for b in self.world}

    def handshake(self, module: str, client: str) -> tuple[Buffer, Buffer]:
        """The command and status buffers through which `client` commands `module`: the
        module's own, or an operator module's channel to that client."""
        if module in self.operators:
            channel = self.operators[module].channels[client]
            return channel.command, channel.status
        return self.modules[module].command, self.modules[module].status

    def all_buffers(self) -> list[Buffer]:
        found = [b for m in self.modules.values() for b in (m.command, m.status, m.mode, m.perf)]
        for o in self.operators.values():
            found += [o.mode, o.perf]
            found += [b for c in o.channels.values() for b in (c.command, c.status, c.answer)]
        every = [*self.processes.values(), *self.pacing.values(), *found, *self.world]
        every += [self.overrides] if self.overrides is not None else []
        every += self.override_fields
        every += self.io.values()
        every += self.state_time.values()
        return sorted(every, key=lambda b: b.offset)


# ---------------------------------------------------------------- a module's reads and writes


@dataclass(frozen=True)
class Gathered:
    """Several buffer fields read or written with one `Struct`, the bytes between them
    skipped: format, offset, the target of each value ("_" for a sequence word), the struct
    of the sequence words alone (for the second read of a seqlock), if any, and the struct
    of the values alone at the same offset (the sequence words skipped); the targets that
    hold strings (decoded after a read), and each value as packed (a string encoded)."""

    format: str
    offset: int
    targets: tuple[str, ...]
    seq_indices: tuple[int, ...]
    seq_format: str
    seq_offset: int
    values_format: str
    texts: tuple[str, ...] = ()
    packed: tuple[str, ...] = ()
    seq_words: tuple[int, ...] = ()  # the sequence words, as indices of 8-byte words


@dataclass(frozen=True)
class WorldRun:
    """Adjacent world buffers a module writes with one struct, and the layout's names of
    their offsets (where each sequence word is stored on its own)."""

    gathered: Gathered
    seq_at: tuple[str, ...]


@dataclass(frozen=True)
class ModuleIO:
    """What a generated module names about the block, all decided by `module_io`: the
    prefix of its buffers' layout names, its imports, its class's attributes, its one read
    of the inputs and its writes (each value as packed), the strings it decodes."""

    own: str  # CO: CO_STATUS_AT, CO_PERF_AT, ... (a stand-in: its controller's)
    imports: tuple[str, ...]  # from its package's layout
    rcs_imports: tuple[str, ...] = ()  # from the runtime contract
    slots: tuple[str, ...] = ()
    inputs: Gathered | None = None
    world_outputs: tuple[Gathered, ...] = ()
    # The sequence words it stores, as (name, the layout offset it is the index of: `name =
    # offset >> 3`): its status, each subordinate's command, its world fields'; and the
    # name each write uses.
    stored_words: tuple[tuple[str, str], ...] = ()
    status_word: str = ""
    sub_words: dict[str, str] = field(default_factory=dict)  # subordinate -> its command's
    world_seq_words: tuple[tuple[str, ...], ...] = ()  # each world run's fields'
    world_values: tuple[tuple[str, ...], ...] = ()
    world_names: tuple[tuple[str, ...], ...] = ()  # each run's fields: their override records
    command_targets: tuple[str, ...] = ()
    status_targets: tuple[str, ...] = ()
    status_struct: str = "STATUS"  # its layout's own struct when it has results
    status_values: tuple[str, ...] = ()
    mode_targets: tuple[str, ...] = ()
    perf_targets: tuple[str, ...] = ()
    sub_targets: dict[str, tuple[str, ...]] = field(default_factory=dict)
    sub_values: dict[str, tuple[str, ...]] = field(default_factory=dict)
    input_texts: tuple[str, ...] = ()
    resume_texts: tuple[str, ...] = ()
    # Its cycle may stop short when idle with nothing new (`idle_shortcut`)
    idle_shortcut: bool = False
    world_set_rules: tuple[RuleId, ...] = ()  # every_cycle rules that raise the `world_set` flag


# ---------------------------------------------------------------- system IR


@dataclass(frozen=True)
class IRExpr:
    """An expression three ways: its typed tree, as the spec writes it, as Python."""

    tree: expr.Expr
    text: str
    python: str


@dataclass(frozen=True)
class IRWorldField:
    name: str
    type: Type
    initial: bool | int | float | str  # an enum's value name, a string's text
    doc: str
    actuator: bool
    # an actuator's safe value (an enum's value name, a string's text): `safe:`, or the
    # type's zero (false, 0, 0.0, the first value, ""); None for a field that is no actuator
    safe: bool | int | float | str | None
    ground_truth: bool  # the simulation's truth, which no sensor gives (E280)


class PropKind(StrEnum):
    """What an atom of a user's property reads in a cycle of its supervisor's model
    (docs/spec.md section 19)."""

    STATE = "state"  # <supervisor>.state == <state>: its table state after the cycle
    COMMAND = "command"  # <supervisor>.command == <COMMAND>: the command it executes
    STATUS = "status"  # <supervisor>.status == <STATUS>: its status after the cycle
    SUB_STATUS = "sub_status"  # <sub>.status == <STATUS>: as the supervisor reads it
    SUB_COMMAND = "sub_command"  # <sub>.command == <COMMAND>: the last one sent to it
    SENT = "sent"  # sent(<sub>.<COMMAND>): sent to it in this cycle
    WRITES = "writes"  # writes(<local>) / writes(world.<field>): a rule that fired sets it
    SAFE = "safe"  # safe(world.<actuator>): the value last set is its safe value


@dataclass(frozen=True)
class IRPropAtom:
    kind: PropKind
    module: str  # the supervisor or the subordinate it is about ('' for WRITES and SAFE)
    value: str  # the state, command or status compared with; the command sent; the name


@dataclass(frozen=True)
class IRPropExpr:
    """A property's condition: an atom, `not`, `and`, `or`, or a constant."""

    op: str  # "atom", "not", "and", "or", "true", "false"
    atom: IRPropAtom | None = None
    args: tuple[IRPropExpr, ...] = ()

    def atoms(self) -> list[IRPropAtom]:
        found = [self.atom] if self.atom is not None else []
        for arg in self.args:
            found += arg.atoms()
        return found


@dataclass(frozen=True)
class IRProperty:
    """A property of the engineer's own, checked by `rcsgen prove` in the model of
    `controller` (the supervisor whose view it is stated in): `then` holds in every
    cycle (`whenever` None), or in the cycle `whenever` holds or one of `within` after."""

    name: str
    controller: str
    span: Span
    text: str  # as written, for messages
    then: IRPropExpr
    whenever: IRPropExpr | None = None
    within: int = 0
    doc: str = ""


@dataclass(frozen=True)
class IRParam:
    name: str
    type: Type
    doc: str = ""
    # an operator task's result: the range a DONE answer's value must lie in (None: open)
    low: float | None = None
    high: float | None = None


@dataclass(frozen=True)
class IRLocal:
    name: str
    type: Type
    initial: bool | int | float | str  # an enum's value name, a string's text
    doc: str


@dataclass(frozen=True)
class IRArg:
    """A parameter of a command sent: `self.<sub>_arg_<param> = <value>`."""

    param: str
    attribute: str
    value: IRExpr


@dataclass(frozen=True)
class IRSend:
    """`send: <sub>.<COMMAND>`: its arguments set, its command code and number written."""

    sub: str
    command: str
    command_const: str  # e.g. CR_SUMP
    args: tuple[IRArg, ...]
    command_attribute: str = ""  # where the command code goes: self.cr_command
    number_attribute: str = ""  # the command number counted up: self.cr_command_num


@dataclass(frozen=True)
class IRAssign:
    target: str  # as the spec writes it: world.goal_x, ticks
    attribute: str  # self.world_goal_x, self.var_ticks
    value: IRExpr


@dataclass(frozen=True)
class IRSet:
    """`set:` world fields, locals and results, in order."""

    assignments: tuple[IRAssign, ...]


@dataclass(frozen=True)
class IRReport:
    """`report: DONE` or `report: ERROR`, with a reason of its own or one passed up."""

    status: str  # DONE or ERROR
    reason_name: str  # as the spec names it (REFUSED, or fx.reason when passed up; '' none)
    reason: str = ""  # the reason's constant (REASON_REFUSED), '' when none is given
    reason_of: str = ""  # the subordinate whose reason is passed up, by name (fx)
    # with reason_of: its reason constants -> this controller's (FX_REASON_REFUSED,
    # REASON_REFUSED); any other code it reports is passed up as NONE
    reason_map: tuple[tuple[str, str], ...] = ()
    reason_of_attribute: str = ""  # with reason_of: where its reason is read (self.fx_error_num)


@dataclass(frozen=True)
class IRCall:
    """`call: <hook>`: the hook called, its result checked and assigned to the targets."""

    hook: str
    args: tuple[str, ...]  # Python text of each argument (the hook state first, if any)
    targets: tuple[str, ...]  # attributes assigned from the hook's result
    kinds: str = ""  # each target's token in the result check (types.Type.hook_kind)
    span: Span | None = None  # where the spec calls it


@dataclass(frozen=True)
class IRPlanAction:
    """An action on a plan (a base: IRLoadPlan or IRAdvance)."""

    plan: str

    @property
    def verb(self) -> PlanVerb:
        raise NotImplementedError


@dataclass(frozen=True)
class IRLoadPlan(IRPlanAction):
    """`plan:` / `replan:`: the planner called with `args`, its steps checked and loaded
    (a replan counted against the plan's `replans`)."""

    planner: str = ""
    replan: bool = False
    args: tuple[str, ...] = ()  # Python text of each argument (the hook state first, if any)
    span: Span | None = None  # where the spec writes it
    replans: int = 0  # the replans the plan declares
    load: str = ""  # its load method: self.plan_route_load
    replans_left: str = ""  # its counter: self.plan_route_replans_left

    @property
    def verb(self) -> PlanVerb:
        return PlanVerb.REPLAN if self.replan else PlanVerb.PLAN


@dataclass(frozen=True)
class IRAdvance(IRPlanAction):
    """`advance:`: the plan's next step becomes the current one."""

    go: str = ""  # its method that makes a step current: self.plan_route_go
    step: str = ""  # its current step: self.plan_route_step

    @property
    def verb(self) -> PlanVerb:
        return PlanVerb.ADVANCE


IRAction = IRSend | IRSet | IRReport | IRCall | IRLoadPlan | IRAdvance


@dataclass(frozen=True)
class IRRule:
    id: RuleId
    span: Span
    doc: str
    guard: IRExpr | None  # None: always fires
    guard_operand: str | None  # the guard as an operand of `and`: `state == S1 and <guard>`
    actions: tuple[IRAction, ...]
    next_state: str | None  # None: stay (NOP after a report)
    code: int = 0  # what the status buffer's `rule` shows when it fires; 0: not recorded
    timing: str = ""  # its `after:`/`for:` as a comment shows them, with the cycles
    # The subordinate whose ERROR its guard requires (`fx.status == ERROR` among its `and`
    # terms): firing, it records that subordinate's link as the cause of a later ERROR.
    cause_of: str = ""


@dataclass(frozen=True)
class IRCounter:
    """The counter of a `for:` rule: `self.<attribute> = self.<attribute> + 1 if <condition>
    else 0`, updated first in its state every cycle the table runs there."""

    attribute: str  # e.g. held_hold_ice_s1_2
    condition: IRExpr  # the rule's `when`


@dataclass(frozen=True)
class IRState:
    name: str
    span: Span
    rules: tuple[IRRule, ...]
    counters: tuple[IRCounter, ...] = ()  # of its `for:` rules, in rule order


@dataclass(frozen=True)
class IRFunction:
    """A pure function, emitted as a module-level `def`."""

    name: str
    params: tuple[tuple[str, Type], ...]  # (name, type) in call order
    returns: Type
    body: IRExpr
    doc: str = ""  # the spec's, the docstring's first paragraph


@dataclass(frozen=True)
class IRCommand:
    name: str
    code: int
    doc: str
    method: str  # the state-table method, e.g. sump_shear_cusp
    params: tuple[IRParam, ...]
    states: tuple[IRState, ...]
    generated: bool
    span: Span
    first_match: tuple[str, ...]  # states whose rules may overlap: the earlier wins
    timed: bool  # a rule waits (`after:`/`for:`): the method keeps `ticks` up to date
    lets: tuple[tuple[str, IRExpr], ...]  # its named values, computed first each cycle
    results: tuple[IRParam, ...]  # the results it declares
    reasons: tuple[str, ...]  # the reasons it declares
    text: str  # an operator module's task: the instruction the screen shows ('' none)


@dataclass(frozen=True)
class IRSub:
    """A subordinate as its supervisor sees it: its command codes and parameter slots."""

    name: str
    commands: tuple[tuple[str, int], ...]  # (constant, code), e.g. ("CC_SUMP", 3)
    params: tuple[IRParam, ...]
    echo_cycles: int | None = None  # cycles it may take to echo a command: then ERROR
    reasons: tuple[tuple[str, int], ...] = ()  # its reasons' constants, when a guard reads one
    results: tuple[IRParam, ...] = ()  # the results of it a guard or value reads
    channel: str = ""  # an operator module's channel to this supervisor (`op/fx`), if it is one
    # `on_lost: continue`: while its process is lost, its status reads ERROR (reason LOST) and
    # the supervisor's own rules handle it (the runtime sets `<sub>_lost`)
    continue_on_lost: bool = False
    # Reasons survive (docs/semantics.md): its number in the layout's CAUSE_MODULES, and
    # whether a rule of the supervisor records its link (then its reason, and its own cause
    # when its status buffer has one, `chained`, are read with its status).
    link: int = 0
    caused: bool = False
    chained: bool = False

    @property
    def key(self) -> str:
        """How the layout's tables name the buffers the supervisor uses: `cr`, `op/fx`."""
        return self.channel or self.name

    @property
    def prefix(self) -> str:
        """The layout's prefix of the buffers the supervisor uses: `CR`, or `OP_FX`."""
        return (self.channel or self.name).replace("/", "_").upper()


@dataclass(frozen=True)
class IRPredicate:
    name: str
    expr: IRExpr


@dataclass(frozen=True)
class IRPlan:
    """A plan: its planner, its step fields in order, capacity and replans."""

    name: str
    doc: str
    planner: str
    fields: tuple[IRParam, ...]
    capacity: int
    replans: int
    args: tuple[str, ...] = ()  # the spec text of the planner's arguments

    @property
    def kinds(self) -> str:
        """Each field's type, one letter (f, i, b), as the runtime's plan check takes them."""
        return "".join(t.type.hook_kind for t in self.fields)

    @property
    def status_fields(self) -> tuple[str, ...]:
        """Its slots in the status buffer: the step, the number of steps, the replans left."""
        return tuple(f"plan_{self.name}_{n}" for n in ("step", "steps", "replans_left"))


@dataclass(frozen=True)
class IRInstance:
    """A controller that is an instance's copy of a template's controller (docs/spec.md
    section 18): the instance, the template, the controller's name there."""

    instance: str
    template: str
    member: str


@dataclass(frozen=True)
class IRController:
    name: str
    title: str
    doc: str
    source: str  # spec path relative to the specs root
    supervisor: str | None
    simulator: bool
    subordinates: tuple[IRSub, ...]
    commands: tuple[IRCommand, ...]
    params: tuple[IRParam, ...]  # every command's parameters, one slot per name
    locals: tuple[IRLocal, ...]
    constants: tuple[tuple[str, str], ...]  # (name, python literal)
    predicates: tuple[IRPredicate, ...]
    hooks_module: str | None  # imported only when a rule calls a hook or hook state is kept
    hooks: tuple[str, ...]
    world_reads: tuple[IRWorldField, ...]  # copied in by pre_process
    world_writes: tuple[IRWorldField, ...]  # copied out by post_process
    states: tuple[str, ...]  # state names; code = index + 1
    every_cycle: tuple[IRRule, ...]  # tried first, every cycle
    hooks_state: str | None  # hook-module factory of the state hooks receive first
    hooks_state_on_restart: str  # "refuse" or "reset"
    buffers: str  # whose command/status buffers it uses: itself, or the replaced one
    runtime_names: tuple[str, ...]  # what the module imports from the runtime contract
    hooks_state_span: Span | None = None  # where `hooks_state` names the factory
    hooks_module_span: Span | None = None  # where `hooks_module` names the module
    timed: bool = False  # some table waits: the controller keeps `ticks`
    results: tuple[IRParam, ...] = ()  # its commands' results, one status slot per name
    reasons: tuple[tuple[str, int], ...] = ()  # its reasons' constants and codes (from 2)
    functions: tuple[IRFunction, ...] = ()  # its pure functions, in declaration order
    counters: tuple[str, ...] = ()  # every `for:` counter attribute, in table order
    # The counters of `for:` every_cycle rules: updated first every cycle, never reset.
    every_cycle_counters: tuple[IRCounter, ...] = ()
    # the enumeration values its expressions name: (value name, index), a module constant each
    enum_values: tuple[tuple[str, int], ...] = ()
    plans: tuple[IRPlan, ...] = ()  # its plans, in declaration order
    # Each hook and planner its tables call: the seconds one call may run before it is
    # interrupted (its `deadline:`, else the default), by name.
    # each hook and planner its tables call: (name, deadline in seconds, the kinds its result
    # is checked against, or None: a planner's, checked by its plan, or a hook with no targets)
    hook_calls: tuple[tuple[str, float, str | None], ...] = ()
    kind: ModuleKind = ModuleKind.CONTROLLER  # OPERATOR: a person at a screen, no table
    clients: tuple[str, ...] = ()  # an operator module's: whom it serves, one channel each
    io: ModuleIO | None = None  # its reads and writes of the block (set once it is laid out)
    instance: IRInstance | None = None  # a template's controller, copied for an instance
    # its status buffer has a `cause` field (a controller that declares reasons): the chain
    # of subordinates' errors its ERROR comes from (docs/semantics.md, "Reasons survive")
    cause: bool = False

    @property
    def is_operator(self) -> bool:
        return self.kind is ModuleKind.OPERATOR

    @property
    def origin(self) -> str:
        """Its spec as a generated header names it: the file, and the instance it is of."""
        if self.instance is None:
            return self.source
        i = self.instance
        return f"{self.source}, `{i.member}` of template `{i.template}` as instance `{i.instance}`"

    @property
    def channels(self) -> tuple[str, ...]:
        """An operator module's channels as the layout names them (`op/fx`)."""
        return tuple(channel_key(self.name, client) for client in self.clients)

    def table_rules(self) -> list[IRRule]:
        """Every rule of the state tables, in code order (code = index + 1)."""
        return [
            rule for command in self.commands for state in command.states for rule in state.rules
        ]

    def rules(self) -> list[IRRule]:
        """Every rule: every_cycle first, then each table's, state by state."""
        return [*self.every_cycle, *self.table_rules()]


@dataclass(frozen=True)
class IRProcess:
    name: str
    cycle_period: float
    doc: str
    modules: tuple[str, ...]
    roots: tuple[str, ...]  # modules of this process with no supervisor: INIT is sent to them
    # controller -> (its stand-in, the modules of this process it replaces: itself + subtree)
    stand_ins: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    # its declared watchdog limits (rcs/loop.py Watchdog's fields); the rest keep their default
    watchdog: dict[str, float] = field(default_factory=dict)
    io: tuple[str, ...] = ()  # the I/O devices it runs (read first, written last)
    realtime: dict[str, object] = field(default_factory=dict)  # rcs/realtime.py's settings
    # module -> where the process lists it (`processes: p: modules:`): findings about order
    module_spans: dict[str, Span] = field(default_factory=dict)


@dataclass(frozen=True)
class IRRequest:
    """A request a module makes of the operator: open while `open_while` is true,
    answered by sending `command` to `module`."""

    name: str
    doc: str
    by: str
    open_while: str
    module: str
    command: str


@dataclass(frozen=True)
class IRSystem:
    name: str
    title: str
    doc: str
    source: str
    cycle_period: float
    heartbeat_timeout: float  # seconds without a heartbeat before a process is reported dead
    world: tuple[IRWorldField, ...]
    controllers: tuple[IRController, ...]
    processes: tuple[IRProcess, ...]
    layout: Layout
    sources: tuple[str, ...]  # every spec file the system was built from
    name_span: Span  # where `system:` names it
    # role -> module -> index in ACCESS_LEVELS, above monitor; empty: no access control
    access: dict[str, dict[str, int]] = field(default_factory=dict)
    # role -> (its users, its groups), for the roles that name who holds them
    role_holders: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = field(default_factory=dict)
    segment_group: str | None = None  # the OS group that shares the segment (mode 0660)
    requests: tuple[IRRequest, ...] = ()  # what modules ask of the operator
    # each actuator world field -> the process whose modules write it (the first by name when
    # several do): who latches it safe when it stops (rcs/override.py)
    actuated_by: dict[str, str] = field(default_factory=dict)
    # each process -> the buffers it writes into its own block, in layout order: what a
    # network transport sends from it (rcs/transport.py)
    writes: dict[str, tuple[Buffer, ...]] = field(default_factory=dict)
    # The run settings its hook-state factories read (name, doc); None: not declared (any
    # setting is taken when a controller has a factory, none otherwise)
    settings: tuple[tuple[str, str], ...] | None = None
    startup_timeout: float = STARTUP_TIMEOUT  # seconds the start-up barrier waits
    # Fieldbus devices (the runtime's own declarations, rcs/io_points.py) and, for each, the
    # controllers that read its inputs or write its outputs (safe state when it is lost)
    io: tuple[Device, ...] = ()
    io_dependents: dict[str, tuple[str, ...]] = field(default_factory=dict)
    # where each device (its name) and each of its points (`device.field`) is declared
    io_spans: dict[str, Span] = field(default_factory=dict)
    # the engineer's own properties (`properties:`), for `rcsgen prove` only
    properties: tuple[IRProperty, ...] = ()

    def controller(self, name: str) -> IRController:
        return next(c for c in self.controllers if c.name == name)
