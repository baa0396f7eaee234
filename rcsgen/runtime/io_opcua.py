"""OPC UA: one device's link, over asyncua's synchronous client.

Imported only when a process runs an OPC UA device (`io_cycle.make_link`); asyncua is the
optional extra `rcsgen[opcua]`. Each poll reads every input node in one Read request and
writes every output node in one Write request, each value as its field's type (Boolean,
Int64, Double). A bad status for a node (an unknown node id, a refused write) is an
exception answer (`IoRefused`), a request with no answer in the device's timeout a timeout.
"""

from __future__ import annotations

import logging
from typing import Any

from .io_points import Device, IoRefused, IoTimeout, Point


class OpcUaLink:
    """An OPC UA session with one server (`device.url`)."""

    def __init__(self, device: Device) -> None:
        from asyncua.sync import Client

        # asyncua logs its security and session notes itself; the I/O module says what failed.
        logging.getLogger("asyncua").setLevel(logging.ERROR)

        self.device = device
        self.client: Any = Client(device.url, timeout=device.timeout)
        self.nodes: dict[str, Any] = {}
        self.variant_types: dict[str, Any] = {}

    def connect(self) -> None:
        from asyncua import ua

        try:
            self.client.connect()
        except Exception as error:  # noqa: BLE001 - any failure to connect: no server there
            self.client.tloop.stop() if self.client.close_tloop else None
            raise ConnectionError(f"no OPC UA server at {self.device.url}: {error}") from None
        self.nodes = {p.field: self.client.get_node(str(p.address)) for p in self.device.points}
        kinds = {"bool": ua.VariantType.Boolean, "int": ua.VariantType.Int64}
        self.variant_types = {
            p.field: kinds.get(p.value_type, ua.VariantType.Double) for p in self.device.points
        }

    def close(self) -> None:
        try:
            self.client.disconnect()
        except Exception:  # noqa: BLE001 - a session already gone: its loop thread still stops
            if self.client.close_tloop:
                self.client.tloop.stop()

    def read(self) -> dict[str, object]:
        inputs = self.device.inputs
        values = self._call(self.client.read_values, [self.nodes[p.field] for p in inputs])
        return {p.field: _as(p, v) for p, v in zip(inputs, values, strict=True)}

    def read_point(self, point: Point) -> object:
        """One node read on its own: `validate --connect`'s probe."""
        return _as(point, self._call(self.client.read_values, [self.nodes[point.field]])[0])

    def write(self, values: dict[str, object]) -> int:
        from asyncua import ua

        outputs = self.device.outputs
        nodes = [self.nodes[p.field] for p in outputs]
        data = [
            ua.DataValue(ua.Variant(_as(p, values[p.field]), self.variant_types[p.field]))
            for p in outputs
        ]
        self._call(self.client.write_values, nodes, data)
        return 0

    def _call(self, function: Any, *args: Any) -> Any:
        from asyncua.ua.uaerrors._base import UaStatusCodeError

        try:
            return function(*args)
        except UaStatusCodeError as error:
            raise IoRefused(str(error)) from None
        except TimeoutError as error:
            raise IoTimeout(str(error) or "no answer") from None


def _as(point: Point, value: object) -> object:
    if point.value_type == "bool":
        return bool(value)
    if point.value_type == "int":
        return int(value)  # type: ignore[call-overload]
    return float(value)  # type: ignore[arg-type]
