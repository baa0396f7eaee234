"""The running-side corpus (tests/cases/running/, its README says what each file holds):
bad input to a running system is one clear line and an exit code, never a traceback, a
hang, a write to the block or anything left behind.

One miner runs in the background for the whole module (`python -m miner`, paced, both
processes); the console's cases attach to it, the launcher's are refused before anything
starts, the CLI's run in a scratch project, and the special cases (signals, failing hooks
under `up`, the monitor through textual's pilot) have a driver each below.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
import yaml
from click.testing import CliRunner
from conftest import read_whole, until, wait_for

from rcsgen.cli import main as rcsgen_main
from rcsgen.compiler.diagnostics import SpecError
from rcsgen.tools.harness import import_package
from rcsgen.tools.scenario import read_trace
from rcsgen.tools.traces import read as traces

REPO = Path(__file__).resolve().parent.parent
CASES = REPO / "tests" / "cases" / "running"
MINER_SPECS = REPO / "specs" / "miner"
HOOKED = REPO / "tests" / "cases" / "valid" / "hooked"
TICKER = REPO / "tests" / "fixtures" / "runtime" / "ticker"
PREFIX = f"rcsgen_ops_{os.getpid()}"
BOUND = 60  # seconds any one command may take before the case counts as a hang


def cases(name: str) -> list[Any]:
    found = yaml.safe_load((CASES / name).read_text(encoding="utf-8"))
    names = [c["name"] for c in found]
    assert len(names) == len(set(names)), f"{name}: two cases have one name"
    return [pytest.param(c, id=c["name"]) for c in found]


def test_the_corpus_has_at_least_80_cases() -> None:
    total = sum(len(cases(f)) for f in ("ctl.yaml", "launch.yaml", "cli.yaml", "special.yaml"))
    assert total >= 80, total


# ---------------------------------------------------------------- the background miner


@dataclass
class Miner:
    popen: subprocess.Popen[str]
    segment: str
    package: ModuleType
    layout: ModuleType
    env: dict[str, str]

    def ctl(self, *argv: str, shm: str | None = None) -> tuple[int, str, str]:
        """The package's console in this process: exit code, stdout, stderr."""
        ctl_main = importlib.import_module(f"{self.package.__name__}.rcs.operate.ctl").main
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = ctl_main(
                self.package.__name__, ["--shm", self.segment if shm is None else shm, *argv]
            )
        return code, out.getvalue(), err.getvalue()

    def ctl_process(self, *argv: str, shm: str | None = None) -> tuple[int, str, str]:
        """The console as its own OS process."""
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "miner",
                "ctl",
                "--shm",
                self.segment if shm is None else shm,
                *argv,
            ],
            env=self.env,
            capture_output=True,
            text=True,
            timeout=BOUND,
        )
        return done.returncode, done.stdout, done.stderr

    def json(self) -> dict[str, Any]:
        code, out, _ = self.ctl("status", "--format", "json")
        return json.loads(out) if code == 0 else {"processes": {}}

    def operator_bytes(self) -> bytes:
        """Every byte an operator's tool may write: the roots' command buffers, the modes,
        the pacing records, the override records and their flag, the answer records."""
        layout = self.layout
        buf = self.block_view()
        below = {s for subs in layout.SUBORDINATES.values() for s in subs}
        records = [
            r for m, r in layout.COMMAND_IN.items() if m in layout.MODULES and m not in below
        ]
        records += [*layout.MODE_IN.values(), *layout.PACING.values()]
        records += [
            *getattr(layout, "OVERRIDE", {}).values(),
            *getattr(layout, "ANSWERS", {}).values(),
        ]
        parts = [bytes(buf[r.offset : r.offset + r.struct.size]) for r in records]
        if hasattr(layout, "OVERRIDDEN_AT"):
            parts.append(bytes(buf[layout.OVERRIDDEN_AT : layout.OVERRIDDEN_AT + 1]))
        return b"".join(parts)

    def block_view(self) -> memoryview:
        if not hasattr(self, "_block"):
            block = importlib.import_module(f"{self.package.__name__}.rcs.block")
            self._block = block.Block(self.layout, self.segment, create=False)
        return self._block.buf  # type: ignore[no-any-return]

    def close(self) -> None:
        if hasattr(self, "_block"):
            self._block.close()


def miner_env() -> dict[str, str]:
    path = os.pathsep.join([str(REPO / "generated"), str(MINER_SPECS)])
    return {**os.environ, "PYTHONPATH": path}


@pytest.fixture(scope="module")
def miner() -> Iterator[Miner]:
    package = import_package((REPO / "generated" / "miner").resolve(), MINER_SPECS)
    layout = importlib.import_module(f"{package.__name__}.layout")
    segment = f"{PREFIX}_miner"
    env = miner_env()
    popen = subprocess.Popen(
        [sys.executable, "-m", "miner", "--shm", segment],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    system = Miner(popen, segment, package, layout, env)
    try:
        wait_for(
            lambda: (
                all(p.get("heartbeat", 0) > 2 for p in system.json()["processes"].values())
                and system.json()["processes"]
            ),
            "the background miner beating",
            BOUND,
        )
        # Its start-up over: INIT reached the roots and came back DONE.
        wait_for(
            lambda: (
                (
                    system.json()["modules"]["sec"].get("command"),
                    system.json()["modules"]["sec"].get("status"),
                )
                == ("INIT", "DONE")
            ),
            "the miner's INIT done",
            BOUND,
        )
        yield system
    finally:
        system.close()
        popen.send_signal(signal.SIGINT)
        out, err = popen.communicate(timeout=BOUND)
        assert "Traceback" not in out + err, err
        assert not Path(f"/dev/shm/{segment}").exists()


def ours() -> tuple[set[str], set[int]]:
    """Our segments in /dev/shm and our child processes (pids), to compare around a case."""
    segments = {p.name for p in Path("/dev/shm").glob(f"{PREFIX}*")}
    pids = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == os.getpid():
            pids.add(int(stat.parent.name))
    return segments, pids


def nothing_left(before: tuple[set[str], set[int]]) -> None:
    """No new segment and no new child process survived the case (waiting a moment for
    processes that are on their way out)."""
    wait_for(lambda: ours()[0] <= before[0] and ours()[1] <= before[1], "nothing left behind", 30)


def one_error_line(err: str, says: str, prefix: str = "") -> None:
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, f"not one line: {err!r}"
    assert lines[0].startswith(prefix), lines[0]
    assert says in lines[0], f"{says!r} not in {lines[0]!r}"


# ---------------------------------------------------------------- ctl.yaml


@pytest.mark.parametrize("case", cases("ctl.yaml"))
def test_ctl(miner: Miner, case: dict[str, Any]) -> None:
    before, written = ours(), miner.operator_bytes()
    run = miner.ctl_process if case.get("process") else miner.ctl
    code, out, err = run(*case["argv"], shm=case.get("shm"))
    assert code == case["exit"], (code, out, err)
    one_error_line(err, case["says"], "ctl: error: ")
    assert miner.operator_bytes() == written, "a refused request wrote to the block"
    nothing_left(before)


def test_what_the_console_takes_reaches_the_block(miner: Miner) -> None:
    """The other side of the contract: a valid send, force and unforce are written, shown
    and released (run after the refusals above, which need an idle machine)."""
    layout, buf = miner.layout, miner.block_view()
    code, out, err = miner.ctl("--role", "crew", "send", "sec", "BOX_CUT", "depth=1.5")
    assert (code, err) == (0, "") and out.startswith("sent sec.BOX_CUT depth=1.5 #"), out
    assert read_whole(layout.COMMAND_IN["sec"], buf)["arg_depth"] == 1.5
    code, out, err = miner.ctl("--role", "engineer", "force", "world.slip=0.25")
    assert (code, err) == (0, ""), err
    wait_for(lambda: miner.json()["world"]["slip"] == 0.25, "slip forced")
    snapshot = miner.json()
    assert snapshot["overrides"]["slip"] == {"state": "FORCED", "value": 0.25}
    text = miner.ctl("status", "--world", "slip,pose_x")[1].splitlines()
    assert any(line.split() == ["slip", "0.25", "FORCED"] for line in text), text
    assert miner.ctl("--role", "engineer", "unforce", "world.slip")[0] == 0
    assert "slip" not in miner.json()["overrides"]


# ---------------------------------------------------------------- launch.yaml


@pytest.fixture(scope="module")
def launcher_main() -> Callable[..., tuple[int, str, str]]:
    package = import_package((REPO / "generated" / "miner").resolve(), MINER_SPECS)
    main = importlib.import_module(f"{package.__name__}.rcs.operate.launcher").main

    def call(*argv: str) -> tuple[int, str, str]:
        out, err = io.StringIO(), io.StringIO()
        code = 0
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(package.__name__, list(argv))
            except SystemExit as done:
                code = int(done.code or 0)
        return code, out.getvalue(), err.getvalue()

    return call


@pytest.mark.parametrize("case", cases("launch.yaml"))
def test_launch(launcher_main: Callable[..., tuple[int, str, str]], case: dict[str, Any]) -> None:
    before = ours()
    # What a case adds comes last (argparse takes the last of an option): were a case not
    # refused, it would run no cycle and stop at once rather than run for ever.
    argv = ["--fast", "--cycles", "0", "--shm", f"{PREFIX}_launch", *case["argv"]]
    if case.get("process"):
        done = subprocess.run(
            [sys.executable, "-m", "miner", *argv],
            env=miner_env(),
            capture_output=True,
            text=True,
            timeout=BOUND,
        )
        code, err = done.returncode, done.stderr
    else:
        code, _, err = launcher_main(*argv)
    assert code == case["exit"], err
    one_error_line(err, case["says"], "python -m ")
    nothing_left(before)


# ---------------------------------------------------------------- cli.yaml


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch project: specs/miner and generated/miner, copied."""
    root = tmp_path_factory.mktemp("project")
    shutil.copytree(
        MINER_SPECS, root / "specs" / "miner", ignore=shutil.ignore_patterns("__pycache__")
    )
    shutil.copytree(REPO / "generated" / "miner", root / "generated" / "miner")
    return root


@pytest.mark.parametrize("case", cases("cli.yaml"))
def test_cli(project: Path, case: dict[str, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    before = ours()
    restore = None
    if "edit" in case:
        path, old, new = case["edit"]
        restore = (project / path, (project / path).read_text())
        assert old in restore[1]
        (project / path).write_text(restore[1].replace(old, new, 1))
    try:
        if case["argv"][0] == "up":  # it replaces its process: never in this one
            done = subprocess.run(
                [sys.executable, "-m", "rcsgen", *case["argv"]],
                cwd=project,
                capture_output=True,
                text=True,
                timeout=BOUND,
            )
            code, err = done.returncode, done.stderr
        else:
            monkeypatch.chdir(project)
            result = CliRunner().invoke(rcsgen_main, case["argv"])
            code, err = result.exit_code, result.stderr
            assert result.exception is None or isinstance(result.exception, SystemExit), (
                result.exception
            )
    finally:
        if restore is not None:
            restore[0].write_text(restore[1])
    assert code == case["exit"], err
    assert "Traceback" not in err and case["says"] in err, err
    assert not (project / "miner").exists()  # nothing written into the working directory
    nothing_left(before)


# ---------------------------------------------------------------- special.yaml


SPECIAL = cases("special.yaml")


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "interrupt"])
def test_interrupted_run_keeps_its_trace(case: dict[str, Any], tmp_path: Path) -> None:
    """`rcsgen run` stopped by a signal once its trace has grown: exit 128 + the signal, the
    trace so far in valid JSON Lines ending with a line that says so, where it stopped on
    stderr, no segment and no process left."""
    before = ours()
    trace = tmp_path / "forever.jsonl"
    argv = [sys.executable, "-m", "rcsgen", "run", str(TICKER / "scenarios" / "forever.yaml")]
    argv += ["--trace", str(trace), *(["--processes"] if case.get("processes") else [])]
    seen: list[str] = []
    with subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as run:
        assert run.stderr is not None and run.stdout is not None
        errors, output = run.stderr, run.stdout
        reader = threading.Thread(target=lambda: seen.extend(iter(errors.readline, "")))
        reader.start()
        try:
            # The run is going once its progress line shows (after 2 s of cycles, on stderr).
            wait_for(lambda: any(line.startswith("  cycle ") for line in seen), "the run", BOUND)
            run.send_signal(getattr(signal, case["signal"]))
            out = output.read()
            run.wait(timeout=BOUND)
        finally:
            if run.poll() is None:
                run.kill()
                run.wait()
            reader.join(timeout=BOUND)
    err = "".join(line for line in seen if not line.startswith("  cycle "))
    assert run.returncode == case["exit"], err
    assert "Traceback" not in out + err
    lines = read_trace(trace)
    last = json.loads(lines[-1])
    assert last == {"cycle": len(lines), "interrupted": case["signal"]}, last
    assert f"interrupted by {case['signal']} in cycle {len(lines)} of forever" in err, err
    loaded = traces.load(trace)  # the trace tools read it: every cycle, and the interruption
    assert loaded.interrupted == case["signal"] and loaded.cycles == list(range(1, len(lines)))
    assert len(lines) > 1, "no cycle ran before the signal"
    nothing_left(before)


@pytest.mark.parametrize("name", ["forever.jsonl", "forever.jsonl.gz"])
def test_a_killed_run_keeps_a_readable_trace_up_to_its_last_cycle(
    tmp_path: Path, name: str
) -> None:
    """`rcsgen run` killed outright (SIGKILL: nothing of it runs after) once its trace file
    has grown: the file, written as the run goes, reads as the cycles that finished (every
    line whole, cycle 1 on, no gap; the trace tools and the golden reader agree), with no
    line saying it was interrupted (no one was left to write it). A `.gz` trace too: a
    gzip stream flushed at each cycle and never ended, which the trace tools read (the
    golden reader refuses it: a golden must be whole)."""
    before = ours()
    trace = tmp_path / name
    argv = [sys.executable, "-m", "rcsgen", "run", str(TICKER / "scenarios" / "forever.yaml")]
    argv += ["--trace", str(trace)]

    def cycles() -> int:
        if not trace.is_file():
            return 0
        data = trace.read_bytes()
        if name.endswith(".gz"):
            data = zlib.decompressobj(wbits=31).decompress(data)
        return data.count(b"\n")

    with subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) as run:
        try:
            # (a busy host may take a while to start it: a generous bound, then kill at once)
            wait_for(lambda: cycles() >= 3, "3 cycles", BOUND)
            run.kill()
            run.wait(timeout=BOUND)
        finally:
            if run.poll() is None:
                run.kill()
                run.wait()
    assert run.returncode == -signal.SIGKILL
    data = trace.read_bytes()
    if name.endswith(".gz"):
        inflate = zlib.decompressobj(wbits=31)
        data = inflate.decompress(data)
        assert not inflate.eof, "the stream was ended: nobody was left to end it"
    text = data.decode("utf-8")
    assert text.endswith("\n"), text[-200:]  # (flushed a whole line at a time)
    loaded = traces.load(trace)
    assert loaded.interrupted is None and len(loaded) >= 3
    assert loaded.cycles == list(range(1, len(loaded) + 1))
    full = [json.loads(line) for line in traces.full_lines(trace)]
    assert [line["cycle"] for line in full] == loaded.cycles
    assert all("modules" in line for line in full)  # each line expands to its whole cycle
    if name.endswith(".gz"):
        with pytest.raises(SpecError, match="ends before its data does"):
            read_trace(trace)
    else:
        assert read_trace(trace) == traces.full_lines(trace)
    nothing_left(before)


@pytest.fixture
def hooked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(HOOKED, tmp_path / "sys", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "sys" / "scenarios").mkdir()
    (tmp_path / "sys" / "scenarios" / "go.yaml").write_text(
        "scenario: go\ntitle: GO once\nmax_cycles: 20\nstop_when_done: top\nevents:\n"
        "  - cycle: 2\n    command: top.GO\n"
    )
    monkeypatch.chdir(tmp_path)
    return tmp_path / "sys"


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "hook_run"])
def test_a_hook_that_lies_or_hangs_fails_the_run(
    hooked: Path, case: dict[str, Any], capfd: pytest.CaptureFixture[str]
) -> None:
    hooks = hooked / "tiny_hooks" / "top.py"
    text = hooks.read_text()
    anchor = "    whole = int(level)\n"
    hooks.write_text(text.replace(anchor, case["body"] + anchor))
    if "deadline" in case:
        top = hooked / "top.yaml"
        top.write_text(
            top.read_text().replace(
                "    returns: [n, world.level]\n",
                f"    returns: [n, world.level]\n    deadline: {case['deadline']}\n",
            )
        )
    if case.get("process"):  # its own OS process: the exit code the shell and CI see
        done = subprocess.run(
            [sys.executable, "-m", "rcsgen", "run", "sys/scenarios/go.yaml"],
            capture_output=True,
            text=True,
            timeout=BOUND,
        )
        code, out, err = done.returncode, done.stdout, done.stderr
    else:
        extra = ["--processes"] if case.get("processes") else []
        result = CliRunner().invoke(rcsgen_main, ["run", "sys/scenarios/go.yaml", *extra])
        assert result.exception is None or isinstance(result.exception, SystemExit)
        code, out, err = result.exit_code, result.stdout, result.stderr
    assert code == case["exit"], err
    errors = [line for line in err.splitlines() if "error[" in line]
    assert len(errors) == 1 and case["says"] in errors[0], err
    assert "Traceback" not in out + err
    if "child" in case:  # in lockstep the process that ran the hook says it (its stderr)
        assert case["child"] in capfd.readouterr().err, err


@pytest.fixture(scope="module")
def failing_miner(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A scratch copy of the miner whose `slip` hook has a 200 ms deadline, built once; the
    cases edit its hooks (restored after each)."""
    root = tmp_path_factory.mktemp("failing")
    shutil.copytree(
        MINER_SPECS, root / "specs" / "miner", ignore=shutil.ignore_patterns("__pycache__")
    )
    mine = root / "specs" / "miner" / "mine.yaml"
    old = "    returns: [world.slip]\n"
    assert old in mine.read_text()
    mine.write_text(mine.read_text().replace(old, old + "    deadline: 200 ms\n"))
    done = subprocess.run(
        [sys.executable, "-m", "rcsgen", "build", "specs", "-o", "generated", "-q"],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=BOUND * 2,
    )
    assert done.returncode == 0, done.stderr
    return root


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "up_failure"])
def test_a_failing_hook_under_up_is_one_line_and_a_failed_launch(
    failing_miner: Path, case: dict[str, Any]
) -> None:
    before = ours()
    hooks_file = failing_miner / "specs" / "miner" / "miner_hooks" / "mine.py"
    original = hooks_file.read_text()
    if "hooks" in case:
        _, old, new = case["hooks"]
        assert old in original
        hooks_file.write_text(original.replace(old, new, 1))
    else:  # from the 5th call of `slip` (cycle 5) on
        head = (
            "def slip(mine: Mine, x: float, boom_angle: float, jack_down: bool, cut: float)"
            " -> float:\n"
        )
        assert head in original
        body = "".join("    " + line + "\n" for line in case["hook_at_cycle"].splitlines())
        guard = (
            '    calls = globals().setdefault("CALLS", [0])\n'
            "    calls[0] += 1\n"
            "    if calls[0] >= 5:\n"
        )
        hooks_file.write_text(original.replace(head, head + guard + body, 1))
    segment = f"{PREFIX}_up"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(
            [str(failing_miner / "generated"), str(failing_miner / "specs" / "miner")]
        ),
    }
    try:
        done = subprocess.run(
            [sys.executable, "-m", "miner", "--shm", segment, "--fast", "--cycles", "200"],
            env=env,
            capture_output=True,
            text=True,
            timeout=BOUND,
        )
    finally:
        hooks_file.write_text(original)
    assert done.returncode != 0, done.stderr
    assert "Traceback" not in done.stdout + done.stderr
    said = [line for line in done.stderr.splitlines() if line.startswith("pc1: ")]
    assert len(said) == 1 and case["says"] in said[0], done.stderr
    assert case["summary"] in done.stdout + done.stderr, done.stdout + done.stderr
    assert not Path(f"/dev/shm/{segment}").exists()
    nothing_left(before)


# ---------------------------------------------------------------- the monitor


def screen(app: Any) -> str:
    from test_monitor import screen_text

    return str(screen_text(app))


def drive_monitor(miner: Miner, case: dict[str, Any]) -> None:
    pytest.importorskip("textual")
    from rcsgen.tools.monitor import Monitor

    layout, buf = miner.layout, miner.block_view()
    drive = case["drive"]

    def cell(app: Any, table: str, row: str, column: str) -> str:
        return str(app.query_one(table).get_cell(row, column))

    def drawn(app: Any) -> bool:
        """The monitor has drawn its first screen: its table has rows."""
        return bool(app.query_one("#modules").row_count)

    async def hammer() -> None:
        """Torn reads while the pilot runs, from another thread, on two records no module
        is writing now (cd's status, idle since INIT; the world's operator_delay): for a
        second their sequence words flip odd and even faster than the screen refreshes
        (torn reads, retried); then they stay odd, as a writer that died mid-write leaves
        them (shown stale); then they are whole again (shown again). No crash throughout."""
        targets = [layout.STATUS_OUT["cd"].offset, layout.WORLD["operator_delay"].offset]
        stop = threading.Event()

        def flip() -> None:
            while not stop.is_set():
                for at in targets:
                    buf[at] |= 1
                time.sleep(0.0003)
                for at in targets:
                    buf[at] &= ~1
                time.sleep(0.0003)

        app = Monitor(layout, miner.segment, interval=0.05, role="engineer")
        async with app.run_test(size=(170, 60)) as pilot:
            await until(pilot, lambda: drawn(app), "the first screen drawn")
            thread = threading.Thread(target=flip)
            thread.start()
            try:
                await pilot.pause(1.0)  # twenty refreshes over torn records
            finally:
                stop.set()
                thread.join()
            assert app.is_running
            for at in targets:
                buf[at] |= 1  # held odd: its writer died mid-write
            try:
                await until(
                    pilot, lambda: cell(app, "#modules", "cd", "status") == "stale", "cd stale"
                )
                await until(
                    pilot,
                    lambda: cell(app, "#world", "operator_delay", "value") == "stale",
                    "stale",
                )
                seen = screen(app)
                assert "stale" in seen and "Traceback" not in seen
            finally:
                for at in targets:
                    buf[at] &= ~1
            await until(pilot, lambda: cell(app, "#modules", "cd", "status") == "DONE", "cd again")
            await until(
                pilot, lambda: cell(app, "#world", "operator_delay", "value") == "3", "again"
            )
            assert app.is_running

    async def whole_values() -> None:
        """Values longer than the first draw's (the command, EXECUTING, #11) shown whole."""
        if read_whole(layout.STATUS_OUT["sec"], buf)["status"] != 1:  # not EXECUTING: give it work
            assert miner.ctl("--role", "crew", "send", "sec", "BOX_CUT", "depth=1.5")[0] == 0
        app = Monitor(layout, miner.segment, interval=0.05, role="engineer")
        async with app.run_test(size=(200, 60)) as pilot:
            await until(pilot, lambda: drawn(app), "the first screen drawn")
            for _ in range(10):  # wm's numbers climb past 9 (its module keeps NEW_CUT short)
                assert miner.ctl("--role", "engineer", "send", "wm", "INIT", "--override")[0] == 0
            assert miner.ctl("--role", "engineer", "run", "sb")[0] == 0
            number = int(read_whole(layout.COMMAND_IN["wm"], buf)["command_num"])
            assert number >= 11
            await until(pilot, lambda: cell(app, "#modules", "wm", "cnum") == str(number), "#")
            await until(
                pilot, lambda: cell(app, "#modules", "sec", "status") == "EXECUTING", "EXECUTING"
            )
            shown = screen(app)  # as a person sees it: every value whole, none cut to a width
            wm = next(line for line in shown.splitlines() if " wm " in f" {line} ")
            assert f" {number} " in f" {wm} ", shown
            sec = next(line for line in shown.splitlines() if line.split()[:1] == ["sec"])
            assert sec.split()[1:4] == [
                "BOX_CUT",
                str(read_whole(layout.COMMAND_IN["sec"], buf)["command_num"]),
                "EXECUTING",
            ], sec

    async def send_form() -> None:
        """The send form refuses what the contract refuses, and writes nothing."""
        app = Monitor(layout, miner.segment, interval=0.1, role="engineer")
        async with app.run_test(size=(170, 40)) as pilot:
            await until(pilot, lambda: drawn(app), "the first screen drawn")
            assert app.selected() == "sec"
            written = miner.operator_bytes()
            await pilot.press("c")
            form = app.query_one("#send")
            await until(pilot, lambda: "BOX_CUT" in str(form.placeholder), "the form for sec")
            assert "BOX_CUT depth=" in str(form.placeholder)
            form.value = case["form"]  # typed (keys: test_monitor.py)
            await pilot.press("enter")
            await until(pilot, lambda: str(app.query_one("#message").render()), "the form said")
            said = str(app.query_one("#message").render())
            assert case["says"] in said, said
            assert miner.operator_bytes() == written
            assert app.is_running

    async def world() -> None:
        """The world table: every field's value, and FORCED beside a forced one."""
        assert miner.ctl("--role", "engineer", "force", "world.tread_stalled=true")[0] == 0
        try:
            app = Monitor(layout, miner.segment, interval=0.05, world=("tread_stalled", "pose_x"))
            async with app.run_test(size=(170, 40)) as pilot:
                await until(pilot, lambda: "FORCED" in screen(app), "the forced field drawn")
                shown = screen(app)
                row = next(line for line in shown.splitlines() if "tread_stalled" in line)
                assert row.split()[:3] == ["tread_stalled", "true", "FORCED"], row
                assert any(line.split()[:1] == ["pose_x"] for line in shown.splitlines())
        finally:
            assert miner.ctl("--role", "engineer", "unforce", "world.tread_stalled")[0] == 0

    asyncio.run(
        {"hammer": hammer, "whole_values": whole_values, "send_form": send_form, "world": world}[
            drive
        ]()
    )


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "monitor"])
def test_monitor(miner: Miner, case: dict[str, Any]) -> None:
    before = ours()
    drive_monitor(miner, case)
    nothing_left(before)


# ---------------------------------------------------------------- the world, forced


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "force_truth"])
def test_ground_truth_is_forced_only_in_simulation(miner: Miner, case: dict[str, Any]) -> None:
    """true_x is the simulated world (tas writes it, simulated): forced and released; with
    tas's simulate flag off, as a real machine's would be, the force is refused."""
    layout, buf = miner.layout, miner.block_view()
    assert miner.ctl("--role", "engineer", "force", "world.true_x=1.0")[0] == 0
    assert miner.ctl("--role", "engineer", "unforce", "world.true_x")[0] == 0
    assert layout.WORLD_WRITERS["true_x"] == ("tas",)
    mode = layout.MODE_IN["tas"]
    mode.write(buf, simulate=False)  # the loop reads this flag only for stand-ins: tas runs on
    try:
        written = miner.operator_bytes()
        code, _, err = miner.ctl("--role", "engineer", "force", "world.true_x=1.0")
        assert code == 1
        one_error_line(err, case["says"], "ctl: error: ")
        assert miner.operator_bytes() == written
    finally:
        mode.write(buf, simulate=True)


def test_a_stand_ins_truth_is_forced_while_its_controller_runs_real(miner: Miner) -> None:
    """loose_coal_true is written by mine and gas (simulators) and by cr_sim, cr's stand-in,
    which runs only while cr is simulated: with cr real, its running writers all simulate,
    so the force is allowed, as `scenario check` allows it (ctl once took cr's REAL flag for
    cr_sim's and refused: "cr writing it run real")."""
    layout, buf = miner.layout, miner.block_view()
    assert layout.WORLD_WRITERS["loose_coal_true"] == ("mine", "gas", "cr_sim")
    assert layout.MODE_IN["cr"].read(buf)["simulate"] is False
    code, out, err = miner.ctl("--role", "engineer", "force", "world.loose_coal_true=0.5")
    assert (code, err) == (0, ""), err
    assert out.startswith("world.loose_coal_true FORCED at 0.5")
    assert miner.ctl("--role", "engineer", "unforce", "world.loose_coal_true")[0] == 0


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "force_cycle"])
def test_force_shows_everywhere_and_unforce_releases(miner: Miner, case: dict[str, Any]) -> None:
    code, out, err = miner.ctl_process("--role", "engineer", "force", "world.path_ok=false")
    assert (code, err) == (0, ""), err
    assert out == "world.path_ok FORCED at false; `ctl unforce world.path_ok` releases it\n"
    text = miner.ctl_process("status")[1]
    assert "world.path_ok FORCED at false" in text.splitlines()
    assert miner.ctl_process("--role", "engineer", "unforce", "world.path_ok")[0] == 0
    assert "path_ok" not in miner.ctl_process("status")[1]


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "scenario_force"])
def test_a_scenario_forces_a_field_and_its_trace_shows_it(
    case: dict[str, Any], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The `force:` and `unforce:` events, run as OS processes in lockstep: the trace shows
    the forced value and FORCED while it lasts, the simulator's own value after."""
    shutil.copytree(HOOKED, tmp_path / "sys", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "sys" / "scenarios").mkdir()
    (tmp_path / "sys" / "scenarios" / "forced.yaml").write_text(
        "scenario: forced\ntitle: level forced\nmax_cycles: 12\ntrace: {world: [level]}\n"
        "events:\n  - cycle: 2\n    command: top.GO\n"
        "  - cycle: 4\n    force: {level: 7.5}\n  - cycle: 8\n    unforce: [level]\n"
    )
    monkeypatch.chdir(tmp_path)
    trace = tmp_path / "forced.jsonl"
    for processes in ([], ["--processes"]):
        result = CliRunner().invoke(
            rcsgen_main, ["run", "sys/scenarios/forced.yaml", "--trace", str(trace), *processes]
        )
        assert result.exit_code == 0, result.output
        lines = [json.loads(line) for line in read_trace(trace)]
        assert [line.get("overrides") for line in lines[3:7]] == [{"level": "FORCED"}] * 4
        assert all(line["world"]["level"] == 7.5 for line in lines[3:7])
        assert all("overrides" not in line for line in lines[7:])


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "golden_match"])
def test_a_golden_match_is_said(case: dict[str, Any], hooked: Path, tmp_path: Path) -> None:
    golden = tmp_path / "go.jsonl"
    (hooked / "scenarios" / "done.yaml").write_text(
        "scenario: done\ntitle: GO, twenty cycles\nmax_cycles: 20\n"
        "events:\n  - cycle: 1\n    set: {flag: true}\n  - cycle: 2\n    command: top.GO\n"
    )
    recorded = CliRunner().invoke(
        rcsgen_main, ["run", "sys/scenarios/done.yaml", "--record", str(golden)]
    )
    assert recorded.exit_code == 0, recorded.output
    compared = CliRunner().invoke(
        rcsgen_main, ["run", "sys/scenarios/done.yaml", "--golden", str(golden)]
    )
    assert compared.exit_code == 0, compared.output
    lines = len(golden.read_text().splitlines())
    assert f"golden    {golden}: identical, cycle for cycle ({lines} lines)" in compared.output


@pytest.mark.parametrize("case", [c for c in SPECIAL if c.values[0]["kind"] == "help"])
def test_help_after_the_system_is_the_packages(case: dict[str, Any]) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "rcsgen", *case["argv"]],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=BOUND,
    )
    assert done.returncode == 0, done.stderr
    for text in case["shows"]:
        assert text in done.stdout, done.stdout


def test_every_special_case_has_a_driver() -> None:
    kinds = {
        "interrupt",
        "hook_run",
        "up_failure",
        "monitor",
        "force_truth",
        "force_cycle",
        "scenario_force",
        "golden_match",
        "help",
    }
    assert {c.values[0]["kind"] for c in SPECIAL} <= kinds


# ---------------------------------------------------------------- small items


def test_status_columns_fit_their_widest_value() -> None:
    """`ctl status` text: a long command, status or number widens its column; the cells
    after it stay in line, and nothing is cut."""
    from rcsgen.runtime.operate.ctl import render

    row = {
        "command": "INIT",
        "command_num": 1,
        "status": "DONE",
        "status_num": 1,
        "state": "NOP",
        "run": "RUN",
        "step": "AUTO",
        "sim": "REAL",
        "alive": True,
        "heartbeat_age_s": 0.01,
    }
    long = {
        **row,
        "command": "INITIAL_APPROACH_FACE_AND_THEN_SOME",
        "command_num": 123456789,
        "status": "ERROR",
        "reason": "MACHINE_FAULT_OF_A_LONG_NAME",
    }
    snapshot = {
        "system": "s",
        "segment": "seg",
        "modules": {"a": row, "b": long, "c": row},
        "processes": {},
    }
    lines = render(snapshot)
    header, a, b, c = lines[1:5]
    assert "INITIAL_APPROACH_FACE_AND_THEN_SOME" in b and "123456789" in b
    assert "ERROR(MACHINE_FAULT_OF_A_LONG_NAME)" in b
    for title in ("status", "state", "mode", "beat"):  # every column starts where its title does
        at = header.index(title)
        for line in (a, b, c):
            assert line[at - 1] == " " and line[at] != " ", (title, line)


def test_docs_say_a_scenario_runs_every_process_by_default() -> None:
    """It runs all of them (process by process, as --processes runs them as OS processes);
    docs/spec.md and the scenario schema once said the first."""
    schema = json.loads((REPO / "rcsgen/compiler/schemas/scenario.schema.json").read_text())
    said = schema["properties"]["process"]["description"]
    assert "every process" in said and "the first" not in said
    spec = (REPO / "docs" / "spec.md").read_text()
    row = next(line for line in spec.splitlines() if line.startswith("| `process` |"))
    assert "every process" in row and "the first" not in row


def test_a_process_started_alone_imports_its_own_modules_only() -> None:
    """Issue 24 (a process's start): `python -m miner pc2` imports pc2's plan and its one
    controller, not pc1's plan or controllers, the operator console or multiprocessing (the
    segment is mapped directly); the run is whole (one cycle) and leaves no segment."""
    segment = f"{PREFIX}_alone"
    code = (
        "import sys\n"
        "from miner.rcs.operate.launcher import main\n"
        f"code = main('miner', ['pc2', '--cycles', '1', '--fast', '--shm', {segment!r}])\n"
        "print(' '.join(sorted(sys.modules)))\n"
        "sys.exit(code)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env=miner_env(),
        capture_output=True,
        text=True,
        timeout=BOUND,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0] == "pc2: 1 cycles"
    modules = set(lines[-1].split())
    assert {"miner.main_pc2", "miner.pp", "miner.layout"} <= modules
    pc1_only = {"miner.main_pc1", "miner.co", "miner.sec", "miner.mine", "miner.cr_sim"}
    assert not modules & pc1_only, "another process's plan or controllers were imported"
    assert "miner.rcs.operate.ctl" not in modules
    assert not {m for m in modules if m == "multiprocessing" or m.startswith("multiprocessing.")}
    assert not os.path.exists(f"/dev/shm/{segment}")
