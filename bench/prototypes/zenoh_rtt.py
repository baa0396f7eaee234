"""Prototype (not in `make bench`): where a Zenoh hop goes. A raw zenoh round trip on
loopback, an echo in a child process, with the receiving side either a Python callback
handing the sample to the waiting thread through a threading.Condition (what
rcs/zenoh_transport.py does) or a FifoChannel read by the waiting thread itself (no
hand-off between threads). No rcsgen code on the way: if the two are alike and close to
rcsgen's hop (bench_zenoh.py), the time is the transport's, not the Python around it.

    python bench/prototypes/zenoh_rtt.py [--messages N]
"""

from __future__ import annotations

import argparse
import json
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable

import zenoh


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def config(listen: str | None = None, connect: str | None = None) -> zenoh.Config:
    made = zenoh.Config()
    made.insert_json5("mode", '"peer"')
    made.insert_json5("scouting/multicast/enabled", "false")
    if listen:
        made.insert_json5("listen/endpoints", json.dumps([listen]))
    if connect:
        made.insert_json5("connect/endpoints", json.dumps([connect]))
    return made


def echo(where: str, mode: str) -> None:
    session = zenoh.open(config(connect=where))
    publisher = session.declare_publisher("b/pong")
    if mode == "callback":
        session.declare_subscriber("b/ping", lambda s: publisher.put(s.payload.to_bytes()))
        while True:
            time.sleep(3600)
    subscriber = session.declare_subscriber("b/ping", zenoh.handlers.FifoChannel(64))
    while True:
        publisher.put(subscriber.recv().payload.to_bytes())


def receiver(session: zenoh.Session, mode: str) -> Callable[[], object]:
    if mode == "channel":
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


def round_trips(mode: str, messages: int) -> dict[str, float]:
    where = f"tcp/127.0.0.1:{free_port()}"
    session = zenoh.open(config(listen=where))
    child = subprocess.Popen([sys.executable, __file__, "--echo", mode, where])
    try:
        publisher = session.declare_publisher("b/ping")
        receive = receiver(session, mode)
        time.sleep(1.5)  # the echo connected and declared
        taken = []
        for number in range(messages + 100):
            began = time.perf_counter_ns()
            publisher.put(b"x" * 64)
            receive()
            if number >= 100:  # the first ones warm up
                taken.append(time.perf_counter_ns() - began)
    finally:
        child.kill()
        child.wait()
        session.close()
    taken.sort()
    return {
        "median_us": taken[len(taken) // 2] / 1e3,
        "p99_us": taken[int(0.99 * len(taken))] / 1e3,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--messages", type=int, default=1500)
    parser.add_argument("--echo", nargs=2, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.echo:
        echo(args.echo[1], args.echo[0])
        return 0
    for _ in range(2):
        for mode in ("callback", "channel"):
            print(mode, round_trips(mode, args.messages), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
