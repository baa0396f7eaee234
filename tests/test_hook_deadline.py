"""A hook call as generated code makes it (rcs/deadline.py's `hook`), without a generated
system: the result check written out for its kinds accepts exactly what the test of each
value accepts; a hook past its deadline is interrupted (main thread) or has its late
result refused (a hook that swallowed the interruption, or one in another thread); what
a hook raises is the module's HookError, chained; the hook is looked up at each call.
"""

from __future__ import annotations

import faulthandler
import os
import random
import signal
import threading
import time
import types
from collections.abc import Iterator
from fractions import Fraction
from itertools import product
from typing import Any

import pytest
from conftest import wait_for

from rcsgen.runtime import deadline
from rcsgen.runtime.contract import HookError, HookOverrun, kind_fits, kind_tokens, result_fits
from rcsgen.runtime.deadline import hook


class Real(float):
    """A float that is not exactly one (numpy-less stand-in for numpy.float64)."""


class Whole(int):
    """An int that is not exactly one (numpy-less stand-in for numpy.int64)."""


NAN, INF = float("nan"), float("inf")
BIG = 1.7e308  # two of them overflow a sum: the written-out check leaves those to the other
VALUES: list[Any] = [0.5, -0.0, BIG, -BIG, NAN, INF, -INF, Real(1.5), Real(NAN), Fraction(1, 3)]
VALUES += [0, 2, 3, -1, 2**63 - 1, -(2**63), 2**63, -(2**63) - 1, Whole(2), True, False]
VALUES += ["abcd", "abcde", "a\0", None, 1 + 2j, (1.0,)]
SMALL = [0.5, BIG, NAN, -INF, Real(1.5), 2, 2**63, Whole(1), True, "ab", None]


def each_fits(kinds: str, result: object) -> bool:
    """The plain rule: one value of its kind, or a tuple of exactly one value per kind,
    each passing its kind's own test."""
    tests = [kind_fits(token) for token in kind_tokens(kinds)]
    if len(tests) == 1:
        return tests[0](result)
    return (
        type(result) is tuple
        and len(result) == len(tests)
        and all(test(value) for test, value in zip(tests, result, strict=True))
    )


def results(kinds: str) -> Iterator[object]:
    """Many results for `kinds`: every mix of awkward values (all of them for one or two
    values, a smaller set for three, a seeded sample beyond), their usual shape, wrong
    lengths and lists."""
    count = len(kind_tokens(kinds))
    if count <= 2:
        mixes: Iterator[tuple[Any, ...]] = product(VALUES, repeat=count)
    elif count == 3:
        mixes = product(SMALL, repeat=3)
    else:
        pick = random.Random(kinds)
        mixes = (tuple(pick.choice(SMALL) for _ in range(count)) for _ in range(3000))
    for mix in mixes:
        yield mix[0] if count == 1 else mix
        if count > 1:
            yield list(mix)
    usual = {"f": 1.5, "i": 7, "b": True, "e": 1, "s": "ab"}
    shape = tuple(usual[token[0]] for token in kind_tokens(kinds))
    yield from (shape, shape[:-1], (*shape, 1.0), list(shape), shape[0])


class Owner:
    cycles = 41


@pytest.mark.parametrize(
    "kinds",
    ["f", "i", "b", "e3", "s4", "ff", "if", "ie2", "fs4", "iff", "ffb", "fff", "fs4e3"]
    + ["bfff", "bffb", "fffbff"],
)
def test_the_written_out_check_accepts_exactly_what_each_value_fits(kinds: str) -> None:
    """`result_fits` and the hook call's own check (both written out for `kinds`) give the
    answer of the value-by-value rule for every result: NaN, infinities, sums that
    overflow, ints at and past int64, bools for ints or floats, ints for floats,
    subclasses of float and int, Fractions, strings, wrong lengths, lists."""
    hooks = types.ModuleType("hooks")
    call = hook("m", hooks, "h", 5.0, kinds)
    fits = result_fits(kinds)
    for result in results(kinds):
        expected = each_fits(kinds, result)
        assert fits(result) is expected, (kinds, result)
        hooks.h = lambda value=result: value  # type: ignore[attr-defined]
        try:
            returned = call(Owner(), "R/S0/1")
        except HookError as error:
            assert not expected, (kinds, result, error)
            assert error.result is result and error.cycle == 42
        else:
            assert expected and returned is result, (kinds, result)


@pytest.fixture
def bounded() -> Iterator[None]:
    """Should a deadline fail, the test process dumps its threads and exits after a minute
    instead of hanging."""
    faulthandler.dump_traceback_later(60, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


def test_a_hook_past_its_deadline_is_interrupted_and_named(bounded: None) -> None:
    hooks = types.ModuleType("hooks")
    hooks.h = lambda: time.sleep(3600)  # type: ignore[attr-defined]
    with pytest.raises(HookError) as caught:
        hook("m", hooks, "h", 0.05, "f")(Owner(), "R/S0/1")
    cause = caught.value.__cause__
    assert isinstance(cause, HookOverrun) and cause.interrupted and cause.deadline == 0.05
    assert (caught.value.module, caught.value.hook, caught.value.rule) == ("m", "h", "R/S0/1")
    assert caught.value.cycle == 42 and "deadline of 0.05 s" in str(caught.value)


def test_a_child_forked_after_the_watcher_started_has_its_own_watcher(bounded: None) -> None:
    """The watcher is a thread, and a fork takes only the forking thread along: a child
    forked after its parent's hook calls started the watcher (multiprocessing's default on
    Linux) still has a hook past its deadline interrupted, not left to run for an hour."""
    hooks = types.ModuleType("hooks")
    hooks.h = lambda: 1.0  # type: ignore[attr-defined]
    call = hook("m", hooks, "h", 0.05, "f")
    assert call(Owner(), "R/S0/1") == 1.0  # the parent's watcher runs from here
    assert deadline._Watch.armed
    # SIGALRM's handler as another generated package's copy of rcs.deadline installs it:
    # not this module's `_on_alarm`, which the child's watcher must still count on
    previous = signal.signal(signal.SIGALRM, lambda n, f: deadline._on_alarm(n, f))
    try:
        pid = os.fork()
    finally:
        signal.signal(signal.SIGALRM, previous)
    if pid == 0:  # the child: exit 0 only if its overrunning hook is interrupted
        code = 1
        try:
            hooks.h = lambda: time.sleep(3600)  # type: ignore[attr-defined]
            call(Owner(), "R/S0/1")
        except HookError as error:
            cause = error.__cause__
            code = 0 if isinstance(cause, HookOverrun) and cause.interrupted else 2
        finally:
            os._exit(code)
    ended: list[int] = []  # the child's exit code, once it has ended

    def child_ended() -> bool:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            ended.append(os.waitstatus_to_exitcode(status))
        return bool(done)

    try:
        wait_for(child_ended, "the forked child's overrunning hook interrupted", 20)
    finally:
        if not ended:  # still running its hour-long hook
            os.kill(pid, 9)
            os.waitpid(pid, 0)
    assert ended == [0]


def test_a_hook_that_swallows_the_interruption_has_its_late_result_refused(
    bounded: None,
) -> None:
    interrupted = []

    def swallows() -> float:
        while len(interrupted) < 2:
            try:
                time.sleep(3600)
            except BaseException as error:  # noqa: BLE001 (what a careless hook does)
                interrupted.append(error)
        return 1.0

    hooks = types.ModuleType("hooks")
    hooks.h = swallows  # type: ignore[attr-defined]
    with pytest.raises(HookError) as caught:
        hook("m", hooks, "h", 0.05, "f")(Owner(), "R/S0/1")
    assert all(isinstance(error, HookOverrun) for error in interrupted)
    cause = caught.value.__cause__
    assert isinstance(cause, HookOverrun) and not cause.interrupted and cause.took > 0.1


def test_a_hook_in_another_thread_has_its_late_result_refused_and_signals_no_one(
    bounded: None,
) -> None:
    """The watcher only interrupts the main thread's hooks: a late hook in another thread is
    refused when it returns, and the main thread, in a hook of its own meanwhile, is not
    interrupted for it."""
    done = threading.Event()
    hooks = types.ModuleType("hooks")
    hooks.late = lambda: time.sleep(0.2) or 1.0  # type: ignore[attr-defined]
    hooks.waits = lambda: done.wait(30) and 2.0  # type: ignore[attr-defined]
    late, waits = hook("m", hooks, "late", 0.05, "f"), hook("m", hooks, "waits", 30.0, "f")
    done.set()
    waits(Owner(), "R/S0/1")  # (the first call in the main thread starts the watcher)
    done.clear()
    outcome: list[BaseException | float] = []

    def other() -> None:
        try:
            outcome.append(late(Owner(), "R/S0/2"))
        except BaseException as error:  # noqa: BLE001 (kept for the main thread to check)
            outcome.append(error)
        done.set()

    threading.Thread(target=other, daemon=True).start()
    assert waits(Owner(), "R/S0/1") == 2.0
    (error,) = outcome
    assert isinstance(error, HookError) and error.hook == "late"
    assert isinstance(error.__cause__, HookOverrun) and not error.__cause__.interrupted


def test_what_a_hook_raises_is_the_modules_hook_error_and_the_hook_is_looked_up_each_call() -> None:
    hooks = types.ModuleType("hooks")
    hooks.h = lambda x: x / 0  # type: ignore[attr-defined]
    call = hook("m", hooks, "h", 1.0, "f")
    with pytest.raises(HookError) as caught:
        call(Owner(), "R/S0/1", 3.0)
    assert isinstance(caught.value.__cause__, ZeroDivisionError)
    assert caught.value.raised and "hook `h` of `m`" in str(caught.value)
    hooks.h = lambda x: x * 2  # type: ignore[attr-defined]
    assert call(Owner(), "R/S0/1", 3.0) == 6.0
