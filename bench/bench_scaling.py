"""Part 3: generator scaling on synthetic systems of 10 to 1,000 controllers.

For each size, bench/synthetic.py writes a system into a scratch directory, then:

- a worker process (a fresh interpreter per run) builds it as `rcsgen build` does and
  times each step: the front end (`compile_paths`: load, schema, model, check, analysis,
  lower, each phase timed by wrapping the front end's functions), the render
  (`emit.render_system`, Jinja), the format (`emit.format_files`, one ruff run) and the
  writing of the files; it reports its peak RSS and the whole build's CPU seconds (its own
  and ruff's). The run of median build time is kept.
- `rcsgen build DIR -o OUT` runs once as a user would run it (interpreter start-up and
  printing the diagnostics included), timed by wall clock. Growth per doubling of the system is
(t(1000) / t(100)) ** (log 2 / log 10); the log-log slope over all sizes from 100 up is
given too.

    python bench/bench_scaling.py [--sizes 10,100,...] [--repeat R] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import BENCH, write_json

SIZES = (10, 100, 200, 500, 1000)
REPEAT = 3
FRONT_PHASES = {  # frontend-module name -> phase
    "_load": "load (YAML)",
    "check_document": "schema",
    "build_system": "model",
    "build_controller": "model",
    "check_system": "check",
    "analyse_system": "analysis",
    "lower_system": "lower",
}


def timed_phases(clock) -> dict[str, float]:
    """The front end's phase functions wrapped (in this interpreter) so that each adds the
    time it takes on `clock` to its phase's entry of the dict returned."""
    from rcsgen.compiler import frontend

    phases = {phase: 0.0 for phase in FRONT_PHASES.values()}

    def timed(function, phase):
        def wrapper(*args, **kwargs):
            start = clock()
            try:
                return function(*args, **kwargs)
            finally:
                phases[phase] += clock() - start

        return wrapper

    for name, phase in FRONT_PHASES.items():
        owner = frontend.model if name.startswith("build_") else frontend
        if hasattr(owner, name):
            setattr(owner, name, timed(getattr(owner, name), phase))
    return phases


def worker(spec_dir: Path, out: Path) -> dict:
    """Time one build into `out` in this process (a fresh interpreter per measurement)."""
    from rcsgen.compiler import frontend
    from rcsgen.compiler.back_end import emit, write
    from rcsgen.compiler.diagnostics import Diagnostics

    phases = timed_phases(time.perf_counter)
    rss_start = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    cpu_start = _cpu()
    start = time.perf_counter()
    front = frontend.compile_paths([spec_dir])
    front_s = time.perf_counter() - start
    if front.diagnostics.errors:
        raise SystemExit(f"synthetic system does not validate: {front.diagnostics.errors[:3]}")
    start = time.perf_counter()
    files = emit.render_system(front.systems[0])
    render_s = time.perf_counter() - start
    start = time.perf_counter()
    formatted = emit.format_files(files)
    format_s = time.perf_counter() - start
    start = time.perf_counter()
    write.apply(write.plan_outputs(formatted, out, [front.systems[0].name], Diagnostics()))
    write_s = time.perf_counter() - start
    return {
        "build_s": front_s + render_s + format_s + write_s,
        "build_cpu_s": _cpu() - cpu_start,
        "front_s": front_s,
        "phases_s": phases,
        "render_s": render_s,
        "format_s": format_s,
        "write_s": write_s,
        "rss_start_kb": rss_start,
        "rss_peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        "files": len(formatted),
        "lines": sum(text.count("\n") for text in formatted.values()),
        "warnings": len(front.diagnostics.items) - len(front.diagnostics.errors),
    }


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (ruff), user and system."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def rcsgen_build(spec_dir: Path, out: Path) -> float:
    """Wall time of `rcsgen build`, as a user runs it (diagnostics printed to /dev/null)."""
    shutil.rmtree(out, ignore_errors=True)
    command = [
        str(Path(sys.executable).with_name("rcsgen")),
        "build",
        str(spec_dir),
        "-o",
        str(out),
    ]
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def per_doubling(sizes: list[int], times: list[float]) -> dict[str, float | None]:
    """Growth per doubling: from t(100) and t(1000), and the log-log slope from 100 up."""
    at = dict(zip(sizes, times, strict=True))
    ten_x = (at[1000] / at[100]) ** (math.log(2) / math.log(10)) if {100, 1000} <= set(at) else None
    points = [(math.log(n), math.log(t)) for n, t in at.items() if n >= 100 and t > 0]
    fit = None
    if len(points) >= 2:
        mean_x = statistics.fmean(x for x, _ in points)
        mean_y = statistics.fmean(y for _, y in points)
        slope = sum((x - mean_x) * (y - mean_y) for x, y in points) / sum(
            (x - mean_x) ** 2 for x, _ in points
        )
        fit = 2**slope
    return {"from_100_to_1000": ten_x, "fit_100_up": fit}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)))
    parser.add_argument("--repeat", type=int, default=REPEAT)
    parser.add_argument("--json", default=None)
    parser.add_argument("--worker", nargs=2, type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(*args.worker)))
        return 0
    started = time.perf_counter()
    sys.path.insert(0, str(BENCH))
    import synthetic

    sizes = [int(size) for size in args.sizes.split(",")]
    results = []
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-scaling-") as scratch:
        for n in sizes:
            spec_dir = synthetic.write(n, Path(scratch) / f"n{n}")
            out = Path(scratch) / f"out{n}"
            runs = []
            for _ in range(args.repeat):
                shutil.rmtree(out, ignore_errors=True)
                done = subprocess.run(
                    [sys.executable, __file__, "--worker", str(spec_dir), str(out)],
                    check=True,
                    capture_output=True,
                    text=True,
                )
                runs.append(json.loads(done.stdout))
            # The run of median build time, whole (its phases add up).
            runs.sort(key=lambda run: run["build_s"])
            median = runs[len(runs) // 2]
            results.append(
                {
                    "controllers": n,
                    **median,
                    "build_runs_s": [run["build_s"] for run in runs],
                    "rss_peak_kb": statistics.median(run["rss_peak_kb"] for run in runs),
                    "cli_build_s": rcsgen_build(spec_dir, out),
                }
            )
            print(f"{n} controllers: build {median['build_s']:.2f} s", file=sys.stderr)
    sizes_done = [r["controllers"] for r in results]
    growth = {
        key: per_doubling(sizes_done, [r[key] for r in results])
        for key in ("build_s", "build_cpu_s", "cli_build_s", "front_s", "render_s", "format_s")
    }
    growth["rss_peak_kb"] = per_doubling(sizes_done, [r["rss_peak_kb"] for r in results])
    write_json(
        args.json,
        {
            "repeat": args.repeat,
            "sizes": results,
            "per_doubling": growth,
            "seconds": time.perf_counter() - started,
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
