"""Prototype (not in `make bench`): where part 8's Zenoh hop goes, stage by stage (issue 24
item 3). The round trip of bench_zenoh.py's hop (this process writes pp's command and
pushes it, an echo process on a block of its own answers with pp's status), both ends the
runtime's `ZenohTransport` (lockstep nodes: the receiver blocks in `wait`), with a stamp at
each stage on the monotonic clock, which two processes of one host share:

- `write`: the command written (rcsgen.tools' Record.write, as the bench does);
- `push`: `ZenohTransport.push` (Mirror.changed, pack, the publisher's put);
- `net->cb`: from the put's return to the receiver's Zenoh callback handing the sample to
  the inbox (the transport's threads on both sides, the socket, the callback's GIL);
- `cb->woke`: from the callback to the waiting thread taking it from the inbox;
- `woke->ready`: `pull` (unpack, filter, apply) and the wait's condition read;
- then the same on the way back (`(echo)` marks the echo's side).

    python bench/prototypes/zenoh_hop_split.py [--hops N]
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path[:0] = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]

from miner import layout  # noqa: E402
from miner.rcs import block as block_mod  # noqa: E402
from miner.rcs import transport  # noqa: E402
from miner.rcs import zenoh_transport as zt  # noqa: E402

now = time.perf_counter_ns  # CLOCK_MONOTONIC on Linux: comparable between processes
COMMAND, STATUS = layout.COMMAND_IN["pp"], layout.STATUS_OUT["pp"]
# the spans between the stamps, in the order they happen
LABELS = (
    "write",
    "push",
    "net->cb (echo)",
    "cb->woke (echo)",
    "woke->ready (echo)",
    "write (echo)",
    "push (echo)",
    "net->cb",
    "cb->woke",
    "woke->ready",
)


class Inbox:
    """The node's inbox with a stamp when the callback puts and when the waiter takes."""

    def __init__(self, inner: queue.SimpleQueue[Any], stamps: list[tuple[str, int]]) -> None:
        self.inner, self.stamps = inner, stamps

    def put(self, item: Any) -> None:
        self.stamps.append(("cb", now()))
        self.inner.put(item)

    def get(self, timeout: float | None = None) -> Any:
        item = self.inner.get(timeout=timeout)
        self.stamps.append(("woke", now()))
        return item

    def empty(self) -> bool:
        return self.inner.empty()

    def get_nowait(self) -> Any:
        return self.inner.get_nowait()


def node(block: Any, **where: tuple[str, ...]) -> tuple[Any, list[tuple[str, int]]]:
    net = zt.ZenohTransport(
        transport.Mirror(layout, block), zt.Options(**where), block_when_congested=True
    )
    stamps: list[tuple[str, int]] = []
    net.inbox = Inbox(net.inbox, stamps)
    return net, stamps


def first(stamps: list[tuple[str, int]], kind: str) -> int:
    return next((t for k, t in stamps if k == kind), 0)


def echo(where: str, count: int, out: str) -> None:
    block = block_mod.Block(layout)
    net, stamps = node(block, connect=(where,))
    seen, rows = 0, []
    while seen < count:
        stamps.clear()
        net.wait(lambda seen=seen: COMMAND.read(block.buf)["command_num"] != seen, 30.0)
        ready = now()
        seen = COMMAND.read(block.buf)["command_num"]
        STATUS.write(block.buf, status_num=seen)
        written = now()
        net.push()
        rows.append((seen, first(stamps, "cb"), first(stamps, "woke"), ready, written, now()))
    Path(out).write_text(json.dumps(rows))
    time.sleep(0.5)
    net.close()
    block.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hops", type=int, default=1000)
    parser.add_argument("--echo", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        echo(args.echo[0], int(args.echo[1]), args.echo[2])
        return 0
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        where = f"tcp/127.0.0.1:{probe.getsockname()[1]}"
    block = block_mod.Block(layout)
    net, stamps = node(block, listen=(where,))
    out = Path(tempfile.mkdtemp(prefix="rcsgen-hop-split-")) / "echo.json"
    total = args.hops + 50
    child = subprocess.Popen([sys.executable, __file__, "--echo", where, str(total), str(out)])
    rows = []
    load = os.getloadavg()[0]
    try:
        net.wait(lambda: len(net.joined) > 1, 30.0)
        time.sleep(0.5)
        for number in range(1, total + 1):
            stamps.clear()
            began = now()
            COMMAND.write(block.buf, command_num=number)
            written = now()
            net.push()
            pushed = now()
            if not net.wait(lambda n=number: STATUS.read(block.buf)["status_num"] == n, 10.0):
                raise SystemExit(f"no echo of #{number}")
            rows.append((number, began, written, pushed, stamps[:], now()))
        child.wait(30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        net.close()
        block.close()
    echoed = {row[0]: row for row in json.loads(out.read_text())}
    out.unlink()
    out.parent.rmdir()
    parts: dict[str, list[float]] = {}
    for number, began, written, pushed, got, done in rows[50:]:
        _, e_cb, e_woke, e_ready, e_written, e_pushed = echoed[number]
        cb = max((t for k, t in got if k == "cb"), default=0)  # the answer's, not a stray one
        woke = max((t for k, t in got if k == "woke"), default=0)
        marks = (began, written, pushed, e_cb, e_woke, e_ready, e_written, e_pushed, cb, woke)
        times = (*marks, done)
        if not all(times) or any(b < a for a, b in zip(times, times[1:], strict=False)):
            continue  # a stamp of another message (a join, a stray): not this round trip
        spans = [b - a for a, b in zip(times, times[1:], strict=False)]
        for label, span in zip(LABELS, spans, strict=True):
            parts.setdefault(label, []).append(span / 1e3)
        parts.setdefault("round trip", []).append((done - began) / 1e3)
    print(
        f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after; "
        f"{len(parts.get('round trip', []))} round trips whole"
    )
    for label, values in parts.items():
        print(
            f"{label:20s} median {statistics.median(values):7.1f} µs  "
            f"mean {statistics.mean(values):7.1f} µs"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
