"""Lockstep, this tree's runtime against an older revision's, side by side in ONE run
(issue 24 item 2).

On the shared 2-core machine two runs of bench_lockstep.py compare two loads, not two
revisions. Here the same generated package is run three ways in one `bench_lockstep.race`
(the versions take turns every 100 system cycles, in alternating order, and must end each
round in the same state): in this one process (`Harness`), as OS processes in lockstep with
the runtime (the package's `rcs/`) of `--before`, and the same with this tree's runtime.
Both launched versions are copies of this tree's package; the older one has every runtime
file of `rcs/` replaced by the revision's `rcsgen/runtime/` (the coordinator's side too: a
`LaunchedHarness` imports its package under a name of its own). The generated modules are
the same in all three, so what differs is the ring, the launcher's lockstep path and the
process's cycle as lockstep runs it.

The launched versions are started in the other order every other round: on the loaded
machine the order alone moved a version's median by up to 10 µs (placement, cache).
`--spin 0` adds this tree's ring that never spins (every hand-off a wake-up), to tell the
spin policy's share from the rest.

    bench/.venv/bin/python bench/prototypes/lockstep_ab.py [--before main] [--cycles 600]
        [--rounds 2] [--parts miner,chain] [--splits 1,2] [--spin 0]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

BENCH = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(BENCH))

import bench_lockstep as lockstep  # noqa: E402
from common import ROOT  # noqa: E402

from rcsgen.tools import scenario as scenarios  # noqa: E402
from rcsgen.tools.harness import Harness, LaunchedHarness, generate  # noqa: E402


def with_runtime(package: Path, into: Path, revision: str | None) -> Path:
    """A copy of `package` in `into`, its `rcs/` files those of `revision` (None: as is)."""
    copy = into / package.name
    shutil.copytree(package, copy, ignore=shutil.ignore_patterns("__pycache__"))
    if revision is not None:
        for path in sorted((copy / "rcs").rglob("*.py")):
            rel = path.relative_to(copy / "rcs").as_posix()
            text = subprocess.run(
                ["git", "-C", str(ROOT), "show", f"{revision}:rcsgen/runtime/{rel}"],
                check=True,
                capture_output=True,
                text=True,
            ).stdout
            path.write_text(text, encoding="utf-8")
    return copy


def versions(
    one: Callable[[], object],
    launched: Callable[..., object],
    before: Path,
    after: Path,
    spin: float | None,
) -> Callable[[], dict[str, object]]:
    kinds: list[tuple[str, Path, dict[str, object]]] = [
        ("before", before, {}),
        ("after", after, {}),
        *([(f"after, spin {spin:g}", after, {"spin": spin})] if spin is not None else []),
    ]
    rounds = itertools.count()

    def open_versions() -> dict[str, object]:
        # started in the other order every other round: the order the processes start in
        # moved a version's figure by up to 10 µs (where they land, what is in cache)
        order = kinds if next(rounds) % 2 == 0 else kinds[::-1]
        opened: dict[str, object] = {"one process": one()}
        try:
            for key, package, options in order:
                opened[key] = launched(package, **options)
        except BaseException:
            for harness in opened.values():
                harness.close()  # type: ignore[attr-defined]
            raise
        return opened

    return open_versions


def report(samples: dict[str, list[int]]) -> dict[str, object]:
    one = statistics.median(samples["one process"])
    result: dict[str, object] = {}
    for key, values in samples.items():
        figures = lockstep.stats(values)
        result[key] = {
            "median_us": round(figures["median"] / 1e3, 1),
            "mean_us": round(figures["mean"] / 1e3, 1),
            "p90_us": round(figures["p90"] / 1e3, 1),
            "extra_median_us": round((figures["median"] - one) / 1e3, 1),
        }
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", default="main")
    parser.add_argument("--cycles", type=int, default=600)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--parts", default="miner,chain")
    parser.add_argument("--splits", default="1,2")
    parser.add_argument("--spin", type=float, default=None)
    args = parser.parse_args()
    parts = args.parts.split(",")
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-lockstep-ab-"))
    results: dict[str, object] = {"before": args.before, "load_before": os.getloadavg()[0]}
    try:
        if "miner" in parts:
            scenario = scenarios.load_scenario(lockstep.SCENARIO)
            events, stop = list(scenario.events), scenario.stop_when_done or "sb"
            old = with_runtime(lockstep.PACKAGE, scratch / "before", args.before)
            new = with_runtime(lockstep.PACKAGE, scratch / "after", None)
            where = (scenario.system_dir, scenario.settings, scenario.simulate)

            def miner(package: Path, **options: object) -> object:
                return LaunchedHarness(package, *where, **options)  # type: ignore[arg-type]

            samples = lockstep.race(
                versions(
                    lambda: scenarios.open_harness(scenario, lockstep.PACKAGE),
                    miner,
                    old,
                    new,
                    args.spin,
                ),
                lambda: lockstep.Driver(events, stop),
                args.cycles,
                args.rounds,
            )
            results["miner"] = report(samples)
        if "chain" in parts:
            import synthetic

            for count in (int(n) for n in args.splits.split(",")):
                spec = synthetic.write(
                    lockstep.CHAIN, scratch / f"p{count}", processes=count, fan_out=1
                )
                out, name = generate(spec)
                old = with_runtime(out / name, scratch / f"before{count}", args.before)
                new = with_runtime(out / name, scratch / f"after{count}", None)
                run = scenarios.Event(cycle=1, command=(synthetic.name(0), "RUN"))
                samples = lockstep.race(
                    versions(
                        lambda new=new: Harness.load(new, send_init=True),
                        LaunchedHarness,
                        old,
                        new,
                        args.spin,
                    ),
                    lambda run=run: lockstep.Driver([run], synthetic.name(0)),
                    args.cycles,
                    args.rounds,
                )
                shutil.rmtree(out, ignore_errors=True)
                results[f"chain over {count}"] = report(samples)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    results["load_after"] = os.getloadavg()[0]
    print(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
