"""Fieldbus I/O: the system's `io:` devices and their points -> checked `Device`s (E450-E457).

A device binds world fields to its points (docs/io.md). What a point kind carries, the
register types and their ranges are the runtime's (`rcsgen/runtime/io_points.py`): what
this accepts is what the I/O module can carry. Checked here: the field exists (E450), the
point can carry it (E451) and its initial and safe values fit (E452), an input field has no
other writer (E453), no ground-truth field is bound (E454), no two points share an address
and no two devices one endpoint (E455), the address is one the protocol can reach (E456),
the device's process exists and uses it, its timeout outlasts a poll (E457).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field

from ...runtime.io_points import (
    DEFAULT_REGISTER_TYPE,
    IN,
    KINDS,
    MODBUS_TCP,
    NODE,
    OPCUA,
    REGISTER_TYPES,
    Device,
    Point,
    raw_range,
)
from ..diagnostics import Diagnostics, Span, known_names_hint, number_shown
from ..front_end.model import ControllerSpec, IoDevice, IoPoint, SystemSpec, Typed
from ..types import Bool, Float, Int

_HOST_PORT = re.compile(r"^(?P<host>[A-Za-z0-9_.\-]+|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})$")
_OPC_URL = re.compile(
    r"^opc\.tcp://(?P<host>[A-Za-z0-9_.\-]+|\[[0-9A-Fa-f:.]+\]):(?P<port>[0-9]{1,5})(/\S*)?$"
)
_NODE_ID = re.compile(r"^(ns=[0-9]+;)?(i=[0-9]+|s=\S.*|g=[0-9A-Fa-f-]{36}|b=\S+)$")


@dataclass(frozen=True)
class CheckedIo:
    """The devices, checked, and for each the controllers that read its inputs."""

    devices: tuple[Device, ...] = ()
    dependents: dict[str, tuple[str, ...]] = field(default_factory=dict)


def check(system: SystemSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics) -> CheckedIo:
    """Check every device of `system.io`; the checked devices (those without errors)."""
    if not system.io:
        return CheckedIo()
    process_of = {m.value: p.name for p in system.processes for m in p.modules}
    readers: dict[str, list[str]] = {}
    writers: dict[str, list[tuple[str, Span]]] = {}
    for spec in by_name.values():
        for item in spec.world_reads:
            readers.setdefault(item.value, []).append(spec.name)
        for item in spec.world_writes:
            writers.setdefault(item.value, []).append((spec.name, item.span))
    devices, dependents = [], {}
    seen = _Seen()
    for declared in system.io.values():
        before = len(diags.errors)
        device = _device(declared, system, process_of, readers, writers, seen, diags)
        if device is None or len(diags.errors) > before:
            continue
        devices.append(device)
        # Lost with the device: the controllers that read its inputs (they decide on stale
        # values) and those that write its outputs (their commands no longer reach it).
        reading = {r for p in device.inputs for r in readers.get(p.field, [])}
        writing = {w for p in device.outputs for w, _ in writers.get(p.field, [])}
        dependents[device.name] = tuple(sorted(reading | writing))
    return CheckedIo(tuple(devices), dependents)


@dataclass
class _Seen:
    """What the devices checked so far took: input fields, endpoints."""

    inputs: dict[str, tuple[str, Span]] = field(default_factory=dict)
    endpoints: dict[tuple[str, int, int], str] = field(default_factory=dict)


def _device(
    device: IoDevice,
    system: SystemSpec,
    process_of: dict[str, str],
    readers: dict[str, list[str]],
    writers: dict[str, list[tuple[str, Span]]],
    seen: _Seen,
    diags: Diagnostics,
) -> Device | None:
    """One device checked; None when a part of it could not be made."""
    points = [p for p in (_point(device, pt, system, diags) for pt in device.points) if p]
    _check_writers(device, points, writers, seen.inputs, diags)
    _check_addresses(device, points, diags)
    protocol = str(device.protocol.value)
    host, port = _address(device, protocol, diags)
    used = {r for p in points for r in readers.get(p.field, [])}
    used |= {w for p in points for w, _ in writers.get(p.field, [])}
    process = _process(device, system, process_of, used, diags)
    poll, timeout = _timing(device, system, process, diags)
    unit = int(device.unit.value) if device.unit is not None else 1
    if device.unit is not None and protocol != MODBUS_TCP:
        diags.error(
            device.unit.span,
            "E456",
            f"`unit:` of {protocol} device `{device.name}`",
            "a unit id is Modbus's; remove it",
        )
    where = (host, port, unit)
    if host and where in seen.endpoints:
        diags.error(
            device.address.span,
            "E455",
            f"device `{device.name}` is at the same address as device `{seen.endpoints[where]}`",
            "one device, one declaration: put both sets of points on one device",
        )
    seen.endpoints.setdefault(where, device.name)
    url = str(device.address.value) if protocol == OPCUA else ""
    return Device(
        device.name, protocol, host, port, process, poll, timeout, tuple(points), unit, url
    )


def _point(
    device: IoDevice, point: IoPoint, system: SystemSpec, diags: Diagnostics
) -> Point | None:
    """The runtime's point for a declared one, or None after an error."""
    world = system.world.get(point.field)
    if world is None:
        diags.error(
            point.span,
            "E450",
            f"device `{device.name}` binds `{point.field}`, which is not a world field",
            known_names_hint("world fields", system.world, point.field),
        )
        return None
    if world.ground_truth:
        diags.error(
            point.span,
            "E454",
            f"ground-truth field `{point.field}` is bound to device `{device.name}`",
            "ground truth is the simulation's, not equipment's: bind the sensed field, or the "
            "actuator command, instead",
        )
        return None
    protocol = str(device.protocol.value)
    if len(point.kinds) != 1:
        given = ", ".join(k.value[0] for k in point.kinds) or "none"
        diags.error(
            point.span,
            "E451",
            f"`{point.field}` on device `{device.name}` needs exactly one point kind "
            f"(given: {given})",
            "Modbus: coil, discrete_input, holding_register or input_register; OPC UA: node",
        )
        return None
    kind, address = point.kinds[0].value
    at = point.kinds[0].span
    if (kind == NODE) != (protocol == OPCUA):
        want = (
            "node"
            if protocol == OPCUA
            else "coil, discrete_input, holding_register, input_register"
        )
        diags.error(
            at,
            "E451",
            f"a `{kind}` point on {protocol} device `{device.name}`",
            f"a {protocol} device's points are: {want}",
        )
        return None
    value_type = _value_type(world)
    if value_type is None:
        diags.error(
            at,
            "E451",
            f"`{point.field}` holds {world.type.words}, which no fieldbus point carries",
            "bind bool, int and float fields only",
        )
        return None
    if kind == NODE:
        return _node(device, point, str(address), value_type, diags)
    carries, output = KINDS[kind]
    if (carries == "bool") != (value_type == "bool"):
        what = "a bit" if carries == "bool" else "a register"
        diags.error(
            at,
            "E451",
            f"`{point.field}` holds {world.type.words}, but a {kind} is {what}",
            "bool fields go on coils and discrete inputs, numbers on holding and input registers",
        )
        return None
    if point.direction is not None:
        diags.error(
            point.direction.span,
            "E451",
            f"`direction:` on a Modbus {kind}",
            "a Modbus point's kind says its direction: remove `direction:`",
        )
        return None
    if carries == "bool":
        extra = next(
            (o for o in (point.register_type, point.scale, point.offset, point.word_order) if o),
            None,
        )
        if extra is not None:
            diags.error(
                extra.span,
                "E451",
                f"register options on {kind} `{point.field}`",
                "type, scale, offset and word_order are for registers",
            )
            return None
        return Point(point.field, kind, int(address), output, value_type)
    return _register(device, point, world, kind, int(address), output, value_type, diags)


def _register(
    device: IoDevice,
    point: IoPoint,
    world: Typed,
    kind: str,
    address: int,
    output: bool,
    value_type: str,
    diags: Diagnostics,
) -> Point | None:
    register_type = str(point.register_type.value) if point.register_type else DEFAULT_REGISTER_TYPE
    scale = _number(point.scale.value) if point.scale else 1.0
    offset = _number(point.offset.value) if point.offset else 0.0
    word_order = str(point.word_order.value) if point.word_order else "big"
    if _register_problem(point, register_type, scale, offset, value_type, diags):
        return None
    made = Point(
        point.field, kind, address, output, value_type, register_type, scale, offset, word_order
    )
    return made if _fits(device, point, world, made, diags) else None


def _number(value: float) -> float:
    """A number of the spec as a float: an int too large for one is infinite, so that it is
    reported as not finite (the loader refuses `.inf` and `1e999`, not a long int)."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _register_problem(
    point: IoPoint,
    register_type: str,
    scale: float,
    offset: float,
    value_type: str,
    diags: Diagnostics,
) -> bool:
    """Whether a register's options cannot carry the field (reported, E451)."""
    for option in (point.scale, point.offset):
        if option is not None and not math.isfinite(_number(option.value)):
            diags.error(
                option.span, "E451", f"`{number_shown(option.value)}` is not a finite number"
            )
            return True
    if scale == 0 and point.scale is not None:
        diags.error(
            point.scale.span,
            "E451",
            f"scale 0 on `{point.field}` loses every value",
            "field value = raw * scale + offset: give a non-zero scale",
        )
        return True
    if point.word_order is not None and REGISTER_TYPES[register_type][1] == 1:
        diags.error(
            point.word_order.span,
            "E451",
            f"word order on a one-register {register_type} (`{point.field}`)",
            "word_order is for 32-bit types (int32, uint32, float32)",
        )
        return True
    whole = register_type != "float32" and scale.is_integer() and offset.is_integer()
    if value_type == "int" and not whole:
        where = point.register_type or point.scale or point.offset or point.kinds[0]
        diags.error(
            where.span,
            "E451",
            f"int field `{point.field}` on a register that gives fractions "
            f"({register_type}, scale {scale:g}, offset {offset:g})",
            "an int field takes an integer register with a whole scale and offset",
        )
        return True
    return False


def _fits(device: IoDevice, point: IoPoint, world: Typed, made: Point, diags: Diagnostics) -> bool:
    """Whether the field's initial value (and an actuator's safe value) fit the register
    (reported, E452)."""
    output, kind, register_type = made.output, made.kind, made.register_type
    low, high = raw_range(made)
    values = [("initial", world.initial, world.initial_span)]
    if output and world.actuator:
        values.append(("safe", world.safe if world.safe is not None else 0, world.safe_span))
    for what, value, span in values:
        if isinstance(value, int | float) and not low <= value <= high:
            diags.error(
                span or point.span,
                "E452",
                f"{what} value {value!r} of `{point.field}` does not fit its {register_type} "
                f"{kind} on device `{device.name}` ({low:g}..{high:g})",
                "widen the register type or change the scale",
            )
            return False
    return True


def _node(
    device: IoDevice, point: IoPoint, node: str, value_type: str, diags: Diagnostics
) -> Point | None:
    extra = next(
        (o for o in (point.register_type, point.scale, point.offset, point.word_order) if o), None
    )
    if extra is not None:
        diags.error(
            extra.span,
            "E451",
            f"register options on OPC UA node `{point.field}`",
            "an OPC UA node carries the field's own type",
        )
        return None
    if point.direction is None:
        diags.error(
            point.span,
            "E451",
            f"OPC UA point `{point.field}` has no `direction:`",
            "say `direction: in` (read from the node) or `direction: out` (written to it)",
        )
        return None
    if not _NODE_ID.match(node):
        diags.error(
            point.kinds[0].span,
            "E456",
            f"`{node}` is not an OPC UA node id",
            "e.g. ns=2;s=Drum.On or ns=2;i=1001",
        )
        return None
    return Point(point.field, NODE, node, point.direction.value != IN, value_type)


def _value_type(world: Typed) -> str | None:
    kind = world.type
    if isinstance(kind, Bool):
        return "bool"
    if isinstance(kind, Int):
        return "int"
    if isinstance(kind, Float):
        return "float"
    return None


def _check_writers(
    device: IoDevice,
    points: list[Point],
    writers: dict[str, list[tuple[str, Span]]],
    inputs: dict[str, tuple[str, Span]],
    diags: Diagnostics,
) -> None:
    """An input field is written by its device only: no controller, no other device (E453)."""
    spans = {p.field: p.span for p in device.points}
    for point in points:
        if point.output:
            continue
        span = spans[point.field]
        for module, at in writers.get(point.field, []):
            diags.error(
                span,
                "E453",
                f"`{point.field}` is an input of device `{device.name}` and is written by "
                f"`{module}` ({at})",
                "a field has one writer: unbind it, or stop writing it in that controller",
            )
        other = inputs.get(point.field)
        if other is not None:
            diags.error(
                span,
                "E453",
                f"`{point.field}` is an input of devices `{other[0]}` and `{device.name}`",
                "a field has one writer: read it from one device",
            )
        inputs.setdefault(point.field, (device.name, span))


def _check_addresses(device: IoDevice, points: list[Point], diags: Diagnostics) -> None:
    """No two points of a device share an address of one table, or one node (E455)."""
    taken: dict[tuple[str, object], str] = {}
    spans = {p.field: p.span for p in device.points}
    for point in points:
        cells: Iterable[object] = (
            [point.address]
            if point.kind == NODE
            else range(int(point.address), int(point.address) + point.registers)
        )
        for cell in cells:
            holder = taken.get((point.kind, cell))
            if holder is not None:
                diags.error(
                    spans[point.field],
                    "E455",
                    f"`{point.field}` and `{holder}` share {point.kind} {cell} of device "
                    f"`{device.name}`",
                    "give each field its own address (a 32-bit type takes two registers)",
                )
                break
            taken[(point.kind, cell)] = point.field
        if point.kind != NODE and int(point.address) + point.registers > 65536:
            diags.error(
                spans[point.field], "E455", f"`{point.field}` runs past the last address (65535)"
            )


def _address(device: IoDevice, protocol: str, diags: Diagnostics) -> tuple[str, int]:
    text = str(device.address.value)
    found = (_OPC_URL if protocol == OPCUA else _HOST_PORT).match(text)
    if found is None or not 0 < int(found["port"]) < 65536:
        diags.error(
            device.address.span,
            "E456",
            f"`{text}` is not an address of a {protocol} device",
            "opc.tcp://HOST:PORT[/PATH]" if protocol == OPCUA else "HOST:PORT, e.g. 127.0.0.1:502",
        )
        return "", 0
    return found["host"].strip("[]"), int(found["port"])


def _process(
    device: IoDevice,
    system: SystemSpec,
    process_of: dict[str, str],
    used: set[str],
    diags: Diagnostics,
) -> str:
    names = [p.name for p in system.processes]
    if device.process is not None:
        if device.process.value not in names:
            diags.error(
                device.process.span,
                "E457",
                f"device `{device.name}` names process `{device.process.value}`, which the "
                "system does not have",
                known_names_hint("processes", names, str(device.process.value)),
            )
            return ""
        return str(device.process.value)
    running = [p for p in names if any(process_of.get(m) == p for m in used)]
    if not running:
        diags.error(
            device.span,
            "E457",
            f"no controller of any process reads or writes a field of device `{device.name}`",
            "say which process runs it (`process:`), or bind fields the controllers use",
        )
        return ""
    return running[0]


def _timing(
    device: IoDevice, system: SystemSpec, process: str, diags: Diagnostics
) -> tuple[float, float]:
    period = next(
        (p.cycle_period for p in system.processes if p.name == process and p.cycle_period),
        system.cycle_period,
    )
    poll = _number(device.poll_period.value) if device.poll_period else period
    timeout = _number(device.timeout.value)
    for item, value in ((device.poll_period, poll), (device.timeout, timeout)):
        if item is not None and not math.isfinite(value):
            diags.error(
                item.span, "E457", f"`{number_shown(item.value)}` is not a finite number of seconds"
            )
            return poll, timeout
    if timeout <= poll:
        diags.error(
            device.timeout.span,
            "E457",
            f"device `{device.name}`'s timeout ({timeout:g} s) is not longer than its poll "
            f"period ({poll:g} s): it would be lost between two polls",
            "a timeout of two to five poll periods rides out one late answer",
        )
    return poll, timeout
