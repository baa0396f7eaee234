"""Override: a world field its writing module must not overwrite, forced or latched safe.

Each world field has an override record in the block (the layout's OVERRIDE): its state,
NONE, FORCED (an operator's force, PLC style: `ctl force`) or SAFE (latched at the
actuator's declared safe value when the process that writes it is lost, stops or trips its
watchdog: ISO 13850's latched stop), and its value. While a field is under an override, the
generated module that writes it writes the override's value instead of its own (`held`),
so every reader sees the forced or safe value; the layout's `any` flag (one byte) tells it
whether to look, so a cycle with no override pays one byte read.

A SAFE latch is released only by `reset` (an explicit act of a role allowed to); a force
never replaces it. Writers serialise on the segment's file (`segment=`, an advisory lock
held for microseconds); a private block has one process. Standard library only: copied
verbatim into every generated package.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType
from typing import Any

from .contract import (
    FORCED,
    NO_OVERRIDE,
    OVERRIDE_STATES,
    READ_TRIES,
    SAFE,
    SEQ,
    Record,
    StaleRead,
    encode_text,
    enum_code,
    is_integer,
    is_real,
    next_odd,
    shared,
    text_problem,
)

LOCK_WAIT = 0.2  # seconds a writer waits for the lock before it writes anyway (a frozen holder)


@shared
class OverrideError(ValueError):
    """An override that cannot be made: an unknown field, a value it cannot hold, a force on
    a latched field, an unforce of a field that is not forced."""


# ---------------------------------------------------------------- the generated modules' side


def held(
    buf: memoryview, records: Sequence[Record], out: tuple[Any, ...], now: tuple[Any, ...]
) -> tuple[Any, ...]:
    """`out` (the values a module is about to write to adjacent world fields, as packed) with
    each field under an override replaced by the override's value; a field whose override
    record is being written keeps the block's value `now` this cycle."""
    values = list(out)
    for i, record in enumerate(records):
        raw = _raw(record, buf)
        if raw is None:
            values[i] = now[i]
        elif raw[0] != NO_OVERRIDE:
            values[i] = raw[1]
    return tuple(values)


def _raw(record: Record, buf: memoryview) -> tuple[Any, ...] | None:
    """An override record's (state, value) as packed (a string as its bytes), read whole;
    None when it is being written."""
    for _ in range(READ_TRIES):
        seq, *values = record.struct.unpack_from(buf, record.offset)
        if seq and seq % 2 == 0 and SEQ.unpack_from(buf, record.offset)[0] == seq:
            return tuple(values)
    return None


# ---------------------------------------------------------------- tools' and the runtime's side


def force(
    layout: ModuleType, buf: memoryview, field: str, value: object, segment: str | None = None
) -> None:
    """Force world field `field` to `value` (an enumeration's value by name or code): the
    module that writes it no longer does until `unforce`. Refused for a field latched SAFE."""
    record = _record(layout, field)
    stored = _stored(layout, field, value)
    with _locked(segment):
        state, _ = _state(record, buf)
        if state == SAFE:
            raise OverrideError(f"{field} is latched at its safe value: reset it first")
        _set(layout, buf, field, FORCED, stored)


def unforce(layout: ModuleType, buf: memoryview, field: str, segment: str | None = None) -> None:
    """Release a force: the module that writes `field` writes it again from its next cycle."""
    record = _record(layout, field)
    with _locked(segment):
        state, value = _state(record, buf)
        if state != FORCED:
            what = "latched at its safe value: reset releases it" if state == SAFE else "not forced"
            raise OverrideError(f"{field} is {what}")
        _write(record, buf, NO_OVERRIDE, value)
        _update_any(layout, buf)


def latch_safe(
    layout: ModuleType, buf: memoryview, fields: Iterable[str], segment: str | None = None
) -> list[str]:
    """Write each actuator's declared safe value and latch it (SAFE, a force too); the fields
    latched now (not already), in order. A field already latched whose value a racing write
    changed (its writer past its look at the flag) gets its safe value again: a process that
    stops has no next cycle to correct it."""
    safe_values = layout.SAFE_VALUES
    chosen = list(fields)
    for field in chosen:
        if field not in safe_values:
            raise OverrideError(f"{field} is not an actuator: it has no safe value")
    latched = []
    with _locked(segment):
        for field in chosen:
            state, value = _state(_record(layout, field), buf)
            if state == SAFE and value == safe_values[field]:
                if _world(layout, buf, field) != value:
                    layout.WORLD[field].write(buf, **{field: value})
                continue
            _set(layout, buf, field, SAFE, safe_values[field])
            latched.append(field)
    return latched


def reset(
    layout: ModuleType,
    buf: memoryview,
    fields: Iterable[str] | None = None,
    segment: str | None = None,
) -> list[str]:
    """Release the SAFE latches of `fields` (all of them when None): the explicit reset after a
    latched stop. The fields released, in order; forces are left alone."""
    names = list(layout.OVERRIDE) if fields is None else list(fields)
    released = []
    with _locked(segment):
        for field in names:
            record = _record(layout, field)
            state, value = _state(record, buf)
            if state == SAFE:
                _write(record, buf, NO_OVERRIDE, value)
                released.append(field)
        _update_any(layout, buf)
    return released


def mirrored(layout: ModuleType, buf: memoryview) -> None:
    """A transport wrote an override record another host made (rcs/transport.py): raise or
    lower the flag the generated modules look at, as a local override would."""
    _update_any(layout, buf)


def overrides(layout: ModuleType, buf: memoryview) -> dict[str, tuple[str, object]]:
    """Every field under an override: field -> (FORCED or SAFE, its value as stored)."""
    found: dict[str, tuple[str, object]] = {}
    if not buf[layout.OVERRIDDEN_AT]:
        return found
    for field, record in layout.OVERRIDE.items():
        state, value = _state(record, buf)
        if state != NO_OVERRIDE:
            found[field] = (OVERRIDE_STATES[state], value)
    return found


# ---------------------------------------------------------------- helpers


def _record(layout: ModuleType, field: str) -> Record:
    record: Record | None = layout.OVERRIDE.get(field)
    if record is None:
        raise OverrideError(f"no world field {field!r}")
    return record


def _state(record: Record, buf: memoryview) -> tuple[int, object]:
    """(state, value) of an override record; a record whose writer died mid-write reads as
    its raw fields (the writer rewrites it whole)."""
    raw = _raw(record, buf)
    if raw is None:
        raw = tuple(record.struct.unpack_from(buf, record.offset)[1:])
    value = raw[1]
    return int(raw[0]), value.rstrip(b"\0").decode("utf-8", "replace") if type(
        value
    ) is bytes else value


def _world(layout: ModuleType, buf: memoryview, field: str) -> object:
    """World field `field` as the block holds it; None while it is being written."""
    try:
        return layout.WORLD[field].read(buf)[field]
    except StaleRead:
        return None


def _stored(layout: ModuleType, field: str, value: object) -> object:
    """`value` as the field holds it, or OverrideError naming what it holds."""
    code = layout.WORLD[field].codes()[field]
    try:
        value = enum_code(layout, "", field, value)
    except ValueError as error:
        raise OverrideError(f"{field}: {error}") from None
    if code == "?":
        ok = type(value) is bool
    elif code == "d":
        ok = is_real(value)
        value = float(value) if ok else value  # type: ignore[arg-type]
    elif code == "q":
        ok = is_integer(value) and -(2**63) <= int(value) < 2**63  # type: ignore[call-overload]
        names = getattr(layout, "ENUMS", {}).get(("", field), ())
        ok = ok and (not names or 0 <= int(value) < len(names))  # type: ignore[call-overload]
    else:
        problem = text_problem(value, int(code[:-1]))
        if problem:
            raise OverrideError(f"{field}: {problem}")
        ok = True
    if not ok:
        kind = {"?": "a bool", "d": "a number", "q": "an int"}.get(code, "a string")
        raise OverrideError(f"{field} holds {kind}, not {value!r}")
    return value


def _set(layout: ModuleType, buf: memoryview, field: str, state: int, value: object) -> None:
    """Mark the override, raise the flag, then write the field itself (its module, from its
    next cycle, keeps it)."""
    _write(layout.OVERRIDE[field], buf, state, value)
    buf[layout.OVERRIDDEN_AT] = 1
    layout.WORLD[field].write(buf, **{field: value})


def _write(record: Record, buf: memoryview, state: int, value: object) -> None:
    if isinstance(value, str):
        value = encode_text(value, int(record.codes()[record.fields[1]][:-1]))
    seq = next_odd(record.seq(buf))
    SEQ.pack_into(buf, record.offset, seq)  # odd before any field changes
    record.struct.pack_into(buf, record.offset, seq, state, value)
    SEQ.pack_into(buf, record.offset, seq + 1)


def _update_any(layout: ModuleType, buf: memoryview) -> None:
    """Lower the flag when no field is under an override any more (one byte, stored whole)."""
    active = any(_state(record, buf)[0] != NO_OVERRIDE for record in layout.OVERRIDE.values())
    buf[layout.OVERRIDDEN_AT] = 1 if active else 0


@contextmanager
def _locked(segment: str | None) -> Iterator[None]:
    """Serialise override writers of a named segment (an advisory lock on its file in
    /dev/shm); a holder that does not let go within LOCK_WAIT (frozen) is not waited for."""
    if segment is None:
        yield
        return
    import fcntl

    try:
        fd = os.open(f"/dev/shm/{segment.lstrip('/')}", os.O_RDWR)
    except OSError:
        yield
        return
    try:
        deadline = time.monotonic() + LOCK_WAIT
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() > deadline:
                    break
                time.sleep(0.001)
        yield
    finally:
        os.close(fd)  # releases the lock
