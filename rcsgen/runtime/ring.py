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
there or goes away (the pipe closes), puts STOP into the link, which ends the read. Where
the machine has a core for every member of the ring, a waiter spins `spin` seconds first
(the next one runs on a core of its own, and the token comes back sooner than the
scheduler could wake a sleeper). The coordinator waits in poll(2), watching every
process's answer pipe too (it closes when the process dies): a process killed holding the
token is seen at once, one stopped when the token has not come back within the
coordinator's timeout. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import os
import select
import struct
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

WORD = struct.Struct("=Q")  # an eventfd takes 8 bytes (a pipe too: one token, one write)
TOKEN = WORD.pack(1)
STOP = WORD.pack(1 << 40)  # into a process's link: stop (a token added to it reads != 1 too)
SPIN = 50e-6  # seconds a waiter spins before it blocks, where every member has a core
READABLE = select.POLLIN | select.POLLHUP | select.POLLERR


@dataclass(frozen=True)
class Link:
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


def default_spin(members: int) -> float:
    """Spin only where every member of the ring (the processes and the coordinator) has a
    core: on fewer, a spinner takes the core the token holder needs."""
    return SPIN if cores() > members else 0.0


def give(fd: int) -> None:
    """Hand the token on."""
    os.write(fd, TOKEN)


class Waiter:
    """Waits for the token on `fd`, or for any of `watch` to become readable."""

    def __init__(self, fd: int, watch: Sequence[int], spin: float = 0.0) -> None:
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        self.poller = select.poll()
        for each in (fd, *watch):
            self.poller.register(each, READABLE)

    def take(self) -> bool:
        """The token, if it is here (without blocking)."""
        try:
            data = os.read(self.fd, len(TOKEN))
        except BlockingIOError:
            return False
        if not data:  # pragma: no cover - a pipe link whose writers are all gone
            raise EOFError("the ring is broken")
        return True

    def wait(self, timeout: float | None) -> int | None:
        """`fd` once the token is taken; the watched descriptor that became readable first
        (it has priority over the token: a death or a stop is never missed); None when
        nothing came within `timeout` seconds (None: no limit)."""
        if self.spin_ns:  # (without, poll(2) returns at once if the token is back)
            end = time.monotonic_ns() + self.spin_ns
            while time.monotonic_ns() < end:
                if self.take():
                    return self.fd
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = -1 if deadline is None else max(0, int((deadline - time.monotonic()) * 1000))
            ready = [fd for fd, _ in self.poller.poll(left)]
            others = [fd for fd in ready if fd != self.fd]
            if others:
                return others[0]
            if ready and self.take():
                return self.fd
            if deadline is not None and time.monotonic() >= deadline:
                return None


class Receiver:
    """A process's end of its link: blocking reads (after a spin where cores are free)."""

    def __init__(self, fd: int, spin: float = 0.0) -> None:
        os.set_blocking(fd, True)  # only this process reads its link
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        self.poller = select.poll()
        self.poller.register(fd, READABLE)

    def wait(self) -> bool:
        """True with the token; False when told to stop (STOP, or the ring broken)."""
        if self.spin_ns:
            end = time.monotonic_ns() + self.spin_ns
            while not self.poller.poll(0) and time.monotonic_ns() < end:
                pass
        data = os.read(self.fd, WORD.size)
        return len(data) == WORD.size and WORD.unpack(data)[0] == 1


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
