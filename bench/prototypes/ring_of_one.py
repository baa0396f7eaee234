"""Where a ring of one's hand-offs go (issue 24 item 2): one forked member and the
coordinator passing the token, nothing else, by each part of rcs/ring.py in turn.

- `syscalls`: no second process: the coordinator writes the token into an eventfd and
  reads it back, twice a cycle (a cycle's two hand-offs' system calls and Python, no
  wake-up);
- `blocking`: the ring as bench_lockstep.py's bare hand-off runs it (Receiver, give,
  Return: blocking reads, the coordinator's watcher thread, nobody spins);
- `no watcher`: the same with the coordinator reading the last link itself (os.read),
  no Return and no thread: what the watcher costs;
- `nudge`: the launcher's ring without a page, spinning forced on (`Load` says a core is
  free): the member nudges the coordinator as it takes the token, the coordinator the
  member as it comes back, a nudged one spins on poll(0) + sched_yield;
- `turn word`: the ring with a page (ring.Page): both spin on their turn words (eager),
  then read the doorbell the giver writes after the word (at once after a spin, asleep
  where the spin ran out);
- `turn word no spin`: the page with spinning off: every hand-off sleeps (what the page
  costs where nobody may spin).

The variants take turns (`--rounds`), each `--cycles` cycles; median and mean µs a cycle.

    .venv/bin/python bench/prototypes/ring_of_one.py [--cycles 3000] [--rounds 3]
        [--members 1] [--variants blocking,turn word] [--load]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

from rcsgen.runtime import ring

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_lockstep as lockstep  # noqa: E402


def syscalls(cycles: int) -> list[int]:
    fd = os.eventfd(0, os.EFD_CLOEXEC)
    taken = []
    for _ in range(cycles):
        began = time.perf_counter_ns()
        for _ in range(2):
            os.write(fd, ring.TOKEN)
            os.read(fd, 8)
        taken.append(time.perf_counter_ns() - began)
    os.close(fd)
    return taken


def fork_ring(cycles: int, spin: float, page: bool, watcher: bool = True) -> list[int]:
    return lockstep.token_ring(MEMBERS, cycles, spin, page, watcher=watcher)


MEMBERS = 1


VARIANTS: dict[str, Callable[[int], list[int]]] = {
    "syscalls": syscalls,
    "blocking": lambda n: fork_ring(n, 0.0, False),
    "no watcher": lambda n: fork_ring(n, 0.0, False, watcher=False),
    "nudge": lambda n: fork_ring(n, ring.SPIN, False),
    "turn word": lambda n: fork_ring(n, ring.SPIN, True),
    "turn word no spin": lambda n: fork_ring(n, 0.0, True),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=3_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--members", type=int, default=1, help="a ring of more than one")
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--load", action="store_true", help="spin only where Load says so")
    args = parser.parse_args()
    global MEMBERS
    MEMBERS = args.members
    if not args.load:
        ring.Load.core_free = lambda self, spinners=0: True  # type: ignore[method-assign]  # spin forced
    variants = {name: VARIANTS[name] for name in args.variants.split(",")}
    samples: dict[str, list[int]] = {name: [] for name in variants}
    for index in range(args.rounds):
        names = list(variants)[:: 1 if index % 2 == 0 else -1]
        for name in names:
            samples[name] += variants[name](args.cycles)
    load = os.getloadavg()[0]
    rows = {
        name: {
            "median_us": round(statistics.median(v) / 1e3, 2),
            "mean_us": round(statistics.fmean(v) / 1e3, 2),
        }
        for name, v in samples.items()
    }
    head = {"load_1min": load, "members": MEMBERS, "cycles": args.cycles, "rounds": args.rounds}
    print(json.dumps({**head, **rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
