"""Does a hand-off cost more when the members work between hand-offs? (issue 24 item 2)

The token ring of rcs/ring.py with N forked members, each of which busy-works `work` µs
(a spin on perf_counter_ns, as a segment of generated code keeps its core busy) before
handing the token on. The coordinator times each system cycle on the wall clock; less the
members' own work (each measures how long its spin really took, written into a shared
array), what is left is what the N+1 hand-offs cost: the system calls and the scheduler's
wake-ups of a process that slept while the others worked. Bench_lockstep.py's bare
hand-off is the `work = 0` row.

With `--spin S` each member nudges its successor as it takes the token (ring.Nudge), the
coordinator nudges the first as the token comes back, and a nudged member spins up to S
seconds, as the launcher's ring does; `--force` nudges even when no core is free (the
/proc/loadavg check off: to measure the spin itself on a busy machine, e.g. under
`chrt -f 10`, where our processes get a CPU at once).

    bench/.venv/bin/python bench/prototypes/handoff_work.py [--members 2] [--cycles 2000]
        [--spin 0.002] [--force]
"""

from __future__ import annotations

import argparse
import json
import mmap
import os
import statistics
import struct
import sys
import time

from rcsgen.runtime import ring

SLOT = struct.Struct("<Q")


def spin(ns: int) -> int:
    began = time.perf_counter_ns()
    end = began + ns
    while time.perf_counter_ns() < end:
        pass
    return time.perf_counter_ns() - began


def cycle_times(members: int, work_us: float, cycles: int, spin_s: float = 0.0) -> dict[str, float]:
    links = ring.new_links(members + 1)
    shared = mmap.mmap(-1, SLOT.size * members)
    controls, pids = [], []
    for at in range(members):
        control, keep = os.pipe()
        pid = os.fork()
        if pid == 0:  # a member: take, work, record the work, hand on
            os.close(keep)
            receiver = ring.Receiver(links[at].read, spin_s)
            nudge = ring.Nudge(links[at + 1].write, spin_s)
            ring.stop_on_control(control, links[at].write)
            while receiver.wait():
                nudge()
                SLOT.pack_into(shared, at * SLOT.size, spin(int(work_us * 1e3)))
                ring.give(links[at + 1].write)
            os._exit(0)
        os.close(control)
        controls.append(keep)
        pids.append(pid)
    waiter, wall, handoffs = ring.Return(links[-1].read, (), spin_s), [], []
    nudge = ring.Nudge(links[0].write, spin_s)
    try:
        for _ in range(cycles):
            began = time.perf_counter_ns()
            ring.give(links[0].write)
            waiter.wait(10.0)
            took = time.perf_counter_ns() - began
            worked = sum(SLOT.unpack_from(shared, i * SLOT.size)[0] for i in range(members))
            wall.append(took)
            handoffs.append(took - worked)
            nudge()
    finally:
        nudge.close()
        waiter.close()
        for fd in controls:
            os.close(fd)
        for pid in pids:
            os.waitpid(pid, 0)
        ring.close_links(links)
    return {
        "work_us": work_us,
        "spin_s": spin_s,
        "wall_us": statistics.median(wall) / 1e3,
        "handoffs_us": statistics.median(handoffs) / 1e3,
        "per_handoff_us": statistics.median(handoffs) / 1e3 / (members + 1),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--members", type=int, default=2)
    parser.add_argument("--cycles", type=int, default=2_000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--spin", type=float, default=0.0)
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    if args.force:
        ring.Load.core_free = lambda self, spinners=0: True  # type: ignore[method-assign]
    rows = []
    for _ in range(args.rounds):  # interleaved: a burst of other work hits every row alike
        for work in (0.0, 25.0, 100.0, 200.0):
            rows.append(cycle_times(args.members, work, args.cycles, args.spin))
    print(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
