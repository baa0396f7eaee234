"""Part 1: one controller, several ways. co (Appendix C) generated, by hand and in libraries.

1. Generate co from the frozen spec bench/co_spec/miner with the current templates.
2. Run every version of co in the seeded closed loop (co_plant.Plant) and compare its
   trace with the generated controller's, cycle by cycle: co's status number, status and
   state, and each subordinate's command number, command (and vg's goal). Any difference
   fails the benchmark.
3. Time each version on the same inputs: the bytes the plant wrote before each cycle of
   the reference run are replayed into a fresh block, open loop, so the plant's own cost
   is not timed. A replay with a controller that does nothing is timed in every round and
   subtracted. Within a round the versions take turns every 10,000 cycles (in rotating
   order), so that a burst of other work on the machine hits all of them alike; the
   report gives the median, min and max of the rounds.

    python bench/bench_co.py [--cycles N] [--rounds R] [--json PATH]
"""

from __future__ import annotations

import argparse
import gc
import importlib
import struct
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from common import BENCH, PREEMPTED_NS, clock_overhead, cpu_ns, summary, wall_ns, write_json

SPEC = BENCH / "co_spec" / "miner"
SEED = 20240501
CYCLES = 200_000
SLOW_CYCLES = 20_000  # sismic: its trace must match this prefix of the same run
ROUNDS = 5
WARMUP = 5_000
CHUNK = 10_000  # cycles each version replays before the next one's turn
TRACE_FIELDS = ("co status_num", "co status", "co state")
TRACE_FIELDS += ("cr command_num", "cr command", "vg command_num", "vg command")
TRACE_FIELDS += ("vg x", "vg y", "cc command_num", "cc command")


@dataclass
class Version:
    key: str
    title: str
    module: str  # where it is, for the report
    make: Callable[[memoryview], Callable[[], None]]
    cycles: int = CYCLES


def build_package(out: Path) -> Path:
    """Generate the frozen co system into `out` and make `miner` and its hooks importable."""
    from rcsgen.compiler.back_end import emit
    from rcsgen.compiler.frontend import compile_paths

    front = compile_paths([SPEC])
    if front.diagnostics.errors:
        raise SystemExit(f"bench/co_spec does not validate: {front.diagnostics.errors}")
    for rel, text in emit.render_all(front.systems).items():
        path = out / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    sys.path[:0] = [str(out), str(SPEC), str(BENCH)]
    return out / "miner" / "co.py"


def versions(cycles: int, slow_cycles: int) -> list[Version]:
    """Every version of co, the generated one (the reference) first."""
    from co_handwritten import HandwrittenCo
    from co_minimal import minimal_co
    from co_sismic import SismicCo
    from co_statemachine import StatemachineCo
    from co_transitions import TransitionsCo
    from miner.co import CoController

    rows = [
        ("generated", "generated (rcsgen)", "generated from co_spec/", cycle_of(CoController)),
        ("handwritten", "hand-written (baseline)", "co_handwritten.py", cycle_of(HandwrittenCo)),
        ("transitions", "transitions", "co_transitions.py", cycle_of(TransitionsCo)),
        ("statemachine", "python-statemachine", "co_statemachine.py", cycle_of(StatemachineCo)),
        ("sismic", "sismic", "co_sismic.py, co_statechart.yaml", cycle_of(SismicCo)),
        ("minimal", "minimal hand-written (floor)", "co_minimal.py", minimal_co),
    ]  # fmt: skip
    return [
        Version(key, title, where, make, slow_cycles if key == "sismic" else cycles)
        for key, title, where, make in rows
    ]


def cycle_of(controller_class: type) -> Callable[[memoryview], Callable[[], None]]:
    """block -> the run_cycle of a new controller of `controller_class` on it."""
    return lambda buf: controller_class(buf).run_cycle


def fresh_block() -> memoryview:
    from miner import layout

    buf = memoryview(bytearray(layout.SIZE))
    layout.initialise(buf)
    return buf


def outputs(buf: memoryview) -> bytes:
    """co's outputs in the block: its status, the three command buffers, the goal.

    The status's `rule` field (which table rule fired) is left out: only the generated
    code records it; the other versions write NO_RULE (so they do a little less work)."""
    from miner import layout
    from miner.rcs.contract import STATUS_FIELDS, struct_format

    before_rule = struct.calcsize(struct_format(STATUS_FIELDS[:-1]))
    status = layout.STATUS_OUT["co"]
    parts = [bytes(buf[status.offset : status.offset + before_rule])]
    records = [*(layout.COMMAND_IN[s] for s in ("cr", "vg", "cc"))]
    records += [layout.WORLD["goal_x"], layout.WORLD["goal_y"]]
    parts += [bytes(buf[r.offset : r.offset + r.struct.size]) for r in records]
    return b"".join(parts)


def closed_loop(version: Version, cycles: int, record: bool = False):
    """Run `version` in the closed loop: its trace, the plant's frames (if `record`) and
    co's outputs in the block at the end."""
    from co_plant import Plant
    from miner import layout

    buf = fresh_block()
    run = version.make(buf)
    plant = Plant(layout, SEED)
    if record:
        plant.record()
    trace = []
    for _ in range(cycles):
        plant.before(buf)
        run()
        trace.append(plant.after(buf))
    return trace, plant.frames, outputs(buf)


def first_difference(reference: list[tuple], trace: list[tuple]) -> str | None:
    from miner import layout

    for cycle, (want, got) in enumerate(zip(reference, trace, strict=False)):
        if want != got:
            for index, (a, b) in enumerate(zip(want, got, strict=True)):
                if a != b:
                    field = TRACE_FIELDS[index]
                    if field.endswith(" command"):
                        names = layout.COMMAND_NAMES[field.split()[0]]
                        a, b = names[a], names[b]
                    elif field == "co state":
                        a, b = layout.STATE_NAMES["co"][a], layout.STATE_NAMES["co"][b]
                    return f"cycle {cycle}: `{field}` expected {a!r}, got {b!r}"
    return None


def replay(frames: list, run: Callable[[], None], buf: memoryview) -> int:
    """Write each cycle's recorded inputs and run one cycle; return the CPU time in ns."""
    start = cpu_ns()
    for frame in frames:
        for where, data in frame:
            buf[where] = data
        run()
    return cpu_ns() - start


def idle() -> None:
    """The null controller: what the replay loop costs by itself."""


def interleaved(
    frames: list, versions: list[Version], rounds: int, ends: dict[str, bytes] | None = None
) -> tuple[dict[str, list[float]], list[float]]:
    """Time `versions` on the recorded inputs: per round, each version's ns per cycle less
    the replay loop's own (the null controller's), which is returned too.

    Every round starts each version on a fresh block and replays the inputs chunk by
    chunk; each chunk is replayed by every version in turn (in rotating order), so a
    burst of other work on the machine hits all of them alike. `ends` are the outputs
    each version must leave in its block (a check that the replay reproduced the run)."""
    times: dict[str, list[float]] = {v.key: [] for v in versions}
    idle_ns: list[float] = []
    for index in range(rounds):
        blocks = {v.key: fresh_block() for v in versions}
        runs = {v.key: v.make(blocks[v.key]) for v in versions}
        totals = dict.fromkeys(runs, 0)
        idle_total, idle_block = 0, fresh_block()
        gc.collect()
        for number, start in enumerate(range(0, len(frames), CHUNK)):
            idle_total += replay(frames[start : start + CHUNK], idle, idle_block)
            turn = (index + number) % len(versions)
            for v in versions[turn:] + versions[:turn]:
                if start < v.cycles:
                    part = frames[start : min(start + CHUNK, v.cycles)]
                    totals[v.key] += replay(part, runs[v.key], blocks[v.key])
        idle_per_cycle = idle_total / len(frames)
        idle_ns.append(idle_per_cycle)
        for v in versions:
            if ends is not None and outputs(blocks[v.key]) != ends[v.key]:
                raise SystemExit(f"{v.key}: the replay did not reproduce the run")
            times[v.key].append(totals[v.key] / v.cycles - idle_per_cycle)
        print(f"round {index + 1}/{rounds} done", file=sys.stderr)
    return times, idle_ns


def step_costs(frames: list, make: Callable[[memoryview], object]) -> dict[str, float] | None:
    """Where a generated controller's cycle goes: ns per call of each QQ1 step, timed one by
    one over the recorded inputs on the wall clock, less the cost of reading it; cycles in
    which the process was descheduled (a step took PREEMPTED_NS) are left out."""
    buf = fresh_block()
    controller = make(buf)
    if not all(hasattr(controller, name) for name in STEPS):
        return None  # the template no longer has the four step methods
    steps = [getattr(controller, name) for name in STEPS]
    totals = [0] * len(steps)
    took = [0] * len(steps)
    counted = 0
    clock = wall_ns
    overhead = clock_overhead(clock)
    gc.collect()
    for frame in frames:
        for where, data in frame:
            buf[where] = data
        for index, step in enumerate(steps):
            start = clock()
            step()
            took[index] = clock() - start
        if max(took) < PREEMPTED_NS:
            counted += 1
            for index, value in enumerate(took):
                totals[index] += value
    return {name: total / counted - overhead for name, total in zip(STEPS, totals, strict=True)}


STEPS = ("pre_process", "check_if_new_command", "decision_process", "post_process")


def trace_stats(trace: list[tuple]) -> dict[str, int]:
    """How much of the table the run exercised (states visited, commands sent)."""
    from miner import layout

    states = {name: 0 for name in layout.STATE_NAMES["co"]}
    for row in trace:
        states[layout.STATE_NAMES["co"][row[2]]] += 1
    last = trace[-1]
    return {
        "co commands": last[0],
        "cr commands": last[3],
        "vg commands": last[5],
        "cc commands": last[9],
        **{f"cycles in {name}": count for name, count in states.items()},
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=CYCLES)
    parser.add_argument("--slow-cycles", type=int, default=SLOW_CYCLES)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--json", default=None, help="write the results here (default stdout)")
    args = parser.parse_args()
    started = time.perf_counter()

    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-co-") as scratch:
        build_package(Path(scratch))
        all_versions = versions(args.cycles, min(args.slow_cycles, args.cycles))
        reference, frames, _ = closed_loop(all_versions[0], args.cycles, record=True)

        # Every version must leave the same trace as the generated one.
        checks = {}
        ends = {}
        for version in all_versions:
            trace, _, end = closed_loop(version, version.cycles)
            ends[version.key] = end
            checks[version.key] = first_difference(reference[: version.cycles], trace)
            print(
                f"trace {version.key:12} {version.cycles} cycles: "
                f"{checks[version.key] or 'identical'}",
                file=sys.stderr,
            )
        traces_ok = all(problem is None for problem in checks.values())

        # Time every version on the recorded inputs, interleaved.
        for version in all_versions:
            buf = fresh_block()
            replay(frames[:WARMUP], version.make(buf), buf)
        rounds, idle_ns = interleaved(frames, all_versions, args.rounds, ends)
        steps = step_costs(
            frames, lambda buf: importlib.import_module("miner.co").CoController(buf)
        )

    results = {
        "seed": SEED,
        "rounds": args.rounds,
        "traces_identical": traces_ok,
        "idle_ns": summary(idle_ns),
        "exercised": trace_stats(reference),
        "steps_ns": steps,
        "versions": [
            {
                "key": v.key,
                "title": v.title,
                "module": v.module,
                "cycles": v.cycles,
                "trace": checks[v.key] or "identical",
                "ns_per_cycle": summary(rounds[v.key]),
                "rounds_ns": rounds[v.key],
            }
            for v in all_versions
        ],
        "seconds": time.perf_counter() - started,
    }
    write_json(args.json, results)
    return 0 if traces_ok else 1


if __name__ == "__main__":
    sys.exit(main())
