"""Prototype (not in `make bench`): where the two-host lockstep miner's cycle goes in CPU,
per process and per thread (issue 24 item 3).

bench_zenoh.py's lockstep miner (`open_harness(..., processes=True, transport="zenoh")`:
a coordinator in this process, pc1 and pc2 each on a block of its own), driven as
bench_lockstep's Driver drives it, and each thread's user + system time read from
/proc/<pid>/task/<tid>/stat before and after N cycles: CPU per system cycle of each
process's main thread ("main"), its other Python threads ("python": zenoh-python's
callback thread, the hook-deadline watcher) and Zenoh's own threads (rx, tx, acc, net,
named by Zenoh). On a loaded 2-core machine the cycle is about as long as this CPU.
The clock tick is 10 ms: the figures are good to about 10 ms / N.

Run it from a checkout whose runtime it measures (PYTHONPATH=. from that checkout's root);
to compare two revisions, export one (`git archive REV | tar -x -C DIR`) and alternate.

    python bench/prototypes/zenoh_lockstep_cpu.py [CYCLES]
"""

from __future__ import annotations

import collections
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path[:0] = [str(ROOT / "bench"), str(ROOT)]

from bench_lockstep import Driver  # noqa: E402

from rcsgen.tools import scenario as scenarios  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def threads(pid: int) -> collections.Counter[str]:
    """CPU ticks so far of each kind of thread of `pid`."""
    found: collections.Counter[str] = collections.Counter()
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/comm") as file:
                comm = file.read().strip()
            with open(f"/proc/{pid}/task/{tid}/stat") as file:
                fields = file.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        name = "main" if tid == str(pid) else (comm.rstrip("0123456789-") or comm)
        found[name] += int(fields[11]) + int(fields[12])  # utime, stime
    return found


def main() -> int:
    cycles = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    scenario = scenarios.load_scenario(ROOT / "specs/miner/scenarios/sump_shear_cusp.yaml")
    harness = scenarios.open_harness(
        scenario, ROOT / "generated" / "miner", processes=True, transport="zenoh"
    )
    driver = Driver(list(scenario.events), scenario.stop_when_done or "sb")
    pids = {"coordinator": os.getpid()}
    pids.update({n: c.popen.pid for n, c in harness.launcher.children.items()})
    try:
        for _ in range(50):  # warm up
            driver.before(harness)
            harness.cycle()
            driver.after(harness)
        before = {p: threads(pid) for p, pid in pids.items()}
        began = time.perf_counter()
        for _ in range(cycles):
            driver.before(harness)
            harness.cycle()
            driver.after(harness)
        wall = time.perf_counter() - began
        after = {p: threads(pid) for p, pid in pids.items()}
    finally:
        harness.close()
    print(f"load {os.getloadavg()[0]:.1f}; wall {wall / cycles * 1e6:.0f} µs a cycle; CPU a cycle:")
    total = 0.0
    for name in pids:
        spent = {
            k: (v - before[name].get(k, 0)) / TICK / cycles * 1e6 for k, v in after[name].items()
        }
        total += sum(spent.values())
        parts = ", ".join(
            f"{k} {v:.0f}" for k, v in sorted(spent.items(), key=lambda x: -x[1]) if v
        )
        print(f"  {name}: {sum(spent.values()):.0f} µs ({parts})")
    print(f"  total {total:.0f} µs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
