"""Ring: the lockstep token, passed process to process (N+1 hand-offs a system cycle).

A lockstep coordinator used to send each process a request and wait for its answer: 2N
scheduler wake-ups a cycle, each one a context switch through the coordinator. Here the
coordinator and the processes form a ring in the execution order: the coordinator hands the
token to the first process, each process runs its cycle and hands it to the next, the last
hands it back. Each link is an eventfd (Linux) or, where there is none, a pipe.

The token is a turn word (`Page`: a small shared mapping, a memfd the launcher passes to
every member, a cache line per link): handing it on is writing the count of tokens handed
into the next one's link, then 8 bytes into its eventfd (the doorbell); taking it is seeing
that count go up, by spinning on the word (a load and a sched_yield a turn) for a bounded
budget, or asleep in a read of the eventfd, and reading the doorbell either way (after a
spin the giver's write is a µs behind its word: that read does not sleep). One write and
one read a hand-off, as without the page, so a ring that sleeps costs what it did; one
that spins takes the token without a wake-up. No memory ordering is asked of Python: the
doorbell is written after the word, so a taker woken by it finds the word written.
Where there is no memfd, the token is the eventfd's 8 bytes alone (`give`).

Who spins. A blocked process is woken by the scheduler, and where the core it wakes on was
idle that is the slow part of a hand-off: a virtual machine's idle CPU is halted, and
waking it costs 25-50 µs; a spinning taker takes the token in a few µs. So each taker
spins as soon as it waits (`Taker.budget`: twice what its recent waits took, at least
SPIN_FLOOR_NS, none where that is more than `spin`: a paced ring sleeps), and the member
that takes the token nudges the next one unless it spins already (WAKE into its link,
`Nudge`: it then spins up to `spin`). Both only while a core is free for the spinner or
nothing but the ring is runnable (`Load`: the kernel's count of runnable tasks against the
cores and against the ring's holder and spinners, looked at every CHECK waits, every
BUSY_CHECK while no core was free): on a machine busy with other work a spinner takes the
time of the holder or of someone else, and the ring sleeps and pays the scheduler.
Spinners yield each turn, so on two cores the holder keeps one and the spinners share the
other.

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
# a slot's words: tokens handed in, told to stop, spinning, nudged (for the token to come)
TURN, STOPPED, SPINNING, NUDGED = 0, 2, 3, 4
CHECK = 32  # a spinner-to-be looks at the load every CHECK waits (Load: ~7 µs a look)
BUSY_CHECK = 4 * CHECK  # ... and, where it saw no core free, every BUSY_CHECK waits
SPIN_FLOOR_NS = 50_000  # an eager spin's least budget (a wake-up costs 25-50 µs here)


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
    """The ring's turn words: a small shared mapping (memfd) with a slot per link, four
    words in it: TURN, the tokens handed into the link so far (written by its giver
    only), STOPPED, 1 once its taker is told to stop, SPINNING, 1 while its taker spins
    (what `Load` counts as the ring's own, and a nudge spares the doorbell of), NUDGED,
    1 from a nudge to the token's taking (a taker whose short eager spin runs out spins
    on where it was nudged meanwhile). A taker spins on TURN (a load, no system call) and
    reads its eventfd when the token has come or its spin ran out; the giver writes TURN,
    then the eventfd."""

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
    """Hands the token into one link: a write of its turn word, then of its eventfd (the
    doorbell); without a page, the eventfd alone (`give`)."""

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
        self.left, self.free = 0, False  # calls until the next look; what it last saw

    def looked(self, page: Page | None) -> bool:
        """Whether a core is free, as last seen: looked at again every CHECK calls where
        one was, every BUSY_CHECK where none was (a look is a read of /proc/loadavg, 1.3-7 µs:
        a busy machine, where nobody spins, pays it a quarter as often; a ring stops
        spinning within CHECK waits of the machine getting busy)."""
        self.left -= 1
        if self.left < 0:
            self.free = self.core_free(page.spinners() if page is not None else 0)
            self.left = CHECK if self.free else BUSY_CHECK
        return self.free

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
    Only where `spin` > 0, only while a core is free for the spinner (`Load.looked`: a
    read of /proc/loadavg costs 1.3-7 µs, a nudge a write of ~1 µs), and with a page only
    where the next one is not spinning already."""

    def __init__(
        self,
        fd: int,
        spin: float,
        page: Page | None = None,
        link: int = 0,
        dedicated: bool = False,
    ) -> None:
        self.fd = fd
        self.load = Load(dedicated) if spin > 0 else None
        self.page, self.words = page, page.words if page is not None else None
        self.at = link * SLOT_WORDS

    def __call__(self) -> None:
        load = self.load
        if load is None or not load.looked(self.page):
            return
        words = self.words
        if words is None:
            os.write(self.fd, WAKE)
            return
        words[self.at + NUDGED] = 1  # a spinner spins on for the token (Taker.take)
        if not words[self.at + SPINNING]:
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
    sched_yield a turn: a spinner that shares a CPU with the holder lets it run), then
    reads its eventfd: at once where the spin saw the token (the doorbell is a µs behind
    the word), asleep where the spin ran out. It spins when nudged (WAKE, up to `spin`)
    and, `eager`, as soon as it waits: for twice what its recent waits took, at least
    SPIN_FLOOR_NS, not at all where that is more than `spin` (a wait that long is better
    slept: a paced ring), and only while a core is free for it or nothing but the ring
    runs (`Load.looked`; while it says no, a wait costs nothing more than the read)."""

    def __init__(
        self,
        fd: int,
        page: Page,
        link: int,
        spin: float,
        eager: bool = True,
        dedicated: bool = False,
    ) -> None:
        os.set_blocking(fd, True)  # only this end reads the link
        self.fd, self.page, self.words, self.at = fd, page, page.words, link * SLOT_WORDS
        self.taken, self.spin_ns = 0, int(spin * 1e9)
        self.load = Load(dedicated) if eager and spin > 0 else None
        self.recent = SPIN_FLOOR_NS  # a running mean of recent waits (ns)

    def budget(self) -> int:
        """How long to spin as a wait begins (ns): eager only."""
        load = self.load
        if load is None or not load.looked(self.page):
            return 0
        want = max(SPIN_FLOOR_NS, 2 * self.recent)
        return want if want <= self.spin_ns else 0

    def take(self) -> tuple[int, bool]:
        """(the turn word, stopped): the word once a token's doorbell is read (the
        caller's to check: one more than it took is the token, more is a broken ring; 0
        where none came), stopped when told to (STOPPED, or STOP in the eventfd).
        Where it does not spin (a busy machine, a paced ring) the wait is the read, and
        the one token alone, not told to stop, is taken on the spot: on a busy machine
        every hand-off comes this way, and the taker has just woken on a cold cache,
        where each line of Python touched costs."""
        words, at = self.words, self.at
        spin = self.budget()
        if spin or words[at + STOPPED]:
            return self._wait(spin, None)
        data = os.read(self.fd, WORD.size)
        if data == TOKEN and not words[at + STOPPED]:
            if words[at + NUDGED]:  # a nudge that found it asleep: spent with this token
                words[at + NUDGED] = 0
            return int(words[at]), False
        return self._wait(0, data)

    def _wait(self, spin: int, data: bytes | None) -> tuple[int, bool]:
        """`take`'s general case: a spin of `spin` ns first, or the doorbell's `data`
        that `take` read already (a stop, a nudge, more than one token); a nudge alone
        makes it spin for the token."""
        words, at, want = self.words, self.at, self.taken + 1
        began = start = time.monotonic_ns() if spin else 0  # how long waits take: spinning
        nudged = False
        while True:
            if data is None:
                if spin and words[at] < want:
                    nudged = self._spin(want, began + spin, nudged)
                if words[at + STOPPED] and words[at] < want:
                    return 0, True
                data = os.read(self.fd, WORD.size)  # the doorbell (a µs away after a spin)
            value = WORD.unpack(data)[0] if len(data) == WORD.size else STOP_VALUE
            if value & TOKEN_MASK or value >= STOP_VALUE:
                break
            spin, began = self.spin_ns, time.monotonic_ns()  # a nudge: the token is near
            nudged, data = True, None
        if value & TOKEN_MASK:
            words[at + NUDGED] = 0  # this cycle's nudge is spent
        if start:
            self.recent = (3 * self.recent + time.monotonic_ns() - start) // 4
        stopped = value >= STOP_VALUE or bool(words[at + STOPPED])
        return (int(words[at]) if value & TOKEN_MASK else 0), stopped

    def _spin(self, want: int, end: int, nudged: bool) -> bool:
        """Spin on the turn word until the token `want` or a stop, or until `end` (ns):
        on for a nudged budget where nudged meanwhile and not before (no doorbell then);
        whether it was nudged."""
        words, at = self.words, self.at
        words[at + SPINNING] = 1
        while words[at] < want and not words[at + STOPPED]:
            if time.monotonic_ns() >= end:
                if nudged or not words[at + NUDGED]:
                    break
                # nudged as it spun (no doorbell then): spin on for the token
                nudged, end = True, time.monotonic_ns() + self.spin_ns
            os.sched_yield()
        words[at + SPINNING] = 0
        return nudged

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
            turn, _ = taker.take()
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
            turn, stopped = taker.take()
            if stopped or turn != taker.taken + 1:
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
