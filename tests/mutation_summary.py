"""`make mutate`'s score: count `mutmut results --all true` (on stdin) by status.

Arguments are the mutant-name patterns the run was given (fnmatch, as mutmut matches
them); mutants of other functions are left out. The score is the share of the tested
mutants (killed, survived or timed out) that the tests killed or that timed out.
"""

from __future__ import annotations

import fnmatch
import sys
from collections import Counter


def main(lines: list[str], patterns: list[str]) -> str:
    counts: Counter[str] = Counter()
    for line in lines:
        name, _, status = line.strip().rpartition(": ")
        if name and any(fnmatch.fnmatchcase(name, p) for p in patterns or ["*"]):
            counts[status] += 1
    tested = counts["killed"] + counts["survived"] + counts["timeout"]
    score = (counts["killed"] + counts["timeout"]) / tested if tested else 0.0
    others = ", ".join(
        f"{n} {s}" for s, n in sorted(counts.items()) if s not in ("killed", "survived", "timeout")
    )
    return (
        f"mutants: {counts['killed']} killed, {counts['survived']} survived, "
        f"{counts['timeout']} timeout, {sum(counts.values())} in all"
        + (f" ({others})" if others else "")
        + f"; score {score:.1%} of {tested} tested"
    )


if __name__ == "__main__":
    print(main(sys.stdin.readlines(), sys.argv[1:]))
