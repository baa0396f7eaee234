"""Does a pipe hand the token on faster than an eventfd? (issue 24 item 2: rejected)

A pipe's writer wakes its reader with a *sync* wake-up (the kernel is told the writer
will sleep soon, so the reader may be run on the writer's CPU); an eventfd's does not.
A ring member sleeps right after it hands the token on, so a pipe might save the
wake-up of another CPU. Here N forked members and the coordinator pass a token round a
ring of blocking reads, each busy-working `work` µs (as a segment keeps its core busy)
before it hands on; per system cycle, the wall time less the members' work, median;
eventfd and pipe links alternated run by run. Measured at load 17 on the 2-core machine:
1 member, 30 µs: eventfd 6.0, pipe 6.8 µs; 2 members: 16.3 against 17.9 µs. The ring
keeps its eventfds.

    python3 bench/prototypes/handoff_pipe_or_eventfd.py [WORK_US] [MEMBERS]
"""

from __future__ import annotations

import os
import statistics
import sys
import time

WORK = int(sys.argv[1]) * 1000 if len(sys.argv) > 1 else 30_000
MEMBERS = int(sys.argv[2]) if len(sys.argv) > 2 else 1
CYCLES = 1500
TOKEN, STOP = (1).to_bytes(8, "little"), (2).to_bytes(8, "little")


def links(kind: str, count: int) -> list[tuple[int, int]]:
    made = []
    for _ in range(count):
        if kind == "eventfd":
            fd = os.eventfd(0)
            made.append((fd, fd))
        else:
            made.append(os.pipe())
    return made


def busy(ns: int) -> None:
    end = time.perf_counter_ns() + ns
    while time.perf_counter_ns() < end:
        pass


def ring(kind: str) -> float:
    ends = links(kind, MEMBERS + 1)
    pids = []
    for at in range(MEMBERS):
        pid = os.fork()
        if pid == 0:  # a member: take, work, hand on, until a stop
            while os.read(ends[at][0], 8) == TOKEN:
                busy(WORK)
                os.write(ends[at + 1][1], TOKEN)
            os._exit(0)
        pids.append(pid)
    taken = []
    for _ in range(CYCLES):
        began = time.perf_counter_ns()
        os.write(ends[0][1], TOKEN)
        os.read(ends[-1][0], 8)
        taken.append(time.perf_counter_ns() - began - MEMBERS * WORK)
        busy(WORK)  # the coordinator's own work between cycles
    for at in range(MEMBERS):
        os.write(ends[at][1], STOP)
    for pid in pids:
        os.waitpid(pid, 0)
    for read, write in ends:
        os.close(read)
        if write != read:
            os.close(write)
    return statistics.median(taken) / 1e3


def main() -> int:
    runs: dict[str, list[float]] = {"eventfd": [], "pipe": []}
    for index in range(6):
        for kind in list(runs)[:: 1 if index % 2 else -1]:
            runs[kind].append(ring(kind))
    for kind, values in runs.items():
        print(f"{kind}: {statistics.median(values):.1f} us a system cycle beyond the work")
    print(f"load average {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
