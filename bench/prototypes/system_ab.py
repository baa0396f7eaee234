"""Part 2's whole miner, this tree against an older revision, in ONE process (issue 24).

On a shared 2-core machine a run of bench_system.py after a run of another revision
compares two loads, not two revisions (at load ~12 the same code measured 174 to 364 µs a
system cycle from one process to the next). Here both run in the same process, taking turns
every `--chunk` system cycles (in alternating order), so a burst of other work hits both
alike: the miner's hook modules (specs/miner/miner_hooks) and the runtime's per-process
cycle (`Process.run_cycle`, `beat`, `run_modules` of the package's rcs/loop.py) of the
revision `--before` are swapped in and out of the imported package. Three combinations:
both as before, this tree's hooks with the loop as before, both as in this tree. Reported:
CPU ns per system cycle (bench_system's clock, less its cost) per combination, median and
lower quartile (the quartile is the less loaded figure), and the median of the ratios to
"before" taken chunk by chunk. With `--hooks`, per hook the instrumented pass's ns per
system cycle (bench_system.per_module), before and after, alternated the same way.

The generated code itself is this tree's in every combination (template changes are
measured by bench/prototypes/ablation.py). Traces are not checked here: the goldens tier
(tests/test_golden.py) checks them.

    .venv/bin/python bench/prototypes/system_ab.py --before REV [--chunk 500] [--reps 40]
        [--hooks]
"""

from __future__ import annotations

import argparse
import importlib
import re
import statistics
import subprocess
import sys
import tempfile
import types
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_system  # noqa: E402
from common import ROOT  # noqa: E402

HOOKS = ("mine", "sim", "vg", "wm", "haulage", "co", "pp")
METHODS = ("run_cycle", "beat", "run_modules")


def extract(revision: str, into: Path) -> None:
    """The revision's hook modules as package `miner_hooks_before`, its generated miner as
    package `miner_before`, under `into` (put on sys.path)."""
    archive = subprocess.run(
        ["git", "-C", str(ROOT), "archive", revision, "specs/miner", "generated/miner"],
        check=True,
        capture_output=True,
    ).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    (into / "specs/miner/miner_hooks").rename(into / "miner_hooks_before")
    (into / "generated/miner").rename(into / "miner_before")
    mine = into / "miner_hooks_before/mine.py"  # its maps: the system directory's
    text = mine.read_text(encoding="utf-8")
    # however the revision finds it (pathlib once, os.path now): one line naming the directory
    text, found = re.subn(
        r"^SYSTEM_DIR = .*$", f"SYSTEM_DIR = {str(ROOT / 'specs/miner')!r}", text, flags=re.M
    )
    if found != 1:
        raise SystemExit(f"{revision}: no SYSTEM_DIR line in miner_hooks/mine.py to point here")
    mine.write_text(text, encoding="utf-8")


def functions(module: types.ModuleType) -> dict[str, types.FunctionType]:
    return {
        name: value
        for name, value in vars(module).items()
        if isinstance(value, types.FunctionType) and value.__module__ == module.__name__
    }


class Variants:
    """Swaps the hooks' functions and the Process methods of the imported package."""

    def __init__(self) -> None:
        self.real = {n: importlib.import_module(f"miner_hooks.{n}") for n in HOOKS}
        old = {n: importlib.import_module(f"miner_hooks_before.{n}") for n in HOOKS}
        self.hooks = {
            "after": {n: functions(m) for n, m in self.real.items()},
            "before": {n: functions(m) for n, m in old.items()},
        }
        loop = next(m for n, m in sys.modules.items() if n.endswith("miner.rcs.loop"))
        old_loop = importlib.import_module("miner_before.rcs.loop")
        self.process = loop.Process
        self.loops = {
            "after": {m: loop.Process.__dict__[m] for m in METHODS},
            "before": {m: old_loop.Process.__dict__[m] for m in METHODS},
        }

    def use(self, hooks: str, loop: str) -> None:
        for name, found in self.hooks[hooks].items():
            for attribute, function in found.items():
                setattr(self.real[name], attribute, function)
        for method, function in self.loops[loop].items():
            setattr(self.process, method, function)


COMBOS = (("before", "before"), ("after", "before"), ("after", "after"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", required=True, help="the revision to compare with")
    parser.add_argument("--chunk", type=int, default=500, help="system cycles per turn")
    parser.add_argument("--reps", type=int, default=40, help="turns of each combination")
    parser.add_argument("--hooks", action="store_true", help="and per hook, instrumented")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="system_ab-") as scratch:
        extract(args.before, Path(scratch))
        sys.path.insert(0, scratch)
        repeater = bench_system.Repeater(bench_system.SCENARIO, bench_system.PACKAGE)
        variants = Variants()
        results: dict[tuple[str, str], list[float]] = {c: [] for c in COMBOS}
        for combo in COMBOS:  # warm-up
            variants.use(*combo)
            repeater.run(args.chunk)
        for turn in range(args.reps):
            for combo in COMBOS if turn % 2 == 0 else COMBOS[::-1]:
                variants.use(*combo)
                took, done, _ = repeater.run(args.chunk)
                results[combo].append(took / done)
        base = results[COMBOS[0]]
        print(f"before = {args.before}; {args.reps} turns of {args.chunk} system cycles each")
        for combo in COMBOS:
            ratios = [a / b for a, b in zip(results[combo], base, strict=True)]
            quartile = statistics.quantiles(results[combo])[0]
            print(
                f"hooks {combo[0]:6s} loop {combo[1]:6s}: "
                f"{statistics.median(results[combo]) / 1000:6.1f} µs a system cycle "
                f"(lower quartile {quartile / 1000:6.1f}), "
                f"ratio to before {statistics.median(ratios):.3f}"
            )
        if args.hooks:
            per_hook(repeater, variants, args)
        variants.use("after", "after")
    return 0


def per_hook(repeater: bench_system.Repeater, variants: Variants, args) -> None:
    found: dict[str, list[dict[str, float]]] = {"before": [], "after": []}
    for turn in range(max(2, args.reps // 10)):
        for which in ("before", "after") if turn % 2 == 0 else ("after", "before"):
            variants.use(which, which)
            _, hooks, _ = bench_system.per_module(repeater, args.chunk * 4)
            found[which].append(hooks)
    names = sorted({k for runs in found.values() for h in runs for k in h})
    names.sort(key=lambda k: -statistics.median(h.get(k, 0.0) for h in found["before"]))
    print(f"{'hook, ns per system cycle (instrumented)':44s} {'before':>8s} {'after':>8s} ratio")
    for name in names:
        before = [h.get(name, 0.0) for h in found["before"]]
        after = [h.get(name, 0.0) for h in found["after"]]
        ratios = [a / b for a, b in zip(after, before, strict=True) if b]
        ratio = statistics.median(ratios) if ratios else float("nan")
        print(
            f"{name:44s} {statistics.median(before):8.0f} {statistics.median(after):8.0f} "
            f"{ratio:.2f}"
        )


if __name__ == "__main__":
    sys.exit(main())
