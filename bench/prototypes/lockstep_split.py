"""Where the lockstep cost goes (issue 24 item 2): the two-process miner's system cycle
split into the modules' own work and the rest, in one process and in the token ring.

Every generated module times its own cycle (its performance buffer's `last_cycle_ns`,
perf_counter_ns around its run_cycle, written by the module itself). After each system
cycle (untimed) this reads every module's last cycle from the block, so each system cycle
is split into

- work: the sum of the modules' own cycle times (what the processes compute),
- rest: the wall time of the system cycle less that work: in one process the loop, the
  beats and the simulation switch; in the ring also the hand-offs (N+1 token passes) and
  the scheduler's wake-ups of each process.

The same scenario as bench_lockstep.py's miner (sump_shear_cusp repeated), both versions
taking turns every 100 cycles; medians over all cycles. If the ring's extra time were all
hand-off, its work would equal the one-process work; work that grows in another process
is the price of running the segment there (a cold cache, a core that was idle, another
process's pages).

    bench/.venv/bin/python bench/prototypes/lockstep_split.py [--cycles N] [--rounds R]
"""

from __future__ import annotations

import argparse
import json
import statistics
import struct
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_lockstep as lockstep  # noqa: E402
from common import wall_ns  # noqa: E402

from rcsgen.runtime.contract import BEAT, PROCESS_FIELDS, field_names  # noqa: E402
from rcsgen.tools import scenario as scenarios  # noqa: E402

PROCESS_NAMES = field_names(PROCESS_FIELDS)

SEGMENT = struct.Struct("<Q")
LAST = struct.Struct("<QQ")  # a performance buffer's sequence word and last_cycle_ns
# a control record's last_cycle_ns: after the sequence word and the fields before it
AT = struct.calcsize(
    "<Q" + "".join(c for n, c in PROCESS_FIELDS[: PROCESS_NAMES.index("last_cycle_ns")])
)


def split(cycles: int, rounds: int) -> dict[str, dict[str, float]]:
    scenario = scenarios.load_scenario(lockstep.SCENARIO)
    events, stop = list(scenario.events), scenario.stop_when_done or "sb"
    samples: dict[str, dict[str, list[int]]] = {}
    for _ in range(rounds):
        opened = {"one process": scenarios.open_harness(scenario, lockstep.PACKAGE)}
        try:
            opened["ring"] = scenarios.open_harness(scenario, lockstep.PACKAGE, processes=True)
            drivers = {key: lockstep.Driver(events, stop) for key in opened}
            for start in range(0, cycles, lockstep.CHUNK):
                for key, harness in opened.items():
                    perf = [r.offset for r in harness.layout.PERFORMANCE.values()]
                    buf, driver = harness.buf, drivers[key]
                    into = samples.setdefault(
                        key, {"wall": [], "work": [], "segments": [], "wall_paired": []}
                    )
                    records = [r.offset + AT for r in harness.layout.PROCESSES.values()]
                    earlier = None  # the previous cycle's give, return and beats
                    for _ in range(min(lockstep.CHUNK, cycles - start)):
                        driver.before(harness)
                        gave = time.monotonic_ns()
                        began = wall_ns()
                        harness.cycle()
                        took = wall_ns() - began
                        back = time.monotonic_ns()
                        into["wall"].append(took)
                        into["work"].append(sum(LAST.unpack_from(buf, at)[1] for at in perf))
                        if key != "ring":
                            driver.after(harness)
                            continue
                        # each process's cycle, from the token to its beat, is in its
                        # control record from its next beat on: this cycle's record holds
                        # the previous cycle's
                        beats = [BEAT.unpack_from(buf, r - AT)[5] for r in records]
                        if earlier is not None:
                            segments = [SEGMENT.unpack_from(buf, at)[0] for at in records]
                            into["segments"].append(sum(segments))
                            into["wall_paired"].append(earlier[3])
                            # each hand-off: from the giver's beat (it hands on right after)
                            # to the taker's start (its beat less its cycle), on the host's
                            # monotonic clock; the coordinator's own give and return
                            starts = [b - g for b, g in zip(earlier[2], segments, strict=True)]
                            ends = [earlier[0], *earlier[2]]
                            for i, (end, begin) in enumerate(
                                zip(ends, [*starts, earlier[1]], strict=True)
                            ):
                                into.setdefault(f"handoff_{i}", []).append(begin - end)
                        earlier = (gave, back, beats, took)
                        driver.after(harness)
        finally:
            for harness in opened.values():
                harness.close()
    result = {}
    for key, series in samples.items():
        rest = [w - k for w, k in zip(series["wall"], series["work"], strict=True)]
        result[key] = {
            "wall_us": statistics.median(series["wall"]) / 1e3,
            "work_us": statistics.median(series["work"]) / 1e3,
            "rest_us": statistics.median(rest) / 1e3,
            "cycles": len(rest),
        }
        if series["segments"]:  # the ring: the processes' own cycles, and between them
            paired = zip(series["wall_paired"], series["segments"], strict=True)
            between = [w - g for w, g in paired]
            result[key]["segments_us"] = statistics.median(series["segments"]) / 1e3
            result[key]["between_segments_us"] = statistics.median(between) / 1e3
            for name, values in series.items():
                if name.startswith("handoff_"):
                    result[key][f"{name}_us"] = statistics.median(values) / 1e3
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=2_000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print(json.dumps(split(args.cycles, args.rounds), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
