"""Running systems seen from a test: the segments it names, what its console says.

Every segment a test makes carries the test process's pid, so a check that nothing is left
in /dev/shm looks only at its own entries, whatever other suites run beside it.
"""

from __future__ import annotations

import itertools
import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml


def segment_names(prefix: str) -> Callable[[], str]:
    """A maker of fresh segment names for one test module: `rcsgen_<prefix>_<pid>_<n>`."""
    numbers = itertools.count(1)
    return lambda: f"rcsgen_{prefix}_{os.getpid()}_{next(numbers)}"


def console_status(package_dir: Path, env: dict[str, str], segment: str) -> dict[str, Any]:
    """What the console of a running system says (`python -m <system> ctl status --format
    json` on `segment`); {} while it cannot say (no segment yet, or not every record)."""
    done = subprocess.run(
        [sys.executable, "-m", package_dir.name, "ctl", "--shm", segment, "status"]
        + ["--format", "json"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    return json.loads(done.stdout) if done.returncode == 0 else {}  # type: ignore[no-any-return]


def children(parent: int | None = None) -> list[str]:
    """Processes whose parent is `parent` (default: this test process), read from /proc,
    with their commands."""
    parent = os.getpid() if parent is None else parent
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == parent:
            try:
                found.append((stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode())
            except OSError:
                continue
    return [command for command in found if command]


def attached(block_module: Any, layout: Any, name: str) -> Callable[[], Any]:
    """A try at attaching to segment `name` another process is creating (for `wait_for`):
    the Block, or None while it is refused - no file yet, or not yet sized and headed (an
    attach in between is rightly refused as no rcsgen block)."""

    def tries() -> Any:
        try:
            return block_module.Block(layout, name, create=False)
        except (FileNotFoundError, block_module.BlockError):
            return None

    return tries


def alive(pid: int) -> bool:
    """Whether process `pid` runs: it exists and is not a zombie (exited, not yet reaped)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def listening(ports: set[int]) -> set[int]:
    """Which of `ports` something on this machine listens on (from /proc/net/tcp)."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            fields = line.split()
            port = int(fields[1].rsplit(":", 1)[1], 16)
            if fields[3] == "0A" and port in ports:  # 0A: LISTEN
                found.add(port)
    return found


# A system a test runs for what it shows or does, not for its detection bounds, runs "at
# ease": a process is lost after 5 s of silence, and its watchdog trips on a cycle of 100
# periods or on cycles 2,000 periods late in all over 50. On the two-core CI host at load
# 15-29 a paced process waits hundreds of milliseconds for a core; at the bounds a system
# declares for its own use (duo: 0.3 s, a cycle of 5 periods) its watchdog halts the roots
# and its supervisors take a starved subordinate for lost, and the test sees a HALT or an
# ERROR nobody gave. A test of a bound runs the system as declared.
AT_EASE_HEARTBEAT_TIMEOUT = 5.0
AT_EASE_WATCHDOG = {"period_factor": 100, "behind": 2000, "window": 50}


def at_ease(
    spec: Path, into: Path, heartbeat_timeout: float | None = AT_EASE_HEARTBEAT_TIMEOUT
) -> Path:
    """A copy in `into` of the system spec directory `spec` whose every process has the
    watchdog above and (unless `heartbeat_timeout` is None: the declared one kept) the
    heartbeat timeout given; its directory, to generate."""
    copy = into / spec.name
    shutil.copytree(spec, copy, ignore=shutil.ignore_patterns("__pycache__"))
    system_yaml = copy / "system.yaml"
    system = yaml.safe_load(system_yaml.read_text(encoding="utf-8"))
    if heartbeat_timeout is not None:
        system["heartbeat_timeout"] = heartbeat_timeout
    for process in system["processes"].values():
        process["watchdog"] = dict(AT_EASE_WATCHDOG)
    system_yaml.write_text(yaml.safe_dump(system, sort_keys=False), encoding="utf-8")
    return copy
