"""Report: diagnostics -> what the user sees: text (with colour), JSON, SARIF 2.1.0, GitHub
workflow annotations or per-code statistics, after the user's selection of warnings.

The command line and `[tool.rcsgen]` choose which warnings are shown (`select`, `ignore`:
code prefixes such as `W5` or `W503`; errors are always shown), whether warnings fail
(`strict`), and the format. Acknowledged warnings (`allow:` in a spec) are shown only on
request: in text as `acknowledged[W503]` with their reason, in SARIF as suppressed results.
"""

from __future__ import annotations

import json
import re
import urllib.parse
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from ..compiler.codes import CODES, WARNING_CODES, Severity
from ..compiler.diagnostics import Diagnostic, Diagnostics, counted, to_json

FORMATS = ("text", "json", "sarif", "github")
__all__ = ["FORMATS", "Options", "Outcome", "to_json", "to_sarif", "to_github"]
SARIF_SCHEMA = "https://json.schemastore.org/sarif-2.1.0.json"
_PREFIX = re.compile(r"W[0-9]{0,3}")


@dataclass(frozen=True)
class Options:
    """How diagnostics are reported: the command line over `[tool.rcsgen]` over defaults."""

    select: tuple[str, ...] = ()  # warning code prefixes to show; empty: all
    ignore: tuple[str, ...] = ()  # warning code prefixes not to show
    strict: bool = False  # a shown warning fails the command
    fmt: str = "text"
    quiet: bool = False  # diagnostics only: no summaries, no progress
    statistics: bool = False  # one line per code instead of each diagnostic
    show_acknowledged: bool = False
    color: bool = False

    def shows(self, diagnostic: Diagnostic) -> bool:
        """Whether a diagnostic is reported (errors always are)."""
        if diagnostic.severity is Severity.ERROR:
            return True
        code = diagnostic.code
        if self.select and not any(code.startswith(p) for p in self.select):
            return False
        return not any(code.startswith(p) for p in self.ignore)


def code_prefix_problem(prefix: str) -> str:
    """'' when `prefix` can select or ignore warnings, else why not."""
    if prefix[:1] in ("E", "S"):
        return f"`{prefix}` names errors: errors are always reported and cannot be ignored"
    if not _PREFIX.fullmatch(prefix):
        return f"`{prefix}` is not a warning code or prefix (such as W5 or W503)"
    if not any(code.startswith(prefix) for code in WARNING_CODES):
        known = ", ".join(sorted(WARNING_CODES))
        return f"no warning code starts with `{prefix}`; the warnings are {known}"
    return ""


@dataclass(frozen=True)
class Outcome:
    """What was reported and whether the command fails because of it."""

    errors: int
    warnings: int
    acknowledged: int
    fails: bool


def shown(diags: Diagnostics, options: Options) -> tuple[list[Diagnostic], list[Diagnostic]]:
    """The active diagnostics the options show, and the acknowledged ones to show."""
    active = [d for d in diags if options.shows(d)]  # sorted, each distinct diagnostic once
    acknowledged: list[Diagnostic] = []
    if options.show_acknowledged:
        acknowledged = sorted(set(diags.acknowledged), key=Diagnostic.sort_key)
    return active, acknowledged


def outcome(diags: Diagnostics, options: Options) -> Outcome:
    active, _ = shown(diags, options)
    errors = sum(d.severity is Severity.ERROR for d in active)
    warnings = len(active) - errors
    return Outcome(
        errors,
        warnings,
        len(set(diags.acknowledged)),
        bool(errors or (options.strict and warnings)),
    )


# ---------------------------------------------------------------- text

_STYLE: dict[str, dict[str, str | bool]] = {
    "error": {"fg": "red", "bold": True},
    "warning": {"fg": "yellow", "bold": True},
    "acknowledged": {"fg": "cyan"},
}


def render_text(
    diagnostic: Diagnostic,
    source_line: str | None,
    style: Callable[..., str] | None = None,
) -> str:
    """`file:line:col: severity[CODE]: message`, the source line and caret, then the hint
    (or the reason of an acknowledged warning); `style` is click.style when colouring."""
    if style is None:
        return diagnostic.render(source_line)
    severity = "acknowledged" if diagnostic.acknowledged else diagnostic.severity
    head = style(f"{severity}[{diagnostic.code}]", **_STYLE[severity])
    text = f"{style(str(diagnostic.span), bold=True)}: {head}: {diagnostic.message}"
    if source_line is not None:
        caret = " " * (max(diagnostic.span.col, 1) - 1) + style("^", fg="green", bold=True)
        bar = style("|", fg="blue")
        text += f"\n  {bar} {source_line.rstrip()}\n  {bar} {caret}"
    if diagnostic.acknowledged:
        text += f"\n  {style('= reason:', fg='cyan')} {diagnostic.acknowledged}"
    elif diagnostic.hint:
        text += f"\n  {style('= hint:', fg='cyan')} {diagnostic.hint}"
    return text


def summary(result: Outcome) -> str:
    """`2 errors, 1 warning`, and how many acknowledged; '' when nothing was found."""
    if not (result.errors or result.warnings):
        return ""
    text = f"{counted(result.errors, 'error')}, {counted(result.warnings, 'warning')}"
    return text + (f" ({result.acknowledged} acknowledged)" if result.acknowledged else "")


def statistics(diagnostics: Sequence[Diagnostic]) -> list[str]:
    """One line per code, most frequent first: count, code, severity, where it first occurs."""
    counts = Counter(
        (d.code, "acknowledged" if d.acknowledged else d.severity) for d in diagnostics
    )
    first: dict[tuple[str, str], Diagnostic] = {}
    for d in sorted(diagnostics, key=Diagnostic.sort_key):
        first.setdefault((d.code, "acknowledged" if d.acknowledged else d.severity), d)
    rows = sorted(counts.items(), key=lambda item: (-item[1], item[0]))
    width = max((len(str(n)) for _, n in rows), default=1)
    return [
        f"{count:>{width}}  {code}  {severity:<12}  e.g. {first[(code, severity)].span}"
        for (code, severity), count in rows
    ]


# ---------------------------------------------------------------- JSON, SARIF, GitHub


def _uri(file: str) -> str:
    """A SARIF artifact URI: relative paths stay relative (to the working directory)."""
    path = Path(file)
    if path.is_absolute():
        return path.as_uri()
    return urllib.parse.quote(PurePosixPath(path.as_posix()).as_posix())


def to_sarif(diagnostics: Iterable[Diagnostic], version: str) -> str:
    """A SARIF 2.1.0 log of one run of rcsgen: every diagnostic a result; acknowledged
    warnings carry an in-source suppression with their reason."""
    unique = sorted(set(diagnostics), key=Diagnostic.sort_key)
    codes = sorted({d.code for d in unique})
    index = {code: i for i, code in enumerate(codes)}
    results = []
    for d in unique:
        text = d.message + (f"\nhint: {d.hint}" if d.hint and not d.acknowledged else "")
        result: dict[str, object] = {
            "ruleId": d.code,
            "ruleIndex": index[d.code],
            "level": str(d.severity),
            "message": {"text": text},
            "locations": [
                {
                    "physicalLocation": {
                        "artifactLocation": {"uri": _uri(d.span.file)},
                        "region": {"startLine": d.span.line, "startColumn": d.span.col},
                    }
                }
            ],
        }
        if d.acknowledged:
            result["suppressions"] = [{"kind": "inSource", "justification": d.acknowledged}]
        results.append(result)
    log = {
        "$schema": SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "rcsgen",
                        "version": version,
                        "rules": [_rule(code) for code in codes],
                    }
                },
                "columnKind": "unicodeCodePoints",
                "results": results,
            }
        ],
    }
    return json.dumps(log, indent=2)


def _rule(code: str) -> dict[str, object]:
    """A SARIF rule: the code, its title and level (the registry's), where it is explained."""
    registered = CODES[code]
    return {
        "id": code,
        "shortDescription": {"text": registered.title},
        "defaultConfiguration": {"level": str(registered.severity)},
        "help": {"text": f"rcsgen's docs/diagnostics.md, section {code}"},
    }


def _escape(text: str, property_value: bool = False) -> str:
    """GitHub workflow-command escaping (data, or a property value)."""
    text = text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
    if property_value:
        text = text.replace(":", "%3A").replace(",", "%2C")
    return text


def to_github(diagnostics: Iterable[Diagnostic]) -> str:
    """GitHub Actions workflow annotations, one line per diagnostic."""
    lines = []
    for d in sorted(set(diagnostics), key=Diagnostic.sort_key):
        kind = "notice" if d.acknowledged else d.severity
        props = ",".join(
            [
                f"file={_escape(d.span.file, True)}",
                f"line={d.span.line}",
                f"col={d.span.col}",
                f"title={_escape(f'rcsgen {d.code}', True)}",
            ]
        )
        extra = d.acknowledged and f"acknowledged: {d.acknowledged}" or d.hint
        text = d.message + (f"\n{extra}" if extra else "")
        lines.append(f"::{kind} {props}::{_escape(text)}")
    return "\n".join(lines)
