"""Part 4: start-up. How long importing a generated system takes, against the peers; and
whole commands: `rcsgen validate specs/`, and a generated process started, run one cycle
and stopped (CPU seconds and peak RSS from the kernel's accounting of each finished child).

Each target is a `python -c "import ..."` in a fresh interpreter, run in interleaved
rounds; its cost is the median wall time less the median of `python -c pass` (the bare
interpreter). `python -X importtime` gives the same imports' cumulative time as Python
itself measures it, and the heaviest standard-library imports of the generated package.

    python bench/bench_startup.py [--rounds R] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import BENCH, ROOT, write_json

ROUNDS = 15


def targets(co_package: Path) -> list[dict]:
    """(key, title, import statement, PYTHONPATH) of every measured import."""
    miner = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]
    co = [str(co_package), str(BENCH / "co_spec" / "miner")]
    return [
        {"key": "python", "title": "bare interpreter (`pass`)", "code": "pass", "path": []},
        {
            "key": "miner",
            "title": "generated miner system (`miner.main_pc1`)",
            "code": "import miner.main_pc1",
            "path": miner,
        },
        {
            "key": "co",
            "title": "generated co alone (`miner.main_pc1` of bench/co_spec)",
            "code": "import miner.main_pc1",
            "path": co,
        },
        {"key": "transitions", "title": "transitions", "code": "import transitions", "path": []},
        {
            "key": "statemachine",
            "title": "python-statemachine",
            "code": "import statemachine",
            "path": [],
        },
        {
            "key": "sismic",
            "title": "sismic (interpreter and YAML import)",
            "code": "import sismic.interpreter, sismic.io",
            "path": [],
        },
    ]


def commands() -> list[dict]:
    """(key, title, argv, PYTHONPATH) of every whole command timed: the CLI's `validate`, and
    each process of the generated miner started, run for one cycle and stopped, as the
    launcher starts it (`python -m miner pc2 --cycles 1 --fast`: its planner built)."""
    miner = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]
    python, rcsgen = sys.executable, str(Path(sys.executable).with_name("rcsgen"))
    segment = f"rcsbench_startup_{os.getpid()}"
    return [
        {
            "key": "validate",
            "title": "`rcsgen validate specs/`",
            "argv": [rcsgen, "validate", "specs/"],
            "path": [],
        },
        *(
            {
                "key": process,
                "title": f"`python -m miner {process} --cycles 1 --fast` (start, one cycle, stop)",
                "argv": [python, "-m", "miner", process, "--cycles", "1", "--fast"]
                + ["--shm", f"{segment}_{process}"],
                "path": miner,
            }
            for process in ("pc1", "pc2")
        ),
    ]


def run_command(command: dict) -> dict[str, float]:
    """One whole command in a fresh process: CPU seconds (user + system, from the kernel's
    accounting of the finished child), wall seconds and peak RSS (MiB)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(command["path"]))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    start = time.perf_counter()
    child = subprocess.Popen(
        command["argv"], env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise SystemExit(f"{' '.join(command['argv'])} failed ({child.returncode})")
    return {
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "wall_s": time.perf_counter() - start,
        "rss_mib": usage.ru_maxrss / 1024,
    }


def run(target: dict, importtime: bool = False) -> tuple[float, str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(target["path"]))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    command = [sys.executable, *(["-X", "importtime"] if importtime else []), "-c", target["code"]]
    start = time.perf_counter()
    done = subprocess.run(command, env=env, check=True, capture_output=True, text=True, cwd=ROOT)
    return time.perf_counter() - start, done.stderr


def import_times(stderr: str) -> list[tuple[str, int, int]]:
    """(module, self µs, cumulative µs) from `-X importtime` output."""
    rows = []
    for line in stderr.splitlines():
        if line.startswith("import time:") and "|" in line and "imported package" not in line:
            own, cumulative, name = line.removeprefix("import time:").split("|")
            rows.append((name.rstrip(), int(own), int(cumulative)))
    return rows


def top_level_us(rows: list[tuple[str, int, int]]) -> int:
    """The cumulative time of the modules imported directly by `-c` (indent 1)."""
    return sum(cumulative for name, _, cumulative in rows if not name.startswith("  "))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    started = time.perf_counter()
    sys.path.insert(0, str(BENCH))
    import bench_co

    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-startup-") as scratch:
        bench_co.build_package(Path(scratch))
        all_targets = targets(Path(scratch))
        for target in all_targets:  # compile the bytecode once, as an installed package has
            run(target)
        walls: dict[str, list[float]] = {t["key"]: [] for t in all_targets}
        for _ in range(args.rounds):
            for target in all_targets:
                walls[target["key"]].append(run(target)[0])
        rows = {t["key"]: import_times(run(t, importtime=True)[1]) for t in all_targets}
    whole = commands()
    for command in whole:  # warm-up: bytecode compiled once
        run_command(command)
    runs: dict[str, list[dict[str, float]]] = {c["key"]: [] for c in whole}
    for _ in range(args.rounds):
        for command in whole:
            runs[command["key"]].append(run_command(command))
    bare = statistics.median(walls["python"])
    bare_us = top_level_us(rows["python"])
    results = []
    for target in all_targets:
        median = statistics.median(walls[target["key"]])
        results.append(
            {
                "key": target["key"],
                "title": target["title"],
                "code": target["code"],
                "wall_ms": median * 1e3,
                "import_ms": (median - bare) * 1e3,
                "importtime_ms": (top_level_us(rows[target["key"]]) - bare_us) / 1e3,
            }
        )
    heaviest = sorted(rows["miner"], key=lambda row: -row[1])[:8]
    write_json(
        args.json,
        {
            "rounds": args.rounds,
            "targets": results,
            "miner_heaviest_self_ms": [(name.strip(), own / 1e3) for name, own, _ in heaviest],
            "miner_cumulative_ms": {
                name.strip(): cumulative / 1e3
                for name, _, cumulative in rows["miner"]
                if name.strip()
                in (
                    "miner.rcs.loop",
                    "miner.layout",
                    "multiprocessing.shared_memory",
                    "typing",
                )
            },
            "commands": [
                {
                    "key": c["key"],
                    "title": c["title"],
                    **{
                        figure: {
                            "median": statistics.median(r[figure] for r in runs[c["key"]]),
                            "min": min(r[figure] for r in runs[c["key"]]),
                            "max": max(r[figure] for r in runs[c["key"]]),
                        }
                        for figure in ("cpu_s", "wall_s", "rss_mib")
                    },
                }
                for c in whole
            ],
            "seconds": time.perf_counter() - started,
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
