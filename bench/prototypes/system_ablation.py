"""Where part 2's system cycle goes: the whole miner with one kind of per-module or
per-process work taken out at a time, the variants taking turns (issue 24).

Each variant is generated/miner as this tree has it, loaded as a package of its own (its
own copy of rcs/), with one change that does not change what the system does (so every
variant runs the same scenario through the same states): the hook calls made directly
(no deadline, no error wrapping, no result check), the result check alone left out, the
modules' execution-time bookkeeping (the clock read, the figures kept and published) left
out, or only their publishing (the clock read and figures kept), the process's
time-in-state check or its beat left out, or all of these at once. Variants take turns
every `--chunk` system cycles (in alternating order) so that
other work on the machine hits them alike; reported: CPU ns per system cycle (median over
turns), and the median of the turn-by-turn differences to "as generated". What a variant
saves is what that work costs; what "all out" keeps is the modules' own reads, tables and
writes, and the hooks. With `--against DIR`, another checkout's generated/miner (its own
rcs/ and templates, this tree's hooks) takes its turns too, unchanged: a before/after side
by side (`--only` leaves the ablations out).

    .venv/bin/python bench/prototypes/system_ablation.py [--chunk 400] [--reps 30]
        [--against /work/main [--only]]
"""

from __future__ import annotations

import argparse
import re
import shutil
import statistics
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_system  # noqa: E402

PERF_TAIL = re.compile(r"        # Its execution time: kept here.*?        return end\n", re.S)
PUBLISH_NOW = re.compile(
    r"        if last > self\.max_cycle_ns or self\.single_step:\n(?:            .*\n)"
    r"        elif last < self\.min_cycle_ns:\n(?:            .*\n)"
)


def no_perf(source: str) -> str:
    """A module's source without its execution-time bookkeeping (its clock read, its figures
    kept and published)."""
    source = source.replace("cycle_start = began or perf_counter_ns()\n", "\n")
    return PERF_TAIL.sub("        self.cycles += 1\n        return 0\n", source)


def no_publish(source: str) -> str:
    """A module's source with its clock read and figures kept, but never published at once
    (with the `no publish` patch, not by its process either): what publishing costs."""
    return PUBLISH_NOW.sub("", source)


def package(scratch: Path, name: str, edit: Callable[[str], str] | None) -> Path:
    """generated/miner copied to scratch/name/miner, each controller's source edited."""
    target = scratch / name / "miner"
    shutil.copytree(bench_system.PACKAGE, target, ignore=shutil.ignore_patterns("__pycache__"))
    if edit is not None:
        for path in target.glob("*.py"):
            text = path.read_text(encoding="utf-8")
            if "def run_cycle" in text and "class " in text:
                path.write_text(edit(text), encoding="utf-8")
    return target


class Variant:
    """A package (edited or not) and the patches made to its classes while it runs."""

    def __init__(self, repeater: bench_system.Repeater, patches: tuple[str, ...]) -> None:
        self.repeater, self.patches = repeater, patches
        harness = repeater.first
        pkg = harness.package.__name__
        self.loop = sys.modules[f"{pkg}.rcs.loop"].Process
        self.deadline = sys.modules[f"{pkg}.rcs.deadline"]
        classes = {type(c) for _, c in bench_system.controllers(harness)}
        for process in harness.processes.values():
            classes |= {type(m) for m in process.stand_ins.values()}
        self.hooked = [
            (cls, attribute, sys.modules[cls.__module__].hooks, attribute[5:])
            for cls in classes
            for attribute in vars(cls)
            if attribute.startswith("hook_") and attribute != "hook_state"
        ]
        self.saved = {(c, a): getattr(c, a) for c, a, _, _ in self.hooked}
        self.saved |= {
            (self.loop, m): getattr(self.loop, m)
            for m in ("run_cycle", "beat", "publish")
            if hasattr(self.loop, m)  # (another checkout's may have no `publish`)
        }

    def apply(self) -> None:
        if "direct" in self.patches:
            for cls, attribute, hooks, name in self.hooked:

                def direct(owner, rule, *args, _hooks=hooks, _name=name):
                    return getattr(_hooks, _name)(*args)

                setattr(cls, attribute, direct)
        if "unchecked" in self.patches:
            for cls, attribute, hooks, name in self.hooked:
                module = cls.__module__.rsplit(".", 1)[-1]
                setattr(cls, attribute, self.deadline.hook(module, hooks, name, 1.0, None))
        if "no publish" in self.patches:
            self.loop.publish = lambda process, now_ns=0: None
        if "no clocks" in self.patches or "no beat" in self.patches:
            timed, beats = "no clocks" not in self.patches, "no beat" not in self.patches

            def run_cycle(process) -> None:
                for step in process.steps:
                    step()
                if timed:
                    buf, cycle = process.block.buf, process.cycle
                    for clock, module in process.timed.values():
                        if module.state != clock.state:
                            clock.enter(buf, module.state, cycle)
                process.cycle += 1
                if beats:
                    process.beat()

            self.loop.run_cycle = run_cycle

    def undo(self) -> None:
        for (owner, attribute), value in self.saved.items():
            setattr(owner, attribute, value)


EDITS: dict[str, Callable[[str], str] | None] = {
    "": None,
    "no perf": no_perf,
    "no publish": no_publish,
}
VARIANTS: dict[str, tuple[str, tuple[str, ...]]] = {  # name -> (source edit, patches)
    "as generated": ("", ()),
    "hook calls direct": ("", ("direct",)),
    "no hook result check": ("", ("unchecked",)),
    "no execution-time bookkeeping": ("no perf", ()),
    "clocks kept, never published": ("no publish", ("no publish",)),
    "no time-in-state check": ("", ("no clocks",)),
    "no beat": ("", ("no beat",)),
    "all of these out": ("no perf", ("direct", "no clocks", "no beat")),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--chunk", type=int, default=400, help="system cycles per turn")
    parser.add_argument("--reps", type=int, default=30, help="turns of each variant")
    parser.add_argument("--against", type=Path, help="another checkout, side by side")
    parser.add_argument("--only", action="store_true", help="with --against: no ablations")
    args = parser.parse_args()
    chosen = dict(list(VARIANTS.items())[:1] if args.only else VARIANTS)
    with tempfile.TemporaryDirectory(prefix="system_ablation-") as scratch:
        variants = {}
        for name, (edited, patches) in chosen.items():
            path = package(Path(scratch), f"v{len(variants)}", EDITS[edited])
            repeater = bench_system.Repeater(bench_system.SCENARIO, path)
            variants[name] = Variant(repeater, patches)
        if args.against is not None:
            other = args.against.resolve() / "generated" / "miner"
            repeater = bench_system.Repeater(bench_system.SCENARIO, other)
            variants[f"{args.against} as generated"] = Variant(repeater, ())
        names = list(variants)
        found: dict[str, list[float]] = {name: [] for name in names}
        for turn in range(args.reps + 1):
            for name in names if turn % 2 == 0 else names[::-1]:
                variant = variants[name]
                variant.apply()
                try:
                    took, done, _ = variant.repeater.run(args.chunk)
                finally:
                    variant.undo()
                if turn:  # the first turn warms up
                    found[name].append(took / done)
        base = found[names[0]]
        print(f"{args.reps} turns of {args.chunk} system cycles each; CPU ns per system cycle")
        for name in names:
            saved = [b - a for a, b in zip(found[name], base, strict=True)]
            ratio = [a / b for a, b in zip(found[name], base, strict=True)]
            print(
                f"{name:32s} {statistics.median(found[name]) / 1000:7.1f} µs"
                f"  saves {statistics.median(saved) / 1000:+6.1f} µs,"
                f" {statistics.median(ratio):.3f}x (medians of turn pairs)"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
