"""Prototype (not in `make bench`): whether a DROP put waits for a stopped peer. A node
publishes 20 KB messages (express, CongestionControl.DROP: what a free-running controller
uses) every millisecond for 6 s to a subscriber process stopped with SIGSTOP, and reports
the longest put; with `low`, both ends use Zenoh's low-latency transport (QoS off). A
controller's cycle must never wait for a stopped peer.

    python bench/prototypes/zenoh_stopped_peer.py default|low
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time

import zenoh
from zenoh_hop import free_port


def config(low: bool, listen: str | None = None, connect: str | None = None) -> zenoh.Config:
    settings = {
        "mode": "peer",
        "listen/endpoints": [listen] if listen else [],
        "connect/endpoints": [connect] if connect else [],
        "scouting/multicast/enabled": False,
        "transport/shared_memory/enabled": False,
        "transport/link/tx/lease": 1000,
    }
    if low:
        settings |= {"transport/unicast/lowlatency": True, "transport/unicast/qos/enabled": False}
    made = zenoh.Config()
    for key, value in settings.items():
        made.insert_json5(key, json.dumps(value))
    return made


def main() -> int:
    if sys.argv[1] == "sub":
        session = zenoh.open(config(sys.argv[2] == "1", connect=sys.argv[3]))
        session.declare_subscriber("t/x", lambda sample: None)
        time.sleep(3600)
        return 0
    low = sys.argv[1] == "low"
    where = f"tcp/127.0.0.1:{free_port()}"
    session = zenoh.open(config(low, listen=where))
    child = subprocess.Popen([sys.executable, __file__, "sub", "1" if low else "0", where])
    try:
        time.sleep(1.5)
        publisher = session.declare_publisher(
            "t/x", congestion_control=zenoh.CongestionControl.DROP, express=True
        )
        child.send_signal(signal.SIGSTOP)

        def give_up() -> None:  # a put that never returns: say so, end both
            print(f"{sys.argv[1]}: a put was still waiting after 20 s", flush=True)
            child.kill()
            os._exit(1)

        watchdog = threading.Timer(20.0, give_up)
        watchdog.start()
        worst, sent, end = 0.0, 0, time.monotonic() + 6
        while time.monotonic() < end:
            began = time.perf_counter()
            publisher.put(b"x" * 20_000)
            worst, sent = max(worst, time.perf_counter() - began), sent + 1
            time.sleep(0.001)
        watchdog.cancel()
        print(f"{sys.argv[1]}: {sent} puts in 6 s, the longest {worst * 1e3:.1f} ms", flush=True)
    finally:
        child.kill()
        child.wait()
    os._exit(0)  # not session.close(): it may wait for the stopped link


if __name__ == "__main__":
    sys.exit(main())
