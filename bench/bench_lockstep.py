"""Part 6: what lockstep costs: a system run as OS processes against the same in one process.

Each launched system is run three times: stepped by the token ring (rcs/ring.py,
"processes": the token a turn word in the ring's page, spun on, then its eventfd written
and read), by the same ring without the page ("eventfd ring": the token an eventfd
write, a nudged member spinning on poll(0), what the ring was before the page), and by the
coordinator's request and answer per process ("request/reply", what lockstep was before
the ring), side by side with the one-process version.

1. The miner: generated/miner as its two processes (pc1, and pp alone in pc2), each an OS
   process over a shared segment stepped in lockstep by the launcher's coordinator
   (`LaunchedHarness`, what `rcsgen run --processes` uses), against the same package with
   both processes' modules in this one process (`Harness`). Both run the nominal scenario
   (specs/miner/scenarios/sump_shear_cusp.yaml), the stop module's command sent again
   each time it is done, as fast as they can (no pacing). And the one-process version
   again, asleep (`time.sleep(SLEEP)`, untimed) before each cycle, as a ring member
   sleeps while the others run: what a cycle costs a process that slept (its caches
   taken by whatever ran meanwhile), with no hand-off at all. That cost, and the bare
   hand-offs below, are the floor of lockstep on this machine: no ring in which a
   member sleeps between its turns does better.
2. A synthetic chain (bench/synthetic.py, fan-out 1) of 16 controllers split over 1, 2, 4
   and 8 processes, its root sent RUN again each time it is done, in lockstep, against the
   same chain in one process.

3. The hand-off alone: N forked processes that do nothing but pass the token
   (rcs/ring.py's Receiver and Return: blocking eventfd reads, nobody nudged or spinning;
   and the launcher's ring with its page, nudges and spins where `Load` sees a free core),
   against the same N answering a request each through pipes: the floor of each design
   on this machine.

Every system cycle is timed on its own on the wall clock (time.perf_counter_ns): lockstep
is waiting for other processes, which CPU time would not see. The in-process and launched
versions take turns every `CHUNK` cycles (in alternating order), so a burst of other work
hits both alike, and the launched versions start in the other order every other round
(`launch`); per version, the median and the mean of its cycles over all rounds. The
extra time per system cycle is the difference of the medians (and of the means, which
include the cycles in which a process waited for the scheduler). At the end of each round
the in-process and launched versions must be in the same state (every module's status and
command, and the world): lockstep leaves the same trace as one process.

    python bench/bench_lockstep.py [--cycles N] [--rounds R] [--json PATH]
        [--parts miner,chain,handoff] [--splits 1,2,4,8] [--dedicated]

`--dedicated`: both rings spin without looking at the machine's load (ring.Load), as on
cores of their own: run it under `chrt -f 10` on a busy machine, where our processes then
get a CPU at once, to see what the design gives on free cores.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import itertools
import os
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from common import ROOT, wall_ns, write_json

from rcsgen.tools import scenario as scenarios
from rcsgen.tools.harness import Harness, LaunchedHarness, generate

LIBC = ctypes.CDLL(None, use_errno=True)
DEDICATED = False  # --dedicated: the rings spin whatever the load (ring.Load)
SCENARIO = ROOT / "specs" / "miner" / "scenarios" / "sump_shear_cusp.yaml"
PACKAGE = ROOT / "generated" / "miner"
CHAIN = 16  # controllers in the synthetic chain
SPLITS = (1, 2, 4, 8)  # processes the chain is split over
CYCLES = 2_000  # system cycles per version and round
ROUNDS = 3
CHUNK = 100
SLEEP = 30e-6  # the one-process version's sleep before each cycle ("slept"), with the
# thread's timer slack at 1 ns meanwhile (an ordinary thread's 50 µs would come on top):
# about as long as pc1 waits for its turn in the two-process miner's ring (the rest of the
# system cycle), or less; what each sleep took is measured
PR_SET_TIMERSLACK, PR_GET_TIMERSLACK = 29, 30


class Driver:
    """Keeps a system busy: applies a scenario's events, and when the stop module is done,
    sends its events again (from the next cycle on)."""

    def __init__(self, events: list[scenarios.Event], stop: str) -> None:
        self.events, self.stop = events, stop
        self.sleep = 0.0  # seconds asleep before each cycle, untimed (race's `sleeps`)
        self.slept: list[int] = []  # with `sleep`: how long each sleep took (ns)
        self.pending: list[tuple[int, scenarios.Event]] = [(e.cycle, e) for e in events]
        self.cycle = 0
        self.restarts = 0

    def before(self, harness) -> None:
        """What happens before cycle `self.cycle + 1`."""
        while self.pending and self.pending[0][0] <= self.cycle + 1:
            apply(harness, self.pending.pop(0)[1])
        if self.sleep:  # last: the cycle timed next starts as a woken process's does
            slack = LIBC.prctl(PR_GET_TIMERSLACK, 0, 0, 0, 0)
            LIBC.prctl(PR_SET_TIMERSLACK, 1, 0, 0, 0)
            began = wall_ns()
            time.sleep(self.sleep)
            self.slept.append(wall_ns() - began)
            LIBC.prctl(PR_SET_TIMERSLACK, slack, 0, 0, 0)

    def after(self, harness) -> None:
        self.cycle += 1
        if not self.pending and finished(harness, self.stop):
            self.pending = [(self.cycle + e.cycle, e) for e in self.events]
            self.restarts += 1


def apply(harness, event: scenarios.Event) -> None:
    harness.world.update(event.world)
    for module, mode in event.mode.items():
        harness.set_mode(module, **mode)
    if event.command is not None:
        module, name = event.command
        harness.command(module, name, **event.args)


def finished(harness, module: str) -> bool:
    status = harness.status(module)
    return status.number == harness.sent(module).number and status.status in ("DONE", "ERROR")


def state(harness) -> tuple:
    """Every module's status and command, and the world: what must be the same either way."""
    modules = tuple(
        (m, harness.status(m), harness.sent(m).command, harness.sent(m).number)
        for m in harness.modules
    )
    return modules, tuple(sorted(harness.world.snapshot().items()))


def race(
    open_versions: Callable[[], dict[str, object]],
    driver_of: Callable[[], Driver],
    cycles: int,
    rounds: int,
    sleeps: dict[str, float] | None = None,
) -> dict[str, list[int]]:
    """Time every system cycle of each version: fresh versions each round, taking turns
    every CHUNK cycles; checks that they end each round in the same state. `sleeps`: the
    versions whose driver sleeps before each cycle, and how long (Driver.sleep); what the
    sleeps took is under the key "<version> sleeps"."""
    samples: dict[str, list[int]] = {}
    for index in range(rounds):
        harnesses = open_versions()
        try:
            drivers = {key: driver_of() for key in harnesses}
            for key, sleep in (sleeps or {}).items():
                drivers[key].sleep = sleep
            keys = list(harnesses)
            gc.collect()
            for number, start in enumerate(range(0, cycles, CHUNK)):
                turn = keys if (index + number) % 2 == 0 else keys[::-1]
                for key in turn:
                    harness, driver = harnesses[key], drivers[key]
                    taken = samples.setdefault(key, [])
                    step = harness.cycle
                    for _ in range(min(CHUNK, cycles - start)):
                        driver.before(harness)
                        began = wall_ns()
                        step()
                        taken.append(wall_ns() - began)
                        driver.after(harness)
            for key, driver in drivers.items():
                if driver.slept:
                    samples.setdefault(f"{key} sleeps", []).extend(driver.slept)
            ends = {key: state(harness) for key, harness in harnesses.items()}
            first, *others = ends.values()  # (a Status holds dicts: compared, not hashed)
            if any(other != first for other in others):
                raise SystemExit(f"round {index + 1}: the versions ended in different states")
        finally:
            for harness in harnesses.values():
                harness.close()
        print(f"round {index + 1}/{rounds} done", file=sys.stderr)
    return samples


# the launched versions: name, LaunchedHarness's options, whether it spins (--dedicated)
LAUNCHED: list[tuple[str, dict[str, bool], bool]] = [
    ("processes", {}, True),
    ("eventfd ring", {"turns": False}, True),
    ("request/reply", {"ring": False}, False),
]
_launches = itertools.count()
SLEPT = "one process, slept"  # the miner's one-process version asleep before each cycle


def launch(opened: dict[str, object], launched: Callable[..., object]) -> None:
    """Start the launched versions into `opened`, in the other order every other call: on
    a loaded machine the order the processes start in moved a version's median by up to
    10 µs (where they land, what is in cache), the same way every round."""
    order = LAUNCHED if next(_launches) % 2 == 0 else LAUNCHED[::-1]
    for key, options, spins in order:
        opened[key] = launched(**options, **({"dedicated": DEDICATED} if spins else {}))


def stats(values: list[int]) -> dict[str, float]:
    ordered = sorted(values)
    return {
        "median": statistics.median(ordered),
        "mean": statistics.fmean(ordered),
        "p90": ordered[int(0.9 * (len(ordered) - 1))],
        "cycles": len(ordered),
    }


def miner(cycles: int, rounds: int) -> dict[str, object]:
    scenario = scenarios.load_scenario(SCENARIO)
    events = list(scenario.events)
    stop = scenario.stop_when_done or "sb"
    processes: dict[str, int] = {}

    def open_versions() -> dict[str, object]:
        one = scenarios.open_harness(scenario, PACKAGE)
        opened: dict[str, object] = {"one process": one}
        where = (PACKAGE, scenario.system_dir, scenario.settings, scenario.simulate)
        try:
            opened[SLEPT] = scenarios.open_harness(scenario, PACKAGE)
            launch(opened, lambda **options: LaunchedHarness(*where, **options))
        except BaseException:
            for harness in opened.values():
                harness.close()
            raise
        placement = one.layout.PLACEMENT
        for name in one.layout.PROCESSES:
            processes[name] = sum(1 for m in one.layout.MODULES if placement.get(m) == name)
        return opened

    samples = race(open_versions, lambda: Driver(events, stop), cycles, rounds, {SLEPT: SLEEP})
    return {
        "scenario": str(SCENARIO.relative_to(ROOT)),
        "processes": processes,
        "one_process_ns": stats(samples["one process"]),
        "one_process_slept_ns": stats(samples[SLEPT]),
        "sleep_ns": stats(samples[f"{SLEPT} sleeps"]),
        "processes_ns": stats(samples["processes"]),
        "eventfd_ring_ns": stats(samples["eventfd ring"]),
        "request_reply_ns": stats(samples["request/reply"]),
    }


def chain(splits: tuple[int, ...], cycles: int, rounds: int) -> list[dict[str, object]]:
    import synthetic

    results = []
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-bench-lockstep-"))
    try:
        for count in splits:
            spec = synthetic.write(CHAIN, scratch / f"p{count}", processes=count, fan_out=1)
            out, name = generate(spec)
            package_dir = out / name
            root = synthetic.name(0)
            run = scenarios.Event(cycle=1, command=(root, "RUN"))

            def open_versions(package_dir: Path = package_dir) -> dict[str, object]:
                opened: dict[str, object] = {
                    "one process": Harness.load(package_dir, send_init=True)
                }
                try:
                    launch(opened, lambda **options: LaunchedHarness(package_dir, **options))
                except BaseException:
                    for harness in opened.values():
                        harness.close()
                    raise
                return opened

            def driver(run: scenarios.Event = run, root: str = root) -> Driver:
                return Driver([run], root)

            samples = race(open_versions, driver, cycles, rounds)
            shutil.rmtree(out, ignore_errors=True)
            results.append(
                {
                    "processes": count,
                    "modules": CHAIN,
                    "one_process_ns": stats(samples["one process"]),
                    "processes_ns": stats(samples["processes"]),
                    "eventfd_ring_ns": stats(samples["eventfd ring"]),
                    "request_reply_ns": stats(samples["request/reply"]),
                }
            )
            print(f"chain over {count} process(es) done", file=sys.stderr)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return results


def token_ring(
    count: int,
    cycles: int,
    spin: float,
    turns: bool,
    dedicated: bool = False,
    watcher: bool = True,
) -> list[int]:
    """`cycles` of a bare ring of `count` forked members (rcs/ring.py, as the launcher
    builds it: `turns`, its page; `spin`, `dedicated` as the launcher's), the wall time of
    each; `watcher=False`: the coordinator reads the last link itself (no `Return`)."""
    from rcsgen.runtime import ring

    links = ring.new_links(count + 1)
    page = ring.Page.create(len(links)) if turns else None
    controls, pids = [], []
    for at in range(count):
        control, keep = os.pipe()
        pid = os.fork()
        if pid == 0:  # a member: take, hand on, until told to stop
            os.close(keep)
            receiver = ring.Receiver(links[at].read, spin, page, at, dedicated)
            nudge = ring.Nudge(links[at + 1].write, spin, page, at + 1, dedicated)
            give = ring.Giver(links[at + 1].write, page, at + 1)
            ring.stop_on_control(control, links[at].write, page, at)
            while receiver.wait():
                nudge()
                give()
            os._exit(0)
        os.close(control)
        controls.append(keep)
        pids.append(pid)
    waiter = ring.Return(links[-1].read, (), spin, page, count, dedicated) if watcher else None
    if waiter is None:
        os.set_blocking(links[-1].read, True)
    give = ring.Giver(links[0].write, page, 0)
    nudge = ring.Nudge(links[0].write, spin, page, 0, dedicated)
    taken = []
    try:
        for _ in range(cycles):
            began = wall_ns()
            give()
            if waiter is not None:
                waiter.wait(10.0)
            else:
                os.read(links[-1].read, 8)
            taken.append(wall_ns() - began)
            nudge()
    finally:
        if waiter is not None:
            waiter.close()
        nudge.close()
        for fd in controls:
            os.close(fd)
        for pid in pids:
            os.waitpid(pid, 0)
        ring.close_links(links)
        if page is not None:
            page.close()
    return taken


def handoff(counts: tuple[int, ...], cycles: int, rounds: int) -> list[dict[str, object]]:
    """The hand-off alone, N processes that run nothing: ring against request/reply."""
    import os

    from rcsgen.runtime import ring

    def ring_cycle(count: int, turns: bool = False) -> list[int]:
        """Blocking eventfds, nobody spinning; `turns`: the launcher's ring (its page,
        nudges, spins where a core is free)."""
        return token_ring(count, cycles, ring.default_spin() if turns else 0.0, turns, DEDICATED)

    def turn_cycle(count: int) -> list[int]:
        return ring_cycle(count, turns=True)

    def reply_cycle(count: int) -> list[int]:
        ends, pids = [], []
        for _ in range(count):
            request, ask = os.pipe()
            answer, tell = os.pipe()
            pid = os.fork()
            if pid == 0:  # a member: answer each request, until the pipe closes
                os.close(ask)
                os.close(answer)
                while os.read(request, 1):
                    os.write(tell, b"d")
                os._exit(0)
            os.close(request)
            os.close(tell)
            ends.append((ask, answer))
            pids.append(pid)
        taken = []
        for _ in range(cycles):
            began = wall_ns()
            for ask, answer in ends:
                os.write(ask, b"s")
                os.read(answer, 1)
            taken.append(wall_ns() - began)
        for ask, answer in ends:
            os.close(ask)
            os.close(answer)
        for pid in pids:
            os.waitpid(pid, 0)
        return taken

    results = []
    for count in counts:
        runs = {"ring": ring_cycle, "turn word": turn_cycle, "request/reply": reply_cycle}
        samples: dict[str, list[int]] = {key: [] for key in runs}
        for index in range(rounds):
            for key in list(runs)[:: 1 if index % 2 == 0 else -1]:
                samples[key] += runs[key](count)
        results.append(
            {
                "processes": count,
                "ring_ns": stats(samples["ring"]),
                "turn_word_ns": stats(samples["turn word"]),
                "request_reply_ns": stats(samples["request/reply"]),
            }
        )
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=CYCLES)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--json", default=None)
    parser.add_argument("--parts", default="miner,chain,handoff", help="some of these only")
    parser.add_argument("--splits", default=",".join(map(str, SPLITS)), help="chain: processes")
    parser.add_argument("--dedicated", action="store_true", help="spin whatever the load")
    args = parser.parse_args()
    global DEDICATED
    DEDICATED = args.dedicated
    parts, splits = args.parts.split(","), tuple(int(n) for n in args.splits.split(","))
    started = time.perf_counter()
    results: dict[str, object] = {
        "cycles_per_round": args.cycles,
        "rounds": args.rounds,
        "chunk": CHUNK,
        "cores": len(os.sched_getaffinity(0)),
        "load_before": os.getloadavg()[0],
        "dedicated": args.dedicated,
    }
    if "miner" in parts:
        results["miner"] = miner(args.cycles, args.rounds)
    if "chain" in parts:
        results["chain"] = chain(splits, args.cycles, args.rounds)
    if "handoff" in parts:
        results["handoff"] = handoff(splits, max(args.cycles, 2_000), args.rounds)
    results["seconds"] = time.perf_counter() - started
    results["load_after"] = os.getloadavg()[0]
    write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
