"""(not in `make bench`) A build's CPU step by step, this tree against another checkout, in turns.

bench/synthetic.py writes a system of N controllers; then, turn after turn, each tree builds it
in a fresh interpreter of its own (the tree first on PYTHONPATH, run from a neutral directory,
so its `rcsgen` is the one imported): the front end's phases (load, schema, model, check,
analysis, lower; CPU seconds, as bench_scaling.py wraps them), the render, the format (ruff's
CPU included) and the write, and the whole build's CPU. The trees take turns, so a burst of
other work on the machine hits both alike; the medians and the ratio of each turn are
printed, and the bytes each tree wrote are compared (they must be the same).

    python bench/prototypes/build_ab.py --against /path/to/other/checkout [--controllers 1000]
        [--turns 3]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
ROOT = HERE.parents[2]
sys.path.insert(0, str(ROOT / "bench"))
from bench_scaling import _cpu, timed_phases  # noqa: E402  (bench/ is not a package)


def worker(spec_dir: Path, out: Path) -> dict[str, object]:
    """One build of `spec_dir` into `out` by the `rcsgen` this interpreter imports."""
    from rcsgen.compiler import frontend
    from rcsgen.compiler.back_end import emit, write
    from rcsgen.compiler.diagnostics import Diagnostics

    spent = timed_phases(time.process_time)
    begin = _cpu()
    start = time.process_time()
    front = frontend.compile_paths([spec_dir])
    spent["front end"] = time.process_time() - start
    start = time.process_time()
    files = emit.render_system(front.systems[0])
    spent["render"] = time.process_time() - start
    start = _cpu()
    formatted = emit.format_files(files)
    spent["format"] = _cpu() - start
    start = time.process_time()
    write.apply(write.plan_outputs(formatted, out, [front.systems[0].name], Diagnostics()))
    spent["write"] = time.process_time() - start
    spent["build"] = _cpu() - begin
    digest = hashlib.sha256()
    for path in sorted(p for p in out.rglob("*") if p.is_file()):
        digest.update(path.relative_to(out).as_posix().encode() + b"\0" + path.read_bytes())
    return {"seconds": spent, "output": digest.hexdigest(), "rcsgen": frontend.__file__}


def build(tree: Path, spec_dir: Path, out: Path) -> dict[str, object]:
    shutil.rmtree(out, ignore_errors=True)
    done = subprocess.run(
        [sys.executable, str(HERE), "--worker", str(spec_dir), str(out)],
        cwd=tempfile.gettempdir(),
        env={**os.environ, "PYTHONPATH": str(tree)},
        check=True,
        capture_output=True,
        text=True,
    )
    result: dict[str, object] = json.loads(done.stdout)
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--against", type=Path, help="the other checkout (its rcsgen/)")
    parser.add_argument("--controllers", type=int, default=1000)
    parser.add_argument("--turns", type=int, default=3)
    parser.add_argument("--worker", nargs=2, type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(*args.worker)))
        return 0
    import synthetic

    trees = {"this": ROOT, "against": args.against.resolve()}
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in trees}
    with tempfile.TemporaryDirectory(prefix="rcsgen-build-ab-") as scratch:
        spec_dir = synthetic.write(args.controllers, Path(scratch) / "specs")
        for turn in range(args.turns):
            order = list(trees.items()) if turn % 2 == 0 else list(trees.items())[::-1]
            outputs = {}
            for name, tree in order:
                result = build(tree, spec_dir, Path(scratch) / f"out-{name}")
                expected = str(tree / "rcsgen" / "compiler" / "frontend.py")
                if result["rcsgen"] != expected:
                    raise SystemExit(f"{name} imported {result['rcsgen']}, not {expected}")
                runs[name].append(result["seconds"])  # type: ignore[arg-type]
                outputs[name] = result["output"]
            if len(set(outputs.values())) != 1:
                raise SystemExit(f"turn {turn + 1}: the trees wrote different files")
            ratio = runs["this"][-1]["build"] / runs["against"][-1]["build"]
            print(f"turn {turn + 1}: build CPU ratio {ratio:.3f}", file=sys.stderr)
    steps = list(runs["this"][0])
    report = {
        "controllers": args.controllers,
        "turns": args.turns,
        "load_average": os.getloadavg()[0],
        "median_cpu_s": {
            name: {step: round(statistics.median(r[step] for r in rs), 3) for step in steps}
            for name, rs in runs.items()
        },
        "build_ratio_per_turn": [
            round(a["build"] / b["build"], 3)
            for a, b in zip(runs["this"], runs["against"], strict=True)
        ],
        "same_output": True,
    }
    print(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
