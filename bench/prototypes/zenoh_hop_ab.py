"""Prototype (not in `make bench`): where a Zenoh hop goes, bare zenoh-python beside the
runtime's transport in one script, the variants taking turns (issue 24 item 3).

Every variant is a round trip from this process to an echo process over loopback, halved,
both ends configured as `zenoh_transport.config_json` configures a node (peer, no scouting,
no shared-memory transport, the runtime's lease) and the same payload: one runtime push of
pp's command record (its bytes as `Mirror.pack` makes them). The pinger always hands a
reply from Zenoh's callback thread to its waiting thread (as a node's `wait` does):

- `bare-cb`: no rcsgen code; the echo answers in its callback (put -> callback -> put);
- `bare-direct`: `bare-cb` with both ends' callbacks run on Zenoh's receiving thread
  (`handlers.Callback(indirect=False)`), not on the Python thread zenoh-python feeds by
  default: one thread wake-up less at each end;
- `bare-queue`: no rcsgen code; the echo's callback hands the sample to its main thread
  through a `queue.SimpleQueue` (the runtime's inbox), which answers: one wake-up more;
- `bare-event`: as `bare-queue` but both waiting threads are woken through a
  `threading.Event` (a Python Condition: lock + notify) instead of the SimpleQueue;
- `bare-mirror`: `bare-queue` with the runtime's Python on the payload at both ends, not
  its transport: the record written, `Mirror.changed` and `pack` before each put, `unpack`
  and `apply` after each get and the record read (the echo: the command read, the status
  written and sent);
- `runtime`: the runtime's `ZenohTransport` at both ends (bench_zenoh's hop: the echo
  waits in `wait`, pulls, answers, pushes; zenoh_hop_callback.py's `wait`);
- `runtime-cb`: the runtime at both ends, the echo's callback thread applying the push and
  answering itself (zenoh_hop_callback.py's `callback`).

So `bare-queue - bare-cb` is one thread hand-off, `runtime - bare-queue` is the runtime's
Python (find, pack, unpack, filter, apply, its wait loop) and `bare-cb` is Zenoh itself.

    python bench/prototypes/zenoh_hop_ab.py [--hops N] [--rounds N] [--variants a,b]
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
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent.parent
sys.path[:0] = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]

import zenoh  # noqa: E402
from miner import layout  # noqa: E402
from miner.rcs import block as block_mod  # noqa: E402
from miner.rcs import transport  # noqa: E402
from miner.rcs import zenoh_transport as zt  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import zenoh_hop_callback  # noqa: E402

COMMAND, STATUS = layout.COMMAND_IN["pp"], layout.STATUS_OUT["pp"]
RUNTIME_MODES = {"runtime": "wait", "runtime-cb": "callback"}
VARIANTS = (
    "bare-cb",
    "bare-direct",
    "bare-queue",
    "bare-event",
    "bare-mirror",
    "runtime",
    "runtime-cb",
)
WARM = 50
END = b"end"  # the echo's last message: it leaves


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def payload() -> bytes:
    """One runtime push of pp's command: what the runtime's hop carries."""
    block = block_mod.Block(layout)
    mirror = transport.Mirror(layout, block)
    mirror.changed()  # the initial records: not this push
    COMMAND.write(block.buf, command_num=1)
    packed = mirror.pack(mirror.changed(slow=False))
    block.close()
    return packed


def bare_session(options: zt.Options) -> Any:
    config = zenoh.Config()
    for key, value in zt.config_json(options).items():
        config.insert_json5(key, json.dumps(value))
    return zenoh.open(config)


class Waker:
    """The hand-off from Zenoh's callback thread to a waiting thread: a SimpleQueue (the
    runtime's inbox) or a threading.Event."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self.inbox: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self.event, self.box = threading.Event(), []

    def put(self, data: bytes) -> None:
        if self.kind == "event":
            self.box.append(data)
            self.event.set()
        else:
            self.inbox.put(data)

    def get(self, timeout: float = 10.0) -> bytes | None:
        """The next message, or None after `timeout` seconds."""
        if self.kind == "event":
            if not self.box and not self.event.wait(timeout):
                return None
            self.event.clear()
            return self.box.pop(0)
        try:
            return self.inbox.get(timeout=timeout) if timeout else self.inbox.get_nowait()
        except queue.Empty:
            return None


def handler(variant: str, callback: Any) -> Any:
    """A Python callback as zenoh-python runs it by default (`indirect`: on a Python thread
    of its own, fed by Zenoh's receiving thread), or on Zenoh's receiving thread itself."""
    return zenoh.handlers.Callback(callback, indirect=not variant.endswith("direct"))


def bare_echo(variant: str, where: str) -> None:
    """Every message back as it came, until END."""
    session = bare_session(zt.Options(connect=(where,)))
    pong = session.declare_publisher("b/pong", congestion_control=zenoh.CongestionControl.BLOCK)
    done = threading.Event()
    if variant in ("bare-cb", "bare-direct"):

        def answer(sample: Any) -> None:
            data = sample.payload.to_bytes()
            if data == END:
                done.set()
            else:
                pong.put(data)

        session.declare_subscriber("b/ping", handler(variant, answer))
        done.wait(300)
    else:
        waker = Waker("event" if variant == "bare-event" else "queue")
        session.declare_subscriber("b/ping", lambda s: waker.put(s.payload.to_bytes()))
        mirror = Mirrored() if variant == "bare-mirror" else None
        while (data := waker.get()) != END:
            if mirror is not None and data != b"hello":
                number = mirror.take(data, COMMAND)["command_num"]
                data = mirror.send(STATUS, status_num=number)
            pong.put(data)
    session.close()


class Mirrored:
    """The runtime's Python on a hop's payload, without its transport: a block and a
    mirror; `send` writes a record and packs what changed, `take` applies a push and reads
    a record."""

    def __init__(self) -> None:
        self.block = block_mod.Block(layout)
        self.mirror = transport.Mirror(layout, self.block)
        self.mirror.changed()
        self.wanted = zt._matcher(transport.reads(layout, None, ()))

    def send(self, record: Any, **values: Any) -> bytes:
        record.write(self.block.buf, **values)
        return bytes(self.mirror.pack(self.mirror.changed(slow=False)))

    def take(self, data: bytes, record: Any) -> dict[str, Any]:
        for key, message in self.mirror.unpack(data) or ():
            if self.wanted(key):
                self.mirror.apply(key, message)
        return dict(record.read(self.block.buf))


def bare_hops(variant: str, count: int, data: bytes) -> list[int]:
    where = f"tcp/127.0.0.1:{free_port()}"
    session = bare_session(zt.Options(listen=(where,)))
    waker = Waker("event" if variant == "bare-event" else "queue")
    session.declare_subscriber(
        "b/pong", handler(variant, lambda s: waker.put(s.payload.to_bytes()))
    )
    ping = session.declare_publisher("b/ping", congestion_control=zenoh.CongestionControl.BLOCK)
    child = subprocess.Popen([sys.executable, __file__, "--echo", variant, where, "0"])
    rtts = []
    try:
        for _ in range(150):  # until the echo is connected and answers
            ping.put(b"hello")
            if waker.get(0.2) is not None:
                break
        else:
            raise SystemExit(f"{variant}: the echo did not answer within 30 s")
        time.sleep(0.3)  # the answers to the other hellos, then none
        while waker.get(0.0) is not None:
            pass
        mirror = Mirrored() if variant == "bare-mirror" else None
        for number in range(count + WARM):
            began = time.perf_counter_ns()
            if mirror is not None:
                data = mirror.send(COMMAND, command_num=number + 1)
                ping.put(data)
                answer = waker.get()
                assert answer is not None
                if mirror.take(answer, STATUS)["status_num"] != number + 1:
                    raise SystemExit(f"{variant}: not the echo of #{number + 1}")
            else:
                ping.put(data)
                waker.get()
            if number >= WARM:
                rtts.append(time.perf_counter_ns() - began)
        ping.put(END)
        child.wait(30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        session.close()
    return rtts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hops", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--echo", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        bare_echo(args.echo[0], args.echo[1])
        return 0
    data = payload()
    variants = args.variants.split(",")
    found: dict[str, list[int]] = {v: [] for v in variants}
    per_round: dict[str, list[float]] = {v: [] for v in variants}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for variant in variants:
            if variant.startswith("bare"):
                rtts = bare_hops(variant, args.hops, data)
            else:  # zenoh_hop_callback's echo: `wait` as the runtime does, or `callback`
                rtts = zenoh_hop_callback.hops(RUNTIME_MODES[variant], args.hops)
            found[variant] += rtts
            per_round[variant].append(statistics.median(rtts) / 2e3)
    print(
        f"payload {len(data)} bytes; load average {load:.2f} before, "
        f"{os.getloadavg()[0]:.2f} after; hop = round trip / 2"
    )
    for variant, rtts in found.items():
        ordered = sorted(rtts)
        p99 = ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]
        rounds = " ".join(f"{m:.0f}" for m in per_round[variant])
        print(
            f"{variant:11s} hop median {statistics.median(rtts) / 2e3:6.1f} µs  "
            f"p99 {p99 / 2e3:7.1f} µs  (round medians {rounds}; {len(rtts)} round trips)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
