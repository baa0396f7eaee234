"""How often each module of the whole miner takes its idle fast path (issue 24).

A generated module that is idle with nothing new (NOP, no rule fired last cycle, nothing
to write, its inputs as they were) skips its copy-in, command check, table and writes: it
only reads its inputs and writes its performance buffer. This counts, per module, the
cycles in which it did more than that (its `inputs` replaced: the full path), over the
same repeated scenario bench_system.py times, so that a per-module cost can be read as
"idle cost + busy share x busy cost". Counting only; nothing is timed.

    bench/.venv/bin/python bench/prototypes/idle_share.py [--cycles 20000]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_system  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=20_000)
    args = parser.parse_args()
    repeater = bench_system.Repeater(bench_system.SCENARIO, bench_system.PACKAGE)
    busy: Counter[str] = Counter()
    calls: Counter[str] = Counter()
    patched = {}
    for _, controller in bench_system.controllers(repeater.first):
        cls = type(controller)
        if cls in patched or not hasattr(controller, "inputs"):
            continue
        original = cls.run_cycle

        def run_cycle(self, began=0, _original=original, _name=cls.__module__):
            before = self.inputs
            end = _original(self, began)
            name = _name.rsplit(".", 1)[-1]
            calls[name] += 1
            if self.inputs is not before:
                busy[name] += 1
            return end

        patched[cls] = original
        cls.run_cycle = run_cycle
    _, done, runs = repeater.run(args.cycles)
    print(f"{done} system cycles, {runs} scenario runs; share of cycles on the full path")
    total_calls = sum(calls.values())
    for name, n in sorted(calls.items(), key=lambda item: -busy[item[0]] / item[1]):
        print(f"{name:6s} {busy[name] / n:6.1%}  ({n} cycles)")
    print(f"all    {sum(busy.values()) / total_calls:6.1%} of {total_calls} module cycles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
