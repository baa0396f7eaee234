"""A quiet cycle of generated modules, this tree's against another checkout's, side by side.

A quiet cycle is what the template adds to a module's cycle when nothing happens: a fresh
block, no command ever sent (the module idles in NOP), so each cycle is the read of its
inputs, the mode, the status and world checks and the performance write. Each module of
generated/miner is loaded twice, as this tree generated it and as the other checkout did
(the layout must be the same: its block is this tree's), and both are run in turns, 2,000
cycles a turn, 40 turns; the figure is each one's fastest turn (wall clock, gc off), which
leaves out what other work on the machine added.

    python bench/prototypes/quiet_cycle.py --against /work/main [MODULE ...]
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
TURNS, CYCLES = 40, 2000


def load(path: Path, name: str, scratch: Path) -> ModuleType:
    """A generated module's source loaded as a module of its own, importing `miner`'s."""
    source = path.read_text().replace("from .layout import", "from miner.layout import")
    source = source.replace("from .rcs.", "from miner.rcs.")
    copy = scratch / f"{name}.py"
    copy.write_text(source)
    spec = importlib.util.spec_from_file_location(name, copy)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--against", type=Path, required=True, help="another checkout")
    parser.add_argument("modules", nargs="*", default=["cv", "cr", "co", "pss", "vg"])
    args = parser.parse_args()
    sys.path[:0] = [str(ROOT / "generated"), str(ROOT / "specs" / "miner")]
    from miner import layout

    other = args.against / "generated" / "miner" / "layout.py"
    if f'LAYOUT_HASH = "{layout.LAYOUT_HASH}"' not in other.read_text():
        raise SystemExit(f"{other}: another layout; the modules cannot share a block")
    with tempfile.TemporaryDirectory(prefix="rcsgen-quiet-") as scratch:
        for name in args.modules:
            runs = {}
            for tag, tree in (("other", args.against), ("this", ROOT)):
                module = load(
                    tree / "generated" / "miner" / f"{name}.py", f"{tag}_{name}", Path(scratch)
                )
                cls = next(v for k, v in vars(module).items() if k.endswith("Controller"))
                buf = memoryview(bytearray(layout.SIZE))
                layout.initialise(buf)
                runs[tag] = cls(buf).run_cycle
            best = dict.fromkeys(runs, float("inf"))
            gc.disable()
            for turn in range(TURNS):
                for tag, run in sorted(runs.items(), reverse=bool(turn % 2)):
                    start = time.perf_counter_ns()
                    for _ in range(CYCLES):
                        run()
                    best[tag] = min(best[tag], (time.perf_counter_ns() - start) / CYCLES)
            gc.enable()
            print(
                f"{name:5} quiet cycle: {best['other']:7,.0f} ns there, {best['this']:7,.0f} ns "
                f"here ({best['this'] / best['other']:.2f}x)"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
