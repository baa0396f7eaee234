"""Prototype (not in `make bench`): what a Zenoh push costs in Python, off the network
(issue 24 item 3: "encoding?"). The miner's pc1 runs the nominal scenario in this process
(its modules writing its records); after each of its cycles the sending side does what
rcs/zenoh_transport.py's `push` does before the put (`Mirror.changed` + `Mirror.pack`),
and a receiving mirror of pc2 does what `pull` does with the payload (`Mirror.unpack` +
`Mirror.apply` of each record it reads). Both timed per push on the wall clock (no
network, no threads): if they are small against a hop (bench_zenoh.py: ~200 µs), the hop
is the transport's and its threads', not the encoding.

With `--slow-every N` only every Nth push carries the performance buffers (as a push of
rcs/zenoh_transport.py does at most every PERF_INTERVAL: about every 100th in lockstep);
with `--observer` the receiver applies every record, as a lockstep coordinator's mirror does.

    python bench/prototypes/zenoh_encoding.py [--cycles N] [--slow-every N] [--observer]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_lockstep as lockstep  # noqa: E402
from bench_zenoh import HOOKS, PACKAGE, modules  # noqa: E402

from rcsgen.tools import scenario as scenarios  # noqa: E402
from rcsgen.tools.harness import import_package  # noqa: E402


def measure(cycles: int, slow_every: int = 1, observer: bool = False) -> dict[str, float]:
    package = import_package(PACKAGE, HOOKS)
    layout, block_mod, transport, zt = modules(package)
    scenario = scenarios.load_scenario(lockstep.SCENARIO)
    driver = lockstep.Driver(list(scenario.events), scenario.stop_when_done or "sb")
    harness = scenarios.open_harness(scenario, PACKAGE)
    layout = harness.layout  # the package the harness runs (its records, its block)
    parts: dict[str, list[int]] = {}
    try:
        sender = transport.Mirror(layout, harness.block, "pc1")
        far = block_mod.Block(layout)
        receiver = transport.Mirror(layout, far, "pc2")
        wanted = zt._matcher(transport.reads(layout, None if observer else "pc2", ("pp",)))
        send, receive, sizes, records = [], [], [], []
        for cycle in range(cycles):
            driver.before(harness)
            harness.cycle()
            driver.after(harness)
            began = time.perf_counter_ns()
            messages = sender.changed(slow=not cycle % slow_every)
            found = time.perf_counter_ns()
            payload = sender.pack(messages)
            sent = time.perf_counter_ns()
            unpacked = receiver.unpack(payload) or ()
            split = time.perf_counter_ns()
            applied = 0
            for key, message in unpacked:
                if wanted(key):
                    applied += receiver.apply(key, message)
            done = time.perf_counter_ns()
            send.append(sent - began)
            receive.append(done - sent)
            parts.setdefault("changed", []).append(found - began)
            parts.setdefault("pack", []).append(sent - found)
            parts.setdefault("unpack", []).append(split - sent)
            parts.setdefault("filter_apply", []).append(done - split)
            parts.setdefault("applied", []).append(applied)
            sizes.append(len(payload))
            records.append(len(messages))
        far.close()
    finally:
        harness.close()
    return {
        "cycles": cycles,
        "slow_every": slow_every,
        "observer": observer,
        "records_per_push": statistics.median(records),
        "bytes_per_push": statistics.median(sizes),
        "send_us": statistics.median(send) / 1e3,
        "receive_us": statistics.median(receive) / 1e3,
        **{f"{k}_us": statistics.median(v) / 1e3 for k, v in parts.items() if k != "applied"},
        "records_applied": statistics.median(parts["applied"]),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=3_000)
    parser.add_argument("--slow-every", type=int, default=1)
    parser.add_argument("--observer", action="store_true")
    args = parser.parse_args()
    print(json.dumps(measure(args.cycles, args.slow_every, args.observer), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
