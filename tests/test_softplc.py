"""The soft PLC (rcsgen/tools/softplc.py), `validate --connect`'s probe (tools/io_connect.py)
and a scenario's device bench (tools/scenario/devices.py) in this process, against the rig
(tests/fixtures/runtime/rig): its `tank` device served by the PLC's Modbus bank on a free
loopback port, in an event loop of the test's own. test_io.py and test_io_scenario.py run
the same tools as the separate OS processes they are in use; here their logic runs where a
line tracer sees it (`make mutate-sample` maps these tests), in a few seconds. A bank, a
server and a port opened here are closed before a test ends.
"""

from __future__ import annotations

import argparse
import asyncio
import importlib
import json
import os
import shutil
import socket
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any
from urllib.parse import urlsplit

import pytest
from conftest import until, wait_for

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.runtime.io_cycle import make_link, relocated
from rcsgen.runtime.io_points import INPUT_REGISTER, Point
from rcsgen.tools import io_connect, softplc
from rcsgen.tools.harness import generate, import_package

pytest.importorskip("pymodbus")

RIG = Path(__file__).resolve().parent / "fixtures" / "runtime" / "rig"


@pytest.fixture(scope="module")
def rig() -> Iterator[Path]:
    scratch, name = generate(RIG)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def layout(rig: Path) -> ModuleType:
    return importlib.import_module(f"{import_package(rig, RIG).__name__}.layout")


@pytest.fixture(scope="module")
def system() -> IRSystem:
    front = compile_paths([RIG])
    assert not front.diagnostics.errors
    return front.systems[0]


def free_port() -> int:
    with socket.socket() as unused:
        unused.bind(("127.0.0.1", 0))
        return int(unused.getsockname()[1])


def listening(port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(0.5)
        return probe.connect_ex(("127.0.0.1", port)) == 0


def serve(
    rig: Path,
    tmp_path: Path,
    device: str,
    client: Callable[..., Any],
    world: tuple[str, ...] = ("level=1.25",),
) -> tuple[Any, dict[str, Any]]:
    """The rig's PLC serving `device` (names, space-separated) on free ports in this
    process's event loop, cycling every 20 ms, while `client(port, ..., control, plant)` runs
    in a thread; then the PLC stopped (its finally: the bank shut, the report written).
    (client's result, the report)."""
    package = import_package(rig, RIG)
    layout = importlib.import_module(f"{package.__name__}.layout")
    plant = softplc.Plant(package, {})
    for item in world:
        plant.set(item)
    ready, report, control = tmp_path / "ready", tmp_path / "report.json", tmp_path / "control"
    control.mkdir(exist_ok=True)
    names = device.split()
    args = argparse.Namespace(
        host="127.0.0.1",
        port=[0] * len(names),
        ready=str(ready),
        control=str(control),
        period=0.02,
        cycles=None,
        report=str(report),
    )

    async def run() -> Any:
        devices = [layout.IO_DEVICES[name] for name in names]
        serving = asyncio.create_task(softplc._serve(args, plant, devices))
        try:
            await until(
                None,
                lambda: ready.is_file() and ready.read_text().count("\n") == len(names),
                "ready",
            )
            ports = [int(line) for line in ready.read_text().split()]
            return await asyncio.to_thread(client, *ports, control, plant)
        finally:
            serving.cancel()
            with pytest.raises(asyncio.CancelledError):
                await serving

    got = asyncio.run(run())
    return got, json.loads(report.read_text())


def test_the_plc_carries_commands_into_its_plant_and_the_plants_values_out(
    rig: Path, layout: ModuleType, tmp_path: Path
) -> None:
    declared = layout.IO_DEVICES["tank"]
    level, valve = (
        next(p for p in declared.points if p.field == f) for f in ("level", "valve_cmd")
    )

    def client(port: int, control: Path, plant: softplc.Plant) -> tuple[object, object]:
        link = make_link(replace(declared, port=port))
        link.connect()
        try:
            first = link.read_point(level)
            link.write({"valve_cmd": 42.5})
            wait_for(
                lambda: (
                    link.read_point(valve) == pytest.approx(42.5)
                    and plant.read("valve_cmd") == pytest.approx(42.5)
                ),
                "the command on its point and in the plant's world",
                deadline=30,
            )
            return first, link.read_point(valve)
        finally:
            link.close()

    (first, held), world = serve(rig, tmp_path, "tank", client, ("level=1.25",))
    assert first == pytest.approx(1.25)  # the plant's value on the point before any poll
    assert held == pytest.approx(42.5)
    assert world["valve_cmd"] == pytest.approx(42.5)  # the command crossed into the plant
    assert world["level"] == pytest.approx(1.25) and world["_cycles"] > 1


def test_an_opc_ua_device_is_served_at_its_endpoints_path_and_its_nodes_written_through(
    rig: Path, layout: ModuleType, system: IRSystem, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The pumps (OPC UA, `opc.tcp://.../rig`) and the tank (Modbus) on one PLC: the client
    reaches the nodes at the declared endpoint path, its writes reach the plant; both
    devices answer `validate --connect` with every point."""
    declared = layout.IO_DEVICES["pumps"]

    def client(
        tank: int, pumps: int, control: Path, plant: softplc.Plant
    ) -> tuple[list[str], object]:
        url = f"opc.tcp://127.0.0.1:{pumps}/rig"
        link = make_link(replace(declared, port=pumps, url=url))
        link.connect()
        try:
            link.write({"pump_on": True, "alarm": False})
            alarm = next(p for p in declared.points if p.field == "alarm")
            wait_for(
                lambda: (
                    link.read_point(alarm) is False
                    and plant.read("pump_on") is True
                    and plant.read("alarm") is False
                ),
                "the writes on their nodes and in the plant's world",
                deadline=30,
            )
            held = link.read_point(alarm)
        finally:
            link.close()
        monkeypatch.setenv("RCSGEN_IO_TANK", f"127.0.0.1:{tank}")
        monkeypatch.setenv("RCSGEN_IO_PUMPS", url)
        return [d.render() for d in io_connect.check_devices(system)], held

    (said, held), world = serve(rig, tmp_path, "tank pumps", client)
    assert said == [] and held is False
    assert world["pump_on"] is True and world["alarm"] is False


def test_an_unplugged_device_refuses_connections_and_comes_back_on_its_port(
    rig: Path, layout: ModuleType, tmp_path: Path
) -> None:
    def client(port: int, control: Path, _plant: softplc.Plant) -> list[bool]:
        seen = [listening(port)]
        for order in ("unplug", "replug"):
            (control / "tank").write_text(order)
            end = time.monotonic() + 30
            while listening(port) != (order == "replug") and time.monotonic() < end:
                time.sleep(0.02)
            seen.append(listening(port))
        return seen

    seen, _ = serve(rig, tmp_path, "tank", client)
    assert seen == [True, False, True]


@pytest.mark.parametrize("device", ["tank", "pumps"])
def test_a_bank_holds_its_starting_values_before_it_listens(
    layout: ModuleType, device: str
) -> None:
    """A device plugged in again takes the plant's values before its server listens: a
    client's write made as soon as the port opens is never overwritten by them (a bench's
    replug, then a freeze and a client's write, read back 0 in CI when they came after).
    An OPC UA node's namespace is registered on the server (its index names an entry of the
    server's namespace array, as a client browsing the server reads it), and its endpoints
    are served at the declared URL's path."""
    declared = layout.IO_DEVICES[device]
    if declared.protocol == "opcua":
        pytest.importorskip("asyncua")
    values = [(p, True if p.value_type == "bool" else 3) for p in declared.points]

    async def run() -> tuple[dict[str, object], list[str], set[str]]:
        bank = softplc._bank(declared, "127.0.0.1", 0)
        seen: dict[str, object] = {}
        namespaces: list[str] = []
        paths: set[str] = set()
        server: Any = bank.server
        listen = "serve_forever" if isinstance(bank, softplc.ModbusBank) else "start"
        original = getattr(server, listen)

        async def listening_now(*args: Any, **kwargs: Any) -> Any:
            for point, _ in values:
                seen[point.field] = await bank.get(point)
            if isinstance(bank, softplc.OpcUaBank):
                namespaces[:] = await server.get_namespace_array()
            return await original(*args, **kwargs)

        setattr(server, listen, listening_now)
        try:
            await bank.start(values)
            await until(None, lambda: len(seen) == len(values), "listening")
            if isinstance(bank, softplc.OpcUaBank):  # the path its endpoints are served at
                paths.update(urlsplit(e.EndpointUrl).path for e in await server.get_endpoints())
        finally:
            await bank.stop()
        return seen, namespaces, paths

    seen, namespaces, paths = asyncio.run(run())
    assert seen == {p.field: v for p, v in values}
    if declared.protocol == "opcua":  # the rig's nodes are in ns=2: one namespace added
        assert {str(p.address).split(";")[0] for p in declared.points} == {"ns=2"}
        assert namespaces[2:] == ["urn:rcsgen:softplc:0"]
        assert urlsplit(declared.url).path == "/rig" and paths == {"/rig"}


def test_validate_connect_names_a_device_that_does_not_answer_and_a_point_it_lacks(
    rig: Path, system: IRSystem, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tank = next(d for d in system.io if d.name == "tank")
    missing = Point("level", INPUT_REGISTER, 40, False, "float", scale=0.01)
    lacking = replace(
        system,
        io=tuple(replace(d, points=(*d.points, missing)) if d is tank else d for d in system.io),
    )
    dead = free_port()

    served: list[int] = []

    def client(port: int, control: Path, _plant: softplc.Plant) -> tuple[list[str], list[str]]:
        served.append(port)
        monkeypatch.setenv("RCSGEN_IO_TANK", f"127.0.0.1:{port}")
        monkeypatch.setenv("RCSGEN_IO_PUMPS", f"opc.tcp://127.0.0.1:{dead}/rig")
        every = io_connect.check_devices(system)
        some = io_connect.check_devices(lacking)
        return [d.render() for d in every], [d.render() for d in some]

    (every, some), _ = serve(rig, tmp_path, "tank", client)
    # the tank's PLC has every point it declares; the pumps' OPC UA server is not there
    assert len(every) == 1, every
    assert (
        "E458" in every[0]
        and f"device `pumps` does not answer at opc.tcp://127.0.0.1:{dead}/rig" in every[0]
    )
    assert "RCSGEN_IO_PUMPS=... points the check elsewhere" in every[0]
    refused = [d for d in some if "tank" in d]
    assert len(refused) == 1, some
    assert (
        f"device `tank` at 127.0.0.1:{served[0]} has no input_register 40 for `level`: "
        in (refused[0])
    ), refused[0]
    assert "system.yaml:" in refused[0]

    monkeypatch.setenv("RCSGEN_IO_TANK", "not an address")
    monkeypatch.setenv("RCSGEN_IO_PUMPS", f"opc.tcp://127.0.0.1:{dead}/rig")
    said = [d.render() for d in io_connect.check_devices(system)]
    assert any(
        "error[E458]: RCSGEN_IO_TANK='not an address': not an address of I/O device tank "
        "(HOST:PORT)" in s
        for s in said
    ), said


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--device", "nope"], "declares no I/O device 'nope' (it has: ['pumps', 'tank'])"),
        (["--device", "tank", "--port", "1", "--port", "2"], "2 --port for 1 --device"),
        (["--device", "tank", "--set", "novalue"], "--set 'novalue': expected KEY=VALUE"),
        (
            ["--device", "tank", "--world", "level"],
            "--world 'level': expected FIELD=VALUE, FIELD a world field",
        ),
        (
            ["--device", "tank", "--world", "levl=1"],
            "--world 'levl=1': expected FIELD=VALUE, FIELD a world field",
        ),
        (["--device", "tank", "--world", "level=abc"], "--world 'level=abc': 'abc' is not a value"),
        (
            ["--device", "tank", "--world", 'level="x"'],
            """--world 'level="x"': '"x"' is not a number or a bool""",
        ),
    ],
)
def test_the_plc_refuses_a_bad_argument_in_one_line(
    rig: Path, argv: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert softplc.main(["--io", str(rig), "--hooks", str(RIG), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("softplc: ") and said in err, err
    assert len(err.strip().splitlines()) == 1


def test_the_plc_needs_the_package_and_a_device(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        softplc.main([])
    assert done.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (
        "python -m rcsgen.tools.softplc: error: the following arguments are required: --io, "
        "--device"
    )


def test_the_plc_refuses_a_plant_without_a_field_its_device_binds(
    rig: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    duo = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"
    scratch, name = generate(duo)
    try:
        argv = ["--io", str(rig), "--device", "tank", "--plant", str(scratch / name)]
        assert softplc.main([*argv, "--hooks", str(duo)]) == 2
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    assert capsys.readouterr().err == (
        "softplc: the plant has no world field 'level' that device tank binds\n"
    )


def test_the_plc_runs_its_cycles_and_reports_its_plants_world(
    rig: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ready, report = tmp_path / "ready", tmp_path / "report.json"
    code = softplc.main(
        [
            "--io",
            str(rig),
            "--hooks",
            str(RIG),
            "--device",
            "tank",
            "--port",
            "0",
            "--cycles",
            "3",
            "--world",
            "level=2.5",
            "--world",
            "valve_cmd=7",
            "--ready",
            str(ready),
            "--report",
            str(report),
        ]
    )
    assert code == 0, capsys.readouterr().err
    assert int(ready.read_text()) > 0 and ready.read_text().count("\n") == 1
    world = json.loads(report.read_text())
    assert list(world) == sorted(world)  # the same plant, the same report, byte for byte
    assert world["_cycles"] == 3
    assert world["level"] == pytest.approx(2.5)
    assert world["valve_cmd"] == pytest.approx(7.0)


def test_the_plc_names_the_extra_a_devices_protocol_needs(monkeypatch: pytest.MonkeyPatch) -> None:
    class Device:
        name, protocol = "pumps", "opcua"

    monkeypatch.setattr(softplc.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(
        ImportError, match=r"device pumps \(opcua\) needs asyncua: pip install 'rcsgen\[opcua\]'"
    ):
        softplc._libraries_there([Device()])
    Device.protocol = "modbus_tcp"
    with pytest.raises(ImportError, match=r"needs pymodbus: pip install 'rcsgen\[modbus\]'"):
        softplc._libraries_there([Device()])


def test_relocated_takes_the_address_from_the_environment(layout: ModuleType) -> None:
    tank, pumps = layout.IO_DEVICES["tank"], layout.IO_DEVICES["pumps"]
    moved = relocated(tank, {"RCSGEN_IO_TANK": "10.0.0.2:5020"})
    assert (moved.host, moved.port, moved.url) == ("10.0.0.2", 5020, "")
    assert relocated(tank, {}) is tank
    url = "opc.tcp://[::1]:4840/rig"
    moved = relocated(pumps, {"RCSGEN_IO_PUMPS": url})
    assert (moved.host, moved.port, moved.url) == ("::1", 4840, url)
    with pytest.raises(ValueError, match="not an address of I/O device tank"):
        relocated(tank, {"RCSGEN_IO_TANK": "10.0.0.2:0"})


# ------------------------------------------------------------ a scenario's device bench


def scenario_with(devices: dict[str, Path | None], settings: dict[str, str] | None = None) -> Any:
    from rcsgen.compiler.diagnostics import Span
    from rcsgen.tools.scenario.model import Scenario, SoftPlc

    where = RIG / "scenarios" / "bench.yaml"
    return Scenario(
        name="bench",
        title="the bench",
        path=where,
        system_dir=RIG,
        process=None,
        max_cycles=10,
        stop_when_done=None,
        trace_world=[],
        events=[],
        settings=settings or {},
        devices={name: SoftPlc(name, plant, Span(where)) for name, plant in devices.items()},
    )


def open_valve(layout: ModuleType) -> None:
    """A client opens the tank's valve on its PLC (wherever RCSGEN_IO_TANK points)."""
    link = make_link(relocated(layout.IO_DEVICES["tank"]))
    link.connect()
    try:
        link.write({"valve_cmd": 50.0})
    finally:
        link.close()


def test_a_scenarios_bench_serves_each_device_and_pulls_its_plug_and_freezes_it(
    rig: Path, layout: ModuleType, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two PLCs of their own (no plant): each device pointed at its PLC's port for the run,
    unplugged (port closed) and plugged in again, its PLC frozen and thawed, the devices
    down tracked; the outputs read back against the safe values; at the end every PLC
    stopped, its port closed, the environment as it was."""
    from rcsgen.tools.scenario.devices import Bench

    monkeypatch.setenv("RCSGEN_IO_TANK", "10.1.1.1:502")
    monkeypatch.delenv("RCSGEN_IO_PUMPS", raising=False)
    bench = Bench(scenario_with({"tank": None, "pumps": None}), rig, tmp_path)
    try:
        bench.start(layout)
        tank, pumps = bench.plcs["tank"], bench.plcs["pumps"]
        assert tank is not pumps and tank.names == ["tank"]
        port, url = tank.ports["tank"], pumps.ports["pumps"]
        assert os.environ["RCSGEN_IO_TANK"] == f"127.0.0.1:{port}"
        assert os.environ["RCSGEN_IO_PUMPS"] == f"opc.tcp://127.0.0.1:{url}/rig"
        assert listening(port) and listening(url)
        # a fresh PLC holds its outputs at the initial values, the safe ones here; a valve
        # opened by a client is read back as not safe
        assert bench.not_safe_on_survivors(layout) == []
        open_valve(layout)
        assert bench.not_safe_on_survivors(layout) == [
            "device `tank` holds `valve_cmd` 50.0, not its safe 0.0"
        ]
        bench.apply("tank", "unplug")
        assert not listening(port) and bench.down == {"tank"}
        bench.apply("tank", "replug")
        assert listening(port) and bench.down == set()
        bench.apply("tank", "freeze")
        assert bench.down == {"tank"}
        assert bench.not_safe_on_survivors(layout) == []  # a frozen device is not asked
        bench.apply("tank", "thaw")
        assert bench.down == set()
        open_valve(layout)  # answering again: read back again
        assert len(bench.not_safe_on_survivors(layout)) == 1
    finally:
        bench.close()
    assert os.environ["RCSGEN_IO_TANK"] == "10.1.1.1:502"
    assert "RCSGEN_IO_PUMPS" not in os.environ
    assert not listening(port) and not listening(url)
    for plc in (tank, pumps):
        assert plc.popen is not None and plc.popen.poll() is not None


def test_a_bench_says_which_plc_did_not_start_and_why(
    rig: Path, layout: ModuleType, tmp_path: Path
) -> None:
    from rcsgen.tools.scenario.devices import Bench, DeviceStartError

    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "system.yaml").write_text("system: broken\n")
    bench = Bench(scenario_with({"tank": broken}), rig, tmp_path / "one")
    with pytest.raises(DeviceStartError) as error:
        bench.start(layout)
    bench.close()
    assert str(error.value) == (
        f"the soft PLC of device `tank` did not start: its plant {broken} does not build"
    )
    # a PLC that exits at once: what it said last is the reason
    nothing = tmp_path / "nothing"
    bench = Bench(scenario_with({"tank": None}), nothing, tmp_path / "two")
    try:
        with pytest.raises(DeviceStartError) as error:
            bench.start(layout)
    finally:
        bench.close()
    assert str(error.value) == (
        f"the soft PLC of device `tank` did not start: softplc: no generated package in {nothing}"
    )


def test_the_plcs_help_says_what_it_is(capsys: pytest.CaptureFixture[str]) -> None:
    """The help word for word (however wide the terminal wraps it): what the PLC is, and what
    each option means, the files it writes for the bench (a scenario's bench reads them)."""
    with pytest.raises(SystemExit) as done:
        softplc.main(["--help"])
    assert done.value.code == 0
    said = capsys.readouterr().out
    assert said.startswith("usage: python -m rcsgen.tools.softplc ")
    words = " ".join(said.split())
    described = (
        "A soft PLC: a system's simulators behind Modbus TCP or OPC UA servers, for hardware in "
        "the loop."
    )
    assert described in words
    assert words.split("options: ", 1)[1] == " ".join(
        (
            "-h, --help show this help message and exit",
            "--plant PLANT the generated package whose simulators run here (default: none, a",
            "PLC whose inputs hold --io's initial world values, or --world's)",
            "--hooks HOOKS the plant's spec directory (its hook modules)",
            "--io IO the generated package that declares the device",
            "--device DEVICE a device this PLC serves (repeatable: one plant behind several",
            "devices)",
            "--host HOST",
            "--port PORT the port of each --device, in their order (default: the declared one;",
            "0: any)",
            "--period PERIOD seconds per PLC cycle (default: the devices' shortest poll period)",
            "--control CONTROL a directory: a file named after a device holding `unplug` stops",
            "its server (connections closed, new ones refused), `replug` starts it again on its",
            "port",
            "--cycles CYCLES stop after this many cycles",
            "--set KEY=VALUE a run setting of the plant",
            "--world FIELD=VALUE start the plant's world field FIELD at VALUE (repeatable)",
            "--report REPORT write the plant's world here (JSON) when stopped",
            "--ready READY write the ports here once listening (a line per --device, in order)",
        )
    )


def test_a_plant_runs_its_packages_simulators_and_nothing_else(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The PLC's plant is the package's simulator modules alone (the cell's `arm`), each a
    root where nothing of the plant supervises it, run a cycle at a time."""
    repo = RIG.parents[3]
    monkeypatch.setattr(sys, "path", list(sys.path))  # the hooks' directory put first: undone
    plant = softplc.Plant(import_package(repo / "generated" / "cell", repo / "specs" / "cell"), {})
    assert plant.layout.SIMULATORS == ("arm",)
    assert list(plant.process.instances) == ["arm"] and plant.process.plan.roots == ("arm",)
    plant.process.run_cycle()
    assert plant.process.cycle == 1


def test_a_cycle_waits_the_rest_of_its_period_and_a_late_one_does_not_catch_up() -> None:
    assert softplc._paced(10.5, 10.0) == (10.5, 0.5)  # early: the rest of the period
    assert softplc._paced(10.0, 10.0) == (10.0, 0.0)
    assert softplc._paced(10.0, 10.25) == (10.25, 0.0)  # late: the next period from now
