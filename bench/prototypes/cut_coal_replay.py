"""The mine's `cut_coal` alone, this tree's against another checkout's (issue 24): the
calls the mine makes in one run of part 2's scenario (bench_system's, recorded through the
hook module) replayed on a fresh map by each version in turns, thread CPU time per call
(min / lower quartile / median of `--reps` turns), every answer compared with the other
version's (the same values, bit for bit, or it stops).

    bench/.venv/bin/python bench/prototypes/cut_coal_replay.py --against /work/main [--reps 20]
"""

from __future__ import annotations

import argparse
import importlib.util
import struct
import sys
import time
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_system  # noqa: E402

HOOK = Path("specs") / "miner" / "miner_hooks" / "mine.py"


def recorded_calls() -> list[tuple[float, float, float, bool]]:
    """The arguments of each cut_coal call of one scenario run (the first mine made)."""
    repeater = bench_system.Repeater(bench_system.SCENARIO, bench_system.PACKAGE)
    hooks = sys.modules["miner_hooks.mine"]
    real, calls, mines = hooks.cut_coal, [], []

    def recording(mine, *args):
        if not mines or mines[-1] is mine:
            mines[:1] = [mine]
            calls.append(args)
        return real(mine, *args)

    hooks.cut_coal = recording
    try:
        repeater.run(400)
    finally:
        hooks.cut_coal = real
    return calls


def version(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(f"miner_hooks.{name}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--against", type=Path, required=True, help="another checkout")
    parser.add_argument("--reps", type=int, default=20)
    args = parser.parse_args()
    calls = recorded_calls()
    versions = {
        "this tree": version(BENCH.parent / HOOK, "mine_this"),
        str(args.against): version(args.against.resolve() / HOOK, "mine_other"),
    }
    bits = struct.Struct("<?ddd").pack
    found: dict[str, list[float]] = {name: [] for name in versions}
    answers: dict[str, list[bytes]] = {}
    for turn in range(args.reps + 1):
        for name, hooks in versions.items() if turn % 2 else reversed(versions.items()):
            mine = hooks.load_map(Path(hooks.SYSTEM_DIR) / hooks.DEFAULT_MAP)
            cut, got = hooks.cut_coal, []
            start = time.thread_time_ns()
            for call in calls:
                got.append(cut(mine, *call))
            took = time.thread_time_ns() - start
            answers[name] = [bits(*answer) for answer in got]
            if turn:  # the first turn warms up
                found[name].append(took / len(calls))
        first, *others = answers.values()
        assert all(other == first for other in others), "the versions' answers differ"
    print(f"{len(calls)} calls of one run, {args.reps} turns; thread CPU ns per call")
    for name, values in found.items():
        values.sort()
        q1, median = values[len(values) // 4], values[len(values) // 2]
        print(f"{name:24s} min {values[0]:6.0f}  q1 {q1:6.0f}  median {median:6.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
