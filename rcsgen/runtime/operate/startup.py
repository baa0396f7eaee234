"""Startup: what `python -m <system>` (and `rcsgen up`) checks before it starts anything, and
how a process that fails says so.

Before a segment is made or a process started: a segment name the system can use, run
settings the system declares (`settings:` in system.yaml; `KEY=VALUE`, each key once), and
one line for each mistake (exit 2, as every usage error). Once running, a process whose
hook or module fails prints one line naming the process, module, hook, rule and cycle, and
ends with an exit code that tells the launcher what happened (HOOK_FAILED, MODULE_FAILED,
START_FAILED), so its summary can say it and its own exit is not 0. Standard library only:
copied verbatim into every generated package.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Mapping, Sequence
from types import ModuleType

from ..contract import HookError
from .command import suggest

# Exit codes of a process (the launcher's summary says them in words); 3 is REFUSED, a
# process that refused to restart (launcher.py).
HOOK_FAILED = 4  # a hook raised, returned what its `returns:` refuses, or overran
MODULE_FAILED = 5  # a module's own code raised (an int beyond 64 bits, a division by 0)
START_FAILED = 6  # a module could not be made: its hook-state factory failed
FAILURES = {
    HOOK_FAILED: "a hook failed",
    MODULE_FAILED: "a module failed",
    START_FAILED: "it could not start: a hook-state factory failed",
}

# A segment name: what a shared-memory name may hold on every POSIX system, short enough
# for the launcher's per-process names (`<name>_<process>`) to fit NAME_MAX.
_SEGMENT = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,199}")


def default_segment(layout: ModuleType) -> str:
    """The segment a system runs over unless `--shm` names another: `rcs_<system>_<hash>`,
    the first 8 characters of its layout's hash (the launcher, the console and the monitor
    all find it by this name)."""
    return f"rcs_{layout.SYSTEM}_{layout.LAYOUT_HASH[:8]}"


def segment_problem(name: str) -> str:
    """'' when `name` can name a shared-memory segment, else what is wrong."""
    if _SEGMENT.fullmatch(name):
        return ""
    shown = repr(name) if len(name) <= 40 else repr(name[:37]) + "..."
    if not name:
        return "--shm: an empty segment name"
    if len(name) > 200:
        return f"--shm: {shown} is {len(name)} characters: a segment name has at most 200"
    return (
        f"--shm: {shown} is not a segment name: letters, digits, `_`, `.` and `-` only "
        "(no `/`), not starting with `.` or `-`"
    )


def parse_settings(layout: ModuleType, items: Sequence[str]) -> dict[str, str]:
    """`--set KEY=VALUE` items as settings, checked (`check_settings`); ValueError naming
    the first mistake."""
    settings: dict[str, str] = {}
    for item in items:
        key, equals, value = item.partition("=")
        if not equals or not key:
            raise ValueError(f"--set: {item!r} is not KEY=VALUE")
        if key in settings:
            raise ValueError(f"--set: setting {key} is given twice")
        settings[key] = value
    problem = settings_problem(layout, settings)
    if problem:
        raise ValueError(f"--set: {problem}")
    return settings


def settings_problem(layout: ModuleType, settings: Mapping[str, str]) -> str:
    """'' when the system takes every one of `settings`, else what is wrong: a name it does
    not declare (`settings:` in system.yaml), or any setting for a system whose controllers
    have no hook-state factory to read it."""
    declared = getattr(layout, "SETTINGS", None)
    for key, value in settings.items():
        if not isinstance(key, str) or not isinstance(value, str):
            return f"setting {key!r}: a setting and its value are text"
        if declared is not None and key not in declared:
            return f"{layout.SYSTEM} has " + suggest(key, list(declared), "setting")
        if declared is None and not getattr(layout, "READS_SETTINGS", True):
            return (
                f"{layout.SYSTEM} reads no setting {key!r}: none of its controllers has a "
                "`hooks_state` factory"
            )
    return ""


def report_failure(process: str, error: BaseException, package: str) -> int:
    """A process stopped by a failure: one line on stderr naming the process, the module, the
    hook and the rule and cycle it was in, and the exit code that says which failure."""
    if isinstance(error, HookError):
        print(f"{process}: {error}", file=sys.stderr)
        return START_FAILED if error.rule == "hooks_state" else HOOK_FAILED
    module = failed_module(error, package)
    text = f"{type(error).__name__}: {error}" if str(error) else type(error).__name__
    where = f"module `{module}` failed" if module else "failed"
    print(f"{process}: {where}: {text}", file=sys.stderr)
    return MODULE_FAILED


def failed_module(error: BaseException, package: str) -> str | None:
    """The generated module of `package` the innermost frame of the traceback is in."""
    from pathlib import Path  # here: a process that never fails does not import them
    from traceback import walk_tb

    found = None
    for frame, _ in walk_tb(error.__traceback__):
        path = Path(frame.f_code.co_filename)
        if path.parent.name == package and path.stem not in ("__init__", "__main__", "layout"):
            found = path.stem
    return found


def ending(name: str, code: int | None) -> str:
    """What the launcher's summary says of a process that ended with exit `code`."""
    if code in FAILURES:
        return f"{name} stopped: {FAILURES[code]} (exit {code}; its error is above)"
    return f"{name} died (exit {code})"
