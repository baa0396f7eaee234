"""Ring: the lockstep token, passed process to process (N+1 hand-offs a system cycle).

A lockstep coordinator used to send each process a request and wait for its answer: 2N
scheduler wake-ups a cycle, each one a context switch through the coordinator. Here the
coordinator and the processes form a ring in the execution order: the coordinator hands the
token to the first process, each process runs its cycle and hands it to the next, the last
hands it back. Each link is an eventfd (Linux) or, where there is none, a pipe: handing the
token is writing 8 bytes into the next one's link, taking it is reading them.

A process waits for the token in a blocking read of its link (one system call, the
cheapest wake-up: poll(2) then read costs ~3 µs more a hand-off on a loaded 2-core
machine); a thread of its own blocks on its control pipe and, when the coordinator writes
there or goes away (the pipe closes), puts STOP into the link, which ends the read.

A blocked process is woken by the scheduler, and where the core it wakes on was idle that
is the slow part of a hand-off: a virtual machine's idle CPU is halted, and waking it costs
25-50 µs (the quiet 2-core host measured 30 µs a hand-off, the same ring 4 µs while other
work kept both CPUs busy). So the member that takes the token nudges the next one (WAKE
into its link, `Nudge`): woken while the token holder works, the next one spins until the
token comes (at most `spin` seconds), on the core the holder leaves free, and takes it
without a wake-up. Only one member spins at a time (the holder's successor), so the ring
needs two cores, not a core per member; and a member nudges only while a core is free for
the spinner (the kernel's count of runnable tasks, /proc/loadavg, looked at every
`Nudge.CHECK` nudges): on a busy machine a spinner would take the time of the holder, or
of someone else's work. The coordinator waits for the token's return in a blocking read
too; a thread of its own polls every process's answer pipe (it closes when the process
dies) and the cycle's deadline, and wakes the read with STOP: a process killed holding
the token is seen at once, one stopped when the token has not come back within the
coordinator's timeout. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
from collections.abc import Sequence
from typing import NamedTuple

WORD = struct.Struct("=Q")  # an eventfd takes 8 bytes (a pipe too: one token, one write)
# What a link carries: an eventfd adds what is written until it is read, so each kind has
# its own bits: a read tells a token, nudges and a stop apart however they came together.
TOKEN_MASK = (1 << 20) - 1  # the tokens (exactly one is a token; more is a broken ring)
TOKEN = WORD.pack(1)
WAKE_VALUE = 1 << 20
WAKE = WORD.pack(WAKE_VALUE)  # the token is near: spin for it (Nudge)
WAKE_MASK = TOKEN_MASK * WAKE_VALUE  # the nudges
STOP_VALUE = 1 << 40
STOP = WORD.pack(STOP_VALUE)  # into a link: stop, or wake (a token added to it is a stop)
SPIN = 2e-3  # the longest a nudged member spins for the token (then it blocks)
READABLE = select.POLLIN | select.POLLHUP | select.POLLERR


class Link(NamedTuple):
    """One hand-off: the descriptor its receiver reads, the one its sender writes (the same
    eventfd, or the two ends of a pipe)."""

    read: int
    write: int


def new_links(count: int) -> list[Link]:
    """`count` links, non-blocking, not inherited (the launcher passes each process its
    own two)."""
    links = []
    for _ in range(count):
        if hasattr(os, "eventfd"):
            fd = os.eventfd(0, os.EFD_NONBLOCK | os.EFD_CLOEXEC)
            links.append(Link(fd, fd))
        else:  # pragma: no cover - not Linux
            read, write = os.pipe()
            os.set_blocking(read, False)
            links.append(Link(read, write))
    return links


def close_links(links: Sequence[Link]) -> None:
    for fd in sorted({fd for link in links for fd in (link.read, link.write)}):
        try:
            os.close(fd)
        except OSError:
            pass


def cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1  # pragma: no cover - not Linux


def default_spin() -> float:
    """Spin where the machine has two cores (one for the token holder, one for its nudged
    successor: one member spins at a time); whether one is free is looked at as it runs."""
    return SPIN if cores() >= 2 else 0.0


class Load:
    """Whether a core is free for a spinner now: the kernel's count of runnable tasks (the
    fourth field of /proc/loadavg, `running/total`; the reader and the token holder among
    them) against the cores. Where there is no /proc/loadavg, never (nobody spins)."""

    def __init__(self) -> None:
        try:
            self.fd = os.open("/proc/loadavg", os.O_RDONLY | os.O_CLOEXEC)
        except OSError:  # pragma: no cover - not Linux
            self.fd = -1
        self.cores = cores()

    def core_free(self) -> bool:
        if self.fd < 0:  # pragma: no cover - not Linux
            return False
        try:
            fields = os.pread(self.fd, 128, 0).split()
            return int(fields[3].split(b"/")[0]) <= self.cores
        except (OSError, IndexError, ValueError):  # pragma: no cover - an odd kernel
            return False

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


class Nudge:
    """A member's nudge to the next one as it takes the token (WAKE into the next one's
    link: it spins for the token instead of being woken by the scheduler when it comes).
    Only where `spin` > 0, and only while a core is free for the spinner (`Load`, looked at
    every CHECK nudges: a read of /proc/loadavg costs ~7 µs, a nudge a write of ~1 µs)."""

    CHECK = 8

    def __init__(self, fd: int, spin: float) -> None:
        self.fd, self.count, self.free = fd, 0, False
        self.load = Load() if spin > 0 else None

    def __call__(self) -> None:
        load = self.load
        if load is None:
            return
        if not self.count % self.CHECK:
            self.free = load.core_free()
        self.count += 1
        if self.free:
            os.write(self.fd, WAKE)

    def close(self) -> None:
        if self.load is not None:
            self.load.close()


def spin_for(poller: select.poll, spin_ns: int) -> None:
    """Spin until the link polled is readable, at most `spin_ns` (a nudged waiter),
    yielding each turn: a spinner that shares a CPU with the token holder lets it run."""
    end = time.monotonic_ns() + spin_ns
    while not poller.poll(0) and time.monotonic_ns() < end:
        os.sched_yield()


def give(fd: int) -> None:
    """Hand the token on."""
    os.write(fd, TOKEN)


class Return:
    """The coordinator's end of the ring: the token's return read blocking on `fd` (the
    cheapest wake-up: poll(2) there costs ~3 µs a cycle more); a thread of its own polls
    the processes' answer pipes (`watch`: readable when a process dies) and the cycle's
    deadline, and wakes the read with STOP. `close` ends the thread: before the launcher
    closes any descriptor it watches."""

    def __init__(self, fd: int, watch: Sequence[int], spin: float = 0.0) -> None:
        os.set_blocking(fd, True)  # only the coordinator reads the last link
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        self.deadline = float("inf")  # of the cycle under way (monotonic seconds)
        self.dead: int | None = None  # the answer pipe that closed
        self.poller = select.poll()
        self.poller.register(fd, READABLE)
        self._quit_read, self._quit_write = os.pipe()
        watched = select.poll()
        for each in (*watch, self._quit_read):
            watched.register(each, READABLE)
        self._thread = threading.Thread(
            target=self._watch, args=(watched,), name="ring-return", daemon=True
        )
        self._thread.start()

    def wait(self, timeout: float) -> int | None:
        """`fd` once the token is back; the answer pipe of a process that died (it has
        priority over the token); None when it has not come back within `timeout`. Nudged
        by the last process (WAKE), it spins for the token where it may."""
        self.deadline = time.monotonic() + timeout
        while True:
            data = os.read(self.fd, WORD.size)
            if self.dead is not None:
                return self.dead
            value = WORD.unpack(data)[0] if len(data) == WORD.size else 0
            if value & TOKEN_MASK:
                self.deadline = float("inf")
                return self.fd
            if time.monotonic() >= self.deadline:
                return None
            if value & WAKE_MASK and self.spin_ns:
                spin_for(self.poller, self.spin_ns)
            # a nudge, or a STOP for a cycle that ended as the watcher woke: the token is
            # still to come

    def _watch(self, watched: select.poll) -> None:
        fired = float("nan")
        while True:
            deadline = self.deadline
            left = deadline - time.monotonic()
            if left <= 0 and deadline != fired:  # the cycle under way is late: wake the read
                fired = deadline
                os.write(self.fd, STOP)
            ms = 250 if left <= 0 or left > 0.25 else max(1, int(left * 1000) + 1)
            for ready, events in watched.poll(ms):
                if ready == self._quit_read or events & select.POLLNVAL:
                    return
                self.dead = ready  # a process's answer pipe closed (or spoke): it is lost
                os.write(self.fd, STOP)
                return

    def close(self) -> None:
        """End the watching thread (idempotent)."""
        if self._quit_write >= 0:
            os.write(self._quit_write, b"q")
            self._thread.join(5.0)
            os.close(self._quit_write)
            os.close(self._quit_read)
            self._quit_write = -1


class Receiver:
    """A process's end of its link: blocking reads (nudged, a spin first)."""

    def __init__(self, fd: int, spin: float = 0.0) -> None:
        os.set_blocking(fd, True)  # only this process reads its link
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        self.poller = select.poll()
        self.poller.register(fd, READABLE)

    def wait(self) -> bool:
        """True with the token; False when told to stop (STOP, or the ring broken: a short
        read, more than one token). Nudged (WAKE alone), it spins for the token first."""
        while True:
            data = os.read(self.fd, WORD.size)
            if len(data) != WORD.size:
                return False
            value = WORD.unpack(data)[0]
            tokens = value & TOKEN_MASK
            if value >= STOP_VALUE or tokens > 1:
                return False
            if tokens:
                return True
            if self.spin_ns:
                spin_for(self.poller, self.spin_ns)


def stop_on_control(control: int, link: int) -> threading.Thread:
    """A thread that puts STOP into `link` once anything comes on `control` (b"q") or it
    closes (the coordinator stops this process, or is gone)."""

    def watch() -> None:
        try:
            os.read(control, 1)
        except OSError:
            pass
        try:
            os.write(link, STOP)
        except OSError:  # pragma: no cover - the process is closing its link already
            pass

    thread = threading.Thread(target=watch, name="ring-control", daemon=True)
    thread.start()
    return thread
