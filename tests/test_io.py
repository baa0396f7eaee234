"""Fieldbus I/O over real protocol stacks on loopback (docs/io.md, issue 27).

The system is `tests/fixtures/runtime/rig`: process p runs the `tank` device (Modbus TCP:
the level in, the valve out), process q the `pumps` device (OPC UA: the pump and the alarm
lamp out), and both processes' controllers read the level. Each device is a soft PLC, a
separate OS process (`python -m rcsgen.tools.softplc`) on a free loopback port, and the
system runs as its own OS processes (`python -m rig`). A test pulls a plug (SIGKILL) or
freezes a PLC (SIGSTOP: it accepts connections and answers nothing) mid-run and waits,
with generous bounded deadlines, for what the operator and the devices see: the device
LOST with its inputs stale, every actuator latched at its safe value, the safe values on
the device that still answers, the controllers in their safe state, then the automatic,
logged reconnection. Nothing here asserts how fast (`make bench` measures detection).
Every PLC and system started is stopped, its port closed, its segment gone. pymodbus and
asyncua come with the `dev` extra (`make test`): without them these tests fail, not skip.
"""

from __future__ import annotations

import importlib
import itertools
import json
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import rcsgen, wait_for

from rcsgen.tools.harness import Harness, generate, import_package
from rcsgen.tools.scenario import read_trace

RIG = Path(__file__).resolve().parent / "fixtures" / "runtime" / "rig"
LEVEL = 1.25  # what the tank PLC's level sensor reads: the pump drains, the valve fills
DRIVING = {"valve_cmd": 50.0, "pump_on": True, "alarm": False}
SAFE = {"valve_cmd": 0.0, "pump_on": False, "alarm": True}
_names = itertools.count()


@pytest.fixture(scope="module")
def rig() -> Iterator[Path]:
    """The rig generated into a scratch directory: the package's directory."""
    scratch, name = generate(RIG)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def package(rig: Path) -> ModuleType:
    return import_package(rig)


def runtime(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


class Plc:
    """A soft PLC serving one of the rig's devices, as its own OS process."""

    def __init__(
        self,
        rig: Path,
        device: str,
        scratch: Path,
        port: int = 0,
        plant: tuple[str, ...] = ("--world", f"level={LEVEL}"),
        also: tuple[tuple[str, int], ...] = (),
    ) -> None:
        """`also`: more devices this PLC serves over the same plant, each (name, port)."""
        self.rig, self.device, self.scratch = rig, device, scratch
        self.also = also
        self.ready = scratch / f"{device}.port"
        self.log = scratch / f"{device}.log"
        self.ready.unlink(missing_ok=True)
        with self.log.open("ab") as log:
            self.popen = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "rcsgen.tools.softplc",
                    "--io",
                    str(rig),
                    "--device",
                    device,
                    "--port",
                    str(port),
                    "--ready",
                    str(self.ready),
                    *plant,
                    *(arg for name, at in also for arg in ("--device", name, "--port", str(at))),
                ],
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        self.port = port

    def wait(self) -> Plc:
        """Once it listens: the port it listens on known."""
        wait_for(self._listening, f"the {self.device} PLC listening", deadline=90, every=0.05)
        self.port, *self.ports = (int(line) for line in self.ready.read_text().split())
        return self

    def _listening(self) -> bool:
        if self.popen.poll() is not None:
            raise AssertionError(f"the {self.device} PLC exited: {self.log.read_text()}")
        lines = self.ready.read_text().splitlines(keepends=True) if self.ready.is_file() else []
        return len(lines) == 1 + len(self.also) and lines[-1].endswith("\n")

    @property
    def address(self) -> str:
        if self.device == "pumps":
            return f"opc.tcp://127.0.0.1:{self.port}/rig"
        return f"127.0.0.1:{self.port}"

    def stop(self) -> None:
        """Stopped whatever was done to it; its port closed."""
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGCONT)  # a frozen PLC handles SIGTERM once thawed
            self.popen.terminate()
            try:
                self.popen.wait(20)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(10)
        for port in (self.port, *getattr(self, "ports", ())):
            wait_for(lambda p=port: not port_open(p), f"port {port} closed", deadline=10)


def port_open(port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(0.5)
        return probe.connect_ex(("127.0.0.1", port)) == 0


@pytest.fixture
def plcs(rig: Path, tmp_path: Path) -> Iterator[dict[str, Plc]]:
    """Both devices' soft PLCs (started side by side); stopped at the end."""
    started: dict[str, Plc] = {}
    try:
        for device in ("tank", "pumps"):  # side by side: each takes seconds to start
            started[device] = Plc(rig, device, tmp_path)
        for plc in started.values():
            plc.wait()
        yield started
    finally:
        for plc in started.values():
            plc.stop()


def environment(plcs: dict[str, Plc]) -> dict[str, str]:
    """The environment pointing each device at its PLC (RCSGEN_IO_<DEVICE>)."""
    return {f"RCSGEN_IO_{name.upper()}": plc.address for name, plc in plcs.items()}


class Running:
    """`python -m rig` as its own OS processes, and a console on its segment."""

    def __init__(self, rig: Path, package: ModuleType, env: dict[str, str], log: Path) -> None:
        self.segment = f"rcsgen_io_{os.getpid()}_{next(_names)}"
        self.log = log
        with log.open("ab") as out:
            self.popen = subprocess.Popen(
                [sys.executable, "-m", "rig", "--shm", self.segment, "--send", "cell.RUN"],
                cwd=rig.parent,
                env={**os.environ, **env},
                stdout=out,
                stderr=subprocess.STDOUT,
            )
        self.layout = runtime(package, "layout")
        ctl = runtime(package, "rcs.operate.ctl")
        self.console: Any = wait_for(lambda: self._attach(ctl), "the rig's segment", deadline=60)

    def _attach(self, ctl: ModuleType) -> Any:
        if self.popen.poll() is not None:
            raise AssertionError(f"the rig exited: {self.log.read_text()}")
        try:
            console = ctl.Console(self.layout, self.segment)
        except Exception:  # noqa: BLE001 - not there (or not initialised) yet
            return None
        return console if console.processes()["q"].get("alive") else console.close()

    def world(self) -> dict[str, Any]:
        return {name: self.console.world([name])[name] for name in SAFE}

    def console_render(self) -> list[str]:
        """The screen `ctl status --world ''` shows."""
        return list(runtime_of(self.layout, "rcs.operate.ctl").render(self.console.snapshot()))

    def devices(self) -> dict[str, Any]:
        return self.console.devices()

    def wait(self, condition: Any, what: str, deadline: float = 30) -> None:
        try:
            wait_for(condition, what, deadline, every=0.02)
        except AssertionError as error:
            snapshot = self.console.snapshot()
            seen = {k: snapshot[k] for k in ("io", "overrides", "world")}
            raise AssertionError(f"{error}; the console saw {json.dumps(seen)}") from None

    def stop(self) -> str:
        """Ctrl-C; the processes gone, the segment too; what they logged."""
        self.console.close()
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGINT)
            try:
                self.popen.wait(30)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(10)
                raise AssertionError(f"the rig did not stop: {self.log.read_text()}") from None
        assert not os.path.exists(f"/dev/shm/{self.segment}"), "segment left behind"
        return self.log.read_text()


def runtime_of(layout: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{layout.__name__.rsplit('.', 1)[0]}.{name}")


def on_tank(plc: Plc) -> float:
    """The valve opening the tank PLC holds (its holding register 0, tenths of a percent)."""
    from pymodbus.client import ModbusTcpClient

    client = ModbusTcpClient("127.0.0.1", port=plc.port, timeout=2)
    try:
        assert client.connect()
        return client.read_holding_registers(0, count=1).registers[0] / 10
    finally:
        client.close()


def on_pumps(plc: Plc) -> dict[str, bool]:
    """The pump and the alarm lamp as the pumps' OPC UA server holds them."""
    from asyncua.sync import Client

    logging.getLogger("asyncua").setLevel(logging.ERROR)
    with Client(plc.address, timeout=5) as client:
        return {
            field: bool(client.get_node(f"ns=2;s={node}").read_value())
            for field, node in (("pump_on", "Pump.On"), ("alarm", "Alarm.Lit"))
        }


@pytest.mark.parametrize(
    ("device", "fault"), [("tank", "kill"), ("tank", "stop"), ("pumps", "kill")]
)
def test_a_lost_device_drives_the_safe_state_and_the_survivor_gets_safe_outputs(
    rig: Path, package: ModuleType, plcs: dict[str, Plc], tmp_path: Path, device: str, fault: str
) -> None:
    """A PLC killed or frozen mid-run: its device LOST (its inputs stale) for the process
    that runs it; every actuator latched SAFE and the controllers in their safe state; the
    other device, which still answers, gets the safe outputs; the lost device reconnects by
    itself when it is back (logged), and the latches stay until a reset."""
    running = Running(rig, package, environment(plcs), tmp_path / "rig.log")
    other = "pumps" if device == "tank" else "tank"
    try:
        running.wait(lambda: running.world() == DRIVING, "the cell running, every actuator on")
        running.wait(
            lambda: all(d["state"] == "ONLINE" for d in running.devices().values()), "online"
        )
        # where each device is, as its process reaches it: the address RCSGEN_IO_<DEVICE>
        # gave (the PLC's free port), not the one the spec declares (1502, 4841)
        assert {n: d["address"] for n, d in running.devices().items()} == {
            n: plc.address for n, plc in plcs.items()
        }
        assert not {p.port for p in plcs.values()} & {1502, 4841}
        running.wait(lambda: on_tank(plcs["tank"]) == 50.0, "the valve open on the PLC")
        on = {"pump_on": True, "alarm": False}
        running.wait(lambda: on_pumps(plcs["pumps"]) == on, "the pump on, on the PLC")
        assert running.console.world(["level"])["level"] == LEVEL, "read from the PLC"

        plc = plcs[device].popen
        plc.send_signal(signal.SIGKILL if fault == "kill" else signal.SIGSTOP)
        running.wait(lambda: running.devices()[device]["state"] == "LOST", f"{device} lost")
        running.wait(lambda: running.world() == SAFE, "every actuator safe")
        held = running.console.overrides()
        assert {name: how["state"] for name, how in held.items()} == dict.fromkeys(SAFE, "SAFE")
        # the request in flight when it went silent is counted once its own timeout is over
        running.wait(
            lambda: running.devices()[device]["timeouts"] + running.devices()[device]["errors"],
            "the failed request counted",
        )
        lost = running.devices()[device]
        assert lost["losses"] == 1
        assert lost["stale"] == (["level"] if device == "tank" else [])
        assert running.devices()[other]["state"] == "ONLINE", "the other device still answers"
        if device == "tank":  # the level is stale: the screen says so, in the world table too
            screen = "\n".join(running.console_render())
            assert f"io tank: lost, modbus_tcp {plcs['tank'].address}" in screen
            assert "(stale: tank)" in screen
            off = {"pump_on": False, "alarm": True}
            running.wait(lambda: on_pumps(plcs["pumps"]) == off, "the pump safe on its PLC")
        else:
            running.wait(lambda: on_tank(plcs["tank"]) == 0.0, "the valve closed on its PLC")
        # the root in its safe state (the process running it reacts at its next cycle)
        running.wait(lambda: running.console.modules()["cell"]["status"] == "ERROR", "cell ERROR")
        assert running.console.modules()["cell"]["error_num"] == 1, "ERROR (LOST)"

        # Back: the frozen PLC thawed, the killed one started again on its port.
        if fault == "stop":
            plc.send_signal(signal.SIGCONT)
        else:
            plc.wait(10)  # reaped: the killed PLC is gone
            plcs[device] = Plc(rig, device, tmp_path, port=plcs[device].port).wait()
        running.wait(lambda: running.devices()[device]["state"] == "ONLINE", "online again")
        back = running.devices()[device]
        assert back["stale"] == [] and back["retries"] >= 1 and back["reconnects"] >= 1, back
        assert running.world() == SAFE, "latched: nothing un-safes them but a reset"
    finally:
        log = running.stop()
    process = "p" if device == "tank" else "q"
    assert f"{process}: I/O device {device} lost: no good answer" in log, log
    assert f"{process}: I/O device {device} answers again" in log, log
    assert "Traceback" not in log, log


def test_a_trace_line_carries_each_device_s_state_and_counts(
    rig: Path, plcs: dict[str, Plc], monkeypatch: pytest.MonkeyPatch
) -> None:
    """In process (the harness drives every process's modules, the I/O modules around
    them): the devices are read and written, and each trace line says so."""
    from rcsgen.tools.scenario import trace_line

    for name, value in environment(plcs).items():
        monkeypatch.setenv(name, value)
    harness = Harness(import_package(rig))
    try:
        harness.command("cell", "RUN")
        harness.cycle()
        wait_for(lambda: harness.cycle() or on_tank(plcs["tank"]) == 50.0, "the valve open")
        on = {"pump_on": True, "alarm": False}
        wait_for(lambda: harness.cycle() or on_pumps(plcs["pumps"]) == on, "the pump on")
        harness.cycle()  # the records say what the devices' threads did up to now
        line = json.loads(trace_line(harness, ["level", "valve_cmd"]))
    finally:
        harness.close()
    assert line["world"] == {"level": LEVEL, "valve_cmd": 50.0}
    tank, pumps = line["io"]["tank"], line["io"]["pumps"]
    assert tank["state"] == pumps["state"] == "ONLINE"
    assert tank["reads"] >= 1 and tank["writes"] >= 1 and pumps["writes"] >= 1
    assert pumps["reads"] == 0, "the pumps device has no inputs"
    assert tank["losses"] == pumps["losses"] == 0


def test_an_exception_code_is_no_answer_and_validate_connect_names_what_is_missing(
    rig: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A device that answers with an exception code (02, a register it does not have) gives
    no good answer: counted as an error, never as a read, so the cycle sees it silent and
    loses it after its timeout. `validate --connect` names the point; a device that is not
    there at all is one E458 at its declaration."""
    from dataclasses import replace

    from rcsgen.runtime.io_cycle import DeviceRunner
    from rcsgen.runtime.io_points import INPUT_REGISTER, Point

    plc = Plc(rig, "tank", tmp_path).wait()
    try:
        layout = importlib.import_module(f"{import_package(rig).__name__}.layout")
        declared = layout.IO_DEVICES["tank"]
        missing = Point("level", INPUT_REGISTER, 40, False, "float", scale=0.01)
        device = replace(declared, port=plc.port, points=(missing,))
        logged: list[str] = []
        runner = DeviceRunner(device, log=logged.append)
        runner.start()
        try:
            wait_for(lambda: runner.snapshot()[2]["errors"] >= 2, "two refused polls")
        finally:
            runner.stop()
        seq, inputs, counts = runner.snapshot()
        assert (seq, inputs, counts["reads"], counts["last_ok_ns"]) == (0, None, 0, 0)
        assert "answered with an exception: exception code 2" in logged[0], logged

        with socket.socket() as unused:  # a port nothing listens on
            unused.bind(("127.0.0.1", 0))
            dead = unused.getsockname()[1]
        monkeypatch.setenv("RCSGEN_IO_TANK", f"127.0.0.1:{plc.port}")
        monkeypatch.setenv("RCSGEN_IO_PUMPS", f"opc.tcp://127.0.0.1:{dead}/rig")
        result = rcsgen("validate", RIG, "--connect")
        assert result.exit_code == 1, result.output
        assert "E458" in result.output and "device `pumps` does not answer" in result.output
        assert "device `tank`" not in result.output, "the tank PLC has every point"
        monkeypatch.setenv("RCSGEN_IO_TANK", "not an address")
        result = rcsgen("validate", RIG, "--connect")
        assert "RCSGEN_IO_TANK='not an address': not an address of I/O device tank" in (
            result.output
        )
    finally:
        plc.stop()


# ---------------------------------------------------------------- the miner in the loop

ROOT = Path(__file__).resolve().parent.parent
GENERATED = ROOT / "generated"
BOX_CUT = ("--send", "sec.BOX_CUT:depth=1.5", "--set", "map=maps/box_cut.map")


def miner_plc(scratch: Path, port: int = 0, conveyor: int = 0) -> Plc:
    """The soft PLC of miner_hil's `plc` and `conveyor`: the miner's simulators (the
    committed package) behind Modbus TCP, the conveyor subsystem behind OPC UA."""
    plant = ("--plant", str(GENERATED / "miner"), "--hooks", str(ROOT / "specs" / "miner"))
    report = ("--report", str(scratch / "plant.json"), "--set", "map=maps/box_cut.map")
    also = (("conveyor", conveyor),)
    return Plc(GENERATED / "miner_hil", "plc", scratch, port, plant + report, also).wait()


def start_hil(plc: Plc, log: Path, *options: str) -> tuple[subprocess.Popen[bytes], str]:
    """`python -m miner_hil` (the committed package) bound to `plc`: its process, segment."""
    segment = f"rcsgen_io_{os.getpid()}_{next(_names)}"
    env = {
        **os.environ,
        "RCSGEN_IO_PLC": plc.address,
        "RCSGEN_IO_CONVEYOR": f"opc.tcp://127.0.0.1:{plc.ports[0]}/miner",
        "PYTHONPATH": str(ROOT / "specs" / "miner_hil"),
    }
    with log.open("ab") as out:
        popen = subprocess.Popen(
            [sys.executable, "-m", "miner_hil", "--shm", segment, *BOX_CUT, *options],
            cwd=GENERATED,
            env=env,
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    return popen, segment


def test_the_box_cut_in_the_loop_ends_as_the_simulated_one(tmp_path: Path) -> None:
    """miner_hil's controllers over Modbus TCP and, for the conveyor subsystem, OPC UA, the
    miner's simulators in a soft PLC serving both (two paced OS processes and a third for
    the PLC): the box cut completes (sec DONE) with the
    simulation's outcome: the depth its golden trace ends at, the floor as clear as the
    scenario expects, the machine where the simulated one ends."""
    golden = json.loads(read_trace(ROOT / "tests" / "golden" / "box_cut.jsonl")[-1])
    scenario = (ROOT / "specs" / "miner" / "scenarios" / "box_cut.yaml").read_text()
    floor = float(scenario.split("loose_coal_true: {max: ")[1].split("}")[0])
    plc = miner_plc(tmp_path)
    log = tmp_path / "hil.log"
    try:
        popen, segment = start_hil(plc, log, "--until-done")
        try:
            code = popen.wait(300)
        except subprocess.TimeoutExpired:
            popen.kill()
            popen.wait(10)
            raise AssertionError(f"the box cut did not end: {log.read_text()}") from None
    finally:
        plc.stop()
    out = log.read_text()
    assert code == 0 and "sec DONE" in out, out
    assert "I/O device plc lost" not in out and "I/O device conveyor lost" not in out, out
    assert not os.path.exists(f"/dev/shm/{segment}")
    plant = json.loads((tmp_path / "plant.json").read_text())
    assert plant["depth_cut"] == golden["world"]["depth_cut"] == 1.5
    assert plant["loose_coal_true"] <= floor
    # where the machine stands at the end: within 10 cm of the simulated run's place
    assert abs(plant["true_x"] - golden["world"]["true_x"]) <= 0.1, plant["true_x"]
    assert abs(plant["true_y"] - golden["world"]["true_y"]) <= 0.1, plant["true_y"]
    # the coal mined is not compared: a command reaches the plant a poll later than in the
    # simulation, so the cut's edges differ (docs/io.md, "Latency"); the face is cut to depth
    assert plant["coal_mined"] > 0.5 * golden["world"]["coal_mined"]


def test_pulling_the_plc_s_plug_mid_shear_stops_the_machine_safe(tmp_path: Path) -> None:
    """The PLC killed while the drum shears down the face: the device LOST, every actuator
    latched at its safe value, the mission ended at the root with ERROR (LOST); plugged in
    again (a PLC on the same port), it reconnects by itself and gets the safe outputs, not
    the commands of before the fault."""
    from pymodbus.client import ModbusTcpClient

    package = import_package(GENERATED / "miner_hil", ROOT / "specs" / "miner_hil")
    layout, ctl = runtime(package, "layout"), runtime(package, "rcs.operate.ctl")
    plc = miner_plc(tmp_path)
    log = tmp_path / "hil.log"
    popen, segment = start_hil(plc, log)
    console: Any = None
    try:

        def attached() -> Any:
            if popen.poll() is not None:
                raise AssertionError(f"miner_hil exited: {log.read_text()}")
            try:
                return ctl.Console(layout, segment)
            except Exception:  # noqa: BLE001 - not there yet
                return None

        console = wait_for(attached, "miner_hil's segment", deadline=60)

        def shearing() -> bool:
            co = console.modules()["co"]
            angle = console.world(["boom_angle"])["boom_angle"]
            return (co.get("command"), co.get("state")) == ("SUMP_SHEAR_CUSP", "S2") and (
                angle is not None and angle < 20.0
            )

        wait_for(shearing, "mid-shear", deadline=120, every=0.02)
        assert console.world(["drum_on_cmd"])["drum_on_cmd"] is True
        plc.popen.kill()
        plc.popen.wait(10)
        safe = dict(layout.SAFE_VALUES)
        wait_for(lambda: console.devices()["plc"]["state"] == "LOST", "the PLC lost", 30)
        wait_for(lambda: console.world(list(safe)) == safe, "every actuator safe", 30)
        held = console.overrides()
        assert {f: how["state"] for f, how in held.items()} == dict.fromkeys(safe, "SAFE")
        wait_for(lambda: console.modules()["sec"]["status"] == "ERROR", "sec ERROR", 30)
        assert console.modules()["sec"]["error_num"] == 1, "ERROR (LOST), the runtime's safe state"
        assert set(console.devices()["plc"]["stale"]) >= {"pose_x", "boom_angle", "jack_down"}

        plc = miner_plc(tmp_path, port=plc.port, conveyor=plc.ports[0])  # plugged in again
        wait_for(lambda: console.devices()["plc"]["state"] == "ONLINE", "online again", 30)
        client = ModbusTcpClient("127.0.0.1", port=plc.port, timeout=2)
        try:
            assert client.connect()
            wait_for(lambda: client.read_coils(0, count=4).bits[:4] == [False] * 4, "coils off")
            registers = client.read_holding_registers(0, count=3).registers
        finally:
            client.close()
        assert registers == [0, 0, 0], "boom still, treads stopped"
    finally:
        if console is not None:
            console.close()
        if popen.poll() is None:
            popen.send_signal(signal.SIGINT)
            popen.wait(30)
        plc.stop()
    out = log.read_text()
    assert "pc1: I/O device plc lost: no good answer" in out, out
    assert "pc1: I/O device plc answers again" in out, out
    assert not os.path.exists(f"/dev/shm/{segment}")


class Recording:
    """A link that answers at once and keeps what it was asked to write."""

    def __init__(self, device: Any) -> None:
        self.written: list[dict[str, object]] = []

    def connect(self) -> None:
        pass

    def read(self) -> dict[str, object]:
        return {}

    def write(self, values: dict[str, object]) -> int:
        self.written.append(dict(values))
        return 0

    def close(self) -> None:
        pass


def test_a_device_thread_writes_latched_values_even_when_the_cycle_hands_nothing_new(
    package: ModuleType,
) -> None:
    """The cycle handed the pump on; then the pump is latched safe in the block and the
    process's loop hands nothing more (stuck in a hook, say): the device's own thread
    writes the latched value at its next poll."""
    cycle = runtime(package, "rcs.io_cycle")
    device = runtime(package, "layout").IO_DEVICES["pumps"]
    links: list[Recording] = []

    def make(device: Any) -> Recording:
        links.append(Recording(device))
        return links[-1]

    latched: dict[str, object] = {}
    runner = cycle.DeviceRunner(device, make, log=lambda _: None, held=lambda: dict(latched))
    runner.hand({"pump_on": True, "alarm": False})
    runner.start()
    try:
        wait_for(lambda: any(links) and links[0].written, "a first write")
        assert links[0].written[-1] == {"pump_on": True, "alarm": False}
        latched.update(pump_on=False)  # as latch_safe leaves the block
        wait_for(lambda: links[0].written[-1] == {"pump_on": False, "alarm": False}, "safe")
    finally:
        runner.stop()


def test_the_execution_order_picture_shows_the_i_o_module_around_the_controllers() -> None:
    """`rcsgen graph --picture order:p`: every full cycle of p reads its device first and
    writes it last; q, which runs the other device, says its own; no I/O in a system
    without devices (the miner)."""
    text = rcsgen("graph", RIG, "--picture", "order:p", "--format", "mermaid").output
    assert "[I/O in: tank] cell tank [I/O out: tank]" in text
    cycle = text.split('subgraph o_cycle1["cycle 1"]')[1].split("end")[0]
    steps = [line.split('["')[0].strip() for line in cycle.strip().splitlines()]
    assert steps == ["x1_io_in", "x1_cell", "x1_tank", "x1_io_out"], steps
    assert (
        "[I/O in: pumps] pump [I/O out: pumps]"
        in rcsgen("graph", RIG, "--picture", "order:q", "--format", "mermaid").output
    )
    miner = rcsgen("graph", ROOT / "specs" / "miner", "--picture", "order", "--format", "mermaid")
    assert "I/O" not in miner.output


def test_a_device_address_the_process_cannot_use_is_one_line_before_anything_starts(
    rig: Path,
) -> None:
    """RCSGEN_IO_<DEVICE> that is not an address: `python -m rig` says so in one line (a
    usage error, exit 2), before a segment or a process exists."""
    segment = f"rcsgen_io_{os.getpid()}_{next(_names)}"
    done = subprocess.run(
        [sys.executable, "-m", "rig", "--shm", segment],
        cwd=rig.parent,
        env={**os.environ, "RCSGEN_IO_TANK": "garbage"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1] == (
        "python -m rig: error: RCSGEN_IO_TANK='garbage': not an address of I/O device tank "
        "(HOST:PORT)"
    )
    assert "Traceback" not in done.stderr
    assert not os.path.exists(f"/dev/shm/{segment}")


def test_a_watched_device_record_left_torn_is_skipped_not_a_crash(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """q watches `tank` (run by p) through its record. A record left mid-write (p killed
    while writing it) cannot be read whole: q's cycle goes on without it (p's loss is the
    process reaction's business), and a LOST record read whole is reacted to."""
    with socket.socket() as unused:  # the pumps device nowhere: q's own device not needed
        unused.bind(("127.0.0.1", 0))
        monkeypatch.setenv("RCSGEN_IO_PUMPS", f"opc.tcp://127.0.0.1:{unused.getsockname()[1]}/x")
    layout, contract = runtime(package, "layout"), runtime(package, "rcs.contract")
    harness = Harness(package, "q")
    try:
        io = harness.processes["q"].io
        assert io.watched == ["tank"]
        record = layout.IO_RECORDS["tank"]
        contract.SEQ.pack_into(harness.buf, record.offset, 7)  # odd: a writer mid-write
        harness.cycle(2)
        assert "tank" not in io.lost
        contract.SEQ.pack_into(harness.buf, record.offset, 8)
        record.write(harness.buf, **dict(record.read(harness.buf), state=2))  # LOST
        harness.cycle()
        assert "tank" in io.lost
        held = runtime(package, "rcs.override").overrides(layout, harness.buf)
        assert {f: state for f, (state, _) in held.items()} == dict.fromkeys(SAFE, "SAFE")
    finally:
        harness.close()


def test_a_soft_plc_without_its_protocol_library_says_which_extra_in_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The soft PLC finds a missing protocol library before any server starts (it was a
    traceback from inside asyncua's import, seen when `make bench`'s venv lacked it)."""
    import importlib.util
    from types import SimpleNamespace

    from rcsgen.runtime.io_points import MODBUS_TCP, OPCUA
    from rcsgen.tools import softplc

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "asyncua" else real(name)
    )
    modbus = SimpleNamespace(name="plc", protocol=MODBUS_TCP)
    conveyor = SimpleNamespace(name="conveyor", protocol=OPCUA)
    softplc._libraries_there([modbus])  # pymodbus is there: nothing said
    with pytest.raises(ImportError) as refused:
        softplc._libraries_there([modbus, conveyor])
    assert str(refused.value) == (
        f"device conveyor ({OPCUA}) needs asyncua: pip install 'rcsgen[opcua]'"
    )
