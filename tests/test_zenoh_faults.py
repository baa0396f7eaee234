"""A host over Zenoh fails safe at its start and at its launcher's death (issue 24, "fail safe").

The start-up barrier over Zenoh (`Launcher.hearing`): a launch whose processes do not all
hear each other within its bound is refused in one line naming who does not hear whom, no
process having run a cycle (nothing it drives moved), everything stopped and cleaned up. A
launcher killed outright (kill -9): its children latch every actuator safe, stop, and remove
their blocks and the launcher's. Real processes of the miner (generated/miner), loopback
only, bounded waits on conditions; nothing here asserts how fast.
"""

from __future__ import annotations

import importlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import read_whole, wait_for
from support.running import alive, attached, listening

from rcsgen.runtime.operate.launcher import not_ready
from rcsgen.tools.harness import import_package

zenoh = pytest.importorskip("zenoh")

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "generated" / "miner"
HOOKS = ROOT / "specs" / "miner"
BOUND = 3.0  # the start-up bound of these launches (the spec's default is 10 s)


@pytest.fixture(scope="module")
def miner() -> ModuleType:
    return import_package(PACKAGE, HOOKS)


def rcs(miner: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{miner.__name__}.{name}")


def own_shm(segment: str) -> set[str]:
    """The entries of /dev/shm of this launch: its launcher's segment and its processes'."""
    names = set(os.listdir("/dev/shm")) if os.path.isdir("/dev/shm") else set()
    return {n for n in names if n == segment or n.startswith(f"{segment}_")}


def test_who_does_not_hear_whom_is_said_for_each_process_not_ready() -> None:
    """The refusal's items: the launcher's node not hearing a process comes first (nothing
    else is known of it), then whom a process said it does not hear, then no cycle yet; a
    process that ended is said with how it ended, unless it had become ready (its cycles
    run). All ready: nothing."""
    names = ["pc1", "pc2", "pc3"]
    hears = {"pc1": {"pc2", "pc3"}, "pc2": {"pc1"}, "pc3": {"pc1", "pc2"}}
    assert not_ready(names, {"pc1", "pc2"}, hears, {"pc1"}, {}) == {
        "pc2": "pc2 does not hear pc3",
        "pc3": "the launcher does not hear pc3",
    }
    assert not_ready(names, set(names), hears, {"pc1", "pc2"}, {"pc2": 1}) == {
        "pc2": "pc2 (exited 1)",
        "pc3": "pc3 (no cycle yet)",
    }
    everyone = {n: set(names) - {n} for n in names}
    assert not_ready(names, set(names), everyone, set(names), {"pc3": 0}) == {}
    assert not_ready(names, set(names), {}, set(names), {}) == {
        "pc1": "pc1 does not hear pc2, pc3",
        "pc2": "pc2 does not hear pc1, pc3",
        "pc3": "pc3 does not hear pc1, pc2",
    }


def launcher_of(miner: ModuleType, segment: str) -> Any:
    module = rcs(miner, "rcs.operate.launcher")
    system = module.System(
        "miner",
        rcs(miner, "layout"),
        {p: rcs(miner, f"main_{p}").PLAN for p in ("pc1", "pc2")},
        (str(PACKAGE.parent), str(HOOKS)),
    )
    launcher = module.Launcher(system, segment, transport="zenoh")
    launcher.startup_timeout = BOUND
    return launcher


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["pc1", "--transport", "zenoh", "--peers", "pc2,pc9"], "--peers: no process(es) ['pc9']"),
        (["pc1", "--peers", "pc2"], "--peers goes with PROCESS and --transport zenoh"),
        (
            ["--transport", "zenoh", "--peers", "pc2"],
            "--peers goes with PROCESS and --transport zenoh",
        ),
    ],
)
def test_a_bad_peers_argument_is_one_line_and_exit_2(
    miner: ModuleType, capsys: pytest.CaptureFixture[str], args: list[str], message: str
) -> None:
    """`--peers` (what a launcher gives its children over Zenoh) names processes of the
    system, with one PROCESS over Zenoh; anything else is a usage mistake."""
    launcher = launcher_of(miner, "unused")
    module = sys.modules[type(launcher).__module__]
    with pytest.raises(SystemExit) as exited:
        module.parse_args(launcher.system, args)
    assert exited.value.code == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.endswith(message), line


@pytest.mark.parametrize("fault", ["stopped", "port taken"])
def test_a_host_whose_processes_do_not_all_hear_each_other_is_refused_safe_and_clean(
    miner: ModuleType, monkeypatch: pytest.MonkeyPatch, fault: str
) -> None:
    """pc2 SIGSTOPped as it starts, before it connects: at the bound the launch is refused,
    the line naming pc2 as not heard (and pc1 not hearing it, if pc1 said so in time). pc2's
    listen port taken by another program: pc2 cannot listen, and the launch is refused at
    once, naming it and its exit. Either way pc1, which runs every controller and writes
    every actuator, never ran a cycle: its block's actuators never left their safe values;
    afterwards no child, no /dev/shm entry and no port of the launch is left."""
    layout = rcs(miner, "layout")
    segment = f"rcsgen_zenohf_{os.getpid()}_{fault.split()[0]}"
    launcher = launcher_of(miner, segment)
    module = sys.modules[type(launcher).__module__]
    spawned: dict[str, subprocess.Popen[bytes]] = {}
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen()
    endpoint = module.local_endpoint
    ports: list[str] = []

    def local_endpoint(security: object) -> str:  # pc2's (the second) is taken, if asked
        found = endpoint(security)
        if fault == "port taken" and len(ports) == 1:
            found = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        ports.append(found)
        return str(found)

    def spawn(name: str, attach: bool) -> subprocess.Popen[bytes]:
        popen = real_spawn(name, attach)
        if fault == "stopped" and name == "pc2":
            popen.send_signal(signal.SIGSTOP)  # at its interpreter's start: nothing opened
        spawned[name] = popen
        return popen

    real_spawn = launcher._spawn
    monkeypatch.setattr(launcher, "_spawn", spawn)
    monkeypatch.setattr(module, "local_endpoint", local_endpoint)
    failure: list[BaseException] = []

    def start() -> None:
        try:
            launcher.start()
        except BaseException as error:  # noqa: BLE001 - what the test looks at
            failure.append(error)

    starting = threading.Thread(target=start)
    starting.start()
    seen: list[dict[str, object]] = []
    pc1 = None
    try:
        while starting.is_alive():  # pc1's own block, as long as it is there
            pc1 = pc1 or attached(rcs(miner, "rcs.block"), layout, f"{segment}_pc1")()
            if pc1 is not None:
                world = {f: read_whole(layout.WORLD[f], pc1.buf)[f] for f in layout.SAFE_VALUES}
                seen.append(world)
                cycles = read_whole(layout.PROCESSES["pc1"], pc1.buf)["heartbeat"]
                assert cycles == 0, "pc1 ran a cycle before it heard pc2"
            time.sleep(0.01)
        starting.join()
    finally:
        taken.close()
        if pc1 is not None:
            pc1.close()
        launcher.stop()  # (were it started after all: stopped, a frozen child continued)
    assert len(failure) == 1 and isinstance(failure[0], module.StartupFailed), failure
    line = str(failure[0])
    assert "\n" not in line
    assert line.startswith(f"the system did not become ready within {BOUND:g} s: ")
    if fault == "stopped":
        assert "the launcher does not hear pc2" in line, line
        assert line.count(";") <= 1 and ("pc1" not in line or "pc1 does not hear pc2" in line)
    else:
        assert line.endswith("pc2 (exited 1)"), line
    assert seen or fault == "port taken", "pc1's block was never seen"  # (refused at once)
    assert all(values == layout.SAFE_VALUES for values in seen)
    (summary,) = [line for line in launcher.final if line.startswith("pc1: ")]
    assert ", 0 cycles, " in summary, launcher.final
    assert not launcher.children
    assert all(not alive(p.pid) for p in spawned.values())
    assert own_shm(segment) == set()
    assert listening({int(e.rsplit(":", 1)[1]) for e in [launcher.listen, *ports]}) == set()


def test_a_killed_launcher_s_children_latch_every_actuator_and_remove_every_block(
    miner: ModuleType,
) -> None:
    """`python -m miner --transport zenoh`, running; its launcher killed outright (kill -9):
    each child sees its pipe close, latches every actuator safe in its block, stops and
    removes its block and the launcher's (which the launcher could not). No child, no
    /dev/shm entry, no port of the launch is left."""
    layout, blocks = rcs(miner, "layout"), rcs(miner, "rcs.block")
    override = rcs(miner, "rcs.override")
    segment = f"rcsgen_zenohf_{os.getpid()}_kill"
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    launcher = subprocess.Popen(
        [sys.executable, "-m", "miner", "--transport", "zenoh", "--shm", segment]
        + ["--listen", f"tcp/127.0.0.1:{port}"],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        stderr=subprocess.DEVNULL,
    )
    pc1 = None
    try:
        pc1 = wait_for(attached(blocks, layout, f"{segment}_pc1"), "pc1's block", deadline=60)
        assert pc1 is not None
        buf = pc1.buf
        wait_for(lambda: layout.PROCESSES["pc1"].read(buf)["heartbeat"] > 2, "pc1 running", 60)
        wait_for(lambda: layout.PROCESSES["pc2"].read(buf)["heartbeat"] > 2, "pc2 heard", 60)
        wait_for(lambda: os.path.exists(f"/dev/shm/{segment}"), "the launcher's block")
        pids = [int(read_whole(layout.PROCESSES[p], buf)["pid"]) for p in ("pc1", "pc2")]
        ports = {port}
        for pid in pids:  # each child's own listening port, from its command line
            words = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            ports.add(int(words[words.index(b"--listen") + 1].rsplit(b":", 1)[1]))
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(30)
        wait_for(
            lambda: set(override.overrides(layout, buf)) == set(layout.SAFE_VALUES),
            "every actuator latched safe in pc1's block",
        )
        values = {f: read_whole(layout.WORLD[f], buf)[f] for f in layout.SAFE_VALUES}
        assert values == layout.SAFE_VALUES
        for pid in pids:
            wait_for(lambda pid=pid: not alive(pid), f"child {pid} gone", deadline=30)
        wait_for(lambda: own_shm(segment) == set(), "every block of the launch removed")
        wait_for(lambda: listening(ports) == set(), "no port of the launch open")
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
        if pc1 is not None:
            pc1.close()
        for name in (segment, f"{segment}_pc1", f"{segment}_pc2"):
            blocks.unlink(name)
