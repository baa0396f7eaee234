"""The soft PLCs a scenario runs against (`devices:`), and the faults its events do to them.

A scenario that names devices gets soft PLCs (`python -m rcsgen.tools.softplc`), each its
own OS process on free loopback ports, its plant's simulators in it (the devices of one
plant share one PLC, as one machine's PLC with several interfaces), and each device
pointed at its server (`RCSGEN_IO_<DEVICE>`) for the harness the run opens afterwards. A
device event pulls its plug (its server stopped through the PLC's control directory:
connections closed, new ones refused, while the PLC and its plant go on), puts it back (a
server again on the same port), freezes the PLC serving it (SIGSTOP: connections accepted,
nothing answered) or thaws it. At the end every PLC is stopped (thawed first), its ports
closed, the environment as it was.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

from ..harness import write_package
from ..softplc import endpoint_path
from .model import FREEZE, REPLUG, THAW, UNPLUG, Scenario, SoftPlc

START_DEADLINE = 120.0  # seconds a soft PLC may take to listen (imports and a plant on 2 cores)


def served_at(protocol: str, url: str, port: int) -> str:
    """Where a device's soft PLC serves it (`RCSGEN_IO_<DEVICE>`): loopback at `port`, an
    OPC UA device's endpoint path kept (`opc.tcp://host:port/PATH`)."""
    if protocol != "opcua":
        return f"127.0.0.1:{port}"
    return f"opc.tcp://127.0.0.1:{port}/{endpoint_path(url)}"


def holds(value: Any, want: Any, scale: float) -> bool:
    """Whether an output read back from a device is `want` to its resolution: within half a
    step of its scale (a register holds whole steps of it)."""
    return abs(float(value) - float(want)) <= abs(scale) / 2


class DeviceStartError(Exception):
    """A soft PLC that did not start: which, and what it said."""

    def __init__(self, plc: SoftPlc, said: str) -> None:
        super().__init__(f"the soft PLC of device `{plc.name}` did not start: {said}")
        self.plc = plc


class Plc:
    """One soft PLC process: the devices it serves (those of one plant share it, as one
    machine's PLC with several interfaces), their ports, its control directory."""

    def __init__(self, names: list[str], plant: Path | None, package: Path | None) -> None:
        self.names, self.plant, self.package = names, plant, package
        self.popen: subprocess.Popen[bytes] | None = None
        self.ports: dict[str, int] = {}


class Bench:
    """The scenario's soft PLCs: `start` before the harness opens, `apply` per device event,
    `close` after the harness closed (also after a failed start)."""

    def __init__(self, scenario: Scenario, package_dir: Path, scratch: Path) -> None:
        self.scenario, self.package_dir, self.scratch = scenario, package_dir, scratch
        self.plcs: dict[str, Plc] = {}  # device -> the PLC serving it
        self.saved: dict[str, str | None] = {}
        self.down: set[str] = set()  # the devices unplugged or frozen now
        self.probes: dict[str, Any] = {}  # device -> a link reading its outputs back
        self.control = scratch / "control"
        self.control.mkdir(parents=True, exist_ok=True)

    def start(self, layout: ModuleType) -> None:
        """Every PLC started side by side, then waited for; the devices pointed at them."""
        by_plant: dict[Path, Plc] = {}
        for name, wanted in self.scenario.devices.items():
            if wanted.plant is None:  # a PLC of its own, its inputs at the initial values
                self.plcs[name] = Plc([name], None, None)
            elif wanted.plant in by_plant:
                by_plant[wanted.plant].names.append(name)
                self.plcs[name] = by_plant[wanted.plant]
            else:
                from ...compiler.frontend import compile_paths

                front = compile_paths([wanted.plant])
                if not front.systems or front.diagnostics.errors:
                    raise DeviceStartError(wanted, f"its plant {wanted.plant} does not build")
                package = write_package(front.systems[0], self.scratch / name)
                self.plcs[name] = by_plant[wanted.plant] = Plc([name], wanted.plant, package)
        plcs = list(dict.fromkeys(self.plcs.values()))
        for plc in plcs:
            self._spawn(plc, [0] * len(plc.names))
        for plc in plcs:
            self._wait(plc)
        for name, plc in self.plcs.items():
            device = layout.IO_DEVICES[name]
            variable = f"RCSGEN_IO_{name.upper()}"
            self.saved.setdefault(variable, os.environ.get(variable))
            os.environ[variable] = served_at(device.protocol, device.url, plc.ports[name])

    def _spawn(self, plc: Plc, ports: list[int]) -> None:
        ready = self.scratch / f"{plc.names[0]}.port"
        ready.unlink(missing_ok=True)
        command = self.command(plc, ports, ready)
        with (self.scratch / f"{plc.names[0]}.log").open("ab") as log:
            plc.popen = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)

    def command(self, plc: Plc, ports: list[int], ready: Path) -> list[str]:
        """The soft PLC's command line: its devices on `ports` (0: any free one), the file it
        writes them to once listening, its control directory, its plant, the settings."""
        command = [sys.executable, "-m", "rcsgen.tools.softplc", "--io", str(self.package_dir)]
        for name, port in zip(plc.names, ports, strict=True):
            command += ["--device", name, "--port", str(port)]
        command += ["--ready", str(ready), "--control", str(self.control)]
        if plc.package is not None:
            command += ["--plant", str(plc.package), "--hooks", str(plc.plant)]
        for key, value in self.scenario.settings.items():
            command += ["--set", f"{key}={value}"]
        return command

    def _wait(self, plc: Plc) -> None:
        ready, popen = self.scratch / f"{plc.names[0]}.port", plc.popen
        assert popen is not None
        first = self.scenario.devices[plc.names[0]]
        deadline = time.monotonic() + START_DEADLINE
        while time.monotonic() < deadline:
            if popen.poll() is not None:
                said = (self.scratch / f"{plc.names[0]}.log").read_text(errors="replace").strip()
                raise DeviceStartError(first, said.splitlines()[-1] if said else "it exited")
            lines = ready.read_text().splitlines(keepends=True) if ready.is_file() else []
            if len(lines) == len(plc.names) and lines[-1].endswith("\n"):
                plc.ports = {n: int(line) for n, line in zip(plc.names, lines, strict=True)}
                return
            time.sleep(0.05)
        raise DeviceStartError(first, f"not listening after {START_DEADLINE:g} s")

    def apply(self, name: str, do: str) -> None:
        """A device event, done before this returns: `unplug` stops the device's server (its
        connections closed, its port refusing; the PLC and its plant go on), `replug` starts
        it again on its port; `freeze` stops the PLC process (every device it serves accepts
        and answers nothing), `thaw` continues it."""
        plc = self.plcs[name]
        popen = plc.popen
        assert popen is not None
        if do in (UNPLUG, REPLUG):
            order = self.control / name
            order.with_suffix(".new").write_text(do, encoding="utf-8")
            order.with_suffix(".new").replace(order)
            _wait_port(plc.ports[name], open_=do == REPLUG)
        elif do == FREEZE:
            popen.send_signal(signal.SIGSTOP)
        elif do == THAW:
            popen.send_signal(signal.SIGCONT)
        gone = [name] if do in (UNPLUG, REPLUG) else plc.names
        if do in (UNPLUG, FREEZE):
            self.down.update(gone)
        else:
            self.down.difference_update(gone)
        for each in gone:
            self._drop_probe(each)

    def not_safe_on_survivors(self, layout: ModuleType) -> list[str]:
        """The actuators bound to a device still up that it does not hold at their safe
        values (read back from the device itself, as a commissioning engineer's client
        would): empty when every one is safe there."""
        from ...runtime.io_cycle import make_link, relocated

        safe = dict(getattr(layout, "SAFE_VALUES", {}))
        missing = []
        for name in self.scenario.devices:
            device = relocated(layout.IO_DEVICES[name])
            points = [p for p in device.outputs if p.field in safe]
            if name in self.down or not points:
                continue
            try:
                if name not in self.probes:
                    probe = make_link(device)
                    probe.connect()
                    self.probes[name] = probe
                held = {p.field: self.probes[name].read_point(p) for p in points}
            except Exception as error:  # noqa: BLE001 - said, and asked again next cycle
                self._drop_probe(name)
                missing.append(f"device `{name}` could not be read back ({error})")
                continue
            for point in points:
                value, want = held[point.field], safe[point.field]
                if not holds(value, want, point.scale):
                    missing.append(
                        f"device `{name}` holds `{point.field}` {value!r}, not its safe {want!r}"
                    )
        return missing

    def _drop_probe(self, name: str) -> None:
        probe = self.probes.pop(name, None)
        if probe is not None:
            try:
                probe.close()
            except Exception:  # noqa: BLE001, S110 - a probe of a device that is gone
                pass

    def close(self) -> None:
        """Every PLC stopped (thawed first: a frozen one handles SIGTERM once thawed), its
        ports closed; the environment as before."""
        for name in list(self.probes):
            self._drop_probe(name)
        plcs = [p for p in dict.fromkeys(self.plcs.values()) if p.popen is not None]
        for plc in plcs:
            assert plc.popen is not None
            if plc.popen.poll() is None:
                plc.popen.send_signal(signal.SIGCONT)
                plc.popen.terminate()
        for plc in plcs:
            assert plc.popen is not None
            try:
                plc.popen.wait(20)
            except subprocess.TimeoutExpired:
                plc.popen.kill()
                plc.popen.wait(10)
            for port in plc.ports.values():
                _wait_port(port, open_=False)
        for variable, value in self.saved.items():
            if value is None:
                os.environ.pop(variable, None)
            else:
                os.environ[variable] = value


def _wait_port(port: int, open_: bool, deadline: float = 10.0) -> None:
    """Wait (bounded) until something listens on `port` on loopback (`open_`), or nothing."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        with socket.socket() as probe:
            probe.settimeout(0.5)
            if (probe.connect_ex(("127.0.0.1", port)) == 0) == open_:
                return
        time.sleep(0.02)
