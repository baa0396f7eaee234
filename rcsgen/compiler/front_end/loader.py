"""Load: YAML text -> plain data whose containers remember the span of every key and value.

Why not `yaml.safe_load`: PyYAML silently keeps the last of two duplicate keys,
and its YAML 1.1 resolver turns `on`/`off`/`yes`/`no` into booleans, so a state
named `on` would become `True`. This stage reads PyYAML's event stream instead:
no constructor ever runs (so no tag can build a Python object), plain scalars
are typed by the strict YAML 1.2 core schema, and tags, anchors, aliases, merge
keys, duplicate or non-string keys, NaN/Inf, extra documents, oversized files and
excessive nesting are all reported as located diagnostics in one pass.
"""

from __future__ import annotations

import errno
import math
import os
import pathlib
import re
import stat
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol, cast

import yaml

from ..diagnostics import Diagnostics, Span, SpecError

MAX_BYTES = 1_000_000
MAX_DEPTH = 64

_DECIMAL = re.compile(r"[-+]?[0-9]+")
_HEX_OR_OCTAL = re.compile(r"0x[0-9a-fA-F]+|0o[0-7]+")
_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
_NON_FINITE = re.compile(r"[-+]?\.inf|\.nan", re.IGNORECASE)
_NO_SHARING = "anchors, aliases and merge keys are not allowed"
_NO_SHARING_HINT = "write the value out in full; a spec never shares nodes"
_TOO_LARGE = f"file is larger than {MAX_BYTES:,} bytes"
_TOO_LARGE_HINT = "a spec is far smaller than this; is this the right file?"


class _Mark(Protocol):
    """Where an event starts: the pure-Python and the libyaml parsers' marks both have these."""

    line: int
    column: int


class LocStr(str):
    """A string scalar (value or key) that remembers where it starts; a quoted, block or
    multi-line one also where it is written (`written`), so a character of its text can be
    found in the file (`char_span`)."""

    span: Span
    written: Written | None = None

    def __new__(cls, value: str, span: Span) -> LocStr:
        self = str.__new__(cls, value)
        self.span = span
        return self

    # Keeps copy/pickle working; str's own takes no span, so the signature differs on purpose.
    def __getnewargs__(self) -> tuple[str, Span]:  # type: ignore[override]
        return (str(self), self.span)


class LocDict(dict[str, Any]):
    """A mapping with str keys, its start span and the span of each key and value.

    Values are `Any`: loaded data is untyped until the schema and the model have checked it.
    """

    span: Span
    key_spans: dict[str, Span]
    value_spans: dict[str, Span]

    def __init__(self, span: Span) -> None:
        super().__init__()
        self.span = span
        self.key_spans = {}
        self.value_spans = {}


class LocList(list[Any]):
    """A sequence with its start span and the span of each item."""

    span: Span
    item_spans: list[Span]

    def __init__(self, span: Span) -> None:
        super().__init__()
        self.span = span
        self.item_spans = []


class Written(NamedTuple):
    """Where a scalar's text is written: the file's text (shared, not copied), where the
    scalar starts and ends in it, and its style (`'`, `"`, `|`, `>`; '' plain)."""

    source: str
    start: int
    end: int
    style: str


def _remember(value: LocStr, source: str, event: yaml.ScalarEvent) -> None:
    """Record where a string scalar whose text is not its first line as written is written
    (quoted, a block, or plain over several lines); a plain one-line scalar's text is."""
    start, end = event.start_mark, event.end_mark
    if start is not None and end is not None and (event.style or start.line != end.line):
        value.written = Written(source, start.index, end.index, event.style or "")


def char_span(node: object, text: str, index: int) -> Span | None:
    """Where character `index` of `text` is written in the file, `text` being `node`'s
    value with its whitespace changed (an expression's runs of spaces and line breaks read
    as one space); past its end: just after its last character. None when `node` is not a
    scalar `written` recorded, or its characters are not found in order.

    Each character but whitespace is looked for in the file after the one before it, so
    what quoting adds (the quotes, a block's indicator line and indentation, escapes,
    folded line breaks) is stepped over."""
    span, where = getattr(node, "span", None), getattr(node, "written", None)
    if not isinstance(span, Span) or not isinstance(where, Written):
        return None
    source, at, stop = where.source, where.start, where.end
    if where.style in ("'", '"'):
        at, stop = at + 1, stop - 1
    elif where.style in ("|", ">"):  # the text starts on the line after the indicator's
        at = source.find("\n", at, stop) + 1
        if at == 0:
            return None
    found = at
    for char in text[: index + 1]:
        if char.isspace():
            continue
        found = source.find(char, at, stop)
        if found < 0:
            return None
        at = found + 1
    if index >= len(text) or text[index].isspace():
        found = at
    line = source.count("\n", 0, found) + 1
    return Span(span.file, line, found - source.rfind("\n", 0, found))


def span_of(node: object, fallback: Span) -> Span:
    """Where the loader found `node` (a string, mapping or list it made), else `fallback`."""
    span = getattr(node, "span", None)
    return span if isinstance(span, Span) else fallback


def value_span(container: object, key: str | int, fallback: Span) -> Span:
    """Where the value at `key` (or the item at an index) of a loaded container starts."""
    spans = getattr(container, "item_spans" if isinstance(key, int) else "value_spans", None)
    try:
        return spans[key] if spans is not None else fallback
    except (KeyError, IndexError, TypeError):
        return fallback


def key_span(container: object, key: str, fallback: Span) -> Span:
    """Where `key` is written in a loaded mapping."""
    spans = getattr(container, "key_spans", None)
    return spans.get(key, fallback) if isinstance(spans, dict) else fallback


# A plain scalar that is a name (a letter or `_`, then letters, digits, `_` and `.`) and none
# of the core schema's words is a string: no pattern of _plain_value can match it.
_WORD = re.compile(
    r"(?!(?:true|True|TRUE|false|False|FALSE|null|Null|NULL)\Z)[A-Za-z_][A-Za-z0-9_.]*"
).fullmatch


def _plain_value(text: str) -> object:
    """Type a plain scalar by the YAML 1.2 core schema; NaN/Inf come back non-finite."""
    if text in ("true", "True", "TRUE"):
        return True
    if text in ("false", "False", "FALSE"):
        return False
    if text in ("", "~", "null", "Null", "NULL"):
        return None
    try:
        if _DECIMAL.fullmatch(text):
            return int(text)  # "010" is 10: YAML 1.2 has no leading-zero octal
        if _HEX_OR_OCTAL.fullmatch(text):
            return int(text, 0)
    except ValueError:  # beyond Python's int digit limit: treat as overflow
        return math.inf
    if _FLOAT.fullmatch(text):
        return float(text)  # may overflow to inf, which is then rejected
    if _NON_FINITE.fullmatch(text):
        return math.nan
    return text


@dataclass
class _Frame:
    """A mapping or sequence being built; mappings alternate key and value nodes."""

    container: LocDict | LocList
    reported: bool  # the node itself already has an E005 (tag or anchor)
    key: LocStr | None = None  # None: the pending key was rejected, drop its value
    has_key: bool = False

    def at_key(self) -> bool:
        return isinstance(self.container, LocDict) and not self.has_key


_STARTS = (yaml.MappingStartEvent, yaml.SequenceStartEvent)
_ENDS = (yaml.MappingEndEvent, yaml.SequenceEndEvent)


class _Builder:
    """Builds located values from parser events, collecting diagnostics."""

    def __init__(self, path: str, diags: Diagnostics, text: str) -> None:
        self.path = path
        self.diags = diags
        self.text = text  # the file's text, where a quoted or block scalar is found again
        self.stack: list[_Frame] = []
        self.result: object = None
        self.documents = 0
        self.stopped = False  # set when the rest of the stream must not be read

    def span(self, mark: _Mark | None) -> Span:
        if mark is None:  # every event a parser emits has a mark
            return Span(self.path)
        return Span(self.path, mark.line + 1, mark.column + 1)

    def feed(self, event: yaml.Event) -> None:
        mark = event.start_mark
        span = Span(self.path, mark.line + 1, mark.column + 1) if mark else Span(self.path)
        kind = type(event)
        if type(event) is yaml.ScalarEvent:  # most events: first, and checked inline
            tagged = event.tag is not None or event.anchor is not None
            self.scalar(event, span, tagged and self.check_node(event, span))
        elif kind in _STARTS:  # then the containers, by exact class (isinstance costs more)
            self.start(cast(yaml.CollectionStartEvent, event), span, kind is _STARTS[0])
        elif kind in _ENDS:
            frame = self.stack.pop()
            self.attach(frame.container, frame.container.span, frame.reported)
        elif isinstance(event, yaml.DocumentStartEvent):
            self.documents += 1
            if self.documents > 1:
                hint = "a spec is a single document; remove this `---` and what follows"
                self.diags.error(span, "E009", "more than one YAML document in a file", hint)
                self.stopped = True
        elif isinstance(event, yaml.AliasEvent):
            self.diags.error(span, "E005", _NO_SHARING, _NO_SHARING_HINT)
            self.attach(None, span, reported=True)
        elif isinstance(event, yaml.ScalarEvent):
            self.scalar(event, span, self.check_node(event, span))
        elif isinstance(event, yaml.CollectionStartEvent):
            self.start(event, span, isinstance(event, yaml.MappingStartEvent))
        elif isinstance(event, yaml.CollectionEndEvent):
            frame = self.stack.pop()
            self.attach(frame.container, frame.container.span, frame.reported)

    def start(self, event: yaml.CollectionStartEvent, span: Span, mapping: bool) -> None:
        """A mapping or sequence begins: a frame to fill (E007 past MAX_DEPTH)."""
        if len(self.stack) >= MAX_DEPTH:
            hint = f"at most {MAX_DEPTH} nested mappings and sequences are allowed"
            self.diags.error(span, "E007", "nesting is too deep", hint)
            self.stopped = True
            return
        container = LocDict(span) if mapping else LocList(span)
        tagged = event.tag is not None or event.anchor is not None
        self.stack.append(_Frame(container, tagged and self.check_node(event, span)))

    def check_node(self, event: yaml.ScalarEvent | yaml.CollectionStartEvent, span: Span) -> bool:
        """Report a tag or an anchor on a node; True when something was reported."""
        if event.tag is not None:
            tag = event.tag.replace("tag:yaml.org,2002:", "!!", 1)
            hint = f"remove `{tag}`; a spec is plain data and no tag is ever constructed"
            self.diags.error(span, "E005", "tags are not allowed", hint)
        if event.anchor is not None:
            self.diags.error(span, "E005", _NO_SHARING, _NO_SHARING_HINT)
        return event.tag is not None or event.anchor is not None

    def scalar(self, event: yaml.ScalarEvent, span: Span, reported: bool) -> None:
        text = event.value
        plain = not event.style  # any quoted or block scalar is a string (libyaml says "")
        value = _plain_value(text) if plain and not _WORD(text) else text
        at_key = not reported and bool(self.stack) and self.stack[-1].at_key()
        if at_key and plain and text == "<<":
            self.diags.error(span, "E005", _NO_SHARING, _NO_SHARING_HINT)
            reported = True
        elif at_key and not isinstance(value, str):
            hint = f'quote the key if it is meant as a name: "{text}"'
            self.diags.error(span, "E003", f"mapping key `{text}` is not a string", hint)
            reported = True
        elif isinstance(value, float) and not math.isfinite(value):
            shown = text if len(text) <= 40 else text[:37] + "..."
            hint = f"numbers must be finite; `{shown}` is not (quote it to mean a string)"
            self.diags.error(span, "E004", "NaN and infinity are not allowed", hint)
        if isinstance(value, str):
            value = LocStr(value, span)
            _remember(value, self.text, event)
        self.attach(value, span, reported)

    def attach(self, value: object, span: Span, reported: bool) -> None:
        """Put a finished node into its parent, or make it the document's value."""
        if not self.stack:
            self.result = value
            return
        frame = self.stack[-1]
        parent = frame.container
        if isinstance(parent, LocList):
            parent.append(value)
            parent.item_spans.append(span)
        elif frame.has_key:
            frame.has_key = False
            if frame.key is not None:
                parent[frame.key] = value
                parent.key_spans[frame.key] = frame.key.span
                parent.value_spans[frame.key] = span
        else:
            frame.has_key = True
            frame.key = None
            if reported:
                return
            if not isinstance(value, LocStr):
                kind = "mapping" if isinstance(value, dict) else "sequence"
                hint = "use a plain or quoted string as the key"
                self.diags.error(span, "E003", f"mapping key is a {kind}, not a string", hint)
            elif value in parent.key_spans:
                first = parent.key_spans[value].line
                hint = f"first defined at line {first}; PyYAML would silently keep the last one"
                self.diags.error(span, "E002", f"duplicate key `{value}`", hint)
            else:
                frame.key = value


def _line_col(data: str | bytes, index: int) -> tuple[int, int]:
    """1-based line and column of `index` (in characters for str, bytes for bytes)."""
    if isinstance(data, str):
        return data.count("\n", 0, index) + 1, index - data.rfind("\n", 0, index)
    return data.count(b"\n", 0, index) + 1, index - data.rfind(b"\n", 0, index)


def _syntax_error(exc: yaml.YAMLError, text: str, path: str) -> tuple[Span, str, str]:
    """Span, message and hint for a PyYAML error, without its traceback text."""
    if isinstance(exc, yaml.reader.ReaderError):
        message = f"unacceptable character #x{exc.character:04x}: {exc.reason}"
        return Span(path, *_line_col(text, exc.position)), message, "remove it"
    if isinstance(exc, yaml.MarkedYAMLError):
        long_key = _long_key(exc, text, path)
        if long_key is not None:
            return long_key
        mark = exc.problem_mark or exc.context_mark
        span = Span(path, mark.line + 1, mark.column + 1) if mark else Span(path)
        hint = "check the indentation (spaces, not tabs), quotes and brackets here"
        if exc.context and exc.context_mark:
            hint = f"{exc.context} that starts at line {exc.context_mark.line + 1}"
        return span, exc.problem or exc.context or "invalid YAML", hint
    return Span(path), str(exc), ""


MAX_PLAIN_KEY = 1024  # characters: YAML's limit for a key written without `? `


def _long_key(exc: yaml.MarkedYAMLError, text: str, path: str) -> tuple[Span, str, str] | None:
    """The clear message of PyYAML's `could not find expected ':'` for a key longer than
    YAML allows a plain key (its scanner gives up on it), else None."""
    mark = exc.context_mark
    if exc.context != "while scanning a simple key" or mark is None:
        return None
    line = text.splitlines()[mark.line] if mark.line < len(text.splitlines()) else ""
    key = line[mark.column :].split(":", 1)[0]
    if len(key) <= MAX_PLAIN_KEY:
        return None
    message = f"a key of {len(key):,} characters: YAML allows a key of at most {MAX_PLAIN_KEY:,}"
    hint = "keys are names: shorten it (a long text belongs in a value, such as `doc:`)"
    return Span(path, mark.line + 1, mark.column + 1), message, hint


def _fail(span: Span, code: str, message: str, hint: str) -> SpecError:
    """A SpecError for a problem that stops loading before any YAML is parsed."""
    diags = Diagnostics()
    diags.error(span, code, message, hint)
    return SpecError(diags)


def load_text(text: str, display_path: str) -> object:
    """Load one YAML document into located values; raise SpecError with every problem."""
    fast = _FAST_PARSER  # libyaml for speed; its events carry the same marks
    try:
        size = len(text.encode("utf-8"))
    except UnicodeEncodeError:  # a lone surrogate (in a str not read from a file: `decode`
        # is strict): libyaml cannot take it, the pure parser says where it is (E001)
        size, fast = len(text.encode("utf-8", "surrogatepass")), None
    if size > MAX_BYTES:
        raise _fail(Span(display_path), "E006", _TOO_LARGE, _TOO_LARGE_HINT)
    text = text.removeprefix("\ufeff")
    if fast is not None:
        try:
            loaded = _plain(text, display_path, fast)
        except yaml.YAMLError:  # a syntax error: `_build` says where
            loaded = _UNUSUAL
        if loaded is not _UNUSUAL:
            return loaded
        diags, result = _build(text, display_path, fast)
        if not diags.errors:
            return result
    # The pure-Python parser's problem messages are the ones diagnostics are written for.
    diags, result = _build(text, display_path, yaml.SafeLoader)
    if diags.errors:
        raise SpecError(diags)
    return result


# A large system has thousands of spec files: the C parser loads them several times faster.
_FAST_PARSER = getattr(yaml, "CSafeLoader", None)


_UNUSUAL = object()  # what `_plain` gives back for a document `_Builder` must read
_new_tuple = tuple.__new__
_new_str = str.__new__


def _plain(text: str, path: str, loader: type) -> object:
    """The document as `_Builder` loads it, when it is plain data (no tag, anchor, alias,
    merge key, duplicate or non-string key, NaN or infinity, second document, nesting past
    MAX_DEPTH): `_UNUSUAL` at the first thing `_Builder` would report, to be read by it
    (a syntax error raises the parser's YAMLError).
    The same values and spans as `_Builder`'s, in a third of the time: one loop over the
    C parser's events, each frame a list, each span made as the tuple it is."""
    # a frame: [container, its item spans (a sequence's) or None, the pending key or None]
    stack: list[list[Any]] = []
    result: object = None
    documents = 0
    event: Any  # each kind of event has its own attributes
    for event in yaml.parse(text, Loader=loader):
        kind = type(event)
        if kind is _SCALAR:
            mark = event.start_mark
            if event.tag is not None or event.anchor is not None or mark is None:
                return _UNUSUAL
            span = _new_tuple(Span, (path, mark.line + 1, mark.column + 1))
            value = event.value
            if event.style or not _WORD(value):  # not a name: typed, a string located
                value = _scalar(event, span, text)
                if value is _UNUSUAL:
                    return _UNUSUAL
            else:  # a name (most keys and values): a string
                value = _new_str(LocStr, value)
                value.span = span
        elif kind is _MAPPING or kind is _SEQUENCE:
            mark = event.start_mark
            if event.tag is not None or event.anchor is not None or mark is None:
                return _UNUSUAL
            if len(stack) >= MAX_DEPTH:
                return _UNUSUAL
            span = _new_tuple(Span, (path, mark.line + 1, mark.column + 1))
            if kind is _MAPPING:
                stack.append([LocDict(span), None, None])
            else:
                container = LocList(span)
                stack.append([container, container.item_spans, None])
            continue
        elif kind is _MAPPING_END or kind is _SEQUENCE_END:
            value = stack.pop()[0]
            span = value.span
        elif kind is yaml.DocumentStartEvent:
            documents += 1
            if documents > 1:
                return _UNUSUAL
            continue
        elif kind is yaml.AliasEvent:
            return _UNUSUAL
        else:  # the stream's and the document's other events
            continue
        if not stack:
            result = value
            continue
        frame = stack[-1]
        if frame[1] is not None:  # a sequence's item
            frame[0].append(value)
            frame[1].append(span)
        elif frame[2] is not None:  # a mapping's value
            key, frame[2] = frame[2], None
            container = frame[0]
            container[key] = value
            container.key_spans[key] = key.span
            container.value_spans[key] = span
        elif type(value) is not LocStr or value in frame[0].key_spans:
            return _UNUSUAL  # a key that is not a string, or a duplicate
        elif value == "<<" and not event.style:
            return _UNUSUAL  # a merge key
        else:
            frame[2] = value
    return result


def _scalar(event: Any, span: Span, text: str) -> object:
    """A scalar that is not a plain name, as `_Builder` loads it: a plain one typed by the
    core schema (`_UNUSUAL` for NaN or infinity), a string with where it is written when
    its text is not its first line as written (`_remember`)."""
    value = event.value
    if not event.style:
        value = _plain_value(value)
        if isinstance(value, float) and not math.isfinite(value):
            return _UNUSUAL
    if isinstance(value, str):
        value = _new_str(LocStr, value)
        value.span = span
        _remember(value, text, event)
    return value


_SCALAR, _MAPPING, _SEQUENCE = yaml.ScalarEvent, yaml.MappingStartEvent, yaml.SequenceStartEvent
_MAPPING_END, _SEQUENCE_END = yaml.MappingEndEvent, yaml.SequenceEndEvent


def _build(text: str, display_path: str, loader: type) -> tuple[Diagnostics, object]:
    """Feed one parser's events to a builder: the diagnostics and the loaded value."""
    diags = Diagnostics()
    builder = _Builder(display_path, diags, text)
    try:
        for event in yaml.parse(text, Loader=loader):
            builder.feed(event)
            if builder.stopped:
                break
    except yaml.YAMLError as exc:
        span, message, hint = _syntax_error(exc, text, display_path)
        diags.error(span, "E001", message, hint)
    return diags, builder.result


# ---------------------------------------------------------------- reading files safely

_KINDS = {
    stat.S_IFDIR: "a directory",
    stat.S_IFIFO: "a named pipe (FIFO)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


@dataclass(frozen=True)
class PathProblem:
    """Why a path cannot be read as a file: a code, a message and a hint."""

    code: str
    message: str
    hint: str = ""

    def error(self, span: Span) -> SpecError:
        return _fail(span, self.code, self.message, self.hint)


def _os_problem(exc: OSError, what: str) -> PathProblem:
    """E010 (or E012 for a symlink loop) for an OSError met reading `what`."""
    if exc.errno == errno.ELOOP:
        return PathProblem("E012", "symbolic link loop (too many levels of links)", _LINK_HINT)
    reason = {
        errno.ENOENT: "no such file or directory",
        errno.EACCES: "permission denied",
        errno.EPERM: "permission denied",
        errno.ENAMETOOLONG: "file name too long",
        errno.ENOTDIR: "a parent of this path is not a directory",
    }.get(exc.errno or 0, (exc.strerror or str(exc)).lower())
    hint = "check the path and its permissions"
    if exc.errno == errno.ENAMETOOLONG:
        hint = "shorten the path: a name is limited to 255 bytes on most file systems"
    return PathProblem("E010", f"cannot read {what}: {reason}", hint)


_LINK_HINT = "fix or remove the symbolic link"
_REGULAR_HINT = "rcsgen reads only regular files"
# (no O_CLOEXEC: os.open makes every descriptor non-inheritable itself, PEP 446)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)


def path_problem(path: pathlib.Path, want: str = "file") -> PathProblem | None:
    """None when `path` is a `want` ("file": a regular file, "dir": a directory, "any": either)
    that exists, else why not: missing, a dangling symlink or a symlink loop, a special file
    (a FIFO would hang a reader, a device would be read until memory runs out)."""
    what = "directory" if want == "dir" else "file"
    name = f"`{path.name or path}`"
    try:
        link = stat.S_ISLNK(os.lstat(path).st_mode)
    except OSError as exc:
        return _os_problem(exc, what)
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if link and exc.errno == errno.ENOENT:
            try:
                target = os.readlink(path)
            except OSError:
                target = "?"
            message = f"{name} is a dangling symbolic link to `{target}`"
            return PathProblem("E012", message, _LINK_HINT)
        return _os_problem(exc, what)
    if stat.S_ISREG(mode):
        if want == "dir":
            return PathProblem("E011", f"{name} is a file, not a directory", "give a directory")
        return None
    if stat.S_ISDIR(mode):
        if want == "file":
            return PathProblem("E011", f"{name} is a directory, not a file", "give a file here")
        return None
    kind = _KINDS.get(stat.S_IFMT(mode), "a special file")
    return PathProblem("E011", f"{name} is {kind}, not a regular file", _REGULAR_HINT)


def read_bytes(path: pathlib.Path, display_path: str, limit: int = MAX_BYTES) -> bytes:
    """The bytes of a regular file, at most `limit`; raises SpecError (E006, E010-E012) for
    anything else. Never blocks on a FIFO nor reads a device."""
    span = Span(display_path)
    problem = path_problem(path)
    if problem is not None:
        raise problem.error(span)
    try:
        # O_NONBLOCK: should the path become a FIFO after the check, opening it cannot hang.
        fd = os.open(path, os.O_RDONLY | _NONBLOCK)
    except OSError as exc:
        raise _os_problem(exc, "file").error(span) from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            message = f"`{path.name}` is not a regular file"
            raise PathProblem("E011", message, _REGULAR_HINT).error(span)
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise _os_problem(exc, "file").error(span) from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) > limit:
        raise _fail(span, "E006", f"file is larger than {limit:,} bytes", _TOO_LARGE_HINT)
    return data


def decode(data: bytes, display_path: str) -> str:
    """UTF-8 text of a file's bytes; E008 located at the first bad byte otherwise (or at the
    start of a file that is UTF-16 without a byte-order mark: as UTF-8 it reads as text
    with a NUL between its characters)."""
    utf16 = utf16_without_bom(data)
    if utf16:
        message = f"file is not UTF-8: it is UTF-16 ({utf16}) without a byte-order mark"
        raise _fail(Span(display_path), "E008", message, "save the file as UTF-8") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        span = Span(display_path, *_line_col(data, exc.start))
        message = f"file is not valid UTF-8: byte 0x{data[exc.start]:02x} ({exc.reason})"
        hint = "save the file as UTF-8"
        if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
            hint = "the file is UTF-16 (it starts with a UTF-16 byte-order mark); save it as UTF-8"
        raise _fail(span, "E008", message, hint) from None


def utf16_without_bom(data: bytes) -> str:
    """`little-endian` or `big-endian` when the bytes are text in UTF-16 without a
    byte-order mark (its first characters ASCII, so every other byte NUL), else ''."""
    head = data[:64]
    if len(head) < 4 or head[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return ""
    even, odd = head[0::2], head[1::2]
    if not odd.strip(b"\0") and even.strip(b"\0"):
        return "little-endian"
    if not even.strip(b"\0") and odd.strip(b"\0"):
        return "big-endian"
    return ""


def load_file(path: pathlib.Path, display_path: str) -> object:
    """Read and load a spec file; unreadable, special, oversized or non-UTF-8 files are errors.

    An empty file (or one with only comments) loads as None, as does `~`."""
    return load_text(decode(read_bytes(path, display_path), display_path), display_path)
