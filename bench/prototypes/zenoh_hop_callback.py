"""Prototype (not in `make bench`): issue 24 item 3's idea measured before it is built: the
receiver's Zenoh callback thread applying a push to the block (and answering) itself,
instead of handing it to the inbox and waking the node's waiting thread.

bench_zenoh.py's hop (this process writes pp's command and pushes it; an echo process on a
block of its own answers with pp's status), the echo in two ways, alternated in one run:
`wait`, the runtime as it is (the callback queues, the node's thread wakes in `wait`, pulls,
answers, pushes); `callback`, the callback thread applies the push, answers and pushes
(the node's thread only takes joins). The round trip, halved, median and p99.

    python bench/prototypes/zenoh_hop_callback.py [--hops N] [--rounds N]
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path[:0] = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]

from miner import layout  # noqa: E402
from miner.rcs import block as block_mod  # noqa: E402
from miner.rcs import transport  # noqa: E402
from miner.rcs import zenoh_transport as zt  # noqa: E402

COMMAND, STATUS = layout.COMMAND_IN["pp"], layout.STATUS_OUT["pp"]


def echo(mode: str, where: str, count: int) -> None:
    block = block_mod.Block(layout)
    net = zt.ZenohTransport(
        transport.Mirror(layout, block), zt.Options(connect=(where,)), block_when_congested=True
    )
    seen = [0]
    lock, done = threading.Lock(), threading.Event()

    def answer() -> None:
        number = COMMAND.read(block.buf)["command_num"]
        if number != seen[0]:
            seen[0] = number
            STATUS.write(block.buf, status_num=number)
            net.push()
            if number >= count:
                done.set()

    if mode == "callback":
        queued = net._arrived

        def arrived(kind: str, key: str, payload: bytes) -> None:
            if kind != "push":
                queued(kind, key, payload)
                return
            with lock:  # the node's thread pulls joins under it
                net._push(key[len(net._pushes) :].partition("/")[0], payload)
                answer()

        net._arrived = arrived  # type: ignore[method-assign]
        while not done.is_set():
            with lock:
                net.pull()
                if net.republish:
                    net.push()
            done.wait(0.05)
    else:
        while not done.is_set():
            net.wait(lambda: COMMAND.read(block.buf)["command_num"] != seen[0], 30.0)
            answer()
    time.sleep(0.5)
    net.close()
    block.close()


def hops(mode: str, count: int) -> list[int]:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        where = f"tcp/127.0.0.1:{probe.getsockname()[1]}"
    block = block_mod.Block(layout)
    net: Any = zt.ZenohTransport(
        transport.Mirror(layout, block), zt.Options(listen=(where,)), block_when_congested=True
    )
    total = count + 50
    child = subprocess.Popen([sys.executable, __file__, "--echo", mode, where, str(total)])
    rtts = []
    try:
        net.wait(lambda: len(net.joined) > 1, 30.0)
        time.sleep(0.5)
        for number in range(1, total + 1):
            began = time.perf_counter_ns()
            COMMAND.write(block.buf, command_num=number)
            net.push()
            if not net.wait(lambda n=number: STATUS.read(block.buf)["status_num"] == n, 10.0):
                raise SystemExit(f"{mode}: no echo of #{number}")
            if number > 50:
                rtts.append(time.perf_counter_ns() - began)
        child.wait(30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        net.close()
        block.close()
    return rtts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hops", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--echo", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        echo(args.echo[0], args.echo[1], int(args.echo[2]))
        return 0
    found: dict[str, list[int]] = {"wait": [], "callback": []}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for mode in found:
            found[mode] += hops(mode, args.hops)
    print(f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after")
    for mode, rtts in found.items():
        ordered = sorted(rtts)
        p99 = ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]
        print(
            f"{mode:9s} hop median {statistics.median(rtts) / 2e3:6.1f} µs  "
            f"p99 {p99 / 2e3:6.1f} µs  ({len(rtts)} round trips)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
