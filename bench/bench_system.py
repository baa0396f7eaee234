"""Part 2: the whole miner system, in one process: ns per system cycle and per module.

The generated package (generated/miner) runs the nominal scenario (a scenario file of
specs/miner/scenarios, as `rcsgen run` would, INIT sent at start-up) again and again,
each time on a fresh block and fresh controllers from the same imported package, until
the scenario's stop module reports DONE (or max_cycles). Every process of the system runs
in this one process, in the system's order (as `rcsgen run` does). Every system cycle is
timed on its own, in CPU time (common.cpu_ns, less the cost of reading the clock); the
scenario's events and the stop check run between cycles, untimed. One round is `--cycles`
system cycles; rounds are repeated and the median reported. A second, instrumented pass
times each module's run_cycle and each call of a hand-written hook function, to show
where a system cycle goes: generated code or hooks.

The same system as several OS processes is measured by bench_lockstep.py.

    python bench/bench_system.py [--scenario PATH] [--cycles N] [--rounds R] [--json PATH]
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
import types
from pathlib import Path

from common import PREEMPTED_NS, ROOT, clock_overhead, cpu_ns, summary, wall_ns, write_json

from rcsgen.tools import scenario as scenarios
from rcsgen.tools.harness import Harness

SCENARIO = ROOT / "specs" / "miner" / "scenarios" / "sump_shear_cusp.yaml"
PACKAGE = ROOT / "generated" / "miner"
CYCLES = 20_000
ROUNDS = 15  # the machine's speed drifts by ±10 % over tens of seconds: a median over ~45 s


class Repeater:
    """Runs a scenario over and over on fresh harnesses of one imported package."""

    def __init__(self, path: Path, package_dir: Path) -> None:
        self.scenario = scenarios.load_scenario(path)
        self.first = self._open(package_dir)

    def _open(self, package_dir: Path) -> Harness:
        if hasattr(scenarios, "open_harness"):
            return scenarios.open_harness(self.scenario, package_dir)
        return Harness.load(
            package_dir, self.scenario.system_dir, self.scenario.process, send_init=True
        )

    def fresh(self) -> Harness:
        """A new block and new controllers, INIT sent, from the already imported package."""
        options = {}
        for name in ("settings", "simulate"):
            if getattr(self.scenario, name, None):
                options[name] = getattr(self.scenario, name)
        return Harness(self.first.package, self.scenario.process, send_init=True, **options)

    def finished(self, harness: Harness) -> bool:
        stop = self.scenario.stop_when_done
        if stop is None:
            return False
        status = harness.status(stop)
        return status.number == harness.sent(stop).number and status.status in ("DONE", "ERROR")

    def apply(self, harness: Harness, event: scenarios.Event) -> None:
        harness.world.update(event.world)
        for module, mode in event.mode.items():
            harness.set_mode(module, **mode)
        if event.command is not None:
            module, name = event.command
            harness.command(module, name, **event.args)

    def run(self, cycles: int, cycle_of=None) -> tuple[int, int, int]:
        """Run `cycles` system cycles of repeated scenarios; returns (ns, cycles, runs).

        `cycle_of(harness)` gives the function that runs one system cycle (default: the
        process's own run_cycle)."""
        clock, overhead = cpu_ns, clock_overhead()
        total = done = runs = 0
        gc.collect()
        while done < cycles:
            harness, runs = self.fresh(), runs + 1
            step = cycle_of(harness) if cycle_of else system_cycle(harness)
            pending = list(self.scenario.events)
            for cycle in range(1, self.scenario.max_cycles + 1):
                while pending and pending[0].cycle <= cycle:
                    self.apply(harness, pending.pop(0))
                start = clock()
                step()
                total += clock() - start - overhead
                done += 1
                if done == cycles or (not pending and self.finished(harness)):
                    break
        return total, done, runs


def system_cycle(harness: Harness):
    """One system cycle: every process's run_cycle, in the declared order (what
    `harness.cycle()` does, without its loop over a count)."""
    steps = tuple(process.run_cycle for process in harness.processes.values())
    if len(steps) == 1:
        return steps[0]

    def cycle() -> None:
        for step in steps:
            step()

    return cycle


def controllers(harness: Harness) -> list[tuple[str, object]]:
    """The controllers the harness runs, every process's, in the system's order (an
    operator module's channels, `op/client`, are the person's, not a controller)."""
    return [(name, harness.controller(name)) for name in harness.modules if "/" not in name]


class TimedHooks:
    """Times the hook functions the controllers call: each is replaced in its hook module by
    a timed stand-in (generated code looks a hook up in its module at each call), until
    `restore`. A call made while another is being timed (a hook calling another through its
    module) is part of the outer one's time, so each controller's call is timed once."""

    def __init__(self, cycle: CycleTimes) -> None:
        self.cycle, self.depth = cycle, 0
        self.patched: list[tuple[types.ModuleType, str, object]] = []

    def patch(self, module: types.ModuleType, name: str) -> None:
        function = getattr(module, name, None)
        if not callable(function) or any(m is module and n == name for m, n, _ in self.patched):
            return
        key = f"{module.__name__}.{name}"
        cycle, clock, timer = self.cycle, wall_ns, self

        def timed(*args, **kwargs):
            if not cycle.active or timer.depth:  # outside a cycle, or inside a timed call
                return function(*args, **kwargs)
            timer.depth += 1
            cycle.calls += 1
            start = clock()
            try:
                return function(*args, **kwargs)
            finally:
                took = clock() - start
                timer.depth -= 1
                cycle.hooks[key] = cycle.hooks.get(key, 0) + took

        self.patched.append((module, name, function))
        setattr(module, name, timed)

    def restore(self) -> None:
        for module, name, function in reversed(self.patched):
            setattr(module, name, function)
        self.patched.clear()


class CycleTimes:
    """What the instrumented pass measured in the current system cycle."""

    def __init__(self) -> None:
        self.active = False
        self.calls = 0  # hook calls timed so far
        self.hooks: dict[str, int] = {}


def hook_timing_cost(samples: int = 20_000) -> int:
    """What timing one hook call adds to the cycle of the module that makes it: the wrapper
    and its two readings of the clock (median of `samples`, less a plain call's)."""
    probe = types.ModuleType("probe")
    probe.nothing = plain = lambda: None
    cycle = CycleTimes()
    cycle.active = True
    timer = TimedHooks(cycle)
    timer.patch(probe, "nothing")
    timed = probe.nothing
    timer.restore()
    clock = wall_ns

    def typical(function) -> float:
        took = []
        for _ in range(samples):
            start = clock()
            function()
            took.append(clock() - start)
        return statistics.median(took)

    return max(0, round(typical(timed) - typical(plain)))


def per_module(repeater: Repeater, cycles: int) -> tuple[dict[str, float], dict[str, float], int]:
    """ns per cycle of each module and of each hook function the modules call, from an
    instrumented pass on the wall clock (the cost of reading it subtracted, and what timing
    a hook call adds subtracted from the module that calls it), leaving out the system
    cycles in which the process was descheduled (a module took PREEMPTED_NS); and how many
    cycles were left out."""
    clock = wall_ns
    overhead = clock_overhead(clock)
    per_hook_call = hook_timing_cost()
    totals: dict[str, int] = {}
    hook_totals: dict[str, int] = {}
    counted = dropped = 0
    cycle_times = CycleTimes()
    timer = TimedHooks(cycle_times)

    def instrumented(harness: Harness):
        steps = [(name, controller.run_cycle) for name, controller in controllers(harness)]
        for _, controller in controllers(harness):
            module = sys.modules[type(controller).__module__]
            hooks = getattr(module, "hooks", None)
            if isinstance(hooks, types.ModuleType):
                # the hooks it calls: a method hook_<name> each (an older template named
                # them in HOOK_DEADLINES)
                called = {a[5:] for a in dir(type(controller)) if a.startswith("hook_")}
                for name in sorted(called | set(getattr(module, "HOOK_DEADLINES", {}))):
                    timer.patch(hooks, name)
        for name, _ in steps:
            totals.setdefault(name, 0)
        took = dict.fromkeys(totals, 0)

        def cycle() -> None:
            nonlocal counted, dropped
            cycle_times.active, cycle_times.hooks = True, {}
            for name, step in steps:
                calls = cycle_times.calls
                start = clock()
                step()
                took[name] = clock() - start - (cycle_times.calls - calls) * per_hook_call
            cycle_times.active = False
            if max(took.values()) >= PREEMPTED_NS:
                dropped += 1
                return
            counted += 1
            for name, value in took.items():
                totals[name] += value - overhead
            for key, value in cycle_times.hooks.items():
                hook_totals[key] = hook_totals.get(key, 0) + value - overhead

        return cycle

    try:
        repeater.run(cycles, instrumented)
    finally:
        timer.restore()
    modules = {name: total / counted for name, total in totals.items()}
    return modules, {key: total / counted for key, total in hook_totals.items()}, dropped


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    parser.add_argument("--package", type=Path, default=PACKAGE)
    parser.add_argument("--cycles", type=int, default=CYCLES)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    args.scenario, args.package = args.scenario.resolve(), args.package.resolve()
    started = time.perf_counter()

    repeater = Repeater(args.scenario, args.package)
    modules = [name for name, _ in controllers(repeater.first)]
    repeater.run(min(2_000, args.cycles))  # warm-up
    per_cycle, runs = [], 0
    for _ in range(args.rounds):
        total, done, runs = repeater.run(args.cycles)
        per_cycle.append(total / done)
    costs, hooks, dropped = per_module(repeater, args.cycles)
    write_json(
        args.json,
        {
            "scenario": str(args.scenario.relative_to(ROOT)),
            "processes": list(repeater.first.processes),
            "modules": modules,
            "cycles_per_round": args.cycles,
            "scenario_runs_per_round": runs,
            "rounds": args.rounds,
            "ns_per_cycle": summary(per_cycle),
            "rounds_ns": per_cycle,
            "ns_per_module": summary([value / len(modules) for value in per_cycle]),
            "module_ns": costs,
            "hook_ns": hooks,
            "instrumented_cycles_dropped": dropped,
            "seconds": time.perf_counter() - started,
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
