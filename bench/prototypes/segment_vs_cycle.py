"""A lockstep process's cycle, the two ways the runtime can run it, in ONE process
(issue 24 item 2): `Process.run_cycle` (what a free-running process, the one-process
`Harness` and, since this round, a member of the token ring run) against `run_segment`
over the whole process (`run_modules`: a dict lookup and a StateClock.tick call per
module; what the ring ran before, what the request/reply coordinator's segments run).

The miner's nominal scenario (bench_lockstep.py's Driver), both ways taking turns every
50 system cycles in alternating order; wall time per system cycle, medians.

    bench/.venv/bin/python bench/prototypes/segment_vs_cycle.py [--chunks 40]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_lockstep as lockstep  # noqa: E402

from rcsgen.tools import scenario as scenarios  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--chunks", type=int, default=40)
    args = parser.parse_args()
    scenario = scenarios.load_scenario(lockstep.SCENARIO)
    harness = scenarios.open_harness(scenario, lockstep.PACKAGE)
    driver = lockstep.Driver(list(scenario.events), scenario.stop_when_done or "sb")
    processes = list(harness.processes.values())
    loop = sys.modules[type(processes[0]).__module__]  # the package's rcs/loop.py
    taken: dict[str, list[int]] = {"run_cycle": [], "run_segment": []}
    try:
        for chunk in range(args.chunks):
            for way in list(taken)[:: 1 if chunk % 2 else -1]:
                for _ in range(50):
                    driver.before(harness)
                    began = time.perf_counter_ns()
                    for process in processes:
                        if way == "run_cycle":
                            process.run_cycle()
                        else:
                            loop.run_segment(process, 0, len(process.plan.modules) - 1, True)
                    taken[way].append(time.perf_counter_ns() - began)
                    driver.after(harness)
    finally:
        harness.close()
    for way, values in taken.items():
        print(f"{way}: {statistics.median(values) / 1e3:.1f} us a system cycle (median)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
