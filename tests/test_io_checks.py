"""A system's fieldbus devices checked (rcsgen/compiler/checks/io.py, E450-E457): what a
good declaration becomes (the runtime's Device and Points, the controllers lost with it) and,
for each way a declaration can be wrong, the one error a person reads, word for word. The
corpus has one case per code; here every branch of each."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.runtime.io_points import Device, Point

HEAD = """\
system: tank
title: Tank on a fieldbus
cycle_period: 0.1

world:
  level: {type: float, initial: 0.0, doc: Sensed level.}
  valve_cmd: {type: float, initial: 0.0, actuator: true, doc: Valve opening.}
  pump_on: {type: bool, initial: false, actuator: true, doc: Pump motor on.}
  batch: {type: int, initial: 0, doc: Batch number.}
  spare: {type: int, initial: 0, doc: A spare input.}
  truth: {type: float, initial: 0.0, ground_truth: true, doc: The true level.}
  label: {type: str, size: 8, initial: "", doc: A name.}
  big: {type: int, initial: 70000, doc: A count past 16 bits.}
  hot: {type: float, initial: 0.0, actuator: true, safe: 900.0, doc: A heater.}

processes:
  p:
    cycle_period: 0.05
    modules: [tank]

"""

TANK = """\
controller: tank
title: Tank level

world:
  reads: [level, batch]
  writes: [valve_cmd, pump_on, hot]

commands:
  FILL:
    doc: Pump until the level is high.
    states:
      S0:
        - when: world.level < 2.0
          do:
            - set: {world.pump_on: true}
            - set: {world.valve_cmd: 50.0}
            - set: {world.hot: 1.0}
        - when: world.level >= 2.0
          do:
            - set: {world.pump_on: false}
            - report: DONE
"""


def front(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, io: str):
    (tmp_path / "system.yaml").write_text(HEAD + "io:\n" + textwrap.indent(io, "  "))
    (tmp_path / "tank.yaml").write_text(TANK)
    monkeypatch.chdir(tmp_path)
    return compile_paths([Path(".")])


def errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, io: str) -> list[tuple[str, ...]]:
    found = front(tmp_path, monkeypatch, io).diagnostics
    return sorted((d.code, d.message, d.hint) for d in found if d.severity.name == "ERROR")


def test_a_modbus_device_becomes_the_runtimes_device_with_its_defaults(tmp_path, monkeypatch):
    built = front(
        tmp_path,
        monkeypatch,
        """\
plc:
  protocol: modbus_tcp
  address: plc.local:5020
  timeout: 0.5
  points:
    level: {input_register: 0, type: int32, scale: 0.01, offset: -1.5, word_order: little}
    batch: {input_register: 2}
    valve_cmd: {holding_register: 7, type: uint16, scale: 0.1}
    pump_on: {coil: 3}
""",
    )
    assert [d.render() for d in built.diagnostics.errors] == []
    [system] = built.systems
    assert system.io == (
        Device(
            "plc",
            "modbus_tcp",
            "plc.local",
            5020,
            "p",  # the process of the controllers that use its fields
            0.05,  # polled once a cycle of that process (its own period) when no poll_period
            0.5,
            (
                Point("level", "input_register", 0, False, "float", "int32", 0.01, -1.5, "little"),
                Point("batch", "input_register", 2, False, "int", "int16", 1.0, 0.0, "big"),
                Point("valve_cmd", "holding_register", 7, True, "float", "uint16", 0.1, 0.0, "big"),
                Point("pump_on", "coil", 3, True, "bool"),
            ),
            1,  # unit 1 unless said
        ),
    )
    assert system.io_dependents == {"plc": ("tank",)}


def test_an_opcua_device_keeps_its_url_and_a_named_process_period(tmp_path, monkeypatch):
    built = front(
        tmp_path,
        monkeypatch,
        """\
ua:
  protocol: opcua
  address: opc.tcp://[::1]:4840/rig
  process: p
  poll_period: 0.1
  timeout: 0.2
  points:
    level: {node: "ns=2;s=Tank.Level", direction: in}
    pump_on: {node: "i=1001", direction: out}
""",
    )
    assert [d.render() for d in built.diagnostics.errors] == []
    [device] = built.systems[0].io
    assert (device.host, device.port, device.url) == ("::1", 4840, "opc.tcp://[::1]:4840/rig")
    assert (device.process, device.poll_period, device.timeout, device.unit) == ("p", 0.1, 0.2, 1)
    assert device.points == (
        Point("level", "node", "ns=2;s=Tank.Level", False, "float"),
        Point("pump_on", "node", "i=1001", True, "bool"),
    )
    assert built.systems[0].io_dependents == {"ua": ("tank",)}


# `process:` named: a device whose points all failed uses no controller's field, and would
# get E457 as well
BUS = "plc:\n  protocol: modbus_tcp\n  address: 127.0.0.1:502\n  timeout: 0.5\n"
MODBUS = BUS + "  process: p\n"
OPCUA = "ua:\n  protocol: opcua\n  address: opc.tcp://h:4840\n  timeout: 0.5\n  process: p\n"
FRACTION = "an int field takes an integer register with a whole scale and offset"


@pytest.mark.parametrize(
    ("io", "want"),
    [
        (
            MODBUS + "  points:\n    levle: {input_register: 0}\n",
            (
                "E450",
                "device `plc` binds `levle`, which is not a world field",
                "did you mean `level`?",
            ),
        ),
        (
            MODBUS + "  points:\n    truth: {input_register: 0}\n",
            (
                "E454",
                "ground-truth field `truth` is bound to device `plc`",
                "ground truth is the simulation's, not equipment's: bind the sensed field, or "
                "the actuator command, instead",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0, holding_register: 1}\n",
            (
                "E451",
                "`level` on device `plc` needs exactly one point kind (given: "
                "holding_register, input_register)",
                "Modbus: coil, discrete_input, holding_register or input_register; OPC UA: node",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {type: int16}\n",
            (
                "E451",
                "`level` on device `plc` needs exactly one point kind (given: none)",
                "Modbus: coil, discrete_input, holding_register or input_register; OPC UA: node",
            ),
        ),
        (
            MODBUS + '  points:\n    level: {node: "i=1", direction: in}\n',
            (
                "E451",
                "a `node` point on modbus_tcp device `plc`",
                "a modbus_tcp device's points are: coil, discrete_input, holding_register, "
                "input_register",
            ),
        ),
        (
            OPCUA + "  points:\n    level: {input_register: 0}\n",
            (
                "E451",
                "a `input_register` point on opcua device `ua`",
                "a opcua device's points are: node",
            ),
        ),
        (
            MODBUS + "  points:\n    label: {input_register: 0}\n",
            (
                "E451",
                "`label` holds a string of at most 8 bytes, which no fieldbus point carries",
                "bind bool, int and float fields only",
            ),
        ),
        (
            MODBUS + "  points:\n    batch: {discrete_input: 0}\n",
            (
                "E451",
                "`batch` holds an integer, but a discrete_input is a bit",
                "bool fields go on coils and discrete inputs, numbers on holding and input "
                "registers",
            ),
        ),
        (
            MODBUS + "  points:\n    pump_on: {holding_register: 0}\n",
            (
                "E451",
                "`pump_on` holds a boolean, but a holding_register is a register",
                "bool fields go on coils and discrete inputs, numbers on holding and input "
                "registers",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0, direction: in}\n",
            (
                "E451",
                "`direction:` on a Modbus input_register",
                "a Modbus point's kind says its direction: remove `direction:`",
            ),
        ),
        (
            MODBUS + "  points:\n    pump_on: {coil: 0, scale: 2}\n",
            (
                "E451",
                "register options on coil `pump_on`",
                "type, scale, offset and word_order are for registers",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0, scale: 0}\n",
            (
                "E451",
                "scale 0 on `level` loses every value",
                "field value = raw * scale + offset: give a non-zero scale",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0, type: uint16, word_order: big}\n",
            (
                "E451",
                "word order on a one-register uint16 (`level`)",
                "word_order is for 32-bit types (int32, uint32, float32)",
            ),
        ),
        (
            MODBUS + "  points:\n    batch: {input_register: 0, type: float32}\n",
            (
                "E451",
                "int field `batch` on a register that gives fractions (float32, scale 1, offset 0)",
                FRACTION,
            ),
        ),
        (
            MODBUS + "  points:\n    batch: {input_register: 0, scale: 0.5}\n",
            (
                "E451",
                "int field `batch` on a register that gives fractions (int16, scale 0.5, offset 0)",
                FRACTION,
            ),
        ),
        (
            MODBUS + "  points:\n    batch: {input_register: 0, offset: 0.25}\n",
            (
                "E451",
                "int field `batch` on a register that gives fractions (int16, scale 1, "
                "offset 0.25)",
                FRACTION,
            ),
        ),
        (
            MODBUS + "  points:\n    big: {input_register: 0, type: uint16}\n",
            (
                "E452",
                "initial value 70000 of `big` does not fit its uint16 input_register on "
                "device `plc` (0..65535)",
                "widen the register type or change the scale",
            ),
        ),
        (
            MODBUS + "  points:\n    hot: {holding_register: 0, type: int16, scale: 0.01}\n",
            (
                "E452",
                "safe value 900.0 of `hot` does not fit its int16 holding_register on device "
                "`plc` (-327.68..327.67)",
                "widen the register type or change the scale",
            ),
        ),
        (
            OPCUA + '  points:\n    level: {node: "i=1", direction: in, scale: 2}\n',
            (
                "E451",
                "register options on OPC UA node `level`",
                "an OPC UA node carries the field's own type",
            ),
        ),
        (
            OPCUA + '  points:\n    level: {node: "i=1"}\n',
            (
                "E451",
                "OPC UA point `level` has no `direction:`",
                "say `direction: in` (read from the node) or `direction: out` (written to it)",
            ),
        ),
        (
            OPCUA + '  points:\n    level: {node: "Tank.Level", direction: in}\n',
            ("E456", "`Tank.Level` is not an OPC UA node id", "e.g. ns=2;s=Drum.On or ns=2;i=1001"),
        ),
        (
            "plc:\n  protocol: modbus_tcp\n  address: 127.0.0.1:0\n  timeout: 0.5\n"
            "  process: p\n"
            "  points:\n    level: {input_register: 0}\n",
            (
                "E456",
                "`127.0.0.1:0` is not an address of a modbus_tcp device",
                "HOST:PORT, e.g. 127.0.0.1:502",
            ),
        ),
        (
            "plc:\n  protocol: modbus_tcp\n  address: 127.0.0.1:65536\n  timeout: 0.5\n"
            "  process: p\n"
            "  points:\n    level: {input_register: 0}\n",
            (
                "E456",
                "`127.0.0.1:65536` is not an address of a modbus_tcp device",
                "HOST:PORT, e.g. 127.0.0.1:502",
            ),
        ),
        (
            "ua:\n  protocol: opcua\n  address: h:4840\n  timeout: 0.5\n  process: p\n"
            '  points:\n    level: {node: "i=1", direction: in}\n',
            (
                "E456",
                "`h:4840` is not an address of a opcua device",
                "opc.tcp://HOST:PORT[/PATH]",
            ),
        ),
        (
            OPCUA + '  unit: 2\n  points:\n    level: {node: "i=1", direction: in}\n',
            ("E456", "`unit:` of opcua device `ua`", "a unit id is Modbus's; remove it"),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0}\n    batch: {input_register: 0}\n",
            (
                "E455",
                "`batch` and `level` share input_register 0 of device `plc`",
                "give each field its own address (a 32-bit type takes two registers)",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 65535, type: int32}\n",
            ("E455", "`level` runs past the last address (65535)", ""),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0}\n"
            "other:\n  protocol: modbus_tcp\n  address: 127.0.0.1:502\n  timeout: 0.5\n"
            "  process: p\n"
            "  points:\n    batch: {input_register: 0}\n",
            (
                "E455",
                "device `other` is at the same address as device `plc`",
                "one device, one declaration: put both sets of points on one device",
            ),
        ),
        (
            MODBUS + "  points:\n    level: {input_register: 0}\n"
            "other:\n  protocol: modbus_tcp\n  address: 127.0.0.1:503\n  timeout: 0.5\n"
            "  process: p\n"
            "  points:\n    level: {input_register: 0}\n",
            (
                "E453",
                "`level` is an input of devices `plc` and `other`",
                "a field has one writer: read it from one device",
            ),
        ),
        (
            BUS + "  process: r\n  points:\n    level: {input_register: 0}\n",
            (
                "E457",
                "device `plc` names process `r`, which the system does not have",
                "declared processes: `p`",
            ),
        ),
        (
            BUS + "  points:\n    spare: {input_register: 0}\n",
            (
                "E457",
                "no controller of any process reads or writes a field of device `plc`",
                "say which process runs it (`process:`), or bind fields the controllers use",
            ),
        ),
        (
            MODBUS.replace("0.5", "0.05") + "  poll_period: 0.05\n"
            "  points:\n    level: {input_register: 0}\n",
            (
                "E457",
                "device `plc`'s timeout (0.05 s) is not longer than its poll period (0.05 s): "
                "it would be lost between two polls",
                "a timeout of two to five poll periods rides out one late answer",
            ),
        ),
    ],
)
def test_each_wrong_declaration_gets_its_one_error(tmp_path, monkeypatch, io, want):
    assert errors(tmp_path, monkeypatch, io) == [want]


LONG = "9" * 400  # an int no float holds (the loader refuses `.inf` and `1e999` itself)


@pytest.mark.parametrize(
    ("io", "want"),
    [
        (
            MODBUS.replace("timeout: 0.5", f"timeout: {LONG}")
            + "  points:\n    level: {input_register: 0}\n",
            ("E457", f"`{'9' * 27}...` is not a finite number of seconds", ""),
        ),
        (
            MODBUS + f"  poll_period: {LONG}\n  points:\n    level: {{input_register: 0}}\n",
            ("E457", f"`{'9' * 27}...` is not a finite number of seconds", ""),
        ),
        (
            MODBUS + f"  points:\n    level: {{input_register: 0, scale: {LONG}}}\n",
            ("E451", f"`{'9' * 27}...` is not a finite number", ""),
        ),
        (
            MODBUS + f"  points:\n    level: {{input_register: 0, offset: -{LONG}}}\n",
            ("E451", f"`-{'9' * 26}...` is not a finite number", ""),
        ),
    ],
)
def test_a_number_too_large_for_a_float_is_refused_as_not_finite(tmp_path, monkeypatch, io, want):
    """A device's times, a point's scale and offset: an int with more digits than a float
    holds is one located error quoting its first digits (it raised OverflowError)."""
    assert errors(tmp_path, monkeypatch, io) == [want]


def test_an_input_written_by_a_controller_names_the_writer(tmp_path, monkeypatch):
    [(code, message, hint)] = errors(
        tmp_path, monkeypatch, MODBUS + "  points:\n    valve_cmd: {input_register: 0}\n"
    )
    assert (code, hint) == (
        "E453",
        "a field has one writer: unbind it, or stop writing it in that controller",
    )
    assert message.startswith("`valve_cmd` is an input of device `plc` and is written by `tank` (")
    assert "tank.yaml:" in message  # where the controller writes it
