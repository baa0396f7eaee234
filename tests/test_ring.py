"""The lockstep token ring's parts (rcsgen/runtime/ring.py), in one process: the hand-off,
the stop through a control pipe, the coordinator's wait that sees a death or times out.
The ring across real processes, with a process killed or stopped holding the token, is in
tests/test_failsafe.py."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator

import pytest

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


def test_spinning_only_where_every_member_has_a_core() -> None:
    assert ring.default_spin(ring.cores()) == 0.0
    assert ring.default_spin(ring.cores() - 1) == ring.SPIN
