"""Deadline: a hook that runs too long is interrupted and reported, never left to hang.

Generated code calls every hook through `hook(...)`, one method of its controller class per
hook (`self.hook_co_position_for_sump(rule, *args)`): `hooks.name(*args)` within the hook's
declared `deadline:` (else a few cycle periods), any failure raised as the module's
`HookError`, the result checked against its targets' kinds. A watcher thread, started with
the first call, looks every 20 ms (a quarter of any shorter hook deadline) among the main
thread's frames for the call it is in (the innermost: its code's file is `WATCHED`, its
locals say when it began); once that has run past its deadline, the watcher sends the main
thread a timer signal (SIGALRM) whose handler raises `HookOverrun` inside the hook,
wherever it is: a Python loop, `time.sleep`, a wait on a lock or a socket (the call
returns early with EINTR and the handler runs). The call turns it into the module's
`HookError`, naming the hook, its rule, its cycle and the deadline. A hook that returns
late anyway (it caught `HookOverrun` with a bare `except:`, or it ran outside the main
thread) is refused when it returns: its result is never used. The same holds in the paced
loop, in lockstep and in a harness, as long as hooks run in the main thread.

What it cannot interrupt, documented in docs/semantics.md: a hook that keeps the
interpreter from running Python code - a long computation inside one C call (a big
`sum()`, a regular expression that backtracks, a C extension that does not release the
GIL), a signal blocked with `pthread_sigmask`, a process that replaced SIGALRM's handler
for its own use (the deadline then only refuses the late result) - or a hook called
outside the main thread, which only its late result can reveal. A call writes nothing for
the watcher and asks for no thread id: it keeps the clock readings it takes, before and
after the hook, in its own frame (about 0.1 us a call; the whole call, result check
included, 0.2-0.4 us more than calling the hook plainly: bench/prototypes/hook_call.py).
The watcher wakes up every 20 ms at most, and only signals a hook that has overrun.

Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from keyword import iskeyword
from types import FrameType, ModuleType
from typing import Any, ClassVar, TypeVar

from .contract import (
    HookError,
    HookOverrun,
    compiled,
    fast_fits,
    result_fits_each,
    shared,
)

FACTORY_DEADLINE = 30.0  # seconds a `hooks_state` factory may take (a map to load, a file)
TICK = 0.02  # seconds between two looks of the watcher (a quarter of any shorter deadline)

_Result = TypeVar("_Result")
_MAIN = threading.main_thread().ident or 0  # (a started thread has its id)
_clock = time.monotonic


@shared
class _Watch:
    """The watcher, one per process (`shared`): every generated package in it has its copy
    of this module, and only one of them can own SIGALRM and the watcher. Lists, so that a
    call changes items, never the class."""

    watcher: threading.Thread | None = None
    watching: ClassVar[list[int]] = [0]  # the main thread's id once the watcher runs
    shortest: ClassVar[list[float]] = [TICK * 4]  # the shortest deadline of a hook made yet
    armed = False  # SIGALRM's handler is ours: an overrun can be interrupted


# The file name of the code of every call under a deadline (`hook`'s and `within`'s): the
# watcher finds the one the main thread is in among its frames, with its locals `began`
# (0.0 once it has returned) and `deadline`.
WATCHED = "<rcs.deadline>"
_get_ident = threading.get_ident


def within(deadline: float, hook: Callable[..., _Result], *args: Any) -> _Result:
    """`hook(*args)`, interrupted with `HookOverrun` once it has run `deadline` seconds
    (in the main thread); `HookOverrun` too when it returns later than that anyway."""
    if not _Watch.watching[0] and _get_ident() == _MAIN:
        _start()
    result: _Result = _within(deadline, hook, args)
    return result


_WITHIN = """\
def within(deadline, hook, args):
    began = _clock()
    try:
        result = hook(*args)
    finally:
        took, began = _clock() - began, 0.0
    if took > deadline:
        raise HookOverrun(deadline, took, interrupted=False)
    return result
"""
_within = compiled(_WITHIN, "within", {"_clock": _clock, "HookOverrun": HookOverrun}, WATCHED)


def hook(
    module: str, hooks: ModuleType, name: str, deadline: float, kinds: str | None = None
) -> Callable[..., Any]:
    """Module `module`'s call of hook `name` of `hooks`, as a method of its controller class:
    `self.name(rule, *args)` calls `hooks.name(*args)` (looked up at each call) within
    `deadline` seconds; whatever it raises, an overrun too, is raised as a `HookError` naming
    the module, the hook, `rule` and the module's cycle; a result that does not fit `kinds`
    (None: the caller checks it, or ignores it) likewise. One frame for the whole call,
    written out for its hook (`_CALL`): the deadline's bookkeeping is `within`'s, inlined,
    and the usual result is accepted by `contract.fast_fits`'s straight-line test."""
    # `hooks.name`, an attribute the interpreter caches, when `name` can be written so
    function = f"hooks.{name}" if name.isidentifier() and not iskeyword(name) else "hook()"
    names: dict[str, Any] = {
        "hooks": hooks,
        "hook": lambda: getattr(hooks, name),
        "module": module,
        "name": name,
        "deadline": deadline,
        "kinds": kinds or "",
        "watching": _Watch.watching,
        "_clock": _clock,
        "within": within,
        "HookError": HookError,
        "HookOverrun": HookOverrun,
    }
    if kinds is None:
        check = "    return result\n"
    else:
        fast, more = fast_fits(kinds, "return result", "    ")
        names |= more | {"fits": result_fits_each(kinds)}
        check = fast + _REFUSE
    call: Callable[..., Any] = compiled(
        _CALL.format(function=function) + check, "call", names, WATCHED
    )
    call.__name__ = call.__qualname__ = name
    _Watch.shortest[0] = min(_Watch.shortest[0], deadline)
    return call


# A hook call: `within`'s, inlined, once the watcher runs (`watching`); until then `within`
# makes the call (it starts the watcher from the main thread).
_CALL = """\
def call(owner, rule, *args):
    try:
        if watching[0]:
            began = _clock()
            try:
                result = {function}(*args)
            finally:
                took, began = _clock() - began, 0.0
            if took > deadline:
                raise HookOverrun(deadline, took, interrupted=False)
        else:
            result = within(deadline, {function}, *args)
    except BaseException as error:
        raise HookError(module, name, rule, owner.cycles) from error
"""
_REFUSE = """\
    if fits(result):
        return result
    raise HookError(module, name, rule, owner.cycles, result, kinds)
"""


def _start() -> None:
    """Install the handler (if SIGALRM is free) and start the watcher, once a process."""
    current = signal.getsignal(signal.SIGALRM)
    if current in (signal.SIG_DFL, None) or current is _on_alarm:
        signal.signal(signal.SIGALRM, _on_alarm)
        _Watch.armed = True
    _Watch.watcher = threading.Thread(target=_watch, name="rcs-hook-deadline", daemon=True)
    _Watch.watcher.start()
    _Watch.watching[0] = _MAIN


def _forget_watcher() -> None:
    """In a child forked after the watcher started: only the forking thread came along, so
    there is no watcher; the child's first hook call starts its own. SIGALRM's handler came
    along (and may be another generated package's copy of `_on_alarm`): `armed` stays."""
    _Watch.watcher, _Watch.watching[0] = None, 0


os.register_at_fork(after_in_child=_forget_watcher)


def _watch() -> None:
    signalled = 0.0  # when it last signalled the main thread
    while True:
        time.sleep(min(TICK, _Watch.shortest[0] / 4))
        frames = sys._current_frames()  # (none kept while it sleeps)
        if _MAIN not in frames:  # the main thread has ended: nothing to interrupt
            return
        began, deadline = running(frames.pop(_MAIN))
        del frames
        if not began or not _Watch.armed:
            continue
        now = _clock()
        # Signalled again every deadline until the hook gives up (it may catch the first).
        if now - began > deadline and now - max(signalled, began) > deadline:
            signalled = now
            try:
                signal.pthread_kill(_MAIN, signal.SIGALRM)
            except (OSError, ValueError):  # the main thread has ended: nothing to interrupt
                return


def running(frame: FrameType | None) -> tuple[float, float]:
    """The call under a deadline that `frame` is in (the innermost): when it began (0.0:
    none, or it has returned) and its deadline. Only the main thread's are watched: a
    hook called from another thread has its late result refused, never a signal."""
    while frame is not None:
        if frame.f_code.co_filename == WATCHED:
            names = frame.f_globals | frame.f_locals  # a hook's deadline: a global of its own
            return names.get("began", 0.0), names.get("deadline", 0.0)
        frame = frame.f_back
    return 0.0, 0.0


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    """SIGALRM in the main thread: interrupt the hook that overran (ignored otherwise)."""
    began, deadline = running(frame)
    if began and _clock() - began > deadline:
        raise HookOverrun(deadline, _clock() - began, interrupted=True)
