"""Part 14: a 10 ms period on a stock kernel, quiet and under a competing busy loop.

A paced loop (rcs/loop.py's Pacer with its Periodicity, what a free-running process
uses) runs a small cycle of work (~0.2 ms of Python) every 10 ms, and records each
wake-up: its lateness past the period boundary, the period error, the overruns (period
boundaries a cycle or a stall ran past). Variants, each `--cycles` wake-ups:

- quiet: nothing of ours competes (the machine's other load is whatever it is);
- busy: a forked process spinning flat out, on every CPU this one may use;
- busy + gc freeze + FIFO: the same, with the realtime settings `gc: freeze` and
  `fifo_priority: 10` applied (rcs/realtime.py; refused without CAP_SYS_NICE: then the
  figure says so, and is the busy one again).

And the ablation: what the periodicity bookkeeping costs per wake-up (Pacer.wait on a
fake clock with and without a Periodicity).

    python bench/bench_period.py [--cycles N] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from struct import Struct

from common import write_json

from rcsgen.runtime import realtime
from rcsgen.runtime.contract import (
    PERIODICITY_FIELDS,
    PROCESS,
    PROCESS_FIELDS,
    field_names,
    struct_format,
)
from rcsgen.runtime.loop import Pacer, Periodicity

PERIOD = 0.010
CYCLES = 1_000


def work() -> int:
    total = 0
    for i in range(4_000):
        total += i * i % 7
    return total


def paced(cycles: int, settings: dict[str, object]) -> dict[str, object]:
    """Run `cycles` paced cycles in a child (the settings stay with it); its figures."""
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read)
        refused = realtime.apply("bench", settings) if settings else []
        periodicity = Periodicity("bench", PERIOD, lambda line: None)
        pacer = Pacer(PERIOD, periodicity=periodicity)
        took = []
        for _ in range(cycles):
            began = time.perf_counter_ns()
            work()
            took.append(time.perf_counter_ns() - began)
            pacer.wait()
        result = {
            "wake_ups": periodicity.count,
            "overruns": pacer.overruns,
            "late_p50_us": periodicity.quantile(0.5) * 1e6,  # the histogram's: within 1/16
            "late_p99_us": periodicity.p99() * 1e6,
            "late_max_us": periodicity.late_max * 1e6,
            "period_error_mean_us": periodicity.error_sum / max(1, periodicity.count) * 1e6,
            "period_error_max_us": periodicity.error_max * 1e6,
            "work_median_us": sorted(took)[len(took) // 2] / 1e3,
            "refused": refused,
        }
        os.write(write, repr(result).encode())
        os._exit(0)
    os.close(write)
    data = b""
    while chunk := os.read(read, 65536):
        data += chunk
    os.close(read)
    os.waitpid(pid, 0)
    return eval(data.decode())  # noqa: S307 - our own child's repr of a dict of numbers


def spinners() -> list[int]:
    pids = []
    for cpu in sorted(os.sched_getaffinity(0)):
        pid = os.fork()
        if pid == 0:
            os.sched_setaffinity(0, {cpu})
            while True:
                pass
        pids.append(pid)
    return pids


def stop(pids: list[int]) -> None:
    for pid in pids:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)


def ablation(calls: int = 100_000, rounds: int = 5) -> dict[str, float]:
    """ns per Pacer.wait on a fake clock (no real sleep), with and without Periodicity:
    the two take turns, `rounds` each; the fastest round of each (the least disturbed)."""

    class Clock:
        now = 0.0

        def __call__(self) -> float:
            return self.now

        def sleep(self, seconds: float) -> None:
            self.now += seconds + 1e-5

    names = field_names(PERIODICITY_FIELDS)
    before = Struct(struct_format(PROCESS_FIELDS[: -len(PERIODICITY_FIELDS)]))
    best: dict[str, float] = {}
    for _ in range(rounds):
        for key in ("without", "with", "published"):
            clock = Clock()
            periodicity = Periodicity("b", 0.01) if key != "without" else None
            pacer = Pacer(0.01, clock, clock.sleep, 0.1, periodicity)
            counters = dict.fromkeys(field_names(PROCESS_FIELDS), 0)
            record = PROCESS if key == "published" else before
            values = list(counters.values())[: len(PROCESS_FIELDS) - len(names)]
            buf = bytearray(PROCESS.size)
            began = time.perf_counter_ns()
            if key == "published":  # as run() does: the figures into the record every cycle
                for _ in range(calls):
                    pacer.wait()
                    if not periodicity.count % periodicity.REFRESH:  # type: ignore[union-attr]
                        counters.update(zip(names, periodicity.fields(), strict=True))  # type: ignore[union-attr]
                    record.pack_into(buf, 0, 1, *counters.values())
            else:
                for _ in range(calls):
                    pacer.wait()
                    record.pack_into(buf, 0, 1, *values)
            taken = (time.perf_counter_ns() - began) / calls
            best[f"{key}_ns"] = min(best.get(f"{key}_ns", taken), taken)
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=CYCLES)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    results: dict[str, object] = {"period_s": PERIOD, "cycles": args.cycles}
    results["quiet"] = paced(args.cycles, {})
    busy = spinners()
    try:
        results["busy"] = paced(args.cycles, {})
        results["busy_realtime"] = paced(args.cycles, {"gc": "freeze", "fifo_priority": 10})
    finally:
        stop(busy)
    results["spinners"] = len(busy)
    results["ablation"] = ablation()
    write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
