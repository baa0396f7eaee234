"""Ring: the lockstep token, passed process to process (N+1 hand-offs a system cycle).

A lockstep coordinator used to send each process a request and wait for its answer: 2N
scheduler wake-ups a cycle, each one a context switch through the coordinator. Here the
coordinator and the processes form a ring in the execution order: the coordinator hands the
token to the first process, each process runs its cycle and hands it to the next, the last
hands it back. Each link is an eventfd (Linux) or, where there is none, a pipe.

The token is a turn word (`Page`: a small shared mapping, a memfd the launcher passes to
every member, a cache line per link): handing it on is writing the count of tokens handed
into the next one's link, taking it is seeing that count go up. A taker spins on its word
(a load and a sched_yield a turn, no other system call) for a bounded budget, and sleeps
in a read of its eventfd when the budget runs out; the giver writes the eventfd only when
the taker sleeps, and the race between the two is closed both ways round (the taker sets
its SLEEPING word, fences, looks at its turn word again and only then blocks; the giver
writes the turn word, fences, then looks at SLEEPING). Where there is no memfd, the token
is an 8-byte write into the eventfd itself (`give`) and a taker blocks in its read.

Who spins. A blocked process is woken by the scheduler, and where the core it wakes on was
idle that is the slow part of a hand-off: a virtual machine's idle CPU is halted, and
waking it costs 25-50 µs; a spinning taker takes the token in a few µs. So each taker
spins as soon as it waits (`Taker.budget`: twice what its recent waits took, at least
SPIN_FLOOR_NS, none where that is more than `spin`: a paced ring sleeps), and the member
that takes the token nudges the next one if it sleeps (WAKE into its link, `Nudge`: it
then spins up to `spin`). Both only while a core is free for the spinner or nothing but
the ring is runnable (`Load`: the kernel's count of runnable tasks against the cores and
against the ring's holder and spinners, looked at every CHECK_NS): on a machine busy
with other work a spinner takes the time of the holder or of someone else, and the ring
sleeps and pays the scheduler. Spinners yield each turn, so on two cores the holder keeps
one and the spinners share the other.

Faults. A process waits for the token until told to stop: a thread of its own blocks on
its control pipe and, when the coordinator writes there or goes away (the pipe closes),
sets its STOPPED word (which ends a spin) and puts STOP into its link (which ends a sleep).
The coordinator waits for the token's return the same way; a thread of its own polls
every process's answer pipe (it closes when the process dies) and the cycle's deadline,
and wakes the wait with STOPPED and STOP: a process killed holding the token is seen at
once, one stopped when the token has not come back within the coordinator's timeout.
Nothing spins for longer than `spin` without looking at its STOPPED word, which is looked
at every turn. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import mmap
import os
import platform
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
# The turn words (`Page`): a cache line per link, four words in it
SLOT_WORDS = 8  # 64 bytes: two links' words never share a cache line
# a slot's words: tokens handed in, taker asleep, told to stop, taker spinning
TURN, SLEEPING, STOPPED, SPINNING = 0, 1, 2, 3
CHECK_NS = 1_000_000  # how often a spinner-to-be looks at the load (Load: ~7 µs a look)
SPIN_FLOOR_NS = 50_000  # an eager spin's least budget (a wake-up costs 25-50 µs here)
DOORBELL_MS = 50  # a sleeper looks at its turn word at least this often (a missed ring)
# Where the fence is a full barrier (x86: an atomic read-modify-write orders a store before
# a later load), a sleeper blocks in its eventfd read (one system call); elsewhere it polls,
# at most DOORBELL_MS at a time, and looks at its turn word again
STRONG = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686")
# The fence between a store and a later load of the turn words: an uncontended lock taken
# and given back is an atomic read-modify-write (x86: a locked instruction, a full barrier;
# ~0.5 µs from Python). Where that is not known (not STRONG), a sleeper's bounded wait
# (DOORBELL_MS) finds its token even if a ring was missed: late, never lost.
_FENCE = threading.Lock()


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


class Page:
    """The ring's turn words: a small shared mapping (memfd) with a slot per link, three
    words in it: TURN, the tokens handed into the link so far (written by its giver only),
    SLEEPING, 1 while its taker is (about to be) blocked in its eventfd (written by the
    taker only), STOPPED, 1 once its taker is told to stop, SPINNING, 1 while its taker
    spins (what `Load` counts as the ring's own). A taker spins on TURN, cheaply
    (a load, no system call), and blocks on its eventfd only when its spin runs out; the
    giver rings that eventfd only when SLEEPING says so. The race is closed both ways
    round: the taker sets SLEEPING, fences, looks at TURN again and only then blocks; the
    giver writes TURN, fences, then looks at SLEEPING."""

    def __init__(self, fd: int) -> None:
        """The page on `fd` (a ring member: the fd the launcher passed it)."""
        size = os.fstat(fd).st_size
        self.fd, self.links = fd, size // (SLOT_WORDS * 8)
        self.map = mmap.mmap(fd, size)
        self.words = memoryview(self.map).cast("Q")

    @classmethod
    def create(cls, links: int) -> Page | None:
        """A new page for `links` links (its fd not inherited: the launcher passes it on);
        None where there is no memfd (the ring then spins on its eventfds)."""
        if not hasattr(os, "memfd_create"):  # pragma: no cover - not Linux
            return None
        fd = os.memfd_create("rcs-ring", os.MFD_CLOEXEC)
        os.ftruncate(fd, links * SLOT_WORDS * 8)
        return cls(fd)

    def spinners(self) -> int:
        """The ring's members spinning now."""
        words, step = self.words, SLOT_WORDS
        return sum(words[at + SPINNING] for at in range(0, self.links * step, step))

    def close(self) -> None:
        """Unmap and close (idempotent)."""
        if self.fd >= 0:
            self.words.release()
            self.map.close()
            os.close(self.fd)
            self.fd = -1


class Giver:
    """Hands the token into one link: a write of its turn word, and the eventfd rung only
    where the taker sleeps; without a page, the eventfd written (`give`)."""

    def __init__(self, fd: int, page: Page | None = None, link: int = 0) -> None:
        self.fd, self.sent = fd, 0
        self.words = page.words if page is not None else None
        self.at = link * SLOT_WORDS

    def __call__(self) -> None:
        words = self.words
        if words is None:
            os.write(self.fd, TOKEN)
            return
        self.sent += 1
        words[self.at + TURN] = self.sent
        _FENCE.acquire()  # the fence: the turn word written before SLEEPING is read
        _FENCE.release()
        if words[self.at + SLEEPING]:
            os.write(self.fd, TOKEN)


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
    them) against the cores, or nothing runnable but the ring itself (the reader, the
    holder and the ring's `spinners`, `Page.spinners`), whose spinners yield to the
    holder and to each other.
    Where there is no /proc/loadavg, never (nobody spins). `dedicated`: the ring has its
    cores to itself (isolated CPUs, or a benchmark under SCHED_FIFO): always, unread."""

    def __init__(self, dedicated: bool = False) -> None:
        self.dedicated = dedicated
        try:
            self.fd = os.open("/proc/loadavg", os.O_RDONLY | os.O_CLOEXEC)
        except OSError:  # pragma: no cover - not Linux
            self.fd = -1
        self.cores = cores()

    def core_free(self, spinners: int = 0) -> bool:
        if self.dedicated:
            return True
        if self.fd < 0:  # pragma: no cover - not Linux
            return False
        try:
            fields = os.pread(self.fd, 128, 0).split()
            running = int(fields[3].split(b"/")[0])
            return running <= self.cores or running <= spinners + 2
        except (OSError, IndexError, ValueError):  # pragma: no cover - an odd kernel
            return False

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


class Nudge:
    """A member's nudge to the next one as it takes the token (WAKE into the next one's
    link: it spins for the token instead of being woken by the scheduler when it comes).
    Only where `spin` > 0, only while a core is free for the spinner (`Load`, looked at
    every CHECK_NS: a read of /proc/loadavg costs ~7 µs, a nudge a write of ~1 µs), and
    with a page only where the next one sleeps (one spinning already needs none)."""

    def __init__(
        self,
        fd: int,
        spin: float,
        page: Page | None = None,
        link: int = 0,
        dedicated: bool = False,
    ) -> None:
        self.fd, self.next_check, self.free = fd, 0, False
        self.load = Load(dedicated) if spin > 0 else None
        self.page, self.words = page, page.words if page is not None else None
        self.at = link * SLOT_WORDS

    def __call__(self) -> None:
        load = self.load
        if load is None:
            return
        now = time.monotonic_ns()
        if now >= self.next_check:
            self.free = load.core_free(self.page.spinners() if self.page is not None else 0)
            self.next_check = now + CHECK_NS
        if not self.free:
            return
        if self.words is None or self.words[self.at + SLEEPING]:
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
    """Hand the token on (a ring without a page)."""
    os.write(fd, TOKEN)


class Taker:
    """A link's taking end on a page: it spins on its turn word (a load and a
    sched_yield a turn: a spinner that shares a CPU with the holder lets it run), and
    where the spin runs out it sleeps on its eventfd (SLEEPING set, fenced, the word
    looked at again, then a blocking read; not STRONG, a poll bounded by DOORBELL_MS and a
    read). It spins when nudged (WAKE, up to `spin`) and, `eager`, as soon as it waits:
    for twice what its recent waits took, at least SPIN_FLOOR_NS, not at all where that
    is more than `spin` (a wait that long is better slept: a paced ring), and only while a
    core is free for it or nothing but the ring runs (`Load`, every CHECK_NS)."""

    def __init__(
        self,
        fd: int,
        page: Page,
        link: int,
        spin: float,
        eager: bool = True,
        dedicated: bool = False,
    ) -> None:
        os.set_blocking(fd, STRONG)  # the eventfd is a doorbell here
        self.fd, self.page, self.words, self.at = fd, page, page.words, link * SLOT_WORDS
        self.taken, self.spin_ns = 0, int(spin * 1e9)
        self.load = Load(dedicated) if eager and spin > 0 else None
        self.next_check, self.free = 0, False
        self.recent = SPIN_FLOOR_NS  # a running mean of recent waits (ns)
        self.poller = select.poll()
        self.poller.register(fd, READABLE)

    def budget(self, now: int) -> int:
        """How long to spin as a wait begins at `now` (monotonic ns): eager only."""
        load = self.load
        if load is None:
            return 0
        if now >= self.next_check:
            self.free = load.core_free(self.page.spinners())
            self.next_check = now + CHECK_NS
        want = max(SPIN_FLOOR_NS, 2 * self.recent)
        return want if self.free and want <= self.spin_ns else 0

    def take(self, ms: int = DOORBELL_MS) -> int:
        """The turn word once a token is in it (the caller's to check: one more than it
        took is the token, more is a broken ring), or 0 when told to stop (STOPPED, STOP
        in the eventfd); a sleep polls at most `ms` at a time (then looks again)."""
        words, at, want = self.words, self.at, self.taken + 1
        if words[at] >= want:  # there already: no spin, no sleep
            return 0 if words[at + STOPPED] else int(words[at])
        began = start = time.monotonic_ns()
        spin = self.budget(began)
        while True:
            if spin:
                end = began + spin
                words[at + SPINNING] = 1
                while words[at] < want and not words[at + STOPPED]:
                    if time.monotonic_ns() >= end:
                        break
                    os.sched_yield()
                words[at + SPINNING] = 0
            if words[at] >= want or words[at + STOPPED]:
                break
            words[at + SLEEPING] = 1
            _FENCE.acquire()  # the fence: SLEEPING written before the turn word is read
            _FENCE.release()
            if words[at] >= want or words[at + STOPPED]:
                words[at + SLEEPING] = 0
                break
            if not STRONG:
                self.poller.poll(ms)
            value = self.drain()
            words[at + SLEEPING] = 0
            if value >= STOP_VALUE:
                return 0
            spin = self.spin_ns if value & WAKE_MASK else 0
            began = time.monotonic_ns()
        if self.load is not None:  # eager: how long waits take
            self.recent = (3 * self.recent + time.monotonic_ns() - start) // 4
        return 0 if words[at + STOPPED] else int(words[at])

    def drain(self) -> int:
        """What the eventfd holds, taken out (STRONG: waiting for it; else 0 when
        nothing)."""
        try:
            data = os.read(self.fd, WORD.size)
        except BlockingIOError:
            return 0
        return WORD.unpack(data)[0] if len(data) == WORD.size else STOP_VALUE

    def close(self) -> None:
        if self.load is not None:
            self.load.close()


class Return:
    """The coordinator's end of the ring: the token's return read blocking on `fd` (the
    cheapest wake-up: poll(2) there costs ~3 µs a cycle more), or with a page its turn
    word (`Taker`); a thread of its own polls the processes' answer pipes (`watch`:
    readable when a process dies) and the cycle's deadline, and wakes the read with STOP
    (with a page also the STOPPED word, which ends a spin). `close` ends the thread:
    before the launcher closes any descriptor it watches."""

    def __init__(
        self,
        fd: int,
        watch: Sequence[int],
        spin: float = 0.0,
        page: Page | None = None,
        link: int = 0,
        dedicated: bool = False,
    ) -> None:
        os.set_blocking(fd, True)  # only the coordinator reads the last link
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        taker = Taker(fd, page, link, spin, dedicated=dedicated) if page is not None else None
        self.taker = taker
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
        if self.taker is not None:
            return self._take()
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

    def _take(self) -> int | None:
        taker = self.taker
        assert taker is not None
        while True:
            turn = taker.take()
            if self.dead is not None:
                return self.dead
            if turn > taker.taken:
                taker.taken = turn
                self.deadline = float("inf")
                return self.fd
            if time.monotonic() >= self.deadline:
                return None
            taker.words[taker.at + STOPPED] = 0  # a stop for a cycle that ended: wait on

    def _watch(self, watched: select.poll) -> None:
        fired = float("nan")
        while True:
            deadline = self.deadline
            left = deadline - time.monotonic()
            if left <= 0 and deadline != fired:  # the cycle under way is late: wake the read
                fired = deadline
                self._stop()
            ms = 250 if left <= 0 or left > 0.25 else max(1, int(left * 1000) + 1)
            for ready, events in watched.poll(ms):
                if ready == self._quit_read or events & select.POLLNVAL:
                    return
                self.dead = ready  # a process's answer pipe closed (or spoke): it is lost
                self._stop()
                return

    def _stop(self) -> None:
        if self.taker is not None:
            self.taker.words[self.taker.at + STOPPED] = 1
        os.write(self.fd, STOP)

    def close(self) -> None:
        """End the watching thread (idempotent)."""
        if self._quit_write >= 0:
            os.write(self._quit_write, b"q")
            self._thread.join(5.0)
            os.close(self._quit_write)
            os.close(self._quit_read)
            self._quit_write = -1
            if self.taker is not None:
                self.taker.close()


class Receiver:
    """A process's end of its link: blocking reads (nudged, a spin first), or with a page
    its turn word (`Taker`)."""

    def __init__(
        self,
        fd: int,
        spin: float = 0.0,
        page: Page | None = None,
        link: int = 0,
        dedicated: bool = False,
    ) -> None:
        os.set_blocking(fd, True)  # only this process reads its link
        self.fd, self.spin_ns = fd, int(spin * 1e9)
        taker = Taker(fd, page, link, spin, dedicated=dedicated) if page is not None else None
        self.taker = taker
        self.poller = select.poll()
        self.poller.register(fd, READABLE)

    def wait(self) -> bool:
        """True with the token; False when told to stop (STOP, or the ring broken: a short
        read, more than one token). Nudged (WAKE alone), it spins for the token first."""
        taker = self.taker
        if taker is not None:
            turn = taker.take()
            if turn != taker.taken + 1:
                return False
            taker.taken = turn
            return True
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

    def close(self) -> None:
        if self.taker is not None:
            self.taker.close()


def stop_on_control(
    control: int, link: int, page: Page | None = None, at: int = 0
) -> threading.Thread:
    """A thread that puts STOP into `link` once anything comes on `control` (b"q") or it
    closes (the coordinator stops this process, or is gone); with a page, STOPPED into
    slot `at` first (which ends a spin)."""

    def watch() -> None:
        try:
            os.read(control, 1)
        except OSError:
            pass
        try:
            if page is not None:
                page.words[at * SLOT_WORDS + STOPPED] = 1
            os.write(link, STOP)
        except (OSError, ValueError):  # pragma: no cover - the process is closing its link
            pass

    thread = threading.Thread(target=watch, name="ring-control", daemon=True)
    thread.start()
    return thread
