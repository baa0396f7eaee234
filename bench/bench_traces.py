"""Part 11: the trace tools: `rcsgen trace show` of a 20,000-cycle trace; the goldens' size.

The long trace is tests/golden/around_pillar.jsonl's cycles repeated (renumbered) up to
20,000 cycles, written into a scratch directory three ways: as `rcsgen run` writes it (a
full line every KEYFRAME cycles, the changes in between: traces/stored.py), the same
gzipped, and every line full (a trace written before that format). For each:

- `rcsgen trace show TRACE -o PAGE` as a user runs it (the specs of specs/ read to find the
  system that recorded it), each run a fresh process: its CPU seconds (user + system) and
  peak RSS from the kernel's accounting of the finished child (`os.wait4`); the median and
  min-max over the runs;
- in one fresh worker interpreter, the same command's steps timed apart (CPU): the imports,
  reading the trace (`traces.load`), checking the specs (`trace_system`), the page (`render`).

The golden traces (tests/golden/**/*.jsonl): their bytes as stored, their full lines
(`traces.expanded`: what the stored form stands for) as text and gzipped, and the stored
form gzipped as `rcsgen run --trace X.jsonl.gz` writes it (`read.compressed`).

    python bench/bench_traces.py [--cycles N] [--runs R] [--json PATH]
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from common import ROOT, write_json

CYCLES = 20_000
RUNS = 5
SOURCE = ROOT / "tests" / "golden" / "around_pillar.jsonl"


def long_trace(cycles: int, path: Path, packed: Path, full: Path) -> Path:
    """SOURCE's cycles over and over, numbered 1..cycles, written as stored to `path`, the
    same gzipped to `packed` and as full lines to `full`, line by line: this process must
    stay small, as the kernel counts a child's peak RSS from before its exec (the parent's
    pages it started with)."""
    from rcsgen.tools.traces import condensed, expanded

    text = SOURCE.read_text("utf-8").splitlines()
    lines = [line for line in expanded(text) if '"interrupted"' not in line]

    def renumbered() -> Iterator[str]:
        for n in range(cycles):
            line = lines[n % len(lines)]
            yield f'{{"cycle":{n + 1}{line[line.index(",") :]}'

    with full.open("w", encoding="utf-8") as out:
        for line in renumbered():
            out.write(line + "\n")
    with (
        path.open("w", encoding="utf-8") as out,
        gzip.GzipFile(packed, "wb", mtime=0) as gz,
    ):
        for line in condensed(renumbered()):
            out.write(line + "\n")
            gz.write((line + "\n").encode("utf-8"))
    return path


def show_run(trace: Path, page: Path) -> dict[str, float]:
    """One `rcsgen trace show` in a fresh process: CPU seconds and peak RSS (MiB)."""
    rcsgen = Path(sys.executable).with_name("rcsgen")
    child = subprocess.Popen(
        [str(rcsgen), "trace", "show", str(trace), "-o", str(page)],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    start = time.perf_counter()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise SystemExit(f"rcsgen trace show {trace} failed ({child.returncode})")
    return {
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "wall_s": time.perf_counter() - start,
        "rss_mib": usage.ru_maxrss / 1024,
    }


def worker(trace: Path) -> dict[str, float]:
    """The steps of `trace show` in this (fresh) interpreter, CPU seconds each."""
    clock = time.process_time
    start = clock()
    from rcsgen import terminal
    from rcsgen.tools import traces
    from rcsgen.tools.traces import view

    imported = clock()
    found = traces.load(trace)
    loaded = clock()
    system = terminal.trace_system(None, [found], required=False)
    checked = clock()
    name, period = (system.name, system.cycle_period) if system else (None, None)
    page = view.render(found, traces.lanes(found, system), name, period)
    rendered = clock()
    return {
        "import_s": imported - start,
        "load_s": loaded - imported,
        "specs_s": checked - loaded,
        "render_s": rendered - checked,
        "page_bytes": len(page.encode("utf-8")),
    }


def goldens() -> dict[str, int]:
    """The golden traces: their bytes as stored (a `.jsonl.gz` one gzipped); their full lines
    as text and gzipped; the stored form gzipped the way `rcsgen run --trace X.jsonl.gz`
    writes a trace."""
    from rcsgen.tools.traces import expanded
    from rcsgen.tools.traces.read import compressed, decompressed

    folder = ROOT / "tests" / "golden"
    files = sorted([*folder.rglob("*.jsonl"), *folder.rglob("*.jsonl.gz")])
    stored = [path.read_bytes() for path in files]
    texts = [decompressed(data, 1 << 30).decode("utf-8") for data in stored]
    full = ["".join(f"{line}\n" for line in expanded(text.splitlines())) for text in texts]
    return {
        "files": len(files),
        "gzipped_files": sum(path.name.endswith(".gz") for path in files),
        "cycles": sum(text.count("\n") for text in texts),
        "stored_bytes": sum(len(data) for data in stored),
        "bytes": sum(len(text.encode("utf-8")) for text in full),
        "gzipped_bytes": sum(len(compressed(text)) for text in full),
        "stored_gzipped_bytes": sum(len(compressed(text)) for text in texts),
    }


def summary(values: list[float]) -> dict[str, float]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=CYCLES)
    parser.add_argument("--runs", type=int, default=RUNS)
    parser.add_argument("--json", default=None)
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker)))
        return 0
    started = time.perf_counter()
    results = {}
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-traces-") as scratch:
        packed, full = Path(scratch) / "long.jsonl.gz", Path(scratch) / "full.jsonl"
        plain = long_trace(args.cycles, Path(scratch) / "long.jsonl", packed, full)
        for key, trace in (("plain", plain), ("gzip", packed), ("full", full)):
            page = Path(scratch) / f"{key}.html"
            show_run(trace, page)  # warm-up: bytecode, the page cache
            runs = [show_run(trace, page) for _ in range(args.runs)]
            steps = subprocess.run(
                [sys.executable, __file__, "--worker", str(trace)],
                cwd=ROOT,
                check=True,
                capture_output=True,
                text=True,
            )
            results[key] = {
                "bytes": trace.stat().st_size,
                "cpu_s": summary([r["cpu_s"] for r in runs]),
                "wall_s": summary([r["wall_s"] for r in runs]),
                "rss_mib": summary([r["rss_mib"] for r in runs]),
                "steps_s": json.loads(steps.stdout),
            }
    write_json(
        args.json,
        {
            "cycles": args.cycles,
            "runs": args.runs,
            "source": str(SOURCE.relative_to(ROOT)),
            "show": results,
            "goldens": goldens(),
            "seconds": time.perf_counter() - started,
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
