"""Modbus TCP: one device's link, over pymodbus's synchronous client.

Imported only when a process runs a Modbus TCP device (`io_cycle.make_link`); pymodbus is
the optional extra `rcsgen[modbus]`. Each poll reads every input in as few requests as the
addresses allow (contiguous ranges, at most the protocol's count per request) and writes
every output the same way (coils with function 15, registers with 16). The client's own
retries are off: the I/O module counts and paces its retries itself.
"""

from __future__ import annotations

import logging
from typing import Any

from .io_points import (
    COIL,
    DISCRETE_INPUT,
    HOLDING_REGISTER,
    INPUT_REGISTER,
    Device,
    IoRefused,
    IoTimeout,
    Point,
    blocks,
    decode,
    encode,
)

# The most one request may carry (Modbus application protocol, 6.1-6.12).
MOST = {COIL: 1968, DISCRETE_INPUT: 2000, HOLDING_REGISTER: 123, INPUT_REGISTER: 125}


def _split(ranges: list[tuple[int, int]], most: int) -> list[tuple[int, int]]:
    return [
        (start + at, min(most, count - at))
        for start, count in ranges
        for at in range(0, count, most)
    ]


class ModbusLink:
    """A Modbus TCP connection to one device (unit id `device.unit`)."""

    def __init__(self, device: Device) -> None:
        from pymodbus.client import ModbusTcpClient

        # pymodbus logs each failed request itself; the I/O module says what failed, once.
        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)

        self.device = device
        self.client: Any = ModbusTcpClient(
            device.host, port=device.port, timeout=device.timeout, retries=0, reconnect_delay=0
        )
        self.reads = [
            (kind, start, count, [p for p in device.inputs if p.kind == kind])
            for kind in (DISCRETE_INPUT, INPUT_REGISTER, COIL, HOLDING_REGISTER)
            for start, count in _split(blocks(device.inputs, kind, gap=8), MOST[kind])
        ]
        self.writes = [
            (kind, start, count)
            for kind in (COIL, HOLDING_REGISTER)
            for start, count in _split(blocks(device.outputs, kind), MOST[kind])
        ]
        self.by_kind = {
            kind: [p for p in device.outputs if p.kind == kind] for kind in (COIL, HOLDING_REGISTER)
        }

    def connect(self) -> None:
        if not self.client.connect():
            raise ConnectionError(f"no Modbus TCP server at {self.device.host}:{self.device.port}")

    def close(self) -> None:
        self.client.close()

    def read(self) -> dict[str, object]:
        values: dict[str, object] = {}
        unit = self.device.unit
        client = self.client
        for kind, start, count, points in self.reads:
            function = {
                DISCRETE_INPUT: client.read_discrete_inputs,
                INPUT_REGISTER: client.read_input_registers,
                COIL: client.read_coils,
                HOLDING_REGISTER: client.read_holding_registers,
            }[kind]
            answer = self._call(function, start, count=count, device_id=unit)
            raw = answer.bits if kind in (COIL, DISCRETE_INPUT) else answer.registers
            for point in points:
                at = int(point.address) - start
                if start <= int(point.address) < start + count:
                    values[point.field] = decode(point, list(raw[at : at + point.registers]))
        return values

    def write(self, values: dict[str, object]) -> int:
        clipped = 0
        unit = self.device.unit
        for kind, start, count in self.writes:
            words = [0] * count
            for point in self._in(kind, start, count):
                raw, was_clipped = encode(point, values[point.field])
                clipped += was_clipped
                at = int(point.address) - start
                words[at : at + point.registers] = raw
            if kind == COIL:
                self._call(self.client.write_coils, start, [bool(w) for w in words], device_id=unit)
            else:
                self._call(self.client.write_registers, start, words, device_id=unit)
        return clipped

    def read_point(self, point: Point) -> object:
        """One point read on its own (outputs too): `validate --connect`'s probe."""
        client, unit = self.client, self.device.unit
        function = {
            DISCRETE_INPUT: client.read_discrete_inputs,
            INPUT_REGISTER: client.read_input_registers,
            COIL: client.read_coils,
            HOLDING_REGISTER: client.read_holding_registers,
        }[point.kind]
        answer = self._call(function, int(point.address), count=point.registers, device_id=unit)
        raw = answer.bits if point.kind in (COIL, DISCRETE_INPUT) else answer.registers
        return decode(point, list(raw[: point.registers]))

    def _in(self, kind: str, start: int, count: int) -> list[Point]:
        return [p for p in self.by_kind[kind] if start <= int(p.address) < start + count]

    def _call(self, function: Any, *args: Any, **kwargs: Any) -> Any:
        from pymodbus.exceptions import ConnectionException, ModbusIOException

        try:
            answer = function(*args, **kwargs)
        except ModbusIOException as error:
            raise IoTimeout(str(error)) from None
        except ConnectionException as error:
            raise ConnectionError(str(error)) from None
        if answer.isError():
            code = getattr(answer, "exception_code", "?")
            raise IoRefused(f"exception code {code} to function {answer.function_code & 0x7F}")
        return answer
