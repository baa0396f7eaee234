"""The scenario runner's own logic (rcsgen/tools/scenario/run.py), in the unit tier, on a
stand-in harness that counts cycles and answers as a module would (the generated systems
run in the system tier's scenarios and goldens): an event happens before the cycle it names,
the run stops when the stop module finishes its command (not before the last event, not
after max_cycles), the phases are counted by command, every module's final status is kept
(an operator's channel once), and a device fault that takes a device down is watched against
its bounds: the device lost within its timeout + 1 cycle, then the devices still up holding
the safe values within their poll + 1 cycle more."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from rcsgen.compiler.diagnostics import Span
from rcsgen.tools.harness import Sent, Status
from rcsgen.tools.scenario.model import (
    DeviceFault,
    Event,
    OperatorScript,
    Scenario,
    ScriptedAnswer,
    SoftPlc,
)

# the module, not the function `rcsgen.tools.scenario.run` the package exports
runner = importlib.import_module("rcsgen.tools.scenario.run")
AT = Span("s.yaml", 9, 7)


class World:
    def __init__(self) -> None:
        self.values: dict[str, Any] = {"depth": 1.5}

    def update(self, values: dict[str, Any]) -> None:
        self.values.update(values)

    def snapshot(self, names: list[str]) -> dict[str, Any]:
        return {n: self.values[n] for n in names}

    def overrides(self) -> dict[str, str]:
        return {}


class Module:
    """A module that takes `takes` cycles to finish a command (DONE), RUN by default."""

    def __init__(self, takes: int) -> None:
        self.takes = takes
        self.sent = Sent("INIT", 1, {})
        self.status = Status("DONE", 1, "S0", 0)
        self.left = 0

    def cycle(self) -> None:
        if self.status.number != self.sent.number:  # a new command: taken up
            self.status = Status("EXECUTING", self.sent.number, "S1", 0)
            self.left = self.takes
        elif self.status.status == "EXECUTING":
            self.left -= 1
            if self.left <= 0:
                self.status = Status("DONE", self.sent.number, "S2", 0, reason="NONE")


class StandInHarness:
    """What run() reads of a harness: cycles, commands sent, statuses, the world."""

    def __init__(self, **takes: int) -> None:
        self.cycles = 0
        self.parts = {name.replace("__", "/"): Module(n) for name, n in takes.items()}
        self.modules = list(self.parts)
        self.world = World()
        self.layout, self.buf = SimpleNamespace(), bytearray()
        self.commands: list[tuple[int, str, str]] = []  # (cycles run before, module, command)

    def command(self, module: str, command: str, **args: Any) -> None:
        self.commands.append((self.cycles, module, command))
        part = self.parts[module]
        part.sent = Sent(command, part.sent.number + 1, args)

    def sent(self, module: str) -> Sent:
        return self.parts[module].sent

    def status(self, module: str) -> Status:
        return self.parts[module].status

    def performance(self, module: str) -> dict[str, int]:
        return {"max_cycle_ns": 1000 + len(module)}

    def cycle(self) -> None:
        self.cycles += 1
        for part in self.parts.values():
            part.cycle()


def scenario(events: list[Event], stop: str | None = "sup", max_cycles: int = 30) -> Scenario:
    made = Scenario("s", "S", Path("s.yaml"), Path("."), None, max_cycles, stop, ["depth"], events)
    made.phases_of = "sup"
    made.figures = ["depth", "sup.reason"]
    return made


def test_an_event_happens_before_the_cycle_it_names_and_the_run_stops_when_its_module_finishes():
    harness = StandInHarness(sup=3, op__fx=1)
    result = runner.run(scenario([Event(4, command=("sup", "RUN"))]), harness)  # type: ignore[arg-type]
    assert harness.commands == [(3, "sup", "RUN")]  # three cycles ran before cycle 4
    # taken up in cycle 4, DONE three cycles later (7): the run stops there
    assert result.cycles == harness.cycles == 7 and len(result.trace) == 7
    assert result.final["status"] == "DONE" and result.final["number"] == 2
    assert result.phase_cycles == Counter({"idle": 4, "RUN": 3})
    assert result.figures == {"depth": 1.5, "sup.reason": "NONE"}
    assert sorted(result.statuses) == ["op/fx", "sup"]
    assert result.max_cycle_ns == {"sup": 1003, "op": 1002}  # an operator module once
    first = json.loads(result.trace[0])
    assert first["cycle"] == 1 and first["world"] == {"depth": 1.5}
    assert first["modules"]["sup"]["command"] == "INIT"


def test_a_run_goes_on_until_its_last_event_and_stops_at_max_cycles():
    # DONE from the start (INIT answered): not a finish while an event is still to come
    harness = StandInHarness(sup=2)
    events = [Event(2, world={"depth": 2.0}), Event(6, command=("sup", "RUN"))]
    result = runner.run(scenario(events), harness)  # type: ignore[arg-type]
    assert harness.commands == [(5, "sup", "RUN")] and result.cycles == 8
    assert json.loads(result.trace[0])["world"] == {"depth": 1.5}
    assert json.loads(result.trace[1])["world"] == {"depth": 2.0}  # before cycle 2
    never = StandInHarness(sup=100)
    result = runner.run(scenario([Event(1, command=("sup", "RUN"))], max_cycles=12), never)  # type: ignore[arg-type]
    assert result.cycles == 12 and result.final["status"] == "EXECUTING"
    unstopped = StandInHarness(sup=1)
    result = runner.run(scenario([], stop=None, max_cycles=5), unstopped)  # type: ignore[arg-type]
    assert result.cycles == 5 and result.final == {}


class Bench:
    """The soft PLCs of a run (what FaultWatch asks of them): what was done to each, and
    what the devices still up do not yet hold."""

    def __init__(self) -> None:
        self.done: list[tuple[str, str]] = []
        self.missing: list[list[str]] = []

    def apply(self, name: str, do: str) -> None:
        self.done.append((name, do))

    def not_safe_on_survivors(self, layout: Any) -> list[str]:
        return self.missing.pop(0) if self.missing else []


def watch(monkeypatch: pytest.MonkeyPatch, checks: list[list[str]]) -> tuple[Any, Any, Bench]:
    """A FaultWatch at a 0.1 s cycle over two devices, plc (timeout 0.25 s, poll 0.15 s)
    and b (1 s, 0.05 s); the block's safe state missing what `checks` says, cycle after
    cycle (then nothing)."""
    device = SimpleNamespace(timeout=0.25, poll_period=0.15)
    other = SimpleNamespace(timeout=1.0, poll_period=0.05)
    harness = SimpleNamespace(
        cycles=0, layout=SimpleNamespace(IO_DEVICES={"plc": device, "b": other})
    )
    monkeypatch.setattr(runner, "cycle_period", lambda harness: 0.1)
    monkeypatch.setattr(runner, "safe_check", lambda harness, name: checks.pop(0) if checks else [])
    bench = Bench()
    return runner.FaultWatch(harness, bench), harness, bench  # type: ignore[arg-type]


def test_a_device_taken_down_is_watched_against_its_two_bounds(monkeypatch):
    fault = DeviceFault("plc", "unplug", AT)
    watcher, harness, bench = watch(monkeypatch, [])
    # plc lost, inputs stale and actuators latched from cycle 8 on; b never
    monkeypatch.setattr(
        runner, "safe_check", lambda h, name: [] if name == "plc" and h.cycles >= 8 else ["UP"]
    )
    assert watcher.cycles(0.25) == 3 and watcher.cycles(0.3) == 3 and watcher.cycles(1.1) == 11
    harness.cycles = 5
    watcher.event(harness, Event(6, device=fault))
    watcher.event(harness, Event(6))  # not a device event: nothing done
    assert bench.done == [("plc", "unplug")]
    [watched] = watcher.open
    # lost within timeout (3 cycles) + 1; held by the devices up within poll (2) + 1 more
    assert (watched.at, watched.bound, watched.reach) == (5, 4, 7)
    watcher.fault(harness, DeviceFault("b", "freeze", AT))  # at the same time
    bench.missing = [["`pump` still on at b"]]
    for cycles in (6, 7, 8, 9):
        harness.cycles = cycles
        watcher.after_cycle(harness)
    assert [w.fault.name for w in watcher.open] == ["b"] and watcher.failures == []
    assert watcher.checks == [
        "plc unplug before cycle 6: lost, inputs stale, every actuator latched safe 3 cycles "
        "later (bound 4: timeout + 1 cycle), held safe by the devices up 4 cycles later "
        "(bound 7)"
    ]
    watcher.event(harness, Event(10, device=DeviceFault("plc", "replug", AT)))
    assert [w.fault.name for w in watcher.open] == ["b"]  # a replug takes nothing down


def test_a_device_not_lost_in_time_fails_where_the_fault_is_written(monkeypatch):
    fault = DeviceFault("plc", "freeze", AT)
    watcher, harness, _ = watch(monkeypatch, [])
    monkeypatch.setattr(runner, "safe_check", lambda harness, name: [f"device `{name}` is UP"])
    watcher.fault(harness, fault)
    harness.cycles = 2
    watcher.fault(harness, DeviceFault("b", "unplug", AT))  # timeout 1 s: bound 11 cycles
    for cycles in (1, 2, 3):
        harness.cycles = cycles
        watcher.after_cycle(harness)
    assert watcher.failures == [] and len(watcher.open) == 2  # 3 cycles: within bound 4
    harness.cycles = 4
    watcher.after_cycle(harness)
    assert watcher.failures == [
        (AT, "freeze of device `plc` before cycle 1: 4 cycles later device `plc` is UP")
    ]
    # the other fault is still watched
    assert [(w.fault.name, w.at, w.bound) for w in watcher.open] == [("b", 2, 11)]


def test_the_devices_up_not_holding_the_safe_values_in_time_fail_and_a_fault_open_at_the_end(
    monkeypatch,
):
    watcher, harness, bench = watch(monkeypatch, [])
    bench.missing = [["`pump` on at b"]] * 3
    watcher.fault(harness, DeviceFault("plc", "unplug", AT))
    for cycles in (1, 2):
        harness.cycles = cycles
        watcher.after_cycle(harness)
    assert watcher.failures == [] and watcher.open[0].safe_after == 1
    harness.cycles = 7
    watcher.after_cycle(harness)
    assert watcher.failures == [(AT, "unplug of device `plc` before cycle 1: `pump` on at b")]
    assert watcher.open == []
    # a fault still open when the run ends fails, said where it is written
    watcher, harness, bench = watch(monkeypatch, [["plc is UP"]] * 2)
    harness.cycles = 3
    watcher.fault(harness, DeviceFault("plc", "unplug", AT))
    harness.cycles = 5
    watcher.after_cycle(harness)
    result = runner.RunResult(scenario([]), [], 5, {}, Counter(), {}, {})
    watcher.finish(result, harness)
    assert result.device_failures == [
        (
            AT,
            "unplug of device `plc` before cycle 4: the run ended 2 cycles later, before its "
            "safe state was complete",
        )
    ]


def test_a_run_serving_devices_is_paced_and_ends_with_its_timing_record(monkeypatch):
    harness = StandInHarness(sup=2)
    harness.layout = SimpleNamespace(IO_DEVICES={})
    monkeypatch.setattr(runner, "cycle_period", lambda harness: 0.001)
    made = scenario([Event(1, command=("sup", "RUN"))])
    made.devices = {"plc": SoftPlc("plc", None, AT)}
    result = runner.run(made, harness, devices=Bench())  # type: ignore[arg-type]
    *cycles, timing = result.trace
    assert len(cycles) == result.cycles == 3
    assert runner.traces.is_timing(timing) and json.loads(timing)["cycle"] == 3


def test_the_scripted_person_takes_requests_up_one_at_a_time_and_leaves_the_console_its_own(
    monkeypatch,
):
    """Requests are answered in the order asked, each `after` cycles after it is taken up
    (the next is taken up only then); one the script leaves to the console (`never`) is
    never queued, and one withdrawn meanwhile is dropped."""
    harness = SimpleNamespace(cycles=0, layout=None, buf=None)
    open_now: list[dict[str, Any]] = []
    answered: list[tuple[Any, ...]] = []

    def write_answer(layout, buf, request, answer, reason, results, typed):  # as ctl answer
        answered.append((harness.cycles, request["name"], answer, reason, results, typed))
        open_now.remove(request)

    monkeypatch.setattr(runner, "channel_requests", lambda layout, buf: list(open_now))
    monkeypatch.setattr(runner, "write_answer", write_answer)
    script = OperatorScript(
        (
            ScriptedAnswer(2, "DONE", task="SPOT", results=(("post", 1.0),)),
            ScriptedAnswer(0, "never", task="MOVE"),
        ),
        ScriptedAnswer(1, "ERROR", "BLOCKED"),
    )
    person = runner.ScriptedPerson(script)

    def request(channel: str, number: int, task: str) -> dict[str, Any]:
        return {"name": channel, "number": number, "operator": "ldr", "task": task, "by": "x"}

    open_now += [request("ldr/pa", 1, "MOVE"), request("ldr/pl", 1, "SPOT")]
    open_now.append(request("ldr/pb", 1, "HALT"))
    for cycles in range(6):
        harness.cycles = cycles
        person.before_cycle(harness)  # type: ignore[arg-type]
    assert answered == [
        (2, "ldr/pl", "DONE", "", {"post": 1.0}, True),
        (3, "ldr/pb", "ERROR", "BLOCKED", {}, True),
    ]
    assert [r["name"] for r in open_now] == ["ldr/pa"]  # the console's
    withdrawn, asked = request("ldr/pl", 2, "SPOT"), request("ldr/pb", 2, "HALT")
    open_now += [withdrawn, asked]
    person.before_cycle(harness)  # cycle 5: pl taken up
    open_now.remove(withdrawn)
    for cycles in (6, 7):
        harness.cycles = cycles
        person.before_cycle(harness)  # type: ignore[arg-type]
    assert answered[2:] == [(7, "ldr/pb", "ERROR", "BLOCKED", {}, True)]  # taken up at 6


def line(record: dict[str, Any]) -> str:
    """A trace line as a run writes it (canonical JSON)."""
    return json.dumps(record, sort_keys=True, separators=(",", ":"))


def test_a_trace_is_written_as_stored_plain_or_compressed_and_read_back_whole(tmp_path):
    lines = [
        line({"cycle": n, "modules": {"sup": {"state": f"S{n // 3}"}}, "world": {}})
        for n in range(1, 8)
    ]
    for name in ("t.jsonl", "t.jsonl.gz"):
        path = tmp_path / "new" / "dir" / name
        runner.write_trace(path, lines)
        runner.write_trace(path, lines)  # again, over the first: its directory is there
        assert runner.read_trace(path) == lines
        assert path.read_bytes().startswith(b"\x1f\x8b") == name.endswith(".gz")
    # stored as it is written: a line per cycle, the changes only between full lines
    stored = (tmp_path / "new" / "dir" / "t.jsonl").read_text().splitlines()
    assert stored == list(runner.traces.condensed(lines)) and stored != lines


def test_a_live_trace_is_on_disk_at_each_cycle_and_written_whole_from_what_it_stored(tmp_path):
    lines = [line({"cycle": n, "modules": {}, "world": {"x": n % 2}}) for n in range(1, 6)]
    for name in ("live.jsonl", "live.jsonl.gz"):
        path = tmp_path / "runs" / name
        live = runner.LiveTrace(path)
        for n, text in enumerate(lines, 1):
            live.append(text)
            assert runner.traces.full_lines(path) == lines[:n]  # a run killed here leaves these
        live.close()
        runner.write_trace(path, live)
        assert runner.read_trace(path) == lines and list(live) == lines
    blocked = tmp_path / "file"
    blocked.write_text("")
    live = runner.LiveTrace(blocked / "t.jsonl")  # no directory can be made under a file
    live.append(lines[0])
    assert live.failed and list(live) == lines[:1]  # kept for the write at the end (E419)


def test_the_cycle_period_of_a_system_is_its_fastest_process(monkeypatch):
    for name, period in (("a", 0.2), ("b", 0.05)):
        monkeypatch.setitem(
            sys.modules,
            f"fleet.cell.main_{name}",
            SimpleNamespace(PLAN=SimpleNamespace(cycle_period=period)),
        )
    layout = SimpleNamespace(__name__="fleet.cell.layout", PROCESSES=("a", "b"))
    assert runner.cycle_period(SimpleNamespace(layout=layout)) == 0.05


def test_a_console_answer_event_is_written_as_the_scenario_types_it_or_stops_the_run(
    monkeypatch,
):
    """An event's `answer:` is written as `ctl answer` writes it, its results the values the
    scenario's YAML gives (typed, not text to parse); a channel with no open request, or
    results that fit another task, stop the run with one line that says where."""
    written: list[tuple[Any, ...]] = []
    open_now = [{"name": "ldr/pl", "number": 3, "operator": "ldr", "task": "SPOT", "by": "pl"}]

    def write_answer(layout, buf, request, status, reason, results, typed):
        if results.get("post") == -1:
            raise ValueError("SPOT: result post is -1: below its minimum 0")
        written.append((request["number"], status, reason, results, typed))

    monkeypatch.setattr(runner, "channel_requests", lambda layout, buf: list(open_now))
    monkeypatch.setattr(runner, "write_answer", write_answer)
    harness = StandInHarness(sup=1)
    event = Event(4, answer=("ldr/pl", "DONE", ""), answer_results={"post": 2})
    runner._apply(harness, event)  # type: ignore[arg-type]
    assert written == [(3, "DONE", "", {"post": 2}, True)]
    with pytest.raises(runner.ScenarioError) as caught:
        runner._apply(harness, Event(5, answer=("ldr/pb", "DONE", ""), doc="the pb report"))  # type: ignore[arg-type]
    assert str(caught.value) == "cycle 5: `ldr/pb` has no open request to answer (the pb report)"
    with pytest.raises(runner.ScenarioError) as caught:
        runner._apply(harness, Event(6, answer=("ldr/pb", "DONE", "")))  # type: ignore[arg-type]
    assert str(caught.value) == "cycle 6: `ldr/pb` has no open request to answer"
    wrong = Event(7, answer=("ldr/pl", "DONE", ""), answer_results={"post": -1})
    with pytest.raises(runner.ScenarioError) as caught:
        runner._apply(harness, wrong)  # type: ignore[arg-type]
    assert str(caught.value) == "cycle 7: `ldr/pl`: SPOT: result post is -1: below its minimum 0"


def test_a_scripted_reply_carries_its_reason():
    """`reply: {alpha: ERROR(NO_FIX)}` echoes the command with ERROR and the reason NO_FIX;
    a plain DONE with no reason."""
    replies: list[tuple[str, str, str]] = []
    harness = SimpleNamespace(
        reply=lambda module, status, reason: replies.append((module, status, reason))
    )
    runner.reply(harness, "alpha", "ERROR(NO_FIX)")  # type: ignore[arg-type]
    runner.reply(harness, "op/fx", "DONE")  # type: ignore[arg-type]
    assert replies == [("alpha", "ERROR", "NO_FIX"), ("op/fx", "DONE", "")]


def test_a_device_is_pointed_at_its_soft_plc_on_loopback_keeping_an_endpoints_path():
    from rcsgen.tools.scenario.devices import served_at

    assert served_at("modbus", "", 5020) == "127.0.0.1:5020"
    assert served_at("opcua", "opc.tcp://10.0.0.2:4840/rig", 5021) == (
        "opc.tcp://127.0.0.1:5021/rig"
    )
    assert served_at("opcua", "opc.tcp://10.0.0.2:4840", 5022) == "opc.tcp://127.0.0.1:5022/"


def test_an_output_read_back_holds_its_safe_value_within_half_a_step_of_its_scale():
    from rcsgen.tools.scenario.devices import holds

    assert holds(0.0, 0.0, 1.0) and holds(0.45, 0.0, 1.0) and holds(-0.5, 0.0, -1.0)
    assert not holds(0.55, 0.0, 1.0) and not holds(0.06, 0.0, 0.1)
    assert not holds(float("nan"), 0.0, 1.0)  # an output read back as NaN is not safe


def test_a_soft_plcs_command_names_its_devices_plant_and_the_scenarios_settings(tmp_path):
    from rcsgen.tools.scenario.devices import Bench, Plc

    made = scenario([])
    made.settings = {"seed": "3", "level": "1.5"}
    bench = Bench(made, tmp_path / "pkg", tmp_path / "scratch")
    plc = Plc(["tank", "pumps"], tmp_path / "plant", tmp_path / "plant_pkg")
    scratch = tmp_path / "scratch"
    assert bench.command(plc, [0, 5020], scratch / "tank.port") == [
        sys.executable,
        *("-m", "rcsgen.tools.softplc", "--io", str(tmp_path / "pkg")),
        *("--device", "tank", "--port", "0", "--device", "pumps", "--port", "5020"),
        *("--ready", str(scratch / "tank.port"), "--control", str(scratch / "control")),
        *("--plant", str(tmp_path / "plant_pkg"), "--hooks", str(tmp_path / "plant")),
        *("--set", "seed=3", "--set", "level=1.5"),
    ]
    alone = Plc(["tank"], None, None)  # a PLC of its own: no plant
    assert "--plant" not in bench.command(alone, [0], scratch / "tank.port")


def test_a_paced_run_wakes_on_its_schedule_and_a_late_cycle_starts_it_again(monkeypatch):
    """Pace: each cycle starts a period after the one before, however long its work took;
    a cycle that ends past its time starts the next at once and the schedule from there
    (no burst to catch up). The timing record counts every wake-up after the first."""
    clock = SimpleNamespace(t=100.0)
    monkeypatch.setattr(runner.time, "monotonic", lambda: clock.t)
    monkeypatch.setattr(runner.time, "sleep", lambda s: setattr(clock, "t", clock.t + s))
    pace = runner.Pace(0.1)
    woke = []
    for work in (0.03, 0.25, 0.01, 0.0):
        pace.wait()
        woke.append(clock.t)
        clock.t += work
    assert woke == pytest.approx([100.0, 100.1, 100.35, 100.45])
    figures = json.loads(pace.line(7) or "")
    assert figures["cycle"] == 7 and figures["periodicity"]["wakeups"] == 3


class FakePopen:
    """What Bench.close does to a PLC's process: its signals and waits, in order."""

    def __init__(self, running: bool, stops: bool = True) -> None:
        self.running, self.stops, self.done = running, stops, []

    def poll(self) -> int | None:
        return None if self.running else 0

    def send_signal(self, signum: int) -> None:
        self.done.append(signum)

    def terminate(self) -> None:
        self.done.append("terminate")

    def kill(self) -> None:
        self.done.append("kill")

    def wait(self, timeout: float) -> int:
        self.done.append(f"wait {timeout:g}")
        if self.running and not self.stops and self.done[-2] != "kill":
            raise subprocess.TimeoutExpired("plc", timeout)
        return 0


def test_closing_the_bench_thaws_and_stops_each_running_plc_once_and_kills_one_that_stays(
    tmp_path, monkeypatch
):
    import signal

    from rcsgen.tools.scenario.devices import Bench, Plc

    monkeypatch.setenv("RCSGEN_IO_TANK", "127.0.0.1:5020")
    bench = Bench(scenario([]), tmp_path, tmp_path / "scratch")
    bench.saved = {"RCSGEN_IO_TANK": "10.0.0.1:502"}
    running, ended, stuck = (
        Plc(["a", "b"], None, None),
        Plc(["c"], None, None),
        Plc(["d"], None, None),
    )
    running.popen, ended.popen, stuck.popen = (
        FakePopen(True),
        FakePopen(False),
        FakePopen(True, False),
    )
    bench.plcs = {"a": running, "b": running, "c": ended, "d": stuck}  # a and b share one
    bench.close()
    assert running.popen.done == [signal.SIGCONT, "terminate", "wait 20"]
    assert ended.popen.done == ["wait 20"]  # it had exited: nothing sent to it
    assert stuck.popen.done == [signal.SIGCONT, "terminate", "wait 20", "kill", "wait 10"]
    assert os.environ["RCSGEN_IO_TANK"] == "10.0.0.1:502"


class DeviceHarness:
    """What safe_check and io_counts read: a device's record, the world and what is held."""

    def __init__(self, state: int, world: dict[str, Any], held: dict[str, str]) -> None:
        counts = dict.fromkeys(("reads", "writes", "timeouts", "retries", "errors"), 1)
        values = {"state": state, "last_ok_ns": 5, "last_error": 1, "round_trip_ns": 2_000_000}
        values |= counts | {"reconnects": 2, "losses": 1, "address": "10.0.0.5:502"}
        device = SimpleNamespace(
            protocol="modbus", process="p", poll_period=0.1, timeout=0.5,
            inputs=[SimpleNamespace(field="level"), SimpleNamespace(field="flow")],
        )  # fmt: skip
        record = SimpleNamespace(read=lambda buf: values.items())
        self.layout = SimpleNamespace(
            IO_DEVICES={"tank": device},
            IO_RECORDS={"tank": record},
            SAFE_VALUES={"valve_cmd": 0.0, "pump_on": False},
        )
        self.buf = bytearray()
        self.world = SimpleNamespace(
            snapshot=lambda names: {n: world[n] for n in names}, overrides=lambda: held
        )


def test_a_lost_device_is_safe_when_lost_its_inputs_stale_and_every_actuator_latched():
    from rcsgen.runtime.io_points import LOST, ONLINE

    safe = {"valve_cmd": 0.0, "pump_on": False}
    latched = {"valve_cmd": "SAFE", "pump_on": "SAFE"}
    lost = DeviceHarness(LOST, safe, latched)
    assert runner.io_counts(lost, "tank", lost.layout.IO_DEVICES["tank"]) == {
        "state": "LOST",
        **dict.fromkeys(("reads", "writes", "timeouts", "retries", "errors"), 1),
        "reconnects": 2,
        "losses": 1,
        "stale": ["level", "flow"],
    }
    assert runner.safe_check(lost, "tank") == []
    online = DeviceHarness(ONLINE, {"valve_cmd": 50.0, "pump_on": False}, {"pump_on": "SAFE"})
    assert runner.safe_check(online, "tank") == [
        "device `tank` is ONLINE, not LOST",
        "its inputs marked stale are [], not ['level', 'flow']",
        "`valve_cmd` is 50.0, not latched at safe 0.0",
    ]
    unlatched = DeviceHarness(LOST, safe, {"valve_cmd": "SAFE"})  # safe, but not held so
    assert runner.safe_check(unlatched, "tank") == ["`pump_on` is False, not latched at safe False"]


def test_the_devices_still_up_are_each_read_back_past_one_that_is_down(monkeypatch, tmp_path):
    """not_safe_on_survivors: a device down (unplugged, frozen) or binding no actuator is
    not asked; every other device is, each read back on its own probe."""
    import rcsgen.runtime.io_cycle as io_cycle
    from rcsgen.tools.scenario.devices import Bench

    def output(name: str) -> Any:
        return SimpleNamespace(field=name, scale=1.0)

    devices = {
        "down": SimpleNamespace(outputs=[output("valve_cmd")]),
        "bare": SimpleNamespace(outputs=[output("lamp")]),  # no actuator with a safe value
        "tank": SimpleNamespace(outputs=[output("valve_cmd")]),
        "pumps": SimpleNamespace(outputs=[output("pump_cmd")]),
    }
    monkeypatch.setattr(io_cycle, "relocated", lambda device: device)
    layout = SimpleNamespace(IO_DEVICES=devices, SAFE_VALUES={"valve_cmd": 0.0, "pump_cmd": 0.0})
    made = scenario([])
    made.devices = {name: SoftPlc(name, None, AT) for name in devices}
    bench = Bench(made, tmp_path / "pkg", tmp_path / "scratch")
    bench.down = {"down"}
    held = {"tank": 50.0, "pumps": 3.0}
    bench.probes = {
        name: SimpleNamespace(read_point=lambda point, v=value: v) for name, value in held.items()
    }
    assert bench.not_safe_on_survivors(layout) == [  # type: ignore[arg-type]
        "device `tank` holds `valve_cmd` 50.0, not its safe 0.0",
        "device `pumps` holds `pump_cmd` 3.0, not its safe 0.0",
    ]


def test_a_trace_line_of_a_system_with_fieldbus_io_holds_each_devices_state_and_counts():
    from rcsgen.runtime.io_points import LOST

    harness = DeviceHarness(LOST, {"valve_cmd": 0.0}, {})
    harness.modules, harness.cycles = [], 4
    harness.world.snapshot = lambda names: {}
    line = json.loads(runner.trace_line(harness, []))  # type: ignore[arg-type]
    assert line["io"] == {
        "tank": runner.io_counts(harness, "tank", harness.layout.IO_DEVICES["tank"])
    }
    assert line["io"]["tank"]["state"] == "LOST"
