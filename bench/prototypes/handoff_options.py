"""Prototype (not in `make bench`): the lockstep hand-off's options, side by side. Two
forked processes pass a token back and forth (a ring of two, nothing else to do); the
hand-off is half a round trip. Each option in turn, in rounds, whatever the machine's load:

- `eventfd`: a blocking read of an eventfd (rcs/ring.py's hand-off when nobody nudges);
- `semaphore`: the same with EFD_SEMAPHORE (a futex-like counting wait);
- `pipe`: a blocking read of a pipe (what request/reply used);
- `spin-poll`: spin on poll(2) of the eventfd with sched_yield each turn, at most `--spin`,
  then block (rcs/ring.py's nudged member, forced whatever the load);
- `spin-read`: the same spinning on a non-blocking read (one system call a turn, not two);
- `word-yield`: a shared turn word (mmap) polled, sched_yield each turn (no system call
  but the yield; no blocking fallback: the floor of a polled word with manners);
- `word-hot`: the same word polled flat out (no yield: the floor, and what a spinner
  takes from whoever else needs the core).

    python bench/prototypes/handoff_options.py [--trips N] [--rounds R] [--spin S]
"""

from __future__ import annotations

import argparse
import mmap
import os
import select
import statistics
import struct
import sys
import time

OPTIONS = ("eventfd", "semaphore", "pipe", "spin-poll", "spin-read", "word-yield", "word-hot")
WORD = struct.Struct("=Q")
ONE = WORD.pack(1)


class Channel:
    """One direction: give() hands the token over, take() waits for it."""

    def __init__(self, option: str, spin_ns: int, shared: mmap.mmap, slot: int) -> None:
        self.option, self.spin_ns, self.shared, self.at = option, spin_ns, shared, slot * 8
        self.turn = 0
        if option == "pipe":
            self.r, self.w = os.pipe()
        elif option.startswith("word"):
            self.r = self.w = -1
        else:
            flags = os.EFD_SEMAPHORE if option == "semaphore" else 0
            self.r = self.w = os.eventfd(0, flags)

    def give(self) -> None:
        if self.r < 0:
            self.turn += 1
            WORD.pack_into(self.shared, self.at, self.turn)
        else:
            os.write(self.w, ONE)

    def take(self) -> None:
        option = self.option
        if self.r < 0:
            self.turn += 1
            want, shared, at = self.turn, self.shared, self.at
            if option == "word-hot":
                while WORD.unpack_from(shared, at)[0] != want:
                    pass
            else:
                while WORD.unpack_from(shared, at)[0] != want:
                    os.sched_yield()
            return
        if option == "spin-poll":
            poller = select.poll()
            poller.register(self.r, select.POLLIN)
            end = time.monotonic_ns() + self.spin_ns
            while not poller.poll(0) and time.monotonic_ns() < end:
                os.sched_yield()
        elif option == "spin-read":
            os.set_blocking(self.r, False)
            end = time.monotonic_ns() + self.spin_ns
            while time.monotonic_ns() < end:
                try:
                    os.read(self.r, 8)
                    return
                except BlockingIOError:
                    os.sched_yield()
            os.set_blocking(self.r, True)
        os.read(self.r, 8 if self.option != "pipe" else 8)


def trips(option: str, count: int, spin: float) -> list[int]:
    shared = mmap.mmap(-1, 16)
    there, back = Channel(option, int(spin * 1e9), shared, 0), Channel(option, 0, shared, 1)
    back.spin_ns = there.spin_ns
    child = os.fork()
    if child == 0:  # the echo: take, give back
        try:
            for _ in range(count + 100):
                there.take()
                back.give()
        finally:
            os._exit(0)
    taken = []
    for number in range(count + 100):
        began = time.perf_counter_ns()
        there.give()
        back.take()
        if number >= 100:
            taken.append(time.perf_counter_ns() - began)
    os.waitpid(child, 0)
    for channel in (there, back):
        for fd in {channel.r, channel.w} - {-1}:
            os.close(fd)
    shared.close()
    return taken


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trips", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--spin", type=float, default=2e-3)
    parser.add_argument("--options", default=",".join(OPTIONS))
    args = parser.parse_args()
    options = args.options.split(",")
    found: dict[str, list[int]] = {o: [] for o in options}
    before = os.getloadavg()[0]
    for _ in range(args.rounds):
        for option in options:
            found[option] += trips(option, args.trips, args.spin)
    print(f"load average {before:.2f} before, {os.getloadavg()[0]:.2f} after; hand-off = RTT/2")
    for option, values in found.items():
        values.sort()
        print(
            f"{option:11s} median {statistics.median(values) / 2e3:8.1f} µs"
            f"  mean {statistics.fmean(values) / 2e3:8.1f} µs"
            f"  p90 {values[int(0.9 * len(values))] / 2e3:8.1f} µs"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
