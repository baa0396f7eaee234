"""Shared by the benchmark scripts: paths, the machine and versions, statistics, formatting."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
PEERS = ("transitions", "python-statemachine", "sismic")
TOOLS = ("rcsgen", "ruff", "jinja2", "pyyaml")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def versions(names: tuple[str, ...]) -> dict[str, str]:
    out = {}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def git_revision() -> str:
    def git(*args: str) -> str:
        done = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return done.stdout.strip() if done.returncode == 0 else ""

    revision = git("rev-parse", "--short", "HEAD") or "unknown"
    # the report a previous run rewrote is no change to what is measured
    changed = git("status", "--porcelain", "--", ".", ":(exclude)bench/RESULTS.md")
    return revision + (" + uncommitted changes" if changed else "")


def machine() -> dict[str, object]:
    return {
        "cpu": cpu_model(),
        "cores": os.cpu_count(),
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "os": f"{platform.system()} {platform.release()}",
        "revision": git_revision(),
        "peers": versions(PEERS),
        "tools": versions(TOOLS),
    }


# Code that runs in one thread and never waits is timed in CPU time (the thread's, from
# the kernel): on a shared machine the time the process spends descheduled while other
# work runs does not count against it. Reading this clock is a system call (~0.6 µs here,
# and it disturbs the code timed after it), so it times long stretches: thousands of
# cycles, or a whole system cycle less `clock_overhead()`. Single steps and modules are
# timed on the wall clock (`wall_ns`, no system call), dropping every cycle in which one
# of them took longer than `PREEMPTED_NS` (the process was descheduled meanwhile). Runs of
# several processes, which wait for each other, are timed on the wall clock.
cpu_ns = time.thread_time_ns
wall_ns = time.perf_counter_ns
PREEMPTED_NS = 1_000_000  # nothing timed one by one takes a millisecond unless descheduled


def clock_overhead(clock=cpu_ns, samples: int = 2_000) -> int:
    """The least time two back-to-back readings of `clock` report: what one timed call adds."""
    return min(-clock() + clock() for _ in range(samples))


def summary(values: list[float]) -> dict[str, float]:
    """Median, min and max of repeated measurements."""
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def ns(value: float) -> str:
    """A duration in nanoseconds, to three significant figures, in a readable unit."""
    for unit, scale in (("s", 1e9), ("ms", 1e6), ("µs", 1e3)):
        if abs(value) >= scale:
            return f"{value / scale:.3g} {unit}"
    return f"{value:.0f} ns"


def ratio(value: float) -> str:
    return f"{value:.2f}×" if value < 10 else f"{value:.0f}×"


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def write_json(path: str | None, data: object) -> None:
    text = json.dumps(data, indent=2)
    if path:
        Path(path).write_text(text + "\n")
    else:
        sys.stdout.write(text + "\n")


def read_whole(record, buf: memoryview, deadline: float = 20.0, poll: float = 0.0005) -> dict:
    """A record of a running system, read whole: `Record.read` gives up (StaleRead) when
    its writer is writing, or was descheduled mid-write (a busy host), so read it again,
    for `deadline` seconds at most (then the writer died mid-write: StaleRead)."""
    from rcsgen.runtime.contract import StaleRead  # one class for every package's copy

    end = time.monotonic() + deadline
    while True:
        try:
            return record.read(buf)
        except StaleRead:
            if time.monotonic() > end:
                raise
            time.sleep(poll)
