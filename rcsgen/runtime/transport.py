"""Transport: a layout, a local block and who this node is -> the records it sends and mirrors.

Every process keeps a local block. With the shared-memory transport (`Local`) the block is
shared by every process of the host and nothing moves. With a network transport (Zenoh,
`zenoh_transport.py`), each node has a block of its own, and a `Mirror` decides what moves:
after each cycle it sends every record whose sequence word this node changed (each record
whole, after the sender's epoch, with its sequence word; a cycle's records packed into one
push), and it writes what arrives into the local block through the seqlock, dropping (and
counting) a record that is not newer than the last one applied from the same sender. A
record is named `<owner>/<buffer>` and a node's pushes travel on
`rcs/<system>/<layout-hash-8>/_push/<node>`, so systems built from other specs never
exchange a byte. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from operator import itemgetter
from struct import Struct
from types import ModuleType
from typing import NamedTuple, Protocol

from .block import Block
from .contract import DEAD, PROCESS, SEQ, Record, next_odd, shared
from .override import mirrored

# Before a record's bytes: the sender's incarnation (random per start).
EPOCH = Struct("<Q")
HEAD = Struct("<QQ")  # a message's head: the sender's epoch, the record's sequence word
# A push (what a node wrote in a cycle) travels as one message: each record as its index in
# the layout's records (by offset: the same on every node of one layout hash), then its
# message (EPOCH and the record's bytes, whose size the layout gives).
INDEX = Struct("<H")
SEQ_RUN = 16  # Mirror.changed compares the sequence words this many at a time
WORLD_OWNER = "_world"
OVERRIDE_OWNER = "_override"  # a world field's override record: `_override/<field>`
PROCESS_OWNER = "_process"
ALIVE = "_alive"  # liveliness tokens: rcs/<system>/<hash-8>/_alive/<node>
STEP_KEY = "_step"  # lockstep requests to a process: rcs/<system>/<hash-8>/_step/<process>
PUSH_KEY = "_push"  # a node's pushes: rcs/<system>/<hash-8>/_push/<node>
# whom a process has heard (the senders of the pushes that reached it), for its launcher's
# start-up barrier: rcs/<system>/<hash-8>/_heard/<process>, the names comma-separated
HEARD_KEY = "_heard"


@shared
class TransportError(Exception):
    """A transport that cannot start: zenoh missing, an endpoint that cannot be used."""


class Transport(Protocol):
    """What a process's loop needs of a transport: `pull` before a cycle mirrors what
    arrived into the local block; `push` after it sends what this process wrote; `close`
    sends what is left (the process's STOPPED) and leaves."""

    def pull(self) -> None: ...

    def push(self) -> None: ...

    def close(self) -> None: ...


class Local:
    """The shared-memory transport: every process of the host shares the block; nothing moves."""

    def pull(self) -> None:
        return None

    def push(self) -> None:
        return None

    def close(self) -> None:
        return None


def prefix(layout: ModuleType) -> str:
    """The key prefix of a system built from one layout: `rcs/<system>/<layout-hash-8>`."""
    return f"rcs/{layout.SYSTEM}/{layout.LAYOUT_HASH[:8]}"


def records(layout: ModuleType) -> dict[str, Record]:
    """Every record of the layout by its key suffix (`pp/status`, `_world/pose_x`,
    `_process/pc1/control`), in layout order."""
    found: dict[str, Record] = {}
    for name in layout.PROCESSES:
        found[f"{PROCESS_OWNER}/{name}/control"] = layout.PROCESSES[name]
        pacing = getattr(layout, "PACING", {})
        if name in pacing:
            found[f"{PROCESS_OWNER}/{name}/pace"] = pacing[name]
    for module in layout.COMMAND_IN:
        found[f"{module}/command"] = layout.COMMAND_IN[module]
        found[f"{module}/status"] = layout.STATUS_OUT[module]
        if "/" not in module:  # an operator module's channel shares its mode and perf
            found[f"{module}/mode"] = layout.MODE_IN[module]
            found[f"{module}/perf"] = layout.PERFORMANCE[module]
    for operator in getattr(layout, "OPERATORS", {}):
        found[f"{operator}/mode"] = layout.MODE_IN[operator]
        found[f"{operator}/perf"] = layout.PERFORMANCE[operator]
    for channel, record in getattr(layout, "ANSWERS", {}).items():  # `op/fx/answer`
        found[f"{channel}/answer"] = record
    for name, record in layout.WORLD.items():
        found[f"{WORLD_OWNER}/{name}"] = record
    for name, record in getattr(layout, "OVERRIDE", {}).items():
        found[f"{OVERRIDE_OWNER}/{name}"] = record
    for module, record in getattr(layout, "TIME_IN_STATE", {}).items():  # `pl/time`
        found[f"{module}/time"] = record
    return found


def reads(layout: ModuleType, process: str | None, modules: tuple[str, ...] = ()) -> list[str]:
    """The key suffixes (Zenoh key expressions) a node subscribes to: everything for an
    observer (`process` None: a coordinator, a launcher, an operator's console); for a
    process, its modules' commands and modes, the status of each subordinate that runs
    elsewhere, every world field (the layout does not say who reads which) and its override
    (a latch or force made on any host holds on the host that writes the field), every
    control record (liveness) and its own pacing record."""
    if process is None:
        return ["**"]
    wanted = [f"{m}/command" for m in modules] + [f"{m}/mode" for m in modules]
    for module in modules:  # an operator module reads its channels' commands and answers
        for channel in getattr(layout, "OPERATORS", {}).get(module, ()):
            wanted += [f"{channel}/command", f"{channel}/answer"]
    for module in modules:
        for sub in layout.SUBORDINATES.get(module, ()):
            if layout.PLACEMENT.get(sub) != process:
                wanted.append(f"{sub}/status")
    wanted += [f"{WORLD_OWNER}/*", f"{OVERRIDE_OWNER}/*"]
    wanted += [f"{PROCESS_OWNER}/*/control", f"{PROCESS_OWNER}/{process}/pace"]
    return wanted


class Counters:
    """What a mirror did: messages sent and applied, dropped as late or out of order,
    from a node of another layout, and liveness events. (A plain class: no process's start
    imports `dataclasses`, loop.py says why.)"""

    def __init__(self) -> None:
        self.sent = self.applied = self.late = self.foreign = self.malformed = 0
        self.lost: list[str] = []  # processes whose token went away
        self.joined: list[str] = []


class Mirror:
    """The records a node sends and those it mirrors, over one local block (no network).

    `changed()` gives the messages of every record this node wrote since it last sent or
    mirrored it; `apply(suffix, payload)` writes a message into the block if it is newer
    than the last one applied from the same sender. A control record's `beat_ns` is the
    receiver's clock when it arrives (monotonic clocks of two hosts are not comparable),
    so the runtime's heartbeat timeout measures silence on the receiving host."""

    def __init__(self, layout: ModuleType, block: Block, node: str | None = None) -> None:
        self.layout, self.block, self.node = layout, block, node
        self.records = records(layout)
        self.epoch = int.from_bytes(os.urandom(8), "little") or 1
        # What every node's new block holds (layout.initialise): anything else in this block
        # was written here, or before a restart, and is sent at the first push.
        fresh = memoryview(bytearray(layout.SIZE))
        layout.initialise(fresh)
        # Every record's sequence word in one unpack (the bytes between them skipped).
        ordered = sorted(self.records, key=lambda k: self.records[k].offset)
        self._keys = tuple(ordered)
        self._index = {key: i for i, key in enumerate(ordered)}
        self._start = self.records[ordered[0]].offset
        layout_format, at = "<", self._start
        for key in ordered:
            offset = self.records[key].offset
            layout_format += (f"{offset - at}x" if offset > at else "") + "Q"
            at = offset + SEQ.size
        self._seqs = Struct(layout_format)
        # each record's message size (its sender's epoch and the record), in the same order
        self._sizes = tuple(EPOCH.size + self.records[k].struct.size for k in ordered)
        # each record's bytes in the block, in the same order
        self._spans = tuple(
            (self.records[k].offset, self.records[k].offset + self.records[k].struct.size)
            for k in ordered
        )
        self.known = list(self._seqs.unpack_from(fresh, self._start))  # as last sent/mirrored
        # A module's performance buffer changes every cycle it runs (its cycle count and
        # times) and is read by people (ctl, the monitor), never by a controller: the
        # pushes of a fast process carry it only when `slow` is asked (zenoh_transport).
        self._fast = tuple(not key.endswith("/perf") for key in ordered)
        # A process looks, after each cycle, only at the records it writes (the layout's
        # WRITES, but the performance buffers: those wait for a slow push), their sequence
        # words in one unpack; the whole block every slow push (an operator's tool on its
        # host may write any record there). An observer (no WRITES of its own) writes
        # anything: it looks at everything every push.
        writes = getattr(layout, "WRITES", {}).get(node)
        self._mine = None if writes is None else self._written(writes)
        self._every = tuple(range(len(ordered)))
        self.owned: set[str] = set()  # keys whose current value this node wrote
        self.last: dict[str, tuple[int, int]] = {}  # key -> (sender epoch, its seq word)
        self.counters = Counters()
        # each record's index, offset and message size, by key (what `apply` looks up once)
        self._where = {
            key: (i, self.records[key].offset, size)
            for i, (key, size) in enumerate(zip(ordered, self._sizes, strict=True))
        }
        self._overrides = {key for key in ordered if key.startswith(f"{OVERRIDE_OWNER}/")}
        self._control = {f"{PROCESS_OWNER}/{p}/control" for p in layout.PROCESSES}
        # a control record's index in a push -> its process; its size there (`last_beat`)
        self._beat_index = {
            self._index[f"{PROCESS_OWNER}/{p}/control"]: p for p in layout.PROCESSES
        }
        self._beat_size = INDEX.size + EPOCH.size + PROCESS.size
        self._own = f"{PROCESS_OWNER}/{node}/control"  # only this process writes it

    def _written(self, offsets: tuple[int, ...]) -> tuple[int, ...]:
        """The indices of the records at `offsets` but the performance buffers; their
        sequence words' unpack (`_mine_seqs`) and what was sent of them (`_mine_known`)."""
        index_at = {span[0]: i for i, span in enumerate(self._spans)}
        mine = tuple(index_at[o] for o in sorted(offsets) if o in index_at)
        mine = tuple(i for i in mine if self._fast[i])
        mine_format, at = "<", self._spans[mine[0]][0] if mine else 0
        self._mine_start = at
        for i in mine:
            offset = self._spans[i][0]
            mine_format += (f"{offset - at}x" if offset > at else "") + "Q"
            at = offset + SEQ.size
        self._mine_seqs = Struct(mine_format)
        self._mine_known = _getter(mine)
        return mine

    def changed(self, everything: bool = False, slow: bool = True) -> list[tuple[str, bytes]]:
        """(key suffix, message) of each record this node wrote since it was last sent (with
        `everything`, of each record whose value this node wrote, to bring a node that
        joined up to date); control records last, so a receiver that has a process's
        control record of cycle N has everything that process wrote up to cycle N. Without
        `slow`, the performance buffers are left for a later push (their latest values
        then): everything else is as above."""
        buf, epoch, known = self.block.buf, EPOCH.pack(self.epoch), self.known
        keys, spans, owned, control = self._keys, self._spans, self.owned, self._control
        found: list[tuple[str, bytes]] = []
        last_ones: list[tuple[str, bytes]] = []
        for i, seq in self._candidates(buf, everything, slow):
            if seq % 2:  # being written (a writer died mid-write): not whole, not sent
                continue
            start, end = spans[i]
            message = epoch + buf[start:end]  # one copy, straight from the block
            # the seqlock's read: the word the same before and after the copy (else it is
            # being rewritten: it goes with a later push)
            if SEQ.unpack_from(buf, start)[0] != seq:
                continue
            known[i] = seq
            key = keys[i]
            owned.add(key)
            (last_ones if key in control else found).append((key, message))
        found += last_ones
        return found

    def pack(self, messages: list[tuple[str, bytes]]) -> bytes:
        """A push as one payload: each message after its record's index."""
        return b"".join(INDEX.pack(self._index[key]) + message for key, message in messages)

    def unpack(self, payload: bytes) -> list[tuple[str, bytes]] | None:
        """The messages of a push, or None (counted) if any part is not a record of this
        layout: a push is applied whole or not at all."""
        found, at, total = [], 0, len(payload)
        keys, sizes, count, step = self._keys, self._sizes, len(self._keys), INDEX.size
        while at < total:
            if at + step > total:
                break
            (index,) = INDEX.unpack_from(payload, at)
            if index >= count:
                break
            start = at + step
            end = start + sizes[index]
            if end > total:
                break
            found.append((keys[index], payload[start:end]))
            at = end
        else:
            return found
        self.counters.malformed += 1
        return None

    def last_beat(self, payload: bytes) -> tuple[str, int] | None:
        """(process, heartbeat) of the control record a push ends with (a process's push
        ends with its own, when it beat: `changed`), as sent; None when its last bytes are
        not one. Constant time, reads nothing but the payload and the layout: any thread
        (Zenoh's, as the push arrives). A push that does not end with a control record may
        still look as if it did (its bytes are data): take what this says as a hint."""
        start = len(payload) - self._beat_size
        if start < 0:
            return None
        process = self._beat_index.get(INDEX.unpack_from(payload, start)[0])
        if process is None:
            return None
        return process, PROCESS.unpack_from(payload, start + INDEX.size + EPOCH.size)[4]

    def _candidates(self, buf: memoryview, everything: bool, slow: bool) -> list[tuple[int, int]]:
        """(index, sequence word) of the records whose word moved since they were last sent
        or mirrored (with `everything`, also those whose value this node wrote; without
        `slow`, not the performance buffers, and of a process only what it writes)."""
        known, mine = self.known, self._mine
        if mine is not None and not (slow or everything):
            words = self._mine_seqs.unpack_from(buf, self._mine_start)
            was = self._mine_known(known)  # what was sent of them, in the same order
            return _moved(words, was, mine)
        seqs = self._seqs.unpack_from(buf, self._start)
        if everything:
            owned, keys = self.owned, self._keys
            return [(i, seq) for i, seq in enumerate(seqs) if seq != known[i] or keys[i] in owned]
        moved = _moved(seqs, known, self._every)
        if slow:
            return moved
        fast = self._fast
        return [(i, seq) for i, seq in moved if fast[i]]

    def apply(self, key: str, payload: bytes, now_ns: int | None = None) -> bool:
        """Mirror one message into the block; False when it is dropped (late, out of
        order, for no record of this layout, or of the wrong size)."""
        where = self._where.get(key)
        if key == self._own:  # another node's idea of us (a launcher's DEAD): ours wins
            return False
        if where is None or len(payload) != where[2]:
            self.counters.malformed += 1
            return False
        epoch, seq = HEAD.unpack_from(payload, 0)
        if epoch == self.epoch:  # our own message, looped back
            return False
        previous = self.last.get(key)
        if previous is not None and previous[0] == epoch and seq <= previous[1]:
            if seq < previous[1]:  # (the same word again: a refresh repeating what we have)
                self.counters.late += 1
            return False
        if seq == 0 or seq % 2:
            self.counters.malformed += 1
            return False
        self.last[key] = (epoch, seq)
        if key in self._control:
            record = self.records[key]
            values = list(record.struct.unpack_from(payload, EPOCH.size))
            # seq, pid, state, watchdog_trips, heartbeat, beat_ns, ...
            values[5] = time.monotonic_ns() if now_ns is None else now_ns
            self._write(key, record, values[1:])
        else:  # its fields' bytes as they came (the same struct, no padding): no unpacking
            self._copy(where, payload)
        if key in self._overrides:  # the flag the generated modules look at
            mirrored(self.layout, self.block.buf)
        self.owned.discard(key)
        self.counters.applied += 1
        return True

    def mark_dead(self, process: str) -> None:
        """A process's token went away (killed, or its network cut): its control record says
        DEAD, so the supervisors of its modules go to their safe state (loop.check_liveness)."""
        key = f"{PROCESS_OWNER}/{process}/control"
        record = self.records.get(key)
        if record is None:
            return
        values = list(record.struct.unpack_from(self.block.buf, record.offset))
        values[2] = DEAD  # seq, pid, state
        self._write(key, record, values[1:])
        self.last.pop(key, None)
        self.counters.lost.append(process)

    def _copy(self, where: tuple[int, int, int], message: bytes) -> None:
        """A message's record bytes after its sequence word, into the block (seqlock), the
        record `where` says: its index, offset and message size (`_where`)."""
        buf, (index, at, size) = self.block.buf, where
        seq = next_odd(SEQ.unpack_from(buf, at)[0])
        SEQ.pack_into(buf, at, seq)  # odd before any field changes
        buf[at + SEQ.size : at + size - EPOCH.size] = message[HEAD.size :]
        SEQ.pack_into(buf, at, seq + 1)
        self.known[index] = seq + 1

    def _write(self, key: str, record: Record, values: list[object]) -> None:
        buf = self.block.buf
        seq = next_odd(record.seq(buf))
        SEQ.pack_into(buf, record.offset, seq)  # odd before any field changes
        record.struct.pack_into(buf, record.offset, seq, *values)
        SEQ.pack_into(buf, record.offset, seq + 1)
        self.known[self._index[key]] = seq + 1

    def heartbeat(self, process: str) -> int:
        """The cycles a process has run, as mirrored here (its control record)."""
        values = PROCESS.unpack_from(self.block.buf, self.layout.PROCESSES[process].offset)
        return int(values[4])  # seq, pid, state, watchdog_trips, heartbeat

    def state(self, process: str) -> int:
        values = PROCESS.unpack_from(self.block.buf, self.layout.PROCESSES[process].offset)
        return int(values[2])


def _moved(
    words: Sequence[int], was: Sequence[int], indices: Sequence[int]
) -> list[tuple[int, int]]:
    """(indices[j], words[j]) for each j where `words` and `was` differ. They are compared
    a run of SEQ_RUN at a time (two slices compared in C: a push changes a few of a layout's
    hundreds of records), one by one only in a run that differs. (Comparing every word by
    itself, even in C with map/compress, made a call per record: 25 of a push's ~60 µs of
    Python in a hop, at load ~8.)"""
    found, count = [], len(words)
    for a in range(0, count, SEQ_RUN):
        b = a + SEQ_RUN
        if words[a:b] != was[a:b]:
            for j in range(a, min(b, count)):
                if words[j] != was[j]:
                    found.append((indices[j], words[j]))
    return found


def _getter(indices: tuple[int, ...]) -> Callable[[Sequence[int]], tuple[int, ...]]:
    """A function of a list: its items at `indices`, as a tuple (in C)."""
    if len(indices) > 1:
        return itemgetter(*indices)
    return lambda items: tuple(items[i] for i in indices)


def check_endpoint(text: str) -> str:
    """`tcp/HOST:PORT` (or udp/, quic/, tls/): a one-line error otherwise."""
    proto, _, rest = text.partition("/")
    host, _, port = rest.rpartition(":")
    if proto not in ("tcp", "udp", "tls", "quic") or not host or not port.isdigit():
        raise ValueError(f"endpoint {text!r} is not PROTO/HOST:PORT (e.g. tcp/127.0.0.1:7447)")
    if not 0 <= int(port) <= 65535:
        raise ValueError(f"endpoint {text!r}: port {port} is not 0..65535")
    return text


class Security(NamedTuple):
    """A Zenoh node's own TLS and user/password authentication, as files (a deployment
    host's `tls` and `auth`, rcs/deploy.py): mutual TLS with `root_ca` as the one trusted
    authority and `certificate`/`key` as this node's identity; `user` with the password in
    `password_file`, and `users_file` (`user:password` lines) the credentials this node
    accepts. Empty: none of it (plaintext, anyone may join). Paths only, never a secret:
    the form a launcher hands its children (`--security`)."""

    root_ca: str = ""
    certificate: str = ""
    key: str = ""
    user: str = ""
    password_file: str = ""
    users_file: str = ""

    @property
    def tls(self) -> bool:
        return bool(self.root_ca)

    @property
    def auth(self) -> bool:
        return bool(self.user)

    def to_text(self) -> str:
        import json

        return json.dumps({k: v for k, v in self._asdict().items() if v}, sort_keys=True)

    @classmethod
    def from_text(cls, text: str) -> Security:
        """The form `to_text` wrote; ValueError for anything else."""
        import json

        try:
            values = json.loads(text)
            return cls(**{str(k): str(v) for k, v in values.items()})
        except (ValueError, TypeError, AttributeError):
            raise ValueError(f"--security: not what a launcher passes: {text[:40]!r}") from None


PLAINTEXT = Security()  # no TLS, no authentication: what a node has unless a deployment says
