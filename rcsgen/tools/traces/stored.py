"""A trace as stored: full lines now and then, and in between only what changed.

A full line is what `trace_line` makes, one canonical JSON object a cycle
(`{"cycle":N,"modules":{...},"world":{...}}`, keys sorted, no spaces). Stored, a trace keeps
the first cycle's full line and one every KEYFRAME cycles (a keyframe: the whole state,
readable on its own); every other cycle is a change line, the values that differ from the
line before and nothing else:

    {"cycle":57,"changed":{"modules":{"co":{"rule":"GO/S1/2","state":"S2"}},"world":{"x":1.5}}}
    {"cycle":58}
    {"cycle":59,"changed":{...},"removed":[["modules","co","cause"]]}

`changed` has the full line's shape, holding only the members that changed (an object that
was an object before holds only its changed members; any other value is whole); `removed`
lists the paths of members that are gone. A line without `modules` that is not a change
line (the run's timing record, an `interrupted` line) is kept as it is. `expanded` gives
back the full lines byte for byte (`condensed` then `expanded` is the identity on what
`trace_line` writes: JSON numbers, strings, booleans and nulls read back as themselves); a
file of full lines only (a trace written before this format, or by hand) reads as it is.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator
from typing import Any

KEYFRAME = 200  # a full line every KEYFRAME cycles (cycle % KEYFRAME == 0), and the first
CHANGED, REMOVED = "changed", "removed"
DELTA_KEYS = frozenset({"cycle", CHANGED, REMOVED})


def dumps(value: Any) -> str:
    """The canonical JSON text of a trace line or of part of one."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"))


def is_delta(record: dict[str, Any]) -> bool:
    """Whether a decoded line is a change line (only `cycle`, `changed`, `removed`)."""
    return "modules" not in record and record.keys() <= DELTA_KEYS


def difference(old: dict[str, Any], new: dict[str, Any]) -> tuple[dict[str, Any], list[list[str]]]:
    """What changed from `old` to `new`: the changed members and the paths of removed ones."""
    changed: dict[str, Any] = {}
    removed: list[list[str]] = []
    for key, value in new.items():
        if key not in old:
            changed[key] = value
            continue
        before = old[key]
        if type(value) is dict and type(before) is dict:
            inner, gone = difference(before, value)
            if inner:
                changed[key] = inner
            removed.extend([key, *path] for path in gone)
        elif type(value) is not type(before) or value != before:
            changed[key] = value
    removed.extend([key] for key in old if key not in new)
    return changed, removed


def applied(base: dict[str, Any], changed: dict[str, Any]) -> dict[str, Any]:
    """`base` with `changed` merged in (a new dict; `base` and what it holds are not touched:
    an unchanged member is the very object it was)."""
    out = dict(base)
    for key, value in changed.items():
        before = out.get(key)
        out[key] = applied(before, value) if type(value) is dict and type(before) is dict else value
    return out


def without(base: dict[str, Any], path: list[str]) -> dict[str, Any]:
    """`base` without the member at `path` (new dicts along the path); KeyError if absent."""
    out = dict(base)
    if len(path) == 1:
        del out[path[0]]
    else:
        inner = out[path[0]]
        if type(inner) is not dict:
            raise KeyError(path[0])
        out[path[0]] = without(inner, path[1:])
    return out


def condensed(lines: Iterable[str], keyframe: int = KEYFRAME) -> Iterator[str]:
    """Full trace lines as stored: a keyframe, then change lines (see the module's doc)."""
    condenser = Condenser(keyframe)
    return (condenser.line(line) for line in lines)


class Condenser:
    """Full lines to stored lines one at a time, as `condensed` makes them: for a trace
    written as its run goes."""

    def __init__(self, keyframe: int = KEYFRAME) -> None:
        self.keyframe = keyframe
        self.last: dict[str, Any] | None = None  # the last full record

    def line(self, line: str) -> str:
        """The stored line for the next full line (a line without `modules`, the timing
        record or an `interrupted` line, as it is)."""
        record = json.loads(line)
        if "modules" not in record:
            return line
        last, self.last = self.last, record
        if last is None or record["cycle"] % self.keyframe == 0:
            return line
        return delta_line(last, record)


def delta_line(last: dict[str, Any], record: dict[str, Any]) -> str:
    """The change line that takes full line `last` to full line `record`."""
    changed, removed = difference(last, record)
    changed.pop("cycle", None)
    text = f'{{"cycle":{record["cycle"]}'
    if changed:
        text += f',"{CHANGED}":{dumps(changed)}'
    if removed:
        text += f',"{REMOVED}":{json.dumps(removed, separators=(",", ":"))}'
    return text + "}"


class Expansion:
    """Stored lines back to full records, one at a time (`record`); ValueError, in words,
    for a change line that cannot be applied."""

    def __init__(self) -> None:
        self.last: dict[str, Any] | None = None  # the last full record

    def record(self, record: dict[str, Any]) -> dict[str, Any]:
        """The full record of one decoded stored line (a line that is not a change line is
        its own; one with `modules` becomes the base of the next change line)."""
        if not is_delta(record):
            if "modules" in record:
                self.last = record
            return record
        if self.last is None:
            raise ValueError("no `modules` object, nor a full line before it to change")
        changed = record.get(CHANGED, {})
        removed = record.get(REMOVED, [])
        if type(changed) is not dict or type(removed) is not list:
            raise ValueError(f"`{CHANGED}` is not an object or `{REMOVED}` not a list")
        full = applied(self.last, changed) if changed else dict(self.last)
        for path in removed:
            if type(path) is not list or not path or not all(type(p) is str for p in path):
                raise ValueError(f"`{REMOVED}` holds {json.dumps(path)}, not a path")
            try:
                full = without(full, path)
            except KeyError:
                raise ValueError(
                    f"`{REMOVED}` names {'.'.join(path)}, which is not there"
                ) from None
        full["cycle"] = record["cycle"]
        self.last = full
        return full


def expanded(lines: Iterable[str]) -> Iterator[str]:
    """Stored lines as full lines, byte for byte what `trace_line` wrote; ValueError (in
    words) for a line that is not JSON or a change line that cannot be applied."""
    expansion = Expansion()
    for line in lines:
        record = json.loads(line) if line.strip() else None
        if not isinstance(record, dict):
            yield line  # (a blank line; anything else is the reader's to refuse)
            continue
        full = expansion.record(record)
        yield line if full is record else dumps(full)
