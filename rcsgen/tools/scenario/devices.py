"""The soft PLCs a scenario runs against (`devices:`), and the faults its events do to them.

A scenario that names devices gets, for each, a soft PLC (`python -m rcsgen.tools.softplc`)
as its own OS process on a free loopback port, its plant's simulators in it, and the
device pointed at it (`RCSGEN_IO_<DEVICE>`) for the harness the run opens afterwards. A
device event pulls the plug (SIGKILL: connections reset, new ones refused), puts it back
(a PLC started again on the same port; its plant starts over, as a PLC powered up again),
freezes it (SIGSTOP: connections accepted, nothing answered) or thaws it. At the end every
PLC is stopped (thawed first), its port closed, the environment as it was.
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
from .model import FREEZE, REPLUG, THAW, UNPLUG, Scenario, SoftPlc

START_DEADLINE = 120.0  # seconds a soft PLC may take to listen (imports and a plant on 2 cores)


class DeviceStartError(Exception):
    """A soft PLC that did not start: which, and what it said."""

    def __init__(self, plc: SoftPlc, said: str) -> None:
        super().__init__(f"the soft PLC of device `{plc.name}` did not start: {said}")
        self.plc = plc


class Bench:
    """The scenario's soft PLCs: `start` before the harness opens, `apply` per device event,
    `close` after the harness closed (also after a failed start)."""

    def __init__(self, scenario: Scenario, package_dir: Path, scratch: Path) -> None:
        self.scenario, self.package_dir, self.scratch = scenario, package_dir, scratch
        self.popens: dict[str, subprocess.Popen[bytes]] = {}
        self.ports: dict[str, int] = {}
        self.plants: dict[str, Path] = {}
        self.saved: dict[str, str | None] = {}
        self.down: set[str] = set()  # the devices unplugged or frozen now
        self.probes: dict[str, Any] = {}  # device -> a link reading its outputs back

    def start(self, layout: ModuleType) -> None:
        """Every PLC started side by side, then waited for; the devices pointed at them."""
        devices = layout.IO_DEVICES
        built: dict[Path, Path] = {}
        for name, plc in self.scenario.devices.items():
            if plc.plant is not None:
                if plc.plant not in built:
                    from ...compiler.frontend import compile_paths

                    front = compile_paths([plc.plant])
                    if not front.systems or front.diagnostics.errors:
                        raise DeviceStartError(plc, f"its plant {plc.plant} does not build")
                    built[plc.plant] = write_package(front.systems[0], self.scratch / name)
                self.plants[name] = built[plc.plant]
            self._spawn(name, 0)
        for name, plc in self.scenario.devices.items():
            self.ports[name] = self._wait(plc)
            device = devices[name]
            variable = f"RCSGEN_IO_{name.upper()}"
            self.saved.setdefault(variable, os.environ.get(variable))
            path = device.url.split("/", 3)[3] if device.url.count("/") >= 3 else ""
            os.environ[variable] = (
                f"opc.tcp://127.0.0.1:{self.ports[name]}/{path}"
                if device.protocol == "opcua"
                else f"127.0.0.1:{self.ports[name]}"
            )

    def _spawn(self, name: str, port: int) -> None:
        plc = self.scenario.devices[name]
        ready = self.scratch / f"{name}.port"
        ready.unlink(missing_ok=True)
        command = [sys.executable, "-m", "rcsgen.tools.softplc", "--io", str(self.package_dir)]
        command += ["--device", name, "--port", str(port), "--ready", str(ready)]
        if plc.plant is not None:
            command += ["--plant", str(self.plants[name]), "--hooks", str(plc.plant)]
        for key, value in self.scenario.settings.items():
            command += ["--set", f"{key}={value}"]
        with (self.scratch / f"{name}.log").open("ab") as log:
            self.popens[name] = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)

    def _wait(self, plc: SoftPlc) -> int:
        ready, popen = self.scratch / f"{plc.name}.port", self.popens[plc.name]
        deadline = time.monotonic() + START_DEADLINE
        while time.monotonic() < deadline:
            if popen.poll() is not None:
                said = (self.scratch / f"{plc.name}.log").read_text(errors="replace").strip()
                raise DeviceStartError(plc, said.splitlines()[-1] if said else "it exited")
            if ready.is_file() and ready.read_text().endswith("\n"):
                return int(ready.read_text())
            time.sleep(0.05)
        raise DeviceStartError(plc, f"not listening after {START_DEADLINE:g} s")

    def apply(self, name: str, do: str) -> None:
        """A device event: the fault done (or undone) now."""
        popen = self.popens[name]
        self.down.discard(name)
        if do in (UNPLUG, FREEZE):
            self.down.add(name)
            self._drop_probe(name)
        if do == UNPLUG:
            popen.kill()
            popen.wait(30)
        elif do == FREEZE:
            popen.send_signal(signal.SIGSTOP)
        elif do == THAW:
            popen.send_signal(signal.SIGCONT)
        elif do == REPLUG:
            self._spawn(name, self.ports[name])
            self._wait(self.scenario.devices[name])

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
                if abs(float(value) - float(want)) > abs(point.scale) / 2:
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
        port closed; the environment as before."""
        for name in list(self.probes):
            self._drop_probe(name)
        for popen in self.popens.values():
            if popen.poll() is None:
                popen.send_signal(signal.SIGCONT)
                popen.terminate()
        for popen in self.popens.values():
            try:
                popen.wait(20)
            except subprocess.TimeoutExpired:
                popen.kill()
                popen.wait(10)
        for port in self.ports.values():
            _closed(port)
        for variable, value in self.saved.items():
            if value is None:
                os.environ.pop(variable, None)
            else:
                os.environ[variable] = value


def _closed(port: int, deadline: float = 10.0) -> None:
    """Wait (bounded) until nothing listens on `port` on loopback any more."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        with socket.socket() as probe:
            probe.settimeout(0.5)
            if probe.connect_ex(("127.0.0.1", port)) != 0:
                return
        time.sleep(0.05)


def safe_check(harness: Any, name: str, bench: Any = None) -> list[str]:
    """What is not yet as a lost device asks (empty: all of it): the device LOST, every input
    field it feeds marked stale, every actuator of the system latched at its safe value, and
    (with the `bench`) held at it by every device still up."""
    from .run import io_counts

    layout = harness.layout
    device = layout.IO_DEVICES[name]
    shown = io_counts(harness, name, device)
    missing = []
    if shown["state"] != "LOST":
        missing.append(f"device `{name}` is {shown['state']}, not LOST")
    inputs = [p.field for p in device.inputs]
    if sorted(shown["stale"]) != sorted(inputs):
        missing.append(f"its inputs marked stale are {shown['stale']}, not {inputs}")
    safe = dict(getattr(layout, "SAFE_VALUES", {}))
    world = harness.world.snapshot(list(safe))
    held = harness.world.overrides()
    for field, value in safe.items():
        if world[field] != value or held.get(field) != "SAFE":
            missing.append(f"`{field}` is {world[field]!r}, not latched at its safe {value!r}")
    if not missing and bench is not None:  # the block is safe: then what the devices hold
        missing = bench.not_safe_on_survivors(layout)
    return missing
