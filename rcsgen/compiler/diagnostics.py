"""Diagnostics: a problem and its span -> a located message; shared by every stage.

Every stage reports problems as `Diagnostic` values collected in a `Diagnostics`
bag instead of raising on the first one, so a user sees all of them at once.
A stage that cannot go on raises `SpecError` carrying the bag.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, replace
from typing import NamedTuple

# counts said with their noun's number: one home, in the contract the runtime shares
from ..runtime.contract import counted as counted
from ..runtime.contract import listed as listed
from .codes import Severity, severity_of


class Span(NamedTuple):
    """A position in a spec file: display path, 1-based line and column. A named tuple, not
    a frozen dataclass: the loader makes one for every YAML node (a quarter of a million for
    a 1,000-controller system), and a tuple is made in half the time; it orders, compares
    and hashes as the dataclass did (by file, line, column)."""

    file: str
    line: int = 1
    col: int = 1

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"


@dataclass(frozen=True, order=True)
class Subject:
    """What a finding is about, to match acknowledgements (`allow:`) against: a controller and,
    as far as they apply, a command (None: the controller's every_cycle rules), a state and a
    rule (1-based, as in `RuleId`)."""

    controller: str
    command: str | None = None
    state: str | None = None
    rule: int | None = None


@dataclass(frozen=True)
class Diagnostic:
    """One located problem: `file:line:col: severity[CODE]: message`, then a hint. Its
    severity is its code's in the registry (`codes.CODES`): an unregistered code is an
    internal error, raised where the diagnostic is made."""

    span: Span
    code: str
    message: str
    hint: str = ""
    # What a warning is about (None: not acknowledgeable), and the reason it was acknowledged.
    subject: Subject | None = field(default=None, compare=False, repr=False)
    acknowledged: str = ""

    def __post_init__(self) -> None:
        severity_of(self.code)

    @property
    def severity(self) -> Severity:
        return severity_of(self.code)

    def sort_key(self) -> tuple[Span, str, str, str]:
        # The hint too: one finding in a template's text, once per instance, differs only in
        # the instance its hint names; without it their order was the set's (hash seeded).
        return (self.span, self.code, self.message, self.hint)

    def as_dict(self) -> dict[str, object]:
        """The JSON form (`--format json`): file, line, col, severity, code, message, hint
        (and `acknowledged`, the reason, for an acknowledged warning)."""
        found: dict[str, object] = {
            "file": self.span.file,
            "line": self.span.line,
            "col": self.span.col,
            "severity": self.severity,
            "code": self.code,
            "message": self.message,
            "hint": self.hint,
        }
        if self.acknowledged:
            found["acknowledged"] = self.acknowledged
        return found

    def render(self, source_line: str | None = None) -> str:
        severity = "acknowledged" if self.acknowledged else self.severity
        text = f"{self.span}: {severity}[{self.code}]: {self.message}"
        if source_line is not None:
            caret = " " * (max(self.span.col, 1) - 1) + "^"
            text += f"\n  | {source_line.rstrip()}\n  | {caret}"
        if self.acknowledged:
            text += f"\n  = reason: {self.acknowledged}"
        elif self.hint:
            text += f"\n  = hint: {self.hint}"
        return text


@dataclass
class Diagnostics:
    """An ordered bag of diagnostics; `errors` tells whether a stage failed.

    Warnings a spec acknowledges (`allow:`, `first_match`) are kept apart in `acknowledged`:
    they are not reported, fail nothing, and are shown only on request."""

    items: list[Diagnostic] = field(default_factory=list)
    acknowledged: list[Diagnostic] = field(default_factory=list)

    def error(self, span: Span, code: str, message: str, hint: str = "") -> None:
        """Report an error; `code` must be an error's in the registry."""
        self._add(Diagnostic(span, code, message, hint), Severity.ERROR)

    def warning(
        self, span: Span, code: str, message: str, hint: str = "", subject: Subject | None = None
    ) -> None:
        """Report a warning (what it is about, if a spec can acknowledge it); `code` must be
        a warning's in the registry."""
        self._add(Diagnostic(span, code, message, hint, subject), Severity.WARNING)

    def _add(self, diagnostic: Diagnostic, severity: Severity) -> None:
        if diagnostic.severity is not severity:
            raise ValueError(
                f"internal error: {diagnostic.code} is a registered {diagnostic.severity}, "
                f"reported as a {severity}"
            )
        self.items.append(diagnostic)

    def acknowledge(self, diagnostic: Diagnostic, reason: str) -> None:
        """Keep a warning as acknowledged, with the spec's reason."""
        self.acknowledged.append(replace(diagnostic, acknowledged=reason))

    def extend(self, other: Iterable[Diagnostic]) -> None:
        self.items.extend(other)

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity is Severity.ERROR]

    def __iter__(self) -> Iterator[Diagnostic]:
        return iter(sorted(set(self.items), key=Diagnostic.sort_key))

    def __len__(self) -> int:
        return len(self.items)


def to_json(diagnostics: Iterable[Diagnostic]) -> str:
    """A JSON array of diagnostics sorted by position, each distinct one once (ASCII only)."""
    unique = sorted(set(diagnostics), key=Diagnostic.sort_key)
    return json.dumps([d.as_dict() for d in unique], indent=2)


class SpecError(Exception):
    """Raised by a stage whose input has errors; carries every diagnostic found."""

    def __init__(self, diagnostics: Diagnostics | Iterable[Diagnostic]):
        if not isinstance(diagnostics, Diagnostics):
            diagnostics = Diagnostics(list(diagnostics))
        self.diagnostics = diagnostics
        super().__init__("\n".join(d.render() for d in diagnostics))


def _edit_distance(a: str, b: str) -> int:
    """Levenshtein distance (insertions, deletions, substitutions)."""
    previous = list(range(len(b) + 1))
    for i, char_a in enumerate(a, start=1):
        current = [i]
        for j, char_b in enumerate(b, start=1):
            current.append(
                min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (char_a != char_b))
            )
        previous = current
    return previous[-1]


def number_shown(value: object) -> str:
    """A number as a message quotes it: whole up to 30 characters, else its first 27 and
    `...` (an int of hundreds of digits is quoted, not printed out)."""
    text = str(value)
    return text if len(text) <= 30 else f"{text[:27]}..."


def did_you_mean(name: str, candidates: Iterable[str]) -> str:
    """A 'did you mean `X`?' hint for a misspelled name, or '' when nothing is close.

    Short names (RCS mnemonics are two letters) are too short for a similarity ratio,
    so a single-edit typo (`cx` for `cc`) counts as close too.
    """
    names = sorted(set(candidates))
    close = difflib.get_close_matches(name, names, n=1, cutoff=0.6)
    if not close:
        close = [
            n for n in names if len(name) > 1 and _edit_distance(name.lower(), n.lower()) == 1
        ][:1]
    return f"did you mean `{close[0]}`?" if close else ""


def known_names_hint(kind: str, candidates: Iterable[str], name: str = "") -> str:
    """A hint naming the close match, else the declared names of that kind (`kind` in the
    plural: "predicates", "results of cc")."""
    names = sorted(set(candidates))
    near = did_you_mean(name, names) if name else ""
    if near:
        return near
    if not names:
        return f"no {kind} are declared"
    shown = ", ".join(f"`{n}`" for n in names[:8])
    more = f" and {len(names) - 8} more" if len(names) > 8 else ""
    return f"declared {kind}: {shown}{more}"
