"""Contract: the codes and buffer shapes generated code, tools and the compiler all read.

The one place the status and mode codes, the built-in commands and the fields of the
buffers every module has (QQ1.h) are spelled. Standard library only: this file is copied
verbatim into every generated package (as `<system>/rcs/contract.py`).
"""

from __future__ import annotations

import numbers
import sys
import weakref
from collections.abc import Callable, Iterable
from struct import Struct
from types import CodeType, ModuleType
from typing import Any, ClassVar, NamedTuple, TypeVar

# Status a module reports to its supervisor (QQ1.h `qq1_responses`), by code.
NOT_READY = 0
EXECUTING = 1
DONE = 2
ERROR = 3
STATUS_NAMES = ("NOT_READY", "EXECUTING", "DONE", "ERROR")
FINISHED = ("DONE", "ERROR")  # the statuses that end a command

# The state of a module with no command to work on.
NOP = 0
# The command code of a buffer that never received a command.
NO_COMMAND = 0
NO_COMMAND_NAME = "NONE"
# Every module accepts these first, with codes 1 and 2; declared commands follow.
BUILTIN_COMMANDS = ("INIT", "HALT")
# What an operator role may do to a module, least to most (the second paper's Figure 29);
# each includes the ones before it, and every role may monitor every module.
ACCESS_LEVELS = ("monitor", "respond", "command", "override")
# Seconds every process of a launch has to run its first cycle (the start-up barrier),
# unless the system spec declares `startup_timeout`.
STARTUP_TIMEOUT = 10.0

# Buffers every module has, in the same shape: (field, struct code). A command buffer is
# its head followed by one `arg_<name>` field per parameter of the module's commands.
COMMAND_HEAD_FIELDS = (("command_num", "Q"), ("command", "I"))
# `rule` is the code of the table rule that fired in the module's last cycle (0: none); the
# layout's RULES names each code (`SUMP_SHEAR_CUSP/S2/3`), for monitors, traces and coverage.
STATUS_FIELDS = (
    ("status_num", "Q"),
    ("status", "I"),
    ("error_num", "I"),
    ("state", "i"),
    ("rule", "i"),
)
NO_RULE = 0
MODE_FIELDS = (
    ("dont_run", "?"),
    ("single_step", "?"),
    ("simulate", "?"),
    ("pad", "x"),
    ("single_step_num", "I"),
)
# A module's performance buffer: its execution times and cycle count, which only people and
# tools read (ctl, the monitor, the launcher's summary). The module keeps them and its
# process publishes them (the module's `publish`, templates/controller.py.j2) every
# PERF_INTERVAL seconds and as it stops; a module publishes at once a cycle that is its
# longest yet (its first too), and in single_step mode (the step's number: ctl step waits
# for it). Over Zenoh they go with a push at most as often (rcs/zenoh_transport.py).
PERF_INTERVAL = 0.1
PERF_FIELDS = (
    ("last_cycle_ns", "Q"),
    ("min_cycle_ns", "Q"),
    ("max_cycle_ns", "Q"),
    ("cycles", "Q"),
    ("single_step_num", "I"),
    ("stale_reads", "I"),  # cycles whose inputs from another process could not be read whole
)
# An operator module (a person at a screen) serves several clients, each through a channel:
# a command buffer (COMMAND_HEAD_FIELDS and arguments) its client writes, a status buffer
# (STATUS_FIELDS) the operator module writes, and an answer record written only by the
# answering side (the console, a scenario's scripted operator): the command number it
# answers, DONE or ERROR, and the reason's code (0: none). The operator module turns an
# answer to its channel's current command into the channel's status.
ANSWER_FIELDS = (("command_num", "Q"), ("status", "I"), ("reason", "I"))
# A channel's states: idle, or a request open on the screen.
OPERATOR_STATES = ("NOP", "ASKING")
ASKING = 1
# The block's header, at offset 0: what a process checks before it attaches. The layout hash
# covers every buffer, field, type and offset and the system's name.
MAGIC = b"RCSBLK02"  # 02: the control record carries periodicity and network counts
HEADER = Struct("<8s32s32sQ")  # magic, layout hash (hex), system name, block size
HEADER_FIELDS = ("magic", "layout_hash", "system", "size")

# Each process's control record: written by the process every cycle (its heartbeat: the
# LIVENESS_WORDS; whole every PERF_INTERVAL, rcs/loop.py), read by the launcher, the other
# processes (liveness) and operator tools.
_BEAT_AND_COUNTS = (
    ("pid", "Q"),
    ("state", "I"),  # PROCESS_STATES
    ("watchdog_trips", "I"),
    ("heartbeat", "Q"),  # cycles run (the heartbeat)
    ("beat_ns", "Q"),  # when the last cycle ended: time.monotonic_ns() (host-wide clock)
    ("overruns", "Q"),  # cycles that ran past their period
    ("late_wakeups", "Q"),  # sleeps that ended later than the period's boundary
    ("load_warnings", "Q"),  # cycles that used more than the warning share of the period
    ("last_cycle_ns", "Q"),
    ("max_cycle_ns", "Q"),
    ("lost", "Q"),  # bit i: process i (layout order) is reported dead
)
# How well a paced process holds its period (rcs/loop.py `Periodicity`), at the end of its
# control record; all 0 in a process that is not paced (lockstep, flat out).
PERIODICITY_FIELDS = (
    ("period_ns", "Q"),  # the declared period it paces at
    ("wakeups", "Q"),  # paced wake-ups measured
    ("period_error_sum_ns", "Q"),  # |time between two wake-ups - the period|, summed
    ("period_error_max_ns", "Q"),
    ("lateness_p99_ns", "Q"),  # of the last 4096 wake-ups (refreshed every 16)
    ("lateness_max_ns", "Q"),
    ("lateness_warnings", "Q"),  # the throttled warning lines it wrote
)
# What a process on the network (Zenoh) did with the records it received from its peers:
# applied, dropped as late or out of order, refused as malformed (not whole records of this
# layout); all 0 on shared memory. Its log names the peer of each malformed push.
NETWORK_FIELDS = (("net_applied", "Q"), ("net_late", "Q"), ("net_malformed", "Q"))
PROCESS_FIELDS = _BEAT_AND_COUNTS + PERIODICITY_FIELDS + NETWORK_FIELDS
# Each process's pacing record: written by operator tools (`ctl slow`), read by the paced loop
# every cycle. `slow` stretches the process's cycle period by that factor (the slow-down of
# the mining paper's debug screen, 4.1.1.1); 0 (a new block) or 1 runs at the declared period.
PACE_FIELDS = (("slow", "d"),)
PROCESS_STATES = ("ABSENT", "STARTING", "RUNNING", "STOPPED", "DEAD")
ABSENT, STARTING, RUNNING, STOPPED, DEAD = range(5)

# The struct code of each spec type (world fields, parameters). An enumeration is stored as
# its value's index (`q`); a string of capacity N as N bytes of UTF-8, NUL-padded (`Ns`).
FORMAT_OF_TYPE = {"bool": "?", "int": "q", "float": "d"}


def format_of_type(kind: str) -> str:
    """The struct code of a spec type: `enum A|B` -> q, `str 32` -> 32s, else FORMAT_OF_TYPE."""
    if kind.startswith("enum "):
        return "q"
    if kind.startswith("str "):
        return kind[4:] + "s"
    return FORMAT_OF_TYPE[kind]


def field_codes(fmt: str) -> list[str]:
    """The struct code of each value a format packs, in order, padding left out:
    `<Q4x32sq` -> [Q, 32s, q]."""
    codes, count = [], ""
    for char in fmt.lstrip("<>=!@"):
        if char.isdigit():
            count += char
            continue
        if char == "s":
            codes.append(count + char)
        elif char != "x":
            codes += [char] * int(count or 1)
        count = ""
    return codes


def _noun(count: int, noun: str, plural: str) -> str:
    return noun if count == 1 else plural or noun + "s"


def counted(count: int, noun: str, plural: str = "") -> str:
    """A count and its noun, singular or plural by the count: `1 argument`, `2 arguments`
    (`plural` where adding an s is wrong)."""
    return f"{count} {_noun(count, noun, plural)}"


def listed(noun: str, names: Iterable[object], plural: str = "") -> str:
    """A noun and the names it counts, singular or plural by them: `parameter x`,
    `parameters x, y`."""
    shown = [str(name) for name in names]
    return f"{_noun(len(shown), noun, plural)} {', '.join(shown)}"


def text_problem(value: object, size: int) -> str:
    """'' when `value` is a string that fits `size` bytes of UTF-8, else what is wrong."""
    if not isinstance(value, str):
        return f"{value!r} is not a string"
    if "\0" in value:
        return "a string may not contain the NUL character"
    used = len(value.encode("utf-8"))
    if used > size:
        shown = repr(value[:20]) + ("..." if len(value) > 20 else "")
        return f"{shown} is {used} bytes: more than the {size} it holds"
    return ""


def range_problem(value: object, low: float | None, high: float | None) -> str:
    """'' when a number lies in [low, high] (None: open on that side), else what is wrong, as
    the end of a sentence that starts with the value's name (an operator task's result)."""
    if not isinstance(value, int | float) or isinstance(value, bool):
        return ""
    if low is not None and value < low:
        return f"is {value}: below its minimum {low}"
    if high is not None and value > high:
        return f"is {value}: above its maximum {high}"
    return ""


def encode_text(value: str, size: int) -> bytes:
    """`value` as a string field of `size` bytes, NUL-padded; ValueError if it does not fit
    (never truncated)."""
    problem = text_problem(value, size)
    if problem:
        raise ValueError(problem)
    return value.encode("utf-8").ljust(size, b"\0")


def decode_text(raw: bytes) -> str:
    """A string field's bytes as text, without its NUL padding."""
    return raw.rstrip(b"\0").decode("utf-8", "replace")


# Every buffer starts with a sequence word (a seqlock): its one writer makes it odd, writes
# the fields, then makes it even again; a reader in another process accepts what it read
# only if the word was even, not 0, and unchanged around the read, retrying `READ_TRIES`
# times at most before calling the buffer stale for this cycle (a controller never waits).
# This relies on stores reaching memory in program order and loads not passing loads,
# which x86-64 guarantees (see docs/semantics.md).
#
# `struct.pack_into` zeroes its whole span before it stores the values (CPython's
# s_pack_internal), in whatever order memset stores: a word written with it reads 0, an
# even value, for a moment, and the fields of a span read 0 before their values arrive.
# So 0 is never a whole buffer's word (`initialise` starts every word at 2, and a reader
# takes 0 for a write in progress), and a writer stores the odd word by itself before the
# pack that overwrites the fields: no field changes while the word is even.
SEQ = Struct("<Q")
READ_TRIES = 3
FIRST_SEQ = 2  # every buffer's word in a new block: whole, never written


def next_odd(seq: int) -> int:
    """The odd word a writer marks a buffer with while it writes, when the buffer held `seq`
    (odd already if a writer died mid-write); the write ends with `next_odd(seq) + 1`."""
    return seq | 1


def field_names(fields: tuple[tuple[str, str], ...]) -> tuple[str, ...]:
    """The names of a buffer's fields, without padding."""
    return tuple(name for name, code in fields if code != "x")


def struct_format(fields: tuple[tuple[str, str], ...]) -> str:
    """The little-endian `struct` format of a buffer: its sequence word, then its fields, with
    no implicit padding."""
    return "<Q" + "".join(code for _, code in fields)


def reason_name(layout: object, module: str, status: str, error_num: int) -> str | None:
    """The reason `module`'s status gives, by name (the layout's REASON_NAMES): `NONE` unless
    the status is ERROR (as its supervisor reads it), `?<code>` for a code it does not
    declare; None for a module that declares no reasons."""
    names = getattr(layout, "REASON_NAMES", {}).get(module)
    if names is None:
        return None
    if status != "ERROR":
        return "NONE"
    return str(names[error_num]) if 0 <= error_num < len(names) else f"?{error_num}"


def status_text(status: str, reason: str | None, cause: str = "") -> str:
    """A status as a person reads it: `ERROR(REFUSED)` in ERROR for a reason, with the cause
    it was passed up from (`ERROR(FIXTURING <- fx: TIMED_OUT <- op: REFUSED)`), else bare."""
    if status != "ERROR":
        return status
    why = [r for r in (reason, cause) if r not in (None, "", "NONE")]
    if not why:
        return status
    if cause and reason in (None, "", "NONE"):  # no reason of its own: only the cause
        why = ["NONE", cause]
    return f"{status}({' <- '.join(str(w) for w in why)})"


# The cause of an ERROR (docs/semantics.md, "Reasons survive"): the subordinates' errors a
# supervisor's ERROR comes from, nearest first, kept in its status buffer's `cause` field
# (u64), beside its own `error_num`, and written with it under the status's sequence word.
# Each link is 16 bits: the module's number in the layout's CAUSE_MODULES (from 1; 0: no
# link) in the high byte, the reason's code in that module's REASON_NAMES in the low byte.
CAUSE_LINKS = 4  # links a chain keeps; past them the root is kept and the one before dropped
CAUSE_CODES = 256  # modules (and a module's reasons) a link can number
_LINK = 0xFFFF


def caused(module: int, reason: int, chain: int) -> int:
    """The cause a supervisor records when its rule reads subordinate `module` in ERROR for
    `reason` (its error_num; 0 if it declares none), `chain` that subordinate's own cause:
    the subordinate's link first, then its chain. Full, the root cause survives: the link
    next to it is dropped."""
    links = [module << 8 | reason & 0xFF, *cause_links(chain)]
    if len(links) > CAUSE_LINKS:
        links = [*links[: CAUSE_LINKS - 1], links[-1]]
    value = 0
    for i, link in enumerate(links):
        value |= link << 16 * i
    return value


def cause_links(chain: int) -> list[int]:
    """A cause's links, nearest first (each `module << 8 | reason`)."""
    links = []
    while chain & _LINK:
        links.append(chain & _LINK)
        chain >>= 16
    return links


def cause_text(layout: object, chain: int) -> str:
    """A cause as a person reads it: `fx: TIMED_OUT <- op: REFUSED` (a module that declares
    no reasons is named alone), '' for none."""
    modules = getattr(layout, "CAUSE_MODULES", ())
    names = getattr(layout, "REASON_NAMES", {})
    parts = []
    for link in cause_links(chain):
        number, code = link >> 8, link & 0xFF
        module = modules[number - 1] if 0 < number <= len(modules) else f"?{number}"
        reasons = names.get(module)
        if reasons is None:
            parts.append(module)
        else:
            reason = reasons[code] if code < len(reasons) else f"?{code}"
            parts.append(f"{module}: {reason}")
    return " <- ".join(parts)


STATUS = Struct(struct_format(STATUS_FIELDS))
MODE = Struct(struct_format(MODE_FIELDS))
PERF = Struct(struct_format(PERF_FIELDS))
PROCESS = Struct(struct_format(PROCESS_FIELDS))
PACE = Struct(struct_format(PACE_FIELDS))
ANSWER = Struct(struct_format(ANSWER_FIELDS))
# A control record's head, read without its seqlock (each field is written whole): the
# sequence word, pid, state, watchdog trips, heartbeat and beat_ns.
BEAT = Struct("<Q" + "".join(code for _, code in PROCESS_FIELDS[:5]))
# The control record's words a beat stores when it does not write the record whole
# (rcs/loop.py: every beat but one each PERF_INTERVAL), as indices from its sequence word:
# state with watchdog_trips (low half, high half: one word), heartbeat, beat_ns.
LIVENESS_WORDS = tuple(
    Struct(struct_format(PROCESS_FIELDS[: field_names(PROCESS_FIELDS).index(name)])).size // 8
    for name in ("state", "heartbeat", "beat_ns")
)


def untimed(state: int) -> None:
    """A module's `on_state` until its process gives it its time-in-state clock's
    (rcs/loop.py, rcs/state_time.py): nothing to tell."""


def performance(at: int) -> Callable[[Any], None]:
    """The `publish` method of a module whose performance buffer is at `at` (PERF_INTERVAL):
    its longest and shortest cycle brought up to its last, then the buffer written from
    the module's attributes (PERF_FIELDS's, single_step_num as perf_single_step_num), odd
    while it is written. One home for the buffer's writing: every generated controller,
    stand-in and operator module has this method."""
    word = at >> 3

    def publish(module: Any) -> None:
        last = module.last_cycle_ns
        module.max_cycle_ns = max(module.max_cycle_ns, last)
        if last < module.min_cycle_ns or not module.min_cycle_ns:  # (0: none yet)
            module.min_cycle_ns = last
        seq = module.perf_seq + 1
        words = module.words
        words[word] = seq  # odd before any field changes, in one 8-byte store
        PERF.pack_into(
            module.buf,
            at,
            seq,
            last,
            module.min_cycle_ns,
            module.max_cycle_ns,
            module.cycles,
            module.perf_single_step_num,
            module.stale_reads,
        )
        words[word] = seq + 1
        module.perf_seq = seq + 1

    return publish


def periodicity(values: Any) -> dict[str, Any] | None:
    """A control record's periodicity figures in µs (period error mean and max, wake-up
    lateness p99 and max), with the wake-ups and warnings counted; None if not paced."""
    wakeups = int(values.get("wakeups", 0))
    if not wakeups or not values.get("period_ns"):
        return None
    us = {k: round(int(values[f"{k}_ns"]) / 1e3, 1) for k in _PERIODICITY_NS}
    return {
        "period_ms": int(values["period_ns"]) / 1e6,
        "wakeups": wakeups,
        "period_error_mean_us": round(int(values["period_error_sum_ns"]) / wakeups / 1e3, 1),
        **{f"{k}_us": v for k, v in us.items() if k != "period_error_sum"},
        "lateness_warnings": int(values["lateness_warnings"]),
    }


_PERIODICITY_NS = ("period_error_sum", "period_error_max", "lateness_p99", "lateness_max")


def periodicity_line(name: str, figures: dict[str, Any] | None) -> str:
    """One line of a summary or status for `periodicity`'s figures of process `name`."""
    if figures is None:
        return f"{name}: periodicity: no paced wake-up"
    return (
        f"{name}: period error mean {figures['period_error_mean_us']:g} µs, max "
        f"{figures['period_error_max_us']:g} µs; wake-up lateness p99 "
        f"{figures['lateness_p99_us']:g} µs, max {figures['lateness_max_us']:g} µs over "
        f"{figures['wakeups']} wake-ups (period {figures['period_ms']:g} ms), "
        f"{counted(int(figures['lateness_warnings']), 'lateness warning')}"
    )


def network_line(name: str, values: Any) -> str | None:
    """What process `name` did with the records its peers sent over the network, from its
    control record's NETWORK_FIELDS (`net_` names, or the same without); None if nothing
    came (shared memory)."""
    counts = [int(values.get(k, values.get(k.removeprefix("net_"), 0))) for k, _ in NETWORK_FIELDS]
    if not any(counts):
        return None
    applied, late, malformed = counts
    return (
        f"{name}: received {applied} records applied, {late} late or out of order "
        f"(dropped), {malformed} malformed (refused)"
    )


def silent(layout: Any, buf: Any, name: str, timeout_ns: int, now_ns: int) -> tuple[bool, int]:
    """(whether process `name` is lost now: STOPPED, DEAD, or a heartbeat older than
    `timeout_ns` stretched by its slow-down; its watchdog trips). One that has not beaten
    yet is not: the start-up barrier covers it. The one test of a loss every watcher (the
    processes, the launcher, a reset) shares."""
    _, _, state, trips, _, beat_ns = BEAT.unpack_from(buf, layout.PROCESSES[name].offset)
    if state in (STOPPED, DEAD):
        return True, trips
    slow = 1.0
    pacing = getattr(layout, "PACING", {})
    if name in pacing:  # one float, written whole: read without the seqlock
        slow = max(1.0, PACE.unpack_from(buf, pacing[name].offset)[1])
    return beat_ns > 0 and now_ns - beat_ns > timeout_ns * slow, trips


# ---------------------------------------------------------------- one class per runtime

# rcsgen's own runtime (`rcsgen.runtime`) and every generated package's copy of it (`<system>.
# rcs`) can be loaded in one Python process: the monitor reads a package's layout with
# rcsgen's console, the harness runs a package's modules and reports their errors. Each copy
# would define its own `StaleRead`, `HookError`, `Record` ...: `except StaleRead` in one
# would miss what the other raises. Each exception and record type is therefore `shared`:
# the first copy to define it registers it, and a later copy whose definition is the same
# (the same code, names and constants: the same runtime, whatever its file) takes the
# registered class instead of its own. A different definition (a package of another rcsgen
# version) keeps its own class.
_SHARED = "_rcs_shared_types"
_Class = TypeVar("_Class", bound=type)


def shared(cls: _Class) -> _Class:
    """The one class of this definition in the process (see above)."""
    registry = sys.modules.get(_SHARED)
    if registry is None:
        registry = sys.modules[_SHARED] = ModuleType(_SHARED, "rcsgen runtime types, shared")
    key = f"{cls.__qualname__}:{hash(_fingerprint(cls))}"
    found: _Class = registry.__dict__.setdefault(key, cls)
    return found


def _fingerprint(value: object, depth: int = 0) -> object:
    """What a class definition is made of, comparable across copies of the runtime: its
    methods' byte code, names and constants (line numbers and file names left out)."""
    if depth > 8:
        return "..."
    if isinstance(value, CodeType):
        consts = tuple(_fingerprint(c, depth + 1) for c in value.co_consts)
        return (value.co_code, value.co_names, value.co_varnames, consts)
    if isinstance(value, type):
        if depth and value.__module__ in ("builtins", "typing", "collections", "dataclasses"):
            return value.__qualname__
        return (
            value.__qualname__,
            tuple(
                (name, _fingerprint(member, depth + 1))
                for name, member in sorted(value.__dict__.items())
                if name not in ("__module__", "__doc__", "__dict__", "__weakref__")
            ),
        )
    code = getattr(value, "__code__", None) or getattr(
        getattr(value, "__func__", None), "__code__", None
    )
    if isinstance(code, CodeType):
        return _fingerprint(code, depth + 1)
    if isinstance(value, property):
        return tuple(_fingerprint(f, depth + 1) for f in (value.fget, value.fset))
    if isinstance(value, str | bytes | int | float | bool | type(None)):
        return value
    if isinstance(value, tuple | list):
        return tuple(_fingerprint(v, depth + 1) for v in value)
    if isinstance(value, dict):
        return tuple((k, _fingerprint(v, depth + 1)) for k, v in sorted(value.items(), key=str))
    return type(value).__qualname__


@shared
class StaleRead(Exception):
    """A buffer could not be read whole: its writer kept writing (or died while writing)."""


@shared
class _Words:
    """Each block's view as 8-byte words, made once and shared by every module on the block
    and every copy of the runtime in the process (`shared`). A view is kept while its block's
    view lives (a weak reference drops it with that view) and released by `release_words`,
    which `Block.close` calls: the segment can be unmapped only when no view of it is left."""

    views: ClassVar[dict[int, tuple[weakref.ref[memoryview], memoryview]]] = {}


def words(buf: memoryview) -> memoryview:
    """`buf` as unsigned 8-byte words: `words(buf)[at >> 3]` is the sequence word of the
    buffer at offset `at` (every buffer is 8-byte aligned), read or stored in one aligned
    8-byte access. The generated code stores its sequence words so, not with
    `SEQ.pack_into`, which parses its arguments and zeroes the word before it stores it
    (three times the time; the word reads 0, a write in progress, meanwhile)."""
    if sys.byteorder != "little":  # the layout's words are little-endian ("<Q")
        raise RuntimeError("rcsgen blocks need a little-endian machine (see docs/semantics.md)")
    views = _Words.views
    key = id(buf)
    found = views.get(key)
    if found is not None and found[0]() is buf:
        return found[1]
    view = buf[: len(buf) >> 3 << 3].cast("Q")
    views[key] = (weakref.ref(buf, lambda _: views.pop(key, None)), view)
    return view


def release_words(buf: memoryview) -> None:
    """Release `buf`'s word view, if one was made (the block is being closed)."""
    found = _Words.views.pop(id(buf), None)
    if found is not None:
        found[1].release()


@shared
class Record(NamedTuple):
    """A buffer for tools (harness, traces, operator consoles): its struct, offset, fields.

    Reads are consistent (the seqlock); writes mark the buffer odd while they write. A tool
    writes only where no module of a running process writes the same buffer (an operator's
    command to a root, a mode, a world input), or while the processes are stopped."""

    struct: Struct
    offset: int
    fields: tuple[str, ...]

    def read(self, buf: memoryview) -> dict[str, object]:
        """The buffer's fields; raises StaleRead when it cannot be read whole."""
        for _ in range(READ_TRIES):
            seq, *values = self.struct.unpack_from(buf, self.offset)
            if seq and seq % 2 == 0 and SEQ.unpack_from(buf, self.offset)[0] == seq:
                return {
                    name: decode_text(v) if type(v) is bytes else v
                    for name, v in zip(self.fields, values, strict=True)
                }
        raise StaleRead(f"buffer at {self.offset} is being written (or its writer died)")

    def seq(self, buf: memoryview) -> int:
        """The buffer's sequence word: it changes with every write."""
        value: int = SEQ.unpack_from(buf, self.offset)[0]
        return value

    def codes(self) -> dict[str, str]:
        """Each field's struct code (`?`, `q`, `d`, `32s`, ...)."""
        codes = field_codes(self.struct.format)[1:]
        return dict(zip(self.fields, codes, strict=True))

    def write(self, buf: memoryview, **values: object) -> None:
        """Change some fields, keeping the others. A string goes into a string field whole or
        not at all: ValueError when it does not fit."""
        unknown = set(values) - set(self.fields)
        if unknown:
            raise KeyError(f"no {listed('field', sorted(unknown))} in a buffer of {self.fields}")
        texts = {k: v for k, v in values.items() if isinstance(v, str)}
        if texts:
            codes = self.codes()
            values.update(
                (k, encode_text(v, int(codes[k][:-1]) if codes[k].endswith("s") else -1))
                for k, v in texts.items()
            )
        try:
            current = self.read(buf)
        except StaleRead:  # a writer died mid-write: the fields named here are rewritten
            values_now = self.struct.unpack_from(buf, self.offset)[1:]
            current = dict(zip(self.fields, values_now, strict=True))
        current = {k: v.encode("utf-8") if isinstance(v, str) else v for k, v in current.items()}
        current.update(values)
        seq = next_odd(self.seq(buf))
        SEQ.pack_into(buf, self.offset, seq)  # odd before any field changes
        self.struct.pack_into(buf, self.offset, seq, *current.values())
        SEQ.pack_into(buf, self.offset, seq + 1)


_PLAN_SLOTS = ("_replans_left", "_steps", "_step")  # `plan_<name><slot>` in a status buffer


def plan_slots(values: dict[str, Any]) -> dict[str, dict[str, int]]:
    """The plans of a status buffer's values: `plan_route_step` -> {"route": {"step": ...}}
    (one place for the harness, traces and the console)."""
    plans: dict[str, dict[str, int]] = {}
    for key, value in values.items():
        if not key.startswith("plan_"):
            continue
        slot = next(s for s in _PLAN_SLOTS if key.endswith(s))
        plans.setdefault(key[len("plan_") : -len(slot)], {})[slot[1:]] = int(value)
    return plans


def enum_name(layout: object, owner: str, field: str, value: object) -> object:
    """A field's value as a person reads it: an enumeration's code as its value name (the
    layout's ENUMS; `owner` is the module, or "" for a world field), anything else as is."""
    names = getattr(layout, "ENUMS", {}).get((owner, field))
    if names and type(value) is int and 0 <= value < len(names):
        return names[value]
    return value


def result_values(layout: object, module: str, values: dict[str, Any]) -> dict[str, object]:
    """The result slots of `module`'s status buffer values by result name, an enumeration's
    by its value name (one place for the harness, traces and the console)."""
    return {
        k.removeprefix("result_"): enum_name(layout, module, k, v)
        for k, v in values.items()
        if k.startswith("result_")
    }


def enum_code(layout: object, owner: str, field: str, value: object) -> object:
    """A value a person gave for a field, as the field holds it: an enumeration's value name
    as its code (ValueError naming the values when it is none of them), anything else as is."""
    names: tuple[str, ...] = getattr(layout, "ENUMS", {}).get((owner, field), ())
    if not names:
        return value
    if isinstance(value, str) and value in names:
        return names.index(value)
    raise ValueError(f"{value!r} is not one of {', '.join(names)}")


# ---------------------------------------------------------------- overrides (fail safe)

# A world field may be under an override: FORCED by an operator (`ctl force`), or latched at
# its declared safe value (SAFE) when the process that writes it is lost, stopped or trips
# its watchdog, until an explicit reset. Its writing module never overwrites it meanwhile:
# every reader sees the override's value (rcs/override.py; docs/semantics.md, "Fail safe").
OVERRIDE_STATES = ("NONE", "FORCED", "SAFE")
NO_OVERRIDE, FORCED, SAFE = range(3)
# The layout's OVERRIDES buffer: `any` is true while some field is under an override. It is
# one byte, stored whole (never with `pack_into`, which zeroes before it stores), so a
# generated module reads it without the seqlock: the one word its cycle pays for overrides.
OVERRIDES_FIELDS = (("any", "?"),)
# Each world field's override record: its state, then a value of the field's own type.
OVERRIDE_HEAD_FIELDS = (("state", "Q"),)


# ---------------------------------------------------------------- hook calls

# What generated code accepts from a hook for a target of each type: any finite real number
# but a bool for a float (an int, as in spec expressions; a numpy float; never NaN or an
# infinity, refused in the module whose hook returned it), any integer but a bool
# within int64 for an int, exactly True or False for a bool. `type(x) in NUMBER` is the
# fast path the generated check takes first; the functions below only when it fails.
NUMBER = (float, int)
INT_MIN, INT_MAX = -(2**63), 2**63 - 1
FLOAT_MAX = sys.float_info.max  # a float target takes a finite number: -FLOAT_MAX..FLOAT_MAX


def is_real(value: object) -> bool:
    """A real number that is not a bool (numpy's and Fraction too)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value: object) -> bool:
    """An integer that is not a bool (numpy's too)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


_KIND_NAMES = {"f": "finite float", "i": "int", "b": "bool", "e": "enum index", "s": "str"}


def kind_tokens(kinds: str) -> list[str]:
    """A hook's target kinds, one token each: `fs32e3` -> [f, s32, e3] (s: a string of that
    many bytes, e: the index of an enumeration of that many values)."""
    tokens: list[str] = []
    for char in kinds:
        if char.isdigit() and tokens:
            tokens[-1] += char
        else:
            tokens.append(char)
    return tokens


def _kind_words(token: str) -> str:
    if token[0] == "s":
        return f"str of at most {token[1:]} bytes"
    if token[0] == "e":
        return f"int 0..{int(token[1:]) - 1} (an enum's index)"
    return _KIND_NAMES[token]


_NOTHING = object()


def _float_fits(value: Any) -> bool:
    return (type(value) in NUMBER or is_real(value)) and -FLOAT_MAX <= value <= FLOAT_MAX


def _int_fits(value: Any) -> bool:
    return (type(value) is int or is_integer(value)) and INT_MIN <= value <= INT_MAX


def _bool_fits(value: object) -> bool:
    return type(value) is bool


def kind_fits(token: str) -> Callable[[Any], bool]:
    """Whether a value may go into a target of this kind token (f, i, b, e<n>, s<n>): the
    one check of a hook's and a planner's results."""
    if token == "f":
        return _float_fits
    if token == "i":
        return _int_fits
    if token == "b":
        return _bool_fits
    size = int(token[1:])
    if token[0] == "e":  # the index of one of its values
        return lambda value: type(value) is int and 0 <= value < size
    if token[0] == "s":  # a string that fits, never truncated
        return lambda value: not text_problem(value, size)
    raise ValueError(f"unknown result kind {token!r}")


def result_fits(kinds: str) -> Callable[[Any], bool]:
    """Whether a hook's result fits targets of `kinds`: one value of its kind, or a tuple of
    exactly that many values of theirs. The usual result is accepted by `fast_fits`'s
    straight-line test; anything else by `result_fits_each`, the test value by value."""
    each = result_fits_each(kinds)
    fast, names = fast_fits(kinds, "return True", "    ")
    if not fast:
        return each
    source = f"def fits(result):\n{fast}    return each(result)\n"
    fits: Callable[[Any], bool] = compiled(source, "fits", names | {"each": each}, "<fits>")
    return fits


def result_fits_each(kinds: str) -> Callable[[Any], bool]:
    """`result_fits` written plainly: each value tested by its kind's `kind_fits`."""
    tests = tuple(kind_fits(token) for token in kind_tokens(kinds))
    if len(tests) == 1:
        return tests[0]
    count = len(tests)

    def fits(result: Any) -> bool:
        return (
            type(result) is tuple
            and len(result) == count
            and all(test(value) for test, value in zip(tests, result, strict=True))
        )

    return fits


# The test of a token's usual value (a float, int or bool of exactly that type) by name:
# a subset of what its `kind_fits` accepts, written out by `fast_fits`; a float target's
# values are tested finite all at once (their sum times 0.0 is 0.0: never for a NaN or an
# infinity; a sum that overflows is left to the test value by value).
_FAST_TYPE = {"f": "float", "i": "int", "b": "bool", "e": "int"}


def fast_fits(kinds: str, accept: str, indent: str) -> tuple[str, dict[str, Any]]:
    """Straight-line Python source (at `indent`) that runs `accept` when `result` is a usual
    result of `kinds` (exactly a float, an int, a bool, of each target's type, in its
    range): what it accepts, `result_fits_each` accepts too; whatever it lets through is
    for that one to judge. '' when there is no such shortcut (a single string). With the
    names the source uses. Generated code's hook calls run it every cycle (rcs/deadline.py):
    a call per value cost more than most hooks."""
    tokens = kind_tokens(kinds)
    for token in tokens:
        kind_fits(token)  # an unknown kind: its ValueError, before any source is written
    names: dict[str, Any] = {"INT_MIN": INT_MIN, "INT_MAX": INT_MAX}
    tuple_of = len(tokens) > 1  # a tuple, unpacked by name (a wrong length: not usual)
    values = [f"v{index}" for index in range(len(tokens))] if tuple_of else ["result"]
    types, ranges, floats = [], [], []
    for index, (token, value) in enumerate(zip(tokens, values, strict=True)):
        if token[0] == "s":  # no shortcut: its own test
            if len(tokens) == 1:
                return "", names
            names[f"test{index}"] = kind_fits(token)
            ranges.append(f"test{index}({value})")
            continue
        types.append(f"type({value}) is {_FAST_TYPE[token[0]]}")
        if token == "f":
            floats.append(value)
        elif token == "i":
            ranges.append(f"INT_MIN <= {value} <= INT_MAX")
        elif token[0] == "e":
            ranges.append(f"0 <= {value} < {int(token[1:])}")
    if floats:
        ranges.append(f"({' + '.join(floats)}) * 0.0 == 0.0")
    tests = types + ranges
    lines = [f"if {' and '.join(tests)}:", f"    {accept}"]
    if tuple_of:
        unpack = ["if type(result) is tuple:", "    try:", f"        {', '.join(values)} = result"]
        lines = [*unpack, "    except ValueError:", "        pass", "    else:"] + [
            f"        {line}" for line in lines
        ]
    return "".join(f"{indent}{line}\n" for line in lines), names


def compiled(source: str, name: str, names: dict[str, Any], filename: str) -> Any:
    """Function `name` of `source` (written by this runtime from checked tokens, never from
    input), with `names` as its globals."""
    scope = dict(names)
    exec(compile(source, filename, "exec"), scope)  # noqa: S102
    return scope[name]


def plan_problem(steps: object, kinds: str, capacity: int) -> str:
    """'' when a planner's result is a plan: a list (or tuple) of at most `capacity` steps,
    each a tuple of one value per step field of `kinds` (f, i, b); else what is wrong, as
    the rest of a sentence that starts with the planner's name."""
    names = ", ".join(_KIND_NAMES[k] for k in kinds)
    shape = f"a list of at most {capacity} steps, each a tuple ({names})"
    if not isinstance(steps, list | tuple):
        return f"returned {_shown(steps)}; a plan is {shape}"
    if len(steps) > capacity:
        return f"returned {len(steps)} steps, more than the plan's capacity ({shape})"
    for index, step in enumerate(steps):
        if (
            not isinstance(step, tuple)
            or len(step) != len(kinds)
            or not all(kind_fits(k)(v) for v, k in zip(step, kinds, strict=True))
        ):
            return f"returned step {index} as {_shown(step)}; a plan is {shape}"
    return ""


def _shown(value: object) -> str:
    shown = repr(value)
    return shown if len(shown) <= 60 else shown[:57] + "..."


@shared
class HookOverrun(BaseException):
    """A hook ran past its deadline (rcs/deadline.py): raised inside it by the timer signal
    (`interrupted`), or when it returned late anyway. A BaseException, so that a hook's own
    `except Exception` does not swallow it."""

    def __init__(self, deadline: float, took: float, interrupted: bool) -> None:
        self.deadline, self.took, self.interrupted = deadline, took, interrupted
        super().__init__(deadline, took, interrupted)

    def __str__(self) -> str:
        if self.interrupted:
            return (
                f"did not return within its deadline of {self.deadline:g} s: interrupted "
                f"after {self.took:.3g} s"
            )
        return (
            f"returned after {self.took:.3g} s, past its deadline of {self.deadline:g} s: "
            "its result is refused"
        )


@shared
class HookError(Exception):
    """A hook call that failed at run time, raised by generated code: the hook raised (the
    exception is the `__cause__`), or its result does not fit its `returns:`.

    Names the module, the hook, the table rule that called it (`SUMP_SHEAR_CUSP/S0/1`,
    `every_cycle/2`, or `hooks_state` for the factory) and the module's cycle (1-based;
    0 while the module is made)."""

    def __init__(
        self,
        module: str,
        hook: str,
        rule: str,
        cycles: int,
        result: object = _NOTHING,
        kinds: str = "",
        why: str = "",
    ) -> None:
        self.module, self.hook, self.rule = module, hook, rule
        self.cycle = cycles + 1 if rule != "hooks_state" else 0
        self.result, self.kinds = result, kinds
        self.why = why  # what is wrong, when it is not the shape of `returns:` (a plan's)
        super().__init__(self.problem())

    @property
    def raised(self) -> bool:
        """The hook raised (rather than returning a wrong result)."""
        return self.result is _NOTHING and not self.why

    def expected(self) -> str:
        """What `returns:` asks for: `a float`, `a tuple of 2 values (float, int)`."""
        names = [_kind_words(k) for k in kind_tokens(self.kinds)]
        if len(names) == 1:
            return f"a{'n' if names[0].startswith(('int', 'enum')) else ''} {names[0]}"
        return f"a tuple of {len(names)} values ({', '.join(names)})"

    def problem(self) -> str:
        who = f"hook `{self.hook}` of `{self.module}`"
        if self.why:
            return f"{who} {self.why}"
        if isinstance(self.__cause__, HookOverrun):
            return f"{who} {self.__cause__}"
        if self.raised:
            cause = self.__cause__
            what = f"{type(cause).__name__}: {cause}" if str(cause) else type(cause).__name__
            what = what if cause is not None else "an exception"
            return f"{who} raised {what}"
        shown = repr(self.result)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        return f"{who} returned {shown}; its `returns:` needs {self.expected()}"

    def __str__(self) -> str:
        # Computed again: `__cause__` is set only after __init__ (`raise ... from error`).
        where = "while made" if self.rule == "hooks_state" else f"rule {self.rule}"
        return f"{self.problem()} ({where}, cycle {self.cycle})"
