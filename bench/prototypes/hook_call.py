"""What one hook call costs the generated code, in CPU time (issue 24): the call a
controller makes (`rcs.deadline.hook`: the deadline's two clock readings, the error
wrapping, the result check), the same without the result check, the deadline's bookkeeping
alone written out, the result check alone, and a plain call of the hook function; each
timed in turns (30 rounds of 20,000 calls, thread CPU time), min / lower quartile / median.
The hook returns (int, float), as vg.align does. `--root DIR`: another checkout's
generated/miner/rcs (its deadline and contract), for a before/after run by run.

    .venv/bin/python bench/prototypes/hook_call.py [--root /work/main]
"""

from __future__ import annotations

import sys
import time
import types
from pathlib import Path

ROOT = Path(sys.argv[2]) if sys.argv[1:2] == ["--root"] else Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "generated"))

from miner.rcs import deadline  # noqa: E402

hooks = types.ModuleType("hooks")
hooks.align = lambda heading, turn: (1, 2.0)
STATE = [0.0, 0.0, 0.0]
CLOCK = time.monotonic


def bookkeeping(owner: object, rule: str, *args: object) -> object:
    """The deadline's work alone: the watched state set, two clock readings."""
    STATE[1] = 1.0
    STATE[0] = began = CLOCK()
    try:
        result = hooks.align(*args)
    finally:
        STATE[0] = 0.0
    if CLOCK() - began > 1.0:
        raise RuntimeError("late")
    return result


class Owner:
    cycles = 0
    checked = deadline.hook("vg", hooks, "align", 1.0, "if")
    unchecked = deadline.hook("vg", hooks, "align", 1.0, None)
    bare = bookkeeping


def main() -> int:
    owner, fits = Owner(), deadline.result_fits("if")
    runs = {
        "hook call (as generated)": lambda: owner.checked("r", 1, 2),
        "without the result check": lambda: owner.unchecked("r", 1, 2),
        "the deadline's bookkeeping alone": lambda: owner.bare("r", 1, 2),
        "the result check alone": lambda: fits((1, 2.0)),
        "the hook function called directly": lambda: hooks.align(1, 2),
    }
    clock, calls = time.thread_time_ns, 20_000
    found: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(30):
        for name, run in runs.items():
            start = clock()
            for _ in range(calls):
                run()
            found[name].append((clock() - start) / calls)
    print(f"{ROOT}/generated/miner/rcs")
    for name, values in found.items():
        values.sort()
        print(
            f"{name:36s} min {values[0]:6.0f}  q1 {values[7]:6.0f}  median {values[15]:6.0f} ns CPU"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
