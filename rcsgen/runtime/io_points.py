"""I/O points: a world field bound to a fieldbus point, and how its value crosses the wire.

A system's `io:` section (docs/io.md) groups points per device; the generated layout
declares each as a `Device` of `Point`s (`layout.IO_DEVICES`). This module is the one place
that says what a point kind is (`KINDS`), what a register type holds (`REGISTER_TYPES`),
which way a point goes, and how a field's value becomes the point's raw value and back
(`encode`, `decode`: scaling, offset, signedness, word order). The compiler's checks read
the same tables, so what the checks accept is what the runtime can carry.

Standard library only: copied verbatim into every generated package. The protocol stacks
are imported by `io_modbus.py` and `io_opcua.py`, only when a system declares such a device.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from .contract import shared

MODBUS_TCP = "modbus_tcp"
OPCUA = "opcua"
PROTOCOLS = (MODBUS_TCP, OPCUA)

# Modbus point kinds -> (the field type it carries: "bool" or "number", whether the
# controllers' process writes it to the device). Coils and holding registers are outputs,
# discrete inputs and input registers inputs: the Modbus data model's own split.
COIL, DISCRETE_INPUT, HOLDING_REGISTER, INPUT_REGISTER = (
    "coil",
    "discrete_input",
    "holding_register",
    "input_register",
)
NODE = "node"  # an OPC UA node: `direction:` says which way it goes
KINDS: dict[str, tuple[str, bool]] = {
    COIL: ("bool", True),
    DISCRETE_INPUT: ("bool", False),
    HOLDING_REGISTER: ("number", True),
    INPUT_REGISTER: ("number", False),
}
IN, OUT = "in", "out"

# Register types: (struct code of the value, registers it takes, smallest, largest raw value).
REGISTER_TYPES: dict[str, tuple[str, int, float, float]] = {
    "int16": ("h", 1, -(2**15), 2**15 - 1),
    "uint16": ("H", 1, 0, 2**16 - 1),
    "int32": ("i", 2, -(2**31), 2**31 - 1),
    "uint32": ("I", 2, 0, 2**32 - 1),
    "float32": ("f", 2, -3.4028234663852886e38, 3.4028234663852886e38),
}
DEFAULT_REGISTER_TYPE = "int16"
WORD_ORDERS = ("big", "little")  # which 16-bit word of a 32-bit value comes first

# A device's state in its record (`layout.IO_RECORDS`, `ctl status`, traces).
CONNECTING, ONLINE, LOST, STOPPED = 0, 1, 2, 3
DEVICE_STATES = ("CONNECTING", "ONLINE", "LOST", "STOPPED")
# What went wrong last with a device (its record's `last_error`, by index): nothing yet, a
# request unanswered in time, an exception code or bad status, no connection, a connection
# broken or a protocol error, a value clipped to fit its register.
ERROR_KINDS = ("none", "timeout", "exception", "cannot connect", "connection lost", "clipped")
NO_ERROR, TIMED_OUT, REFUSED, UNCONNECTED, BROKEN, CLIPPED = range(len(ERROR_KINDS))
# A device record's fields after `seq`: its state, the counts, the last error (int64
# each), then the address the process that runs it uses (ADDRESS_BYTES of UTF-8: the
# declared one, or the one `RCSGEN_IO_<DEVICE>` gave it, which a console cannot know).
DEVICE_FIELDS = (
    "state",
    "reads",
    "writes",
    "timeouts",
    "retries",
    "errors",
    "reconnects",
    "losses",
    "last_ok_ns",
    "round_trip_ns",
    "last_error",
    "address",
)
ADDRESS_BYTES = 128
TALLIES = DEVICE_FIELDS[1:-1]  # what a device's thread keeps (all but its state and address)
COUNTS = ("reads", "writes", "timeouts", "retries", "errors", "reconnects", "losses")


@shared
@dataclass(frozen=True)
class Point:
    """One world field bound to one point of a device."""

    field: str
    kind: str  # a key of KINDS, or NODE
    address: int | str  # the register or bit number; an OPC UA node id
    output: bool  # written to the device (else read from it)
    value_type: str  # the field's: "bool", "int" or "float"
    register_type: str = DEFAULT_REGISTER_TYPE  # registers only
    scale: float = 1.0
    offset: float = 0.0
    word_order: str = "big"

    @property
    def registers(self) -> int:
        """How many 16-bit registers (or bits) the point takes."""
        if self.kind in (HOLDING_REGISTER, INPUT_REGISTER):
            return REGISTER_TYPES[self.register_type][1]
        return 1


@shared
@dataclass(frozen=True)
class Device:
    """A device: where it is, how often it is polled, when it counts as lost, its points."""

    name: str
    protocol: str  # MODBUS_TCP or OPCUA
    host: str
    port: int
    process: str  # the process whose I/O module runs it
    poll_period: float  # seconds between two exchanges
    timeout: float  # seconds without a good answer: the device is lost
    points: tuple[Point, ...]
    unit: int = 1  # Modbus unit (device) id
    url: str = ""  # OPC UA endpoint

    @property
    def inputs(self) -> tuple[Point, ...]:
        return tuple(p for p in self.points if not p.output)

    @property
    def outputs(self) -> tuple[Point, ...]:
        return tuple(p for p in self.points if p.output)


@shared
class IoTimeout(Exception):
    """A request to a device got no answer in time."""


@shared
class IoRefused(Exception):
    """A device answered with an exception code (a point it does not have, a busy device)."""


# ---------------------------------------------------------------- values across the wire


def raw_range(point: Point) -> tuple[float, float]:
    """The smallest and largest field value the point can carry (scaled)."""
    if point.kind not in (HOLDING_REGISTER, INPUT_REGISTER):
        return (-math.inf, math.inf)
    _, _, low, high = REGISTER_TYPES[point.register_type]
    ends = sorted((low * point.scale + point.offset, high * point.scale + point.offset))
    return ends[0], ends[1]


def range_problem(point: Point, value: object) -> str:
    """Why the field value `value` cannot go to (or come from) the point; "" when it can."""
    if point.kind in (COIL, DISCRETE_INPUT) or point.kind == NODE:
        return ""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return f"{value!r} is not a number"
    low, high = raw_range(point)
    if not low <= value <= high:
        held = f"{low:g}..{high:g}"
        return f"{value!r} is outside what a {point.register_type} register holds here ({held})"
    return ""


def encode(point: Point, value: object) -> tuple[list[int], bool]:
    """A field value as the point's raw registers (a bit: [0] or [1]) and whether it had to
    be clipped to the point's range (the value sent is then the nearest it holds)."""
    if point.kind in (COIL, DISCRETE_INPUT):
        return [1 if value else 0], False
    code, count, low, high = REGISTER_TYPES[point.register_type]
    raw = (float(value) - point.offset) / point.scale  # type: ignore[arg-type]
    clipped = not low <= raw <= high
    raw = min(max(raw, low), high)
    number: float | int = raw if code == "f" else round(raw)
    if code != "f":
        number = min(max(int(number), int(low)), int(high))
    data = struct.pack(">" + code, number)
    words = [int.from_bytes(data[i : i + 2], "big") for i in range(0, 2 * count, 2)]
    if point.word_order == "little":
        words.reverse()
    return words, clipped


def decode(point: Point, words: list[int]) -> bool | int | float:
    """The point's raw registers (or bit) as the field's value."""
    if point.kind in (COIL, DISCRETE_INPUT):
        return bool(words[0])
    code, count, _, _ = REGISTER_TYPES[point.register_type]
    ordered = list(words[:count])
    if point.word_order == "little":
        ordered.reverse()
    data = b"".join(int(w & 0xFFFF).to_bytes(2, "big") for w in ordered)
    raw: float = struct.unpack(">" + code, data)[0]
    value = raw * point.scale + point.offset
    if point.value_type == "int":
        return round(value)
    if point.value_type == "bool":
        return bool(value)
    return float(value)


def blocks(points: tuple[Point, ...], kind: str, gap: int = 0) -> list[tuple[int, int]]:
    """The points of `kind` as contiguous (start, count) ranges: one request each. Ranges
    closer than `gap` addresses are joined (reading a few unused addresses is cheaper than
    another round trip)."""
    spans = sorted((int(p.address), int(p.address) + p.registers) for p in points if p.kind == kind)
    merged: list[list[int]] = []
    for start, end in spans:
        if merged and start <= merged[-1][1] + gap:
            merged[-1][1] = max(merged[-1][1], end)
        else:
            merged.append([start, end])
    return [(start, end - start) for start, end in merged]


def where(device: Device) -> str:
    """A device's address as a person writes it: its OPC UA endpoint URL, or HOST:PORT."""
    return device.url or f"{device.host}:{device.port}"


def shown_address(device: Device) -> str:
    """`where(device)` as its record holds it: whole if it fits ADDRESS_BYTES, else cut
    (at a character) and marked with `...`."""
    text = where(device)
    if len(text.encode("utf-8")) <= ADDRESS_BYTES:
        return text
    cut = text.encode("utf-8")[: ADDRESS_BYTES - 3].decode("utf-8", "ignore")
    return cut + "..."


def device_status(device: Device, values: dict[str, int], now_ns: int) -> dict[str, object]:
    """A device's record as the console shows it (`ctl status`, its JSON, traces): its state
    by name, where it is (the address its process uses, from the record), its counts, how
    long ago it last answered well and how long that exchange took; `stale`, the input
    fields it feeds that hold old values while it is lost (or not yet heard from).
    `values`: the record's fields ({} when it stayed unreadable)."""
    if not values:
        return {"state": "?"}
    state = int(values["state"])
    last = int(values["last_ok_ns"])
    error = int(values["last_error"])
    silent = state in (LOST, CONNECTING) or (state == STOPPED and not last)
    return {
        "state": DEVICE_STATES[state] if 0 <= state < len(DEVICE_STATES) else str(state),
        "protocol": device.protocol,
        "address": str(values.get("address") or "") or where(device),
        "process": device.process,
        "poll_period_s": device.poll_period,
        "timeout_s": device.timeout,
        **{name: int(values[name]) for name in COUNTS},
        "last_answer_age_s": round((now_ns - last) / 1e9, 3) if last else None,
        "round_trip_ms": round(int(values["round_trip_ns"]) / 1e6, 3) if last else None,
        "stale": [p.field for p in device.inputs] if silent else [],
        "last_error": ERROR_KINDS[error] if 0 <= error < len(ERROR_KINDS) else str(error),
    }
