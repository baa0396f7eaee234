"""Ctl: an operator's console over a running system's segment (`python -m <system> ctl VERB`).

The debug screen of the mining paper (4.1.1.1, Appendix D) as commands: `status` shows
every module's command, status, state, the rule that fired, its modes and cycle times and
its process's heartbeat; `stop`/`run`/`step`/`simulate` set a module's mode buffer; `slow`
stretches the processes' cycle periods; `send` gives a module a command, checked by the
one command contract (rcs/operate/command.py) before anything is written; `wait` waits for a module
to finish; `requests` lists what modules ask of the operator and `answer` answers (an
operator module's channel: DONE or ERROR with a reason, in its answer record); `status
--world` shows the world fields; `force`/`unforce` force a world field PLC style and
`reset` releases fields latched safe (rcs/override.py). It attaches to the segment by name
(checking the layout hash) and needs only the package's layout: no hooks, no compiler.
Every read is a consistent read and every write goes through `Record.write` (the seqlock);
it writes only mode, pacing, command buffers, answer and override records. Bad input is one line on
stderr and exit 2 (usage) or 1 (the system refused or is not there). Standard library only:
copied verbatim into every generated package.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from types import ModuleType
from typing import Any, NoReturn

from .. import override
from ..block import Block, BlockError, group_name, user_name
from ..contract import (
    ACCESS_LEVELS,
    BUILTIN_COMMANDS,
    DONE,
    ERROR,
    EXECUTING,
    FINISHED,
    NETWORK_FIELDS,
    PROCESS_STATES,
    RUNNING,
    STATUS_NAMES,
    StaleRead,
    cause_text,
    counted,
    enum_name,
    field_names,
    listed,
    network_line,
    periodicity,
    periodicity_line,
    plan_slots,
    reason_name,
    result_values,
    shared,
    status_text,
)
from ..io_points import device_status
from ..state_time import shares, totals
from ..transport import TransportError, check_endpoint
from .command import (
    Command,
    answer_results,
    check_command,
    outcome,
    parse_command,
    parse_value,
    shown,
    suggest,
    task_results,
    write_command,
)
from .startup import default_segment, segment_problem

USAGE, FAILED = 2, 1
MAX_SLOW = 1000.0  # the largest slow-down factor: 0.1 s periods stretched to 100 s
MAX_STEPS = 1_000_000  # cycles one `step` may single-step
MAX_WAIT = 86_400.0  # the longest time-out, seconds (a day)
POLL = 0.005  # seconds between two reads while waiting for the system


@shared
class CtlError(Exception):
    """A request the console refuses: one line for the operator, and an exit code."""

    def __init__(self, message: str, code: int = FAILED) -> None:
        super().__init__(message)
        self.code = code


def usage(message: str) -> CtlError:
    return CtlError(message, USAGE)


# ---------------------------------------------------------------- operator modules' requests


def channel_requests(layout: ModuleType, buf: memoryview) -> list[dict[str, Any]]:
    """The requests open on the operator modules' channels now, in layout order: a client
    sent a task (not INIT or HALT) that the channel has not answered, and no answer to its
    number is on its way. Each: the channel (`name`, `op/fx`), the client (`by`), the task,
    its command number, the instruction text with the parameters' values (`doc`) and the
    reasons an ERROR may give. One place for what "open" means: the console, the monitor
    and a scenario's scripted operator all read it here."""
    found = []
    for operator, channels in getattr(layout, "OPERATORS", {}).items():
        for channel in channels:
            try:
                command = layout.COMMAND_IN[channel].read(buf)
                status = layout.STATUS_OUT[channel].read(buf)
                answer = layout.ANSWERS[channel].read(buf)
            except StaleRead:
                continue  # being written: it shows next time
            number, code = int(command["command_num"]), int(command["command"])
            if code <= len(BUILTIN_COMMANDS) or answer["command_num"] == number:
                continue  # nothing asked, a withdrawal, or answered already
            if status["status_num"] == number and status["status"] != EXECUTING:
                continue  # answered and closed
            task = layout.COMMAND_NAMES[channel][code]
            args = {k.removeprefix("arg_"): v for k, v in command.items() if k.startswith("arg_")}
            text = layout.INSTRUCTIONS[operator].get(task, "")
            found.append(
                {
                    "name": channel,
                    "by": channel.split("/", 1)[1],
                    "operator": operator,
                    "task": task,
                    "number": number,
                    "doc": text.format(
                        **{
                            k: shown(enum_name(layout, operator, f"arg_{k}", v))
                            for k, v in args.items()
                        }
                    ),
                    "answer": "DONE|ERROR",
                    "reasons": list(layout.REASON_NAMES.get(operator, ())[2:]),
                    "results": result_forms(layout, operator, task),
                }
            )
    return found


def result_forms(layout: ModuleType, operator: str, task: str) -> dict[str, str]:
    """What a DONE answer to `task` gives, result by result, as a person types it:
    `KEEP|REWORK`, `0.0..5.0` (a float's range), `int`, `true|false`, `text`."""
    forms = {}
    for name, (code, names, low, high) in task_results(layout, operator, task).items():
        if names:
            form = "|".join(names)
        elif code == "?":
            form = "true|false"
        elif code.endswith("s"):
            form = "text"
        elif low is not None or high is not None:
            form = f"{'' if low is None else low}..{'' if high is None else high}"
        else:
            form = "int" if code == "q" else "float"
        forms[name] = form
    return forms


def write_answer(
    layout: ModuleType,
    buf: memoryview,
    request: dict[str, Any],
    status: str,
    reason: str = "",
    results: Mapping[str, object] | None = None,
    typed: bool = False,
) -> None:
    """Answer an open channel request (one of `channel_requests`): DONE with the results the
    task records (`results`: text as typed, or with `typed` values as a scenario gives
    them), or ERROR with one of its reasons (none: NONE). ValueError for another status, an
    unknown reason, or results that do not fit the task (`answer_results`): nothing is
    written then. The one writer of answer records: the console and a scenario's scripted
    operator both answer here."""
    if status not in FINISHED:
        raise ValueError(f"answer DONE or ERROR, not {status!r}")
    names = layout.REASON_NAMES.get(request["operator"], ())
    if reason and status != "ERROR":
        raise ValueError(f"a reason goes with ERROR only; DONE needs none (got {reason!r})")
    if reason and reason not in request["reasons"]:
        raise ValueError(suggest(reason, request["reasons"], "reason") + f" of {request['task']}")
    if status == "ERROR" and results:
        raise ValueError(
            f"results go with DONE only; an ERROR records none (got {', '.join(results)})"
        )
    slots = (
        answer_results(layout, request["operator"], request["task"], results or {}, typed)
        if status == "DONE"
        else {}
    )
    code = DONE if status == "DONE" else ERROR
    layout.ANSWERS[request["name"]].write(
        buf,
        command_num=request["number"],
        status=code,
        reason=names.index(reason) if reason else 0,
        **slots,
    )


# ---------------------------------------------------------------- access levels


class Access:
    """What the operator's role may do, module by module (the layout's ROLES, from the
    system file's `operators.roles`). A system that declares no roles restricts nothing;
    one that does lets an operator without a role only monitor. A role that names who
    holds it (ROLE_HOLDERS) is refused, exit 1, to a user who is not one of them."""

    def __init__(self, layout: ModuleType, role: str | None) -> None:
        self.roles: dict[str, dict[str, int]] = getattr(layout, "ROLES", {})
        self.system = layout.SYSTEM
        if role is not None and not self.roles:
            raise usage(f"{self.system} declares no operator roles; leave out --role")
        if role is not None and role not in self.roles:
            raise usage(suggest(role, list(self.roles), "role"))
        if role is not None:
            problem = holder_problem(layout, role)
            if problem:
                raise CtlError(f"refused: {problem}")
        self.role = role

    def level(self, module: str) -> int:
        """The role's level on `module` (an operator module's, for its channel `op/fx`),
        an index in ACCESS_LEVELS."""
        if not self.roles:
            return len(ACCESS_LEVELS) - 1
        if self.role is None:
            return 0
        return self.roles[self.role].get(module.split("/")[0], 0)

    def require(self, level: str, module: str, what: str) -> None:
        """Refuse (exit 1) unless the role has `level` on `module`."""
        needed = ACCESS_LEVELS.index(level)
        if self.level(module) >= needed:
            return
        able = [r for r, levels in self.roles.items() if levels.get(module, 0) >= needed]
        who = f"roles that may: {', '.join(able)}" if able else "no role may"
        if self.role is None:
            has = f"no --role was given, so this console only monitors ({who})"
        else:
            has = f"role {self.role} may only {ACCESS_LEVELS[self.level(module)]} {module} ({who})"
        raise CtlError(f"refused: {what} needs {level} on {module}; {has}")

    def matrix(self, modules: Sequence[str]) -> list[str]:
        """The access matrix as text: a row per module, a column per role."""
        roles = list(self.roles)
        width = max([6, *(len(r) for r in roles)]) + 2
        lines = ["module".ljust(8) + "".join(r.ljust(width) for r in roles)]
        for module in modules:
            cells = [ACCESS_LEVELS[self.roles[r].get(module, 0)].ljust(width) for r in roles]
            lines.append((module.ljust(8) + "".join(cells)).rstrip())
        return lines


def holder_problem(layout: ModuleType, role: str) -> str:
    """'' when this process's user may act in `role`: the role names no holders, or the
    user is one of its `users` or in one of its `groups` (the process's real, effective and
    supplementary groups, as `id` lists them); else why not, in one line. The OS decides
    who a user is: this keeps an honest operator to their role, it does not stop one who
    can write the segment (docs/access.md)."""
    holders = getattr(layout, "ROLE_HOLDERS", {}).get(role)
    if holders is None:
        return ""
    users, groups = holders
    me = user_name(os.geteuid())
    mine = sorted({group_name(g) for g in {os.getgid(), os.getegid(), *os.getgroups()}})
    if me in users or set(groups) & set(mine):
        return ""
    held = " and ".join(
        part
        for part in (
            listed("user", users) if users else "",
            f"members of {', '.join(groups)}" if groups else "",
        )
        if part
    )
    return (
        f"role {role} of {layout.SYSTEM} is held by {held}; you are {me} (groups {', '.join(mine)})"
    )


# ---------------------------------------------------------------- the console


def writers_home(layout: ModuleType) -> dict[str, frozenset[str]]:
    """Each world field written by modules of known processes -> those processes (a
    stand-in counted where its controller runs); what `Console.stale` looks at."""
    placement = dict(getattr(layout, "PLACEMENT", {}))
    for module, stand_in in getattr(layout, "STAND_INS", {}).items():
        placement.setdefault(stand_in, placement.get(module, ""))  # (runs in its place)
    found = {}
    for field, writers in getattr(layout, "WORLD_WRITERS", {}).items():
        homes = frozenset(str(placement.get(module, "")) for module in writers)
        if homes and "" not in homes:  # (else written where no process is said)
            found[field] = homes
    return found


class Console:
    """A running system's segment, read and written as an operator does."""

    def __init__(
        self,
        layout: ModuleType,
        segment: str,
        role: str | None = None,
        connect: Sequence[str] = (),
    ) -> None:
        self.layout = layout
        self.segment = f"zenoh {' '.join(connect)}" if connect else segment
        self.access = Access(layout, role)  # before attaching: a bad role is a usage error
        # With `connect`: a private block kept current over Zenoh (zenoh_transport.Attached)
        self.attached = attach(layout, connect)
        self.block = self.attached.block if self.attached else Block(layout, segment, False)
        self.buf = self.block.buf
        self.supervisor = {
            sub: boss
            for boss in layout.MODULES
            for sub in layout.SUBORDINATES.get(boss, ())
            if sub in layout.COMMAND_IN
        }
        self.writers_home = writers_home(layout)

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
            pace = self.read(pacing[name]) if name in pacing else {}
            slow = max(1.0, float(pace.get("slow", 0.0)))  # a slowed process beats less often
            timeout = self.layout.HEARTBEAT_TIMEOUT * slow
            alive = state == RUNNING and age is not None and age <= timeout
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
                "slow": slow,
                **timing(values),
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
                    k.removeprefix("arg_"): enum_name(layout, name, k, v)
                    for k, v in command.items()
                    if k.startswith("arg_")
                }
            if status:
                row["status"] = _name(STATUS_NAMES, int(status["status"]))
                row["status_num"] = status["status_num"]
                row["error_num"] = status["error_num"]
                reason = reason_name(layout, name, row["status"], int(status["error_num"]))
                if reason is not None:  # a module that declares reasons
                    row["reason"] = reason
                cause = cause_text(layout, int(status.get("cause", 0)))
                if cause and row["status"] == "ERROR":  # what its ERROR was passed up from
                    row["cause"] = cause
                row["state"] = _name(layout.STATE_NAMES[runs], int(status["state"]))
                results = result_values(layout, name, status)
                if results:
                    row["results"] = results
                plans = plan_slots(status)
                if plans:  # a module with plans: where its executor is in each
                    row["plans"] = plans
                rule = _name(layout.RULES[runs], int(status["rule"]))
                row["rule"] = rule or None
            if mode:
                row["run"] = "STOP" if mode["dont_run"] else "RUN"
                row["step"] = "SINGLE" if mode["single_step"] else "AUTO"
                row["sim"] = "SIMU" if mode["simulate"] else "REAL"
            row.update(self.time_in_state(runs, proc))
            if perf:
                for key in ("last", "min", "max"):
                    row[f"{key}_cycle_us"] = round(int(perf[f"{key}_cycle_ns"]) / 1000, 1)
                row["cycles"] = perf["cycles"]
                row["stale_reads"] = perf["stale_reads"]
            row["heartbeat_age_s"] = proc.get("heartbeat_age_s")
            row["alive"] = bool(proc.get("alive"))
            row["supervisor"] = self.supervisor.get(name)
            rows[name] = row
        for name, row in list(rows.items()):
            if row["runs"] != name:  # its stand-in runs in place of its subtree in its process
                for sub in self._subtree(name):
                    if layout.PLACEMENT.get(sub) == row["process"]:
                        rows[sub]["runs"] = None
                        rows[sub]["skipped_by"] = name
        return rows

    def _subtree(self, name: str) -> list[str]:
        found, todo = [], list(self.layout.SUBORDINATES.get(name, ()))
        while todo:
            sub = todo.pop(0)
            if sub in self.layout.COMMAND_IN and sub not in found:
                found.append(sub)
                todo += self.layout.SUBORDINATES.get(sub, ())
        return found

    def time_in_state(self, runs: str, process: dict[str, Any]) -> dict[str, Any]:
        """The share of its cycles a controller (or the stand-in running in its place) has
        spent in each state since start, in percent (rcs/state_time.py; `process`: its
        process's control record, whose heartbeat closes the open interval), and how many
        cycles were counted; {} for a module that has no clock."""
        record = getattr(self.layout, "TIME_IN_STATE", {}).get(runs)
        values = self.read(record) if record is not None else {}
        if not values:
            return {}
        counts = totals(values, int(process.get("heartbeat") or 0))
        return {"state_cycles": sum(counts.values()), "time_in_state": shares(counts)}

    def snapshot(self, world: Sequence[str] | None = None) -> dict[str, Any]:
        """Everything the console shows, as plain data: the processes, every module's line,
        the open requests and the world fields (`world`: those named, else all)."""
        processes, devices = self.processes(), self.devices()
        return {
            "system": self.layout.SYSTEM,
            "segment": self.segment,
            "layout_hash": self.layout.LAYOUT_HASH,
            "role": self.access.role,
            "processes": processes,
            "modules": self.modules(processes),
            "requests": self.requests(),
            "world": self.world(world),
            "overrides": self.overrides(),
            "io": devices,
            "stale": self.stale(processes, devices),
        }

    def stale(
        self, processes: dict[str, dict[str, Any]], devices: dict[str, dict[str, Any]]
    ) -> dict[str, str]:
        """The world fields whose values nobody keeps current, and why: the I/O device that
        feeds one is lost (its name), or every module that writes one runs in a process
        that is not running (`pc2 lost`, `pc2 stopped`): the value is the last one written."""
        found = {f: name for name, device in devices.items() for f in device.get("stale", ())}
        for field, homes in self.writers_home.items():
            if field in found:
                continue  # (a device's input)
            down = sorted(p for p in homes if not processes.get(p, {}).get("alive"))
            if len(down) == len(homes):
                state = str(processes.get(down[0], {}).get("state", "?"))
                found[field] = f"{down[0]} {'lost' if state == 'RUNNING' else state.lower()}"
        return found

    def devices(self) -> dict[str, dict[str, Any]]:
        """Each fieldbus device's state, counts and stale inputs (rcs/io_points.py); {} for
        a system that declares none."""
        now = time.monotonic_ns()
        records = getattr(self.layout, "IO_RECORDS", {})
        return {
            name: device_status(device, self.read(records[name]), now)
            for name, device in getattr(self.layout, "IO_DEVICES", {}).items()
        }

    def world_names(self, names: Sequence[str]) -> list[str]:
        """`names` checked against the world fields (usage error with a did-you-mean)."""
        for name in names:
            if name not in self.layout.WORLD:
                raise usage(suggest(name, list(self.layout.WORLD), "world field"))
        return list(names)

    def world(self, names: Sequence[str] | None = None) -> dict[str, Any]:
        """The world fields now (those named, else every one, in the layout's order), an
        enumeration's by value name; None for a field that stayed unreadable (stale)."""
        found: dict[str, Any] = {}
        for name in self.world_names(names) if names is not None else self.layout.WORLD:
            values = self.read(self.layout.WORLD[name])
            found[name] = enum_name(self.layout, "", name, values[name]) if values else None
        return found

    # ------------------------------------------------------------ requests

    def requests(self) -> list[dict[str, Any]]:
        """The requests modules are making of the operator now: those world fields hold
        open (`operators.requests`), then those open on operator modules' channels."""
        found = self.field_requests()
        for _ in range(20):  # a channel being written shows after a moment
            try:
                return found + channel_requests(self.layout, self.buf)
            except StaleRead:
                time.sleep(0.0005)
        return found

    def field_requests(self) -> list[dict[str, Any]]:
        """The requests open while a world field is true (`operators.requests`)."""
        found = []
        for name, request in getattr(self.layout, "REQUESTS", {}).items():
            value = self.read(self.layout.WORLD[request["while"]]).get(request["while"])
            if value:
                module, command = request["answer"]
                found.append(
                    {
                        "name": name,
                        "by": request["by"],
                        "doc": request["doc"],
                        "answer": f"{module}.{command}",
                    }
                )
        return found

    def answer_channel(
        self,
        name: str,
        status: str = "DONE",
        reason: str = "",
        results: Mapping[str, object] | None = None,
    ) -> dict[str, Any]:
        """Answer the request open on channel `name` (`op/fx`; the role must respond to the
        operator module): DONE with the results its task records (as typed, `NAME=VALUE`),
        or ERROR with a reason. The request answered."""
        operator = name.split("/")[0]
        self.access.require("respond", operator, f"answering {name}")
        request = next(
            (r for r in channel_requests(self.layout, self.buf) if r["name"] == name), None
        )
        if request is None:
            client = name.split("/", 1)[1]
            raise CtlError(f"{client} is asking nothing of {operator} now; nothing to answer")
        try:
            write_answer(self.layout, self.buf, request, status, reason, results)
        except ValueError as error:
            raise usage(str(error)) from None
        return request

    def answer(self, name: str) -> tuple[Command, int]:
        """Answer request `name` (the role must respond to its module): send its answer
        command; the command sent and its number."""
        requests = getattr(self.layout, "REQUESTS", {})
        if name not in requests:
            raise usage(suggest(name, request_names(self.layout), "request"))
        request = requests[name]
        self.access.require("respond", request["by"], f"answering {name}")
        if not any(r["name"] == name for r in self.field_requests()):
            raise CtlError(f"{request['by']} is not asking for {name} now; nothing to answer")
        module, command = request["answer"]
        sent = check_command(self.layout, module, command, {})
        return sent, self._write(sent)

    # ------------------------------------------------------------ modes

    def set_mode(self, module: str, **mode: object) -> None:
        """Write `module`'s mode buffer: manual override, so the role must override it."""
        self.access.require("override", self.module(module), f"changing {module}'s mode")
        self.layout.MODE_IN[module].write(self.buf, **mode)

    def step(self, module: str, count: int = 1, timeout: float = 10.0) -> int:
        """Single-step `module` `count` cycles, each one seen run; the cycles it stepped."""
        self.access.require("override", self.module(module), f"stepping {module}")
        record, perf = self.layout.MODE_IN[module], self.layout.PERFORMANCE[module]
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

    # ------------------------------------------------------------ the world, forced

    def field(self, name: str) -> str:
        """`world.X` (or `X`) as a world field's name; a usage error naming the fields."""
        field = name.removeprefix("world.")
        if field not in self.layout.WORLD:
            raise usage(suggest(field, list(self.layout.WORLD), "world field"))
        return field

    def _forcible(self, field: str, what: str) -> None:
        """Refuse (exit 1) unless this console may force `field`: through the segment, by a
        role with override on every module that writes it (on every module, for a field no
        module writes), and for the simulation's truth only while its writers simulate."""
        if self.attached is not None:
            raise CtlError(f"{what} writes the segment: run ctl on the host that runs the system")
        writers = [self._controller_of(w) for w in self.layout.WORLD_WRITERS.get(field, ())]
        for module in dict.fromkeys(writers or self.layout.MODE_IN):
            self.access.require("override", module, what)
        if field in self.layout.GROUND_TRUTH:  # (one no module writes is the run's input)
            # a stand-in is a simulator whenever it runs (and writes nothing while its
            # controller runs real): only a module whose simulate flag is off is real
            stand_ins = set(getattr(self.layout, "STAND_INS", {}).values())
            real = [
                m
                for m in self.layout.WORLD_WRITERS.get(field, ())
                if m not in stand_ins and not self.read(self.layout.MODE_IN[m]).get("simulate")
            ]
            if real:
                raise CtlError(
                    f"refused: {field} is ground truth (the world itself, which no operator can "
                    f"force) and {', '.join(real)} writing it run real, not simulated"
                )

    def _controller_of(self, module: str) -> str:
        """A stand-in's controller (whose mode says whether it runs), else the module."""
        stand_ins = {s: c for c, s in getattr(self.layout, "STAND_INS", {}).items()}
        return str(stand_ins.get(module, module))

    def force(self, field: str, raw: str) -> object:
        """Force world field `field` (`world.X`) to the value `raw` says, PLC style: the
        module that writes it writes the forced value until `unforce`. The value forced."""
        field = self.field(field)
        code = self.layout.WORLD[field].codes()[field]
        names = getattr(self.layout, "ENUMS", {}).get(("", field), ())
        try:
            value = parse_value(raw, code, names)
        except ValueError as error:
            raise usage(f"world.{field} {error}") from None
        self._forcible(field, f"forcing world.{field}")
        try:
            override.force(self.layout, self.buf, field, value, self.segment)
        except override.OverrideError as error:
            raise CtlError(f"refused: {error}") from None
        return value

    def unforce(self, field: str) -> None:
        """Release the force on `field`: its module writes it again from its next cycle."""
        field = self.field(field)
        self._forcible(field, f"releasing world.{field}")
        try:
            override.unforce(self.layout, self.buf, field, self.segment)
        except override.OverrideError as error:
            raise CtlError(f"refused: {error}") from None

    def reset(self, fields: Sequence[str]) -> list[str]:
        """Release the SAFE latches of `fields` (every latched field when none is named): the
        explicit reset after a latched stop. The fields released."""
        names = [self.field(f) for f in fields] or list(self.overrides())
        for field in names:
            self._forcible(field, f"resetting world.{field}")
        try:
            return override.reset(self.layout, self.buf, names, self.segment)
        except override.OverrideError as error:
            raise CtlError(f"refused: {error}") from None

    def overrides(self) -> dict[str, dict[str, Any]]:
        """The world fields under an override now: field -> its state (FORCED or SAFE) and
        value, an enumeration's by name."""
        if not hasattr(self.layout, "OVERRIDE"):
            return {}
        found = override.overrides(self.layout, self.buf)
        return {
            field: {"state": state, "value": enum_name(self.layout, "", field, value)}
            for field, (state, value) in found.items()
        }

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
        for module in self.layout.MODULES:  # a slower process slows every module in it
            if self.layout.PLACEMENT.get(module) in names:
                self.access.require("override", module, "slowing the system down")
        for name in names:
            pacing[name].write(self.buf, slow=factor)
        return names

    # ------------------------------------------------------------ commands

    def send(self, command: Command, override: bool = False) -> tuple[int, list[str]]:
        """Write `command` to its module's command buffer, numbered after the last one; the
        number and what the operator should know (a supervisor put in manual override)."""
        notes = []
        boss = self.supervisor.get(command.module)
        if boss is None:
            self.access.require("command", command.module, f"commanding {command.module}")
        else:
            if not override:
                raise CtlError(
                    f"{command.module} is commanded by {boss}: its next command would replace "
                    f"yours; use --override to put {boss} in manual override (STOP) first"
                )
            what = f"commanding {command.module} out of {boss}'s turn"
            self.access.require("override", command.module, what)
            self.access.require("override", boss, what)
            self.set_mode(boss, dont_run=True)
            notes.append(
                f"{boss} is in manual override (STOP): it sends nothing until "
                f"`ctl run {boss}`, whose next command to {command.module} replaces this one"
            )
        return self._write(command), notes

    def _write(self, command: Command) -> int:
        """Write a checked `command` through the one writer (rcs/operate/command.py); its number."""
        try:
            return write_command(self.layout, self.buf, command)
        except StaleRead:
            raise CtlError(f"{command.module}'s command buffer cannot be read whole") from None

    def seen(self, module: str, number: int) -> bool:
        """Whether `module` has echoed command `number` (its status number caught up)."""
        return int(self.read(self.layout.STATUS_OUT[module]).get("status_num", -1)) >= number

    def outcome(self, module: str, number: int | None = None) -> tuple[str, str] | None:
        """DONE or ERROR once `module` reported on the command in its buffer (or command
        `number`), with that command as `NAME #number` from the same read (a later command
        written meanwhile is not shown as the one that ended); else None. CtlError when
        `number` was replaced before it finished."""
        command = self.read(self.layout.COMMAND_IN[module])
        status = self.read(self.layout.STATUS_OUT[module])
        try:
            result = outcome(command, status, number)
        except ValueError as replaced:
            raise CtlError(f"{module}'s {replaced}") from None
        if result is None:
            return None
        name = _name(self.layout.COMMAND_NAMES[module], int(command["command"]))
        return result, f"{name} #{command['command_num']}"


def request_names(layout: ModuleType) -> list[str]:
    """What `ctl answer` accepts: the world-field requests, then the operator channels."""
    return [*getattr(layout, "REQUESTS", {}), *getattr(layout, "ANSWERS", {})]


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
    "module",
    "command",
    "#",
    "status",
    "#",
    "state",
    "rule",
    "mode",
    "cycle us last/min/max",
    "beat",
)


def columns(rows: Sequence[Sequence[str]]) -> list[str]:
    """Rows of cells as lines, each column as wide as its widest cell: a long value widens
    its column, it never pushes the cells after it out of line nor is it cut."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in rows
    ]


def render(snapshot: dict[str, Any]) -> list[str]:
    """The debug screen as text: one line per module, then one per process."""
    lines = [f"{snapshot['system']} on {snapshot['segment']}"]
    rows: list[Sequence[str]] = [COLUMNS]
    for name, row in snapshot["modules"].items():
        mode = f"{row.get('run', '?')} {row.get('step', '?')} {row.get('sim', '?')}"
        if row.get("skipped_by"):
            mode = f"skipped: {row['skipped_by']} SIMU"
        times = "/".join(str(row.get(f"{k}_cycle_us", "?")) for k in ("last", "min", "max"))
        age = row.get("heartbeat_age_s")
        beat = "dead" if not row.get("alive") else f"{age:.2f}s"
        rows.append(
            [
                name,
                str(row.get("command", "?")),
                str(row.get("command_num", "?")),
                status_text(str(row.get("status", "?")), row.get("reason"), row.get("cause", "")),
                str(row.get("status_num", "?")),
                str(row.get("state", "?")),
                str(row.get("rule") or "-"),
                mode,
                times,
                beat,
            ]
        )
    lines += columns(rows)
    for name, row in snapshot["modules"].items():
        if row.get("results"):
            values = ", ".join(f"{k} {shown(v)}" for k, v in row["results"].items())
            lines.append(f"results {name}: {values}")
        for plan, at in (row.get("plans") or {}).items():
            lines.append(
                f"plan {name}.{plan}: step {at['step']} of {at['steps']}, "
                f"{at['replans_left']} replans left"
            )
    lines += state_time_lines(snapshot)
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
    lines += periodicity_lines(snapshot)
    lines += network_lines(snapshot)
    for name, device in (snapshot.get("io") or {}).items():
        lines.append(device_line(name, device))
    for request in snapshot.get("requests", ()):
        lines.append(f"request {request['name']} from {request['by']}: {request['doc']}")
    return lines + world_lines(snapshot)


def state_time_lines(snapshot: dict[str, Any]) -> list[str]:
    """Time per state (the paper's % of execution time per state): for each controller that
    has run, the share of its cycles since start spent in each state it has been in."""
    lines = []
    for name, row in snapshot["modules"].items():
        shares = row.get("time_in_state")
        if shares:
            spent = ", ".join(f"{state} {share:g}%" for state, share in shares.items())
            lines.append(f"time in state {name} ({row['state_cycles']} cycles): {spent}")
    return lines


# ---------------------------------------------------------------- periodicity


def timing(values: dict[str, Any]) -> dict[str, Any]:
    """A control record's timing for the console: the process's cycle time (last, max)
    and how well it holds its period (contract.periodicity: None when not paced)."""
    return {
        "last_cycle_us": round(int(values["last_cycle_ns"]) / 1e3, 1),
        "max_cycle_us": round(int(values["max_cycle_ns"]) / 1e3, 1),
        "periodicity": periodicity(values),
        # what it received over the network (Zenoh): all 0 on shared memory
        "network": {k.removeprefix("net_"): int(values[k]) for k in NETWORK_NAMES},
    }


NETWORK_NAMES = field_names(NETWORK_FIELDS)


def network_lines(snapshot: dict[str, Any]) -> list[str]:
    """Per process on the network, what it did with the records its peers sent: applied,
    dropped as late or out of order, refused as malformed (its log names the peer)."""
    lines = []
    for name, proc in snapshot["processes"].items():
        line = network_line(name, proc.get("network") or {})
        if line is not None:
            lines.append(f"network {line}")
    return lines


def slowest_modules(modules: dict[str, dict[str, Any]]) -> dict[str, tuple[str, float]]:
    """Per process, its module with the longest cycle so far, and that cycle (µs)."""
    slowest: dict[str, tuple[str, float]] = {}
    for module, row in modules.items():
        took, process = row.get("max_cycle_us"), str(row.get("process", ""))
        if took is not None and took >= slowest.get(process, ("", -1.0))[1]:
            slowest[process] = (module, float(took))
    return slowest


def periodicity_lines(snapshot: dict[str, Any]) -> list[str]:
    """The debug screen's periodicity section: per process its period error, wake-up
    lateness and throttled warnings (or that it is not paced), its cycle time, and the
    execution time of its slowest module (each module's own is in the table above)."""
    slowest = slowest_modules(snapshot["modules"])
    lines = []
    for name, proc in snapshot["processes"].items():
        if proc.get("state") == "?":
            continue
        line = f"periodicity {periodicity_line(name, proc.get('periodicity'))}"
        line += f"; cycle last {proc['last_cycle_us']:g} µs, max {proc['max_cycle_us']:g} µs"
        if name in slowest:
            module, took = slowest[name]
            line += f"; slowest module {module} (max {took:g} µs)"
        lines.append(line)
    return lines


def world_lines(snapshot: dict[str, Any]) -> list[str]:
    """The world table (`status --world`): each field's value, marked stale while nothing
    keeps it current (`Console.stale`: its I/O device or its writers' process lost), and its
    override; then the overrides not in the table."""
    world = snapshot.get("world") or {}
    held = snapshot.get("overrides") or {}
    stale = snapshot.get("stale") or {}
    lines: list[str] = []
    if world:
        fields: list[Sequence[str]] = [("world", "value", "override")]
        for name, v in world.items():
            value = "stale" if v is None else shown(v)
            if name in stale:
                value += f" (stale: {stale[name]})"
            fields.append((name, value, held.get(name, {}).get("state", "")))
        lines += columns(fields)
    for name, how in held.items():
        if name not in world:
            lines.append(f"world.{name} {how['state']} at {shown(how['value'])}")
    return lines


def device_line(name: str, device: dict[str, Any]) -> str:
    """One fieldbus device's line of the debug screen."""
    if device.get("state") == "?":
        return f"io {name}: record unreadable"
    age, trip = device["last_answer_age_s"], device["round_trip_ms"]
    heard = "never answered" if age is None else f"answered {age:.2f}s ago in {trip:g} ms"
    counts = ", ".join(f"{device[c]} {c}" for c in ("reads", "writes", "timeouts", "retries"))
    more = ", ".join(f"{device[c]} {c}" for c in ("errors", "reconnects", "losses"))
    line = (
        f"io {name}: {device['state'].lower()}, {device['protocol']} {device['address']} "
        f"(run by {device['process']}), {heard}; {counts}; {more}"
    )
    if device["stale"]:
        line += f"; stale: {', '.join(device['stale'])}"
    return line


# ---------------------------------------------------------------- command line


def number(
    kind: type[int | float], low: float, high: float, above: bool = False
) -> Callable[[str], Any]:
    """An argparse type for a numeric option: a whole number (`int`) or a finite number
    (`float`) from `low` (excluded with `above`) to `high`; anything else (`nan`, `inf`,
    `-1`, `1e999`, `ten`) is a usage error naming the range."""
    code = "q" if kind is int else "d"
    lower = f"more than {_plain(low)}" if above else f"at least {_plain(low)}"
    words = f"{'a whole number' if kind is int else 'a number'} {lower} and at most {_plain(high)}"

    def parse(raw: str) -> Any:
        try:
            value = parse_value(raw, code)
        except ValueError:
            value = None
        if not isinstance(value, int | float) or not (
            (value > low if above else value >= low) and value <= high
        ):
            raise argparse.ArgumentTypeError(f"{raw!r} is not {words}")
        return kind(value)

    parse.__name__ = words
    return parse


def _plain(value: float) -> str:
    """1000000, not 1e+06; 0.01 as it is."""
    return str(int(value)) if value == int(value) else f"{value:g}"


class _Parser(argparse.ArgumentParser):
    """argparse, but a mistake is one line and exit 2."""

    def error(self, message: str) -> NoReturn:
        raise usage(message)


def parser(package: str, layout: ModuleType) -> argparse.ArgumentParser:
    default = default_segment(layout)
    top = _Parser(
        prog=f"python -m {package} ctl",
        description=f"Operate a running {layout.SYSTEM} system through its segment.",
    )
    top.add_argument("--shm", default=default, help=f"the segment [default: {default}]")
    role = os.environ.get("RCS_ROLE") or None
    top.add_argument(
        "--role",
        default=role,
        help=f"the operator role whose access levels apply [default: $RCS_ROLE: {role}]",
    )
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
    status.add_argument(
        "--interval",
        type=number(float, 0.01, 3600),
        default=0.5,
        help="seconds between refreshes (0.01 to 3600)",
    )
    status.add_argument("--format", choices=("text", "json"), default="text")
    status.add_argument(
        "--world",
        nargs="?",
        const="",
        default=None,
        metavar="FIELD,...",
        help="also the world fields now: every one, or those named (JSON has them all anyway)",
    )
    for verb, text in (("stop", "hold MODULE's table (STOP)"), ("run", "RUN and AUTO again")):
        verbs.add_parser(verb, help=text).add_argument("module")
    step = verbs.add_parser("step", help="single-step MODULE N cycles (SINGLE)")
    step.add_argument("module")
    step.add_argument("count", nargs="?", type=number(int, 1, MAX_STEPS), default=1)
    step.add_argument(
        "--timeout",
        type=number(float, 0, MAX_WAIT, above=True),
        default=10.0,
        help="seconds per step",
    )
    simulate = verbs.add_parser("simulate", help="run MODULE's stand-in in its place, or not")
    simulate.add_argument("module")
    simulate.add_argument("switch", choices=("on", "off"))
    slow = verbs.add_parser("slow", help="stretch the cycle periods by FACTOR (1: normal)")
    slow.add_argument("factor", type=number(float, 1, MAX_SLOW))
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
    requests = verbs.add_parser("requests", help="what the modules are asking the operator")
    requests.add_argument("--format", choices=("text", "json"), default="text")
    answer = verbs.add_parser(
        "answer",
        help="answer REQUEST: a channel's (op/fx) DONE or ERROR [--reason R], or a world "
        "field's request by sending its answer command",
    )
    answer.add_argument("request")
    answer.add_argument("status", nargs="?", default=None, help="DONE (default) or ERROR")
    answer.add_argument(
        "results",
        nargs="*",
        metavar="NAME=VALUE",
        help="with DONE: what the person records, each result of the task (`ctl requests`)",
    )
    answer.add_argument("--reason", default="", help="with ERROR: why (one of the task's reasons)")
    force = verbs.add_parser(
        "force",
        help="force a world field to a value (world.X=V): its writer keeps it until `unforce`",
    )
    force.add_argument("assignment", metavar="world.FIELD=VALUE")
    unforce = verbs.add_parser("unforce", help="release a forced world field (world.X)")
    unforce.add_argument("field", metavar="world.FIELD")
    reset = verbs.add_parser(
        "reset", help="release world fields latched at their safe value (all when none named)"
    )
    reset.add_argument("fields", nargs="*", metavar="world.FIELD")
    verbs.add_parser("roles", help="the access matrix: what each role may do to each module")
    for sub in verbs.choices.values():  # `ctl send ... --role crew` reads as well
        sub.add_argument("--role", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    wait = verbs.add_parser("wait", help="wait until MODULE reports DONE or ERROR")
    wait.add_argument("module")
    wait.add_argument("outcome", choices=FINISHED)
    wait.add_argument(
        "--timeout",
        type=number(float, 0, MAX_WAIT),
        default=None,
        help="give up after this many seconds (exit 1) [default: wait for ever]",
    )
    wait.add_argument(
        "--number",
        type=number(int, 1, 2**64 - 1),
        default=None,
        help="the outcome of this command number (as `send` printed it), not the latest",
    )
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
    except BrokenPipeError:  # `ctl status | head`: the reader has gone, which is no error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so that the flush at exit does not fail again
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
    requests = getattr(layout, "REQUESTS", {})
    channels = getattr(layout, "ANSWERS", {})
    if args.verb == "answer" and args.request not in [*requests, *channels]:
        raise usage(suggest(args.request, request_names(layout), "request"))
    if args.verb == "answer":
        _answer_arguments(args)
    if (
        args.verb == "answer"
        and args.request in requests
        and (args.status or args.reason or args.results)
    ):
        raise usage(
            f"{args.request} is answered by its command alone: no DONE/ERROR/--reason/results"
        )
    if args.verb == "roles":  # from the layout alone: no running system needed
        access = Access(layout, args.role)
        if not access.roles:
            print(f"{layout.SYSTEM} declares no operator roles: every operator may do everything")
        else:
            print("\n".join(access.matrix(layout.MODULES)))
        return 0
    if not args.connect and segment_problem(args.shm):
        raise usage(segment_problem(args.shm))
    try:
        console = Console(layout, args.shm, args.role, args.connect)
    except (BlockError, TransportError, ValueError) as error:
        raise CtlError(str(error)) from None
    try:
        return _verb(console, args, command)
    finally:
        console.close()


def _answer_arguments(args: argparse.Namespace) -> None:
    """`answer REQUEST [DONE|ERROR] [NAME=VALUE ...]`: a first word with `=` is a result
    (DONE left out); any other status word is refused. Each result once."""
    if args.status is not None and "=" in args.status:
        args.results, args.status = [args.status, *args.results], None
    if args.status is not None and args.status not in FINISHED:
        raise usage(f"answer: {args.status!r} is neither DONE nor ERROR nor NAME=VALUE")
    given: dict[str, str] = {}
    for item in args.results:
        name, equals, raw = item.partition("=")
        if not equals or not name:
            raise usage(f"answer: {item!r} is not NAME=VALUE")
        if name in given:
            raise usage(f"answer: result {name} is given twice")
        given[name] = raw
    args.results = given


def attach(layout: ModuleType, endpoints: Sequence[str]) -> Any:
    """With `--connect`: a private block that mirrors the system over Zenoh (else None)."""
    if not endpoints:
        return None
    from ..zenoh_transport import Attached, Options

    return Attached(layout, Options(connect=tuple(check_endpoint(e) for e in endpoints)))


def _verb(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    """Run one checked verb on the console; its exit code."""
    return _VERBS[args.verb](console, args, command)


def _verb_status(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    named = [n for n in (args.world or "").split(",") if n] or None
    if named is not None:
        console.world_names(named)  # a misspelt field: one line, exit 2
    while True:
        snapshot = console.snapshot(named)
        if args.format == "json":
            text = json.dumps(snapshot, indent=2)
        else:
            view = snapshot if args.world is not None else {**snapshot, "world": {}}
            text = "\n".join(render(view))
        if not args.watch:
            print(text)
            return 0
        print("\x1b[H\x1b[2J" + text, flush=True)
        time.sleep(args.interval)


def _verb_stop(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    console.set_mode(args.module, dont_run=True)
    print(f"{args.module}: STOP")
    return 0


def _verb_run(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    console.set_mode(args.module, dont_run=False, single_step=False)
    print(f"{args.module}: RUN AUTO")
    return 0


def _verb_step(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    console.step(args.module, args.count, args.timeout)
    row = console.modules()[args.module]
    print(
        f"{args.module}: stepped {counted(args.count, 'cycle')}, SINGLE: state {row.get('state')}, "
        f"rule {row.get('rule') or '-'}; `run {args.module}` goes back to AUTO"
    )
    return 0


def _verb_simulate(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    console.simulate(args.module, args.switch == "on")
    print(f"{args.module}: {'SIMU' if args.switch == 'on' else 'REAL'}")
    return 0


def _verb_slow(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    names = console.slow(args.factor, args.process)
    print(f"slow x{args.factor:g}: {', '.join(names)}")
    return 0


def _verb_send(console: Console, args: argparse.Namespace, command: Command | None) -> int:
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
    return 0


def _verb_requests(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    found = console.requests()
    if args.format == "json":
        print(json.dumps(found, indent=2))
        return 0
    if not found:
        print("no requests")
    for request in found:
        task = f"{request['task']} #{request['number']}: " if "task" in request else ""
        print(f"{request['name']} from {request['by']}: {task}{request['doc']}")
        if request.get("results"):  # what a DONE answer gives
            forms = " ".join(f"{k}={v}" for k, v in request["results"].items())
            print(f"  answer: DONE {forms}")
    return 0


def _verb_answer(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    if args.request in getattr(console.layout, "ANSWERS", {}):  # an operator module's channel
        status = args.status or "DONE"
        request = console.answer_channel(args.request, status, args.reason, args.results)
        why = f" ({args.reason})" if args.reason else ""
        given = "".join(f" {k}={v}" for k, v in args.results.items())
        print(
            f"answered {args.request}: {request['task']} #{request['number']} {status}{why}{given}"
        )
        return 0
    sent, number = console.answer(args.request)
    print(f"answered {args.request}: sent {sent} #{number}")
    return 0


def _verb_force(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    field, equals, raw = args.assignment.partition("=")
    if not equals:
        raise usage(f"force: {args.assignment!r} is not world.FIELD=VALUE")
    value = console.force(field, raw)
    name = console.field(field)
    print(f"world.{name} FORCED at {shown(value)}; `ctl unforce world.{name}` releases it")
    return 0


def _verb_unforce(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    console.unforce(args.field)
    print(f"world.{console.field(args.field)} released: its module writes it again")
    return 0


def _verb_reset(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    released = console.reset(args.fields)
    print(f"released: {', '.join(released)}" if released else "nothing was latched safe")
    return 0


def _verb_wait(console: Console, args: argparse.Namespace, command: Command | None) -> int:
    module, number = args.module, args.number
    ended: list[tuple[str, str]] = []  # the outcome and its command, read together

    def finished() -> bool:
        found = console.outcome(module, number)
        ended.extend([found] if found else [])
        return found is not None

    if not _until(finished, args.timeout):
        raise CtlError(f"{module} did not finish within {args.timeout:g} s")
    result, which = ended[-1]
    print(f"{module} {result} {which}")
    return 0 if result == args.outcome else FAILED


_VERBS: dict[str, Callable[[Console, argparse.Namespace, Command | None], int]] = {
    "status": _verb_status,
    "stop": _verb_stop,
    "run": _verb_run,
    "step": _verb_step,
    "simulate": _verb_simulate,
    "slow": _verb_slow,
    "send": _verb_send,
    "requests": _verb_requests,
    "answer": _verb_answer,
    "force": _verb_force,
    "unforce": _verb_unforce,
    "reset": _verb_reset,
    "wait": _verb_wait,
}
