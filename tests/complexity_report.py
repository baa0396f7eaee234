"""`make complexity`: cyclomatic complexity of rcsgen's functions, measured with radon.

Prints, for the whole package and for each of its parts (compiler, runtime, tools, cli),
how many functions there are, how many have complexity 20 or more (and their share), the
largest, and then every function at 20 or more, worst first. The budget (issue 25): at
most 1.5 % of the functions at 20 or more, none above 30; `tests/test_architecture.py`
holds the compiler to it.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from radon.complexity import cc_visit
from radon.visitors import Function

PACKAGE = Path(__file__).resolve().parents[1] / "rcsgen"
HIGH = 20  # complexity from which a function counts as complex
BUDGET_SHARE = 0.015  # of the functions at HIGH or more
BUDGET_MAX = 30  # no function above


@dataclass(frozen=True)
class Measured:
    path: str  # relative to the repository
    name: str  # Class.method or function
    complexity: int


def measure(root: Path = PACKAGE) -> list[Measured]:
    """Every function and method under `root`, worst first (as `radon cc` counts them: a
    closure is part of the function it is defined in)."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent).as_posix()
        for block in cc_visit(path.read_text("utf-8")):
            if isinstance(block, Function):  # functions and methods; classes are not counted
                found.append(Measured(rel, block.fullname, block.complexity))
    return sorted(found, key=lambda m: (-m.complexity, m.path, m.name))


def part(measured: list[Measured], prefix: str) -> list[Measured]:
    return [m for m in measured if m.path.startswith(prefix)]


def line(label: str, measured: list[Measured]) -> str:
    high = [m for m in measured if m.complexity >= HIGH]
    share = len(high) / len(measured) if measured else 0.0
    worst = measured[0].complexity if measured else 0
    return (
        f"{label:<10} {len(measured):4d} functions, {len(high):3d} at {HIGH} or more "
        f"({share:.1%}), worst {worst}"
    )


def main() -> int:
    measured = measure()
    print(line("rcsgen", measured))
    for name in ("compiler", "runtime", "tools"):
        print(line(name, part(measured, f"rcsgen/{name}/")))
    print(line("cli", part(measured, "rcsgen/cli.py")))
    print()
    for m in measured:
        if m.complexity >= HIGH:
            print(f"{m.complexity:4d}  {m.path}  {m.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
