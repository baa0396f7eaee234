"""Launcher: a generated package -> its processes as OS processes over one segment, and a summary.

`python -m <system>` runs every process of the system: the launcher creates (and owns) the
shared-memory segment, starts one OS process per `processes:` entry, watches them (a
process that dies is marked DEAD in its control record, so the supervisors of its modules
go to their safe state; with `--restart` it is started again and resumes), and on Ctrl-C
or SIGTERM stops them all, prints a summary per process and removes the segment. In
lockstep (`--lockstep`, or `Launcher(lockstep=True)` from a test harness) a `Coordinator`
steps the processes in the system's execution order, a token passed process to process
(rcs/ring.py), so a multi-process run leaves the same trace as a one-process run.
`python -m <system> PROCESS` runs one process (as the launcher's child, or by hand).
Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import argparse
import importlib
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from collections.abc import Set as AbstractSet
from types import ModuleType
from typing import TYPE_CHECKING, Any, NamedTuple, NoReturn, Self

from ..block import Block, BlockError
from ..contract import (
    BEAT,
    DEAD,
    PROCESS_STATES,
    RUNNING,
    STARTUP_TIMEOUT,
    STOPPED,
    StaleRead,
    enum_code,
    enum_name,
    listed,
    network_line,
    periodicity,
    periodicity_line,
    shared,
)
from ..loop import (
    DONE_REPLY,
    READY,
    STEP,
    DuplicateProcess,
    Process,
    ProcessPlan,
    RestartRefused,
    Stop,
    reaction,
    run,
    serve,
    serve_ring,
    start,
    start_realtime,
)
from ..override import latch_safe
from ..realtime import RealtimeRefused
from ..ring import (
    Giver,
    Link,
    Nudge,
    Page,
    Return,
    close_links,
    default_spin,
    new_links,
)
from ..transport import PLAINTEXT, Security, TransportError, check_endpoint
from .command import (
    Command,
    outcome,
    parse_command,
    parse_value,
    suggest,
    write_command,
)

if TYPE_CHECKING:  # imported where the launcher starts processes: ~5 ms a process's start
    import subprocess

from .startup import (
    FAILURES,
    START_FAILED,
    default_segment,
    ending,
    parse_settings,
    report_failure,
    segment_problem,
)

STOP_GRACE = 5.0  # seconds a process has to stop before it is killed
# Seconds a lockstep process may take over one segment before it counts as lost: well past
# any segment whose hooks keep their deadlines (a hook's default is 1 s).
LOCKSTEP_TIMEOUT = 20.0
PR_SET_PDEATHSIG = 1  # prctl(2): the signal a child gets when its parent dies (Linux)
REFUSED = 3  # the exit code of a process that refused to restart (the launcher gives up)


class System(NamedTuple):
    """A generated package as the launcher sees it: its layout and each process's plan."""

    package: str
    layout: ModuleType
    plans: Mapping[str, ProcessPlan]
    path: tuple[str, ...] = ()  # where the processes find the package and its hooks

    @classmethod
    def load(cls, package: str) -> System:
        layout = importlib.import_module(f"{package}.layout")
        return cls(package, layout, Plans(package, tuple(layout.PROCESSES)))

    @property
    def default_segment(self) -> str:
        return default_segment(self.layout)

    def segments(self) -> list[tuple[str, int, int, bool]]:
        """The system's execution order as lockstep segments: (process, first, last, end)
        with `first`..`last` indices into that process's plan; `end` on the last segment of
        each process in a cycle. The order is the processes' modules, process by process."""
        found = []
        for name, plan in self.plans.items():
            found.append((name, 0, len(plan.modules) - 1, True))
        return found


class Plans(Mapping[str, ProcessPlan]):
    """Each process's plan by name, its module (`main_<process>`, which imports the
    process's controllers and their hooks) imported when the plan is first asked for: a
    process started alone imports its own modules only, not every process's."""

    def __init__(self, package: str, names: tuple[str, ...]) -> None:
        self.package, self.names, self.loaded = package, names, dict[str, ProcessPlan]()

    def __getitem__(self, name: str) -> ProcessPlan:
        if name not in self.loaded:
            if name not in self.names:
                raise KeyError(name)
            plan: ProcessPlan = importlib.import_module(f"{self.package}.main_{name}").PLAN
            self.loaded[name] = plan
        return self.loaded[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name: object) -> bool:
        return name in self.names


# ---------------------------------------------------------------- one process


def ring_args(text: str) -> tuple[tuple[int, int], float, tuple[int, int] | None, bool]:
    """`--ring READ,WRITE,SPIN,PAGE,AT,DEDICATED` (what `Launcher._spawn` writes) as
    serve_ring's arguments: the link's two fds, the spin, the page's fd and this member's
    place (None where PAGE is -1: no page), whether to spin whatever the load."""
    read, write, spin, page, at, dedicated = text.split(",")
    turns = (int(page), int(at)) if int(page) >= 0 else None
    return (int(read), int(write)), float(spin), turns, dedicated == "1"


def run_process(system: System, args: argparse.Namespace) -> int:
    """`python -m <system> PROCESS ...`: one process, as the launcher's child or by hand."""
    plan = system.plans[args.process]
    stop = Stop()
    settings = parse_settings(system.layout, args.set)  # checked already by `main`
    if args.child:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the launcher decides when to stop
    signal.signal(signal.SIGTERM, stop)
    if args.transport == "zenoh":
        return run_networked(system, args, stop, settings)
    if args.lockstep:
        try:
            process = start(plan, system.layout, args.shm, not args.attach, settings, args.simulate)
        except (BlockError, RestartRefused, DuplicateProcess) as error:
            print(f"{args.process}: {error}", file=sys.stderr)
            return 1
        except Exception as error:  # noqa: BLE001 - a hook-state factory: one line, and why
            return report_failure(args.process, error, system.package)
        try:
            start_realtime(process)
        except RealtimeRefused as error:
            print(error, file=sys.stderr)
            process.block.close()
            return 1
        try:
            if args.ring:
                serve_ring(process, sys.stdin.fileno(), sys.stdout.fileno(), *ring_args(args.ring))
            else:
                serve(process, sys.stdin.fileno(), sys.stdout.fileno())
        except (OSError, EOFError):  # the coordinator's end of the pipe is gone (BrokenPipeError)
            pass
        except Exception as error:  # noqa: BLE001 - a hook or module failed: one line, and why
            process.block.close()
            return report_failure(args.process, error, system.package)
        except BaseException:
            process.block.close()
            raise
        # The coordinator closed the pipe (it stops us) or is gone (killed): as when free-
        # running, the last one out removes the segment, which a living launcher does too.
        process.block.owner = process.block.owner or args.child
        process.block.close()
        return 0
    if not args.child:
        signal.signal(signal.SIGINT, stop)
    else:  # the launcher's end (even a crash): stop, the actuators safe
        watch_the_launcher(stop, args.shm)
    try:
        process = run(
            plan,
            system.layout,
            args.cycles,
            not args.fast,
            args.shm,
            not args.attach,
            settings=settings,
            simulate=args.simulate,
            stop=stop,
        )
    except (BlockError, RestartRefused, DuplicateProcess) as error:
        print(f"{args.process}: {error}", file=sys.stderr)
        return REFUSED if isinstance(error, RestartRefused) else 1
    except RealtimeRefused as error:  # its line says which setting and why
        print(error, file=sys.stderr)
        return 1
    except Exception as error:  # noqa: BLE001 - a hook or module failed: one line, and why
        return report_failure(args.process, error, system.package)
    finally:
        stop.finished.set()
    report(system, args, process)
    if args.child and stop.orphaned:
        process.block.owner = True  # the launcher is gone: the last one out removes it
    process.block.close()
    return 0


def report(system: System, args: argparse.Namespace, process: Process) -> None:
    """A process run by hand (not the launcher's child) prints its cycles and summary."""
    if not args.child:
        print(f"{args.process}: {process.cycle} cycles")
        for line in summary(system, process.block.buf, [args.process]):
            print(line)  # with its periodicity line (paced), from its control record


def run_networked(
    system: System, args: argparse.Namespace, stop: Stop, settings: dict[str, str]
) -> int:
    """One process on its own block, its records moved over Zenoh: free-running, or in
    lockstep for a coordinator on the network (`--lockstep`)."""
    from ..transport import Mirror
    from ..zenoh_transport import ZenohTransport, serve

    plan, layout = system.plans[args.process], system.layout
    options = network_options(system, args)
    # Its launcher's block, which it names this one after (`Launcher._spawn`): a launcher
    # that dies (kill -9) cannot remove it, so each of its children, orphaned, does.
    launchers = args.shm.removesuffix(f"_{args.process}") if args.child else None
    if launchers is not None:  # the launcher's end (even a crash): stop, the actuators safe
        watch_the_launcher(stop, args.shm, launchers)
    else:
        signal.signal(signal.SIGINT, stop)

    def connect(process: Process) -> ZenohTransport:
        mirror = Mirror(layout, process.block, args.process)
        net = ZenohTransport(mirror, options, args.process, plan.modules, args.lockstep)
        net.report = process.counters  # what it received, in its control record
        # A launcher's child runs no cycle before it has heard the other processes of its
        # launch (its `--peers`): nothing it drives moves while it may not hear a peer.
        missing = net.hear(args.peers, lambda: stop.requested, process.beat)
        if missing:  # stopped first (its launcher refused the start, or gave up)
            process.safe_stop()
            process.beat(STOPPED)
            net.close()
            raise TransportError(f"stopped before it heard {', '.join(missing)}")
        return net

    try:
        if args.lockstep:
            process = start(plan, layout, args.shm, not args.attach, settings, args.simulate)
            try:
                transport = connect(process)
            except BaseException:
                process.block.close()
                raise
            try:
                problem = serve(process, transport, stop)
            finally:
                transport.close()
            if problem is not None:
                print(f"{args.process}: {problem}", file=sys.stderr)
        else:
            process = run(
                plan,
                layout,
                args.cycles,
                not args.fast,
                args.shm,
                not args.attach,
                settings=settings,
                simulate=args.simulate,
                stop=stop,
                transport=connect,
            )
            problem = None
    except (BlockError, RestartRefused, TransportError) as error:
        print(f"{args.process}: {error}", file=sys.stderr)
        return REFUSED if isinstance(error, RestartRefused) else 1
    finally:
        stop.finished.set()
        if launchers is not None and stop.orphaned:
            unlink_quietly(launchers)
    report(system, args, process)
    process.block.owner = True  # its own block: nobody else on this host uses it
    process.block.close()
    return 1 if problem is not None else 0


def network_options(system: System, args: argparse.Namespace) -> Any:
    """The Zenoh options of `--listen` and `--connect`; a link silent for the heartbeat
    timeout is closed, so a partitioned host is reported within it."""
    from ..zenoh_transport import Options

    lease_ms = max(100, int(system.layout.HEARTBEAT_TIMEOUT * 1000))
    return Options(tuple(args.listen), tuple(args.connect), lease_ms, args.security)


def watch_the_launcher(stop: Stop, *segments: str) -> None:
    """A free-running child learns that its launcher is gone in two ways: its stdin pipe
    closes (the launcher's end, even a crash), and on Linux its parent-death signal (SIGHUP,
    set with prctl), which comes too when the pipe stays open (a fork of the launcher holds
    its end) or a hook took stdin. Either way every actuator is latched safe at once, from
    a thread (the loop may be stuck in a hook), the loop is asked to stop, and a loop that
    has not stopped within STOP_GRACE (a hook that never returns) is not waited for: the
    segment is removed and the process exits, as a living launcher would have killed it."""
    parent, gone = os.getppid(), threading.Event()

    def hang_up(*_: object) -> None:
        if os.getppid() != parent:  # not a stray SIGHUP, nor the spawning thread's end
            gone.set()

    if _die_with_parent(signal.SIGHUP, hang_up) and os.getppid() != parent:
        gone.set()  # it died before the signal was asked for
    threading.Thread(target=_read_to_eof, args=(gone,), daemon=True).start()
    threading.Thread(target=_orphaned, args=(stop, gone, segments), daemon=True).start()


def _die_with_parent(signum: int, handler: Callable[..., None]) -> bool:
    """Ask the kernel for `signum` when our parent dies (Linux prctl PR_SET_PDEATHSIG),
    handled by `handler`; False where there is no such thing."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        signal.signal(signum, handler)
        return bool(libc.prctl(PR_SET_PDEATHSIG, signum, 0, 0, 0) == 0)
    except (OSError, AttributeError, ValueError):  # no libc prctl; not the main thread
        return False


def _read_to_eof(gone: threading.Event) -> None:
    try:
        while os.read(0, 1):
            pass
    except OSError:
        pass
    gone.set()


def _orphaned(stop: Stop, gone: threading.Event, segments: tuple[str, ...]) -> None:
    gone.wait()
    stop.orphaned = True
    stop()
    process = stop.process
    if process is not None and not stop.finished.is_set():
        process.safe_stop(everything=True)  # the others may be gone too: every actuator
    if not stop.finished.wait(STOP_GRACE):
        print(
            f"{segments[0]}: the launcher is gone and the loop did not stop: exiting",
            file=sys.stderr,
        )
        for segment in segments:  # its own (a Zenoh child's), and its launcher's
            unlink_quietly(segment)
        os._exit(1)


# ---------------------------------------------------------------- the launcher


class Child:
    def __init__(self, name: str, popen: subprocess.Popen[bytes], restarts: int = 0) -> None:
        self.name, self.popen, self.restarts = name, popen, restarts
        self.restarting = False  # dead, started again once every survivor has seen it dead


class Launcher:
    """Every process of a system as an OS process over one segment the launcher owns."""

    def __init__(
        self,
        system: System,
        segment: str | None = None,
        *,
        lockstep: bool = False,
        pace: bool = True,
        cycles: int | None = None,
        settings: Sequence[str] = (),
        simulate: Sequence[str] = (),
        restart: bool = False,
        python: str = sys.executable,
        world: Mapping[str, object] | None = None,
        transport: str = "shm",
        listen: str | None = None,
        connect: Sequence[str] = (),
        processes: Sequence[str] | None = None,
        also_listen: Sequence[str] = (),
        security: Security = PLAINTEXT,
        ring: bool = True,
        spin: float | None = None,
        turns: bool = True,
        dedicated: bool = False,
    ) -> None:
        self.system = system
        self.segment = segment or system.default_segment
        # With Zenoh, each process has a block of its own (named after the launcher's) and
        # the launcher's block mirrors them all: a local `ctl`, a harness and the summary
        # read it as they read the shared one. Its node listens where the processes connect.
        self.transport_name = transport
        self.listen = listen or local_endpoint(security)
        self.child_listen: dict[str, str] = {}  # where each process's node listens (Zenoh)
        # A host of a deployment (`--deploy`): only its processes here, its node also
        # listening on the host's other endpoints and connecting to the other hosts.
        self.connect, self.also_listen = tuple(connect), tuple(also_listen)
        self.security = security  # a deployment host's TLS and authentication, or none
        self.processes = list(system.plans) if processes is None else list(processes)
        self.net: Any = None
        self.lockstep, self.pace, self.cycles = lockstep, pace, cycles
        # Lockstep over one segment: the token ring (rcs/ring.py), or with `ring=False` the
        # coordinator's request and answer per process (kept to measure one against the other)
        self.ring = ring and lockstep and transport != "zenoh"
        self.links: list[Link] = []  # the ring's: process i waits on i, hands on to i + 1
        # and its turn words (rcs/ring.py Page), or with `turns=False` none: the ring then
        # spins on its eventfds (kept to measure one against the other)
        self.turns = turns
        self.page: Page | None = None
        self.order = [name for name, *_ in system.segments()]
        self.spin = default_spin() if spin is None else spin
        # the ring's cores are its own (isolated CPUs): spin without looking at the load
        self.dedicated = dedicated
        self.settings, self.simulate = list(settings), list(simulate)
        self.restart, self.python = restart, python
        self.world = dict(world or {})  # world fields to start from, over their initial values
        self.block: Block | None = None
        self.children: dict[str, Child] = {}
        self.events: list[str] = []  # what happened, for the summary
        self.failed: list[str] = []  # processes that ended because a hook or module failed
        self.final: list[str] = []  # the summary, taken when the processes have stopped
        # the start-up barrier's: the spec's `startup_timeout` (a layout built before: 10 s)
        self.startup_timeout = float(getattr(system.layout, "STARTUP_TIMEOUT", STARTUP_TIMEOUT))
        self.lost: set[str] = set()  # processes silent past the heartbeat timeout (frozen)
        self.trips: dict[str, int] = {}  # each process's watchdog trips, last seen
        self.halted = ""  # why the system was halted (a loss that was not contained), if it was
        self.on_stop: list[Callable[[], None]] = []  # first thing `stop` does (a coordinator's)

    # ------------------------------------------------------------ lifecycle

    def start(self) -> None:
        """Create the segment (refusing one that exists) and start every process."""
        self.block = Block(self.system.layout, self.segment, create=True)
        layout = self.system.layout
        for name, value in self.world.items():
            layout.WORLD[name].write(self.block.buf, **{name: enum_code(layout, "", name, value)})
        try:
            if self.transport_name == "zenoh":
                from ..transport import Mirror
                from ..zenoh_transport import Options, ZenohTransport

                lease_ms = max(100, int(self.system.layout.HEARTBEAT_TIMEOUT * 1000))
                self.net = ZenohTransport(
                    Mirror(self.system.layout, self.block),
                    Options(
                        (self.listen, *self.also_listen), self.connect, lease_ms, self.security
                    ),
                    block_when_congested=self.lockstep,
                )
            self.links = new_links(len(self.order) + 1) if self.ring else []
            self.page = Page.create(len(self.links)) if self.links and self.turns else None
            for name in self.processes:
                self.children[name] = Child(name, self._spawn(name, attach=True))
            if self.net is not None:
                self.hearing()
            elif not self.lockstep:
                self.barrier()
        except BaseException:
            self.stop()
            raise

    def barrier(self) -> None:
        """Wait until every process has run a cycle (the start-up barrier); StartupFailed
        naming each one that has not, within `startup_timeout` (and how it ended)."""
        assert self.block is not None
        layout, buf = self.system.layout, self.block.buf
        deadline = time.monotonic() + self.startup_timeout
        while True:
            missing = [
                n
                for n in self.processes
                if BEAT.unpack_from(buf, layout.PROCESSES[n].offset)[4] < 1
            ]
            ended = {
                n: c.popen.poll() for n, c in self.children.items() if c.popen.poll() is not None
            }
            if not missing:
                return
            if ended.keys() & set(missing) or time.monotonic() > deadline:
                why = [
                    how_ended(n, ended[n]) if n in ended else f"{n} (no cycle yet)" for n in missing
                ]
                raise StartupFailed(
                    f"the system did not become ready within {self.startup_timeout:g} s: "
                    f"{', '.join(why)} did not start"
                )
            time.sleep(0.01)

    def hearing(self) -> None:
        """The start-up barrier over Zenoh: within `startup_timeout`, every process has heard
        every other process of this launch (a process runs no cycle before it has: each says
        whom it heard, zenoh_transport `hear`), the launcher's node has heard each one, and
        each free-running one has run a cycle; else StartupFailed naming who does not hear
        whom (at once, naming it and how, when a process ends)."""
        net, names = self.net, self.processes
        deadline = time.monotonic() + self.startup_timeout
        while True:
            net.pull()
            ended = {
                n: c.popen.poll() for n, c in self.children.items() if c.popen.poll() is not None
            }
            cycled = {n for n in names if self.lockstep or net.mirror.heartbeat(n) >= 1}
            why = not_ready(names, net.heard, net.hears, cycled, ended)
            if not why:
                return
            if why.keys() & ended.keys() or time.monotonic() > deadline:
                raise StartupFailed(
                    f"the system did not become ready within {self.startup_timeout:g} s: "
                    + "; ".join(why.values())
                )
            net.wait(lambda: False, 0.05)  # what arrives meanwhile waits in its inbox

    def _spawn(self, name: str, attach: bool) -> subprocess.Popen[bytes]:
        import subprocess

        self.trips[name] = 0  # a new process has tripped nothing yet
        command = [self.python, "-m", self.system.package, name, "--shm", self.segment, "--child"]
        if self.transport_name == "zenoh":  # its own block, a peer of the launcher's node
            command[5] = f"{self.segment}_{name}"
            # It listens on a port of its own and connects to the launcher's node and to
            # every process started before it: Zenoh's gossip alone (each finding the others
            # through the launcher's node) sometimes never connected two processes that
            # started together (1 run in ~15: each heard the launcher, never the other, and
            # a connection made from gossip is not tried again); a configured one is.
            siblings = [self.child_listen[n] for n in self.child_listen if n != name]
            self.child_listen[name] = local_endpoint(self.security)
            command += ["--transport", "zenoh", "--connect", self.listen]
            command += [arg for sibling in siblings for arg in ("--connect", sibling)]
            command += ["--listen", self.child_listen[name]]
            # the processes of this launch it must hear before its first cycle (`hearing`)
            peers = [n for n in self.processes if n != name]
            command += ["--peers", ",".join(peers)] if peers else []
            if self.security != PLAINTEXT:  # paths only: no secret on a command line
                command += ["--security", self.security.to_text()]
        else:
            command += ["--attach"] if attach else []
        command += ["--lockstep"] if self.lockstep else []
        ring: tuple[int, ...] = ()
        if self.links:  # the fds keep their numbers in the child (pass_fds)
            at = self.order.index(name)
            ring = (self.links[at].read, self.links[at + 1].write)
            page = -1 if self.page is None else self.page.fd
            spin, dedicated = self.spin, int(self.dedicated)
            command += ["--ring", f"{ring[0]},{ring[1]},{spin!r},{page},{at},{dedicated}"]
            ring += () if self.page is None else (self.page.fd,)
        command += [] if self.pace else ["--fast"]
        command += ["--cycles", str(self.cycles)] if self.cycles is not None else []
        for item in self.settings:
            command += ["--set", item]
        simulate = [m for m in self.simulate if m in self.system.plans[name].stand_ins]
        for module in simulate:
            command += ["--simulate", module]
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(p for p in (*self.system.path, *sys.path) if p)
        return subprocess.Popen(
            command,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE if self.lockstep and self.net is None else None,
            env=env,
            pass_fds=ring,
        )

    def poll(self) -> list[str]:
        """Check the children: each one that ended is reported (and marked DEAD in its
        control record if it did not stop on its own), with `restart` started again; each
        one silent past the heartbeat timeout (frozen, starved) is reported lost, and each
        watchdog trip; every such fault latches the actuators it leaves at their safe values
        (rcs/loop.py `reaction`), and is printed the moment it is seen."""
        assert self.block is not None
        ended = []
        for name, child in list(self.children.items()):
            if child.restarting:
                self._restart_when_seen(name, child)
                continue
            code = child.popen.poll()
            if code is None:
                self._watch(name)
                continue
            ended.append(name)
            record = self.system.layout.PROCESSES[name]
            state = _read(record, self.block.buf).get("state")
            if code != 0 or state != STOPPED:
                if self.net is not None:  # the others see its token go: a local mark only
                    self.net.mirror.mark_dead(name)
                else:
                    record.write(self.block.buf, state=DEAD)
                refused = code == REFUSED and child.restarts > 0
                self._fault(
                    name,
                    f"{name} refused to restart: see its error above"
                    if refused
                    else ending(name, code),
                )
                self.lost.discard(name)
                if code in FAILURES:  # a hook or a module failed: it would fail again
                    self.failed.append(name)
                    refused = True
                if self.restart and not self.lockstep and not refused:
                    _close(child.popen)
                    child.restarting = True
                    self._restart_when_seen(name, child)
                    continue
            _close(child.popen)
            del self.children[name]
        return ended

    def _restart_when_seen(self, name: str, child: Child) -> None:
        """Start `name` again once every running survivor has seen it dead: its control
        record reports `name` in its lost mask, so it has reacted (its supervisors in their
        safe state, their clients told). Started at once, the new process could overwrite the
        DEAD mark before a survivor that did not run meanwhile (a loaded machine) looked, and
        the mission would go on as if nothing had happened. A survivor that does not tell is
        silent and so lost itself within the heartbeat timeout: it holds nothing up then.
        Over Zenoh the others see the process's token go, and the restart is at once."""
        if self.net is None and self.block is not None:
            layout, buf = self.system.layout, self.block.buf
            bit = 1 << list(layout.PROCESSES).index(name)
            for other, survivor in self.children.items():
                if other in self.lost or survivor.restarting or survivor.popen.poll() is not None:
                    continue
                record = _read(layout.PROCESSES[other], buf)
                if record.get("state") == RUNNING and not int(record.get("lost", 0)) & bit:  # type: ignore[call-overload]
                    return
        child.restarting = False
        child.popen = self._spawn(name, attach=True)
        child.restarts += 1
        self._event(f"{name} restarted")

    def _watch(self, name: str) -> None:
        """A running child: lost when its heartbeat is older than the timeout (stretched by
        its slow-down), found again when it beats; a new watchdog trip is a fault too."""
        assert self.block is not None
        layout, buf = self.system.layout, self.block.buf
        _, _, _, trips, _, beat_ns = BEAT.unpack_from(buf, layout.PROCESSES[name].offset)
        if self.net is not None or self.lockstep:
            return
        slow = 1.0
        if name in getattr(layout, "PACING", {}):
            slow = max(1.0, float(_read(layout.PACING[name], buf).get("slow", 1.0) or 1.0))  # type: ignore[arg-type]
        silent = (
            beat_ns > 0 and time.monotonic_ns() - beat_ns > layout.HEARTBEAT_TIMEOUT * slow * 1e9
        )
        if silent and name not in self.lost:
            self.lost.add(name)
            age = (time.monotonic_ns() - beat_ns) / 1e9
            self._fault(name, f"{name} lost: no heartbeat for {age:.2f} s (frozen or starved?)")
        elif not silent and name in self.lost:
            self.lost.discard(name)
            self._event(f"{name} beats again (its latched outputs stay safe until a reset)")
        if trips > self.trips.get(name, trips):
            self._fault(name, f"{name} tripped its watchdog ({trips} trips)")
        self.trips[name] = trips

    def _fault(self, name: str, what: str) -> None:
        """A fault of process `name`: printed now, in the summary, its reaction's actuators
        latched safe (the last line of defence: it does not depend on the faulty process;
        with Zenoh the latches travel from the launcher's mirror to the writers' blocks)."""
        self._event(what)
        todo = reaction(self.system.layout, name)
        if self.block is not None:
            latched = latch_safe(self.system.layout, self.block.buf, todo.latch, self.segment)
            if latched:
                self._event(f"latched safe: {', '.join(latched)}")
        if not todo.contained and not self.halted:
            self.halted = what

    def _event(self, what: str) -> None:
        self.events.append(what)
        print(f"{self.system.layout.SYSTEM}: {what}", file=sys.stderr, flush=True)

    def wait(self, stop: Stop, interval: float = 0.05) -> None:
        """Watch the children until they have all ended or `stop` is requested (or one could
        not start: the system cannot run without it)."""
        while self.children and not stop.requested and not self.start_failed():
            self.poll()
            self.exchange()
            time.sleep(interval)

    def start_failed(self) -> bool:
        """A process ended because one of its modules could not be made (startup.py)."""
        return any(e.endswith(f"(exit {START_FAILED}; its error is above)") for e in self.events)

    def exchange(self) -> None:
        """With Zenoh: mirror what the processes sent, send what was written here (an
        operator's `ctl` on this host, a DEAD mark)."""
        if self.net is not None:
            self.net.pull()
            self.net.push()

    def stop(self) -> None:
        """Stop every process (closing its pipe, then SIGTERM, then SIGKILL after a grace
        period) and remove the segment."""
        while self.on_stop:
            self.on_stop.pop()()
        for child in self.children.values():
            _close_stdin(child.popen)
            if child.popen.poll() is None:
                child.popen.terminate()
                child.popen.send_signal(signal.SIGCONT)  # a frozen one then stops, safe
        import subprocess

        deadline = time.monotonic() + STOP_GRACE
        for child in self.children.values():
            try:
                child.popen.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                child.popen.kill()
                child.popen.wait()
                self.events.append(f"{child.name} did not stop: killed")
            _close(child.popen)
        self.children.clear()
        close_links(self.links)
        self.links = []
        if self.page is not None:
            self.page.close()
            self.page = None
        if self.net is not None:  # each process's last word (STOPPED) or its leaving
            names, mirror = self.processes, self.net.mirror
            self.net.wait(
                lambda: all(n in self.net.lost or mirror.state(n) != RUNNING for n in names), 2.0
            )
            self.net.close()
            self.net = None
            for name in self.processes:  # a killed process could not remove its own
                unlink_quietly(f"{self.segment}_{name}")
        if self.block is not None:
            if self.net is None:  # stopped: every actuator safe, whoever was left running
                latch_safe(self.system.layout, self.block.buf, self.system.layout.SAFE_VALUES)
            self.final = [
                *self.events,
                *summary(self.system, self.block.buf, self.processes),
            ]
            self.block.close()
            self.block = None

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


class Coordinator:
    """Steps a launched system in lockstep: every segment of the execution order, in turn.

    A process that does not answer a segment within `timeout` seconds (stopped, hung in C
    code) is lost like one that died: every actuator of the block is latched at its safe
    value at once, and ProcessLost is raised; a lockstep run never waits for good."""

    def __init__(self, launcher: Launcher, timeout: float = LOCKSTEP_TIMEOUT) -> None:
        self.launcher, self.timeout = launcher, timeout
        self.segments = launcher.system.segments()
        self.cycle = 0
        self.broken = ""  # why the ring was lost: no cycle after it
        for child in launcher.children.values():  # each has started and sent its INITs
            if child.popen.stdout is None or child.popen.stdout.read(len(READY)) != READY:
                raise ProcessLost(f"process {child.name} did not start")
        self.waiter: Return | None = None
        if launcher.links:  # the ring: the token comes back on the last link
            self.answers = {
                c.popen.stdout.fileno(): c for c in launcher.children.values() if c.popen.stdout
            }
            page, last = launcher.page, len(launcher.links) - 1
            self.waiter = Return(
                launcher.links[-1].read,
                list(self.answers),
                launcher.spin,
                page,
                last,
                launcher.dedicated,
            )
            launcher.on_stop.append(self.waiter.close)  # before it closes what is watched
            self.hand_on = Giver(launcher.links[0].write, page, 0)
            # the first process, as the token comes back
            self.nudge = Nudge(launcher.links[0].write, launcher.spin, page, 0, launcher.dedicated)
            launcher.on_stop.append(self.nudge.close)
            self.beats = self._beats()

    def step(self, cycles: int = 1) -> None:
        """Run `cycles` whole system cycles; raises ProcessLost if a process is gone."""
        if self.waiter is not None:
            self._ring(cycles)
            return
        for _ in range(cycles):
            for name, first, last, end in self.segments:
                child = self.launcher.children.get(name)
                if child is None or child.popen.stdin is None or child.popen.stdout is None:
                    raise ProcessLost(f"process {name} is not running")
                try:
                    child.popen.stdin.write(STEP.pack(b"s", first, last, end))
                    child.popen.stdin.flush()
                    reply = answer(child.popen.stdout.fileno(), self.timeout)
                except (BrokenPipeError, OSError):
                    reply = b""
                if reply != DONE_REPLY:
                    self.lost()
                    if reply is None:
                        raise ProcessLost(
                            f"process {name} did not answer within {self.timeout:g} s "
                            "(stopped, or stuck where its hooks' deadlines cannot reach)"
                        )
                    raise ProcessLost(stopped_answering(child))
            self.cycle += 1

    def _ring(self, cycles: int) -> None:
        """Cycles of the token ring: a process killed is lost as its answer pipe closes, one
        stopped (or stuck) when the token has not come back within `timeout`."""
        assert self.waiter is not None
        hand_on, done = self.hand_on, self.launcher.links[-1].read
        for _ in range(cycles):
            if self.broken or len(self.launcher.children) != len(self.answers):
                self.broken = self.broken or "a process of the ring is not running"
                raise ProcessLost(self.broken)
            hand_on()
            woke = self.waiter.wait(self.timeout)
            if woke == done:
                self.cycle += 1
                self.nudge()  # the first process spins for the next cycle's token
                continue
            self.lost()
            if woke is None:
                self.broken = (
                    f"process {self._holder()} did not answer within {self.timeout:g} s "
                    "(stopped, or stuck where its hooks' deadlines cannot reach)"
                )
            else:
                self.broken = stopped_answering(self.answers[woke])
            raise ProcessLost(self.broken)

    def _beats(self) -> dict[str, int]:
        block = self.launcher.block
        assert block is not None
        processes = self.launcher.system.layout.PROCESSES
        return {n: BEAT.unpack_from(block.buf, processes[n].offset)[4] for n in processes}

    def _holder(self) -> str:
        """The process the token stopped at: the first in the ring not yet through this
        cycle (each beats once a cycle, as it hands the token on)."""
        beats = self._beats()
        return next(
            (n for n in self.launcher.order if beats[n] <= self.beats[n] + self.cycle),
            self.launcher.order[-1],
        )

    def lost(self) -> None:
        """A process is lost: every actuator safe now, latched (the launcher's stop does it
        again, for whatever runs until then)."""
        block = self.launcher.block
        if block is not None:
            layout = self.launcher.system.layout
            latch_safe(layout, block.buf, getattr(layout, "SAFE_VALUES", {}), self.launcher.segment)


def answer(fd: int, timeout: float) -> bytes | None:
    """A lockstep process's one-byte answer on `fd`: b"" when its pipe closed (it died),
    None when nothing came within `timeout` seconds."""
    ready, _, _ = select.select([fd], [], [], timeout)
    return os.read(fd, len(DONE_REPLY)) if ready else None


class NetworkCoordinator:
    """Steps a system whose processes run on Zenoh nodes, in lockstep: a request to each
    process, answered by its control record of the next cycle, which it sends after
    everything else it wrote. Each request names the cycle every other process must have
    reached in the receiver's mirror first, so every process reads what it would read in
    one block, in the execution order. Only whole-process segments (`System.segments`)."""

    def __init__(self, launcher: Launcher, timeout: float = 20.0) -> None:
        self.launcher, self.timeout = launcher, timeout
        self.net = launcher.net
        self.segments = launcher.system.segments()
        self.names = list(launcher.system.layout.PROCESSES)
        self.cycle = 0
        mirror = self.net.mirror
        if not self.net.wait(lambda: all(mirror.state(n) == RUNNING for n in self.names), timeout):
            missing = [n for n in self.names if mirror.state(n) != RUNNING]
            raise ProcessLost(f"process(es) {missing} did not start within {timeout:g} s")
        self.reached = {n: mirror.heartbeat(n) for n in self.names}

    def step(self, cycles: int = 1) -> None:
        """Run `cycles` whole system cycles; raises ProcessLost if a process is gone.

        Every request of a cycle goes at once, in one message: each names the cycle the
        processes before it reach in this cycle, so a process waits in its own mirror for
        their records (which come to it directly) and none waits for the coordinator to hear
        the one before it: three network hops on the way of a two-process cycle, not four."""
        from ..zenoh_transport import step_request

        net, mirror = self.net, self.net.mirror
        for _ in range(cycles):
            net.push()  # what was written here (a scenario's events) goes first
            targets, requests = dict(self.reached), {}
            for name, first, last, end in self.segments:
                if not end:
                    raise ProcessLost(f"process {name}: a segment that does not end a cycle")
                if name in net.lost or name not in self.launcher.children:
                    raise ProcessLost(f"process {name} is not running")
                requests[name] = step_request(first, last, end, [targets[n] for n in self.names])
                targets[name] = self.reached[name] + 1
            net.send_steps(requests)  # one message a cycle: each process takes its own
            if not net.wait(_answered(mirror, net.lost, targets), self.timeout, targets):
                late = [n for n in self.names if mirror.heartbeat(n) < targets[n]]
                raise ProcessLost(f"process(es) {late} did not answer within {self.timeout:g} s")
            gone = sorted(net.lost & set(self.names))
            if gone:
                raise ProcessLost(f"process(es) {gone} left the network (died?)")
            self.reached = targets
            self.cycle += 1


def _answered(mirror: Any, lost: set[str], targets: dict[str, int]) -> Callable[[], bool]:
    return lambda: (
        bool(lost & targets.keys()) or all(mirror.heartbeat(n) >= t for n, t in targets.items())
    )


def how_ended(name: str, code: int | None) -> str:
    """A process that ended before the system was ready: the failure its exit code says,
    else the code."""
    if code in FAILURES:
        return f"{name} ({FAILURES[code or 0]}, exit {code})"
    return f"{name} (exited {code})"


def not_ready(
    names: Sequence[str],
    heard: AbstractSet[str],
    hears: Mapping[str, AbstractSet[str]],
    cycled: AbstractSet[str],
    ended: Mapping[str, int | None],
) -> dict[str, str]:
    """Why each of the processes `names` of a launch over Zenoh that is not ready is not
    (none when all are): not heard by the launcher's node (`heard`), not hearing some of
    the others (whom each said it heard: `hears`), no cycle yet; or, ended, how it ended."""
    why = {}
    for name in names:
        deaf = [n for n in names if n != name and n not in hears.get(name, ())]
        if name not in heard:
            why[name] = f"the launcher does not hear {name}"
        elif deaf:
            why[name] = f"{name} does not hear {', '.join(deaf)}"
        elif name not in cycled:
            why[name] = f"{name} (no cycle yet)"
        if name in why and name in ended:  # (one that ended ready, its cycles run, is)
            why[name] = how_ended(name, ended[name])
    return why


def stopped_answering(child: Child) -> str:
    """Why a lockstep process gave no answer: the failure its exit code says (a hook, a
    module: its own line is above), else that it died."""
    import subprocess

    try:
        code = child.popen.wait(timeout=2.0)
    except subprocess.TimeoutExpired:
        code = None
    if code in FAILURES:
        return ending(f"process {child.name}", code)
    return f"process {child.name} stopped answering (it died?)"


@shared
class ProcessLost(Exception):
    """A process of a lockstep run is gone."""


@shared
class StartupFailed(Exception):
    """Some process did not start running within the start-up timeout."""


def free_port() -> int:
    """A TCP port of 127.0.0.1 that nothing listens on now."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def local_endpoint(security: Security) -> str:
    """A Zenoh endpoint on 127.0.0.1 that nothing listens on now (TLS where `security` asks
    for it): the launcher's node's, or one of its processes'."""
    return f"{'tls' if security.tls else 'tcp'}/127.0.0.1:{free_port()}"


def unlink_quietly(name: str) -> None:
    from ..block import unlink

    unlink(name)


def _close_stdin(popen: subprocess.Popen[bytes]) -> None:
    try:
        if popen.stdin is not None:
            popen.stdin.close()
    except OSError:
        pass


def _close(popen: subprocess.Popen[bytes]) -> None:
    _close_stdin(popen)
    if popen.stdout is not None:
        popen.stdout.close()


def _read(record: object, buf: memoryview) -> dict[str, object]:
    try:
        return record.read(buf)  # type: ignore[attr-defined, no-any-return]
    except StaleRead:
        return {}


# ---------------------------------------------------------------- summary


def summary(system: System, buf: memoryview, processes: list[str]) -> Iterator[str]:
    """Per process: its state, cycles, overruns, late wake-ups, watchdog trips, load
    warnings, stale reads, and the longest cycle of each of its modules."""
    layout = system.layout
    for name in processes:
        record = _read(layout.PROCESSES[name], buf)
        if not record:
            yield f"{name}: control record unreadable"
            continue
        state = PROCESS_STATES[int(record["state"])]  # type: ignore[call-overload]
        yield (
            f"{name}: {state.lower()}, {record['heartbeat']} cycles, {record['overruns']} "
            f"overruns, {record['late_wakeups']} late wake-ups, {record['watchdog_trips']} "
            f"watchdog trips, {record['load_warnings']} load warnings"
        )
        figures = periodicity(record)
        if figures is not None:  # paced: how well it held its period
            yield f"  {periodicity_line(name, figures)}"
        network = network_line(name, record)
        if network is not None:  # on Zenoh: what it received from its peers
            yield f"  {network}"
        modules = system.plans[name].modules
        cells, stale = [], 0
        for module in modules:
            perf = _read(layout.PERFORMANCE[module], buf)
            if perf:
                cells.append(f"{module} {int(perf['max_cycle_ns']) / 1000:.1f}")  # type: ignore[call-overload]
                stale += int(perf["stale_reads"])  # type: ignore[call-overload]
        yield f"  max cycle time per module (us): {'  '.join(cells)}"
        if stale:
            yield f"  stale reads: {stale}"


# ---------------------------------------------------------------- command line


def main(package: str, argv: list[str] | None = None) -> int:
    """`python -m <system> [PROCESS] [options]`, or `python -m <system> ctl VERB ...`: the
    arguments parsed and checked (`parse_args`), then one run (`dispatch`)."""
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["ctl"]:  # the operator's console needs only the layout
        from .ctl import main as ctl

        return ctl(package, argv[1:])
    try:
        system = System.load(package)
    except ImportError as error:
        return cannot_import(package, error)
    parsed = parse_args(system, argv)
    if parsed is None:  # the deployment file is wrong: its located error is said
        return 2
    refused = check_role(system, parsed[0])
    if refused:
        return refused
    process = parsed[0].process  # its plan only; a launch imports every plan before starting
    try:
        for name in [process] if process is not None else list(system.plans):
            system.plans[name]
    except ImportError as error:
        return cannot_import(package, error)
    return dispatch(system, *parsed)


def cannot_import(package: str, error: ImportError) -> int:
    """One line for a package or a plan that does not import (most often: the hook modules
    are not on the path), and the exit code 1."""
    missing = f"module {error.name!r}" if error.name else str(error)
    print(
        f"{package}: cannot import {missing}; put the directory that holds the system's "
        "hook modules (the spec directory) on PYTHONPATH",
        file=sys.stderr,
    )
    return 1


def check_role(system: System, args: argparse.Namespace) -> int:
    """`--role R`: held by the user who runs this (system.yaml `operators.roles`), and with
    --send its command access; 0, or the refusal's exit code after its one line."""
    if args.role is None:
        return 0
    from .ctl import Access, CtlError  # the operator's console: only for a role

    try:
        access = Access(system.layout, args.role)
        if args.send is not None:
            access.require("command", args.send.module, f"--send {args.send}")
    except CtlError as error:
        print(f"{system.layout.SYSTEM}: {error}", file=sys.stderr)
        return error.code
    return 0


def dispatch(system: System, args: argparse.Namespace, host: Any = None) -> int:
    """One run of checked arguments: one PROCESS (a child of a launch, or a process started
    by hand), or a launch of every process (of a deployment's `host`); its exit code."""
    if args.process is not None:
        own = f"_{args.process}" if args.transport == "zenoh" else ""
        args.shm = args.shm or system.default_segment + own
        return run_process(system, args)
    return launch(system, args, host)


def parser(system: System) -> argparse.ArgumentParser:
    """The launcher's options (`python -m <system> --help`)."""
    top = _OneLineParser(
        prog=f"python -m {system.package}",
        description=f"Run the {system.layout.SYSTEM} system: every process (the default), "
        "or one PROCESS.",
    )
    top.add_argument(
        "process",
        nargs="?",
        metavar="PROCESS|HOST",
        help=f"run only this process ({', '.join(system.plans)}); with --deploy, this host's",
    )
    top.add_argument(
        "--deploy",
        default=None,
        metavar="FILE",
        help="a deployment file (JSON): run HOST's processes (default: the host named after "
        "this machine) with its endpoints, over Zenoh",
    )
    top.add_argument("--cycles", type=int, default=None, help="stop after this many cycles")
    top.add_argument("--fast", action="store_true", help="do not pace to the cycle period")
    top.add_argument(
        "--shm", default=None, help=f"shared-memory segment [default: {system.default_segment}]"
    )
    top.add_argument("--attach", action="store_true", help="attach to a running segment")
    top.add_argument("--restart", action="store_true", help="restart a process that dies")
    top.add_argument(
        "--lockstep", action="store_true", help="step the processes in lockstep (no pacing)"
    )
    top.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    # a lockstep child's place in the token ring: READ_FD,WRITE_FD,SPIN (rcs/ring.py)
    top.add_argument("--ring", default=None, help=argparse.SUPPRESS)
    # a deployment host's TLS and authentication files, as its launcher passes them on
    top.add_argument("--security", default=None, help=argparse.SUPPRESS)
    # a Zenoh child's: the other processes of its launch, heard before its first cycle
    top.add_argument("--peers", default="", help=argparse.SUPPRESS)
    top.add_argument(
        "--transport",
        choices=("shm", "zenoh"),
        default=None,
        help="how processes exchange buffers: one shared-memory segment (one host), or "
        "Zenoh (each process its own block; hosts anywhere) [default: shm]",
    )
    top.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="PROTO/HOST:PORT",
        help="with --transport zenoh: listen here for other hosts (repeatable)",
    )
    top.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="PROTO/HOST:PORT",
        help="with --transport zenoh: connect to a host listening here (repeatable)",
    )
    top.add_argument(
        "--send",
        default=None,
        metavar="MODULE.COMMAND[:NAME=VALUE,...]",
        help="once MODULE has finished INIT, send it this command (e.g. sec.BOX_CUT:depth=1.5)",
    )
    top.add_argument(
        "--report",
        default="",
        metavar="FIELD,...",
        help="world fields to print at the end of a run",
    )
    top.add_argument(
        "--until-done",
        action="store_true",
        help="with --send: stop when the module reports DONE (exit 0) or ERROR (exit 1)",
    )
    top.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a run setting for the hook-state factories (repeatable)",
    )
    top.add_argument(
        "--simulate",
        action="append",
        default=[],
        metavar="MODULE",
        help="run this controller's stand-in in its place (repeatable)",
    )
    top.add_argument(
        "--role",
        default=None,
        help="act in this operator role (system.yaml `operators.roles`): refused unless you "
        "hold it; --send then needs its command access (without --role, the user who starts "
        "the system owns it)",
    )
    top.add_argument(
        "--world",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="start with this world field's value instead of its initial one (repeatable)",
    )
    return top


def parse_args(system: System, argv: list[str]) -> tuple[argparse.Namespace, Any] | None:
    """The arguments of a start, each checked against the system (a usage mistake exits 2
    with one line, argparse's way), and the deployment's host (None without --deploy); None
    after a located error in the deployment file."""
    usage = parser(system)
    args = usage.parse_args(argv)
    host = None
    try:
        args.security = Security.from_text(args.security) if args.security else PLAINTEXT
        _check_settings(system, args)
        if args.deploy is not None:
            host = deployed(system, args)
            if host is None:
                return None
        elif args.process is not None and args.process not in system.plans:
            choices = ", ".join(repr(p) for p in system.plans)
            raise ValueError(
                f"argument process: invalid choice: {args.process!r} (choose from {choices})"
            )
        _check_run(system, args)
        _check_transport(args)
        _check_peers(system, args)
    except ValueError as error:
        usage.error(str(error))
    return args, host


def _check_settings(system: System, args: argparse.Namespace) -> None:
    if args.shm is not None and segment_problem(args.shm):
        raise ValueError(segment_problem(args.shm))
    parse_settings(system.layout, args.set)
    for device in getattr(system.layout, "IO_DEVICES", {}).values():
        from ..io_cycle import relocated  # only a system with I/O imports it

        relocated(device)  # RCSGEN_IO_<DEVICE>, if set, is an address it can use


def _check_run(system: System, args: argparse.Namespace) -> None:
    """--cycles, --simulate, --report, --send and --world against the system (the typed
    values of the last three put in `args`)."""
    if args.cycles is not None and args.cycles < 0:
        raise ValueError("--cycles must be 0 or more")
    # Only when asked: it imports every process's plan (and with it, its controllers).
    switchable = (
        {m for plan in system.plans.values() for m in plan.stand_ins} if args.simulate else set()
    )
    unknown = sorted(set(args.simulate) - switchable)
    if unknown:
        raise ValueError(f"no stand-in for {unknown}; these have one: {sorted(switchable)}")
    if args.until_done and args.send is None:
        raise ValueError("--until-done goes with --send")
    args.report = [f for f in args.report.split(",") if f]
    unknown_fields = [f for f in args.report if f not in system.layout.WORLD]
    if unknown_fields:
        raise ValueError(f"--report: no world {listed('field', unknown_fields)}")
    if args.send is not None:
        args.send = parse_send(system.layout, args.send)
        if args.process is not None or args.lockstep:
            raise ValueError(
                "--send goes with a launch of every process, not PROCESS or --lockstep"
            )
    args.world = parse_world(system.layout, args.world)
    if args.world and (args.process is not None or args.attach):
        raise ValueError("--world goes with a launch of every process, which makes the segment")


def _check_transport(args: argparse.Namespace) -> None:
    args.transport = args.transport or "shm"
    if args.transport == "shm" and (args.listen or args.connect):
        raise ValueError("--listen and --connect go with --transport zenoh")
    for endpoint in (*args.listen, *args.connect):
        check_endpoint(endpoint)


def _check_peers(system: System, args: argparse.Namespace) -> None:
    """`--peers P,...` (what a launcher over Zenoh gives its children) as a list of names,
    each a process of the system."""
    args.peers = [p for p in args.peers.split(",") if p]
    unknown = [p for p in args.peers if p not in system.plans]
    if unknown:
        raise ValueError(f"--peers: no process(es) {unknown}")
    if args.peers and (args.transport != "zenoh" or args.process is None):
        raise ValueError("--peers goes with PROCESS and --transport zenoh")


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is one line on stderr, exit 2; its help as wide as the
    terminal, found without `shutil` (which argparse would import: ~4 ms a process's start)."""

    def __init__(self, **options: Any) -> None:
        super().__init__(**options, formatter_class=_help_formatter)

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def _help_formatter(prog: str) -> argparse.HelpFormatter:
    """argparse's formatter at the width `shutil.get_terminal_size` would give it."""
    try:
        width = int(os.environ["COLUMNS"])
    except (KeyError, ValueError):
        try:
            width = os.get_terminal_size(sys.__stdout__.fileno()).columns  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):
            width = 80
    return argparse.HelpFormatter(prog, width=max(width, 1) - 2)


def deployed(system: System, args: argparse.Namespace) -> Any:
    """`--deploy FILE [HOST]`: the host's entry of the checked file, its endpoints and
    transport put in `args` (its one process in `args.process`); None after a located
    error on stderr. ValueError: a usage mistake."""
    import socket

    from .deploy import DeployError, load

    if args.listen or args.connect or args.transport is not None:
        raise ValueError(
            "--deploy gives the transport and endpoints: no --transport, --listen, --connect"
        )
    if args.lockstep:
        raise ValueError("--lockstep steps the processes of one launch, not the hosts of --deploy")
    try:
        deployment = load(args.deploy, system.layout.SYSTEM, list(system.plans))
        host = deployment.host(args.process, socket.gethostname())
    except DeployError as error:
        print(error, file=sys.stderr)
        return None
    args.transport, args.listen, args.connect = "zenoh", list(host.listen), list(host.connect)
    args.security = host.security
    args.process = host.processes[0] if len(host.processes) == 1 else None
    return host


def parse_world(layout: ModuleType, items: Sequence[str]) -> dict[str, object]:
    """`FIELD=VALUE` items, each checked against the layout's world fields and typed."""
    values: dict[str, object] = {}
    for item in items:
        name, equals, raw = item.partition("=")
        if not equals:
            raise ValueError(f"--world: {item!r} is not FIELD=VALUE")
        if name not in layout.WORLD:
            raise ValueError("--world: " + suggest(name, list(layout.WORLD), "world field"))
        code = layout.WORLD[name].codes()[name]
        try:
            names = getattr(layout, "ENUMS", {}).get(("", name), ())
            values[name] = parse_value(raw, code, names)
        except ValueError as error:
            raise ValueError(f"--world: {name} {error}") from None
    return values


def parse_send(layout: ModuleType, text: str) -> Command:
    """Parse and check `MODULE.COMMAND[:NAME=VALUE,...]` against the layout (the one command
    contract, rcs/operate/command.py)."""
    head, _, rest = text.partition(":")
    module, _, command = head.partition(".")
    try:
        return parse_command(layout, module, command, [i for i in rest.split(",") if i])
    except ValueError as error:
        raise ValueError(f"--send: {error}") from None


def give(send: Command, layout: ModuleType, buf: memoryview) -> int | None:
    """Write `send` once its module has ended its last command (rcs/operate/command.py, the one
    writer and the one reading of an outcome); its number, or None while it is busy."""
    record, status = layout.COMMAND_IN[send.module], layout.STATUS_OUT[send.module]
    if outcome(_read(record, buf), _read(status, buf)) is None:
        return None
    try:
        return write_command(layout, buf, send)
    except StaleRead:  # being written: the next poll tries again
        return None


def finished(send: Command, number: int, layout: ModuleType, buf: memoryview) -> str | None:
    """DONE or ERROR once the module reported on command `number`; else None (also when a
    command given by someone else replaced it: its outcome is not this run's to say)."""
    record, status = layout.COMMAND_IN[send.module], layout.STATUS_OUT[send.module]
    try:
        return outcome(_read(record, buf), _read(status, buf), number)
    except ValueError:
        return None


def launch(system: System, args: argparse.Namespace, host: Any = None) -> int:
    """Every process (or a deployment `host`'s): until Ctrl-C / SIGTERM (or `--cycles`),
    then a summary."""
    stop = Stop()
    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    launcher = Launcher(
        system,
        args.shm,
        lockstep=args.lockstep,
        pace=not args.fast,
        cycles=None if args.lockstep else args.cycles,
        settings=args.set,
        simulate=args.simulate,
        restart=args.restart,
        world=args.world,
        transport=args.transport,
        listen=args.listen[0] if args.listen else None,
        connect=args.connect,
        processes=None if host is None else host.processes,
        also_listen=args.listen[1:],
        security=args.security,
    )
    try:
        launcher.start()
    except (BlockError, TransportError, StartupFailed) as error:
        print(f"{system.layout.SYSTEM}: {error}", file=sys.stderr)
        return 1
    code = 0
    try:
        print(
            f"{system.layout.SYSTEM}: {len(system.plans)} process(es) on segment "
            f"{launcher.segment}; Ctrl-C stops",
            file=sys.stderr,
        )
        if args.lockstep:
            coordinator: Coordinator | NetworkCoordinator = (
                NetworkCoordinator(launcher) if launcher.net is not None else Coordinator(launcher)
            )
            while not stop.requested and (args.cycles is None or coordinator.cycle < args.cycles):
                coordinator.step()
        elif args.send is not None:
            code = operate(launcher, args.send, args.until_done, stop)
        else:
            launcher.wait(stop)
    except ProcessLost as error:
        print(f"{system.layout.SYSTEM}: {error}", file=sys.stderr)
        code = 1
    finally:
        if launcher.block is not None:
            for field in args.report:
                value = _read(system.layout.WORLD[field], launcher.block.buf).get(field)
                print(f"{field} = {enum_name(system.layout, '', field, value)}")
        launcher.stop()
    for line in launcher.final:
        print(line)
    if launcher.failed:  # a process stopped because a hook or a module failed
        print(
            f"{system.layout.SYSTEM}: {', '.join(launcher.failed)} stopped on a failure",
            file=sys.stderr,
        )
        return code or 1
    return code


def operate(launcher: Launcher, send: Command, until_done: bool, stop: Stop) -> int:
    """Give `send` once its module is ready, watch the processes, and with `until_done`
    stop when it reports: 0 for DONE, 1 for ERROR (or when every process ended first)."""
    layout = launcher.system.layout
    assert launcher.block is not None
    buf = launcher.block.buf
    number = None
    while launcher.children and not stop.requested and not launcher.start_failed():
        launcher.poll()
        launcher.exchange()
        if number is None:
            number = give(send, layout, buf)
            if number is not None:
                print(f"sent {send.module}.{send.command} #{number}", file=sys.stderr)
        elif until_done:
            result = finished(send, number, layout, buf)
            if result is not None:
                print(f"{send.module} {result} #{number}")
                return 0 if result == "DONE" else 1
        if until_done and launcher.halted:  # the outputs are latched safe: it cannot go on
            print(f"{send.module} did not finish: the system halted ({launcher.halted})")
            return 1
        time.sleep(0.01)
    return 1 if until_done else 0
