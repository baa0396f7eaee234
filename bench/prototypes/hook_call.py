"""What one hook call costs the generated code, in CPU time (issue 24): the call a
controller makes (`rcs.deadline.hook`: the deadline's two clock readings, the error
wrapping, the result check) for each result shape the miner's hooks return, the same
without the result check, the result check alone (`contract.result_fits`), and a plain
call of the hook function; each timed in turns (`--reps` rounds of 20,000 calls, thread
CPU time): min / median / max, and the median over rounds of the call less the plain
call. `--against DIR`: another checkout's generated/miner/rcs (its deadline and contract)
takes its turns too, in the same rounds (alternating order): a before/after run by run.

    .venv/bin/python bench/prototypes/hook_call.py [--against /work/main] [--reps 30]
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import sys
import time
import types
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CALLS = 20_000
# The miner's result kinds (`grep -h '= hook(' generated/miner/*.py`), a usual result of
# each and how many calls of that shape a system cycle makes (bench/prototypes/system_
# ablation's scenario: noisy x3, slip, turn_boom; align; steer; haul; noisy_pose, advance;
# cut_coal; wm_estimate).
SHAPES: dict[str, tuple[object, float]] = {
    "f": (1.5, 5.3),
    "if": ((1, 2.0), 1.0),
    "iff": ((1, 2.0, 3.0), 1.0),
    "ffb": ((1.0, 2.0, True), 1.0),
    "fff": ((1.0, 2.0, 3.0), 1.3),
    "bfff": ((True, 1.0, 2.0, 3.0), 1.0),
    "fffbff": ((1.0, 2.0, 3.0, False, 4.0, 5.0), 1.0),
}


def runtime(root: Path, name: str) -> types.ModuleType:
    """`root`'s generated/miner/rcs imported as package `name` (its own deadline, contract)."""
    folder = root / "generated" / "miner" / "rcs"
    spec = importlib.util.spec_from_file_location(
        name, folder / "__init__.py", submodule_search_locations=[str(folder)]
    )
    assert spec is not None and spec.loader is not None
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    importlib.import_module(f"{name}.deadline")
    importlib.import_module(f"{name}.contract")
    return package


class Owner:
    cycles = 0


def runs(package: types.ModuleType, kinds: str, value: object) -> dict[str, Callable[[], object]]:
    """The calls timed for one runtime and one result shape."""
    hooks = types.ModuleType("hooks")
    hooks.h = lambda heading, turn: value  # type: ignore[attr-defined]
    checked = package.deadline.hook("vg", hooks, "h", 1.0, kinds)
    unchecked = package.deadline.hook("vg", hooks, "h", 1.0, None)
    fits = package.contract.result_fits(kinds)
    owner = Owner()
    return {
        "hook call (as generated)": lambda: checked(owner, "r", 1, 2),
        "without the result check": lambda: unchecked(owner, "r", 1, 2),
        "the result check alone": lambda: fits(value),
        "the hook function called directly": lambda: hooks.h(1, 2),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--against", type=Path, help="another checkout, side by side")
    parser.add_argument("--reps", type=int, default=30, help="rounds")
    args = parser.parse_args()
    roots = {"this tree": ROOT} | ({str(args.against): args.against} if args.against else {})
    packages = {label: runtime(root, f"rcs_{n}") for n, (label, root) in enumerate(roots.items())}
    clock = time.thread_time_ns
    found: dict[tuple[str, str, str], list[float]] = {}
    for turn in range(args.reps + 1):
        labels = list(packages) if turn % 2 == 0 else list(packages)[::-1]
        for label in labels:
            for kinds, (value, _) in SHAPES.items():
                for what, run in runs(packages[label], kinds, value).items():
                    start = clock()
                    for _ in range(CALLS):
                        run()
                    if turn:  # the first round warms up
                        found.setdefault((label, kinds, what), []).append((clock() - start) / CALLS)
    for label in packages:
        print(f"{roots[label]}/generated/miner/rcs: ns CPU per call, min / median / max")
        per_cycle = 0.0
        for kinds, (_, count) in SHAPES.items():
            for what in runs(packages[label], kinds, None):
                values = sorted(found[label, kinds, what])
                print(
                    f"  {kinds:7s} {what:34s} {values[0]:5.0f} {statistics.median(values):5.0f}"
                    f" {values[-1]:5.0f}"
                )
            call = found[label, kinds, "hook call (as generated)"]
            plain = found[label, kinds, "the hook function called directly"]
            extra = statistics.median(c - p for c, p in zip(call, plain, strict=True))
            per_cycle += extra * count
            print(f"  {kinds:7s} the call less the plain call, median {extra:5.0f}")
        print(f"  a miner system cycle's calls, less plain calls: {per_cycle / 1000:.2f} µs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
