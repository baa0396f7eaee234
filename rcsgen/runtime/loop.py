"""Loop: a process plan and a block -> its modules run cyclically, in order, paced.

A generated `main_<process>.py` declares its `ProcessPlan` (modules in execution order,
roots, stand-ins, controller classes); `Process` instantiates it over a block and runs one
cycle at a time, writing the process's control record (its heartbeat) after each. `run`
paces it (free-running: a `Pacer` holds the period; a watchdog halts the roots when the
process falls too far behind its schedule; supervisors of modules in a process that stopped
beating go to their safe state). `serve` runs it in lockstep for a coordinator instead (see
`launcher.py`), `serve_ring` in its token ring (`ring.py`). The clock and sleep are
parameters, so tests drive the loop with a fake clock. Standard library only: copied
verbatim into every generated package.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from operator import itemgetter
from struct import Struct
from time import perf_counter_ns as _module_clock  # the clock generated modules read
from types import MappingProxyType, ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

from .block import Block
from .contract import (
    BEAT,
    LIVENESS_WORDS,
    MODE_FIELDS,
    PACE,
    PERF_INTERVAL,
    PERIODICITY_FIELDS,
    PROCESS,
    PROCESS_FIELDS,
    RUNNING,
    STARTING,
    STOPPED,
    counted,
    field_names,
    periodicity,
    periodicity_line,
    shared,
    silent,
    struct_format,
    words,
)
from .override import latch_safe
from .realtime import apply as apply_realtime
from .ring import Giver, Nudge, Page, Receiver, stop_on_control
from .state_time import PAUSED, StateClock, clocks
from .transport import Local, Transport

if TYPE_CHECKING:  # io_cycle is imported by a process that has I/O: ~5 ms of the others' start
    from .io_cycle import IoModule

PERF_INTERVAL_NS = round(PERF_INTERVAL * 1e9)  # how often a beat writes its record whole
STATE_WORD, HEARTBEAT_WORD, BEAT_NS_WORD = LIVENESS_WORDS
LOST_SUBORDINATE = 1  # error_num of a supervisor whose subordinate's process was lost


@shared
class RestartRefused(Exception):
    """A process cannot be restarted: a module of it keeps hook state a restart would lose."""


@shared
class DuplicateProcess(Exception):
    """A second copy of a process: its control record names a live owner."""


class Module(Protocol):
    """What the loop needs of a generated controller."""

    def run_cycle(self, began: int = 0) -> int | None:
        """One cycle; `began`: the clock read (perf_counter_ns) that ended the module before
        it (0: none). Returns the clock read that ends it (None: it took none), so that the
        modules of a process's cycle are timed by one read of the clock each."""

    def resume(self) -> None: ...


ModuleClass = Callable[[memoryview, "dict[str, str] | None"], Module]


# No record type a process imports as it starts is a dataclass: `dataclasses` imports
# `inspect` (with `ast`, `dis`, `tokenize`) and writes each class's methods with `exec`, ~15 ms
# of every process's start (bench/RESULTS.md section 4). A frozen record is a NamedTuple (its
# copy with changes: `plan._replace(...)`), a mutable one a plain class.
_NONE: Mapping[str, Any] = MappingProxyType({})  # an empty mapping no one can change


@shared
class ProcessPlan(NamedTuple):
    """One process of a system as the spec declares it."""

    name: str
    cycle_period: float
    modules: tuple[str, ...]  # in execution order
    roots: tuple[str, ...]  # modules with no supervisor: INIT is sent to them at start-up
    # The controller-simulation switch: a controller can be replaced by its stand-in, which
    # then runs in the controller's place while the modules below it are skipped.
    # controller -> (its stand-in, the modules of this process it replaces)
    stand_ins: Mapping[str, tuple[str, tuple[str, ...]]] = _NONE
    classes: Mapping[str, ModuleClass] = _NONE
    # The declared watchdog limits (system.yaml `watchdog:`): Watchdog's fields -> values
    watchdog: Mapping[str, float] = _NONE
    io: tuple[str, ...] = ()  # the I/O devices it runs: read first, written last (io_cycle.py)
    # The declared real-time settings (system.yaml `realtime:`), applied as it starts
    realtime: Mapping[str, object] = _NONE


class Watchdog(NamedTuple):
    """When a paced process trips its watchdog, and when it warns of load."""

    behind: float = 5.0  # periods: the cycles of the last `window` periods this late in all
    window: int = 10  # periods
    period_factor: float = 3.0  # one cycle longer than this many periods trips it too
    load_warning: float = 0.8  # a cycle longer than this share of the period is counted

    def trips(self, pacer: Pacer, took_ns: int, period: float) -> bool:
        """Whether the cycle that took `took_ns` (and the wait after it) trips the watchdog:
        the cycles of the last `window` periods started `behind` periods late or more, in
        all (`Pacer.behind`: a stall counts its length; a starved process, late now and on
        time then, adds up), or the cycle took longer than `period_factor` periods. A trip
        starts the count again."""
        late = pacer.behind(self.window) >= self.behind
        if late or took_ns > self.period_factor * period * 1e9:
            pacer.forget()
            return True
        return False


class Reaction(NamedTuple):
    """What the loss of one process (dead, stopped, frozen, starved, or its watchdog
    tripped) asks of everyone else (docs/semantics.md, "Fail safe").

    Contained (every module of the process hangs below a supervisor that declared
    `on_lost: continue` for it): only the actuators that process writes are latched safe,
    and those supervisors see the subordinate's status ERROR (LOST) while it is lost.
    Otherwise (`halt_all`, the default): every actuator of the system is latched safe, and
    every controller that supervises one of its modules, with every controller above it,
    goes to the safe state (HALT to its subordinates, ERROR with reason LOST)."""

    latch: tuple[str, ...]
    safe: tuple[str, ...]
    told: tuple[tuple[str, str], ...]  # (supervisor, subordinate): `continue` rules handle it
    contained: bool


def reaction(layout: ModuleType, process: str) -> Reaction:
    """The reaction to the loss of `process`, from the layout's hierarchy and policies."""
    placement, subordinates = layout.PLACEMENT, layout.SUBORDINATES
    supervisor = {sub: sup for sup, subs in subordinates.items() for sub in subs}
    continued = getattr(layout, "ON_LOST_CONTINUE", {})
    # A simulator (`simulators:`) stands for equipment and the world, commanded by nobody: it
    # goes with the process that runs it and does not make the loss the whole system's.
    simulators = set(getattr(layout, "SIMULATORS", ()))
    mine = [
        m
        for m, p in placement.items()
        if p == process and m in layout.MODULES and m not in simulators
    ]
    outside = [
        (supervisor[m], m)
        for m in mine
        if placement.get(supervisor.get(m, "")) not in (None, process)
    ]
    inside = [m for m in mine if placement.get(supervisor.get(m, "")) == process]
    contained = bool(outside) and len(outside) + len(inside) == len(mine)
    contained = contained and all(m in continued.get(s, ()) for s, m in outside)
    actuated_by = getattr(layout, "ACTUATED_BY", {})
    if contained:
        latch = tuple(f for f, p in actuated_by.items() if p == process)
        return Reaction(latch, (), tuple(outside), True)
    safe: list[str] = []
    for above, _ in outside:
        while above and above not in safe and placement.get(above) != process:
            safe.append(above)
            above = supervisor.get(above, "")
    return Reaction(tuple(getattr(layout, "SAFE_VALUES", {})), tuple(safe), (), False)


class Process:
    """A process's modules over one block, called in the declared execution order."""

    def __init__(
        self,
        plan: ProcessPlan,
        layout: ModuleType,
        block: Block,
        settings: dict[str, str] | None = None,
        simulate: Iterable[str] = (),
        restarting: bool = False,
    ) -> None:
        self.plan, self.layout, self.block = plan, layout, block
        if restarting:
            self._refuse_a_second_copy()
            self._refuse_lost_hook_state()
        self.cycle = 0
        self.periodicity: Periodicity | None = None  # paced by `run`: how well it held
        unknown = sorted(set(simulate) - set(plan.stand_ins))
        if unknown:
            raise ValueError(f"no stand-in for {unknown}; these have one: {sorted(plan.stand_ins)}")
        buf = block.buf
        for name in simulate:
            layout.MODE_IN[name].write(buf, simulate=True)
        # Every module and stand-in is built once; the simulate flags choose who runs.
        self.instances: dict[str, Module] = {
            name: plan.classes[name](buf, settings) for name in plan.modules
        }
        self.stand_ins: dict[str, Module] = {
            name: plan.classes[stand_in](buf, settings)
            for name, (stand_in, _) in plan.stand_ins.items()
        }
        at = struct_format(MODE_FIELDS[: [n for n, _ in MODE_FIELDS].index("simulate")])
        offset = Struct(at).size
        self._switch_at = {name: layout.MODE_IN[name].offset + offset for name in plan.stand_ins}
        # the simulate flags' bytes as one C call reads them (a tuple, or one int for one),
        # and as they were when the stand-ins were last chosen: unchanged, nothing to choose
        self._flag_bytes = itemgetter(*self._switch_at.values()) if self._switch_at else None
        self._flags_seen: object = None
        self.simulated: tuple[str, ...] = ()
        self.modules: dict[str, Module] = {}
        self._publishers: tuple[Callable[[], None], ...] = ()  # each module's `publish`
        self._publish_due = 0  # monotonic_ns: when the next beat publishes them
        self._longest_shown = 0  # the control record's max_cycle_ns as last written whole
        self.steps: tuple[Callable[[int], int | None], ...] = ()  # each running module's cycle
        # time in state (rcs/state_time.py): each controller's and stand-in's clock, and the
        # clock of each module running now (a stand-in's under its controller's name)
        before = int(layout.PROCESSES[plan.name].read(buf)["heartbeat"]) if restarting else 0
        self.clocks = clocks(
            layout, buf, [*plan.modules, *(s for s, _ in plan.stand_ins.values())], before
        )
        self.timed: dict[str, tuple[StateClock, Any]] = {}
        self._looked: dict[str, tuple[StateClock, Any]] = {}  # timed, but cannot tell
        self.io_steps: tuple[tuple[Callable[[], None], ...], ...] = ((), ())
        self._choose(self._simulate_flags())
        # The control record: this process is its only writer (the launcher marks it dead).
        self.record = layout.PROCESSES[plan.name]
        self.record_seq = self.record.seq(buf)
        self.record_word = self.record.offset >> 3  # its sequence word (contract.words)
        self.words = words(buf)
        self.record_seq += self.record_seq & 1
        self.counters = dict.fromkeys(field_names(PROCESS_FIELDS), 0)
        self.counters.update(pid=os.getpid(), state=STARTING)
        self.lost: set[str] = set()
        self.tripped: dict[str, int] = {}  # each other process's watchdog trips, last seen
        self.reactions = {name: reaction(layout, name) for name in layout.PROCESSES}
        self.io: IoModule | None = None  # unless the system declares I/O this process touches
        if getattr(layout, "IO_DEVICES", None):
            from .io_cycle import attach as attach_io

            self.io = attach_io(self)
        if self.io is not None:
            self.io_steps = ((self.io.before,), (self.io.after,))
            self._choose(self.simulated)
        self.beat()

    def _refuse_a_second_copy(self) -> None:
        """A process whose control record names a live owner is running: refuse to be a
        second copy (two writers of every buffer it owns)."""
        record = self.layout.PROCESSES[self.plan.name]
        _, pid, state, _, _, _ = BEAT.unpack_from(self.block.buf, record.offset)
        if state in (STARTING, RUNNING) and pid and pid != os.getpid() and _alive(pid):
            raise DuplicateProcess(
                f"process {self.plan.name} is already running (pid {pid}): a second copy is "
                "refused; stop that one first (or, if it is frozen, kill it)"
            )

    def _refuse_lost_hook_state(self) -> None:
        """A module that ran before and keeps hook state outside the block (a simulator's
        mine) cannot be restarted unless its spec says the state may start again."""
        buf = self.block.buf
        for name in self.plan.modules:
            cls = self.plan.classes[name]
            if getattr(cls, "HOOK_STATE_ON_RESTART", "reset") != "refuse":
                continue
            if self.layout.PERFORMANCE[name].read(buf)["cycles"]:
                raise RestartRefused(
                    f"{name} keeps hook state outside the block, which a restart of process "
                    f"{self.plan.name} would lose (it would simulate again what it already "
                    "did); restart the whole system, or declare `hooks_state_on_restart: "
                    f"reset` in {name}'s spec if starting that state again is harmless"
                )

    # ------------------------------------------------------------ the simulation switch

    def _simulate_flags(self) -> tuple[str, ...]:
        buf = self.block.buf
        return tuple(name for name, at in self._switch_at.items() if buf[at])

    def _choose(self, simulated: tuple[str, ...]) -> None:
        """Run each switchable controller, or its stand-in in its place (skipping the modules
        below it); a module taking over resumes from the block."""
        skipped = {name for sim in simulated for name in self.plan.stand_ins[sim][1]}
        modules = {}
        for name in self.plan.modules:
            if name in simulated:
                modules[name] = self.stand_ins[name]
            elif name not in skipped:
                modules[name] = self.instances[name]
        self._hand_over(modules)
        self.simulated, self.modules = simulated, modules
        runs = {n: self.plan.stand_ins[n][0] if n in simulated else n for n in modules}
        timed = {
            n: (self.clocks[runs[n]], m)
            for n, m in modules.items()
            if runs[n] in self.clocks and hasattr(m, "state")  # (a test's stand-in may not)
        }
        running = {id(clock) for clock, _ in timed.values()}
        for clock, _ in self.timed.values():  # replaced by a stand-in, or back: no time now
            if id(clock) not in running:
                clock.enter(self.block.buf, PAUSED, self.cycle)
        self.timed = timed
        self._looked = self._tell_states(timed)
        self.steps = tuple(module.run_cycle for module in modules.values())
        self._publishers = tuple(m.publish for m in modules.values() if hasattr(m, "publish"))

    def _hand_over(self, modules: dict[str, Module]) -> None:
        """Modules `modules` take over from the running ones: one leaving publishes its
        figures as they are, one taking over resumes from the block."""
        for name, module in self.modules.items():
            if modules.get(name) is not module and hasattr(module, "publish"):
                module.publish()
        for name, module in modules.items():
            if self.modules and self.modules.get(name) is not module:
                module.resume()

    def _tell_states(self, timed: dict[str, tuple[StateClock, Any]]) -> dict[str, Any]:
        """Each timed module's clock, given to it: a generated controller or stand-in changes
        its state only in a cycle that writes its status record (post_process writes it
        whenever a rule fired or status_dirty is set, as every state change sets one), and
        tells its `on_state` as it does; its clock counts from that process cycle. The
        modules that cannot tell (an operator module, a test's stand-in): looked at after
        every cycle, {name: (clock, module)}."""
        buf, looked = self.block.buf, {}
        for name, (clock, module) in timed.items():
            if hasattr(module, "on_state"):
                module.on_state = self._teller(clock)
                clock.tick(buf, module.state, self.cycle)  # the state it takes over in
            else:
                looked[name] = (clock, module)
        return looked

    def _teller(self, clock: StateClock) -> Callable[[int], None]:
        buf = self.block.buf

        def tell(state: int) -> None:
            clock.tick(buf, state, self.cycle)

        return tell

    # ------------------------------------------------------------ running

    def run_cycle(self) -> None:
        """Run every module once, in the declared order (between the I/O's read and write),
        then beat. The clock is read once before the first module and once by each module as
        it ends: a module's execution time is from the read before it to its own."""
        if self._flag_bytes is not None:
            seen = self._flag_bytes(self.block.buf)
            if seen != self._flags_seen:
                self._flags_seen = seen
                flags = self._simulate_flags()
                if flags != self.simulated:
                    self._choose(flags)
        before, after = self.io_steps
        for io in before:
            io()
        now: int | None = _module_clock()  # (the modules' clock, not the pacing one)
        for step in self.steps:
            now = step(now or 0)
        for io in after:
            io()
        if self._looked:  # the modules that cannot tell their clock of a new state
            buf, cycle = self.block.buf, self.cycle
            for clock, module in self._looked.values():
                clock.tick(buf, module.state, cycle)
        self.cycle += 1
        self.beat()

    def run_modules(self, first: int, last: int) -> None:
        """Run the plan's modules `first` to `last` (indices into plan.modules, inclusive)
        that are running: one segment of a lockstep cycle."""
        if first == 0 and self._switch_at:
            flags = self._simulate_flags()
            if flags != self.simulated:
                self._choose(flags)
        if first == 0:
            for step in self.io_steps[0]:
                step()
        now: int | None = _module_clock()  # (the modules' clock, not the pacing one)
        for name in self.plan.modules[first : last + 1]:
            module = self.modules.get(name)
            if module is not None:
                now = module.run_cycle(now or 0)
                if name in self._looked:  # (the others tell their clocks themselves)
                    clock, timed = self._looked[name]
                    clock.tick(self.block.buf, timed.state, self.cycle)

    def beat(self, state: int = RUNNING, now_ns: int | None = None) -> None:
        """Write the control record's liveness words (the state and watchdog trips, the
        heartbeat, when it beat) under its sequence word; and, with the first beat
        PERF_INTERVAL_NS after the last, the whole record (its counts and times, for people)
        and the modules' performance buffers. Also whole: any beat but RUNNING's (starting,
        stopping), any that reports a process lost or no longer lost, and any after its
        longest cycle yet (as a module's)."""
        counters = self.counters  # set one by one: update(**) would build a dict a beat
        counters["state"] = state
        counters["heartbeat"] = self.cycle
        counters["beat_ns"] = now = time.monotonic_ns() if now_ns is None else now_ns
        lost = self._lost_mask() if self.lost else 0
        seq = self.record_seq + 1
        words, word = self.words, self.record_word
        longest = counters["max_cycle_ns"]
        if (
            now >= self._publish_due
            or state != RUNNING
            or lost != counters["lost"]
            or longest != self._longest_shown
        ):
            self.publish(now)
            counters["lost"], self._longest_shown = lost, longest
            words[word] = seq  # odd before any field changes, in one 8-byte store
            PROCESS.pack_into(self.block.buf, self.record.offset, seq, *counters.values())
        else:  # the liveness words alone, each one 8-byte store (contract.LIVENESS_WORDS)
            words[word] = seq
            words[word + STATE_WORD] = state | counters["watchdog_trips"] << 32
            words[word + HEARTBEAT_WORD] = self.cycle
            words[word + BEAT_NS_WORD] = now
        words[word] = seq + 1
        self.record_seq = seq + 1

    def publish(self, now_ns: int = 0) -> None:
        """Each running module's performance buffer written (its `publish`): its execution
        times and cycle count, which only people and tools read, are kept in the module and
        published every PERF_INTERVAL_NS (and at once by a module whose cycle is its
        longest yet, or a single step), not by every cycle of every module."""
        for publish in self._publishers:
            publish()
        self._publish_due = now_ns + PERF_INTERVAL_NS

    def _lost_mask(self) -> int:
        if not self.lost:  # nearly always: no list built for a beat
            return 0
        names = list(self.layout.PROCESSES)
        return sum(1 << names.index(name) for name in self.lost)

    def send_init(self, only_idle: bool = False) -> None:
        """Send INIT to the root modules; the state tables ripple it down the hierarchy.

        With `only_idle`, a root that has had a command is left alone: a restarted process
        must not drop the mission a running root is in the middle of."""
        buf = self.block.buf
        for name in self.plan.roots:
            record = self.layout.COMMAND_IN[name]
            number = record.read(buf)["command_num"]
            assert isinstance(number, int)
            if only_idle and number:
                continue
            init = self.layout.COMMAND_NAMES[name].index("INIT")
            record.write(buf, command_num=number + 1, command=init)

    def react(self, process: str, reason: int = 1) -> list[str]:
        """The reaction to the loss (or trip) of `process`, for this process's part: latch
        the actuators safe, put the supervisors here in their safe state, tell the ones with
        `on_lost: continue`. The actuators latched now (not already)."""
        todo = self.reactions[process]
        latched = latch_safe(self.layout, self.block.buf, todo.latch, self.block.name)
        for name in todo.safe:
            module = self.modules.get(name)
            safe_state = getattr(module, "safe_state", None)
            if safe_state is not None:
                safe_state(reason)
        for supervisor, sub in todo.told:
            module = self.modules.get(supervisor)
            if module is not None:
                setattr(module, f"{sub}_lost", True)
        return latched

    def recovered(self, process: str) -> None:
        """`process` beats again: the supervisors told it was lost see its status again (the
        latched actuators stay latched until a reset)."""
        for supervisor, sub in self.reactions[process].told:
            module = self.modules.get(supervisor)
            if module is not None:
                setattr(module, f"{sub}_lost", False)

    def safe_stop(self, everything: bool = False) -> list[str]:
        """This process stops (or has lost its launcher: `everything`): latch the actuators
        it writes (every actuator of the system) at their safe values."""
        actuated_by = getattr(self.layout, "ACTUATED_BY", {})
        fields = [f for f, p in actuated_by.items() if everything or p == self.plan.name]
        if everything:
            fields = list(getattr(self.layout, "SAFE_VALUES", {}))
        return latch_safe(self.layout, self.block.buf, fields, self.block.name)

    def halt_roots(self) -> None:
        """Send HALT to the root modules (the watchdog's safe stop)."""
        buf = self.block.buf
        for name in self.plan.roots:
            record = self.layout.COMMAND_IN[name]
            number = record.read(buf)["command_num"]
            assert isinstance(number, int)
            halt = self.layout.COMMAND_NAMES[name].index("HALT")
            record.write(buf, command_num=number + 1, command=halt)

    # ------------------------------------------------------------ liveness

    def watched(self) -> list[str]:
        """The other processes: each one's loss asks something of this one (its supervisors'
        safe state, or the actuators every survivor latches)."""
        return [name for name in self.layout.PROCESSES if name != self.plan.name]

    def check_liveness(self, timeout_ns: int, now_ns: int, watched: Iterable[str]) -> None:
        """Report a watched process lost when its heartbeat is older than `timeout_ns`
        stretched by its slow-down (a freeze, a starved CPU), or it is marked STOPPED or
        DEAD, and react (`react`); react again to each watchdog trip it reports. A lost
        process that beats again is no longer lost (its latches stay until a reset)."""
        buf = self.block.buf
        for name in watched:
            lost, trips = silent(self.layout, buf, name, timeout_ns, now_ns)
            if lost and name not in self.lost:
                self.lost.add(name)
                self.react(name)
            elif not lost and name in self.lost:
                self.lost.discard(name)
                self.recovered(name)
            if trips > self.tripped.get(name, trips):
                self.react(name)
            elif not lost and trips == self.tripped.get(name) and name not in self.lost:
                self.recovered(name)  # a trip is told for one cycle
            self.tripped[name] = trips


def _alive(pid: int) -> bool:
    """Whether a process of this id exists (ours to signal or not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def start(
    plan: ProcessPlan,
    layout: ModuleType,
    shm_name: str | None = None,
    create: bool = True,
    settings: dict[str, str] | None = None,
    simulate: Iterable[str] = (),
) -> Process:
    """Allocate (or attach to) the block and send INIT to the roots that have had no
    command yet (all of them in a new block; a restarted process resumes the others)."""
    block = Block(layout, shm_name, create)
    try:
        process = Process(plan, layout, block, settings, simulate, restarting=not create)
        process.send_init(only_idle=not create)
    except BaseException:
        block.close()
        raise
    return process


class Stop:
    """A flag a signal handler sets to end `run` after the current cycle; `run` names the
    process it runs in it, and the caller sets `finished` when the process is done with (a
    watcher of the launcher's death uses both: launcher.py)."""

    def __init__(self) -> None:
        self.requested = False
        self.orphaned = False  # the launcher went away (a child then removes the segment)
        self.process: Process | None = None
        self.finished = threading.Event()

    def __call__(self, *args: object) -> None:
        self.requested = True


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
    stop: Stop | None = None,
    watchdog: Watchdog | None = None,
    heartbeat_timeout: float | None = None,
    transport: Callable[[Process], Transport] | None = None,
) -> Process:
    """Start the process and run it: `cycles` times (forever if None), paced or flat out,
    until `on_cycle` returns True or `stop` is requested. The caller closes its block.

    Paced, the period is stretched by the process's `slow` factor (its pacing record, set by
    an operator) each cycle; the watchdog (from the second cycle on) latches the process's
    reaction and halts the roots when the cycles of the last `watchdog.window` periods
    started `watchdog.behind` periods late in all, or a cycle took longer than
    `watchdog.period_factor` periods, and
    supervisors of modules in another process go to their safe state when its heartbeat is
    older than `heartbeat_timeout` seconds (`layout.HEARTBEAT_TIMEOUT` by default).

    With a network `transport` (made for the started process), what arrived is mirrored
    into the block before each cycle and what the process wrote is sent after it.
    """
    process = start(plan, layout, shm_name, create, settings, simulate)
    if stop is not None:
        stop.process = process
    try:
        start_realtime(process)
        net = transport(process) if transport is not None else Local()
    except BaseException:
        process.block.close()
        raise
    period = plan.cycle_period if pace else 0.0
    measured = process.periodicity = Periodicity(plan.name, period, _warn)
    pacer = Pacer(period, periodicity=measured)
    periodicity_names = field_names(PERIODICITY_FIELDS)
    dog = watchdog or Watchdog(**plan.watchdog)  # type: ignore[arg-type]
    timeout = heartbeat_timeout if heartbeat_timeout is not None else layout.HEARTBEAT_TIMEOUT
    timeout_ns = int(timeout * 1e9)
    watched = process.watched()
    counters = process.counters
    pacing = getattr(layout, "PACING", {}).get(plan.name)  # the operator's slow-down
    try:
        while cycles is None or process.cycle < cycles:
            began = time.perf_counter_ns()
            net.pull()
            process.run_cycle()
            net.push()
            took = time.perf_counter_ns() - began
            counters["last_cycle_ns"] = took
            counters["max_cycle_ns"] = max(counters["max_cycle_ns"], took)
            if watched:
                process.check_liveness(timeout_ns, time.monotonic_ns(), watched)
            if on_cycle is not None and on_cycle(process):
                break
            if stop is not None and stop.requested:
                break
            if period > 0:
                if pacing is not None:  # one float, written whole: read without the seqlock
                    pacer.period = period * max(
                        1.0, PACE.unpack_from(process.block.buf, pacing.offset)[1]
                    )
                if took > dog.load_warning * period * 1e9:
                    counters["load_warnings"] += 1
                pacer.wait()
                counters["overruns"], counters["late_wakeups"] = pacer.overruns, pacer.late
                if not measured.count % measured.REFRESH:  # with its p99: one snapshot
                    counters.update(zip(periodicity_names, measured.fields(), strict=True))
                if process.cycle == 1:  # the start-up cycle: the start-up barrier bounds it
                    pacer.forget()
                elif dog.trips(pacer, took, period):  # its outputs safe, its roots halted
                    counters["watchdog_trips"] += 1
                    process.react(plan.name)
                    process.halt_roots()
    finally:
        # Stopped (Ctrl-C, SIGTERM, --cycles) or orphaned (the launcher died): the actuators
        # it writes (orphaned: every actuator, as the others may be gone too) go safe, latched.
        process.safe_stop(everything=stop is not None and stop.orphaned)
        if process.io is not None:
            process.io.close()  # the devices get the safe outputs once more
        if measured.count:  # the last figures, the p99 as of now, for the summary
            measured.p99()
            counters.update(zip(periodicity_names, measured.fields(), strict=True))
        process.beat(STOPPED)
        net.close()  # sends the STOPPED
    return process


def start_realtime(process: Process) -> None:
    """The process's declared real-time settings applied (rcs/realtime.py): a line on
    stderr for each refused; RealtimeRefused if they are required."""
    if process.plan.realtime:
        for line in apply_realtime(process.plan.name, process.plan.realtime):
            _warn(line)


def _warn(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


class Pacer:
    """Holds each cycle to the period on a monotonic clock; `period=0` runs as fast as possible.

    Counts overruns (each period boundary a cycle or a stall ran past: the schedule goes on
    from the next boundary), late wake-ups (a sleep that ended more than `late_after` of a
    period past its boundary), and remembers how late each recent cycle started (`behind`)."""

    def __init__(
        self,
        period: float,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        late_after: float = 0.1,
        periodicity: Periodicity | None = None,
    ) -> None:
        self.period, self.clock, self.sleep = period, clock, sleep
        self.now = clock()
        self.deadline = self.now + period
        self.overruns = self.late = 0
        self.late_after = late_after * period
        self.lateness: deque[tuple[float, float]] = deque()  # (when, seconds late)
        self.periodicity = periodicity

    def wait(self) -> None:
        """Sleep until the next cycle boundary; count the boundaries a cycle or a stall
        (frozen, starved) ran past, and remember how late the next cycle starts."""
        if self.period <= 0:
            return
        now = self.clock()
        if now <= self.deadline:
            self.sleep(self.deadline - now)
            now = self.clock()
            late = now - self.deadline
            if late > self.late_after:
                self.late += 1
            missed = int(late // self.period) if late >= self.period else 0
            self.deadline += (missed + 1) * self.period
        else:  # each period it missed is an overrun: a 3 s stall at 0.1 s is 30
            late = now - self.deadline
            missed = int(late // self.period) + 1
            self.deadline = now + self.period
        self.overruns += missed
        if self.periodicity is not None:
            self.periodicity.add(now, late, now - self.now - self.period)
        self.now = now
        if late > self.late_after:  # jitter below a tenth of a period is not remembered
            self.lateness.append((now, late))

    def behind(self, window: int) -> float:
        """How late, in periods, the cycles of the last `window` periods started, in all."""
        horizon = self.now - window * self.period
        while self.lateness and self.lateness[0][0] <= horizon:
            self.lateness.popleft()
        return sum(late for _, late in self.lateness) / self.period

    def forget(self) -> None:
        """Start the count of recent lateness again (a trip, the start-up cycle)."""
        self.lateness.clear()


class Periodicity:
    """How well a paced process holds its period: each wake-up's lateness (a histogram of
    the last `window`, for the p99) and period error (the time since the previous wake-up
    minus the period: the mean of its magnitude, and its largest), and throttled warnings:
    at most one line every `every` seconds, when wake-ups came more than `warn_after` of a
    period late, saying how many did since the last line.

    Cheap enough for every cycle: a wake-up costs a bucket index and two counts (no sort);
    the p99 is taken from the histogram every `REFRESH` wake-ups, as the upper edge of its
    bucket (1 µs wide below 32 µs, then 16 buckets an octave: within 1/16 of the value),
    never above the largest lateness seen; `run` copies the figures into the control
    record at the same moments (and when the process stops), one snapshot of them all.
    `fields()` gives the figures the control record carries (contract.PERIODICITY_FIELDS),
    so `ctl status`, the monitor and the launcher's summary show what the process measured."""

    REFRESH = 16  # wake-ups between two p99s taken from the histogram

    def __init__(
        self,
        name: str,
        period: float,
        warn: Callable[[str], None] | None = None,
        warn_after: float = 0.5,
        every: float = 10.0,
        window: int = 4096,
    ) -> None:
        self.name, self.period, self.warn = name, period, warn
        self.warn_after, self.every = warn_after * period, every
        self.buckets: deque[int] = deque(maxlen=window)  # the last wake-ups' buckets
        self.histogram = [0] * LATENESS_BUCKETS
        self.count, self.error_sum, self.error_max, self.late_max = 0, 0.0, 0.0, 0.0
        self.warned_at, self.unwarned, self.warnings = -every, 0, 0
        self.p99_s = 0.0

    def add(self, now: float, late: float, error: float) -> None:
        self.count += 1
        bucket = lateness_bucket(late)
        kept = self.buckets
        if len(kept) == kept.maxlen:
            self.histogram[kept[0]] -= 1  # the oldest leaves the window as this one comes
        kept.append(bucket)
        self.histogram[bucket] += 1
        error = abs(error)
        self.error_sum += error
        self.error_max = max(self.error_max, error)
        self.late_max = max(self.late_max, late)
        if not self.count % self.REFRESH:
            self.p99_s = self.quantile(0.99)
        if late > self.warn_after:
            self.unwarned += 1
            if now - self.warned_at >= self.every and self.warn is not None:
                self.warn(
                    f"{self.name}: {counted(self.unwarned, 'wake-up')} more than "
                    f"{self.warn_after * 1e3:g} ms late (the last {late * 1e3:.1f} ms, "
                    f"period {self.period * 1e3:g} ms): loaded machine, or the period too "
                    "short"
                )
                self.warned_at, self.unwarned, self.warnings = now, 0, self.warnings + 1

    def quantile(self, q: float) -> float:
        """The `q` quantile of the kept wake-ups' lateness (seconds): the upper edge of the
        bucket it falls in, at most the largest lateness seen; 0 before any wake-up."""
        kept = len(self.buckets)
        if not kept:
            return 0.0
        rank = min(kept - 1, int(q * kept))  # as sorted(lateness)[rank] would be
        seen = 0
        for bucket, count in enumerate(self.histogram):
            seen += count
            if seen > rank:
                return min(bucket_edge(bucket) * 1e-6, self.late_max)
        return self.late_max  # (not reached: the counts add up to `kept`)

    def p99(self) -> float:
        """The 99th percentile of the kept wake-ups' lateness (seconds), as of now."""
        self.p99_s = self.quantile(0.99)
        return self.p99_s

    def fields(self) -> tuple[int, ...]:
        """The control record's periodicity fields (contract.PERIODICITY_FIELDS), in ns."""
        return (
            int(self.period * 1e9),
            self.count,
            int(self.error_sum * 1e9),
            int(self.error_max * 1e9),
            int(self.p99_s * 1e9),
            int(self.late_max * 1e9),
            self.warnings,
        )

    def line(self) -> str:
        """One line for a summary (contract.periodicity_line), the p99 as of now."""
        self.p99()
        figures = dict(zip(field_names(PERIODICITY_FIELDS), self.fields(), strict=True))
        return periodicity_line(self.name, periodicity(figures))


def lateness_bucket(late: float) -> int:
    """The histogram bucket of a lateness (seconds): whole µs below 32 µs, then 16 buckets
    an octave (each within 1/16 of its values); a negative lateness is 0, a huge one the
    last bucket."""
    us = int(late * 1e6)
    if us < 32:
        return max(0, us)
    shift = us.bit_length() - 5
    return min(LATENESS_BUCKETS - 1, 16 * shift + (us >> shift))


def bucket_edge(bucket: int) -> int:
    """The upper edge (µs, exclusive) of a lateness bucket."""
    if bucket < 32:
        return bucket + 1
    shift, mantissa = bucket // 16 - 1, bucket % 16 + 16
    return (mantissa + 1) << shift


LATENESS_BUCKETS = 16 * 32  # up to 2^35 µs (9.5 hours): anything later is in the last


# ---------------------------------------------------------------- lockstep

# A coordinator steps a process through a pipe: each request is one segment of a system
# cycle (the plan's modules `first`..`last`), and `end` says whether the process's cycle
# ends with it; the process answers when it has run them.
STEP = Struct("<cHH?")  # b"s", first, last, end; b"q" asks the process to stop
DONE_REPLY = b"d"
READY = b"r"  # a process says so once it has started (and sent INIT to its idle roots)


def serve(process: Process, requests: int, replies: int) -> None:
    """Run `process` in lockstep: one segment per request read from the file descriptor
    `requests`, an answer written to `replies`, until b"q" or the coordinator goes away."""
    os.write(replies, READY)
    while True:
        message = _read_exactly(requests, STEP.size)
        if message is None:
            break
        op, first, last, end = STEP.unpack(message)
        if op != b"s":
            break
        run_segment(process, first, last, end)
        os.write(replies, DONE_REPLY)
    if process.io is not None:
        process.io.close()
    process.beat(STOPPED)


def serve_ring(
    process: Process,
    control: int,
    replies: int,
    link: tuple[int, int],
    spin: float,
    turns: tuple[int, int] | None = None,
    dedicated: bool = False,
) -> None:
    """Run `process` in a lockstep ring (rcs/ring.py): a whole cycle each time the token
    comes on `link[0]`, then the token on to `link[1]`; until the coordinator writes on
    (or closes) the `control` pipe. With the token, it nudges the next member, which then
    spins for it (where `spin` > 0 and a core is free). `turns`: the ring's page (its fd)
    and this member's place in the ring, where the token is a turn word (ring.Page);
    `dedicated`: spin without looking at the machine's load (ring.Load)."""
    page = Page(turns[0]) if turns is not None else None
    at = turns[1] if turns is not None else 0
    receiver = Receiver(link[0], spin, page, at, dedicated)
    nudge, give = Nudge(link[1], spin, page, at + 1, dedicated), Giver(link[1], page, at + 1)
    stop_on_control(control, link[0], page, at)
    os.write(replies, READY)
    counters, clock = process.counters, time.perf_counter_ns
    while receiver.wait():
        began = clock()
        nudge()
        process.run_cycle()  # the whole process cycle, as a free-running process runs it
        ended = clock()
        give()
        # from the token to its beat, in the control record from the next beat on (as a
        # free-running process's); counted after the hand-on, which the next one waits for
        took = counters["last_cycle_ns"] = ended - began
        counters["max_cycle_ns"] = max(counters["max_cycle_ns"], took)
    nudge.close()
    receiver.close()
    if process.io is not None:
        process.io.close()
    process.beat(STOPPED)


def run_segment(process: Process, first: int, last: int, end: bool) -> None:
    """One segment of a lockstep cycle; with `end`, the process's cycle ends (it beats)."""
    process.run_modules(first, last)
    if end:
        for step in process.io_steps[1]:
            step()
        process.cycle += 1
        process.beat()


def _read_exactly(fd: int, size: int) -> bytes | None:
    data = b""
    while len(data) < size:
        chunk = os.read(fd, size - len(data))
        if not chunk:
            return None
        data += chunk
    return data
