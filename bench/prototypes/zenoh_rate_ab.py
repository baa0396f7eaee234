"""Part 8's throughput (records one process sends over Zenoh), this tree against older
revisions, in ONE process, taking turns (issue 24 item 3).

bench_zenoh.py's `rate` runs a sender and a receiver node in one process for one burst of
60,000 records: run after run of the same code on the shared 2-core machine it moved from
12,000 to 70,000 records/s (load ~7), so two revisions run one after the other compare two
loads. Here every revision's generated miner (its `rcs/` runtime: Mirror, ZenohTransport)
is imported side by side under a name of its own, each with its own sender and receiver
sessions on loopback (lockstep nodes, as in bench_zenoh: every push sent, none dropped);
they take turns every `--burst` pushes (a push per round of the world's float fields, as
bench_zenoh), in rotating order, and the receiver has applied a burst before the next
begins. Reported per revision: the median over the bursts of the wall time per push
(records/s = fields per push / it), of `push()` on the wall clock and on the thread's CPU
clock (what is Python and Zenoh's put in this thread; the rest is waiting: the GIL, the
transport's threads, the other work on the machine).

    .venv/bin/python bench/prototypes/zenoh_rate_ab.py --against e0c817b [--against REV]
        [--rounds 30] [--burst 100]
"""

from __future__ import annotations

import argparse
import importlib
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent.parent


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def extract(revision: str, into: Path) -> str:
    """The revision's generated miner as package `miner_<revision>` under `into`."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", revision, "generated/miner"],
        check=True,
        capture_output=True,
    ).stdout
    scratch = into / revision
    scratch.mkdir()
    subprocess.run(["tar", "-x", "-C", str(scratch)], input=archive, check=True)
    name = f"miner_{revision}".replace("-", "_").replace(".", "_")
    (scratch / "generated/miner").rename(into / name)
    return name


class Pair:
    """A revision's sender and receiver nodes, each on a block of its own."""

    def __init__(self, package: str) -> None:
        def load(module: str) -> Any:
            return importlib.import_module(f"{package}.{module}")

        self.layout, block = load("layout"), load("rcs.block")
        transport, zt = load("rcs.transport"), load("rcs.zenoh_transport")
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.blocks = (block.Block(self.layout), block.Block(self.layout))
        self.receiver = zt.ZenohTransport(
            transport.Mirror(self.layout, self.blocks[1]),
            zt.Options(listen=(endpoint,)),
            block_when_congested=True,
        )
        self.sender = zt.ZenohTransport(
            transport.Mirror(self.layout, self.blocks[0]),
            zt.Options(connect=(endpoint,)),
            block_when_congested=True,
        )
        for node in (self.receiver, self.sender):
            if not node.wait(lambda node=node: len(node.joined) > 1, 10.0):
                raise SystemExit(f"{package}: the two nodes did not meet")
        self.floats = [n for n, v in self.layout.WORLD_INITIAL.items() if isinstance(v, float)]
        self.number = 0

    def burst(self, pushes: int) -> tuple[float, float, float]:
        """Wall µs per push of the whole burst; push() wall and CPU µs per push."""
        world, buf, sender = self.layout.WORLD, self.blocks[0].buf, self.sender
        target = self.receiver.mirror.counters.applied + pushes * len(self.floats)
        push_wall = push_cpu = 0
        began = time.perf_counter_ns()
        for _ in range(pushes):
            for name in self.floats:
                self.number += 1
                world[name].write(buf, **{name: float(self.number)})
            wall, cpu = time.perf_counter_ns(), time.thread_time_ns()
            sender.push()
            push_cpu += time.thread_time_ns() - cpu
            push_wall += time.perf_counter_ns() - wall
        whole = time.perf_counter_ns() - began
        receiver = self.receiver
        if not receiver.wait(lambda: receiver.mirror.counters.applied >= target, 30.0):
            raise SystemExit("a burst did not arrive within 30 s")
        return whole / pushes / 1e3, push_wall / pushes / 1e3, push_cpu / pushes / 1e3

    def close(self) -> None:
        self.sender.close()
        self.receiver.close()
        for block in self.blocks:
            block.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--against", action="append", default=[], metavar="REV")
    parser.add_argument("--rounds", type=int, default=30)
    parser.add_argument("--burst", type=int, default=100)
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-zenoh-ab-"))
    sys.path.insert(0, str(scratch))
    sys.path.insert(0, str(ROOT / "generated"))
    names = {"this tree": "miner"}
    for revision in args.against:
        names[revision] = extract(revision, scratch)
    pairs: dict[str, Pair] = {}
    try:
        for label, package in names.items():
            pairs[label] = Pair(package)
        time.sleep(0.5)
        labels = list(pairs)
        taken: dict[str, list[tuple[float, float, float]]] = {label: [] for label in labels}
        load = os.getloadavg()[0]
        for turn in range(args.rounds):
            order = labels[turn % len(labels) :] + labels[: turn % len(labels)]
            for label in order:
                taken[label].append(pairs[label].burst(args.burst))
        print(f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
        for label in labels:
            whole, wall, cpu = (
                statistics.median(column) for column in zip(*taken[label], strict=True)
            )
            fields = len(pairs[label].floats)
            print(
                f"{label:12s} {fields * 1e6 / whole:9,.0f} records/s sent  "
                f"push() {wall:6.1f} µs wall, {cpu:6.1f} µs CPU  ({len(taken[label])} bursts)"
            )
    finally:
        for pair in pairs.values():
            pair.close()
        subprocess.run(["rm", "-rf", str(scratch)], check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
