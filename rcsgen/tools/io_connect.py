"""`validate --connect`: ask each declared device whether every bound point is there (E458).

For a Modbus TCP device: connect (within its declared timeout) and read each point on its
own, outputs too (a coil or holding register answers a read), so an exception code (02,
illegal data address) names the one point the device does not have. For an OPC UA device:
read each node's value. A device that does not answer is one E458 at its declaration; a
point it refuses, one at the point's line. Reads only: nothing is written to a device.
"""

from __future__ import annotations

from ..compiler.diagnostics import Diagnostics, Span
from ..compiler.ir import IRSystem
from ..runtime.io_cycle import make_link, relocated
from ..runtime.io_points import Device, IoRefused, IoTimeout, Point


def check_devices(system: IRSystem) -> Diagnostics:
    """E458 for each device of `system` that does not answer and each point it refuses."""
    diags = Diagnostics()
    for declared in system.io:
        span = system.io_spans.get(declared.name, Span(system.source))
        try:
            device = relocated(declared)
        except ValueError as error:
            diags.error(span, "E458", str(error))
            continue
        where = device.url or f"{device.host}:{device.port}"
        try:
            refused = _probe(device)
        except ImportError as error:  # make_link's message names the extra to install
            diags.error(span, "E458", f"device `{device.name}`: {error}")
            continue
        except (OSError, IoTimeout) as error:
            diags.error(
                span,
                "E458",
                f"device `{device.name}` does not answer at {where}: {error}",
                "is it on, and at this address? (RCSGEN_IO_"
                f"{device.name.upper()}=... points the check elsewhere)",
            )
            continue
        for point, why in refused:
            at = system.io_spans.get(f"{device.name}.{point.field}", span)
            diags.error(
                at,
                "E458",
                f"device `{device.name}` at {where} has no {point.kind} {point.address} "
                f"for `{point.field}`: {why}",
            )
    return diags


def _probe(device: Device) -> list[tuple[Point, str]]:
    """Each point of `device` read once over its protocol's link: the ones it refuses."""
    link = make_link(device)
    link.connect()
    refused = []
    try:
        for point in device.points:
            try:
                link.read_point(point)
            except IoRefused as error:
                refused.append((point, str(error)))
    finally:
        link.close()
    return refused
