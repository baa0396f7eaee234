"""Traces: a trace file (JSON Lines, one line per cycle) -> checked columns per module and world.

A trace is stored as `stored` says: a full line now and then, and in between only what
changed; a change line is read as the full line it stands for (a trace of full lines only
reads as well).

`load` reads what `rcsgen run` writes and checks every line, so the viewers can trust it:
a problem is a `TraceError` whose message is one line naming the file and line. It reads
line by line (a long trace is never held whole as text), plain or gzip-compressed
(`.jsonl.gz`: `rcsgen run --trace X.jsonl.gz` writes one; known by its first bytes, not its
name). `lanes`
orders the modules as a system runs them (execution order, level, simulators, stand-ins)
when the specs are at hand, and alphabetically otherwise.
"""

from __future__ import annotations

import gzip
import io
import json
import math
import zlib
from collections.abc import Generator, Iterable, Iterator
from dataclasses import dataclass, field
from itertools import chain, repeat
from pathlib import Path
from typing import IO, Any, cast

from ...compiler.ir import IRProcess, IRSystem
from ...runtime import contract
from .stored import CHANGED, REMOVED, applied, expanded, is_delta, without

FIELDS = ("command", "command_num", "status", "status_num", "state", "rule")
# Only for modules that declare them, on every line or none: the reason's name and the
# result slots ({name: value}).
OPTIONAL = ("reason", "result")
# Only on the lines where a module with reasons is in ERROR with a cause (what it was passed
# up from, docs/semantics.md "Reasons survive"): a column of those modules, '' elsewhere.
SPARSE = "cause"


# A paced run's trace ends with one record of how well the run held its period (after the
# cycles, before an `interrupted` line): `{"cycle": N, "periodicity": {...}}`, the figures
# of `ctl status` (contract.periodicity). Timing is never the same twice: comparisons with
# a golden trace leave it out (scenario/run.py `first_difference`).
TIMING = "periodicity"
# Its figures (contract.periodicity's names, whatever the values), each a finite number: the
# views write them into a page's JSON and its title.
FIGURES = tuple(
    sorted(
        contract.periodicity(dict.fromkeys(contract.field_names(contract.PERIODICITY_FIELDS), 1))
        or ()
    )
)


def is_timing(line: str) -> bool:
    """Whether a trace line is the timing record (its keys sorted: cycle, periodicity)."""
    return line.partition(",")[2].startswith(f'"{TIMING}":')


class TraceError(Exception):
    """A file that is not a readable trace, or one that does not fit the specs; one line."""


@dataclass
class Trace:
    name: str  # the path as given
    cycles: list[int]
    modules: list[str]  # sorted, as every line holds them
    columns: dict[str, dict[str, list[Any]]]  # module -> field -> one value per cycle
    world: dict[str, list[Any]] = field(default_factory=dict)  # field -> one value per cycle
    # The signal that interrupted the run (`rcsgen run` on SIGINT/SIGTERM writes the cycles
    # it ran and a last line saying so), or CUT for a trace whose run was killed while it
    # wrote the last line; None for a run that ended.
    interrupted: str | None = None
    # module -> the indices of the cycles whose line holds another object for it than the
    # line before (0 first): its values change nowhere else, so a viewer that looks for
    # changes need only look there. Empty: not known (look at every cycle).
    starts: dict[str, list[int]] = field(default_factory=dict)
    # How well a paced run held its period (its timing record, TIMING); None if not paced.
    periodicity: dict[str, Any] | None = None

    def __len__(self) -> int:
        return len(self.cycles)


FULL = '"modules":{'  # a full line's second member (`{"cycle":N,"modules":{...`)
GZIP_MAGIC = b"\x1f\x8b"  # the first bytes of a gzip file (a `.jsonl.gz` trace)


def load(path: Path) -> Trace:
    """Read and check a trace file; TraceError with a one-line message if it is not one."""
    shown = str(path)
    if not path.exists():
        raise TraceError(f"no trace file at {shown}")
    if not path.is_file():
        raise TraceError(f"{shown} is not a file")
    lines = _Lines(path, shown)
    try:
        return parse_lines(lines, shown)
    except OSError as error:
        raise TraceError(f"{shown} is not a trace: cannot read it ({error})") from None
    finally:
        lines.close()  # the file is closed however the reading ended


def full_lines(path: Path) -> list[str]:
    """A trace file's lines, each a whole cycle (a stored trace expanded, `stored`): what
    `rcsgen run` wrote before it stored only the changes, for `jq`, `diff` or a script;
    TraceError with a one-line message if it cannot be read. A last line written only in
    part is left out (`_Lines`)."""
    shown = str(path)
    if not path.is_file():
        raise TraceError(
            f"no trace file at {shown}" if not path.exists() else f"{shown} is not a file"
        )
    lines = _Lines(path, shown)
    try:
        return list(expanded(lines))
    except ValueError as error:
        raise TraceError(f"{shown} is not a trace: {error}") from None
    except OSError as error:
        raise TraceError(f"{shown} is not a trace: cannot read it ({error})") from None
    finally:
        lines.close()


class _Lines:
    """The text lines of a trace file, one at a time, decompressed if it is gzip. A last line
    that has no newline and is not JSON (`rcsgen run` killed outright while writing it: the
    trace it writes as it goes, `LiveTrace`) is left out and `cut` says so: the cycles before
    it are whole and readable, as an interrupted run's trace must be."""

    def __init__(self, path: Path, shown: str) -> None:
        self.cut = False
        self._read = self._lines(path, shown)

    def __iter__(self) -> Iterator[str]:
        return self._read

    def close(self) -> None:
        self._read.close()

    def _lines(self, path: Path, shown: str) -> Generator[str, None, None]:
        with path.open("rb") as raw:
            stream: IO[bytes] = raw
            if raw.peek(len(GZIP_MAGIC))[: len(GZIP_MAGIC)] == GZIP_MAGIC:
                stream = cast(IO[bytes], io.BufferedReader(_Inflating(raw)))
            text = io.TextIOWrapper(stream, encoding="utf-8")
            try:
                for line in text:
                    if line.endswith("\n") or not self._cut_short(line):
                        yield line.rstrip("\n")
            except UnicodeDecodeError as error:
                raise TraceError(
                    f"{shown} is not a trace: cannot read it as UTF-8 text ({error})"
                ) from None
            except zlib.error as error:
                raise TraceError(f"{shown} is not a trace: a damaged gzip file ({error})") from None
            finally:
                text.detach()  # `raw` is closed by its own `with`

    def _cut_short(self, last: str) -> bool:
        """Whether the file's last line (it has no newline) was written only in part."""
        try:
            json.loads(last)
        except json.JSONDecodeError:
            self.cut = True
        return self.cut


class _Inflating(io.RawIOBase):
    """A gzip file's text bytes (every member in turn). A stream that stops before its end
    gives what it holds: `rcsgen run` writes a `.jsonl.gz` trace as it goes, flushed whole
    lines at a time (`LiveTrace`), so a run killed outright leaves its cycles readable;
    the last line, if cut, is then left out as in a plain trace (`_Lines`)."""

    def __init__(self, raw: IO[bytes]) -> None:
        super().__init__()
        self.raw, self.inflate, self.out = raw, zlib.decompressobj(wbits=31), b""

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        while not self.out:
            data = self.inflate.unused_data or self.raw.read(1 << 16)
            if not data:
                return 0  # the end of the file, whole or not
            if self.inflate.eof:  # the member before ended: another one follows
                self.inflate = zlib.decompressobj(wbits=31)
            self.out = self.inflate.decompress(data)
        size = min(len(buffer), len(self.out))
        buffer[:size], self.out = self.out[:size], self.out[size:]
        return size


CUT = "cut short (the run was killed while writing its last line)"  # Trace.interrupted


def beside(path: Path, suffix: str) -> Path:
    """A file next to a trace, named after it: `x.jsonl` and `x.jsonl.gz` give `x<suffix>`."""
    name = path.name.removesuffix(".gz")
    if name.endswith(".jsonl"):
        return path.with_name(name.removesuffix(".jsonl") + suffix)
    return path.with_name(name).with_suffix(suffix)


def decompressed(data: bytes, limit: int) -> bytes:
    """A trace file's bytes as text bytes: gunzipped if they are gzip (at most `limit`
    bytes out; ValueError when it is larger or damaged), else as they are."""
    if data[: len(GZIP_MAGIC)] != GZIP_MAGIC:
        return data
    inflate = zlib.decompressobj(wbits=31)  # 31: a gzip header and trailer
    try:
        out = inflate.decompress(data, limit + 1)
    except zlib.error as error:
        raise ValueError(f"a damaged gzip file ({error})") from None
    if len(out) > limit:
        raise ValueError(f"it holds more than {limit:,} bytes of text")
    if not inflate.eof:
        raise ValueError("a damaged gzip file (it ends before its data does)")
    return out


def compressed(text: str) -> bytes:
    """`text` gzipped, reproducibly: no time or file name in the header."""
    return gzip.compress(text.encode("utf-8"), mtime=0)


def parse(text: str, shown: str = "<trace>") -> Trace:
    """A trace from its text (see parse_lines)."""
    return parse_lines(text.splitlines(), shown)


def parse_lines(lines: Iterable[str], shown: str = "<trace>") -> Trace:
    """Check a trace's lines, one at a time, into columns; TraceError naming the line."""
    trace = Trace(shown, [], [], {}, {})
    reader = _Reader(trace)
    for where, record in _records(lines, shown):
        if trace.interrupted is not None:
            raise TraceError(f"{where}: a line after the one that says the run was interrupted")
        if trace.periodicity is not None and "interrupted" not in record:
            raise TraceError(f"{where}: a cycle after the run's timing record")
        if TIMING in record:  # after the cycles of a paced run: how well it held its period
            trace.periodicity = _timing(record, where, trace)
            continue
        if "interrupted" in record:  # the run's last word: stopped by a signal in this cycle
            trace.interrupted = _interruption(record, where)
            continue
        if is_delta(record):  # what changed since the line before
            reader.change(record, where)
        else:
            reader.append(record, where)
    reader.columns()
    if getattr(lines, "cut", False) and trace.interrupted is None:  # (`_Lines`)
        trace.interrupted = CUT
    if not trace.cycles and trace.interrupted is None:
        raise TraceError(f"{shown} is empty: a trace has one JSON line per cycle")
    if not trace.cycles:
        raise TraceError(
            f"{shown} holds no cycle: its run was interrupted before its first one ended"
        )
    return trace


BATCH = 256  # change lines decoded in one go (one JSON array: a third less time than one by one)


def _records(lines: Iterable[str], shown: str) -> Iterator[tuple[str, dict[str, Any]]]:
    """Each non-blank line's place (`file:line`) and record, in order. A full line whose
    `modules` text is the last one's has only the rest decoded (`_Modules`); the other lines
    (change lines, mostly) are decoded BATCH at a time, and one by one only where a batch
    does not decode (to name the line)."""
    memo = _Modules()
    batch: list[tuple[int, str]] = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        if (
            line.startswith('{"cycle":')
            and line.endswith("}")
            and not line.startswith(FULL, line.find(",") + 1)
        ):  # (a line of rcsgen's shape: one that is not JSON alone cannot hide in the batch)
            batch.append((number, line))
            if len(batch) >= BATCH:
                yield from _decoded(batch, shown)
                batch = []
            continue
        if batch:
            yield from _decoded(batch, shown)
            batch = []
        where = f"{shown}:{number}"
        if line.startswith(FULL, line.find(",") + 1):  # (else not a full line: decoded once)
            yield where, memo.reuse(line) or memo.remember(line, _record(line, where))
        else:
            yield where, _record(line, where)
    yield from _decoded(batch, shown)


def _decoded(batch: list[tuple[int, str]], shown: str) -> Iterator[tuple[str, dict[str, Any]]]:
    """A batch of lines' places and records (checked as `_record` checks one)."""
    try:
        records = json.loads(f"[{','.join(line for _, line in batch)}]")
    except json.JSONDecodeError:
        records = None  # (one of them is not JSON, or is more than one value: which?)
    if records is None or len(records) != len(batch):
        records = [_record(line, f"{shown}:{number}") for number, line in batch]
    for (number, line), record in zip(batch, records, strict=True):
        where = f"{shown}:{number}"
        if type(record) is not dict or type(record.get("cycle")) is not int:
            _record(line, where)  # (raises, naming the line)
        yield where, record


def _record(line: str, where: str) -> dict[str, Any]:
    """One line's JSON object, with its `cycle` number."""
    try:
        record = json.loads(line)
    except json.JSONDecodeError as error:
        raise TraceError(f"{where}: not a trace line: {error.msg}") from None
    if not isinstance(record, dict) or not isinstance(record.get("cycle"), int):
        raise TraceError(f"{where}: not a trace line (no `cycle` number)")
    return record


class _Modules:
    """The `modules` object of the last line read whole, and its text: a line whose modules
    text is the same (three lines in four of a long run) has only the rest decoded.

    `rcsgen run` writes `{"cycle":N,"modules":{...},"world":{...}}`. In JSON a `"` inside
    a string is always escaped, so `},"world":{` is a key `world` of some object after an
    object value, and `,"modules":` right after the cycle's digits is the line's own key:
    when the text between them is balanced (the rest then decodes as an object without
    it), it is the whole `modules` member. Any other shape is decoded whole."""

    def __init__(self) -> None:
        self.text: str | None = None  # `"modules":{...}` of the last line decoded whole
        self.modules: Any = None  # what it decoded to

    @staticmethod
    def _split(line: str) -> tuple[int, int] | None:
        start, end = line.find(',"modules":'), line.find('},"world":{')
        if 0 < start < end and line.startswith('{"cycle":') and line[9:start].isdigit():
            return start, end
        return None

    def reuse(self, line: str) -> dict[str, Any] | None:
        """The line's record, its `modules` the last one's, if its text is the same."""
        split = self._split(line) if self.text is not None else None
        if split is None:
            return None
        start, end = split
        if line[start + 1 : end + 1] != self.text:
            return None
        try:
            record = json.loads(line[: start + 1] + line[end + 2 :])
        except json.JSONDecodeError:
            return None
        if not isinstance(record, dict) or "modules" in record:
            return None
        record["modules"] = self.modules
        return record

    def remember(self, line: str, record: dict[str, Any]) -> dict[str, Any]:
        """A record decoded whole (from `line`), its modules kept for the next line."""
        split = self._split(line)
        self.text = None if split is None else line[split[0] + 1 : split[1] + 1]
        self.modules = record.get("modules")
        return record


def _timing(record: dict[str, Any], where: str, trace: Trace) -> dict[str, Any]:
    """The figures of a timing record (it holds only them and `cycle`, after a cycle)."""
    figures = record[TIMING]
    if sorted(record) != ["cycle", TIMING] or not isinstance(figures, dict) or not trace.cycles:
        raise TraceError(
            f"{where}: not a trace line (a `{TIMING}` record has only it and `cycle`, "
            "after the cycles)"
        )
    if sorted(figures) != list(FIGURES) or not all(map(_finite_number, figures.values())):
        raise TraceError(
            f"{where}: not a trace line (a `{TIMING}` record's figures are "
            f"{', '.join(FIGURES)}, each a finite number)"
        )
    return figures


def _finite_number(value: Any) -> bool:
    return type(value) in (int, float) and math.isfinite(value)


def _interruption(record: dict[str, Any], where: str) -> str:
    """The signal an `interrupted` line names (it holds only that and `cycle`)."""
    if sorted(record) != ["cycle", "interrupted"] or not isinstance(record["interrupted"], str):
        raise TraceError(
            f"{where}: not a trace line (an `interrupted` line has only it and `cycle`)"
        )
    return record["interrupted"]


class _Reader:
    """A trace's lines into its columns, checked against the first line's. A module's values
    and a world field's value are kept as runs (the checked values and the index of the
    cycle they start in) and written out as columns at the end: most modules repeat their
    last line's object in most cycles (98 % of them in a long run), and such a line passed
    the same checks then, so it costs nothing (no checks, no per-cycle copies); a change
    line says which world fields changed, so only those are looked at."""

    def __init__(self, trace: Trace) -> None:
        self.trace = trace
        self.texts: dict[str, str] = {}  # each text value once: a trace repeats a few names
        self.last: dict[str, dict[str, Any]] = {}  # module -> its object on the last line
        self.runs: dict[str, list[tuple[list[Any], int]]] = {}  # module -> (values, start)
        self.found: Any = object()  # the last line's `modules` object, checked (none yet)
        self.world: dict[str, Any] = {}  # field -> its value on the last line
        # field -> its values where they change, and the index of the cycle each starts in
        self.world_values: dict[str, list[Any]] = {}
        self.world_starts: dict[str, list[int]] = {}

    def append(self, record: dict[str, Any], where: str) -> None:
        """One cycle's full line."""
        found = record.get("modules")
        self._cycle(record, where)
        if found is not self.found:  # (else the last line's modules, checked then)
            self._modules(record, found, where)
        self._world(record.get("world") or {}, where, None, record["cycle"])

    def change(self, record: dict[str, Any], where: str) -> None:
        """One cycle's change line (traces.stored): the last line's values with its changes."""
        if not self.trace.cycles:
            raise TraceError(
                f"{where}: not a trace line (no `modules` object, nor a full line before it "
                "to change)"
            )
        self._cycle(record, where)
        changed, removed = record.get(CHANGED, {}), record.get(REMOVED, [])
        if type(changed) is not dict or type(removed) is not list:
            raise TraceError(
                f"{where}: not a trace line (`{CHANGED}` is not an object or `{REMOVED}` not "
                "a list)"
            )
        found, world = self.found, changed.get("world", {})
        if "modules" in changed:
            modules = changed["modules"]
            found = applied(found, modules) if type(modules) is dict else modules
        for path in removed:
            found = self._removed(found, path, where)
        if found is not self.found:  # (the modules changed: only those, unless any removed)
            named = changed["modules"] if type(changed.get("modules")) is dict else None
            self._modules(record, found, where, None if removed or named is None else named)
        if type(world) is not dict:
            raise TraceError(f"{where}: world fields differ from the first line's")
        self._world(world, where, world, record["cycle"])

    def _cycle(self, record: dict[str, Any], where: str) -> None:
        cycles = self.trace.cycles
        if cycles and record["cycle"] <= cycles[-1]:
            raise TraceError(f"{where}: cycle {record['cycle']} after cycle {cycles[-1]}")

    def _removed(self, found: Any, path: Any, where: str) -> Any:
        """The modules without the member at `path` (a removed world field is an error; what
        the reader does not read, e.g. `overrides`, is not looked at)."""
        if type(path) is not list or not path or not all(type(p) is str for p in path):
            raise TraceError(
                f"{where}: not a trace line (`{REMOVED}` holds {json.dumps(path)}, not a path)"
            )
        if path[0] == "world":
            raise TraceError(f"{where}: world fields differ from the first line's")
        if path[0] != "modules" or len(path) < 2:
            return found
        try:
            return without(found, path[1:])
        except KeyError:
            gone = ".".join(path)
            raise TraceError(
                f"{where}: not a trace line (`{REMOVED}` names {gone}, which is not there)"
            ) from None

    def _modules(
        self, record: dict[str, Any], found: Any, where: str, names: Iterable[str] | None = None
    ) -> None:
        """A line's modules: all of them (`names` None: a full line's), or the modules named
        (those a change line changes: the others are the last line's objects)."""
        trace = self.trace
        if names is not None and found.keys() == self.last.keys():
            modules: Iterable[str] = names
            if not all(isinstance(found[m], dict) for m in names):
                raise TraceError(f"{where}: not a trace line (no `modules` object)")
        else:
            if not isinstance(found, dict) or not all(isinstance(v, dict) for v in found.values()):
                raise TraceError(f"{where}: not a trace line (no `modules` object)")
            if not trace.cycles:  # the first line: which modules, optional and world fields
                self._first(record, found)
            elif found.keys() != self.last.keys():  # (the modules' names, each once: as sets)
                extra = sorted(set(found) ^ set(trace.modules))
                raise TraceError(
                    f"{where}: modules differ from the first line's ({', '.join(extra)})"
                )
            modules = trace.modules  # (after the first line has said which)
        last, runs, at = self.last, self.runs, len(trace.cycles)
        for module in modules:
            values = found[module]
            if values is last[module] or values == last[module]:
                continue
            checked = _checked(trace.columns[module], module, values, where, self.texts)
            runs[module].append((checked, at))
            last[module] = values
        self.found = found

    def _world(self, fields: Any, where: str, names: Iterable[str] | None, cycle: int) -> None:
        """The world fields of a line: all of them (`names` None: a full line's), or a change
        line's (`names`: its changed fields, `fields` itself)."""
        trace = self.trace
        # (keys compared as sets: the world's are the first line's, sorted, each once)
        if not isinstance(fields, dict) or (
            fields.keys() != self.world.keys()
            if names is None
            else not fields.keys() <= self.world.keys()
        ):
            raise TraceError(f"{where}: world fields differ from the first line's")
        texts, last, at = self.texts, self.world, len(trace.cycles)
        values, starts = self.world_values, self.world_starts
        if names is not None:  # a change line: each value it names is a change
            for name, value in fields.items():
                values[name].append(texts.setdefault(value, value) if type(value) is str else value)
                starts[name].append(at)
            last.update(fields)
            trace.cycles.append(cycle)
            return
        for name in last:
            value, before = fields[name], last[name]
            if value is before or (type(value) is type(before) and value == before):
                continue
            values[name].append(texts.setdefault(value, value) if type(value) is str else value)
            starts[name].append(at)
            last[name] = value
        trace.cycles.append(cycle)

    def _first(self, record: dict[str, Any], found: dict[str, Any]) -> None:
        trace = self.trace
        trace.modules = sorted(found)
        trace.columns = {
            m: {
                f: []
                for f in (*FIELDS, *(o for o in OPTIONAL if o in found[m]))
                + ((SPARSE,) if "reason" in found[m] else ())
            }
            for m in trace.modules
        }
        names = sorted(record.get("world") or {})
        trace.world = {name: [] for name in names}
        self.last = {m: {"": object()} for m in trace.modules}  # (equal to no object)
        self.runs = {m: [] for m in trace.modules}
        self.world = dict.fromkeys(names, _NOTHING)
        self.world_values = {name: [] for name in names}
        self.world_starts = {name: [] for name in names}

    def columns(self) -> None:
        """The runs written out as the trace's columns (one value per cycle), and where each
        module's runs start (`Trace.starts`)."""
        trace, total = self.trace, len(self.trace.cycles)
        for module, runs in self.runs.items():
            starts = trace.starts[module] = [at for _, at in runs]
            lengths = _lengths(starts, total)
            for index, series in enumerate(trace.columns[module].values()):
                series[:] = _spread([values[index] for values, _ in runs], lengths)
        for name, values in self.world_values.items():  # (a field moving every cycle: as is)
            trace.world[name] = (
                values
                if len(values) == total
                else _spread(values, _lengths(self.world_starts[name], total))
            )


def _lengths(starts: list[int], total: int) -> list[int]:
    """How many cycles each run lasts, from where each starts (of `total` cycles)."""
    return [end - at for at, end in zip(starts, [*starts[1:], total], strict=True)]


def _spread(values: list[Any], lengths: list[int]) -> list[Any]:
    """Each value repeated for its run's length: a column, one value per cycle."""
    if len(values) == sum(lengths):  # (a value every cycle: a world field always moving)
        return values
    return list(chain.from_iterable(map(repeat, values, lengths)))


_NOTHING = object()  # a world field's value before the first line (equal to no value)


def _checked(
    columns: dict[str, list[Any]],
    module: str,
    values: dict[str, Any],
    where: str,
    texts: dict[str, str],
) -> list[Any]:
    """A module's values on one line, checked, in the order of its columns."""
    missing = [f for f in columns if f not in values and f != SPARSE]
    if missing:
        raise TraceError(f"{where}: module {module} has no `{missing[0]}`")
    extra = [f for f in OPTIONAL if f in values and f not in columns]
    if extra:
        raise TraceError(
            f"{where}: module {module} has a `{extra[0]}` the first line does not have"
        )
    if "result" in values and not isinstance(values["result"], dict):
        raise TraceError(f"{where}: module {module}'s `result` is not an object")
    if SPARSE in values and SPARSE not in columns:
        raise TraceError(f"{where}: module {module} has a `{SPARSE}` but declares no reasons")
    out = []
    for name in columns:
        value = values.get(name, "")
        out.append(texts.setdefault(value, value) if type(value) is str else value)
    return out


def status_text(column: dict[str, list[Any]], i: int) -> str:
    """A module's status at cycle index `i` as a person reads it: `ERROR(REFUSED)` when it
    is in ERROR for a reason, the bare status otherwise."""
    reason = column["reason"][i] if "reason" in column else None
    cause = column[SPARSE][i] if SPARSE in column else ""
    return contract.status_text(str(column["status"][i]), reason, str(cause))


# ---------------------------------------------------------------- a trace beside its specs


@dataclass(frozen=True)
class Lane:
    """A module as the viewers show it: in execution order, with its level and title."""

    module: str
    title: str = ""
    level: int = 0  # 0: a simulator, or no specs at hand
    simulator: bool = False
    runs_as: str = ""  # the controller whose table it runs: itself, or its stand-in


def module_of(row: str) -> str:
    """The module a trace's row belongs to: itself, or the operator module of a channel
    (`op/fx` -> `op`)."""
    return row.split("/", 1)[0]


def process_of(system: IRSystem, trace: Trace) -> IRProcess | None:
    """What ran the trace: the one process whose modules it holds, else the whole system
    (every process's modules, process by process: a scenario runs them all)."""
    held = {module_of(m) for m in trace.modules}
    for process in system.processes:
        if held <= set(process.modules):
            return process
    whole = whole_system(system)
    return whole if held <= set(whole.modules) else None


def whole_system(system: IRSystem) -> IRProcess:
    """Every process of `system` as one: modules in the order a whole-system run takes."""
    first = system.processes[0]
    return IRProcess(
        name=system.name,
        cycle_period=first.cycle_period,
        doc=f"every process of {system.name}",
        modules=tuple(m for p in system.processes for m in p.modules),
        roots=tuple(m for p in system.processes for m in p.roots),
        stand_ins={k: v for p in system.processes for k, v in p.stand_ins.items()},
    )


def runs_as(process: IRProcess, trace: Trace) -> dict[str, str]:
    """Which controller's table each module of the trace ran: a controller whose subtree is
    missing from the trace ran as its stand-in (`simulate:` in the scenario)."""
    out = {m: module_of(m) for m in trace.modules}
    for replaced, (stand_in, subtree) in process.stand_ins.items():
        others = [m for m in subtree if m != replaced]
        if replaced in out and others and not any(m in out for m in others):
            out[replaced] = stand_in
    return out


def check_against(system: IRSystem, trace: Trace) -> IRProcess:
    """The trace's process; TraceError when a module or a rule is not in the specs."""
    names = {c.name for c in system.controllers}
    unknown = [m for m in trace.modules if module_of(m) not in names]
    if unknown:
        raise TraceError(
            f"{trace.name}: module `{unknown[0]}` is not in system {system.name}: "
            "was the trace recorded from other specs?"
        )
    process = process_of(system, trace)
    if process is None:
        raise TraceError(f"{trace.name}: no process of system {system.name} runs its modules")
    for module, controller in runs_as(process, trace).items():
        known = {str(rule.id) for rule in system.controller(controller).table_rules()}
        rules, starts = trace.columns[module]["rule"], trace.starts.get(module)
        fired = {rules[i] for i in starts} if starts else set(rules)  # (a run's rule is one)
        fired.discard(None)
        stale = sorted(fired - known)
        if stale:
            raise TraceError(
                f"{trace.name}: {module} fired rule `{stale[0]}`, which {controller}'s tables "
                f"do not have: the specs changed since the trace was recorded; run the "
                "scenario again"
            )
    return process


def recorded_by(systems: list[IRSystem], found: list[Trace]) -> tuple[IRSystem | None, str]:
    """The first of `systems` that every trace of `found` fits (`check_against`), or None and
    why not: the one system's reason, or '' when several systems each refused."""
    problems = []
    for system in systems:
        try:
            for one in found:
                check_against(system, one)
            return system, ""
        except TraceError as error:
            problems.append(str(error))
    return None, problems[0] if len(problems) == 1 else ""


def lanes(trace: Trace, system: IRSystem | None) -> list[Lane]:
    """The trace's modules in execution order with titles and levels, when `system` ran it;
    alphabetical and bare otherwise."""
    if system is None:
        return [Lane(m) for m in trace.modules]
    from ..graph import levels  # here: reading a trace needs none of the graph's imports

    process = check_against(system, trace)
    level = levels(system)
    ran = runs_as(process, trace)
    out = []
    for name in process.modules:
        for module in [row for row in ran if module_of(row) == name]:  # an operator's channels
            controller = system.controller(ran[module])
            out.append(
                Lane(
                    module,
                    controller.title,
                    0 if controller.simulator and module == ran[module] else level[name],
                    controller.simulator,
                    ran[module],
                )
            )
    return out


def select(trace: Trace, wanted: list[str]) -> list[str]:
    """The modules named (comma-separated lists allowed), checked; all when none."""
    names = [n.strip() for item in wanted for n in item.split(",") if n.strip()]
    for name in names:
        if name not in trace.modules:
            import difflib

            close = difflib.get_close_matches(name, trace.modules, n=1)
            hint = f"; did you mean `{close[0]}`?" if close else ""
            raise TraceError(f"unknown module `{name}`: {trace.name} has no such module{hint}")
    return names or list(trace.modules)
