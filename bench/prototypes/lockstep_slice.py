"""Lockstep with a short scheduler slice (issue 24 item 2): does asking the kernel for a
short EEVDF slice (sched_setattr's `sched_runtime` for a SCHED_OTHER task, Linux 6.12+)
make a ring member's wake-up cheaper on a machine busy with other work?

A woken task under EEVDF preempts the one running only where its virtual deadline is
earlier; a task's deadline is its slice ahead, so a task that asks for a short slice
(0.1 ms against the default ~1.4 ms here) preempts sooner, with the same weight (the same
share of the CPU: nobody is starved). Children inherit the attribute over fork and exec,
so a version launched while the harness's slice is short has every member short.

Versions, taking turns every CHUNK cycles (in alternating order), ending each round in
the same state: the miner (or the 16-chain over `--splits`) in one process, in the ring as
it is, and in the ring with every member and the coordinator on a short slice (`--slice`
µs). The coordinator's own slice is set each time its version's turn begins. `--bare`
adds the bare ring of `--members` forked members (bench_lockstep.token_ring), both ways.

    bench/.venv/bin/python bench/prototypes/lockstep_slice.py [--cycles 600] [--rounds 2]
        [--slice 100] [--parts miner,chain,bare] [--splits 1,2]
"""

from __future__ import annotations

import argparse
import ctypes
import itertools
import json
import os
import shutil
import statistics
import struct
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_lockstep as lockstep  # noqa: E402
from common import wall_ns  # noqa: E402

from rcsgen.tools import scenario as scenarios  # noqa: E402
from rcsgen.tools.harness import Harness, LaunchedHarness, generate  # noqa: E402

ATTR = struct.Struct("=IIQiIQQQII")  # struct sched_attr (56 bytes)
SETATTR, GETATTR = 314, 315  # x86-64
LIBC = ctypes.CDLL(None, use_errno=True)


def get_slice() -> int:
    buf = ctypes.create_string_buffer(ATTR.size)
    if LIBC.syscall(GETATTR, 0, buf, ATTR.size, 0) != 0:
        raise OSError(ctypes.get_errno(), "sched_getattr")
    return int(ATTR.unpack(buf.raw)[5])


def set_slice(ns: int) -> None:
    """This thread's slice (SCHED_OTHER, nice 0 kept); 0: the kernel's default."""
    nice = os.getpriority(os.PRIO_PROCESS, 0)
    buf = ctypes.create_string_buffer(ATTR.pack(ATTR.size, 0, 0, nice, 0, ns, 0, 0, 0, 0))
    if LIBC.syscall(SETATTR, 0, buf, 0) != 0:
        raise OSError(ctypes.get_errno(), "sched_setattr")


def race(
    open_versions: Callable[[], dict[str, tuple[object, int]]],
    driver_of: Callable[[], lockstep.Driver],
    cycles: int,
    rounds: int,
) -> dict[str, list[int]]:
    samples: dict[str, list[int]] = {}
    for index in range(rounds):
        versions = open_versions()
        try:
            drivers = {key: driver_of() for key in versions}
            keys = list(versions)
            for number, start in enumerate(range(0, cycles, lockstep.CHUNK)):
                for key in keys if (index + number) % 2 == 0 else keys[::-1]:
                    (harness, ns), driver = versions[key], drivers[key]
                    set_slice(ns)
                    taken = samples.setdefault(key, [])
                    for _ in range(min(lockstep.CHUNK, cycles - start)):
                        driver.before(harness)
                        began = wall_ns()
                        harness.cycle()  # type: ignore[attr-defined]
                        taken.append(wall_ns() - began)
                        driver.after(harness)
            ends = [lockstep.state(h) for h, _ in versions.values()]
            if any(end != ends[0] for end in ends[1:]):
                raise SystemExit(f"round {index + 1}: the versions ended in different states")
        finally:
            set_slice(0)
            for harness, _ in versions.values():
                harness.close()  # type: ignore[attr-defined]
    return samples


_launches = itertools.count()


def launched_both(
    opened: dict[str, tuple[object, int]], make: Callable[[], object], ns: int
) -> None:
    """Both rings into `opened`, started in the other order every other call."""
    kinds = (("ring", 0), ("ring, short slice", ns))
    for key, slice_ns in kinds[:: 1 if next(_launches) % 2 == 0 else -1]:
        set_slice(slice_ns)
        try:
            opened[key] = (make(), slice_ns)
        finally:
            set_slice(0)


def summary(samples: dict[str, list[int]]) -> dict[str, object]:
    out: dict[str, object] = {
        key: {
            "median_us": statistics.median(v) / 1e3,
            "mean_us": round(statistics.fmean(v) / 1e3, 1),
        }
        for key, v in samples.items()
    }
    one = statistics.median(samples["one process"])
    for key in samples:
        if key != "one process":
            out[f"extra {key}"] = round((statistics.median(samples[key]) - one) / 1e3, 1)
    return out


def miner(cycles: int, rounds: int, ns: int) -> dict[str, object]:
    scenario = scenarios.load_scenario(lockstep.SCENARIO)
    events, stop = list(scenario.events), scenario.stop_when_done or "sb"
    where = (lockstep.PACKAGE, scenario.system_dir, scenario.settings, scenario.simulate)

    def open_versions() -> dict[str, tuple[object, int]]:
        opened: dict[str, tuple[object, int]] = {
            "one process": (scenarios.open_harness(scenario, lockstep.PACKAGE), 0)
        }
        launched_both(opened, lambda: LaunchedHarness(*where), ns)
        return opened

    return summary(race(open_versions, lambda: lockstep.Driver(events, stop), cycles, rounds))


def chain(splits: tuple[int, ...], cycles: int, rounds: int, ns: int) -> dict[str, object]:
    import synthetic

    results: dict[str, object] = {}
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-slice-"))
    try:
        for count in splits:
            spec = synthetic.write(
                lockstep.CHAIN, scratch / f"p{count}", processes=count, fan_out=1
            )
            out, name = generate(spec)
            package = out / name
            root = synthetic.name(0)
            run = scenarios.Event(cycle=1, command=(root, "RUN"))

            def open_versions(package: Path = package) -> dict[str, tuple[object, int]]:
                opened: dict[str, tuple[object, int]] = {
                    "one process": (Harness.load(package, send_init=True), 0)
                }
                launched_both(opened, lambda: LaunchedHarness(package), ns)
                return opened

            def driver(run: scenarios.Event = run, root: str = root) -> lockstep.Driver:
                return lockstep.Driver([run], root)

            samples = race(open_versions, driver, cycles, rounds)
            results[str(count)] = summary(samples)
            shutil.rmtree(out, ignore_errors=True)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return results


def bare(members: tuple[int, ...], cycles: int, rounds: int, ns: int) -> dict[str, object]:
    from rcsgen.runtime import ring

    results: dict[str, object] = {}
    for count in members:
        samples: dict[str, list[int]] = {"default": [], "short slice": []}
        for index in range(rounds * 2):
            key = ("default", "short slice")[(index + index // 2) % 2]
            set_slice(ns if key == "short slice" else 0)
            try:
                samples[key] += lockstep.token_ring(count, cycles, ring.default_spin(), True)
            finally:
                set_slice(0)
        results[str(count)] = {
            key: {
                "median_us": statistics.median(v) / 1e3,
                "mean_us": round(statistics.fmean(v) / 1e3, 1),
            }
            for key, v in samples.items()
        }
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=600)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--slice", type=float, default=100.0, help="µs (0.1 ms is the least)")
    parser.add_argument("--parts", default="miner,chain,bare")
    parser.add_argument("--splits", default="1,2")
    args = parser.parse_args()
    ns, parts = int(args.slice * 1e3), args.parts.split(",")
    splits = tuple(int(n) for n in args.splits.split(","))
    print(f"default slice {get_slice()} ns", file=sys.stderr)
    result: dict[str, object] = {"load_before": os.getloadavg()[0], "slice_us": args.slice}
    if "miner" in parts:
        result["miner"] = miner(args.cycles, args.rounds, ns)
    if "chain" in parts:
        result["chain"] = chain(splits, args.cycles, args.rounds, ns)
    if "bare" in parts:
        result["bare"] = bare(splits, max(args.cycles, 2000), args.rounds, ns)
    result["load_after"] = os.getloadavg()[0]
    print(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
