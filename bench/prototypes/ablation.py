"""What each proposed template change buys: the generated co, changed one step at a time.

Each step is a text edit of the generated co.py (as a template change would make it),
applied on top of the previous ones; a step whose key starts with R undoes an adopted
change instead (applied to the generated code alone), to show what that change buys.
Every variant must leave the generated controller's trace (checked over the first 20,000
cycles of the closed loop); then all variants are timed on the same recorded inputs,
interleaved, as in bench_co.py. An edit whose text is no longer in the generated code (the
template changed) is reported as not applicable. The hand-written baseline and the minimal
floor run in the same rounds, for the ratios.

Proposals adopted in the templates are no longer listed as proposals: one read for all
inputs, one write for adjacent world fields, comparisons instead of max()/min() (148c872);
run_cycle holding the four steps itself (formerly P2; R1 undoes it), and world outputs
compared with the block's values instead of with what was last written (44fa027).

    python bench/prototypes/ablation.py [--cycles N] [--rounds R] [--json PATH]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_co  # noqa: E402
from common import summary, write_json  # noqa: E402

PEERS = ["handwritten", "minimal"]  # timed in the same rounds, for the ratios

# (key, what the template would do, [(old text, new text), ...] or a function of the source)
# Keys starting with R undo an adopted change, to show what it buys; they apply to the
# generated code alone, and the proposals (P) go on from the generated code.
STEPS = [
    ("R1", "run_cycle calls the four step methods (the template before 44fa027)", "unfuse"),
    (
        "P1",
        "predicates inlined into the guards that use them (no method call per use)",
        [("self.too_much_loose_coal()", "(self.world_loose_coal > LOOSE_COAL_LIMIT)")],
    ),
]
FOUR_CALLS = """\
    def run_cycle(self) -> None:
        \"\"\"One cycle: the four steps, one call each.\"\"\"
        self.pre_process()
        self.check_if_new_command()
        self.decision_process()
        self.post_process()

"""


def unfuse(source: str) -> str | None:
    """run_cycle as four calls of the step methods (which the template still emits)."""
    start = source.find("    def run_cycle(self) -> None:\n")
    end = source.find("    def pre_process(self) -> None:\n")
    if start < 0 or end < start or "self.pre_process()\n        self.check" in source:
        return None
    return source[:start] + FOUR_CALLS + source[end:]


def variants(generated: str) -> list[tuple[str, str, str | None]]:
    """(key, description, source or None if the edit no longer applies), cumulative."""
    source = generated.replace("from .layout import", "from miner.layout import")
    source = source.replace("from .rcs.", "from miner.rcs.")
    out = [("generated", "as generated today", source)]
    for key, description, edits in STEPS:
        changed: str | None = source
        if edits == "unfuse":
            changed = unfuse(source)
        else:
            for old, new in edits:
                changed = changed.replace(old, new) if changed and old in changed else None
        out.append((key, description, changed))
        if not key.startswith("R"):
            source = changed or source
    return out


def load(name: str, source: str, directory: Path):
    path = directory / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(f"ablation_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=bench_co.CYCLES)
    parser.add_argument("--rounds", type=int, default=bench_co.ROUNDS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-ablation-") as scratch:
        generated = bench_co.build_package(Path(scratch)).read_text()
        steps = variants(generated)
        makers = {}
        for key, _, source in steps:
            if source is not None:
                controller = load(key, source, Path(scratch)).CoController
                makers[key] = lambda buf, controller=controller: controller(buf).run_cycle
        versions = [
            bench_co.Version(key, key, "", make, args.cycles) for key, make in makers.items()
        ]
        makers |= {v.key: v.make for v in bench_co.versions(args.cycles, 0) if v.key in PEERS}
        reference, frames, _ = bench_co.closed_loop(versions[0], args.cycles, record=True)
        check = min(args.cycles, 20_000)
        for version in versions[1:]:
            trace, _, _ = bench_co.closed_loop(version, check)
            if trace != reference[:check]:
                raise SystemExit(
                    f"{version.key} changed the trace: "
                    f"{bench_co.first_difference(reference, trace)}"
                )
        timed = [bench_co.Version(key, key, "", make, args.cycles) for key, make in makers.items()]
        rounds, _ = bench_co.interleaved(frames, timed, args.rounds)
    changes = {key: (description, source is not None) for key, description, source in steps}
    changes |= {key: (f"({key}, for the ratios)", True) for key in PEERS}
    write_json(
        args.json,
        {
            "versions": [
                {
                    "key": key,
                    "change": description,
                    "applied": applied,
                    "ns_per_cycle": summary(rounds[key]) if applied else None,
                    "rounds_ns": rounds.get(key, []),
                }
                for key, (description, applied) in changes.items()
            ]
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
