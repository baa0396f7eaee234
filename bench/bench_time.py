"""Time in a state: per-cycle cost of a table with `after:`/`for:` -> ns per cycle, as JSON.

Runs the helm of tests/fixtures/language/timed (ICE_MANEUVER waiting in S1: its `for:`
counter and `ticks` kept by the generated code) and of bench/time_workaround (the same
table with hand-kept counters in every_cycle rules, as before issue 14), each for `--cycles`
cycles in-process, interleaved, the best of five runs each. Not part of `make bench`; run it with
`.venv/bin/python bench/bench_time.py`.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import time
from collections.abc import Callable
from pathlib import Path

from rcsgen.tools.harness import Harness

ROOT = Path(__file__).resolve().parent.parent
SPECS = {
    "after_for": ROOT / "tests" / "fixtures" / "language" / "timed",
    "hand_kept_counters": ROOT / "bench" / "time_workaround",
}


def timed(run: Callable[[], None], cycles: int) -> float:
    start = time.perf_counter_ns()
    for _ in range(cycles):
        run()
    return (time.perf_counter_ns() - start) / cycles


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=100_000)
    args = parser.parse_args()
    with contextlib.ExitStack() as stack:
        runs = {}
        for name, spec_dir in SPECS.items():  # the helm waiting in S1: rudder turning, no ice
            h = stack.enter_context(Harness.build(spec_dir))
            h.command("helm", "ICE_MANEUVER")
            h.step("helm")
            h.world["ice_ahead"] = False
            runs[name] = (h, h.controller("helm").run_cycle)
        best = dict.fromkeys(SPECS, float("inf"))
        for _ in range(5):  # interleaved, so a busy moment of the machine hits both
            for name, (_, run) in runs.items():
                best[name] = min(best[name], timed(run, args.cycles))
        for h, _ in runs.values():
            assert h.status("helm").state == "S1", "the helm must still be waiting in S1"
    print(json.dumps({name: round(value) for name, value in best.items()}))


if __name__ == "__main__":
    main()
