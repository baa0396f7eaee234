"""Deadline: a hook that runs too long is interrupted and reported, never left to hang.

Generated code calls every hook through `hook(...)`, one method of its controller class per
hook (`self.hook_co_position_for_sump(rule, *args)`): `hooks.name(*args)` within the hook's
declared `deadline:` (else a few cycle periods), any failure raised as the module's
`HookError`, the result checked against its targets' kinds. A watcher thread, started with
the first call, looks every few milliseconds at the hook running in the main thread; once
it has run past its deadline, the watcher sends the main thread a timer signal (SIGALRM)
whose handler raises `HookOverrun` inside the hook, wherever it is: a Python loop,
`time.sleep`, a wait on a lock or a socket (the call returns early with EINTR and the
handler runs). The call turns it into the module's `HookError`, naming the hook, its rule,
its cycle and the deadline. A hook that returns late anyway (it caught `HookOverrun` with a
bare `except:`, or it ran outside the main thread) is refused when it returns: its result
is never used. The same holds in the paced loop, in lockstep and in a harness, as long as
hooks run in the main thread.

What it cannot interrupt, documented in docs/semantics.md: a hook that keeps the
interpreter from running Python code - a long computation inside one C call (a big
`sum()`, a regular expression that backtracks, a C extension that does not release the
GIL), a signal blocked with `pthread_sigmask`, a process that replaced SIGALRM's handler
for its own use (the deadline then only refuses the late result) - or a hook called
outside the main thread, which only its late result can reveal. The watcher costs each
hook call about 0.4 us (two reads of the clock), wakes up every 20 ms at most, and only
signals a hook that has overrun.

Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable
from keyword import iskeyword
from types import ModuleType
from typing import Any, ClassVar, TypeVar

from .contract import HookError, HookOverrun, compiled, fast_fits, result_fits_each, shared

FACTORY_DEADLINE = 30.0  # seconds a `hooks_state` factory may take (a map to load, a file)
TICK = 0.02  # seconds between two looks of the watcher (a quarter of a shorter deadline)

_Result = TypeVar("_Result")
_MAIN = threading.main_thread().ident
_clock = time.monotonic


@shared
class _Watch:
    """The hook the main thread is running, in `state`: when it began (0: none), its
    deadline, when the watcher last signalled it. One per process (`shared`): every
    generated package in it has its copy of this module, and only one of them can own
    SIGALRM and the watcher. A list, so that a call changes items, never the class."""

    state: ClassVar[list[float]] = [0.0, 0.0, 0.0]  # began, deadline, signalled
    watcher: threading.Thread | None = None
    watching: ClassVar[list[int]] = [0]  # the main thread's id once the watcher runs
    armed = False  # SIGALRM's handler is ours: an overrun can be interrupted


_STATE = _Watch.state
BEGAN, DEADLINE, SIGNALLED = 0, 1, 2
_get_ident = threading.get_ident


def within(deadline: float, hook: Callable[..., _Result], *args: Any) -> _Result:
    """`hook(*args)`, interrupted with `HookOverrun` once it has run `deadline` seconds
    (in the main thread); `HookOverrun` too when it returns later than that anyway."""
    state = _STATE
    if _get_ident() != _MAIN:  # no signal reaches it: only a late result is refused
        began = _clock()
        result = hook(*args)
    else:
        if not _Watch.watching[0]:
            _start()
        state[DEADLINE] = deadline
        state[BEGAN] = began = _clock()
        try:
            result = hook(*args)
        finally:
            state[BEGAN] = 0.0
    took = _clock() - began
    if took > deadline:
        raise HookOverrun(deadline, took, interrupted=False)
    return result


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
        "state": _STATE,
        "watching": _Watch.watching,
        "_get_ident": _get_ident,
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
    source = _CALL.format(function=function, BEGAN=BEGAN, DEADLINE=DEADLINE) + check
    call: Callable[..., Any] = compiled(source, "call", names, f"<hook {module}.{name}>")
    call.__name__ = call.__qualname__ = name
    return call


# A hook call. `watching` holds the main thread's id once its watcher runs: until then, and
# in any other thread, `within` makes the call (it starts the watcher; elsewhere a late
# result is refused).
_CALL = """\
def call(owner, rule, *args):
    try:
        if _get_ident() == watching[0]:
            state[{DEADLINE}] = deadline
            state[{BEGAN}] = began = _clock()
            try:
                result = {function}(*args)
            finally:
                state[{BEGAN}] = 0.0
            took = _clock() - began
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
    _Watch.watching[0] = _MAIN  # type: ignore[assignment]


def _watch() -> None:
    state = _STATE
    while True:
        deadline = state[DEADLINE]
        time.sleep(min(TICK, deadline / 4) if deadline > 0 else TICK)
        began = state[BEGAN]
        if not began or not _Watch.armed:
            continue
        now = _clock()
        # Signalled again every deadline until the hook gives up (it may catch the first).
        if now - began > state[DEADLINE] and now - max(state[SIGNALLED], began) > state[DEADLINE]:
            state[SIGNALLED] = now
            try:
                signal.pthread_kill(_MAIN, signal.SIGALRM)  # type: ignore[arg-type]
            except (OSError, ValueError):  # the main thread has ended: nothing to interrupt
                return


def _on_alarm(signum: int, frame: object) -> None:
    """SIGALRM in the main thread: interrupt the hook that overran (ignored otherwise)."""
    began, deadline = _STATE[BEGAN], _STATE[DEADLINE]
    if began and _clock() - began > deadline:
        raise HookOverrun(deadline, _clock() - began, interrupted=True)
