"""Part: fail safe: detection time and time to safe outputs, the two-process miner.

The miner runs as `python -m miner --send sec.BOX_CUT:depth=1.5` (the launcher and its two
processes, paced at 0.1 s, heartbeat_timeout 1 s). Once an actuator is commanded away from
its safe value (the machine moving), one fault is injected:

- kill: SIGKILL of the process;
- stop: SIGSTOP of the process (frozen: alive, silent);
- starve: the process held to about 3 % of a CPU (SIGSTOP 290 ms, SIGCONT 10 ms, repeated):
  it never falls silent for the heartbeat timeout, its watchdog must trip;
- launcher: SIGKILL of the launcher itself.

Measured on the wall clock from the injection, polling the block every 0.5 ms through an
attachment of our own: detection, the first reaction anyone makes visible (a watcher's
`lost` bit for it, its DEAD mark, a watchdog trip, an override latched); safe, every
actuator at its safe value and latched. Goal: both within 3 periods + the heartbeat timeout.
Every launch is stopped (SIGCONT, SIGTERM, SIGKILL) and its segment removed.

    python bench/bench_failsafe.py [--runs N] [--json PATH]
"""

from __future__ import annotations

import argparse
import itertools
import os
import signal
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

from common import ROOT, write_json

sys.path[:0] = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]

from miner import layout  # noqa: E402
from miner.rcs.block import Block, unlink  # noqa: E402
from miner.rcs.contract import StaleRead  # noqa: E402
from miner.rcs.override import overrides  # noqa: E402

RUNS = 10
POLL = 0.0005
DEADLINE = 30.0
CASES = [
    ("pc1", "kill"),
    ("pc1", "stop"),
    ("pc1", "starve"),
    ("pc2", "kill"),
    ("pc2", "stop"),
    ("pc2", "starve"),
    ("launcher", "kill"),
]
_names = itertools.count(1)


def wait_for(condition, what: str, deadline: float = DEADLINE) -> None:
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        if condition():
            return
        time.sleep(0.002)
    raise RuntimeError(f"gave up waiting: {what}")


def read(record, buf: memoryview) -> dict:
    try:
        return record.read(buf)
    except StaleRead:  # being written this instant: look again at the next poll
        return {}


def safe(buf: memoryview) -> bool:
    held = overrides(layout, buf)
    return all(held.get(f, ("", None))[0] == "SAFE" for f in layout.SAFE_VALUES) and all(
        read(layout.WORLD[f], buf).get(f, object()) == v for f, v in layout.SAFE_VALUES.items()
    )


def moving(buf: memoryview) -> bool:
    return any(read(layout.WORLD[f], buf).get(f, v) != v for f, v in layout.SAFE_VALUES.items())


def reacted(buf: memoryview, target: str, trips_before: dict[str, int]) -> bool:
    """Whether anyone made a reaction to `target`'s fault visible in the block."""
    if buf[layout.OVERRIDDEN_AT]:
        return True
    names = list(layout.PROCESSES)
    for name, record in layout.PROCESSES.items():
        values = read(record, buf)
        if not values:
            continue
        if target in names and values["lost"] & (1 << names.index(target)):
            return True
        if name == target and values["state"] == 4:  # DEAD
            return True
        if values["watchdog_trips"] > trips_before.get(name, 0):
            return True
    return False


def starve(pid: int, until: threading.Event) -> None:
    while not until.is_set():
        try:
            os.kill(pid, signal.SIGSTOP)
            until.wait(0.29)
            os.kill(pid, signal.SIGCONT)
            until.wait(0.01)
        except ProcessLookupError:
            return


def one(target: str, fault: str) -> dict[str, float]:
    segment = f"rcs_bench_fs_{os.getpid()}_{next(_names)}"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path[:2]))
    launcher = subprocess.Popen(
        [sys.executable, "-m", "miner", "--shm", segment, "--send", "sec.BOX_CUT:depth=1.5"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    block = None
    stop_starving = threading.Event()
    pids: list[int] = []
    try:
        wait_for(lambda: os.path.exists(f"/dev/shm/{segment}"), "the segment")
        time.sleep(0.05)
        block = Block(layout, segment, create=False)
        buf = block.buf
        wait_for(lambda: moving(buf), "the miner moving")
        records: dict[str, dict] = {}  # each control record, read whole (a beat may be going on)
        for name, record in layout.PROCESSES.items():
            wait_for(lambda n=name, r=record: records.update({n: read(r, buf)}) or records[n], name)
        pids = [int(r["pid"]) for r in records.values()]
        trips = {n: int(r["watchdog_trips"]) for n, r in records.items()}
        pid = launcher.pid if target == "launcher" else int(records[target]["pid"])
        began = time.monotonic()
        if fault == "kill":
            os.kill(pid, signal.SIGKILL)
        elif fault == "stop":
            os.kill(pid, signal.SIGSTOP)
        else:
            threading.Thread(target=starve, args=(pid, stop_starving), daemon=True).start()
        detected = at_safe = None
        while time.monotonic() - began < DEADLINE and at_safe is None:
            now = time.monotonic() - began
            if detected is None and reacted(buf, target, trips):
                detected = now
            if at_safe is None and safe(buf):
                at_safe = now
                detected = now if detected is None else detected
            time.sleep(POLL)
        if at_safe is None:
            raise RuntimeError(f"{target} {fault}: not safe within {DEADLINE} s")
        return {"detected_s": detected, "safe_s": at_safe}
    finally:
        stop_starving.set()
        for p in [launcher.pid, *pids]:
            try:
                os.kill(p, signal.SIGCONT)
            except (ProcessLookupError, PermissionError):
                pass
        if launcher.poll() is None:
            launcher.terminate()
            try:
                launcher.wait(15)
            except subprocess.TimeoutExpired:
                launcher.kill()
                launcher.wait()
        for p in pids:  # a child of a killed launcher stops on its own: make sure
            end = time.monotonic() + 10
            while time.monotonic() < end:
                try:
                    os.kill(p, 0)
                except ProcessLookupError:
                    break
                time.sleep(0.01)
            else:
                try:
                    os.kill(p, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        if block is not None:
            block.close()
        unlink(segment)


def summary(values: list[float]) -> dict[str, float]:
    return {"min": min(values), "median": statistics.median(values), "max": max(values)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=RUNS)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    period = 0.1
    results = {
        "system": "miner",
        "cycle_period_s": period,
        "heartbeat_timeout_s": layout.HEARTBEAT_TIMEOUT,
        "goal_s": 3 * period + layout.HEARTBEAT_TIMEOUT,
        "cases": [],
    }
    for target, fault in CASES:
        runs = [one(target, fault) for _ in range(args.runs)]
        case = {
            "target": target,
            "fault": fault,
            "runs": len(runs),
            "detected_s": summary([r["detected_s"] for r in runs]),
            "safe_s": summary([r["safe_s"] for r in runs]),
        }
        results["cases"].append(case)
        print(
            f"{target:8} {fault:6} detected {case['detected_s']['median']:.3f} s "
            f"(max {case['detected_s']['max']:.3f}), safe {case['safe_s']['median']:.3f} s "
            f"(max {case['safe_s']['max']:.3f})",
            file=sys.stderr,
            flush=True,
        )
    if args.json:
        write_json(args.json, results)
    else:
        print(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
