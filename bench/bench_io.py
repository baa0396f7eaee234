"""Part: fieldbus I/O over Modbus TCP and OPC UA on loopback (issue 27): its cost, its effect.

The soft PLC (`python -m rcsgen.tools.softplc`, its own OS process) serves miner_hil's `plc`
device (Modbus TCP) and `conveyor` device (OPC UA, the conveyor subsystem), the miner's
actuator, sensor, mine and operator simulators behind both. Three figures:

1. The I/O module's cost per cycle: miner_hil's pc1 in this process (the harness), paced
   at its period (0.05 s), the machine cutting; each cycle's `before` (the device's latest
   inputs copied into the world fields) and `after` (the outputs handed to the device's
   thread), both devices, timed with perf_counter_ns: median and p99. The protocols run on
   the devices' threads; each one's round trip per poll (every input read, every output
   written) is reported from the device's record too.
2. The box cut's cycle time with and without hardware in the loop: the whole system's
   modules per cycle, median and p99 (in one process: pc1 and pc2 run by the harness); the
   miner in simulation (its simulators in the cycle), and miner_hil with the simulators in
   the PLC and the I/O module in the cycle instead. Also the cycles and the wall time each
   box cut took (the HIL one paced: it runs in real time, as the PLC does).
3. Detection of a device that stops answering: `python -m miner_hil` paced (two OS
   processes), the PLC frozen (SIGSTOP) `--runs` times; from the stop to the device's
   record LOST, and to every actuator latched safe, polling the block every 0.5 ms. Goal:
   the device's timeout + 1 cycle. Between runs: SIGCONT, the device online again, reset.

Every process started is stopped and every segment removed on the way out.

    python bench/bench_io.py [--cycles N] [--runs N] [--json PATH]
"""

from __future__ import annotations

import argparse
import importlib
import itertools
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from common import ROOT, write_json

from rcsgen.tools.harness import Harness, import_package

GENERATED = ROOT / "generated"
SPECS = ROOT / "specs"
POLL = 0.0005
_names = itertools.count()


def wait_for(condition: Any, what: str, deadline: float = 60.0, poll: float = 0.005) -> Any:
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(poll)
    raise SystemExit(f"gave up waiting: {what}")


def percentile(values: list[float], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


def figures(values: list[float]) -> dict[str, float]:
    return {
        "median": statistics.median(values),
        "min": min(values),
        "p99": percentile(values, 0.99),
        "max": max(values),
        "n": len(values),
    }


class Plc:
    """The soft PLC of miner_hil's `plc` and `conveyor`, the miner's simulators behind."""

    def __init__(self, scratch: Path, port: int = 0) -> None:
        ready = scratch / f"plc{next(_names)}.port"
        self.popen = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rcsgen.tools.softplc",
                *("--plant", str(GENERATED / "miner"), "--hooks", str(SPECS / "miner")),
                *("--io", str(GENERATED / "miner_hil"), "--device", "plc", "--port", str(port)),
                *("--device", "conveyor", "--port", "0"),
                *("--ready", str(ready), "--set", "map=maps/box_cut.map"),
            ],
            cwd=ROOT,
            start_new_session=True,
        )
        wait_for(lambda: ready.is_file() and ready.read_text().count("\n") == 2, "the PLC", 120)
        self.port, self.conveyor = (int(line) for line in ready.read_text().split())

    @property
    def environ(self) -> dict[str, str]:
        """Each device pointed at its server."""
        return {
            "RCSGEN_IO_PLC": f"127.0.0.1:{self.port}",
            "RCSGEN_IO_CONVEYOR": f"opc.tcp://127.0.0.1:{self.conveyor}/miner",
        }

    def stop(self) -> None:
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGCONT)
            self.popen.terminate()
            try:
                self.popen.wait(20)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


def timed(function: Any, into: list[float]) -> Any:
    def wrapper() -> None:
        began = time.perf_counter_ns()
        function()
        into.append(time.perf_counter_ns() - began)

    return wrapper


def box_cut(harness: Harness, period: float | None, limit: int = 2000) -> dict[str, Any]:
    """Run the box cut on `harness` (paced at `period`, else flat out): each cycle's time."""
    harness.cycle(5)
    harness.command("sec", "BOX_CUT", depth=1.5)
    took: list[float] = []
    began = time.perf_counter()
    next_at = time.monotonic()
    for _ in range(limit):
        start = time.perf_counter_ns()
        harness.cycle()
        took.append(time.perf_counter_ns() - start)
        if harness.status("sec").status in ("DONE", "ERROR"):
            break
        if period:
            next_at += period
            time.sleep(max(0.0, next_at - time.monotonic()))
    return {
        "status": harness.status("sec").status,
        "cycles": len(took),
        "wall_s": time.perf_counter() - began,
        "cycle_ns": figures(took),
    }


def in_the_loop(scratch: Path) -> dict[str, Any]:
    """Figures 1 and 2: miner_hil in this process, bound to a PLC; the miner simulated."""
    plc = Plc(scratch)
    os.environ.update(plc.environ)
    try:
        package = import_package(GENERATED / "miner_hil", SPECS / "miner_hil")
        harness = Harness(package, send_init=True, settings={"map": "maps/box_cut.map"})
        try:
            pc1 = harness.processes["pc1"]
            io, period = pc1.io, pc1.plan.cycle_period
            before: list[float] = []
            after: list[float] = []
            trips: dict[str, list[float]] = {name: [] for name in io.runners}
            seen = dict.fromkeys(io.runners, 0)

            def timed_before() -> None:
                began = time.perf_counter_ns()
                io.before()
                before.append(time.perf_counter_ns() - began)
                for name, runner in io.runners.items():
                    seq, _, counts = runner.snapshot()  # a new exchange: its round trip
                    if seq != seen[name]:
                        seen[name] = seq
                        trips[name].append(float(counts["round_trip_ns"]))

            def timed_after() -> None:
                began = time.perf_counter_ns()
                io.after()
                after.append(time.perf_counter_ns() - began)

            # the I/O's read and write, around the process's modules: time them
            pc1.io_steps = ((timed_before,), (timed_after,))
            hil = box_cut(harness, period)
        finally:
            harness.close()
    finally:
        plc.stop()
        for name in plc.environ:
            del os.environ[name]
    devices = harness.layout.IO_DEVICES
    miner = import_package(GENERATED / "miner", SPECS / "miner")
    simulated = Harness(miner, send_init=True, settings={"map": "maps/box_cut.map", "seed": "7"})
    try:
        sim = box_cut(simulated, None)
    finally:
        simulated.close()
    return {
        "devices": {
            name: {
                "protocol": d.protocol,
                "points": len(d.points),
                "inputs": len(d.inputs),
                "poll_period_s": d.poll_period,
                "round_trip_ns": figures(trips[name]),
            }
            for name, d in devices.items()
        },
        "cycle_period_s": period,
        "before_ns": figures(before),
        "after_ns": figures(after),
        "both_ns": figures([a + b for a, b in zip(before, after, strict=False)]),
        "hil": hil,
        "simulated": sim,
    }


def detection(scratch: Path, runs: int) -> dict[str, Any]:
    """Figure 3: the PLC frozen under a paced `python -m miner_hil`: stop -> LOST, -> safe."""
    package = import_package(GENERATED / "miner_hil", SPECS / "miner_hil")
    layout = importlib.import_module(f"{package.__name__}.layout")
    ctl = importlib.import_module(f"{package.__name__}.rcs.operate.ctl")
    override = importlib.import_module(f"{package.__name__}.rcs.override")
    device = layout.IO_DEVICES["plc"]
    record = layout.IO_RECORDS["plc"]
    plc = Plc(scratch)
    segment = f"rcsgen_bench_io_{os.getpid()}"
    env = {**os.environ, **plc.environ, "PYTHONPATH": str(SPECS / "miner_hil")}
    system = subprocess.Popen(
        [sys.executable, "-m", "miner_hil", "--shm", segment],
        cwd=GENERATED,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    lost_s: list[float] = []
    safe_s: list[float] = []
    console = None
    try:

        def attach() -> Any:
            try:
                return ctl.Console(layout, segment)
            except Exception:  # noqa: BLE001 - not there yet
                return None

        console = wait_for(attach, "miner_hil's segment")
        buf = console.buf

        def state() -> int:
            try:
                return int(record.read(buf)["state"])
            except Exception:  # noqa: BLE001 - a torn read: look again
                return -1

        safe = dict(layout.SAFE_VALUES)
        for _ in range(runs):
            wait_for(lambda: state() == 1, "the PLC online")
            time.sleep(1.0)  # polls going on
            plc.popen.send_signal(signal.SIGSTOP)
            began = time.perf_counter()
            lost = latched = None
            while lost is None or latched is None:
                now = time.perf_counter() - began
                if now > 30:
                    raise SystemExit("the PLC's loss was not detected in 30 s")
                if lost is None and state() == 2:
                    lost = now
                if latched is None and len(override.overrides(layout, buf)) == len(safe):
                    latched = now
                time.sleep(POLL)
            lost_s.append(lost)
            safe_s.append(latched)
            plc.popen.send_signal(signal.SIGCONT)
            wait_for(lambda: state() == 1, "the PLC online again")
            override.reset(layout, buf, segment=segment)
    finally:
        if console is not None:
            console.close()
        system.send_signal(signal.SIGINT)
        try:
            system.wait(30)
        except subprocess.TimeoutExpired:
            system.kill()
            system.wait()
        plc.stop()
    period = float(importlib.import_module(f"{package.__name__}.main_pc1").PLAN.cycle_period)
    return {
        "timeout_s": device.timeout,
        "poll_period_s": device.poll_period,
        "cycle_period_s": period,
        "goal_s": device.timeout + period,
        "runs": runs,
        "lost_s": figures(lost_s),
        "safe_s": figures(safe_s),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--json")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-io-") as scratch:
        result = in_the_loop(Path(scratch))
        result["detection"] = detection(Path(scratch), args.runs)
    write_json(args.json, result)


if __name__ == "__main__":
    main()
