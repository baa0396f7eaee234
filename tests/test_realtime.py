"""Opt-in real-time settings per process (system.yaml `processes.P.realtime`,
rcsgen/runtime/realtime.py): the schema's located errors, the generated plan, and a real
process refusing what the OS does not allow with one clear line, then running without it
or (`required`) not starting; and the periodicity line a process run by hand ends with."""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.runtime import realtime
from rcsgen.tools.harness import generate

FLEET = Path(__file__).resolve().parent / "fixtures" / "runtime" / "fleet"


def fleet_with(tmp_path: Path, settings: str) -> Path:
    spec = tmp_path / "fleet"
    shutil.copytree(FLEET, spec)
    system = spec / "system.yaml"
    text = system.read_text()
    old = "  pl:\n    modules: [lead]\n"
    assert old in text
    system.write_text(text.replace(old, old + "    realtime: " + settings + "\n", 1))
    return spec


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ("{fifo_priority: 0}", "fifo_priority"),
        ("{gc: off}", "`off` is not a valid value: expected `freeze` or `disable`"),
        ("{cpus: []}", "cpus"),
        ("{nice: 3}", "nice"),
    ],
)
def test_a_bad_realtime_setting_is_a_located_error(
    tmp_path: Path, settings: str, message: str
) -> None:
    spec = fleet_with(tmp_path, settings)
    errors = compile_paths([spec]).diagnostics.errors
    assert errors, "accepted"
    # the line of `realtime:` (46 in the copied fixture), not the file
    assert any(message in d.message and "system.yaml:46:" in str(d.span) for d in errors), [
        (d.code, d.message, str(d.span)) for d in errors
    ]


@pytest.fixture
def segment() -> Iterator[str]:
    name = f"rcsgen_rt_{os.getpid()}"
    yield name
    assert not Path(f"/dev/shm/{name}").exists(), "a segment left behind"


def run_pl(tmp_path: Path, settings: str, segment: str) -> subprocess.CompletedProcess[str]:
    out, name = generate(fleet_with(tmp_path, settings))
    plan = (out / name / "main_pl.py").read_text()
    assert "realtime={" in plan
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(out), str(FLEET)]))
    return subprocess.run(
        [sys.executable, "-m", name, "pl", "--shm", segment, "--cycles", "3"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )


def allowed_cpus() -> str:
    """The CPUs this process may use as the refusal names them: `CPU 0`, `CPUs 0, 1`."""
    cpus = sorted(os.sched_getaffinity(0))
    return ("CPU " if len(cpus) == 1 else "CPUs ") + ", ".join(str(c) for c in cpus)


def test_a_refused_setting_is_one_line_and_the_process_runs_without_it(
    tmp_path: Path, segment: str
) -> None:
    done = run_pl(tmp_path, "{gc: freeze, cpus: [4096]}", segment)
    assert done.returncode == 0, done.stderr
    refused = [line for line in done.stderr.splitlines() if "realtime" in line]
    assert refused == [
        f"pl: realtime cpus refused: CPU 4096 not available here (this process may use "
        f"{allowed_cpus()}); running without it"
    ]
    assert "pl: 3 cycles" in done.stdout
    assert "pl: period error mean" in done.stdout and "over 3 wake-ups" in done.stdout


def test_a_refused_required_setting_stops_the_process_before_its_first_cycle(
    tmp_path: Path, segment: str
) -> None:
    done = run_pl(tmp_path, "{cpus: [4096], required: true}", segment)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines() == [
        f"pl: realtime cpus refused: CPU 4096 not available here (this process may use "
        f"{allowed_cpus()}) (realtime.required: not started)"
    ]
    assert "cycles" not in done.stdout


def test_fifo_and_mlockall_refused_by_the_os_each_give_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Where the OS refuses (no CAP_SYS_NICE, no CAP_IPC_LOCK: not root). This machine's
    tests may run as root, where both would be granted (and SCHED_FIFO on a shared CI
    machine is not something to try): the OS calls answer as an unprivileged user's."""

    def refuse(*args: object) -> None:
        raise PermissionError(1, "Operation not permitted")

    class Libc:
        def mlockall(self, flags: int) -> int:
            assert flags == realtime.MCL_CURRENT | realtime.MCL_FUTURE
            return -1

    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(ctypes, "CDLL", lambda *a, **k: Libc())
    monkeypatch.setattr(ctypes, "get_errno", lambda: 12)
    lines = realtime.apply("p1", {"fifo_priority": 50, "mlockall": True})
    assert lines == [
        "p1: realtime fifo_priority refused: Operation not permitted (SCHED_FIFO needs "
        "CAP_SYS_NICE or an rtprio limit); running without it",
        "p1: realtime mlockall refused: Cannot allocate memory (needs CAP_IPC_LOCK or a "
        "large enough memlock limit); running without it",
    ]
    with pytest.raises(realtime.RealtimeRefused, match="fifo_priority refused"):
        realtime.apply("p1", {"fifo_priority": 50, "required": True})
