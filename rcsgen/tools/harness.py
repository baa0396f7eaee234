"""Harness: a generated package -> one process of it, driven cycle by cycle from a test.

`Harness.build(spec_dir)` generates the system into a scratch directory and imports it;
`Harness.load(package_dir)` imports an already generated package. Either way a test can
write a controller's command and its subordinates' status, set world fields, run one
module or one whole cycle, and read back what each module sent and reports:

    with Harness.build("specs/miner") as h:
        h.command("co", "SUMP_SHEAR_CUSP")
        h.step("co")                      # co alone: its subordinates do not run
        assert h.sent("cc").command == "SUMP"
        h.reply("cc", "DONE")             # cc echoes its command number with DONE
"""

from __future__ import annotations

import importlib
import importlib.util
import itertools
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

from ..compiler.back_end import emit
from ..compiler.diagnostics import Diagnostics, SpecError
from ..compiler.frontend import compile_paths
from ..compiler.ir import IRSystem
from ..runtime.contract import enum_code, enum_name, plan_slots, result_values
from ..runtime.operate.command import check_command, write_command
from ..runtime.operate.startup import settings_problem

_unique = itertools.count(1)


@dataclass(frozen=True)
class Sent:
    """A module's command buffer: what its supervisor (or the harness) last sent it."""

    command: str
    number: int
    args: dict[str, Any]


@dataclass(frozen=True)
class Status:
    """A module's status buffer and state."""

    status: str
    number: int
    state: str
    error_num: int
    rule: str | None = None  # the table rule that fired in the module's last cycle
    # Why it is in ERROR, by name (`NONE` otherwise); None: the module declares no reasons.
    reason: str | None = None
    # Its result slots by name (`result.<name>` in the spec); empty: it declares no results.
    results: dict[str, Any] = field(default_factory=dict)
    # each plan's step, number of steps and replans left (modules with plans only)
    plans: dict[str, dict[str, int]] = field(default_factory=dict)
    # What its ERROR was passed up from (`fx: TIMED_OUT <- op: REFUSED`; docs/semantics.md,
    # "Reasons survive"), '' for none.
    cause: str = ""


def import_package(package_dir: Path, hooks_dir: Path | None = None) -> ModuleType:
    """Import a generated package from `package_dir` under a unique name (no sys.path edits
    for the package itself); `hooks_dir` is put on sys.path for the user's hook modules."""
    if hooks_dir is not None:
        _use_hooks_from(hooks_dir)
    name, init = f"_rcsgen_{next(_unique)}_{package_dir.name}", package_dir / "__init__.py"
    spec = (
        importlib.util.spec_from_file_location(
            name, init, submodule_search_locations=[str(package_dir)]
        )
        if init.is_file()  # (else the spec is made all the same, and loading it says Errno 2)
        else None
    )
    if spec is None or spec.loader is None:
        raise ImportError(f"no generated package in {package_dir}")
    package = importlib.util.module_from_spec(spec)
    sys.modules[name] = package
    spec.loader.exec_module(package)
    return package


def import_layout(package_dir: Path) -> ModuleType:
    """The `layout` module of the generated package in `package_dir` (all a console needs)."""
    return importlib.import_module(f"{import_package(package_dir.resolve()).__name__}.layout")


def _use_hooks_from(hooks_dir: Path) -> None:
    """Put `hooks_dir` first on sys.path and forget same-named hook modules imported from
    elsewhere (two copies of a spec directory must not share the first one's hooks)."""
    if str(hooks_dir) in sys.path:
        sys.path.remove(str(hooks_dir))
    sys.path.insert(0, str(hooks_dir))
    tops = {p.stem for p in hooks_dir.glob("*.py")} | {
        p.parent.name for p in hooks_dir.glob("*/__init__.py")
    }
    for name in [m for m in sys.modules if m.split(".")[0] in tops]:
        origin = getattr(sys.modules[name], "__file__", None) or ""
        if not Path(origin).resolve().is_relative_to(hooks_dir.resolve()):
            del sys.modules[name]


def generate(spec_dir: Path) -> tuple[Path, str]:
    """Generate the one system in `spec_dir` into a new scratch directory: (it, the name).
    SpecError with every problem, as `rcsgen build` reports them; a directory of several
    systems is one error at each of their names (E224): the harness runs one."""
    front = compile_paths([spec_dir])
    if front.diagnostics.errors:
        raise SpecError(front.diagnostics)
    if len(front.systems) != 1:
        names = ", ".join(f"`{s.name}` ({s.name_span.file})" for s in front.systems)
        diags = Diagnostics()
        for system in front.systems:
            diags.error(
                system.name_span,
                "E224",
                f"`{spec_dir}` holds {len(front.systems)} systems, {names}: the harness runs one",
                f"give one system's directory: `{Path(system.name_span.file).parent}`",
            )
        raise SpecError(diags)
    system = front.systems[0]
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-harness-"))
    write_package(system, scratch)
    return scratch, system.name


def write_package(system: IRSystem, root: Path) -> Path:
    """Render `system` into `root` (a scratch directory, not the user's output): its package."""
    for rel, text in emit.render_all([system]).items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root / system.name


class BlockView:
    """A generated system's block, read and written through its layout's records, by name."""

    layout: ModuleType
    contract: ModuleType
    buf: memoryview
    _states_of: dict[str, str]

    def command(self, module: str, command: str, **args: Any) -> int:
        """Write a new command to `module` (as its supervisor would); returns its number.
        Checked as an operator's command is (rcs/operate/command.py): ValueError names what is
        wrong, and nothing is written."""
        checked = check_command(self.layout, module, command, args, client=True)
        return write_command(self.layout, self.buf, checked)

    def sent(self, module: str) -> Sent:
        """What is in `module`'s command buffer: the last command its supervisor sent."""
        values = self.layout.COMMAND_IN[module].read(self.buf)
        args = {
            k.removeprefix("arg_"): self.contract.enum_name(self.layout, module, k, v)
            for k, v in values.items()
            if k.startswith("arg_")
        }
        name = self.layout.COMMAND_NAMES[module][values["command"]]
        return Sent(name, values["command_num"], args)

    def reply(self, module: str, status: str, number: int | None = None, reason: str = "") -> None:
        """Write `module`'s status as if it had run: by default echoing its command number;
        an ERROR with `reason` (one of the module's reason names) gives that reason."""
        echoed = self.sent(module).number if number is None else number
        code = self.contract.STATUS_NAMES.index(status)
        fields: dict[str, int] = {"status_num": echoed, "status": code}
        if reason:  # an operator module's channel (`op/fx`) gives the module's reasons
            names = self.layout.REASON_NAMES[module.partition("/")[0]]
            fields["error_num"] = list(names).index(reason)
        self.layout.STATUS_OUT[module].write(self.buf, **fields)

    def status(self, module: str) -> Status:
        values = self.layout.STATUS_OUT[module].read(self.buf)
        runs = self._states_of.get(module, module)  # a stand-in's names, while it runs
        status = self.contract.STATUS_NAMES[values["status"]]
        return Status(
            status,
            values["status_num"],
            self.layout.STATE_NAMES[runs][values["state"]],
            values["error_num"],
            self.layout.RULES[runs][values["rule"]] or None,
            self.contract.reason_name(self.layout, module, status, values["error_num"]),
            result_values(self.layout, module, values),
            plan_slots(values),
            self.contract.cause_text(self.layout, values.get("cause", 0))
            if status == "ERROR"
            else "",
        )

    def set_mode(self, module: str, **mode: Any) -> None:
        """Set dont_run, single_step, simulate or single_step_num in `module`'s mode buffer."""
        self.layout.MODE_IN[module].write(self.buf, **mode)

    def performance(self, module: str) -> dict[str, int]:
        return dict(self.layout.PERFORMANCE[module].read(self.buf))

    def process_record(self, process: str) -> dict[str, int]:
        """A process's control record: heartbeat, counters, state."""
        return dict(self.layout.PROCESSES[process].read(self.buf))

    def results(self, module: str) -> dict[str, Any]:
        """`module`'s results in its status buffer, by name (an enumeration's by value name)."""
        return self.status(module).results

    @property
    def world(self) -> World:
        return World(self.layout, self.buf)

    def _rows(self, modules: tuple[str, ...]) -> tuple[str, ...]:
        """`modules` with each operator module replaced by its channels (`op/fx`, ...): the
        names that have a command and status buffer each."""
        channels = getattr(self.layout, "OPERATORS", {})
        return tuple(row for m in modules for row in channels.get(m, (m,)))


class Harness(BlockView):
    """A generated system on a private in-process block: one process of it, or all of them
    (`process=None`: every process's modules, process by process, the lockstep order)."""

    def __init__(
        self,
        package: ModuleType,
        process: str | None = None,
        send_init: bool = False,
        scratch: Path | None = None,
        settings: dict[str, str] | None = None,
        simulate: tuple[str, ...] = (),
    ) -> None:
        self.package = package
        self.layout = importlib.import_module(f"{package.__name__}.layout")
        runtime = f"{package.__name__}.rcs"
        self.contract = importlib.import_module(f"{runtime}.contract")
        loop = importlib.import_module(f"{runtime}.loop")
        names = [process] if process is not None else list(self.layout.PROCESSES)
        plans = {
            name: importlib.import_module(f"{package.__name__}.main_{name}").PLAN for name in names
        }
        unknown = sorted(set(simulate) - {m for plan in plans.values() for m in plan.stand_ins})
        if unknown:
            raise ValueError(f"no stand-in for {unknown}")
        if settings_problem(self.layout, settings or {}):
            raise ValueError(settings_problem(self.layout, settings or {}))
        self.block = importlib.import_module(f"{runtime}.block").Block(self.layout)
        self.buf = self.block.buf
        self.processes = {
            name: loop.Process(
                plan,
                self.layout,
                self.block,
                settings,
                [m for m in simulate if m in plan.stand_ins],
            )
            for name, plan in plans.items()
        }
        self.process = next(iter(self.processes.values()))
        self.process_name = next(iter(self.processes))
        if send_init:
            for each in self.processes.values():
                each.send_init()
        self._scratch = scratch

    @property
    def _states_of(self) -> dict[str, str]:  # type: ignore[override]
        """Whose state names a module's status uses: a stand-in's, while it runs in its place."""
        return {
            name: each.plan.stand_ins[name][0]
            for each in self.processes.values()
            for name in each.simulated
        }

    # ------------------------------------------------------------ construction

    @classmethod
    def build(cls, spec_dir: str | Path, process: str | None = None, **options: Any) -> Harness:
        """Generate the system in `spec_dir` into a scratch directory and load it."""
        spec_dir = Path(spec_dir)
        scratch, name = generate(spec_dir)
        package = import_package(scratch / name, spec_dir.resolve())
        return cls(package, process, scratch=scratch, **options)

    @classmethod
    def load(
        cls,
        package_dir: str | Path,
        hooks_dir: str | Path | None = None,
        process: str | None = None,
        **options: Any,
    ) -> Harness:
        """Load an already generated package (e.g. `generated/miner`)."""
        hooks = Path(hooks_dir).resolve() if hooks_dir is not None else None
        return cls(import_package(Path(package_dir).resolve(), hooks), process, **options)

    def close(self) -> None:
        for each in self.processes.values():  # fieldbus devices: their threads stopped
            if each.io is not None:
                each.io.close()
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)
            self._scratch = None

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ running

    @property
    def modules(self) -> tuple[str, ...]:
        """The modules this run executes, in order (a stand-in runs under its controller's
        name, an operator module as its channels, `op/fx`)."""
        return self._rows(tuple(m for each in self.processes.values() for m in each.modules))

    def controller(self, module: str) -> Any:
        """The generated controller object of `module` (its local buffers are attributes)."""
        for each in self.processes.values():
            if module in each.modules:
                return each.modules[module]
        raise KeyError(f"{module} does not run in this harness")

    def performance(self, module: str) -> dict[str, int]:
        """`module`'s performance buffer as of its last cycle: a module running here
        publishes it first (a process does every PERF_INTERVAL, rcs/contract.py)."""
        try:
            publish = getattr(self.controller(module), "publish", None)
        except KeyError:  # not running here (skipped under its stand-in): as the block has it
            publish = None
        if publish is not None:
            publish()
        return super().performance(module)

    def step(self, module: str) -> None:
        """Run one module for one cycle; nothing else runs."""
        self.controller(module).run_cycle()

    def cycle(self, count: int = 1) -> None:
        """Run whole system cycles: every module once, in the declared order."""
        for _ in range(count):
            for each in self.processes.values():
                each.run_cycle()

    @property
    def cycles(self) -> int:
        return int(self.process.cycle)


class LaunchedHarness(BlockView):
    """A generated system run as its processes, one OS process each over a shared segment
    (or, with `transport="zenoh"`, each on a block of its own, connected only through Zenoh
    on 127.0.0.1, the harness reading the launcher's block that mirrors them all), stepped
    in lockstep: a whole system cycle at a time, in the order `Harness` runs them, so a
    scenario leaves the same trace either way. INIT reaches the roots as in `Harness`
    with `send_init`. Use as a context manager: closing stops the processes and removes
    the segment."""

    _segments = itertools.count(1)

    def __init__(
        self,
        package_dir: str | Path,
        hooks_dir: str | Path | None = None,
        settings: dict[str, str] | None = None,
        simulate: tuple[str, ...] = (),
        transport: str = "shm",
        ring: bool = True,
        spin: float | None = None,
        turns: bool = True,
        dedicated: bool = False,
    ) -> None:
        package_dir = Path(package_dir).resolve()
        hooks = Path(hooks_dir).resolve() if hooks_dir is not None else None
        package = import_package(package_dir, hooks)
        self.package = package
        self.layout = importlib.import_module(f"{package.__name__}.layout")
        self.contract = importlib.import_module(f"{package.__name__}.rcs.contract")
        launcher = importlib.import_module(f"{package.__name__}.rcs.operate.launcher")
        plans = {
            name: importlib.import_module(f"{package.__name__}.main_{name}").PLAN
            for name in self.layout.PROCESSES
        }
        unknown = sorted(set(simulate) - {m for plan in plans.values() for m in plan.stand_ins})
        if unknown:
            raise ValueError(f"no stand-in for {unknown}")
        if settings_problem(self.layout, settings or {}):
            raise ValueError(settings_problem(self.layout, settings or {}))
        path = (str(package_dir.parent), *([str(hooks)] if hooks else []))
        system = launcher.System(package_dir.name, self.layout, plans, path)
        segment = f"rcsgen_run_{os.getpid()}_{next(self._segments)}"
        settings_args = [f"{key}={value}" for key, value in (settings or {}).items()]
        self.launcher = launcher.Launcher(
            system,
            segment,
            lockstep=True,
            settings=settings_args,
            simulate=list(simulate),
            transport=transport,
            ring=ring,  # False: the coordinator's request and answer (bench/bench_lockstep.py)
            spin=spin,  # seconds a ring member spins before it blocks (None: where cores allow)
            turns=turns,  # False: the ring spins on its eventfds, no turn words (the bench)
            dedicated=dedicated,  # spin without looking at the load (cores of its own)
        )
        self.launcher.start()
        try:
            if transport == "zenoh":  # the launcher's block mirrors every process's
                self.coordinator = launcher.NetworkCoordinator(self.launcher)
            else:
                self.coordinator = launcher.Coordinator(self.launcher)
        except BaseException:
            self.launcher.stop()
            raise
        self.block = self.launcher.block
        self.buf = self.block.buf
        self._states_of = {m: stand_in_of(plans, m) for m in simulate}
        skipped = {
            n
            for plan in plans.values()
            for m in simulate
            if m in plan.stand_ins
            for n in plan.stand_ins[m][1]
            if n != m
        }
        self._modules = tuple(
            m for plan in plans.values() for m in plan.modules if m not in skipped
        )

    @property
    def modules(self) -> tuple[str, ...]:
        return self._rows(self._modules)

    def cycle(self, count: int = 1) -> None:
        """Run whole system cycles, every process in turn."""
        self.coordinator.step(count)

    @property
    def cycles(self) -> int:
        return int(self.coordinator.cycle)

    def summary(self) -> list[str]:
        """The launcher's summary, once closed."""
        return list(self.launcher.final)

    def close(self) -> None:
        self.launcher.stop()

    def __enter__(self) -> LaunchedHarness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def stand_in_of(plans: dict[str, Any], module: str) -> str:
    """The stand-in that runs in `module`'s place."""
    return str(
        next(plan.stand_ins[module][0] for plan in plans.values() if module in plan.stand_ins)
    )


AnyHarness = Harness | LaunchedHarness


class World:
    """The world model in the block, as a mapping: `h.world["loose_coal"] = 5.0`."""

    def __init__(self, layout: ModuleType, buf: memoryview) -> None:
        self._layout, self._buf = layout, buf

    def __getitem__(self, name: str) -> Any:
        value = self._layout.WORLD[name].read(self._buf)[name]
        return enum_name(self._layout, "", name, value)

    def __setitem__(self, name: str, value: Any) -> None:
        value = enum_code(self._layout, "", name, value)
        self._layout.WORLD[name].write(self._buf, **{name: value})

    def update(self, values: dict[str, Any]) -> None:
        for name, value in values.items():
            self[name] = value

    def snapshot(self, names: list[str] | None = None) -> dict[str, Any]:
        return {n: self[n] for n in (names if names is not None else self._layout.WORLD)}

    def overrides(self) -> dict[str, str]:
        """The fields under an override: name -> FORCED or SAFE (latched); {} when none
        (one byte read), so traces of systems without overrides are unchanged."""
        at = getattr(self._layout, "OVERRIDDEN_AT", None)
        if at is None or not self._buf[at]:
            return {}
        states = ("NONE", "FORCED", "SAFE")
        held = {n: int(r.read(self._buf)["state"]) for n, r in self._layout.OVERRIDE.items()}
        return {n: states[state] for n, state in held.items() if state}
