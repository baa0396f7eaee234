"""The operator's console, `python -m <system> ctl` (rcsgen/runtime/operate/ctl.py), against running
systems: the duo fixture (a supervisor `top` in process p1 commanding an `arm` in p2) and the
miner, each launched paced as real OS processes; every verb is run as a command line, and
bad input must be one line on stderr with exit 2 (usage) or 1, never a traceback.
"""

from __future__ import annotations

import atexit
import functools
import importlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest
from conftest import rcsgen, wait_for
from support.running import at_ease, children, console_status, segment_names

from rcsgen.tools.harness import generate, import_package

DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"
REPO = Path(__file__).resolve().parent.parent


segment_name = segment_names("ctl")


@pytest.fixture(scope="module")
def duo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The duo at ease (support.running.at_ease): these tests check what the console says
    and does, and on a busy host the duo's own watchdog and 0.3 s heartbeat timeout would
    halt its root under them."""
    scratch, name = generate(at_ease(DUO, tmp_path_factory.mktemp("duo")))
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def timed_duo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The duo with its declared heartbeat timeout (0.3 s), for the test of that bound; its
    watchdog at ease, as it is not what that test checks."""
    spec = at_ease(DUO, tmp_path_factory.mktemp("timed_duo"), heartbeat_timeout=None)
    scratch, name = generate(spec)
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def package(duo: Path) -> ModuleType:
    return import_package(duo, DUO)


class Running:
    """A system launched as `python -m <system> --shm SEGMENT`, and its console."""

    def __init__(self, package_dir: Path, hooks: Path, layout: ModuleType, *options: str) -> None:
        self.name, self.layout = package_dir.name, layout
        self.segment = segment_name()
        self.env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(package_dir.parent), str(hooks)]),
        }
        self.popen = subprocess.Popen(
            [sys.executable, "-m", self.name, "--shm", self.segment, *options],
            env=self.env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            wait_for(lambda: self.json()["processes"], "the system running", 60)
            wait_for(
                lambda: all(p.get("heartbeat", 0) > 2 for p in self.json()["processes"].values()),
                "every process beating",
            )
        except BaseException:
            self.stop()
            raise

    def ctl(self, *args: str, shm: str | None = None) -> subprocess.CompletedProcess[str]:
        done = subprocess.run(
            [sys.executable, "-m", self.name, "ctl", "--shm", shm or self.segment, *args],
            env=self.env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert "Traceback" not in done.stdout + done.stderr, done.stderr
        return done

    def json(self) -> dict[str, object]:
        done = self.ctl("status", "--format", "json")
        return json.loads(done.stdout) if done.returncode == 0 else {"processes": {}}

    def module(self, name: str) -> dict[str, object]:
        return self.json()["modules"][name]  # type: ignore[index, no-any-return]

    def stop(self) -> str:
        self.popen.terminate()
        out, err = self.popen.communicate(timeout=30)
        assert "Traceback" not in out + err, err
        return out


@pytest.fixture
def running(duo: Path, package: ModuleType) -> Iterator[Running]:
    system = Running(duo, DUO, importlib.import_module(f"{package.__name__}.layout"))
    yield system
    system.stop()


@pytest.fixture(scope="module")
def refusing(duo: Path, package: ModuleType) -> Iterator[Running]:
    """One running system for the bad-input cases: each is refused before it touches the
    block, so they need no system of their own (a launch each cost a second or more)."""
    system = Running(duo, DUO, importlib.import_module(f"{package.__name__}.layout"))
    yield system
    system.stop()


def test_status_shows_every_module_and_process_as_text_and_json(running: Running) -> None:
    text = running.ctl("status")
    assert text.returncode == 0, text.stderr
    lines = text.stdout.splitlines()
    assert lines[0] == f"duo on {running.segment}"
    assert lines[1].split()[:4] == ["module", "command", "#", "status"]
    top = next(line for line in lines if line.startswith("top "))
    assert top.split()[1:5] == ["INIT", "1", "DONE", "1"], top
    assert "RUN AUTO REAL" in top
    assert any(line.startswith("process p2: running") for line in lines)
    snapshot = running.json()
    assert set(snapshot["modules"]) == {"top", "arm"}  # type: ignore[arg-type]
    arm = snapshot["modules"]["arm"]  # type: ignore[index]
    assert arm["process"] == "p2" and arm["supervisor"] == "top" and arm["alive"]
    assert 0 < arm["min_cycle_us"] <= arm["max_cycle_us"]
    assert snapshot["processes"]["p1"]["heartbeat_age_s"] < 5  # type: ignore[index]


def test_status_shows_how_well_each_process_holds_its_period(running: Running) -> None:
    """Each paced process's control record carries its periodicity (issue 24 item 4): the
    text status has a line per process, the JSON the figures, consistent with each other
    and with the duo's 20 ms period."""
    wait_for(
        lambda: all(
            (p.get("periodicity") or {}).get("wakeups", 0) >= 20
            for p in running.json()["processes"].values()  # type: ignore[attr-defined]
        ),
        "20 paced wake-ups measured in each process",
    )
    for name, proc in running.json()["processes"].items():  # type: ignore[attr-defined]
        figures = proc["periodicity"]
        assert figures["period_ms"] == 20.0, name
        assert 0 <= figures["period_error_mean_us"] <= figures["period_error_max_us"], figures
        assert 0 <= figures["lateness_p99_us"] <= figures["lateness_max_us"], figures
        assert 0 < proc["last_cycle_us"] <= proc["max_cycle_us"], proc
    lines = running.ctl("status").stdout.splitlines()
    for name, module in (("p1", "top"), ("p2", "arm")):
        line = next(x for x in lines if x.startswith(f"periodicity {name}: "))
        assert "period error mean" in line and "wake-up lateness p99" in line, line
        assert "(period 20 ms)" in line and f"slowest module {module} (max" in line, line


def test_a_reader_that_goes_away_ends_status_watch_quietly(running: Running) -> None:
    """`ctl status --watch | head`: when the reader closes the pipe, ctl ends with 0 and
    no BrokenPipeError traceback."""
    watch = subprocess.Popen(
        [sys.executable, "-m", running.name, "ctl", "--shm", running.segment]
        + ["status", "--watch", "--interval", "0.05"],
        env=running.env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert watch.stdout is not None and watch.stderr is not None
    assert "duo on " in watch.stdout.readline()
    watch.stdout.close()
    assert watch.wait(timeout=30) == 0
    with watch.stderr:
        assert watch.stderr.read() == ""


def test_send_to_a_root_then_wait_for_done(running: Running) -> None:
    sent = running.ctl("send", "top", "MOVE", "--seen")
    assert sent.returncode == 0, sent.stderr
    assert sent.stdout.splitlines()[0] == "sent top.MOVE #2"
    assert "top saw #2 after" in sent.stdout
    done = running.ctl("wait", "top", "DONE", "--timeout", "20")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "top DONE MOVE #2"
    assert running.ctl("wait", "top", "ERROR", "--timeout", "5").returncode == 1
    # by number: #2 is done; #3 is not given yet; once #3 is, #2 is no longer known
    assert running.ctl("wait", "top", "DONE", "--number", "2").returncode == 0
    early = running.ctl("wait", "top", "DONE", "--number", "3", "--timeout", "0.3")
    assert early.returncode == 1 and "did not finish within 0.3 s" in early.stderr
    assert running.ctl("send", "top", "MOVE", "--seen").returncode == 0
    assert running.ctl("wait", "top", "DONE", "--number", "3", "--timeout", "20").returncode == 0
    gone = running.ctl("wait", "top", "DONE", "--number", "2")
    assert (gone.returncode, gone.stderr) == (
        1,
        "ctl: error: top's command #2 was replaced by #3: its outcome is no longer in the "
        "status buffer\n",
    )


def test_a_command_to_a_module_with_a_supervisor_needs_override(running: Running) -> None:
    refused = running.ctl("send", "arm", "POWER", "level=0.5")
    assert refused.returncode == 1
    assert "arm is commanded by top" in refused.stderr and "--override" in refused.stderr
    assert len(refused.stderr.splitlines()) == 1
    given = running.ctl("send", "arm", "POWER", "level=0.5", "--override")
    assert given.returncode == 0, given.stderr
    assert "top is in manual override (STOP)" in given.stdout
    assert running.module("top")["run"] == "STOP"
    wait_for(
        lambda: (m := running.module("arm"))["command"] == "POWER" and m["status"] == "DONE",
        "arm DONE with the operator's POWER",
    )
    assert running.module("arm")["args"] == {"level": 0.5}
    assert running.ctl("run", "top").stdout.strip() == "top: RUN AUTO"
    # the supervisor's next command is numbered after the operator's: the arm sees it
    assert running.ctl("send", "top", "MOVE").returncode == 0
    assert running.ctl("wait", "top", "DONE", "--timeout", "20").returncode == 0
    assert running.module("arm")["args"] == {"level": 1.0}


def test_stop_step_and_run_a_module(running: Running) -> None:
    assert running.ctl("stop", "arm").returncode == 0
    assert running.module("arm")["run"] == "STOP"
    stepped = running.ctl("step", "arm", "3")
    assert stepped.returncode == 0, stepped.stderr
    assert stepped.stdout.startswith("arm: stepped 3 cycles, SINGLE")
    arm = running.module("arm")
    assert (arm["run"], arm["step"]) == ("RUN", "SINGLE")
    cycles = arm["cycles"]
    held = wait_for(  # the arm's table is held, its cycles still counted
        lambda: (arm := running.module("arm"))["cycles"] > cycles + 5 and arm,
        "the held arm's cycles counted",
    )
    assert (held["run"], held["step"]) == ("RUN", "SINGLE")  # type: ignore[index]
    assert running.ctl("run", "arm").returncode == 0
    arm = running.module("arm")
    assert (arm["run"], arm["step"]) == ("RUN", "AUTO") and arm["cycles"] > cycles


def test_simulate_switches_to_the_stand_in_and_back(running: Running) -> None:
    assert running.ctl("simulate", "arm", "on").stdout.strip() == "arm: SIMU"
    wait_for(lambda: running.module("arm")["runs"] == "arm_sim", "the stand-in running")
    assert running.module("arm")["sim"] == "SIMU"
    assert running.ctl("simulate", "arm", "off").returncode == 0
    assert running.module("arm")["runs"] == "arm"
    refused = running.ctl("simulate", "top", "on")
    assert refused.returncode == 2 and "top has no stand-in; these do: arm" in refused.stderr


def beats(running: Running, process: str, at_least: int) -> int:
    """The process's heartbeat (its cycles) once it is at least `at_least`, else 0."""
    beat = int(running.json()["processes"].get(process, {}).get("heartbeat", 0))  # type: ignore[attr-defined]
    return beat if beat >= at_least else 0


def test_slow_stretches_the_period_of_every_process(running: Running) -> None:
    assert running.ctl("slow", "5").stdout.strip() == "slow x5: p1, p2"
    assert running.json()["processes"]["p1"]["slow"] == 5.0  # type: ignore[index]
    beat = running.json()["processes"]["p1"]["heartbeat"]  # type: ignore[index]
    wait_for(lambda: beats(running, "p1", beat + 2), "the slowed period begun")
    start = time.monotonic()  # before the beat is read: cycle `first + 1` starts after it
    first = beats(running, "p1", 0)
    wait_for(lambda: beats(running, "p1", first + 10), "ten slowed cycles", deadline=30)
    # The pacer keeps a grid of boundaries a period apart and never catches up in a burst,
    # so ten cycles at the slowed 0.1 s (5 x 0.02 s) start at least 0.8 s after `start`
    # however loaded the host is; at full speed they would take 0.2 s.
    assert time.monotonic() - start >= 0.6
    assert running.ctl("slow", "1", "--process", "p1").stdout.strip() == "slow x1: p1"


@pytest.fixture
def timed(timed_duo: Path) -> Iterator[Running]:
    """A running duo with its declared heartbeat timeout."""
    package = import_package(timed_duo, DUO)
    system = Running(timed_duo, DUO, importlib.import_module(f"{package.__name__}.layout"))
    yield system
    system.stop()


def test_a_slowed_process_is_not_taken_for_lost(timed: Running) -> None:
    """Slowed 30 times, a duo cycle (0.6 s) outlasts the heartbeat timeout (0.3 s): the
    timeout stretches with the slow-down, so top keeps holding the arm instead of going to
    its safe state, and the console still shows both processes alive."""
    running = timed
    assert running.ctl("send", "top", "RUN", "--seen").returncode == 0
    wait_for(lambda: running.module("arm")["status"] == "EXECUTING", "the arm held")
    assert running.ctl("slow", "30").returncode == 0
    beat = running.json()["processes"]["p1"]["heartbeat"]  # type: ignore[index]
    # more than three slowed cycles (0.6 s each, twice the heartbeat timeout) of p1
    wait_for(lambda: beats(running, "p1", beat + 4), "four slowed cycles of p1", deadline=30)
    snapshot = running.json()
    top = snapshot["modules"]["top"]  # type: ignore[index]
    assert (top["status"], top["error_num"]) == ("EXECUTING", 0), top
    assert all(p["alive"] for p in snapshot["processes"].values()), snapshot["processes"]  # type: ignore[attr-defined]
    assert running.ctl("slow", "1").returncode == 0


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (["send", "tap", "MOVE"], 2, "no module 'tap' (did you mean 'top'?); modules: top, arm"),
        (["send", "top", "MOV"], 2, "top has no command 'MOV' (did you mean 'MOVE'?)"),
        (["send", "arm", "POWER", "levl=1"], 2, "arm.POWER has no parameter 'levl' (did you mean"),
        (["send", "arm", "POWER", "level=high"], 2, "parameter level is 'high', not a finite"),
        (["send", "arm", "POWER", "level"], 2, "arm.POWER: 'level' is not NAME=VALUE"),
        (["stop", "nobody"], 2, "no module 'nobody'"),
        (["step", "arm", "0"], 2, "'0' is not a whole number at least 1 and at most 1000000"),
        (["slow", "0.5"], 2, "'0.5' is not a number at least 1 and at most 1000"),
        (["slow", "2", "--process", "p3"], 2, "no process 'p3'"),
        (["frobnicate"], 2, "invalid choice: 'frobnicate'"),
        (["wait", "top", "DONE", "--timeout", "0.2"], 1, "top did not finish within 0.2 s"),
    ],
)
def test_bad_input_is_one_line_and_exit_2_or_1(
    refusing: Running, args: list[str], code: int, message: str
) -> None:
    if args[0] == "wait":  # a command that never ends: top holds the arm
        refusing.ctl("send", "top", "RUN")
    done = refusing.ctl(*args)
    assert done.returncode == code, done.stderr
    assert message in done.stderr
    assert len(done.stderr.splitlines()) == 1 and done.stderr.startswith("ctl: error: ")


def test_no_such_segment_is_one_line_and_exit_1(duo: Path) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(duo.parent), str(DUO)])}
    done = subprocess.run(
        [sys.executable, "-m", duo.name, "ctl", "--shm", segment_name(), "status"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1
    assert done.stderr.startswith("ctl: error: no shared-memory segment")
    assert len(done.stderr.splitlines()) == 1


def test_a_segment_of_another_layout_is_refused(duo: Path, package: ModuleType) -> None:
    """The miner's console pointed at the duo's segment refuses, naming both layouts."""
    block = importlib.import_module(f"{package.__name__}.rcs.block")
    layout = importlib.import_module(f"{package.__name__}.layout")
    theirs = block.Block(layout, segment_name(), create=True)
    try:
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join([str(REPO / "generated"), str(REPO / "specs" / "miner")]),
        }
        done = subprocess.run(
            [sys.executable, "-m", "miner", "ctl", "--shm", theirs.name, "status"],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        theirs.close()
    assert done.returncode == 1
    assert "holds layout" in done.stderr and "system 'duo'" in done.stderr
    assert len(done.stderr.splitlines()) == 1


def test_a_block_of_another_layout_version_is_refused_naming_both(
    duo: Path, package: ModuleType
) -> None:
    """A segment left by a runtime of another layout version (RCSBLK01: the control record
    without the periodicity figures) is refused with one line naming both versions."""
    block = importlib.import_module(f"{package.__name__}.rcs.block")
    layout = importlib.import_module(f"{package.__name__}.layout")
    theirs = block.Block(layout, segment_name(), create=True)
    try:
        theirs.buf[:8] = b"RCSBLK01"
        with pytest.raises(block.BlockError) as refused:
            block.Block(layout, theirs.name, create=False)
    finally:
        theirs.close()
    assert "layout version 01 (this package's runtime has 02)" in str(refused.value)


def test_rcsgen_ctl_runs_the_console_of_a_built_system(
    running: Running, duo: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`rcsgen ctl SYSTEM_DIR ...` execs `python -m <system> ctl ...` (like `rcsgen up`)."""
    calls: list[list[str]] = []

    def execve(path: str, argv: list[str], env: dict[str, str]) -> None:
        calls.append(argv)
        raise SystemExit(0)

    monkeypatch.setattr(os, "execve", execve)
    result = rcsgen("ctl", DUO, "--generated", duo.parent, "--shm", running.segment, "status")
    assert result.exit_code == 0, result.output
    assert calls[0][1:] == ["-m", "duo", "ctl", "--shm", running.segment, "status"]


# ---------------------------------------------------------------- the miner


def miner_layout() -> ModuleType:
    miner = REPO / "generated" / "miner"
    return importlib.import_module(
        f"{import_package(miner, REPO / 'specs' / 'miner').__name__}.layout"
    )


@functools.cache
def miner_at_ease() -> tuple[Path, ModuleType]:
    """specs/miner generated at ease (support.running.at_ease), once for the test run: the
    package's directory and its layout. These tests check the console and the roles, and
    at load 15-29 the miner's own watchdog halted sec under them (`sec HALT #3 ERROR`)."""
    into = Path(tempfile.mkdtemp(prefix="rcsgen-ctl-miner-"))
    atexit.register(shutil.rmtree, into, ignore_errors=True)
    scratch, name = generate(at_ease(REPO / "specs" / "miner", into))
    atexit.register(shutil.rmtree, scratch, ignore_errors=True)
    package = import_package(scratch / name, REPO / "specs" / "miner")
    return scratch / name, importlib.import_module(f"{package.__name__}.layout")


def running_miner(*options: str) -> Running:
    """The miner launched paced (at ease), with the operator at the console (the scripted
    operator never answers the conveyor-tail request)."""
    miner, layout = miner_at_ease()
    return Running(
        miner, REPO / "specs" / "miner", layout, "--world", "operator_delay=-1", *options
    )


def test_the_miner_walk_through_from_the_readme() -> None:
    """Start the miner with the operator at the console (`--world operator_delay=-1`), send
    sec BOX_CUT depth=1.5 as the crew (the section, the top; the shift boss below it is the
    engineer's to override), answer the conveyor-tail request as the crew, single-step co
    five cycles, switch cr to simulation and back as the engineer, stop it: every step a
    command line, in the README's order, the system paced, each role refused what it may not
    do. (Stepping and simulating before the tail request, as this test once did, let a
    loaded machine reach the sump while cr was simulated: its stand-in never asks for the
    tail, and the real cr then waited for ever for coal that nothing hauls away.)"""
    system = running_miner()
    try:
        refused = system.ctl("send", "sec", "BOX_CUT", "depth=1.5")  # no role: monitor only
        assert refused.returncode == 1 and refused.stdout == ""
        assert refused.stderr.splitlines() == [
            "ctl: error: refused: commanding sec needs command on sec; no --role was given, so "
            "this console only monitors (roles that may: crew, engineer)"
        ]
        under = system.ctl("--role", "crew", "send", "sb", "BOX_CUT", "depth=1.5")
        assert under.returncode == 1 and under.stdout == "", under.stdout
        assert under.stderr.startswith("ctl: error: sb is commanded by sec: "), under.stderr
        sent = system.ctl("--role", "crew", "send", "sec", "BOX_CUT", "depth=1.5", "--seen")
        assert sent.returncode == 0, sent.stderr
        assert sent.stdout.startswith("sent sec.BOX_CUT depth=1.5 #2")
        # ct asks for the conveyor tail (at the first sump: seconds, a minute and more at
        # load 18, where each paced cycle starts late); nobody but the console answers it
        try:
            wait_for(lambda: system.json().get("requests"), "the tail request", 180)
        except AssertionError as error:  # say what the system did instead (a trip? a halt?)
            raise AssertionError(f"{error}\n{system.ctl('status').stdout}") from None
        listed = system.ctl("requests")
        assert listed.stdout.splitlines() == [
            "tail from ct: Put the conveyor tail over the haulage, then answer."
        ]
        assert "request tail from ct:" in system.ctl("status").stdout
        assert system.module("ct")["status"] == "EXECUTING"
        refused = system.ctl("answer", "tail")
        assert refused.returncode == 1 and "answering tail needs respond on ct" in refused.stderr
        answered = system.ctl("answer", "tail", "--role", "crew")
        assert answered.returncode == 0, answered.stderr
        assert answered.stdout.startswith("answered tail: sent oi.TAIL_IN_POSITION #")
        wait_for(lambda: system.module("ct")["status"] == "DONE", "ct done")
        assert system.ctl("requests").stdout == "no requests\n"
        again = system.ctl("answer", "tail", "--role", "crew")
        assert again.returncode == 1 and "ct is not asking for tail now" in again.stderr
        wait_for(lambda: system.module("co")["status"] == "EXECUTING", "co working")
        refused = system.ctl("step", "co", "5", "--role", "crew")
        assert refused.returncode == 1
        assert "refused: stepping co needs override on co; role crew may only monitor co" in (
            refused.stderr
        )
        assert system.module("co")["step"] == "AUTO"  # nothing was written
        stepped = system.ctl("step", "co", "5", "--role", "engineer")
        assert stepped.returncode == 0, stepped.stderr
        assert system.module("co")["step"] == "SINGLE"
        assert system.ctl("run", "co", "--role", "engineer").returncode == 0
        assert system.ctl("simulate", "cr", "on", "--role", "engineer").returncode == 0
        wait_for(lambda: system.module("cr")["runs"] == "cr_sim", "cr's stand-in")
        skipped = {n: r.get("skipped_by") for n, r in system.json()["modules"].items()}
        assert [n for n, by in skipped.items() if by] == ["gh", "cv", "ct"]
        assert set(skipped.values()) == {None, "cr"}
        gh = next(line for line in system.ctl("status").stdout.splitlines() if line[:3] == "gh ")
        assert "skipped: cr SIMU" in gh
        assert system.ctl("simulate", "cr", "off", "--role", "engineer").returncode == 0
        wait_for(lambda: system.module("cr")["runs"] == "cr", "cr again")
        assert not system.module("gh").get("skipped_by")
        assert system.module("sec")["command"] == system.module("sb")["command"] == "BOX_CUT"
    finally:
        out = system.stop()
    assert "pc1: stopped" in out and "pc2: stopped" in out
    # the launcher's summary: each paced process's periodicity, from its control record
    for name in ("pc1", "pc2"):
        line = next(x for x in out.splitlines() if x.startswith(f"  {name}: period error mean"))
        assert "wake-up lateness p99" in line and "(period 100 ms)" in line, line


def test_the_access_matrix_and_a_bad_role() -> None:
    """`ctl roles` prints the matrix from the layout alone; an unknown role, or a role given
    to a system that declares none, is a usage error (exit 2, one line)."""
    layout = miner_layout()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO / "generated")])}

    def ctl(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "miner", "ctl", *args],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )

    matrix = ctl("roles").stdout.splitlines()
    assert matrix[0].split() == ["module", "crew", "engineer"]
    rows = {line.split()[0]: line.split()[1:] for line in matrix[1:]}
    assert rows["sec"] == ["command", "override"] and rows["sb"] == ["monitor", "override"]
    assert rows["ct"] == ["respond", "override"]
    assert rows["co"] == ["monitor", "override"] and len(rows) == len(layout.MODULES)
    bad = ctl("--role", "enginer", "status")
    assert (bad.returncode, bad.stderr) == (
        2,
        "ctl: error: no role 'enginer' (did you mean 'engineer'?); roles: crew, engineer\n",
    )
    bad = ctl("answer", "tial")  # checked against the layout before attaching
    assert bad.returncode == 2 and "did you mean 'tail'" in bad.stderr


def test_a_role_for_a_system_without_roles_is_refused(running: Running) -> None:
    done = running.ctl("--role", "crew", "status")
    assert (done.returncode, done.stderr) == (
        2,
        "ctl: error: duo declares no operator roles; leave out --role\n",
    )
    assert "every operator may do everything" in running.ctl("roles").stdout


def test_world_start_values_are_checked() -> None:
    """`python -m miner --world FIELD=VALUE`: the field and its type checked, one line."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO / "generated")])}
    done = subprocess.run(
        [sys.executable, "-m", "miner", "--cycles", "1"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )  # the hooks are not on the path: said in one line, no traceback
    assert (done.returncode, done.stderr) == (
        1,
        "miner: cannot import module 'miner_hooks'; put the directory that holds the system's "
        "hook modules (the spec directory) on PYTHONPATH\n",
    )
    env["PYTHONPATH"] += os.pathsep + str(REPO / "specs" / "miner")
    for value, message in (
        ("operator_dealy=-1", "no world field 'operator_dealy' (did you mean 'operator_delay'?)"),
        ("operator_delay=soon", "operator_delay is 'soon', not a whole number (64-bit)"),
        ("operator_delay", "'operator_delay' is not FIELD=VALUE"),
    ):
        done = subprocess.run(
            [sys.executable, "-m", "miner", "--world", value, "--cycles", "0", "--fast"],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert "Traceback" not in done.stderr


# ---------------------------------------------------------------- a clean stop


def test_sigterm_stops_rcsgen_run_with_a_summary_and_no_segment_left() -> None:
    """`rcsgen run --processes` on SIGTERM (as on Ctrl-C): no traceback, the processes'
    summary, exit 143 (128 + SIGTERM), and the segment it made removed."""
    run = subprocess.Popen(
        [sys.executable, "-m", "rcsgen", "run", "specs/miner/scenarios/late_tail.yaml"]
        + ["--processes", "--trace", os.devnull],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    shm = Path("/dev/shm")
    segments = wait_for(lambda: list(shm.glob(f"rcsgen_run_{run.pid}_*")), "the run's segment")
    wait_for(lambda: children(run.pid), "the run's processes started")
    run.terminate()
    out, err = run.communicate(timeout=60)
    if run.returncode == 0:  # it finished first: nothing to interrupt
        pytest.skip("the scenario ended before the signal")
    assert run.returncode == 143, err
    assert "Traceback" not in out + err
    if "while starting" not in err:  # the signal came once the run had begun
        assert "interrupted by SIGTERM in cycle" in err
        assert any(line.startswith("pc1: stopped, ") for line in out.splitlines()), out
    assert not any(path.exists() for path in segments)  # type: ignore[attr-defined]


def processes_running(package_dir: Path, env: dict[str, str], segment: str) -> bool:
    """Whether every process of the system on `segment` says RUNNING in its control record."""
    found = console_status(package_dir, env, segment).get("processes", {}).values()
    return bool(found) and all(p["state"] == "RUNNING" for p in found)


def test_a_killed_lockstep_launcher_leaves_no_segment(duo: Path) -> None:
    """The launcher of a lockstep run killed outright: its processes see their pipe close,
    and the last one out removes the segment."""
    segment = segment_name()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(duo.parent), str(DUO)])}
    run = subprocess.Popen(
        [sys.executable, "-m", duo.name, "--lockstep", "--shm", segment],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    shm = Path("/dev/shm") / segment
    wait_for(shm.exists, "the segment")
    wait_for(lambda: processes_running(duo, env, segment), "p1 and p2 attached and running")
    run.kill()
    run.wait(timeout=30)
    wait_for(lambda: not shm.exists(), "the segment removed by the last process out")
