"""Ctl: an operator's console over a running system's segment (`python -m <system> ctl VERB`).

The debug screen of the mining paper (4.1.1.1, Appendix D) as commands: `status` shows
every module's command, status, state, the rule that fired, its modes and cycle times and
its process's heartbeat; `stop`/`run`/`step`/`simulate` set a module's mode buffer; `slow`
stretches the processes' cycle periods; `send` gives a module a command, its parameters
checked against the layout; `wait` waits for a module to finish. It attaches to the segment
by name (checking the layout hash) and needs only the package's layout: no hooks, no
compiler. Every read is a consistent read and every write goes through `Record.write`
(the seqlock); it writes only mode, pacing and command buffers. Bad input is one line on
stderr and exit 2 (usage) or 1 (the system refused or is not there). Standard library only:
copied verbatim into every generated package.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from types import ModuleType
from typing import Any, NoReturn

from .block import Block, BlockError
from .contract import FINISHED, PROCESS_STATES, RUNNING, STATUS_NAMES, StaleRead
from .transport import TransportError, check_endpoint

USAGE, FAILED = 2, 1
POLL = 0.005  # seconds between two reads while waiting for the system


class CtlError(Exception):
    """A request the console refuses: one line for the operator, and an exit code."""

    def __init__(self, message: str, code: int = FAILED) -> None:
        super().__init__(message)
        self.code = code


def usage(message: str) -> CtlError:
    return CtlError(message, USAGE)


def suggest(name: str, choices: Sequence[str], what: str) -> str:
    """`no module 'cx' (did you mean 'co'?); modules: sb, co, ...`."""
    close = difflib.get_close_matches(name, list(choices), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return f"no {what} {name!r}{hint}; {what}s: {', '.join(choices) or 'none'}"


@dataclass(frozen=True)
class Command:
    """A command an operator gives a module, its parameters typed by the layout."""

    module: str
    command: str
    args: dict[str, object]

    def __str__(self) -> str:
        args = " ".join(f"{k}={_shown(v)}" for k, v in self.args.items())
        return f"{self.module}.{self.command}" + (f" {args}" if args else "")


def parse_command(layout: ModuleType, module: str, command: str, items: Sequence[str]) -> Command:
    """Check `MODULE COMMAND NAME=VALUE ...` against the layout; ValueError says what is wrong,
    naming the module's commands or parameters (with a did-you-mean)."""
    if module not in layout.COMMAND_IN:
        raise ValueError(suggest(module, layout.MODULES, "module"))
    commands = layout.COMMAND_NAMES[module][1:]
    if command not in commands:
        raise ValueError(f"{module} has " + suggest(command, commands, "command"))
    record = layout.COMMAND_IN[module]
    slots = {f.removeprefix("arg_"): f for f in record.fields if f.startswith("arg_")}
    values: dict[str, object] = {}
    for item in items:
        name, equals, raw = item.partition("=")
        if not equals:
            raise ValueError(f"{item!r} is not NAME=VALUE")
        if name not in slots:
            raise ValueError(f"{module} has " + suggest(name, list(slots), "parameter"))
        code = str(record.struct.format).lstrip("<")[list(record.fields).index(slots[name]) + 1]
        values[name] = typed(raw, code, name)
    return Command(module, command, values)


def typed(raw: str, code: str, name: str = "") -> object:
    """`raw` as the struct `code` of a parameter or world field: ? bool, q int, d float."""
    try:
        if code == "?":
            if raw not in ("true", "false"):
                raise ValueError
            return raw == "true"
        return int(raw) if code == "q" else float(raw)
    except ValueError:
        kind = {"?": "true or false", "q": "an integer"}.get(code, "a number")
        where = f" ({name})" if name else ""
        raise ValueError(f"{raw!r} is not {kind}{where}") from None


def _shown(value: object) -> str:
    return str(value).lower() if isinstance(value, bool) else str(value)


# ---------------------------------------------------------------- the console


class Console:
    """A running system's segment, read and written as an operator does."""

    def __init__(self, layout: ModuleType, segment: str, attached: Any = None) -> None:
        self.layout = layout
        self.segment = segment
        # `attached`: a block kept current over the network (zenoh_transport.Attached)
        self.attached = attached
        self.block = attached.block if attached is not None else Block(layout, segment, False)
        self.buf = self.block.buf
        self.supervisor = {
            sub: boss
            for boss in layout.MODULES
            for sub in layout.SUBORDINATES.get(boss, ())
            if sub in layout.COMMAND_IN
        }

    def close(self) -> None:
        if self.attached is not None:
            self.attached.close()
        else:
            self.block.close()

    def read(self, record: Any, tries: int = 20) -> dict[str, Any]:
        """A consistent read, retried briefly while a writer is busy; {} if it stays torn."""
        for _ in range(tries):
            try:
                return dict(record.read(self.buf))
            except StaleRead:
                time.sleep(0.0005)
        return {}

    def module(self, name: str) -> str:
        if name not in self.layout.COMMAND_IN:
            raise usage(suggest(name, self.layout.MODULES, "module"))
        return name

    # ------------------------------------------------------------ status

    def processes(self) -> dict[str, dict[str, Any]]:
        now = time.monotonic_ns()
        found: dict[str, dict[str, Any]] = {}
        pacing = getattr(self.layout, "PACING", {})
        for name, record in self.layout.PROCESSES.items():
            values = self.read(record)
            if not values:
                found[name] = {"state": "?"}
                continue
            beat = int(values["beat_ns"])
            age = (now - beat) / 1e9 if beat else None
            state = int(values["state"])
            alive = state == RUNNING and age is not None and age <= self.layout.HEARTBEAT_TIMEOUT
            pace = self.read(pacing[name]) if name in pacing else {}
            found[name] = {
                "state": _name(PROCESS_STATES, state),
                "alive": alive,
                "pid": values["pid"],
                "heartbeat": values["heartbeat"],
                "heartbeat_age_s": None if age is None else round(age, 3),
                "overruns": values["overruns"],
                "late_wakeups": values["late_wakeups"],
                "watchdog_trips": values["watchdog_trips"],
                "load_warnings": values["load_warnings"],
                "slow": max(1.0, float(pace.get("slow", 0.0))),
            }
        return found

    def modules(self, processes: dict[str, dict[str, Any]] | None = None) -> dict[str, Any]:
        """Every module's debug-screen line as plain data."""
        layout = self.layout
        processes = processes if processes is not None else self.processes()
        stand_ins = getattr(layout, "STAND_INS", {})
        rows: dict[str, Any] = {}
        for name in layout.MODULES:
            command = self.read(layout.COMMAND_IN[name])
            status = self.read(layout.STATUS_OUT[name])
            mode = self.read(layout.MODE_IN[name])
            perf = self.read(layout.PERFORMANCE[name])
            runs = stand_ins[name] if mode.get("simulate") and name in stand_ins else name
            process = layout.PLACEMENT.get(name, "")
            proc = processes.get(process, {})
            row: dict[str, Any] = {"process": process, "runs": runs}
            if command:
                row["command"] = _name(layout.COMMAND_NAMES[name], int(command["command"]))
                row["command_num"] = command["command_num"]
                row["args"] = {
                    k.removeprefix("arg_"): v for k, v in command.items() if k.startswith("arg_")
                }
            if status:
                row["status"] = _name(STATUS_NAMES, int(status["status"]))
                row["status_num"] = status["status_num"]
                row["error_num"] = status["error_num"]
                row["state"] = _name(layout.STATE_NAMES[runs], int(status["state"]))
                rule = _name(layout.RULES[runs], int(status["rule"]))
                row["rule"] = rule or None
            if mode:
                row["run"] = "STOP" if mode["dont_run"] else "RUN"
                row["step"] = "SINGLE" if mode["single_step"] else "AUTO"
                row["sim"] = "SIMU" if mode["simulate"] else "REAL"
            if perf:
                for key in ("last", "min", "max"):
                    row[f"{key}_cycle_us"] = round(int(perf[f"{key}_cycle_ns"]) / 1000, 1)
                row["cycles"] = perf["cycles"]
                row["stale_reads"] = perf["stale_reads"]
            row["heartbeat_age_s"] = proc.get("heartbeat_age_s")
            row["alive"] = bool(proc.get("alive"))
            row["supervisor"] = self.supervisor.get(name)
            rows[name] = row
        return rows

    def snapshot(self) -> dict[str, Any]:
        processes = self.processes()
        return {
            "system": self.layout.SYSTEM,
            "segment": self.segment,
            "layout_hash": self.layout.LAYOUT_HASH,
            "processes": processes,
            "modules": self.modules(processes),
        }

    # ------------------------------------------------------------ modes

    def set_mode(self, module: str, **mode: object) -> None:
        self.layout.MODE_IN[self.module(module)].write(self.buf, **mode)

    def step(self, module: str, count: int = 1, timeout: float = 10.0) -> int:
        """Single-step `module` `count` cycles, each one seen run; the cycles it stepped."""
        record, perf = self.layout.MODE_IN[self.module(module)], self.layout.PERFORMANCE[module]
        for done in range(count):
            number = int(self.read(record).get("single_step_num", 0)) + 1
            record.write(self.buf, dont_run=False, single_step=True, single_step_num=number)
            if not _until(partial(self._stepped, perf, number), timeout):
                raise CtlError(
                    f"{module} did not run its step {done + 1} within {timeout:g} s (is its "
                    "process running, and is it not skipped under a simulated supervisor?)"
                )
        return count

    def _stepped(self, perf: Any, number: int) -> bool:
        return bool(self.read(perf).get("single_step_num") == number)

    def simulate(self, module: str, on: bool) -> None:
        stand_ins = getattr(self.layout, "STAND_INS", {})
        if self.module(module) not in stand_ins:
            raise usage(f"{module} has no stand-in; these do: {', '.join(stand_ins) or 'none'}")
        self.set_mode(module, simulate=on)

    def slow(self, factor: float, processes: Sequence[str] = ()) -> list[str]:
        pacing = getattr(self.layout, "PACING", {})
        names = list(processes) or list(pacing)
        for name in names:
            if name not in pacing:
                raise usage(suggest(name, list(pacing), "process"))
        for name in names:
            pacing[name].write(self.buf, slow=factor)
        return names

    # ------------------------------------------------------------ commands

    def send(self, command: Command, override: bool = False) -> tuple[int, list[str]]:
        """Write `command` to its module's command buffer, numbered after the last one; the
        number and what the operator should know (a supervisor put in manual override)."""
        notes = []
        boss = self.supervisor.get(command.module)
        if boss is not None:
            if not override:
                raise CtlError(
                    f"{command.module} is commanded by {boss}: its next command would replace "
                    f"yours; use --override to put {boss} in manual override (STOP) first"
                )
            self.set_mode(boss, dont_run=True)
            notes.append(
                f"{boss} is in manual override (STOP): it sends nothing until "
                f"`ctl run {boss}`, whose next command to {command.module} replaces this one"
            )
        record = self.layout.COMMAND_IN[command.module]
        current = self.read(record)
        if not current:
            raise CtlError(f"{command.module}'s command buffer cannot be read whole")
        number = int(current["command_num"]) + 1
        code = self.layout.COMMAND_NAMES[command.module].index(command.command)
        args = {f"arg_{k}": v for k, v in command.args.items()}
        record.write(self.buf, command_num=number, command=code, **args)
        return number, notes

    def seen(self, module: str, number: int) -> bool:
        """Whether `module` has echoed command `number` (its status number caught up)."""
        return int(self.read(self.layout.STATUS_OUT[module]).get("status_num", -1)) >= number

    def outcome(self, module: str) -> str | None:
        """DONE or ERROR once `module` reported on the command in its buffer; else None."""
        command = self.read(self.layout.COMMAND_IN[module])
        status = self.read(self.layout.STATUS_OUT[module])
        if not command or not status or status["status_num"] != command["command_num"]:
            return None
        name = _name(STATUS_NAMES, int(status["status"]))
        return name if name in FINISHED else None


def _name(names: Sequence[str], code: int) -> str:
    return names[code] if 0 <= code < len(names) else f"?{code}"


def _until(condition: Callable[[], object], timeout: float | None) -> bool:
    end = None if timeout is None else time.monotonic() + timeout
    while not condition():
        if end is not None and time.monotonic() > end:
            return False
        time.sleep(POLL)
    return True


# ---------------------------------------------------------------- the screen


COLUMNS = (
    ("module", 6),
    ("command", 14),
    ("#", 4),
    ("status", 9),
    ("#", 4),
    ("state", 10),
    ("rule", 22),
    ("mode", 16),
    ("cycle us last/min/max", 22),
    ("beat", 6),
)


def render(snapshot: dict[str, Any]) -> list[str]:
    """The debug screen as text: one line per module, then one per process."""
    lines = [f"{snapshot['system']} on {snapshot['segment']}"]
    lines.append("  ".join(title.ljust(width) for title, width in COLUMNS).rstrip())
    for name, row in snapshot["modules"].items():
        mode = f"{row.get('run', '?')} {row.get('step', '?')} {row.get('sim', '?')}"
        times = "/".join(str(row.get(f"{k}_cycle_us", "?")) for k in ("last", "min", "max"))
        age = row.get("heartbeat_age_s")
        beat = "dead" if not row.get("alive") else f"{age:.2f}s"
        cells = [
            name,
            str(row.get("command", "?")),
            str(row.get("command_num", "?")),
            str(row.get("status", "?")),
            str(row.get("status_num", "?")),
            str(row.get("state", "?")),
            str(row.get("rule") or "-"),
            mode,
            times,
            beat,
        ]
        widths = [w for _, w in COLUMNS]
        lines.append("  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)).rstrip())
    for name, proc in snapshot["processes"].items():
        if proc.get("state") == "?":
            lines.append(f"process {name}: control record unreadable")
            continue
        age = proc["heartbeat_age_s"]
        lines.append(
            f"process {name}: {proc['state'].lower()}, pid {proc['pid']}, {proc['heartbeat']} "
            f"cycles, beat {'-' if age is None else f'{age:.2f}s'} ago, {proc['overruns']} "
            f"overruns, {proc['late_wakeups']} late wake-ups, {proc['watchdog_trips']} "
            f"watchdog trips, slow x{proc['slow']:g}"
        )
    return lines


# ---------------------------------------------------------------- command line


class _Parser(argparse.ArgumentParser):
    """argparse, but a mistake is one line and exit 2."""

    def error(self, message: str) -> NoReturn:
        raise usage(message)


def parser(package: str, layout: ModuleType) -> argparse.ArgumentParser:
    default = f"rcs_{layout.SYSTEM}_{layout.LAYOUT_HASH[:8]}"
    top = _Parser(
        prog=f"python -m {package} ctl",
        description=f"Operate a running {layout.SYSTEM} system through its segment.",
    )
    top.add_argument("--shm", default=default, help=f"the segment [default: {default}]")
    top.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="PROTO/HOST:PORT",
        help="attach through Zenoh to a host of the system (--transport zenoh), not a segment",
    )
    verbs = top.add_subparsers(dest="verb", required=True, parser_class=_Parser)
    status = verbs.add_parser("status", help="every module's debug-screen line")
    status.add_argument("--watch", action="store_true", help="refresh until Ctrl-C")
    status.add_argument("--interval", type=float, default=0.5, help="seconds between refreshes")
    status.add_argument("--format", choices=("text", "json"), default="text")
    for verb, text in (("stop", "hold MODULE's table (STOP)"), ("run", "RUN and AUTO again")):
        verbs.add_parser(verb, help=text).add_argument("module")
    step = verbs.add_parser("step", help="single-step MODULE N cycles (SINGLE)")
    step.add_argument("module")
    step.add_argument("count", nargs="?", type=int, default=1)
    step.add_argument("--timeout", type=float, default=10.0, help="seconds per step")
    simulate = verbs.add_parser("simulate", help="run MODULE's stand-in in its place, or not")
    simulate.add_argument("module")
    simulate.add_argument("switch", choices=("on", "off"))
    slow = verbs.add_parser("slow", help="stretch the cycle periods by FACTOR (1: normal)")
    slow.add_argument("factor", type=float)
    slow.add_argument("--process", action="append", default=[], help="only this (repeatable)")
    send = verbs.add_parser("send", help="give MODULE a COMMAND with NAME=VALUE parameters")
    send.add_argument("module")
    send.add_argument("command")
    send.add_argument("params", nargs="*", metavar="NAME=VALUE")
    send.add_argument(
        "--override", action="store_true", help="put MODULE's supervisor in manual override first"
    )
    send.add_argument(
        "--seen", action="store_true", help="wait until the module echoes it, print the latency"
    )
    wait = verbs.add_parser("wait", help="wait until MODULE reports DONE or ERROR")
    wait.add_argument("module")
    wait.add_argument("outcome", choices=FINISHED)
    wait.add_argument("--timeout", type=float, default=None)
    return top


def main(package: str, argv: Sequence[str]) -> int:
    """`python -m <system> ctl [--shm NAME] VERB ...`: 0 done, 1 refused or failed, 2 usage."""
    layout = importlib.import_module(f"{package}.layout")
    try:
        args = parser(package, layout).parse_args(list(argv))
        return _run(layout, args)
    except CtlError as error:
        print(f"ctl: error: {error}", file=sys.stderr)
        return error.code
    except KeyboardInterrupt:
        return 0


def _run(layout: ModuleType, args: argparse.Namespace) -> int:
    command = None
    if args.verb == "send":
        try:
            command = parse_command(layout, args.module, args.command, args.params)
        except ValueError as error:
            raise usage(str(error)) from None
    elif hasattr(args, "module") and args.module not in layout.COMMAND_IN:
        raise usage(suggest(args.module, layout.MODULES, "module"))
    if args.verb == "step" and args.count < 1:
        raise usage("step: N must be 1 or more")
    if args.verb == "slow" and args.factor < 1.0:
        raise usage("slow: FACTOR must be 1 (normal speed) or more")
    try:
        where = f"zenoh {' '.join(args.connect)}" if args.connect else args.shm
        console = Console(layout, where, attach(layout, args.connect))
    except (BlockError, TransportError, ValueError) as error:
        raise CtlError(str(error)) from None
    try:
        return _verb(console, args, command)
    finally:
        console.close()


def attach(layout: ModuleType, endpoints: Sequence[str]) -> Any:
    """With `--connect`: a private block that mirrors the system over Zenoh (else None)."""
    if not endpoints:
        return None
    from .zenoh_transport import Attached, Options

    return Attached(layout, Options(connect=tuple(check_endpoint(e) for e in endpoints)))


def _verb(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    verb = args.verb
    if verb == "status":
        while True:
            snapshot = console.snapshot()
            if args.format == "json":
                text = json.dumps(snapshot, indent=2)
            else:
                text = "\n".join(render(snapshot))
            if not args.watch:
                print(text)
                return 0
            print("\x1b[H\x1b[2J" + text, flush=True)
            time.sleep(args.interval)
    if verb == "stop":
        console.set_mode(args.module, dont_run=True)
        print(f"{args.module}: STOP")
    elif verb == "run":
        console.set_mode(args.module, dont_run=False, single_step=False)
        print(f"{args.module}: RUN AUTO")
    elif verb == "step":
        console.step(args.module, args.count, args.timeout)
        row = console.modules()[args.module]
        print(
            f"{args.module}: stepped {args.count} cycle(s), SINGLE: state {row.get('state')}, "
            f"rule {row.get('rule') or '-'}; `run {args.module}` goes back to AUTO"
        )
    elif verb == "simulate":
        console.simulate(args.module, args.switch == "on")
        print(f"{args.module}: {'SIMU' if args.switch == 'on' else 'REAL'}")
    elif verb == "slow":
        names = console.slow(args.factor, args.process)
        print(f"slow x{args.factor:g}: {', '.join(names)}")
    elif verb == "send":
        assert command is not None
        began = time.perf_counter()
        number, notes = console.send(command, args.override)
        for note in notes:
            print(note)
        print(f"sent {command} #{number}")
        if args.seen:
            if not _until(lambda: console.seen(command.module, number), 10.0):
                raise CtlError(f"{command.module} did not echo #{number} within 10 s")
            took = (time.perf_counter() - began) * 1000
            print(f"{command.module} saw #{number} after {took:.1f} ms")
    elif verb == "wait":
        module = args.module
        if not _until(lambda: console.outcome(module) is not None, args.timeout):
            raise CtlError(f"{module} did not finish within {args.timeout:g} s")
        outcome = console.outcome(module)
        row = console.modules()[module]
        print(f"{module} {outcome} {row.get('command')} #{row.get('command_num')}")
        return 0 if outcome == args.outcome else FAILED
    return 0
