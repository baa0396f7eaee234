"""The lockstep token ring's parts (rcsgen/runtime/ring.py), in one process: the hand-off,
the stop through a control pipe, the coordinator's wait that sees a death or times out.
The ring across real processes, with a process killed or stopped holding the token, is in
tests/test_failsafe.py."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator

import pytest
from conftest import wait_for

from rcsgen.runtime import ring


@pytest.fixture
def links() -> Iterator[list[ring.Link]]:
    made = ring.new_links(2)
    yield made
    ring.close_links(made)


def test_the_token_back_wakes_the_coordinator(links: list[ring.Link]) -> None:
    back = ring.Return(links[1].read, ())
    try:
        ring.give(links[1].write)
        assert back.wait(10.0) == links[1].read
        ring.give(links[1].write)  # a second cycle: one token each
        assert back.wait(10.0) == links[1].read
    finally:
        back.close()
        back.close()  # idempotent: the launcher's stop may call it again


def test_the_coordinator_wait_times_out_then_sees_a_closed_answer_pipe(
    links: list[ring.Link],
) -> None:
    read, write = os.pipe()
    back = ring.Return(links[1].read, (read,))
    try:
        assert back.wait(0.05) is None  # nothing came: the caller reports the holder
        os.close(write)  # a process died: its answer pipe closes
        write = -1
        assert back.wait(10.0) == read  # woken by the watcher, not by a token
        assert back.dead == read
    finally:
        back.close()
        os.close(read)
        if write >= 0:
            os.close(write)


def test_a_late_wake_for_a_cycle_that_ended_is_not_taken_for_a_timeout(
    links: list[ring.Link],
) -> None:
    """The watcher wakes the read with STOP as the deadline passes; if the token came
    back just then, the STOP left behind must not end the next cycle early."""
    back = ring.Return(links[1].read, ())
    try:
        os.write(links[1].write, ring.STOP)  # as a watcher firing too late would
        ring.give(links[1].write)  # the token of the next cycle, in time
        assert back.wait(10.0) == links[1].read
        os.write(links[1].write, ring.STOP)  # a stale STOP alone: wait on for the token
        threading.Timer(0.1, ring.give, (links[1].write,)).start()
        assert back.wait(10.0) == links[1].read
    finally:
        back.close()


def test_a_spinning_coordinator_still_blocks_and_times_out(links: list[ring.Link]) -> None:
    back = ring.Return(links[1].read, (), spin=1e-3)
    try:
        assert back.wait(0.02) is None
        ring.give(links[1].write)
        assert back.wait(10.0) == links[1].read
    finally:
        back.close()


@pytest.mark.parametrize("how", ["closed", "written"])
def test_a_process_blocked_for_the_token_stops_when_its_control_pipe_says(
    links: list[ring.Link], how: str
) -> None:
    """A process blocks in a read of its link; its coordinator stopping it (b"q") or going
    away (the pipe closes) ends the read with STOP, not a token."""
    receiver = ring.Receiver(links[0].read)
    ring.give(links[0].write)
    assert receiver.wait()  # a token
    control, coordinator = os.pipe()
    watcher = ring.stop_on_control(control, links[0].write)
    got: list[bool] = []
    blocked = threading.Thread(target=lambda: got.append(receiver.wait()), daemon=True)
    blocked.start()
    if how == "closed":
        os.close(coordinator)
    else:
        os.write(coordinator, b"q")
    blocked.join(10.0)
    watcher.join(10.0)
    assert got == [False]
    os.close(control)
    if how == "written":
        os.close(coordinator)


def test_a_token_added_to_a_stop_is_still_a_stop(links: list[ring.Link]) -> None:
    receiver = ring.Receiver(links[0].read)
    os.write(links[0].write, ring.STOP)
    ring.give(links[0].write)  # the process before it handed on the token meanwhile
    assert not receiver.wait()


def test_spinning_wherever_there_are_two_cores() -> None:
    """One member spins at a time (the holder's successor): two cores are enough."""
    assert ring.default_spin() == (ring.SPIN if ring.cores() >= 2 else 0.0)


def _pending(fd: int) -> int:
    """What a link holds, taken out of it (0 when nothing)."""
    os.set_blocking(fd, False)
    try:
        return ring.WORD.unpack(os.read(fd, ring.WORD.size))[0]
    except BlockingIOError:
        return 0


def test_a_nudge_is_not_a_token(links: list[ring.Link]) -> None:
    """A nudged process spins, then waits on for the token; a nudge that came with the
    token is the token; a nudge with a stop is a stop."""
    receiver = ring.Receiver(links[0].read, spin=1e-3)
    os.write(links[0].write, ring.WAKE)
    threading.Timer(0.05, ring.give, (links[0].write,)).start()
    assert receiver.wait()  # the token, after the nudge's spin ran out
    os.write(links[0].write, ring.WAKE)
    ring.give(links[0].write)
    assert receiver.wait()
    os.write(links[0].write, ring.WAKE)
    os.write(links[0].write, ring.STOP)
    assert not receiver.wait()
    ring.give(links[0].write)
    ring.give(links[0].write)  # two tokens: the ring is broken
    assert not receiver.wait()


def test_a_nudged_coordinator_waits_on_for_the_token_and_still_times_out(
    links: list[ring.Link],
) -> None:
    back = ring.Return(links[1].read, (), spin=1e-3)
    try:
        os.write(links[1].write, ring.WAKE)
        assert back.wait(0.05) is None  # a nudge alone is no token back
        os.write(links[1].write, ring.WAKE)
        threading.Timer(0.02, ring.give, (links[1].write,)).start()
        assert back.wait(10.0) == links[1].read
    finally:
        back.close()


@pytest.mark.parametrize("free", [True, False])
def test_a_member_nudges_the_next_only_while_a_core_is_free(
    links: list[ring.Link], monkeypatch: pytest.MonkeyPatch, free: bool
) -> None:
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: free)
    nudge = ring.Nudge(links[0].write, spin=1e-3)
    try:
        nudge()
        assert _pending(links[0].read) == (ring.WAKE_VALUE if free else 0)
    finally:
        nudge.close()
    idle = ring.Nudge(links[0].write, spin=0.0)  # spinning off: never a nudge
    idle()
    assert _pending(links[0].read) == 0


def test_a_busy_machine_is_looked_at_a_quarter_as_often(
    links: list[ring.Link], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A look at the load is a read of /proc/loadavg (~7 µs). Where it saw no core free,
    the next look is BUSY_CHECK nudges away (nobody spins there: the look is all the spin
    machinery costs); where it saw one, CHECK, so a ring that spins stops soon after the
    machine gets busy."""
    looks: list[bool] = []
    free = [False]

    def core_free(self: ring.Load, spinners: int = 0) -> bool:
        looks.append(free[0])
        return free[0]

    monkeypatch.setattr(ring.Load, "core_free", core_free)
    nudge = ring.Nudge(links[0].write, spin=1e-3)
    try:
        for _ in range(ring.BUSY_CHECK + 1):
            nudge()
        assert looks == [False] and _pending(links[0].read) == 0
        free[0] = True
        nudge()  # looked again: free, a nudge
        assert looks == [False, True] and _pending(links[0].read) == ring.WAKE_VALUE
        for _ in range(ring.CHECK):
            nudge()
        free[0] = False
        nudge()  # CHECK nudges after a free look: looked again, busy
        assert looks == [False, True, False]
        assert ring.CHECK < ring.BUSY_CHECK
    finally:
        nudge.close()


def test_a_core_is_free_while_the_runnable_tasks_fit_the_cores(tmp_path) -> None:
    """/proc/loadavg's fourth field is running/total (the kernel's runnable count)."""
    load = ring.Load()
    try:
        cores = load.cores
        for running, free in ((cores, True), (cores + 1, False)):
            os.close(load.fd)
            path = tmp_path / f"loadavg{running}"
            path.write_text(f"0.50 0.40 0.30 {running}/321 4242\n")
            load.fd = os.open(path, os.O_RDONLY)
            assert load.core_free() is free
            # more than the cores, all of them the ring's own: this reader, the token's
            # holder and the ring's spinners
            assert load.core_free(spinners=running - 2) is True
            assert load.core_free(spinners=running - 3) is free
    finally:
        load.close()


# ---------------------------------------------------------------- the turn words (Page)


@pytest.fixture
def page() -> Iterator[ring.Page]:
    made = ring.Page.create(3)
    assert made is not None  # Linux: a memfd
    yield made
    made.close()
    made.close()  # idempotent: the launcher's stop may call it again


def _word(page: ring.Page, link: int, word: int) -> int:
    return page.words[link * ring.SLOT_WORDS + word]


def test_a_token_is_a_turn_word_and_its_doorbell_is_read_spun_or_slept(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Handing the token on writes the turn word, then the eventfd; the taker reads that
    doorbell whether it saw the word spinning or slept until the doorbell came, so each
    hand-off leaves the eventfd empty."""
    free = [True]
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: free[0])
    give = ring.Giver(links[0].write, page, 0)
    receiver = ring.Receiver(links[0].read, 1e-3, page, 0)
    give()
    assert _word(page, 0, ring.TURN) == 1
    assert receiver.wait()  # spinning (eager): the word, then the doorbell at once
    assert _pending(links[0].read) == 0
    os.set_blocking(links[0].read, True)
    free[0], receiver.taker.load.left = False, 0  # no core free: it sleeps
    got: list[bool] = []
    asleep = threading.Thread(target=lambda: got.append(receiver.wait()), daemon=True)
    asleep.start()
    time.sleep(0.02)
    give()  # the doorbell wakes the sleeper, which finds the word written
    asleep.join(20.0)
    assert got == [True] and _pending(links[0].read) == 0
    os.set_blocking(links[0].read, True)
    give()
    give()  # two tokens in one link: the ring is broken
    assert not receiver.wait()


def test_a_sleeping_taker_takes_only_the_token_alone_on_the_spot(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A taker that may not spin (no core free for it) takes the token as its doorbell's
    read returns; what else the read may return is still told apart: a nudge (its
    predecessor saw a core free) is no token but a spin for it, a stop with the token a
    stop, two tokens a broken ring."""
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: False)
    receiver = ring.Receiver(links[0].read, 1e-3, page, 0)
    give = ring.Giver(links[0].write, page, 0)
    give()
    assert receiver.wait()  # the token alone
    os.write(links[0].write, ring.WAKE)
    threading.Timer(0.05, give).start()
    assert receiver.wait()  # the nudge woke it; the token came after its spin
    assert _word(page, 0, ring.NUDGED) == 0 and _pending(links[0].read) == 0
    os.set_blocking(links[0].read, True)
    give()
    os.write(links[0].write, ring.STOP)
    assert not receiver.wait()
    receiver.taker.taken = _word(page, 0, ring.TURN)
    page.words[ring.STOPPED] = 0
    give()
    give()
    assert not receiver.wait()  # two tokens: the ring is broken
    receiver.close()


def test_a_nudge_that_finds_its_taker_spinning_keeps_it_spinning(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A nudge spares the doorbell of a taker that spins already; where that was its
    short eager spin, the taker spins on for the token (its nudged budget, 60 s here)
    instead of going to sleep when the eager one runs out (the nudge was lost before: the
    member slept, and a ring test that waited for its spin failed now and then)."""
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: True)
    receiver = ring.Receiver(links[0].read, 60.0, page, 0)
    assert receiver.taker is not None
    receiver.taker.recent = 50_000_000  # an eager spin of 0.1 s
    nudge = ring.Nudge(links[0].write, 60.0, page, 0)
    got: list[bool] = []
    waiting = threading.Thread(target=lambda: got.append(receiver.wait()), daemon=True)
    spinning = lambda: _word(page, 0, ring.SPINNING) == 1  # noqa: E731
    try:
        waiting.start()
        wait_for(spinning, "the eager spin", every=0.001)
        seen = time.monotonic()
        nudge()  # it spins: the NUDGED word, and no doorbell
        assert _word(page, 0, ring.NUDGED) == 1
        while time.monotonic() < seen + 0.4:  # 4 times the eager budget: still spinning
            assert spinning()
            time.sleep(0.01)
        ring.Giver(links[0].write, page, 0)()
        waiting.join(20.0)
        assert got == [True] and not spinning() and _pending(links[0].read) == 0
        assert _word(page, 0, ring.NUDGED) == 0  # spent with the token it was for
    finally:
        if waiting.is_alive():  # failed: stop it (the STOPPED word ends a spin)
            page.words[ring.STOPPED] = 1
            os.write(links[0].write, ring.STOP)
            waiting.join(20.0)
        nudge.close()
        receiver.close()


def test_a_stop_ends_a_spinning_member_long_before_its_spin(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A member nudged (WAKE) spins for its token, here for up to 60 s; its coordinator
    going away (the control pipe closes) sets its STOPPED word, which ends the spin at
    once: nothing spins for ever, nor for its whole budget once told."""
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: True)
    receiver = ring.Receiver(links[0].read, 60.0, page, 0)
    nudge = ring.Nudge(links[0].write, 60.0, page, 0)
    control, coordinator = os.pipe()
    got: list[bool] = []
    waiting = threading.Thread(target=lambda: got.append(receiver.wait()), daemon=True)
    try:
        waiting.start()
        nudge()
        wait_for(
            lambda: _word(page, 0, ring.SPINNING) == 1, "the nudged member spinning", every=0.001
        )
        ring.stop_on_control(control, links[0].write, page, 0)
        began = time.monotonic()
        os.close(coordinator)
        waiting.join(20.0)
        assert got == [False] and time.monotonic() - began < 20.0
        assert _word(page, 0, ring.STOPPED) == 1 and _word(page, 0, ring.SPINNING) == 0
    finally:
        nudge.close()
        receiver.close()
        os.close(control)


def test_a_spinning_coordinator_sees_a_death_and_its_deadline(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The coordinator spins as soon as it waits (eager: a core is free), up to 60 s
    here; the watcher's STOPPED word ends that spin at the cycle's deadline and when an
    answer pipe closes."""
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: True)
    two = ring.Page.create(2)
    assert two is not None
    read, write = os.pipe()
    back = ring.Return(links[1].read, (read,), 60.0, two, 1)
    try:
        assert back.taker is not None and back.taker.budget() > 0  # eager
        ring.Giver(links[1].write, two, 1)()
        assert back.wait(10.0) == links[1].read
        began = time.monotonic()
        assert back.wait(0.05) is None  # the deadline, not the 60 s spin
        assert time.monotonic() - began < 20.0
        threading.Timer(0.05, os.close, (write,)).start()
        assert back.wait(30.0) == read  # a process died: its answer pipe closed
        write = -1
    finally:
        back.close()
        two.close()
        os.close(read)
        if write >= 0:
            os.close(write)


def test_an_eager_spin_follows_what_recent_waits_took(
    links: list[ring.Link], page: ring.Page, monkeypatch: pytest.MonkeyPatch
) -> None:
    free = [True]
    monkeypatch.setattr(ring.Load, "core_free", lambda self, spinners=0: free[0])
    taker = ring.Taker(links[0].read, page, 0, 2e-3, eager=True)
    try:
        taker.recent = 10_000  # short waits: the floor
        assert taker.budget() == ring.SPIN_FLOOR_NS
        taker.recent = 300_000  # twice that, within the 2 ms cap
        assert taker.budget() == 600_000
        taker.recent = 1_500_000  # a wait that long is better slept
        assert taker.budget() == 0
        taker.recent, free[0], taker.load.left = 10_000, False, 0  # no core free: no spin
        assert taker.budget() == 0
    finally:
        taker.close()
    assert ring.Taker(links[1].read, page, 1, 2e-3, eager=False).budget() == 0
