"""A spec directory's YAML -> the lines each kind of `# workaround(kind)` marker covers.

The inspection workstation (docs/inspection.md) writes out, plainly, what issue 14's
language features will replace, and marks it: `# workaround(time|result|expr|reuse|operator)`.
An inline marker (after YAML on the same line) covers that line. A marker on a line of its
own (with the comment lines right after it) covers the YAML that follows at its
indentation or deeper, up to a blank line, a comment line at its indentation or less, or a
line indented less. A line under two markers (an inline `time` inside a `reuse` block)
counts for both kinds, once in the total.

    python tests/workarounds.py specs/inspection
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass
from pathlib import Path

MARK = re.compile(r"#\s*workaround\((\w+)\)")


@dataclass(frozen=True)
class Count:
    markers: dict[str, int]
    lines: dict[str, int]
    covered: int  # distinct lines under any marker
    total: int  # YAML lines in the directory


def _indent(text: str) -> int:
    return len(text) - len(text.lstrip())


def count(directory: Path) -> Count:
    covered: dict[str, set[tuple[str, int]]] = {}
    markers: dict[str, int] = {}
    total = 0
    for path in sorted(directory.glob("*.yaml")):
        lines = path.read_text(encoding="utf-8").splitlines()
        total += len(lines)
        for i, line in enumerate(lines):
            found = MARK.search(line)
            if not found:
                continue
            kind = found.group(1)
            markers[kind] = markers.get(kind, 0) + 1
            mine = covered.setdefault(kind, set())
            if not line.lstrip().startswith("#"):
                mine.add((path.name, i))
                continue
            j = i + 1
            while j < len(lines) and lines[j].lstrip().startswith("#"):
                if MARK.search(lines[j]):
                    break
                j += 1  # the marker's continuation
            while j < len(lines):
                text = lines[j]
                comment = text.lstrip().startswith("#") and _indent(text) <= _indent(line)
                if not text.strip() or _indent(text) < _indent(line) or comment:
                    break
                mine.add((path.name, j))
                j += 1
    every = set().union(*covered.values()) if covered else set()
    lines_of = {kind: len(covered[kind]) for kind in sorted(covered)}
    return Count(dict(sorted(markers.items())), lines_of, len(every), total)


def table(result: Count) -> str:
    """The Markdown table docs/inspection.md shows."""
    rows = ["| kind | markers | spec lines |", "|---|---:|---:|"]
    rows += [f"| `{k}` | {result.markers[k]} | {result.lines[k]} |" for k in result.markers]
    rows.append(f"| all | {sum(result.markers.values())} | {result.covered} of {result.total} |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(table(count(Path(sys.argv[1]))))
