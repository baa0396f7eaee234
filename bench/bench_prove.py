"""Part: `rcsgen prove` - its time on the shipped systems, per supervisor, and its catch rate.

- whole: `rcsgen prove specs/` as a user runs it (counter-examples replayed, written to a
  scratch directory), wall clock and CPU time of the child (goal: 30 s on two cores);
- per controller: states explored, transitions, wall and CPU time of its exploration and
  checks, in process (goal: 1 s each);
- seeded bugs: rcsgen/tools/prove_seeds.py plants each handshake bug it enumerates in a copy
  of each shipped system (every `--every`-th of each kind) and proves it: caught, refused by
  the build, equivalent (no handshake bug, with why), masked (the unchanged system already
  has that finding there) or missed;
- the miner's per-leaf HALT bounds, with its execution order.

    python bench/bench_prove.py [--every N] [--json PATH]
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from common import ROOT, write_json

SPECS = ROOT / "specs"


def whole(scratch: Path) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "rcsgen", "prove", str(SPECS), "--counterexamples", str(scratch)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    wall = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"exit": done.returncode, "wall_s": wall, "cpu_s": cpu, "tail": done.stderr[-300:]}


def controllers() -> tuple[list[dict], dict, list[dict]]:
    from rcsgen.compiler.frontend import compile_paths
    from rcsgen.compiler.prove import INFINITE, prove_front
    from rcsgen.compiler.prove.system import prove

    systems: list[dict] = []

    front = compile_paths([SPECS])
    result = prove_front(front)
    rows, miner = [], {}
    for proof, system in zip(result.proofs, front.systems, strict=True):
        began, began_cpu = time.perf_counter(), time.process_time()
        again = prove(system)  # timed alone: the system's whole proof, bounds composed
        systems.append(
            {
                "system": proof.system,
                "wall_s": time.perf_counter() - began,
                "cpu_s": time.process_time() - began_cpu,
                "controllers": len(again.controllers),
                "states": sum(r.states for r in again.controllers.values()),
                "properties": [[p.name, p.controller, held] for p, held in again.properties],
            }
        )
        for name, r in proof.controllers.items():
            rows.append(
                {
                    "system": proof.system,
                    "controller": name,
                    "subordinates": len(system.controller(name).subordinates),
                    "states": r.states,
                    "transitions": r.transitions,
                    "wall_s": r.seconds,
                    "cpu_s": r.cpu,
                }
            )
        if proof.system == "miner":
            miner = {
                "order": {p.name: list(p.modules) for p in system.processes},
                "halt": [
                    {
                        "start": b.start,
                        "leaf": b.leaf,
                        "k": None if b.cycles == INFINITE else b.cycles,
                        "safe": None
                        if b.safe is None
                        else ("never" if b.safe == INFINITE else b.safe),
                        "path": list(b.path),
                    }
                    for b in proof.halt
                ],
            }
    return rows, miner, systems


def seeded(every: int) -> dict:
    from rcsgen.tools.prove_seeds import trial

    out: dict = {"every": every, "systems": {}, "missed": [], "masked": [], "equivalent": []}
    for system in ("inspection", "miner", "platoon", "submarine"):
        began = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="rcsgen-seeds-") as work:
            outcomes = trial(SPECS / system, Path(work), every=every)
        counts = Counter(f"{o.seed.kind}:{o.verdict}" for o in outcomes)
        out["systems"][system] = {"seconds": time.perf_counter() - began, "counts": dict(counts)}
        for o in outcomes:
            if o.verdict in ("missed", "masked", "equivalent"):
                out[o.verdict].append({"kind": o.seed.kind, "where": o.seed.where, "why": o.why})
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--every", type=int, default=1, help="seed every N-th of each kind")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rcsgen-prove-") as scratch:
        result = {"whole": whole(Path(scratch))}
    result["controllers"], result["miner"], result["systems"] = controllers()
    result["seeds"] = seeded(args.every)
    write_json(str(args.json) if args.json else None, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
