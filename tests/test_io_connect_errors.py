"""`validate --connect`'s probe (rcsgen/tools/io_connect.py) as a person reads its E458s, in the
unit tier, on miner_hil's two devices: a device that does not answer (a loopback port nothing
listens on), an address in RCSGEN_IO_<DEVICE> it cannot use, a protocol whose extra is not
installed, and the one point a device refuses, each located at its declaration or its point's
line. The real protocol stacks answering are test_softplc's; here a stand-in link refuses."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.runtime.io_points import Device, IoRefused, Point
from rcsgen.tools import io_connect

SPECS = Path(__file__).resolve().parent.parent / "specs"
SYSTEM_YAML = "specs/miner_hil/system.yaml"


@pytest.fixture(scope="module")
def hil() -> IRSystem:
    front = compile_paths([SPECS / "miner_hil"])
    assert not front.diagnostics.errors
    return front.systems[0]


def closed_port() -> int:
    """A loopback port nothing listens on (bound once, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def said(system: IRSystem) -> list[tuple[str, str, str]]:
    return [(str(d.span), d.message, d.hint) for d in io_connect.check_devices(system).errors]


class Refusing:
    """A link that answers every read but those of `refused` (fields), and says it closed."""

    def __init__(self, refused: set[str], log: list[str]) -> None:
        self.refused, self.log = refused, log

    def connect(self) -> None:
        self.log.append("connect")

    def read_point(self, point: Point) -> None:
        self.log.append(point.field)
        if point.field in self.refused:
            raise IoRefused("exception code 02 (illegal data address)")

    def close(self) -> None:
        self.log.append("close")


def test_a_device_that_does_not_answer_and_an_address_that_cannot_be_used(
    hil: IRSystem, monkeypatch: pytest.MonkeyPatch
) -> None:
    port = closed_port()
    monkeypatch.setenv("RCSGEN_IO_PLC", f"127.0.0.1:{port}")
    monkeypatch.setenv("RCSGEN_IO_CONVEYOR", "127.0.0.1:4850")  # an OPC UA device wants a URL
    [plc, conveyor] = said(hil)
    assert plc[0] == f"{SYSTEM_YAML}:249:3"
    assert plc[1].startswith(f"device `plc` does not answer at 127.0.0.1:{port}: ")
    assert plc[2] == (
        "is it on, and at this address? (RCSGEN_IO_PLC=... points the check elsewhere)"
    )
    assert conveyor == (
        f"{SYSTEM_YAML}:275:3",
        "RCSGEN_IO_CONVEYOR='127.0.0.1:4850': not an address of I/O device conveyor "
        "(opc.tcp://HOST:PORT[/PATH])",
        "",
    )


def test_a_protocol_whose_extra_is_missing_names_it(
    hil: IRSystem, monkeypatch: pytest.MonkeyPatch
) -> None:
    def missing(device: Device) -> None:
        raise ImportError(f"{device.protocol} needs its extra: pip install 'rcsgen[x]'")

    monkeypatch.setattr(io_connect, "make_link", missing)
    assert said(hil) == [
        (
            f"{SYSTEM_YAML}:249:3",
            "device `plc`: modbus_tcp needs its extra: pip install 'rcsgen[x]'",
            "",
        ),
        (
            f"{SYSTEM_YAML}:275:3",
            "device `conveyor`: opcua needs its extra: pip install 'rcsgen[x]'",
            "",
        ),
    ]


def test_each_point_a_device_refuses_is_one_error_at_its_line_and_every_point_is_asked(
    hil: IRSystem, monkeypatch: pytest.MonkeyPatch
) -> None:
    logs: dict[str, list[str]] = {}

    def link(device: Device) -> Refusing:
        log = logs.setdefault(device.name, [])
        return Refusing({"jack_down_cmd", "pose_y", "tail_request"}, log)

    monkeypatch.setattr(io_connect, "make_link", link)
    why = "exception code 02 (illegal data address)"
    assert said(hil) == [
        (
            f"{SYSTEM_YAML}:259:7",
            f"device `plc` at 127.0.0.1:5020 has no coil 1 for `jack_down_cmd`: {why}",
            "",
        ),
        (
            f"{SYSTEM_YAML}:268:7",
            f"device `plc` at 127.0.0.1:5020 has no input_register 2 for `pose_y`: {why}",
            "",
        ),
        (
            f"{SYSTEM_YAML}:286:7",
            "device `conveyor` at opc.tcp://127.0.0.1:4850/miner has no node "
            f"ns=2;s=Conveyor.TailRequest for `tail_request`: {why}",
            "",
        ),
    ]
    # a refusal does not end the probe: every point read once, then the link closed
    plc = [p.field for p in next(d for d in hil.io if d.name == "plc").points]
    assert logs["plc"] == ["connect", *plc, "close"]
    assert logs["conveyor"] == [
        "connect",
        "conveyor_on_cmd",
        "tail_request",
        "tail_in_position",
        "close",
    ]


def test_a_device_refused_for_its_address_does_not_stop_the_next(
    hil: IRSystem, monkeypatch: pytest.MonkeyPatch
) -> None:
    port = closed_port()
    monkeypatch.setenv("RCSGEN_IO_PLC", "plc.local")  # no port
    monkeypatch.setenv("RCSGEN_IO_CONVEYOR", f"opc.tcp://127.0.0.1:{port}/miner")
    [plc, conveyor] = said(hil)
    assert plc == (
        f"{SYSTEM_YAML}:249:3",
        "RCSGEN_IO_PLC='plc.local': not an address of I/O device plc (HOST:PORT)",
        "",
    )
    assert conveyor[0] == f"{SYSTEM_YAML}:275:3"
    assert conveyor[1].startswith(  # the dev extra has asyncua
        f"device `conveyor` does not answer at opc.tcp://127.0.0.1:{port}/miner: "
    )
