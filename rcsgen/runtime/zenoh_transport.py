"""Zenoh transport: a node's mirror, where it listens and connects -> records moved between hosts.

One Zenoh session per node (a process, or an observer: a lockstep coordinator, a launcher, an
operator's console), peer to peer with no broker. Data arrives on Zenoh's threads and waits
in an inbox; `pull` applies it to the local block in arrival order, in the node's own thread,
at a cycle boundary, so a module never sees a record change under it. `push` sends what the
node wrote (`transport.Mirror`). Each node declares a liveliness token
`rcs/<system>/<hash-8>/_alive/<node>`: when a process's token goes away (killed, or its link
silent for the lease) every node marks it DEAD and its dependants go to their safe state;
when any node joins, the others send it everything they wrote, and a node of another layout
is named and ignored. Zenoh's shared-memory transport is switched off, so nothing is left
in /dev/shm. `zenoh` (the `eclipse-zenoh` package) is imported only here, only when a node
is made: a system run on shared memory needs nothing but Python.
"""

from __future__ import annotations

import json
import queue
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from struct import Struct
from typing import Any

from .block import Block
from .contract import ABSENT, DEAD, PERF_INTERVAL, STOPPED
from .loop import STEP, Process, Stop
from .transport import (
    ALIVE,
    HEARD_KEY,
    PLAINTEXT,
    PUSH_KEY,
    STEP_KEY,
    Mirror,
    Security,
    TransportError,
    prefix,
    reads,
)

FULL = "full"  # the last part of a full push's key: everything its sender wrote

DEFAULT_PORT = 7447  # Zenoh's own default
# A free-running process that cycles faster than this sends its records at most this often:
# the latest value of each (what a reader on one machine sees, reading once a cycle), so a
# `--fast` process does not flood the network. Paced at the miner's 0.1 s, every cycle goes.
MIN_PUSH_INTERVAL = 0.005
# The modules' performance buffers (cycle counts and times, for people: ctl, the monitor)
# go with a push at most every contract.PERF_INTERVAL, as often as they are published (and
# with the last and a full push). At the miner's 0.1 s every push carries them; a lockstep
# or `--fast` process sends its controllers' records every cycle and these ~10 times a second.
# A free-running push may be dropped where the network is congested (a busy host's queue
# full: it never blocks a controller), and a record that does not change again would then
# never arrive (a DONE its supervisor waits for, for ever). So a free-running node sends
# every record it wrote again at least this often: what a dropped push lost is repaired
# within it (a receiver takes a repeat as the value it has, and counts nothing).
REFRESH_INTERVAL = 1.0
WARN_EVERY = 10.0  # seconds: at most one line a peer about its malformed pushes
# A lockstep cycle's step requests travel as one message from the coordinator (every
# process's, each after this: the process's index in the layout and the request's size);
# each process takes its own. One put a cycle, not one per process, and each process
# receives one message, not every other process's request too (all subscribe to the
# whole prefix).
STEP_ENTRY = Struct("<HH")


@dataclass(frozen=True)
class Options:
    """Where a node listens and whom it connects to (`tcp/HOST:PORT` endpoints), and how
    long a silent link lives (`lease_ms`: a partitioned host is reported after it)."""

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    lease_ms: int = 1000
    security: Security = PLAINTEXT  # its own TLS and authentication (a deployment's)


def config_json(options: Options) -> dict[str, Any]:
    """The Zenoh configuration of a node, as JSON: a peer, no multicast scouting (hosts are
    named, nothing is discovered behind the user's back), gossip over the links it has (so
    peers that connect to one node find each other), no shared-memory transport.

    With `options.security`: TLS only (no plaintext link can be opened), both ends showing a
    certificate the one trusted authority signed (mutual TLS; the authority is the trust,
    so host names are not checked against certificates), and Zenoh's user/password
    authentication, the password read from its file now (never on a command line)."""
    config: dict[str, Any] = {
        "mode": "peer",
        "listen/endpoints": list(options.listen),
        "connect/endpoints": list(options.connect),
        "scouting/multicast/enabled": False,
        "transport/shared_memory/enabled": False,
        "transport/link/tx/lease": options.lease_ms,
    }
    secure = options.security
    if secure.tls:
        tls = "transport/link/tls/"
        config["transport/link/protocols"] = ["tls"]
        config[tls + "root_ca_certificate"] = secure.root_ca
        for side in ("listen", "connect"):
            config[f"{tls}{side}_private_key"] = secure.key
            config[f"{tls}{side}_certificate"] = secure.certificate
        config[tls + "enable_mtls"] = True
        config[tls + "verify_name_on_connect"] = False
    if secure.auth:
        try:
            with open(secure.password_file, encoding="utf-8") as file:
                password = file.readline().rstrip("\r\n")
        except (OSError, UnicodeDecodeError) as error:
            raise TransportError(f"cannot read {secure.password_file}: {error}") from None
        config["transport/auth/usrpwd/user"] = secure.user
        config["transport/auth/usrpwd/password"] = password
        config["transport/auth/usrpwd/dictionary_file"] = secure.users_file
    return config


def _zenoh() -> Any:
    try:
        import zenoh
    except ImportError:
        raise TransportError(
            "the zenoh transport needs the eclipse-zenoh package: pip install 'rcsgen[zenoh]' "
            "(or eclipse-zenoh==1.10.2)"
        ) from None
    return zenoh


class ZenohTransport:
    """A node on the Zenoh network: its subscriptions feed its mirror, its token tells the
    others it is alive. `process` is the process it runs (None for an observer, which
    receives everything). `block_when_congested` (lockstep) makes a put wait rather than
    drop when the network is congested; a free-running controller never waits."""

    def __init__(
        self,
        mirror: Mirror,
        options: Options,
        process: str | None = None,
        modules: tuple[str, ...] = (),
        block_when_congested: bool = False,
        log: Callable[[str], None] | None = None,
    ) -> None:
        zenoh = _zenoh()
        self.mirror, self.process = mirror, process
        layout = mirror.layout
        self.prefix = prefix(layout)
        self.node = process if process is not None else f"_observer_{mirror.epoch:016x}"
        # What Zenoh's threads delivered, in order: a SimpleQueue (put and a timed get in C:
        # no Python Condition on either side of the hand-off). What wakes a waiting node
        # (`wait`, `hear`) is a token in `_bell`, put after each message that may let it go
        # on: every message, but while `eager` is False (a lockstep process waiting for its
        # step) not another node's push, which waits in the inbox to be applied with the
        # step (one wake-up a cycle fewer for each other process's push); and while a wait
        # names the heartbeats it needs (`awaited`: a lockstep process's records to read, a
        # coordinator's answers), only the push after which every one of them has been
        # sent (`beats`: the highest heartbeat each process has sent, as the ends of its
        # pushes say, kept by Zenoh's thread; only ever raised, so a push's data mistaken
        # for a beat can wake the thread early, which then waits again, and never keep it
        # from waking).
        self.inbox: queue.SimpleQueue[tuple[str, str, bytes]] = queue.SimpleQueue()
        self._bell: queue.SimpleQueue[None] = queue.SimpleQueue()
        self.eager = True
        self.awaited: Mapping[str, int] | None = None
        self.beats: dict[str, int] = {}
        self.steps: deque[bytes] = deque()
        self.lost: set[str] = set()
        self.joined: set[str] = set()
        # senders whose full push (everything they wrote, sent when this node joined) arrived
        self.synced: set[str] = set()
        self.republish = False
        # The start-up barrier's: the nodes whose pushes reached this one, and (a launcher's
        # node) whom each process says it has heard. A process tells its own whenever it
        # hears someone new, and again to a node that joins (`push`).
        self.heard: set[str] = set()
        self.hears: dict[str, frozenset[str]] = {}
        self._tell = False
        self.log = log or (lambda text: print(text, file=sys.stderr))
        self._warned: set[str] = set()
        # What came from each peer (the sender of a push): applied, late, malformed
        self.peers: dict[str, dict[str, int]] = {}
        self._told: dict[str, float] = {}  # when a peer's malformed push was last said
        # The process's control-record counters (contract.NETWORK_FIELDS), kept current
        self.report: dict[str, int] | None = None
        self._congestion = (
            zenoh.CongestionControl.BLOCK if block_when_congested else zenoh.CongestionControl.DROP
        )
        self._lockstep, self._next_push, self._next_perf = block_when_congested, 0.0, 0.0
        self._next_refresh = time.monotonic() + REFRESH_INTERVAL
        self._zenoh = zenoh
        config = zenoh.Config()
        for key, value in config_json(options).items():
            config.insert_json5(key, json.dumps(value))
        try:
            self.session = zenoh.open(config)
        except zenoh.ZError as error:  # e.g. a --listen port in use; not where in zenoh
            raise TransportError(f"zenoh: {str(error).split(' at /')[0]}") from None
        self._declared: list[Any] = []
        self._cut = len(self.prefix) + 1
        self._steps = f"{STEP_KEY}/"
        # each process's index in the layout: its entry in a cycle's step message
        self._index = {name: i for i, name in enumerate(layout.PROCESSES)}
        self._me = self._index.get(process) if process is not None else None
        # a request's size: the segment, then the heartbeat each process must have reached
        self._request_size = STEP.size + 8 * len(self._index)
        self._pushes = f"{PUSH_KEY}/"
        self._heard = f"{HEARD_KEY}/"
        # Messages go through publishers declared once, not express: Zenoh batches only
        # under back-pressure (an idle link sends at once, so a hop is no slower), and an
        # express put makes the sender wait for the link on every message (a push stream
        # sent 25-30 % fewer records a second: bench/prototypes/zenoh_rate_ab.py).
        self._publisher: Any = None
        self._stepper: Any = None
        # One subscriber for the system's whole prefix, filtered here by what this node
        # reads: one zenoh-python thread then delivers everything in the order each sender
        # sent it (a push whole, a coordinator's records before its step request). Several
        # subscribers would each have a thread of their own, with no order between them.
        self._wanted = _matcher(reads(layout, process, modules))
        self._declared.append(
            self.session.declare_subscriber(
                f"{self.prefix}/**", self._sample, allowed_origin=zenoh.Locality.REMOTE
            )
        )
        self._declared.append(
            self.session.liveliness().declare_subscriber(
                f"rcs/{layout.SYSTEM}/*/{ALIVE}/*", self._token, history=True
            )
        )
        self.token = self.session.liveliness().declare_token(f"{self.prefix}/{ALIVE}/{self.node}")

    # ------------------------------------------------------------ Zenoh's threads

    def _sample(self, sample: Any) -> None:
        key = str(sample.key_expr)[self._cut :]
        if key.startswith(self._pushes):
            payload = sample.payload.to_bytes()
            beats, beat = self.beats, self.mirror.last_beat(payload)
            if beat is not None and beat[1] > beats.get(beat[0], -1):
                beats[beat[0]] = beat[1]
            self.inbox.put(("push", key, payload))
            awaited = self.awaited  # (the token after the message: see `pull`)
            if self.eager and (awaited is None or _met(beats, awaited)):
                self._bell.put(None)
        elif key.startswith(self._steps):
            if self._me is not None:  # (an observer runs no step)
                self._arrived("step", key[len(self._steps) :], sample.payload.to_bytes())
        elif key.startswith(self._heard):
            self._arrived("heard", key[len(self._heard) :], sample.payload.to_bytes())

    def _arrived(self, kind: str, key: str, payload: bytes) -> None:
        self.inbox.put((kind, key, payload))
        self._bell.put(None)  # (the token after the message: see `pull`)

    def _token(self, sample: Any) -> None:
        parts = str(sample.key_expr).split("/")  # rcs, system, hash-8, _alive, node
        if len(parts) != 5:
            return
        kind = "join" if sample.kind == self._zenoh.SampleKind.PUT else "leave"
        if parts[2] != self.prefix.split("/")[2]:
            kind = "foreign-" + kind
        self._arrived(kind, parts[4], parts[2].encode())

    # ------------------------------------------------------------ the node's thread

    def pull(self) -> None:
        """Apply everything that arrived, in order: records into the block, step requests
        to `steps`, tokens to liveness (a lost process is marked DEAD)."""
        bell, inbox, arrived = self._bell, self.inbox, []
        # The tokens first, then the messages (this thread is the only reader of both): a
        # token put after this is for a message taken now or later, so none is lost (at
        # worst one wake-up finds nothing new).
        while not bell.empty():
            bell.get_nowait()
        while not inbox.empty():
            arrived.append(inbox.get_nowait())
        mirror = self.mirror
        for kind, key, payload in arrived:
            if kind == "push":  # a sender's cycle, whole: applied whole, in the order sent
                sender, _, full = key[len(self._pushes) :].partition("/")
                if sender not in self.heard:
                    self.heard.add(sender)
                    self._tell = True
                whole = self._push(sender, payload)
                if full == FULL and whole:
                    self.synced.add(sender)
            elif kind == "step":
                self._step(key, payload)
            elif kind == "heard":  # a process's names, comma-separated (others ignored)
                names = payload.decode("utf-8", "replace").split(",")
                self.hears[key] = frozenset(n for n in names if n in mirror.layout.PROCESSES)
            elif kind == "join":
                self.republish = True  # a node joined: send it what we wrote
                self.joined.add(key)
                if key in mirror.layout.PROCESSES:
                    self.lost.discard(key)
                    mirror.counters.joined.append(key)
            elif kind == "leave":
                self.joined.discard(key)
                self.synced.discard(key)
                if key in mirror.layout.PROCESSES and key != self.process:
                    self.lost.add(key)
                    if mirror.state(key) != STOPPED:  # it did not say goodbye: lost
                        mirror.mark_dead(key)
            elif kind == "foreign-join":
                mirror.counters.foreign += 1
                if key not in self._warned:
                    self._warned.add(key)
                    self.log(
                        f"{self.node}: node {key} of {mirror.layout.SYSTEM} runs layout "
                        f"{payload.decode()}, not {self.prefix.split('/')[2]}: ignored "
                        "(rebuild every host from the same specs)"
                    )

    def _push(self, sender: str, payload: bytes) -> bool:
        """One push from `sender`: its records applied whole, or refused whole (malformed,
        said in one line at most every WARN_EVERY seconds per peer); counted per peer.
        Whether it was whole."""
        mirror, counters = self.mirror, self.mirror.counters
        before = (counters.applied, counters.late, counters.malformed)
        records = mirror.unpack(payload)
        for record, message in records or ():
            if self._wanted(record):
                mirror.apply(record, message)
        peer = self._peer(sender)
        after = (counters.applied, counters.late, counters.malformed)
        for name, old, new in zip(peer, before, after, strict=True):
            peer[name] += new - old
        if records is None:
            self._malformed(
                sender,
                f"push from {sender} ({len(payload)} bytes, not whole records of layout "
                f"{mirror.layout.LAYOUT_HASH[:8]}): refused whole, nothing applied",
            )
        self._reported()
        return records is not None

    def _step(self, sender: str, payload: bytes) -> None:
        """A coordinator's step message: this process's request in it to `steps`; one that
        is not whole entries of this layout's size is refused whole, counted for `sender`."""
        at, total, size, found = 0, len(payload), self._request_size, None
        while at < total:
            if at + STEP_ENTRY.size > total:
                break
            index, length = STEP_ENTRY.unpack_from(payload, at)
            start = at + STEP_ENTRY.size
            at = start + length
            if length != size or at > total:
                break
            if index == self._me:
                found = payload[start:at]
        else:
            if found is not None:
                self.steps.append(found)
            return
        self.mirror.counters.malformed += 1
        self._peer(sender)["malformed"] += 1
        self._reported()
        self._malformed(
            sender,
            f"step request from {sender} ({total} bytes, not whole requests of layout "
            f"{self.mirror.layout.LAYOUT_HASH[:8]}): refused, no step run",
        )

    def _peer(self, sender: str) -> dict[str, int]:
        """What came from `sender` so far: applied, late, malformed."""
        return self.peers.setdefault(sender, dict.fromkeys(("applied", "late", "malformed"), 0))

    def _malformed(self, sender: str, what: str) -> None:
        """Say a malformed message from `sender` (`what` it was), at most once every
        WARN_EVERY seconds per peer."""
        now = time.monotonic()
        if now - self._told.get(sender, -WARN_EVERY) >= WARN_EVERY:
            self._told[sender] = now
            count = self.peers[sender]["malformed"]
            self.log(f"{self.node}: a malformed {what} ({count} from {sender} so far)")

    def _reported(self) -> None:
        """The process's control-record counters, as the mirror's now."""
        if self.report is not None:
            counters, report = self.mirror.counters, self.report
            report["net_applied"], report["net_late"] = counters.applied, counters.late
            report["net_malformed"] = counters.malformed

    def push(self, last: bool = False) -> None:
        """Send every record this node wrote since the last push (everything it wrote, when
        a node joined since). The `last` push, as the node leaves, waits rather than drops
        when the network is congested: its STOPPED must arrive before its token goes."""
        now = time.monotonic()
        if not (last or self.republish or self._lockstep):
            if now < self._next_push:  # faster than the network should carry: coalesce
                return
            self._next_push = now + MIN_PUSH_INTERVAL
        everything, self.republish = self.republish, False
        if (self._tell or everything) and self.process is not None:
            self._tell = False  # whom it has heard: the start-up barrier's (launcher.py)
            self.session.put(
                f"{self.prefix}/{HEARD_KEY}/{self.node}",
                ",".join(sorted(self.heard)).encode(),
                congestion_control=self._zenoh.CongestionControl.BLOCK,
            )
        slow = last or now >= self._next_perf
        if slow:
            self._next_perf = now + PERF_INTERVAL
        refresh = not self._lockstep and now >= self._next_refresh  # (REFRESH_INTERVAL)
        if refresh:
            self._next_refresh = now + REFRESH_INTERVAL
        messages = self.mirror.changed(everything or refresh, slow or refresh)
        if not messages:
            return
        payload = self.mirror.pack(messages)
        key = f"{self.prefix}/{PUSH_KEY}/{self.node}"
        if last or everything:  # never dropped; a full push says so in its key
            block = self._zenoh.CongestionControl.BLOCK
            self.session.put(
                key + (f"/{FULL}" if everything else ""),
                payload,
                congestion_control=block,
            )
        else:
            if self._publisher is None:
                self._publisher = self.session.declare_publisher(
                    key, congestion_control=self._congestion
                )
            self._publisher.put(payload)
        self.mirror.counters.sent += len(messages)

    def hear(
        self, peers: list[str], stopped: Callable[[], bool], beat: Callable[[], None]
    ) -> list[str]:
        """Before a process's first cycle: pull and push (calling `beat` before each push:
        the process is alive, its heartbeat still 0) until a push from each of `peers` has
        arrived here. The peers not heard, when `stopped()` ended the wait first (else none)."""
        while True:
            self.pull()
            missing = [peer for peer in peers if peer not in self.heard]
            if not missing or stopped():
                if not missing:
                    self.push()  # whom it heard, at once: the barrier waits for it
                return missing
            beat()
            self.push()
            try:  # the next message wakes this thread at once; a stop within 0.1 s
                self._bell.get(timeout=0.1)
            except queue.Empty:
                pass

    def send_steps(self, requests: Mapping[str, bytes]) -> None:
        """A lockstep cycle's requests (`step_request`) to the processes named, as one
        message (after this node's own records: same link, in order)."""
        index = self._index
        payload = b"".join(
            STEP_ENTRY.pack(index[name], len(request)) + request
            for name, request in requests.items()
        )
        if self._stepper is None:
            self._stepper = self.session.declare_publisher(
                f"{self.prefix}/{STEP_KEY}/{self.node}",
                congestion_control=self._zenoh.CongestionControl.BLOCK,
            )
        self._stepper.put(payload)

    def wait(
        self,
        ready: Callable[[], bool],
        timeout: float | None,
        awaited: Mapping[str, int] | None = None,
    ) -> bool:
        """Pull until `ready()` holds (True) or `timeout` seconds pass (False). With
        `awaited` (process -> heartbeat: what `ready` waits for, besides liveness), a push
        wakes this thread only once every process named has sent its heartbeat (a lockstep
        cycle's records in: not woken by each other push before them)."""
        self.awaited = awaited
        try:
            return self._wait(ready, timeout)
        finally:
            self.awaited = None

    def _wait(self, ready: Callable[[], bool], timeout: float | None) -> bool:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            self.pull()
            if self.republish:  # a node joined while we wait: it needs what we wrote
                self.push()
            if ready():
                return True
            left = None if deadline is None else deadline - time.monotonic()
            if left is not None and left <= 0:
                return False
            try:  # the next message wakes this thread at once (at most 0.2 s: a stop)
                self._bell.get(timeout=0.2 if left is None else min(left, 0.2))
            except queue.Empty:
                pass

    def close(self) -> None:
        """Leave: send what is left (a process's STOPPED), then the token goes (the others
        see this node gone), then the session."""
        if not self.session.is_closed():
            self.push(last=True)
            self.token.undeclare()
            self.session.close()


class Attached:
    """An observer's private block, kept current by a thread that mirrors what the system's
    processes send and sends what is written here: an operator's console on another host."""

    def __init__(self, layout: Any, options: Options, wait: float = 5.0) -> None:
        self.block = Block(layout)
        self.net = ZenohTransport(Mirror(layout, self.block), options)
        names, mirror = list(layout.PROCESSES), self.net.mirror
        self.net.wait(lambda: all(mirror.state(n) != ABSENT for n in names), wait)
        if all(mirror.state(n) == ABSENT for n in names):
            self.net.close()
            self.block.close()
            where = " ".join(options.connect)
            raise TransportError(
                f"no process of {layout.SYSTEM} (layout {layout.LAYOUT_HASH[:8]}) answered "
                f"through {where} within {wait:g} s: is it running with --transport zenoh?"
            )
        # Before the first read: every running process's full push, so that what is shown
        # is whole (a process's regular push can come before the one that answers our join).
        synced = self.net.synced
        self.net.wait(
            lambda: all(
                n in synced for n in names if mirror.state(n) not in (ABSENT, DEAD, STOPPED)
            ),
            wait,
        )
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.net.pull()
            self.net.push()
            self._stop.wait(0.01)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()
        self.net.push()
        self.net.close()
        self.block.close()


# ---------------------------------------------------------------- lockstep


def step_request(first: int, last: int, end: bool, required: list[int]) -> bytes:
    """A lockstep step: the segment, then the heartbeat each process (layout order) must have
    reached, as the receiver mirrors it, before the segment runs."""
    return STEP.pack(b"s", first, last, end) + Struct(f"<{len(required)}Q").pack(*required)


def serve(
    process: Process, transport: ZenohTransport, stop: Stop, timeout: float = 30.0
) -> str | None:
    """Run `process` in lockstep for a coordinator on the network: one segment per request,
    after the records of the cycles the request names have arrived; after each, push what
    it wrote (its control record last: the coordinator's answer). Returns None when stopped,
    or why it gave up."""
    names = list(process.layout.PROCESSES)
    mirror = transport.mirror
    transport.push()  # the INITs to our roots, the first beat
    try:
        while not stop.requested:
            transport.eager = False  # until a step comes, another node's push can wait
            stepped = transport.wait(lambda: bool(transport.steps) or stop.requested, None)
            transport.eager = True
            if not stepped:
                continue
            if stop.requested:
                break
            request = transport.steps.popleft()
            op, first, last, end = STEP.unpack_from(request, 0)
            if op != b"s":
                break
            required = Struct(f"<{len(names)}Q").unpack_from(request, STEP.size)
            me = process.plan.name
            others = [(n, r) for n, r in zip(names, required, strict=True) if n != me]
            if not transport.wait(_reached(mirror, others), timeout, dict(others)):
                missing = [n for n, r in others if mirror.heartbeat(n) < r]
                return f"the records of {missing} did not arrive within {timeout:g} s"
            process.run_modules(first, last)
            if end:
                process.cycle += 1
                process.beat()
            transport.push()
    finally:
        process.beat(STOPPED)  # sent as the caller closes the transport
    return None


def _met(beats: Mapping[str, int], awaited: Mapping[str, int]) -> bool:
    """Whether every process `awaited` names has sent (`beats`) the heartbeat it needs."""
    return all(beats.get(name, -1) >= beat for name, beat in awaited.items())


def _reached(mirror: Mirror, others: list[tuple[str, int]]) -> Callable[[], bool]:
    return lambda: all(mirror.heartbeat(n) >= r for n, r in others)


def _matcher(patterns: list[str]) -> Callable[[str], bool]:
    """Whether a key suffix matches one of `patterns` (Zenoh's `*`: one chunk; `**`: any)."""
    import re

    def chunk(text: str) -> str:
        return "[^/]+" if text == "*" else ".*" if text == "**" else re.escape(text)

    parts = ["/".join(chunk(c) for c in pattern.split("/")) for pattern in patterns]
    regex = re.compile("(?:" + "|".join(parts) + ")" + "\\Z")
    known: dict[str, bool] = {}  # a layout has a few hundred keys: each matched once

    def matches(key: str) -> bool:
        found = known.get(key)
        if found is None:
            found = known[key] = regex.match(key) is not None
        return found

    return matches
