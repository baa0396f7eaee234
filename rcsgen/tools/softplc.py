"""A soft PLC: a system's simulators behind a Modbus TCP server, for hardware in the loop.

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
the server listens (the port it listens on, for `--port 0`). Needs `rcsgen[modbus]`.
"""

from __future__ import annotations

import argparse
import asyncio
import importlib
import json
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

    def world(self) -> dict[str, object]:
        return {f: self.read(f) for f in self.layout.WORLD}


def _datastore(device: Any) -> Any:
    """pymodbus's device with four tables, each as long as the device's points need."""
    from pymodbus.simulator import DataType, SimData, SimDevice

    def table(kinds: tuple[str, ...], bits: bool) -> list[Any]:
        end = max(
            (int(p.address) + p.registers for p in device.points if p.kind in kinds), default=1
        )
        if bits:
            return [SimData(0, count=end, values=False, datatype=DataType.BITS)]
        return [SimData(0, count=end, values=0, datatype=DataType.REGISTERS)]

    return SimDevice(
        device.unit,
        simdata=(
            table((COIL,), True),
            table((DISCRETE_INPUT,), True),
            table((HOLDING_REGISTER,), False),
            table((INPUT_REGISTER,), False),
        ),
    )


async def _serve(args: argparse.Namespace, plant: Plant, device: Any) -> int:
    from pymodbus.server import ModbusTcpServer

    server = ModbusTcpServer(_datastore(device), address=(args.host, args.port))
    serving = asyncio.create_task(server.serve_forever())
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(signum, stop.set)
    port = await _listening_port(server, args.port)
    if args.ready:
        Path(args.ready).write_text(f"{port}\n", encoding="utf-8")
    outputs, inputs = device.outputs, device.inputs
    unit = device.unit
    # Start with the plant's sensed values on the inputs, as a PLC has them before any poll.
    await _publish(server, plant, inputs, unit)
    period = args.period
    next_at = time.monotonic()
    cycles = 0
    try:
        while not stop.is_set() and (args.cycles is None or cycles < args.cycles):
            for point in outputs:
                words = await server.async_getValues(
                    unit, FUNCTION[point.kind], int(point.address), point.registers
                )
                plant.write(point.field, decode(point, [int(w) for w in words]))
            plant.process.run_cycle()
            await _publish(server, plant, inputs, unit)
            cycles += 1
            next_at += period
            delay = next_at - time.monotonic()
            if delay < 0:
                next_at, delay = time.monotonic(), 0.0
            try:
                await asyncio.wait_for(stop.wait(), delay)
            except TimeoutError:
                pass
    finally:
        await server.shutdown()
        serving.cancel()
        if args.report:
            world = plant.world()
            world["_cycles"] = cycles
            Path(args.report).write_text(json.dumps(world, sort_keys=True) + "\n", encoding="utf-8")
    return 0


async def _publish(server: Any, plant: Plant, inputs: Any, unit: int) -> None:
    for point in inputs:
        words, _ = encode(point, plant.read(point.field))
        values: list[Any] = (
            [bool(w) for w in words]
            if point.registers == 1 and point.kind == DISCRETE_INPUT
            else words
        )
        await server.async_setValues(unit, FUNCTION[point.kind], int(point.address), values)


async def _listening_port(server: Any, asked: int) -> int:
    """The port the server listens on (the one the system chose for port 0)."""
    for _ in range(500):
        transport = getattr(server, "transport", None)
        if transport is not None:
            sockets = transport.sockets if hasattr(transport, "sockets") else None
            if sockets:
                return int(sockets[0].getsockname()[1])
        await asyncio.sleep(0.01)
    return asked


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m rcsgen.tools.softplc", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--plant", required=True, help="the generated package whose simulators run here"
    )
    parser.add_argument("--hooks", help="the plant's spec directory (its hook modules)")
    parser.add_argument(
        "--io", required=True, help="the generated package that declares the device"
    )
    parser.add_argument("--device", required=True, help="the device this PLC is")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument(
        "--port", type=int, help="default: the device's declared port (0: any free one)"
    )
    parser.add_argument(
        "--period", type=float, help="seconds per PLC cycle (default: the device's poll period)"
    )
    parser.add_argument("--cycles", type=int, help="stop after this many cycles")
    parser.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="a run setting of the plant"
    )
    parser.add_argument("--report", help="write the plant's world here (JSON) when stopped")
    parser.add_argument("--ready", help="write the port here once listening")
    args = parser.parse_args(argv)
    try:
        io = importlib.import_module(f"{import_package(Path(args.io).resolve()).__name__}.layout")
        devices = getattr(io, "IO_DEVICES", {})
        if args.device not in devices:
            known = sorted(devices) or "none"
            raise ValueError(f"{args.io} declares no I/O device {args.device!r} (it has: {known})")
        device = devices[args.device]
        settings = dict(item.split("=", 1) for item in args.set if "=" in item)
        bad = [item for item in args.set if "=" not in item]
        if bad:
            raise ValueError(f"--set {bad[0]!r}: expected KEY=VALUE")
        hooks = Path(args.hooks).resolve() if args.hooks else None
        plant = Plant(import_package(Path(args.plant).resolve(), hooks), settings)
        missing = sorted(p.field for p in device.points if p.field not in plant.layout.WORLD)
        if missing:
            raise ValueError(
                f"the plant has no world field(s) {missing} that device {args.device} binds"
            )
    except (ValueError, OSError, ImportError) as error:
        print(f"softplc: {error}", file=sys.stderr)
        return 2
    if args.port is None:
        args.port = device.port
    args.period = args.period or device.poll_period
    return asyncio.run(_serve(args, plant, device))


if __name__ == "__main__":
    sys.exit(main())
