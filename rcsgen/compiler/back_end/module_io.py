"""Module I/O: a lowered controller and the layout -> what its module reads and writes.

Decided here, before anything is rendered: every attribute of the generated class (its
`__slots__`), every name it imports from the layout and the runtime contract, the one read
of its inputs (command, mode, subordinates' status, world; which sequence words guard the
fields another process writes), the writes of its status, its subordinates' commands and
its world fields (adjacent world buffers packed with one struct), and which fields are
strings (decoded after a read, encoded on a write). `emit` places these in the template.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from dataclasses import dataclass

from ...runtime.contract import MODE_FIELDS, PERF_FIELDS, STATUS_FIELDS, field_names
from ...runtime.io_points import Device
from .. import ir
from ..checks import naming
from ..checks.tables import RuleId


@dataclass(frozen=True)
class Field:
    """A buffer field to read or write with others: its offset and struct code, the target
    it is copied to or from (None: a sequence word), its capacity if it holds a string."""

    offset: int
    code: str
    target: str | None
    text: int = 0

    @classmethod
    def of(cls, slot: ir.Slot, target: str | None) -> Field:
        return cls(slot.offset, slot.code, target, slot.text)


def gather(fields: Iterable[Field]) -> ir.Gathered:
    """One struct over the fields, in block order, the bytes between them skipped."""
    ordered = sorted(fields, key=lambda f: f.offset)
    fmt, targets, start = _format(ordered)
    seqs = [f for f in ordered if f.target is None]
    seq_fmt, _, seq_start = _format(seqs) if seqs else ("", [], 0)
    indices = [i for i, f in enumerate(ordered) if f.target is None]
    values = [f for f in ordered if f.target is not None]
    values_fmt, _, values_start = _format(values) if values else ("<", [], start)
    if values_start > start:  # from the same offset as the whole
        values_fmt = f"<{values_start - start}x{values_fmt[1:]}"
    return ir.Gathered(
        fmt,
        start,
        tuple(targets),
        tuple(indices),
        seq_fmt,
        seq_start,
        values_fmt,
        texts=tuple(f.target for f in ordered if f.target is not None and f.text),
        packed=tuple(packed(f.target, f.text) for f in values if f.target is not None),
        seq_words=tuple(f.offset // 8 for f in seqs),  # every buffer is 8-byte aligned
    )


def _format(fields: list[Field]) -> tuple[str, list[str], int]:
    start = at = fields[0].offset
    fmt, targets = "<", []
    for f in fields:
        if f.offset > at:
            fmt += f"{f.offset - at}x"
        fmt += f.code
        at = f.offset + struct.calcsize("<" + f.code)
        targets.append(f.target or "_")
    return fmt, targets, start


def packed(target: str, text: int) -> str:
    """The value a struct packs for `target`: a string field's text encoded and NUL-padded
    (`encode_text` refuses a text that does not fit: never truncated)."""
    return f"encode_text({target}, {text})" if text else target


@dataclass(frozen=True)
class Placement:
    """Which process runs each module and writes each world field: a buffer written in
    another process than its reader's is read under its seqlock."""

    process_of: dict[str, str]
    world_writers: dict[str, set[str]]  # world field -> the processes whose modules write it

    @classmethod
    def of(
        cls, processes: Iterable[ir.IRProcess], controllers: Iterable[ir.IRController]
    ) -> Placement:
        controllers = list(controllers)
        process_of = {m: p.name for p in processes for m in p.modules}
        for c in controllers:  # a stand-in runs in its controller's process
            process_of.setdefault(c.name, process_of.get(c.buffers, ""))
        writers: dict[str, set[str]] = {}
        for c in controllers:
            for f in c.world_writes:
                writers.setdefault(f.name, set()).add(process_of[c.name])
        return cls(process_of, writers)


def inputs(c: ir.IRController, layout: ir.Layout, placement: Placement) -> ir.Gathered:
    """Everything pre_process copies in: command, mode, subordinates' status, world fields,
    with the sequence word of each buffer another process writes."""
    here = placement.process_of[c.name]
    own = layout.modules[c.buffers]
    fields = [Field.of(s, f"self.{s.name}") for s in own.command.fields]
    # A root's commands come from an operator's tool (another OS process): check them too.
    if c.supervisor is None or placement.process_of[c.supervisor] != here:
        fields.append(Field(own.command.offset, "Q", None))
    fields += [Field.of(s, f"self.{s.name}") for s in own.mode.fields if s.name != "pad"]
    for sub in c.subordinates:
        status = layout.handshake(sub.name, c.buffers)[1]
        # status_num and status, and the reason and results its guards read
        # (docs/semantics.md, "Results and reasons")
        read = {"error_num"} if sub.reasons else set()
        read |= {"cause"} if sub.chained else set()  # its own cause, to chain (reasons survive)
        read |= {f"result_{r.name}" for r in sub.results}
        fields += [
            Field.of(s, f"self.{sub.name}_{s.name}")
            for index, s in enumerate(status.fields)
            if index < 2 or s.name in read
        ]
        if placement.process_of[sub.name] != here:
            fields.append(Field(status.offset, "Q", None))
    by_name = layout.world_by_name
    for f in c.world_reads:
        buffer = by_name[f.name]
        fields.append(Field.of(buffer.fields[0], f"self.world_{f.name}"))
        if placement.world_writers.get(f.name, set()) - {here}:
            fields.append(Field(buffer.offset, "Q", None))
    return gather(fields)


def world_outputs(c: ir.IRController, layout: ir.Layout) -> tuple[ir.WorldRun, ...]:
    """The world fields post_process writes, one struct per run of adjacent field buffers
    (each its sequence word and value; only alignment padding lies between them, so packing
    never touches anyone else's field), with the layout's names of their buffers' offsets
    (where each sequence word is stored on its own)."""
    by_name = layout.world_by_name
    buffers = sorted((by_name[f.name] for f in c.world_writes), key=lambda b: b.offset)
    runs: list[list[ir.Buffer]] = []
    for buffer in buffers:
        if runs and buffer.offset == align(runs[-1][-1].offset + runs[-1][-1].size):
            runs[-1].append(buffer)
        else:
            runs.append([buffer])
    found = []
    for run in runs:
        fields: list[Field] = []
        for b in run:
            value = b.fields[0]
            fields += [Field(b.offset, "Q", None), Field.of(value, f"self.world_{value.name}")]
        found.append(ir.WorldRun(gather(fields), tuple(f"{b.const}_AT" for b in run)))
    return tuple(found)


def world_set_rules(c: ir.IRController) -> tuple[RuleId, ...]:
    """The every_cycle rules that set a world output. A table rule that fires records its
    code (`rule`), which tells post_process to look at the world outputs; these records
    none, so they raise a flag of their own (`world_set`)."""
    if not c.world_writes:
        return ()
    return tuple(rule.id for rule in c.every_cycle if any(_sets_world(a) for a in rule.actions))


def _sets_world(action: object) -> bool:
    if isinstance(action, ir.IRSet):
        return any(a.attribute.startswith("self.world_") for a in action.assignments)
    if isinstance(action, ir.IRCall):
        return any(t.startswith("self.world_") for t in action.targets)
    return False


def align(offset: int, to: int = 8) -> int:
    """`offset` rounded up to a multiple of `to`."""
    return -(-offset // to) * to


def idle_shortcut(c: ir.IRController, read: ir.Gathered) -> bool:
    """Whether a cycle of `c` stops short when it is idle with nothing new (NOP, no rule
    fired, nothing to write, the inputs as in its last cycle): only a module with no
    every_cycle rule (they run in NOP too) whose inputs are all written in its own process
    (another process's are read under the seqlock, its retries in `read_inputs`)."""
    return not c.every_cycle and not read.seq_indices


def _slots(c: ir.IRController, targets: list[str], shortcut: bool) -> tuple[str, ...]:
    """Every attribute of the generated class: its buffers' fields (`targets`), its
    subordinates', world fields, locals, time counters and plans; its last inputs, where an
    idle cycle may stop short."""
    slots = ["buf", "words", *targets, "status_seq", "status_dirty", "perf_seq", "on_state"]
    if shortcut:
        slots.append("inputs")
    if world_set_rules(c):
        slots.append("world_set")
    if c.hooks_state:
        slots.append("hook_state")
    for s in c.subordinates:
        slots += [f"self.{s.name}_status_num", f"self.{s.name}_status"]
        slots += [f"{s.name}_result_{r.name}" for r in s.results]
        slots += [f"{s.name}_error_num"] if s.reasons else []
        slots += [f"{s.name}_cause"] if s.chained else []
        slots.append(f"{s.name}_written")
        if s.echo_cycles:
            slots.append(f"{s.name}_sent_at")
        if s.continue_on_lost:  # set by the runtime while its process is lost
            slots.append(f"{s.name}_lost")
    slots += [f"world_{f.name}" for f in c.world_reads]
    slots += [f"var_{v.name}" for v in c.locals]
    if c.timed:
        slots += ["ticks", *c.counters]
    slots += [counter.attribute for counter in c.every_cycle_counters]
    for plan in c.plans:  # its list, its done flag, the current step's fields (and, in the
        # status buffer, step, steps and replans_left)
        slots += [f"plan_{plan.name}", naming.plan_attribute(plan.name, "done")]
        slots += [naming.plan_attribute(plan.name, f.name) for f in plan.fields]
    return tuple(sorted(s.removeprefix("self.") for s in slots))


def controller_io(c: ir.IRController, layout: ir.Layout, placement: Placement) -> ir.ModuleIO:
    """Everything a controller module's template names about the block."""
    own = c.buffers.upper()  # a stand-in uses the buffers of the controller it replaces
    command = ("self.command_num", "self.command", *(f"self.arg_{p.name}" for p in c.params))
    status = layout.modules[c.buffers].status  # with its results, if any
    status_fields = [Field.of(slot, f"self.{slot.name}") for slot in status.fields]
    own_status = len(status.fields) > len(field_names(STATUS_FIELDS))  # it has results
    mode = tuple(f"self.{n}" for n in field_names(MODE_FIELDS))
    perf = tuple(f"self.{naming.attribute_of(n, PERF_FIELDS)}" for n in field_names(PERF_FIELDS))
    sub_fields = {s.name: _sub_fields(c, s, layout) for s in c.subordinates}
    sub_all = [f for fs in sub_fields.values() for f in fs]
    worlds = world_outputs(c, layout)
    read = inputs(c, layout, placement)
    resume_texts = _texts([*status_fields, *sub_all])
    written = [*status_fields, *sub_all, *_world_texts(worlds)]
    runtime = _runtime_names(c, read, resume_texts, written, own_status)
    commands = {s.name: f"{s.prefix}_COMMAND_AT" for s in c.subordinates}
    # the sequence words it stores, in this order: status, commands, world fields (its
    # performance buffer's is rcs.contract.performance's to store)
    stored = [f"{own}_STATUS_AT", *commands.values(), *(at for r in worlds for at in r.seq_at)]
    return ir.ModuleIO(
        own=own,
        imports=_ordered(_layout_imports(c, own, worlds, own_status)),
        rcs_imports=_ordered(runtime),
        slots=_slots(
            c,
            [*command, *_targets(status_fields), *mode, *perf, *_targets(sub_all)],
            idle_shortcut(c, read),
        ),
        inputs=read,
        world_outputs=tuple(run.gathered for run in worlds),
        stored_words=tuple((word_name(at), at) for at in stored),
        status_word=word_name(f"{own}_STATUS_AT"),
        sub_words={name: word_name(at) for name, at in commands.items()},
        world_seq_words=tuple(tuple(map(word_name, run.seq_at)) for run in worlds),
        world_values=tuple(run.gathered.packed for run in worlds),
        world_names=tuple(
            tuple(t.removeprefix("self.world_") for t in run.gathered.targets if t != "_")
            for run in worlds
        ),
        command_targets=command,
        status_targets=_targets(status_fields),
        status_struct=f"{own}_STATUS" if own_status else "STATUS",
        status_values=_packed(status_fields),
        mode_targets=mode,
        perf_targets=perf,
        sub_targets={name: _targets(fs) for name, fs in sub_fields.items()},
        sub_values={name: _packed(fs) for name, fs in sub_fields.items()},
        input_texts=read.texts,
        resume_texts=resume_texts,
        world_set_rules=world_set_rules(c),
        idle_shortcut=idle_shortcut(c, read),
    )


def word_name(at: str) -> str:
    """The name of the block word (an index of rcs.contract.words) at a layout offset
    named `at`: CO_STATUS_AT -> CO_STATUS_WORD."""
    return at.removesuffix("_AT") + "_WORD"


def _targets(fields: Iterable[Field]) -> tuple[str, ...]:
    return tuple(str(f.target) for f in fields)


def _packed(fields: Iterable[Field]) -> tuple[str, ...]:
    return tuple(packed(str(f.target), f.text) for f in fields)


def _texts(fields: Iterable[Field]) -> tuple[str, ...]:
    """The targets of the string fields among `fields`: decoded after a read."""
    return tuple(str(f.target) for f in fields if f.text)


def _ordered(names: set[str]) -> tuple[str, ...]:
    """Names in the order ruff's isort sorts an import's names."""
    return tuple(sorted(names, key=naming.import_order))


def _world_texts(worlds: tuple[ir.WorldRun, ...]) -> list[Field]:
    """The string fields the world runs write (as Fields: only that they are text counts)."""
    return [Field(0, "", t, 1) for run in worlds for t in run.gathered.texts]


def _sub_fields(c: ir.IRController, sub: ir.IRSub, layout: ir.Layout) -> list[Field]:
    """The fields of the command buffer through which `c` commands `sub` (an operator
    module's subordinate: the client's own channel), each with its attribute."""
    targets = [
        f"self.{sub.name}_command_num",
        f"self.{sub.name}_command",
        *(naming.sub_arg_attribute(sub.name, p.name) for p in sub.params),
    ]
    slots = layout.handshake(sub.name, c.name)[0].fields
    return [Field.of(slot, target) for slot, target in zip(slots, targets, strict=True)]


def _layout_imports(
    c: ir.IRController, own: str, worlds: tuple[ir.WorldRun, ...], own_status: bool
) -> set[str]:
    """The layout's names a controller module imports: its status and performance offsets
    (its status struct, when it has results), its world runs' sequence offsets, each
    subordinate's command struct and offset."""
    imports = {f"{own}_STATUS_AT", f"{own}_PERF_AT", *(n for r in worlds for n in r.seq_at)}
    for s in c.subordinates:
        imports |= {f"{s.prefix}_COMMAND", f"{s.prefix}_COMMAND_AT"}
    if own_status:  # its status buffer's own struct, from the layout
        imports.add(f"{own}_STATUS")
    if worlds:  # a field under an override keeps its value (rcs/override.py)
        imports |= {"OVERRIDE", "OVERRIDDEN_AT"}
    return imports


def _runtime_names(
    c: ir.IRController,
    read: ir.Gathered,
    resume_texts: tuple[str, ...],
    written: list[Field],
    own_status: bool,
) -> set[str]:
    """The contract's names a controller module imports: those its rules need (lowered with
    them), the block's word view, the text codec of its string fields, the seqlock's tries."""
    names = {*c.runtime_names, "words", "NOP", "performance", "untimed"}  # NOP: idle, no table
    if read.texts or resume_texts:
        names.add("decode_text")
    if any(f.text for f in written):
        names.add("encode_text")
    if own_status:
        names.discard("STATUS")
    if read.seq_indices:
        names.add("READ_TRIES")
    if c.subordinates:  # safe_state halts them and reports ERROR
        names |= {"ERROR", "NOP"}
    if any(s.caused for s in c.subordinates):  # a rule records a subordinate's error as cause
        names |= {"ERROR", "caused"}
    return names


def operator_io(c: ir.IRController) -> ir.ModuleIO:
    """What an operator module's template names: its layout constants."""
    own = c.name.upper()
    imports = [f"{own}_MODE_AT", f"{own}_PERF_AT"]
    for client in c.clients:
        imports += [f"{own}_{client.upper()}_{part}_AT" for part in ("COMMAND", "STATUS", "ANSWER")]
        if c.results:  # its status and answer records' own structs, with the results
            imports += [f"{own}_{client.upper()}_{part}" for part in ("STATUS", "ANSWER")]
    return ir.ModuleIO(own=own, imports=tuple(sorted(imports)))


def process_writes(
    processes: Iterable[ir.IRProcess],
    controllers: Iterable[ir.IRController],
    layout: ir.Layout,
    placement: Placement,
    world: Iterable[ir.IRWorldField],
    devices: Iterable[Device] = (),
) -> dict[str, tuple[ir.Buffer, ...]]:
    """The buffers each process writes into its own block, in layout order: what a network
    transport looks at after each of its cycles (rcs/transport.py `Mirror`). Its control
    record; for each module it runs (a stand-in too) its status, performance, mode (the
    loop sets `simulate` at start), time in state, its subordinates' commands and the world
    fields it writes; a root's command (the loop's INIT and HALT); an operator module's
    channels' status; its I/O devices' points; and every actuator with its override record
    (a process that loses another latches them safe: rcs/loop.py `react`)."""
    controllers = list(controllers)
    by_name = layout.world_by_name
    overrides = {b.fields[1].name: b for b in layout.override_fields}
    actuators = [f.name for f in world if f.actuator]
    latched = [b for name in actuators for b in (by_name[name], overrides[name])]
    found: dict[str, list[ir.Buffer]] = {}
    for p in processes:
        mine = found[p.name] = [layout.processes[p.name], *latched]
        mine += [layout.modules[r].command for r in p.roots if r in layout.modules]
        mine += [by_name[point.field] for d in devices if d.process == p.name for point in d.points]
    for c in controllers:
        mine = found[placement.process_of[c.name]]
        if c.is_operator:
            own = layout.operators[c.name]
            mine += [own.mode, own.perf, *(ch.status for ch in own.channels.values())]
            continue
        buffers = layout.modules[c.buffers]
        mine += [buffers.status, buffers.perf, buffers.mode, layout.state_time[c.name]]
        mine += [layout.handshake(s.name, c.buffers)[0] for s in c.subordinates]
        mine += [by_name[f.name] for f in c.world_writes]
    return {
        name: tuple(sorted({b.offset: b for b in buffers}.values(), key=lambda b: b.offset))
        for name, buffers in found.items()
    }
