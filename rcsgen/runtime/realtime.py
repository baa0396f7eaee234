"""Realtime: a process's opt-in real-time settings (system.yaml `processes.P.realtime`).

Applied as the process starts, once its modules are built: `gc` (`freeze`: what exists
then is never scanned again; `disable`: no cyclic collection), `cpus` (its affinity),
`fifo_priority` (SCHED_FIFO), `mlockall` (its memory locked in RAM). Each one the OS does
not allow is refused with one line (`refusals`), and the process runs without it, unless
the spec says `required: true`: then it stops (RealtimeRefused) before its first cycle.
Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import gc
import os
from collections.abc import Callable, Mapping

from .contract import listed, shared

MCL_CURRENT, MCL_FUTURE = 1, 2  # mlockall(2)


@shared
class RealtimeRefused(Exception):
    """A `required` real-time setting was refused: the process does not run."""


def apply(name: str, settings: Mapping[str, object]) -> list[str]:
    """Apply `settings` to this process; one line for each refused (empty: all applied).
    Raises RealtimeRefused with those lines when the settings are `required`."""
    refused = []
    for key, setter in SETTERS.items():
        if key in settings:
            problem = setter(settings[key])
            if problem:
                refused.append(f"{name}: realtime {key} refused: {problem}")
    if refused and settings.get("required"):
        raise RealtimeRefused("; ".join(refused) + " (realtime.required: not started)")
    return [f"{line}; running without it" for line in refused]


def _gc(mode: object) -> str:
    gc.collect()
    if mode == "freeze":
        gc.freeze()
    elif mode == "disable":
        gc.disable()
    else:
        return f"{mode!r} is neither freeze nor disable"
    return ""


def _cpus(cpus: object) -> str:
    wanted = {int(c) for c in cpus}  # type: ignore[attr-defined]
    if not hasattr(os, "sched_setaffinity"):  # pragma: no cover - not Linux
        return "this OS has no CPU affinity"
    allowed = os.sched_getaffinity(0)
    if not wanted <= allowed:
        return (
            f"{listed('CPU', sorted(wanted - allowed))} not available here "
            f"(this process may use {listed('CPU', sorted(allowed))})"
        )
    try:
        os.sched_setaffinity(0, wanted)
    except OSError as error:
        return error.strerror or str(error)
    return ""


def _fifo(priority: object) -> str:
    if not hasattr(os, "SCHED_FIFO"):  # pragma: no cover - not Linux
        return "this OS has no SCHED_FIFO"
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(int(priority)))  # type: ignore[call-overload]
    except OSError as error:
        return f"{error.strerror or error} (SCHED_FIFO needs CAP_SYS_NICE or an rtprio limit)"
    return ""


def _mlockall(wanted: object) -> str:
    if not wanted:
        return ""
    import ctypes  # here: only a process that asks for it pays its import

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
            error = ctypes.get_errno()
            return f"{os.strerror(error)} (needs CAP_IPC_LOCK or a large enough memlock limit)"
    except (OSError, AttributeError) as error:  # pragma: no cover - no libc mlockall
        return str(error)
    return ""


SETTERS: dict[str, Callable[[object], str]] = {
    "cpus": _cpus,
    "fifo_priority": _fifo,
    "mlockall": _mlockall,
    "gc": _gc,  # last: what the others allocated is frozen too
}
