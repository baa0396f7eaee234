"""Loop: a process plan and a block -> its modules run cyclically, in order, paced.

A generated `main_<process>.py` declares its `ProcessPlan` (modules in execution order,
roots, stand-ins, controller classes); `Process` instantiates it over a block, `start`
prepares a block and sends INIT, `run` cycles it. The clock and sleep are parameters of
the `Pacer`, so tests drive it with a fake clock. Standard library only: copied verbatim
into every generated package.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import ModuleType
from typing import Protocol

from .block import Block
from .contract import Record


class Module(Protocol):
    """What the loop needs of a generated controller."""

    def run_cycle(self) -> None: ...


ModuleClass = Callable[[memoryview, "dict[str, str] | None"], Module]


@dataclass(frozen=True)
class ProcessPlan:
    """One process of a system as the spec declares it."""

    name: str
    cycle_period: float
    modules: tuple[str, ...]  # in execution order
    roots: tuple[str, ...]  # modules with no supervisor: INIT is sent to them at start-up
    # The controller-simulation switch: a run may replace a controller by its stand-in,
    # which then runs in the controller's place while the modules below it are skipped.
    # controller -> (its stand-in, the modules of this process it replaces)
    stand_ins: Mapping[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    classes: Mapping[str, ModuleClass] = field(default_factory=dict)


class Process:
    """A process's modules over one block, called in the declared execution order."""

    __slots__ = ("block", "cycle", "layout", "modules", "plan", "simulated", "steps")

    def __init__(
        self,
        plan: ProcessPlan,
        layout: ModuleType,
        block: Block,
        settings: dict[str, str] | None = None,
        simulate: Iterable[str] = (),
    ) -> None:
        self.plan, self.layout, self.block = plan, layout, block
        self.cycle = 0
        self.simulated = tuple(simulate)
        unknown = sorted(set(self.simulated) - set(plan.stand_ins))
        if unknown:
            raise ValueError(f"no stand-in for {unknown}; these have one: {sorted(plan.stand_ins)}")
        skipped = {name for sim in self.simulated for name in plan.stand_ins[sim][1]}
        self.modules: dict[str, Module] = {}
        for name in plan.modules:
            if name in self.simulated:
                stand_in = plan.stand_ins[name][0]
                self.modules[name] = plan.classes[stand_in](block.buf, settings)
            elif name not in skipped:
                self.modules[name] = plan.classes[name](block.buf, settings)
        self.steps = tuple(module.run_cycle for module in self.modules.values())

    def run_cycle(self) -> None:
        """Run every module once, in the declared order."""
        for step in self.steps:
            step()
        self.cycle += 1

    def send_init(self) -> None:
        """Send INIT to the root modules; the state tables ripple it down the hierarchy."""
        buf = self.block.buf
        for name in self.plan.roots:
            record: Record = self.layout.COMMAND_IN[name]
            number = record.read(buf)["command_num"]
            assert isinstance(number, int)
            init = self.layout.COMMAND_NAMES[name].index("INIT")
            record.write(buf, command_num=number + 1, command=init)


def start(
    plan: ProcessPlan,
    layout: ModuleType,
    shm_name: str | None = None,
    create: bool = True,
    settings: dict[str, str] | None = None,
    simulate: Iterable[str] = (),
) -> Process:
    """Allocate (or attach to) the block, initialise the world if we made it, send INIT."""
    block = Block(layout.SIZE, shm_name, create)
    if create:
        layout.initialise(block.buf)
    process = Process(plan, layout, block, settings, simulate)
    for name in process.simulated:
        layout.MODE_IN[name].write(block.buf, simulate=True)
    process.send_init()
    return process


def run(
    plan: ProcessPlan,
    layout: ModuleType,
    cycles: int | None = None,
    pace: bool = True,
    shm_name: str | None = None,
    create: bool = True,
    on_cycle: Callable[[Process], bool | None] | None = None,
    settings: dict[str, str] | None = None,
    simulate: Iterable[str] = (),
) -> Process:
    """Start the process and run it: `cycles` times (forever if None), paced or flat out.

    `on_cycle` is called after every cycle; returning True stops the loop.
    """
    process = start(plan, layout, shm_name, create, settings, simulate)
    pacer = Pacer(plan.cycle_period if pace else 0.0)
    while cycles is None or process.cycle < cycles:
        process.run_cycle()
        if on_cycle is not None and on_cycle(process):
            break
        pacer.wait()
    return process


class Pacer:
    """Holds each cycle to the period on a monotonic clock; `period=0` runs as fast as possible."""

    def __init__(
        self,
        period: float,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.period, self.clock, self.sleep = period, clock, sleep
        self.deadline = clock() + period
        self.overruns = 0

    def wait(self) -> None:
        """Sleep until the next cycle boundary; count a cycle that ran past it."""
        if self.period <= 0:
            return
        now = self.clock()
        if now <= self.deadline:
            self.sleep(self.deadline - now)
            self.deadline += self.period
        else:
            self.overruns += 1
            self.deadline = now + self.period
