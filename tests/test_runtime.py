"""The multi-process runtime: consistent reads, liveness, faults, the launcher (docs/semantics.md).

Most tests run `tests/fixtures/runtime/duo`: a supervisor `top` in process p1 commanding an
`arm` in process p2, as real OS processes over a shared segment, and inject the faults the
runtime must contain: a writer killed mid-write, a process killed, a cycle that overruns, a
second launch, a segment of another layout. Waiting for a paced system to react is bounded
by generous deadlines; nothing here asserts how fast anything is (`make bench` measures).
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType

import pytest
from conftest import read_whole, wait_for
from support.running import console_status, segment_names

from rcsgen.tools.harness import Harness, generate, import_package
from rcsgen.tools.scenario import read_trace

DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"


segment_name = segment_names("rt")


@pytest.fixture(scope="module")
def duo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The duo system generated into a scratch directory: the package's directory."""
    scratch, name = generate(DUO)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def package(duo: Path) -> ModuleType:
    return import_package(duo, DUO)


def runtime(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


@pytest.fixture
def launched(duo: Path, package: ModuleType) -> Iterator[Callable[..., object]]:
    """Start the duo system paced, as two OS processes; stopped at the end of the test."""
    launcher_module = runtime(package, "rcs.operate.launcher")
    made = []

    def launch(**options: object) -> object:
        system = launcher_module.System(
            duo.name,
            runtime(package, "layout"),
            {p: runtime(package, f"main_{p}").PLAN for p in ("p1", "p2")},
            (str(duo.parent), str(DUO)),
        )
        launcher = launcher_module.Launcher(system, segment_name(), **options)
        made.append(launcher)
        launcher.start()
        layout = system.layout
        wait_for(
            lambda: all(
                layout.PROCESSES[p].read(launcher.block.buf)["heartbeat"] > 2 for p in ("p1", "p2")
            ),
            "both processes running",
        )
        return launcher

    yield launch
    for launcher in made:
        launcher.stop()


def status(layout: ModuleType, buf: memoryview, module: str) -> dict[str, object]:
    return read_whole(layout.STATUS_OUT[module], buf)


def command_to(layout: ModuleType, buf: memoryview, module: str, command: str) -> None:
    """Write a command to a root, as an operator does."""
    record = layout.COMMAND_IN[module]
    number = read_whole(record, buf)["command_num"] + 1
    record.write(buf, command_num=number, command=layout.COMMAND_NAMES[module].index(command))


# ---------------------------------------------------------------- consistent reads


WRITER = """
import importlib, sys, time
sys.path[:0] = [sys.argv[1], sys.argv[2]]
layout = importlib.import_module(sys.argv[3] + ".layout")
block = importlib.import_module(sys.argv[3] + ".rcs.block").Block(layout, sys.argv[4], create=False)
record = layout.COMMAND_IN["arm"]
end = time.monotonic() + float(sys.argv[5])
k = 0
while time.monotonic() < end:
    k += 1
    # every field of one write tells the same number
    record.write(block.buf, command_num=k, command=k % 1000, arg_level=float(k))
block.close()
print(k)
"""


def test_a_reader_never_accepts_a_torn_record(duo: Path, package: ModuleType) -> None:
    """Stress, two processes: a writer rewrites a record as fast as it can; every read the
    reader accepts is whole (its fields tell the same number), and the reader did retry."""
    layout, contract = runtime(package, "layout"), runtime(package, "rcs.contract")
    block = runtime(package, "rcs.block").Block(layout, segment_name(), create=True)
    try:
        writer = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(duo.parent), str(DUO), duo.name, block.name, "1.5"],
            stdout=subprocess.PIPE,
            text=True,
        )
        record = layout.COMMAND_IN["arm"]
        accepted = stale = torn = last = 0
        while writer.poll() is None:
            try:
                values = record.read(block.buf)
            except contract.StaleRead:
                stale += 1
                continue
            number = values["command_num"]
            accepted += 1
            # whole: every field tells the same write, and no older one than a write read
            # before (pack_into zeroes a buffer before it fills it: the zeros are no write)
            if values["command"] != number % 1000 or values["arg_level"] != float(number):
                torn += 1
            elif number < last:
                torn += 1
            last = max(last, number)
        writes = int(writer.communicate(timeout=30)[0])
    finally:
        block.close()
    assert writer.returncode == 0
    assert writes > 100 and accepted > 100, (writes, accepted)
    assert torn == 0, f"{torn} torn records accepted of {accepted}"


def test_a_writer_killed_mid_write_leaves_its_readers_stale_not_torn(package: ModuleType) -> None:
    """A buffer left odd (its writer died mid-write) is never read: the reader keeps its last
    whole inputs and counts a stale read each cycle; a new write makes it readable again."""
    layout, contract = runtime(package, "layout"), runtime(package, "rcs.contract")
    h = Harness(package, "p1")  # top alone: arm's status comes from another process
    h.command("top", "MOVE")
    h.cycle()
    h.reply("arm", "DONE", 1)  # arm echoes, whole
    h.cycle()
    assert h.status("top").status == "DONE"
    buf, at = h.buf, layout.STATUS_OUT["arm"].offset
    h.command("top", "MOVE")
    h.cycle()  # top sends POWER #2 and waits
    seq = contract.SEQ.unpack_from(buf, at)[0]
    contract.SEQ.pack_into(buf, at, seq + 1)  # the writer marks the buffer odd ...
    contract.STATUS.pack_into(buf, at, seq + 1, 2, 2, 0, 0, 0)  # ... writes, and dies
    with pytest.raises(contract.StaleRead):
        layout.STATUS_OUT["arm"].read(buf)
    before = h.performance("top")["stale_reads"]
    h.cycle(3)
    top = h.controller("top")
    assert h.performance("top")["stale_reads"] == before + 3
    assert (top.arm_status_num, h.status("top").status) == (1, "EXECUTING"), "not the torn DONE"
    h.reply("arm", "DONE", 2)  # a restarted writer writes it whole
    h.cycle()
    assert h.status("top").status == "DONE"
    assert h.performance("top")["stale_reads"] == before + 3


# ---------------------------------------------------------------- timeouts and liveness


def test_a_subordinate_that_does_not_echo_in_time_is_an_error(package: ModuleType) -> None:
    """echo_timeouts: arm may take 5 cycles to echo; it never runs here, so top's table sees
    arm.status == ERROR after them and reports ERROR (not before)."""
    h = Harness(package, "p1")
    h.command("top", "MOVE")
    h.cycle(5)
    assert h.status("top").status == "EXECUTING"
    h.cycle(2)
    assert h.status("top").status == "ERROR"


def test_a_killed_process_puts_the_supervisors_of_its_modules_in_their_safe_state(
    launched: Callable[..., object], package: ModuleType
) -> None:
    """Kill p2 (the arm) mid-command: p1 stops hearing its heartbeat, and top, arm's
    supervisor, sends arm HALT and reports ERROR (reason 1: subordinate lost)."""
    launcher = launched()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    command_to(layout, buf, "top", "RUN")
    wait_for(lambda: status(layout, buf, "arm")["state"] == 2, "arm holding (RUN S1)")
    launcher.children["p2"].popen.send_signal(signal.SIGKILL)
    wait_for(lambda: status(layout, buf, "top")["status"] == 3, "top reports ERROR")
    assert status(layout, buf, "top")["error_num"] == 1
    sent = read_whole(layout.COMMAND_IN["arm"], buf)
    assert layout.COMMAND_NAMES["arm"][sent["command"]] == "HALT"
    record = read_whole(layout.PROCESSES["p1"], buf)
    assert record["lost"] == 0b10, "p1 reports p2 (index 1) lost"
    launcher.poll()
    assert any(e.startswith("p2 died") for e in launcher.events)
    assert read_whole(layout.PROCESSES["p2"], buf)["state"] == 4  # DEAD


def test_a_restarted_process_resumes_without_sending_init_again(
    launched: Callable[..., object], package: ModuleType
) -> None:
    """With --restart, a killed process is started again: it attaches, and the root that
    is in the middle of a command keeps it (no INIT re-sent); a restarted subordinate
    resumes its state from the block."""
    launcher = launched(restart=True)
    layout, buf = runtime(package, "layout"), launcher.block.buf
    command_to(layout, buf, "top", "RUN")
    wait_for(lambda: status(layout, buf, "arm")["state"] == 2, "arm holding (RUN S1)")
    sent_before = read_whole(layout.COMMAND_IN["top"], buf)
    first = launcher.children["p1"].popen.pid
    launcher.children["p1"].popen.send_signal(signal.SIGKILL)
    wait_for(  # once p2 has seen p1 dead (Launcher._restart_when_seen)
        lambda: launcher.poll() is not None and launcher.children["p1"].restarts, "p1 restarted"
    )
    assert launcher.children["p1"].popen.pid != first
    wait_for(lambda: layout.PROCESSES["p1"].read(buf)["state"] == 2, "the restarted p1 running")
    beat = read_whole(layout.PROCESSES["p1"], buf)["heartbeat"]
    wait_for(
        lambda: layout.PROCESSES["p1"].read(buf)["heartbeat"] >= beat + 10,
        "ten cycles of the restarted p1",
    )
    assert read_whole(layout.COMMAND_IN["top"], buf) == sent_before, "no INIT re-sent to top"
    top = status(layout, buf, "top")
    assert (top["status"], layout.STATE_NAMES["top"][top["state"]]) == (1, "S1"), top
    assert status(layout, buf, "arm")["state"] == 2, "the arm still holds"


def test_a_process_whose_module_keeps_hook_state_is_not_restarted(
    launched: Callable[..., object], package: ModuleType
) -> None:
    """arm keeps hook state outside the block (hooks_state_on_restart: refuse, the
    default): a restart of p2 would lose it, so p2 refuses, and the launcher gives up on it
    rather than restarting it again and again; its supervisor goes to its safe state."""
    launcher = launched(restart=True)
    layout, buf = runtime(package, "layout"), launcher.block.buf
    command_to(layout, buf, "top", "RUN")
    wait_for(lambda: status(layout, buf, "arm")["state"] == 2, "arm holding")
    launcher.children["p2"].popen.send_signal(signal.SIGKILL)
    wait_for(
        lambda: launcher.poll() is not None and "p2" not in launcher.children,
        "p2 refusing to restart",
    )
    # (under load the launcher may also see a process silent for a moment: not asked here)
    assert [e for e in launcher.events if e.startswith("p2") and "beat" not in e] == [
        "p2 died (exit -9)",
        "p2 restarted",
        "p2 refused to restart: see its error above",
    ]
    assert "p2" not in launcher.children
    wait_for(lambda: status(layout, buf, "top")["status"] == 3, "top reports ERROR")


def test_the_watchdog_halts_the_roots_after_a_cycle_far_too_long(
    launched: Callable[..., object], package: ModuleType
) -> None:
    """A cycle longer than three periods trips p1's watchdog: HALT goes to its root."""
    launcher = launched()
    layout, buf = runtime(package, "layout"), launcher.block.buf
    command_to(layout, buf, "top", "RUN")
    wait_for(lambda: status(layout, buf, "arm")["state"] == 2, "arm holding")
    layout.WORLD["slow"].write(buf, slow=True)  # top's hook now naps 0.15 s (7.5 periods)
    wait_for(lambda: layout.PROCESSES["p1"].read(buf)["watchdog_trips"] > 0, "the watchdog trips")
    layout.WORLD["slow"].write(buf, slow=False)
    sent = read_whole(layout.COMMAND_IN["top"], buf)
    assert layout.COMMAND_NAMES["top"][sent["command"]] == "HALT"
    wait_for(lambda: layout.WORLD["arm_power"].read(buf)["arm_power"] == 0.0, "arm halted")
    assert read_whole(layout.PROCESSES["p1"], buf)["load_warnings"] > 0


# ---------------------------------------------------------------- the simulation switch


def test_setting_simulate_switches_a_controller_to_its_stand_in_and_back(
    package: ModuleType,
) -> None:
    """The simulate flag, set while running, replaces arm by arm_sim from the next cycle
    (its commands reach the stand-in); cleared, arm runs again and resumes from the block."""
    h = Harness(package, send_init=True)
    h.cycle(3)
    h.set_mode("arm", simulate=True)
    h.command("top", "MOVE")
    h.cycle(4)
    assert h.status("top").status == "DONE"
    assert (h.world["sim_power"], h.world["arm_power"]) == (1.0, 0.0)
    h.set_mode("arm", simulate=False)
    h.command("top", "MOVE")
    h.cycle(4)
    assert h.status("top").status == "DONE"
    assert h.world["arm_power"] == 1.0


def test_a_module_leaving_for_its_stand_in_publishes_its_figures_and_the_stand_in_goes_on(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """arm's figures, kept in arm and published only every PERF_INTERVAL (here never after
    the first beat; no cycle is the longest yet), are published as arm leaves for
    arm_sim, which takes up the performance record they share from the block: its count
    goes on from arm's last cycle, not from an older published one."""
    monkeypatch.setattr(runtime(package, "rcs.loop"), "PERF_INTERVAL_NS", 10**18)
    h = Harness(package, send_init=True)
    h.cycle(2)
    arm = h.controller("arm")
    arm.max_cycle_ns, arm.min_cycle_ns = 10**15, 1  # no cycle publishes at once from here
    published = h.layout.PERFORMANCE["arm"].read(h.buf)["cycles"]
    h.cycle(3)
    assert (arm.cycles, h.layout.PERFORMANCE["arm"].read(h.buf)["cycles"]) == (5, published)
    h.set_mode("arm", simulate=True)
    h.cycle(1)
    stand_in = h.controller("arm")
    assert stand_in is not arm
    assert stand_in.cycles == 6
    assert stand_in.max_cycle_ns == 10**15


def test_a_harness_shows_a_module_s_figures_as_of_its_last_cycle(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A harness's `performance` (what a scenario's report reads) publishes the module's
    figures first: its count and last cycle as the module has them, though its process
    has not published them yet."""
    monkeypatch.setattr(runtime(package, "rcs.loop"), "PERF_INTERVAL_NS", 10**18)
    h = Harness(package, send_init=True)
    h.cycle(1)
    arm = h.controller("arm")
    arm.max_cycle_ns, arm.min_cycle_ns = 10**15, 1  # no cycle publishes at once from here
    h.cycle(3)
    assert h.layout.PERFORMANCE["arm"].read(h.buf)["cycles"] == 1
    shown = h.performance("arm")
    assert (shown["cycles"], shown["last_cycle_ns"]) == (4, arm.last_cycle_ns)


# ---------------------------------------------------------------- identity and lifecycle


def test_a_second_launch_on_the_same_segment_refuses(
    launched: Callable[..., object], package: ModuleType
) -> None:
    launcher = launched()
    block = runtime(package, "rcs.block")
    with pytest.raises(block.BlockError, match="already exists: another run of duo"):
        block.Block(runtime(package, "layout"), launcher.segment, create=True)


def test_attaching_with_another_layout_refuses_naming_both(
    tmp_path: Path, package: ModuleType
) -> None:
    """Two world fields swapped: the same size, another layout. Attaching refuses, naming
    both hashes."""
    spec = tmp_path / "duo"
    shutil.copytree(DUO, spec)
    text = (spec / "system.yaml").read_text(encoding="utf-8")
    first, second = text.index("  arm_power:"), text.index("  sim_power:")
    third = text.index("  slow:")
    swapped = text[:first] + text[second:third] + text[first:second] + text[third:]
    (spec / "system.yaml").write_text(swapped, encoding="utf-8")
    scratch, name = generate(spec)
    try:
        other = import_package(scratch / name, spec)
        ours, theirs = runtime(package, "layout"), runtime(other, "layout")
        assert ours.SIZE == theirs.SIZE and ours.LAYOUT_HASH != theirs.LAYOUT_HASH
        block = runtime(package, "rcs.block")
        created = block.Block(ours, segment_name(), create=True)
        try:
            with pytest.raises(runtime(other, "rcs.block").BlockError) as error:
                runtime(other, "rcs.block").Block(theirs, created.name, create=False)
        finally:
            created.close()
        message = str(error.value)
        assert ours.LAYOUT_HASH in message and theirs.LAYOUT_HASH in message
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def cycled(package_dir: Path, env: dict[str, str], segment: str, cycles: int) -> bool:
    """Whether every process of the system on `segment` has run `cycles` cycles (its
    heartbeat, as the console reads it)."""
    found = console_status(package_dir, env, segment).get("processes", {}).values()
    return bool(found) and all(p["heartbeat"] >= cycles for p in found)


def test_ctrl_c_stops_every_process_prints_a_summary_and_removes_the_segment(
    duo: Path,
) -> None:
    """`python -m duo`: both processes run paced; SIGINT ends the run without a traceback,
    with a summary per process, no process left and nothing left in /dev/shm."""
    segment = segment_name()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(duo.parent), str(DUO)])}
    run = subprocess.Popen(
        [sys.executable, "-m", duo.name, "--shm", segment],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    shm = Path("/dev/shm") / segment
    wait_for(shm.exists, "the segment")
    wait_for(lambda: cycled(duo, env, segment, 5), "five cycles of each process")
    run.send_signal(signal.SIGINT)
    out, err = run.communicate(timeout=30)
    assert run.returncode == 0, err
    assert "Traceback" not in out + err
    lines = out.splitlines()
    assert lines[0].startswith("p1: stopped, ") and "cycles" in lines[0], out
    assert any(line.startswith("p2: stopped, ") for line in lines), out
    assert not shm.exists()


def test_lockstep_from_the_command_line_runs_every_process_to_the_end(duo: Path) -> None:
    """`python -m duo --lockstep --cycles 10` runs both processes in lockstep to the end."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(duo.parent), str(DUO)])}
    done = subprocess.run(
        [sys.executable, "-m", duo.name, "--lockstep", "--cycles", "10", "--shm", segment_name()],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert "p1: stopped, 10 cycles" in done.stdout and "p2: stopped, 10 cycles" in done.stdout


# ---------------------------------------------------------------- the miner as processes

REPO = Path(__file__).resolve().parent.parent


def python_m_miner(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(REPO / "generated"), str(REPO / "specs" / "miner")]),
    }
    return subprocess.run(
        [sys.executable, "-m", "miner", "--shm", segment_name(), *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def test_the_miner_as_two_free_running_processes_completes_the_box_cut() -> None:
    """`python -m miner`: pc1 and pc2 (the path planner) as two OS processes, not in
    lockstep and not paced (each as fast as it can); the operator's BOX_CUT is sent once
    the section (sec) has finished INIT, and the box cut ends DONE at the depth of the
    one-process run."""
    done = python_m_miner(
        "--fast",
        "--set", "map=maps/box_cut.map",
        "--set", "seed=7",
        "--send", "sec.BOX_CUT:depth=1.5",
        "--until-done",
        "--report", "depth_cut,coal_mined",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "sec DONE #2", done.stdout
    assert lines[1] == "depth_cut = 1.5"
    golden = read_trace(REPO / "tests" / "golden" / "box_cut.jsonl")[-1]
    one_process = json.loads(golden)["world"]["coal_mined"]
    assert float(lines[2].split(" = ")[1]) == pytest.approx(one_process)
    assert any(line.startswith("pc2: stopped, ") for line in lines)


@pytest.mark.parametrize(
    ("send", "message"),
    [
        ("xx.BOX_CUT", "no module 'xx'"),
        ("sb.BOX_CUTT", "sb has no command 'BOX_CUTT'"),
        ("sb.BOX_CUT:deep=1", "sb.BOX_CUT has no parameter 'deep'"),
        ("sb.BOX_CUT:depth=deep", "parameter depth is 'deep', not a finite number"),
    ],
)
def test_a_bad_send_is_one_line_and_exit_2(send: str, message: str) -> None:
    done = python_m_miner("--send", send, timeout=60)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr
