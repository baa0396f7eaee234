"""The I/O module: a process's devices read at the start of its cycle, written at its end.

A system that binds world fields to fieldbus points (`io:` in system.yaml, docs/io.md) gets,
in each process that runs a device, an I/O module around its controllers: `before` copies
the device's latest inputs into the world fields (first in the execution order), `after`
hands the output fields' values to the device (last). The protocol traffic runs on one
thread per device, at the device's poll period, so a silent device never stretches the
cycle; the cycle only looks at what the thread last got and when.

Faults: a device with no good answer (silence, a late answer, a Modbus exception code, a
refused connection) for longer than its declared `timeout` is lost, detected by the first
cycle after that: its input fields are stale (they keep their last values, `ctl status`
marks them), and the process reacts as to a lost process (`loop.Process.react`): every
actuator is latched at its safe value, so the outputs written to the devices that still
answer are the safe values, and the controllers that read the device's inputs or write its
outputs, with every controller above them, go to their safe state. Another process whose
controllers depend on the device so watches its record and reacts the same way. The thread
reconnects by itself (logged); the latches stay until an operator's reset, as after any loss.

Each device's record in the block (`layout.IO_RECORDS`) holds its state and its counts of
reads, writes, timeouts, retries, errors, reconnections and losses (`ctl status`, traces).
Standard library only: the protocol stacks are imported by the link a device's protocol
names (`io_modbus.py`, `io_opcua.py`), when the device is started.
"""

from __future__ import annotations

import os
import re
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any, Protocol

from .contract import Record, StaleRead
from .io_points import (
    BROKEN,
    CLIPPED,
    CONNECTING,
    LOST,
    MODBUS_TCP,
    ONLINE,
    OPCUA,
    REFUSED,
    STOPPED,
    TALLIES,
    TIMED_OUT,
    UNCONNECTED,
    Device,
    IoRefused,
    IoTimeout,
    Point,
    shown_address,
)
from .override import overrides


class Link(Protocol):
    """What a protocol gives the I/O module: one connection to one device."""

    def connect(self) -> None: ...

    def read(self) -> dict[str, object]: ...  # input field -> value

    def read_point(self, point: Point) -> object: ...  # one point; IoRefused if it has none

    def write(self, values: dict[str, object]) -> int: ...  # the values clipped to fit

    def close(self) -> None: ...


def make_link(device: Device) -> Link:
    """The link a device's protocol names; its library is imported only now. ImportError,
    naming the extra to install, when the library is not there."""
    extra = "modbus" if device.protocol == MODBUS_TCP else "opcua"
    try:
        if device.protocol == MODBUS_TCP:
            from .io_modbus import ModbusLink

            return ModbusLink(device)
        from .io_opcua import OpcUaLink

        return OpcUaLink(device)
    except ImportError as error:
        raise ImportError(
            f"I/O device {device.name} ({device.protocol}) needs {error.name or error}: "
            f"pip install 'rcsgen[{extra}]'"
        ) from None


def _log(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


class DeviceRunner:
    """One device's thread: connects, polls its inputs and writes its outputs every poll
    period, reconnects after a failure; counts everything. The cycle reads `snapshot()`."""

    def __init__(
        self,
        device: Device,
        link_factory: Callable[[Device], Link] = make_link,
        log: Callable[[str], None] = _log,
        who: str = "",
        held: Callable[[], dict[str, object]] | None = None,
    ) -> None:
        self.device, self.link_factory, self.log = device, link_factory, log
        # The overrides of the block (field -> value) the thread writes over what the cycle
        # handed it: an actuator latched safe reaches the device at the next poll, even when
        # the process's loop is stuck (a hook that blocks) and hands nothing new.
        self.held = held
        self.who = who or device.name
        self.lock = threading.Lock()
        self.counts: dict[str, int] = dict.fromkeys(TALLIES, 0)
        self.state = CONNECTING
        self.inputs: dict[str, object] | None = None
        self.inputs_seq = 0  # how many good reads there have been
        self.outputs: dict[str, object] | None = None  # the last the cycle handed over
        self.stopping = threading.Event()
        self.first = threading.Event()  # set after the first good exchange (or a stop)
        self.thread = threading.Thread(target=self._run, name=f"io-{device.name}", daemon=True)
        self.link: Link | None = None
        # The first link, made by the caller's thread: the protocol library imported (and a
        # missing one said) before the cycles start, not on the device's clock.
        self.spare: Link | None = link_factory(device)
        self.ever_connected = False
        self.failed = False  # the last attempt failed (so the next connect is a retry)

    def start(self) -> None:
        self.thread.start()

    # ------------------------------------------------------------ the thread

    def _run(self) -> None:
        device = self.device
        next_at = time.monotonic()
        while not self.stopping.is_set():
            self._exchange()
            next_at += device.poll_period
            now = time.monotonic()
            if next_at < now:  # fell behind (a long timeout): poll again one period from now
                next_at = now + device.poll_period
            self.stopping.wait(next_at - now)
        self.first.set()

    def _exchange(self) -> None:
        """Connect if needed, read every input, write every output: one poll."""
        if self.link is None and not self._connect():
            return
        link = self.link
        assert link is not None
        began = time.monotonic_ns()
        try:
            values = link.read() if self.device.inputs else {}
            with self.lock:
                outputs = self.outputs
            if outputs is not None and self.held is not None:
                overlay = self.held()
                if overlay:
                    outputs = {f: overlay.get(f, v) for f, v in outputs.items()}
            clipped = link.write(outputs) if outputs is not None and self.device.outputs else 0
        except IoRefused as error:
            self._count("errors", REFUSED)
            self._failed(f"answered with an exception: {error}", close=False)
            return
        except IoTimeout as error:
            self._count("timeouts", TIMED_OUT)
            self._failed(f"no answer in time: {error}", close=True)
            return
        except Exception as error:  # noqa: BLE001 - a broken connection, a protocol error
            self._count("errors", BROKEN)
            self._failed(f"{type(error).__name__}: {error}", close=True)
            return
        now = time.monotonic_ns()
        with self.lock:
            self.inputs = values
            self.inputs_seq += 1
            counts = self.counts
            counts["reads"] += 1 if self.device.inputs else 0
            counts["writes"] += 1 if outputs is not None and self.device.outputs else 0
            counts["errors"] += clipped
            if clipped:
                counts["last_error"] = CLIPPED
            counts["last_ok_ns"] = now
            counts["round_trip_ns"] = now - began
            recovered = self.failed
            self.failed = False
        if recovered:
            self.log(f"{self.who}: I/O device {self.device.name} answers again ({self._where()})")
        self.first.set()

    def _connect(self) -> bool:
        if self.failed or self.ever_connected:
            self._count("retries")
        try:
            link, self.spare = self.spare or self.link_factory(self.device), None
            link.connect()
        except Exception as error:  # noqa: BLE001 - any failure to connect is a retry
            with self.lock:
                self.counts["last_error"] = UNCONNECTED
            self._failed(f"cannot connect: {error}", close=False)
            return False
        self.link = link
        if self.ever_connected:  # logged once it answers again (a frozen device accepts)
            self._count("reconnects")
        self.ever_connected = True
        return True

    def _failed(self, what: str, close: bool) -> None:
        if not self.failed:
            self.log(f"{self.who}: I/O device {self.device.name} ({self._where()}): {what}")
        self.failed = True
        if close and self.link is not None:
            self._close_link()

    def _close_link(self) -> None:
        link, self.link = self.link, None
        try:
            if link is not None:
                link.close()
        except Exception:  # noqa: BLE001, S110 - closing a broken connection: nothing to do
            pass

    def _where(self) -> str:
        return self.device.url or f"{self.device.host}:{self.device.port}"

    def _count(self, name: str, error: int | None = None) -> None:
        with self.lock:
            self.counts[name] += 1
            if error is not None:
                self.counts["last_error"] = error

    # ------------------------------------------------------------ the cycle's side

    def snapshot(self) -> tuple[int, dict[str, object] | None, dict[str, int]]:
        """(how many good reads, the latest inputs, the counts), taken together."""
        with self.lock:
            return self.inputs_seq, self.inputs, dict(self.counts)

    def hand(self, outputs: dict[str, object]) -> None:
        """The output fields' values the device is to get at its next poll."""
        with self.lock:
            self.outputs = outputs

    def stop(self, final: dict[str, object] | None = None) -> None:
        """Stop the thread; write `final` (the safe outputs) once more if the device is
        connected, then close the connection."""
        self.stopping.set()
        if self.thread.is_alive():
            self.thread.join(self.device.timeout + 1.0)
        if final is not None and self.link is not None and self.device.outputs:
            try:
                self.link.write(final)
                self._count("writes")
            except Exception:  # noqa: BLE001, S110 - a device that is gone keeps what it had
                pass
        self._close_link()


class IoModule:
    """A process's I/O: the devices it runs (`before`, `after` around its controllers) and
    the devices run elsewhere whose inputs its controllers read (watched)."""

    def __init__(
        self,
        process: Any,
        link_factory: Callable[[Device], Link] = make_link,
        log: Callable[[str], None] = _log,
    ) -> None:
        layout: ModuleType = process.layout
        self.process, self.layout, self.buf = process, layout, process.block.buf
        devices: dict[str, Device] = layout.IO_DEVICES
        self.records: dict[str, Record] = layout.IO_RECORDS
        name = process.plan.name
        self.devices = [relocated(devices[d]) for d in process.plan.io]
        mine = set(process.plan.modules)
        reactions = {d: device_reaction(layout, d) for d in devices}
        # devices run elsewhere whose loss puts a module of this process in its safe state
        self.watched = [
            d.name
            for d in devices.values()
            if d.name not in process.plan.io and mine & set(reactions[d.name].safe)
        ]
        self.runners = {
            d.name: DeviceRunner(d, link_factory, log, who=name, held=self.held)
            for d in self.devices
        }
        self.lost: set[str] = set()
        self.copied = dict.fromkeys(self.runners, 0)  # the read last copied into the block
        self.world = {p.field: layout.WORLD[p.field] for d in self.devices for p in d.points}
        for device, reaction in reactions.items():
            process.reactions[key(device)] = reaction
        self.started_ns = time.monotonic_ns()
        self.log = log

    def held(self) -> dict[str, object]:
        """The block's overrides, field -> value (a device's thread reads them each poll);
        {} while there are none (one byte read) or while one is being written."""
        if not self.buf[self.layout.OVERRIDDEN_AT]:
            return {}
        try:
            return {field: value for field, (_, value) in overrides(self.layout, self.buf).items()}
        except StaleRead:  # an override being written: the next poll has it
            return {}

    def start(self) -> None:
        """Start every device's thread and wait (each at most its timeout) for its first
        exchange, so the first cycle reads the devices rather than the initial values."""
        for runner in self.runners.values():
            self._write_record(runner.device.name, CONNECTING, runner.counts)
            address = shown_address(runner.device)  # (RCSGEN_IO_<DEVICE>'s, if it was set)
            self.records[runner.device.name].write(self.buf, address=address)
            runner.start()
        for runner in self.runners.values():
            runner.first.wait(runner.device.timeout)
        self.started_ns = time.monotonic_ns()

    # ------------------------------------------------------------ each cycle

    def before(self) -> None:
        """The start of the cycle: each device's latest inputs into the world fields (none
        from a lost device, whose fields are then stale), a device silent for longer than
        its timeout lost; watched devices lost elsewhere reacted to."""
        now = time.monotonic_ns()
        forced = overrides(self.layout, self.buf) if self.buf[self.layout.OVERRIDDEN_AT] else {}
        for name, runner in self.runners.items():
            seq, inputs, counts = runner.snapshot()
            device = runner.device
            last_ok = counts["last_ok_ns"] or self.started_ns
            silent = now - last_ok > device.timeout * 1e9
            if silent:
                if name not in self.lost:
                    self.lost.add(name)
                    counts["losses"] += 1
                    with runner.lock:
                        runner.counts["losses"] += 1
                    self.log(
                        f"{self.process.plan.name}: I/O device {name} lost: no good answer "
                        f"for {device.timeout:g} s; its inputs are stale, actuators safe"
                    )
                    self.process.react(key(name))
            else:
                if name in self.lost:
                    self.lost.discard(name)
                if inputs is not None and seq != self.copied[name]:
                    self.copied[name] = seq
                    for field, value in inputs.items():
                        if field not in forced:
                            self.world[field].write(self.buf, **{field: value})
            self._write_record(
                name, LOST if name in self.lost else ONLINE if seq else CONNECTING, counts
            )
        for name in self.watched:
            try:
                state = int(self.records[name].read(self.buf)["state"])  # type: ignore[call-overload]
            except StaleRead:  # being written, or its writer died mid-write (a lost process)
                continue
            if state == LOST and name not in self.lost:
                self.lost.add(name)
                self.process.react(key(name))
            elif state != LOST and name in self.lost:
                self.lost.discard(name)

    def after(self) -> None:
        """The end of the cycle: the output fields' values to each device's next poll."""
        for runner in self.runners.values():
            runner.hand(self.outputs(runner.device))

    def outputs(self, device: Device) -> dict[str, object]:
        buf, world = self.buf, self.layout.WORLD
        return {p.field: world[p.field].read(buf)[p.field] for p in device.outputs}

    def close(self) -> None:
        """Stop every device, writing its outputs once more (the process latched them safe
        when it stopped), and mark it STOPPED."""
        for name, runner in self.runners.items():
            runner.stop(self.outputs(runner.device))
            self._write_record(name, STOPPED, runner.snapshot()[2])

    def _write_record(self, name: str, state: int, counts: dict[str, int]) -> None:
        record = self.records[name]
        record.write(self.buf, state=state, **{f: counts[f] for f in TALLIES})


def relocated(device: Device, environ: dict[str, str] | None = None) -> Device:
    """`device`, at the address `RCSGEN_IO_<DEVICE>` gives instead of the declared one, if
    set (HOST:PORT for Modbus TCP, the endpoint URL for OPC UA): the same build pointed at
    a test bench's PLC or a simulator. ValueError, one line, for an address it cannot use."""
    variable = f"RCSGEN_IO_{device.name.upper()}"
    text = (os.environ if environ is None else environ).get(variable)
    if text is None:
        return device
    if device.protocol == OPCUA:
        found = re.match(r"^opc\.tcp://([^\s/:]+|\[[0-9A-Fa-f:.]+\]):([0-9]{1,5})(/\S*)?$", text)
    else:
        found = re.match(r"^([^\s:]+|\[[0-9A-Fa-f:.]+\]):([0-9]{1,5})$", text)
    if found is None or not 0 < int(found[2]) < 65536:
        want = "opc.tcp://HOST:PORT[/PATH]" if device.protocol == OPCUA else "HOST:PORT"
        raise ValueError(
            f"{variable}={text!r}: not an address of I/O device {device.name} ({want})"
        )
    url = text if device.protocol == OPCUA else ""
    return replace(device, host=found[1].strip("[]"), port=int(found[2]), url=url)


def key(device: str) -> str:
    """The name a device's loss reaction goes by among the process's reactions."""
    return f"io:{device}"


@dataclass(frozen=True)
class DeviceReaction:
    """What `loop.Process.react` reads of a reaction, for a device."""

    latch: tuple[str, ...]
    safe: tuple[str, ...]
    told: tuple[tuple[str, str], ...] = ()
    contained: bool = False


def device_reaction(layout: ModuleType, device: str) -> DeviceReaction:
    """What the loss of `device` asks: every actuator latched safe; the controllers that read
    its inputs or write its outputs, with every controller above them, in their safe state
    (the `halt_all` reaction to a lost process, for the controllers that depend on it)."""
    supervisor = {sub: sup for sup, subs in layout.SUBORDINATES.items() for sub in subs}
    safe: list[str] = []
    for module in layout.IO_DEPENDENTS.get(device, ()):
        while module and module not in safe:
            safe.append(module)
            module = supervisor.get(module, "")
    return DeviceReaction(tuple(getattr(layout, "SAFE_VALUES", {})), tuple(safe))


def attach(process: Any) -> IoModule | None:
    """The process's I/O module, started, or None when the system declares no I/O its
    controllers touch."""
    if not getattr(process.layout, "IO_DEVICES", None):
        return None
    module = IoModule(process)
    if not module.devices and not module.watched:
        return None
    module.start()
    return module
