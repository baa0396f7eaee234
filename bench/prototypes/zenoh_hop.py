"""Prototype (not in `make bench`): what a Zenoh hop costs, by ablation. A raw zenoh-python
round trip on loopback to an echo process, both ends configured as rcs/zenoh_transport.py
configures a node (peer, no scouting, no shared memory, its lease), then one thing changed
at a time, on both ends:

- `runtime`: as the runtime (a declared publisher, default QoS, the receiver a callback
  handing the sample to the waiting thread through a Condition);
- `express`: the publishers `express=True` (Zenoh >= 1.0 otherwise queues a small message
  for batching);
- `nobatch`: the session's tx batching off (`transport/link/tx/queue/batching/enabled`);
- `lowlatency`: `transport/unicast/lowlatency` (and QoS off, which it requires);
- `realtime`: express and `Priority.REAL_TIME`;
- `channel`: express, the receiver reading a FifoChannel in its own thread (no callback);
- `block`: express, `CongestionControl.BLOCK` (what a lockstep node uses).

The variants take turns in rounds (side by side, whatever the machine's load), each a
fresh pair of sessions; median and p99 of the round trip, halved (a hop).

    python bench/prototypes/zenoh_hop.py [--messages N] [--rounds R] [--variants a,b]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import zenoh

VARIANTS = ("runtime", "express", "nobatch", "lowlatency", "realtime", "channel", "block")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def config(variant: str, listen: str | None = None, connect: str | None = None) -> zenoh.Config:
    settings: dict[str, Any] = {
        "mode": "peer",
        "listen/endpoints": [listen] if listen else [],
        "connect/endpoints": [connect] if connect else [],
        "scouting/multicast/enabled": False,
        "transport/shared_memory/enabled": False,
        "transport/link/tx/lease": 1000,
    }
    if variant == "nobatch":
        settings["transport/link/tx/queue/batching/enabled"] = False
    if variant == "lowlatency":
        settings["transport/unicast/lowlatency"] = True
        settings["transport/unicast/qos/enabled"] = False
    made = zenoh.Config()
    for key, value in settings.items():
        made.insert_json5(key, json.dumps(value))
    return made


def publisher(session: zenoh.Session, key: str, variant: str) -> Any:
    options: dict[str, Any] = {}
    if variant in ("express", "realtime", "channel", "block"):
        options["express"] = True
    if variant == "realtime":
        options["priority"] = zenoh.Priority.REAL_TIME
    if variant == "block":
        options["congestion_control"] = zenoh.CongestionControl.BLOCK
    return session.declare_publisher(key, **options)


def echo(variant: str, where: str) -> None:
    session = zenoh.open(config(variant, connect=where))
    pong = publisher(session, "b/pong", variant)
    if variant == "channel":
        subscriber = session.declare_subscriber("b/ping", zenoh.handlers.FifoChannel(64))
        while True:
            pong.put(subscriber.recv().payload.to_bytes())
    session.declare_subscriber("b/ping", lambda s: pong.put(s.payload.to_bytes()))
    while True:
        time.sleep(3600)


def receiver(session: zenoh.Session, variant: str) -> Callable[[], object]:
    if variant == "channel":
        subscriber = session.declare_subscriber("b/pong", zenoh.handlers.FifoChannel(64))
        return subscriber.recv
    cond, box = threading.Condition(), []

    def arrived(sample: zenoh.Sample) -> None:
        with cond:
            box.append(sample.payload.to_bytes())
            cond.notify_all()

    session.declare_subscriber("b/pong", arrived)

    def receive() -> None:
        with cond:
            while not box:
                cond.wait(1.0)
            box.clear()

    return receive


def round_trips(variant: str, messages: int) -> list[int]:
    where = f"tcp/127.0.0.1:{free_port()}"
    session = zenoh.open(config(variant, listen=where))
    child = subprocess.Popen([sys.executable, __file__, "--echo", variant, where])
    try:
        ping = publisher(session, "b/ping", variant)
        receive = receiver(session, variant)
        time.sleep(1.0)  # the echo connected and declared
        taken = []
        payload = b"x" * 200  # about one push of a few records
        for number in range(messages + 100):
            began = time.perf_counter_ns()
            ping.put(payload)
            receive()
            if number >= 100:  # the first ones warm up
                taken.append(time.perf_counter_ns() - began)
    finally:
        child.kill()
        child.wait()
        session.close()
    return taken


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--messages", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--echo", nargs=2, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        echo(*args.echo)
        return 0
    variants = args.variants.split(",")
    taken: dict[str, list[int]] = {v: [] for v in variants}
    load = os.getloadavg()[0]
    for _ in range(args.rounds):
        for variant in variants:
            taken[variant] += round_trips(variant, args.messages)
    print(f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after; hop = RTT / 2")
    for variant, values in taken.items():
        values.sort()
        p99 = values[int(0.99 * len(values))]
        print(
            f"{variant:11s} hop median {statistics.median(values) / 2e3:7.1f} µs"
            f"  p99 {p99 / 2e3:8.1f} µs  ({len(values)} round trips)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
