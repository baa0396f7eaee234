"""What a ring member's own side of a hand-off costs in CPU (issue 24 item 2): take,
nudge and give (rcs/ring.py's Receiver, Nudge and Giver on a page, spin 2 ms as the
launcher's), with the token already in the link, so nothing waits: the Python and the
system calls alone. Two ring.py files side by side (e.g. a revision's against this
tree's), alternated run by run; CPU time per hand-off, median with min and max. On a busy
machine `Load` sees no core free: nobody nudges or spins, the looks at /proc/loadavg are
what the spin machinery costs.

    git show main:rcsgen/runtime/ring.py > /tmp/ring_main.py
    bench/.venv/bin/python bench/prototypes/ring_python.py \\
        main=/tmp/ring_main.py this=rcsgen/runtime/ring.py
"""

from __future__ import annotations

import importlib.util
import os
import statistics
import sys
import time
from types import ModuleType

SPIN = 0.002
HAND_OFFS = 20_000
RUNS = 9


def load(name: str, path: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"ring_{name}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run(ring: ModuleType) -> float:
    """CPU ns per hand-off: the token handed in, taken, the next nudged and handed it."""
    links = ring.new_links(2)
    page = ring.Page.create(2)
    receiver = ring.Receiver(links[0].read, SPIN, page, 0)
    nudge = ring.Nudge(links[1].write, SPIN, page, 1)
    give, arrive = ring.Giver(links[1].write, page, 1), ring.Giver(links[0].write, page, 0)
    os.set_blocking(links[1].read, True)
    began = time.process_time_ns()
    for _ in range(HAND_OFFS):
        arrive()
        receiver.wait()
        nudge()
        give()
        os.read(links[1].read, 8)  # the next one's doorbell (and any nudge)
    took = (time.process_time_ns() - began) / HAND_OFFS
    receiver.close()
    nudge.close()
    ring.close_links(links)
    page.close()
    return took


def main() -> int:
    rings = {name: load(name, path) for name, path in (a.split("=", 1) for a in sys.argv[1:])}
    taken: dict[str, list[float]] = {name: [] for name in rings}
    for index in range(RUNS):
        for name in list(rings)[:: 1 if index % 2 else -1]:
            taken[name].append(run(rings[name]))
    for name, values in taken.items():
        print(
            f"{name}: {statistics.median(values):.0f} ns a hand-off "
            f"(min {min(values):.0f}, max {max(values):.0f})"
        )
    print(f"load average {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
