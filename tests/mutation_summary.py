"""`make mutate`'s summary: `mutmut results --all true` (on stdin) counted per package.

Arguments are the mutant-name patterns the run was given (fnmatch, as mutmut matches them;
none: every mutant); mutants of other functions are left out. For each package (compiler,
tools, runtime) it prints how many mutants the tests killed (a timeout counts as killed, as
mutmut counts it), how many survived, how many no test reaches, and the score: the killed
share of the mutants that were tested or that no test reaches. A mutant listed in
tests/mutation_equivalent.txt (`name  # why it cannot be killed`) is left out of the score
and counted apart; a listed name that is not a survivor any more is reported, so the list is
kept honest. Then every survivor (and every mutant no test reaches), by package.
"""

from __future__ import annotations

import fnmatch
import sys
from collections import Counter, defaultdict
from pathlib import Path

EQUIVALENT = Path(__file__).with_name("mutation_equivalent.txt")
PACKAGES = ("compiler", "tools", "runtime")
KILLED = ("killed", "timeout", "segfault", "caught by type check")
UNKILLED = ("survived", "no tests")


def read_equivalent(text: str) -> dict[str, str]:
    """`name  # reason` lines (blank lines and `#` lines skipped) -> {name: reason}."""
    found = {}
    for line in text.splitlines():
        name, _, reason = line.partition("#")
        if name.strip():
            found[name.strip()] = reason.strip()
    return found


def package_of(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) > 2 and parts[0] == "rcsgen" else "other"


def main(lines: list[str], patterns: list[str], equivalent: dict[str, str]) -> str:
    status_of: dict[str, str] = {}
    for line in lines:
        name, _, status = line.strip().rpartition(": ")
        if name and any(fnmatch.fnmatchcase(name, p) for p in patterns or ["*"]):
            status_of[name] = status
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    unkilled: dict[str, list[str]] = defaultdict(list)
    for name, status in sorted(status_of.items()):
        package = package_of(name)
        if status == "survived" and name in equivalent:
            counts[package]["equivalent"] += 1
            continue
        counts[package][status] += 1
        if status in UNKILLED:
            unkilled[package].append(f"{name}: {status}")
    out = []
    for package in [*PACKAGES, *sorted(set(counts) - set(PACKAGES))]:
        if package not in counts:
            continue
        c = counts[package]
        killed = sum(c[s] for s in KILLED)
        scored = killed + sum(c[s] for s in UNKILLED)
        others = ", ".join(
            f"{n} {s}" for s, n in sorted(c.items()) if s not in (*KILLED, *UNKILLED, "equivalent")
        )
        score = f"score {killed / scored:.1%} of {scored}" if scored else "nothing tested"
        out.append(
            f"{package}: {killed} killed ({c['timeout']} by timeout), {c['survived']} survived, "
            f"{c['no tests']} reached by no test, {c['equivalent']} equivalent"
            + (f", {others}" if others else "")
            + f"; {score}"
        )
    stale = sorted(
        n for n in equivalent if n in status_of and status_of[n] != "survived"
    )  # listed, in this run, and not a survivor: killed now, or not run yet
    if stale:
        out.append("listed in tests/mutation_equivalent.txt but not survivors: " + ", ".join(stale))
    for package in sorted(unkilled):
        out.append(f"\n{package}: {len(unkilled[package])} not killed")
        out += [f"    {entry}" for entry in unkilled[package]]
    return "\n".join(out)


if __name__ == "__main__":
    listed = read_equivalent(EQUIVALENT.read_text(encoding="utf-8")) if EQUIVALENT.exists() else {}
    print(main(sys.stdin.readlines(), sys.argv[1:], listed))
