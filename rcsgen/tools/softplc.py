"""A soft PLC: a system's simulators behind Modbus TCP or OPC UA servers, for hardware in the loop.

`python -m rcsgen.tools.softplc --plant generated/miner --hooks specs/miner --io
generated/miner_hil --device plc --port 5020` runs the plant package's simulator modules
(the miner's actuator, sensor, mine and operator simulators, `simulators:` in its spec) on
a private block, paced, and serves the points the I/O system declares for `--device` on
pymodbus's TCP server. Each PLC cycle: the coils and holding registers (the controllers'
commands) into the plant's world fields, one cycle of the simulators, then the plant's
sensed fields onto the discrete inputs and input registers. The values cross with the same
codecs as the I/O module's (rcs/io_points.py), so scaling, signedness and word order are
exercised both ways.

It is a separate OS process, as a PLC is a separate machine: a test pulls the plug by
killing it (SIGKILL) or freezing it (SIGSTOP). On SIGTERM or SIGINT it stops, writes the
plant's world as JSON to `--report` if given, and exits 0. `--ready FILE` is written once
the servers listen (the port each listens on, a line per device, for `--port 0`). Needs
`rcsgen[modbus]`.

One PLC can serve several devices of the I/O system over one plant (`--device` repeated,
a `--port` each): a Modbus TCP device and an OPC UA device on one machine's simulators, as
a PLC with both interfaces. `--control DIR` lets a test or a scenario unplug one of them
(its server stopped, connections closed, new ones refused) while the plant and the other
devices go on, and plug it in again on its port.

A device declared `protocol: opcua` is served the same way by asyncua's server (needs
`rcsgen[opcua]`): a variable of its field's type at each declared node id.
"""

from __future__ import annotations

import argparse
import asyncio
import importlib
import importlib.util
import json
import logging
import signal
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

from ..runtime.io_points import (
    COIL,
    DISCRETE_INPUT,
    HOLDING_REGISTER,
    INPUT_REGISTER,
    OPCUA,
    decode,
    encode,
)
from .harness import import_package

# pymodbus function codes of the four tables (the datastore is addressed by them)
FUNCTION = {COIL: 1, DISCRETE_INPUT: 2, HOLDING_REGISTER: 3, INPUT_REGISTER: 4}


class Plant:
    """The plant package's simulators on a private block: one cycle at a time."""

    def __init__(self, package: ModuleType, settings: dict[str, str]) -> None:
        name = package.__name__
        self.layout = importlib.import_module(f"{name}.layout")
        loop = importlib.import_module(f"{name}.rcs.loop")
        block = importlib.import_module(f"{name}.rcs.block").Block(self.layout)
        simulators = set(self.layout.SIMULATORS)
        plans = [importlib.import_module(f"{name}.main_{p}").PLAN for p in self.layout.PROCESSES]
        modules = tuple(m for plan in plans for m in plan.modules if m in simulators)
        classes = {m: plan.classes[m] for plan in plans for m in plan.modules if m in simulators}
        supervised = {s for subs in self.layout.SUBORDINATES.values() for s in subs}
        plan = loop.ProcessPlan(
            name=plans[0].name,
            cycle_period=plans[0].cycle_period,
            modules=modules,
            roots=tuple(m for m in modules if m not in supervised),
            classes=classes,
        )
        self.process = loop.Process(plan, self.layout, block, settings)
        self.process.send_init()
        self.buf = block.buf

    def read(self, field: str) -> object:
        return self.layout.WORLD[field].read(self.buf)[field]

    def write(self, field: str, value: object) -> None:
        self.layout.WORLD[field].write(self.buf, **{field: value})

    def set(self, item: str) -> None:
        """FIELD=VALUE (`--world`): the field starts at VALUE. ValueError, one line, else."""
        name, equals, text = item.partition("=")
        if not equals or name not in self.layout.WORLD:
            raise ValueError(f"--world {item!r}: expected FIELD=VALUE, FIELD a world field")
        try:
            value = json.loads(text)
        except json.JSONDecodeError:
            raise ValueError(f"--world {item!r}: {text!r} is not a value") from None
        if not isinstance(value, bool | int | float):
            raise ValueError(f"--world {item!r}: {text!r} is not a number or a bool")
        self.write(name, value)

    def world(self) -> dict[str, object]:
        return {f: self.read(f) for f in self.layout.WORLD}


class ModbusBank:
    """The device's points as pymodbus's TCP server and its four tables, each as long as
    the device's points need; values cross with the I/O module's codecs."""

    def __init__(self, device: Any, host: str, port: int) -> None:
        from pymodbus.server import ModbusTcpServer
        from pymodbus.simulator import DataType, SimData, SimDevice

        def table(kind: str) -> list[Any]:
            end = max(
                (int(p.address) + p.registers for p in device.points if p.kind == kind), default=1
            )
            if kind in (COIL, DISCRETE_INPUT):
                return [SimData(0, count=end, values=False, datatype=DataType.BITS)]
            return [SimData(0, count=end, values=0, datatype=DataType.REGISTERS)]

        kinds = (COIL, DISCRETE_INPUT, HOLDING_REGISTER, INPUT_REGISTER)
        tables: Any = tuple(table(kind) for kind in kinds)
        store = SimDevice(device.unit, simdata=tables)
        self.server = ModbusTcpServer(store, address=(host, port))
        self.unit, self.asked = device.unit, port
        self.serving: asyncio.Task[Any] | None = None

    async def start(self, values: list[tuple[Any, object]]) -> int:
        for point, value in values:  # on the tables before any client can connect
            await self.put(point, value)
        self.serving = asyncio.create_task(self.server.serve_forever())
        for _ in range(500):  # the port it listens on (the one the system chose for port 0)
            sockets = getattr(getattr(self.server, "transport", None), "sockets", None)
            if sockets:
                return int(sockets[0].getsockname()[1])
            await asyncio.sleep(0.01)
        return self.asked

    async def get(self, point: Any) -> object:
        words = await self.server.async_getValues(
            self.unit, FUNCTION[point.kind], int(point.address), point.registers
        )
        return decode(point, [int(w) for w in words])

    async def put(self, point: Any, value: object) -> None:
        words, _ = encode(point, value)
        values: list[Any] = [bool(w) for w in words] if point.kind == DISCRETE_INPUT else words
        await self.server.async_setValues(
            self.unit, FUNCTION[point.kind], int(point.address), values
        )

    async def stop(self) -> None:
        await self.server.shutdown()  # type: ignore[no-untyped-call]
        if self.serving is not None:
            self.serving.cancel()


class OpcUaBank:
    """The device's nodes on asyncua's server, each a variable of its field's type at the
    node id the device declares (its namespace registered), writable by clients."""

    def __init__(self, device: Any, host: str, port: int) -> None:
        from asyncua.server.server import Server

        logging.getLogger("asyncua").setLevel(logging.ERROR)  # its notes on security: none here

        self.device, self.host, self.port = device, host, port
        self.server = Server()
        self.nodes: dict[str, Any] = {}

    async def start(self, values: list[tuple[Any, object]]) -> int:
        from asyncua import ua

        server = self.server
        await server.init()
        server.set_endpoint(f"opc.tcp://{self.host}:{self.port}/{endpoint_path(self.device.url)}")
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
        kinds = {"bool": ua.VariantType.Boolean, "int": ua.VariantType.Int64}
        zero = {"bool": False, "int": 0}
        for point in self.device.points:
            node_id = ua.NodeId.from_string(str(point.address))
            while len(await server.get_namespace_array()) <= node_id.NamespaceIndex:
                await server.register_namespace(f"urn:rcsgen:softplc:{len(self.nodes)}")
            node = await server.nodes.objects.add_variable(
                node_id,
                ua.QualifiedName(point.field, node_id.NamespaceIndex),
                ua.Variant(
                    zero.get(point.value_type, 0.0),
                    kinds.get(point.value_type, ua.VariantType.Double),
                ),
            )
            await node.set_writable()
            self.nodes[point.field] = node
        for point, value in values:  # on the nodes before any client can connect
            await self.put(point, value)
        await server.start()
        listening: Any = server.bserver._server if server.bserver else None
        sockets = listening.sockets if listening is not None else ()
        return int(sockets[0].getsockname()[1]) if sockets else self.port

    async def get(self, point: Any) -> object:
        return await self.nodes[point.field].read_value()

    async def put(self, point: Any, value: object) -> None:
        from asyncua import ua

        kinds = {"bool": ua.VariantType.Boolean, "int": ua.VariantType.Int64}
        typed = {"bool": bool, "int": int}.get(point.value_type, float)(value)
        variant = ua.Variant(typed, kinds.get(point.value_type, ua.VariantType.Double))
        await self.nodes[point.field].write_value(variant)

    async def stop(self) -> None:
        await self.server.stop()


def endpoint_path(url: str) -> str:
    """An OPC UA endpoint URL's path (`opc.tcp://host:port/PATH` -> `PATH`; '' for none):
    where the PLC serves the device, on whatever host and port."""
    return url.split("/", 3)[3] if url.count("/") >= 3 else ""


def _bank(device: Any, host: str, port: int) -> ModbusBank | OpcUaBank:
    return (OpcUaBank if device.protocol == OPCUA else ModbusBank)(device, host, port)


class Served:
    """One device this PLC serves: its bank while it is plugged in, None while unplugged
    (`--control`), and the port it keeps for when it is plugged in again."""

    def __init__(self, device: Any, host: str, port: int) -> None:
        self.device, self.host, self.port = device, host, port
        self.bank: ModbusBank | OpcUaBank | None = _bank(device, host, port)

    async def start(self, plant: Plant) -> None:
        assert self.bank is not None
        # The plant's values on every point, as a PLC has them before any poll: put there
        # before the server listens, so that no client's write is overwritten by them.
        values = [(point, plant.read(point.field)) for point in self.device.points]
        self.port = await self.bank.start(values)

    async def control(self, wanted: str, plant: Plant) -> None:
        """`unplug`: the server stopped (its connections closed, new ones refused); `replug`:
        a server again on the same port, the plant's values on it."""
        if wanted == "unplug" and self.bank is not None:
            await self.bank.stop()
            self.bank = None
        elif wanted == "replug" and self.bank is None:
            self.bank = _bank(self.device, self.host, self.port)
            await self.start(plant)


async def _cycle(served: list[Served], plant: Plant, control: Path | None) -> None:
    """One PLC cycle: each device's plug as `--control` orders, the commands the devices
    hold into the plant, one cycle of its simulators, its sensed values onto the devices."""
    for each in served:
        if control is not None and (control / each.device.name).is_file():
            await each.control((control / each.device.name).read_text("utf-8").strip(), plant)
        if each.bank is not None:
            for point in each.device.outputs:
                plant.write(point.field, await each.bank.get(point))
    plant.process.run_cycle()
    for each in served:
        if each.bank is not None:
            for point in each.device.inputs:
                await each.bank.put(point, plant.read(point.field))


def _libraries_there(devices: list[Any]) -> None:
    """ImportError, one line naming the extra, for a device whose protocol library is not
    installed: found before any server starts, not as a traceback from inside one."""
    for device in devices:
        package, extra = (
            ("asyncua", "opcua") if device.protocol == OPCUA else ("pymodbus", "modbus")
        )
        if importlib.util.find_spec(package) is None:
            raise ImportError(
                f"device {device.name} ({device.protocol}) needs {package}: "
                f"pip install 'rcsgen[{extra}]'"
            )


def _paced(due: float, now: float) -> tuple[float, float]:
    """(when the next cycle is due, the seconds to wait for it): the rest of its period; a
    cycle that ran past it makes the next one due now, not a burst of cycles catching up."""
    if due < now:
        return now, 0.0
    return due, due - now


async def _serve(args: argparse.Namespace, plant: Plant, devices: list[Any]) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(signum, stop.set)
    served = [Served(d, args.host, port) for d, port in zip(devices, args.port, strict=True)]
    for each in served:
        await each.start(plant)
    if args.ready:
        Path(args.ready).write_text("".join(f"{s.port}\n" for s in served), encoding="utf-8")
    control = Path(args.control) if args.control else None
    period = args.period
    next_at = time.monotonic()
    cycles = 0
    try:
        while not stop.is_set() and (args.cycles is None or cycles < args.cycles):
            await _cycle(served, plant, control)
            cycles += 1
            next_at, delay = _paced(next_at + period, time.monotonic())
            try:
                await asyncio.wait_for(stop.wait(), delay)
            except TimeoutError:
                pass
    finally:
        for each in served:
            if each.bank is not None:
                await each.bank.stop()
        if args.report:
            world = plant.world()
            world["_cycles"] = cycles
            Path(args.report).write_text(json.dumps(world, sort_keys=True) + "\n", encoding="utf-8")
    return 0


def _devices(args: argparse.Namespace, declared: dict[str, Any]) -> list[Any]:
    """The devices `--device` names, each once, in order; ValueError for one not declared
    or more ports than devices."""
    unknown = [name for name in args.device if name not in declared]
    if unknown:
        known = sorted(declared) or "none"
        raise ValueError(f"{args.io} declares no I/O device {unknown[0]!r} (it has: {known})")
    devices = [declared[name] for name in dict.fromkeys(args.device)]
    if len(args.port) > len(devices):
        raise ValueError(f"{len(args.port)} --port for {len(devices)} --device")
    return devices


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m rcsgen.tools.softplc", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--plant",
        help="the generated package whose simulators run here (default: none, a PLC whose "
        "inputs hold --io's initial world values, or --world's)",
    )
    parser.add_argument("--hooks", help="the plant's spec directory (its hook modules)")
    parser.add_argument(
        "--io", required=True, help="the generated package that declares the device"
    )
    parser.add_argument(
        "--device",
        required=True,
        action="append",
        help="a device this PLC serves (repeatable: one plant behind several devices)",
    )
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument(
        "--port",
        type=int,
        action="append",
        default=[],
        help="the port of each --device, in their order (default: the declared one; 0: any)",
    )
    parser.add_argument(
        "--period",
        type=float,
        help="seconds per PLC cycle (default: the devices' shortest poll period)",
    )
    parser.add_argument(
        "--control",
        help="a directory: a file named after a device holding `unplug` stops its server "
        "(connections closed, new ones refused), `replug` starts it again on its port",
    )
    parser.add_argument("--cycles", type=int, help="stop after this many cycles")
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="a run setting of the plant"
    )
    parser.add_argument(
        "--world",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="start the plant's world field FIELD at VALUE (repeatable)",
    )
    parser.add_argument("--report", help="write the plant's world here (JSON) when stopped")
    parser.add_argument(
        "--ready", help="write the ports here once listening (a line per --device, in order)"
    )
    args = parser.parse_args(argv)
    try:
        io = importlib.import_module(f"{import_package(Path(args.io).resolve()).__name__}.layout")
        devices = _devices(args, getattr(io, "IO_DEVICES", {}))
        settings = dict(item.split("=", 1) for item in args.set if "=" in item)
        bad = [item for item in args.set if "=" not in item]
        if bad:
            raise ValueError(f"--set {bad[0]!r}: expected KEY=VALUE")
        hooks = Path(args.hooks).resolve() if args.hooks else None
        plant = Plant(import_package(Path(args.plant or args.io).resolve(), hooks), settings)
        for item in args.world:
            plant.set(item)
        missing = [(d.name, p.field) for d in devices for p in d.points]
        missing = [(d, f) for d, f in missing if f not in plant.layout.WORLD]
        if missing:
            raise ValueError(
                f"the plant has no world field {missing[0][1]!r} that device {missing[0][0]} binds"
            )
        _libraries_there(devices)
    except (ValueError, OSError, ImportError) as error:
        print(f"softplc: {error}", file=sys.stderr)
        return 2
    args.port += [d.port for d in devices[len(args.port) :]]
    args.period = args.period or min(d.poll_period for d in devices)
    return asyncio.run(_serve(args, plant, devices))


if __name__ == "__main__":
    sys.exit(main())
