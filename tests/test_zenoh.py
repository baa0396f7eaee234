"""The miner across "hosts" over Zenoh on 127.0.0.1: each process on a block of its own.

The mirror (what moves, late messages dropped) is tested on private blocks; the rest runs
real processes connected only through Zenoh, on ports chosen here: the lockstep trace
equals the golden one, a stopped (partitioned) or killed host is detected and its
dependants go to their safe state, a host that comes back re-joins, and nothing is left
in /dev/shm, listening, or running.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import read_whole, until, wait_for
from support.running import attached, listening

from rcsgen.tools.harness import import_package
from rcsgen.tools.scenario import load_scenario, open_harness, read_trace, run

zenoh = pytest.importorskip("zenoh")

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "generated" / "miner"
HOOKS = ROOT / "specs" / "miner"


@pytest.fixture(scope="module")
def miner() -> ModuleType:
    return import_package(PACKAGE, HOOKS)


def rcs(miner: ModuleType, name: str) -> ModuleType:
    import importlib

    return importlib.import_module(f"{miner.__name__}.{name}")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def shm_files() -> set[str]:
    """This test run's own entries in /dev/shm: every segment these tests and their
    harnesses make names the test process's pid (others' entries come and go as other
    suites run beside this one). What Zenoh itself might put there is checked apart, by
    what this process maps (`shm_mapped`)."""
    found = set(os.listdir("/dev/shm")) if os.path.isdir("/dev/shm") else set()
    return {n for n in found if str(os.getpid()) in n}


def shm_mapped() -> set[str]:
    """The /dev/shm files this process has mapped or open: Zenoh's own shared memory, were
    it on, would show here while a session is open."""
    maps = Path("/proc/self/maps").read_text()
    found = {line.split(maxsplit=5)[-1] for line in maps.splitlines() if "/dev/shm/" in line}
    for fd in Path("/proc/self/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("/dev/shm/"):
            found.add(target)
    return found


# ---------------------------------------------------------------- the mirror, no network


def test_a_node_sends_only_what_it_wrote_and_its_control_record_last(miner: ModuleType) -> None:
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    block = rcs(miner, "rcs.block").Block(layout)
    mirror = transport.Mirror(layout, block, "pc2")
    assert list(mirror.changed()) == []  # a new block: nothing written yet
    layout.STATUS_OUT["pp"].write(block.buf, status_num=1, status=2)
    layout.PROCESSES["pc2"].write(block.buf, heartbeat=1)
    layout.WORLD["wp_x"].write(block.buf, wp_x=1.0)
    sent = [key for key, _ in mirror.changed()]
    assert sent == ["pp/status", "_world/wp_x", "_process/pc2/control"]
    assert list(mirror.changed()) == []  # sent once
    assert [k for k, _ in mirror.changed(everything=True)] == sent  # for a node that joined


def test_a_record_caught_mid_write_is_left_for_the_push_after_its_writer_ends(
    miner: ModuleType,
) -> None:
    """A record whose sequence word is odd (its writer, a console on this host, is between
    its two words) is not sent torn: it goes, whole, once the word is even again."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    block = rcs(miner, "rcs.block").Block(layout)
    mirror = transport.Mirror(layout, block, "pc2")
    status, seq = layout.STATUS_OUT["pp"], transport.SEQ
    status.write(block.buf, status_num=1, status=2)
    word = seq.unpack_from(block.buf, status.offset)[0]
    seq.pack_into(block.buf, status.offset, word + 1)  # a writer began
    assert mirror.changed() == []
    seq.pack_into(block.buf, status.offset, word + 2)  # and ended
    ((key, message),) = mirror.changed()
    assert key == "pp/status"
    assert seq.unpack_from(message, transport.EPOCH.size)[0] == word + 2
    assert mirror.changed() == []


def test_performance_buffers_wait_for_a_slow_push_and_then_go_as_they_are_then(
    miner: ModuleType,
) -> None:
    """A module's performance buffer changes every cycle and only people read it: a push
    that is not `slow` leaves it for later, and the later one sends its latest value."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    block = rcs(miner, "rcs.block").Block(layout)
    mirror = transport.Mirror(layout, block, "pc2")
    perf = layout.PERFORMANCE["pp"]
    perf.write(block.buf, cycles=1)
    layout.STATUS_OUT["pp"].write(block.buf, status_num=1, status=2)
    assert [k for k, _ in mirror.changed(slow=False)] == ["pp/status"]
    perf.write(block.buf, cycles=2)
    assert [k for k, _ in mirror.changed(slow=False)] == []
    ((key, message),) = mirror.changed()  # slow: what waited, as it is now
    assert key == "pp/perf"
    receiver = transport.Mirror(layout, rcs(miner, "rcs.block").Block(layout), "pc1")
    assert receiver.apply(key, message)
    assert perf.read(receiver.block.buf)["cycles"] == 2
    # a node that joined gets everything this one wrote, its performance buffers too
    assert sorted(k for k, _ in mirror.changed(everything=True, slow=False)) == [
        "pp/perf",
        "pp/status",
    ]


def test_a_changed_record_is_found_wherever_it_lies_in_the_runs_of_sequence_words(
    miner: ModuleType,
) -> None:
    """`changed` compares the sequence words SEQ_RUN at a time: a record at either end of a
    run, in the last (short) run, or two in one run, is found and sent once, in layout order
    (an observer's mirror: it looks at every record every push)."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    block = rcs(miner, "rcs.block").Block(layout)
    mirror = transport.Mirror(layout, block)
    keys, run = mirror._keys, transport.SEQ_RUN
    picks = sorted({0, run - 1, run, run + 1, 3 * run - 1, len(keys) - 2, len(keys) - 1})
    seq = transport.SEQ
    for i in picks:  # a whole write: the word moved by two
        record = mirror.records[keys[i]]
        seq.pack_into(block.buf, record.offset, seq.unpack_from(block.buf, record.offset)[0] + 2)
    sent = [key for key, _ in mirror.changed()]
    control = [keys[i] for i in picks if keys[i].endswith("/control")]
    assert sent == [keys[i] for i in picks if keys[i] not in control] + control
    assert mirror.changed() == []
    fast = [i for i in picks if not keys[i].endswith("/perf")]
    for i in picks:
        record = mirror.records[keys[i]]
        seq.pack_into(block.buf, record.offset, seq.unpack_from(block.buf, record.offset)[0] + 2)
    assert {key for key, _ in mirror.changed(slow=False)} == {keys[i] for i in fast}


def test_a_process_looks_every_push_only_at_what_it_writes_and_at_the_rest_every_slow_one(
    miner: ModuleType,
) -> None:
    """A process's push looks only at the records the layout's writer table gives it; what
    else is written into its block (an operator's `ctl slow` on its host) goes with the next
    slow push, and a record of its table in the same run of words as the other is found."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    block = rcs(miner, "rcs.block").Block(layout)
    mirror = transport.Mirror(layout, block, "pc2")
    mine = {key for key, r in mirror.records.items() if r.offset in layout.WRITES["pc2"]}
    assert {"pp/status", "_process/pc2/control"} <= mine
    assert not {"_process/pc2/pace", "sec/status", "pp/answer"} & mine
    layout.PACING["pc2"].write(block.buf, slow=2.0)  # not pc2's to write: an operator's
    layout.STATUS_OUT["pp"].write(block.buf, status_num=1, status=2)
    layout.PROCESSES["pc2"].write(block.buf, heartbeat=1)
    assert [k for k, _ in mirror.changed(slow=False)] == ["pp/status", "_process/pc2/control"]
    assert [k for k, _ in mirror.changed(slow=False)] == []
    assert [k for k, _ in mirror.changed()] == ["_process/pc2/pace"]  # slow: everything
    assert mirror.changed() == []


def test_a_late_or_out_of_order_message_is_dropped_and_counted(miner: ModuleType) -> None:
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block = rcs(miner, "rcs.block").Block
    sender_block, receiver_block = Block(layout), Block(layout)
    sender = transport.Mirror(layout, sender_block, "pc1")
    receiver = transport.Mirror(layout, receiver_block, "pc2")
    record = layout.COMMAND_IN["pp"]
    messages = []
    for number in (1, 2):
        record.write(sender_block.buf, command_num=number, command=3, arg_x=float(number))
        messages += [m for k, m in sender.changed() if k == "pp/command"]
    assert receiver.apply("pp/command", messages[1])
    assert record.read(receiver_block.buf)["command_num"] == 2
    assert not receiver.apply("pp/command", messages[0])  # older: dropped
    assert not receiver.apply("pp/command", messages[1])  # a repeat (a refresh): dropped
    assert record.read(receiver_block.buf)["arg_x"] == 2.0
    assert receiver.counters.late == 1  # the older one; a repeat is not late
    # a restarted sender (a new epoch) starts its sequence words again: accepted
    restarted = transport.Mirror(layout, Block(layout), "pc1")
    record.write(restarted.block.buf, command_num=7, command=3)
    (message,) = [m for k, m in restarted.changed() if k == "pp/command"]
    assert receiver.apply("pp/command", message)
    assert record.read(receiver_block.buf)["command_num"] == 7
    assert not receiver.apply("pp/command", message[:-1])  # the wrong size
    assert not receiver.apply("no/such", message)
    assert receiver.counters.malformed == 2
    assert receiver.counters.applied == 2


def test_a_push_travels_as_one_message_and_is_applied_whole_or_not_at_all(
    miner: ModuleType,
) -> None:
    """pp writes wp_x and reports DONE in one cycle: a reader must never see the DONE
    without the wp_x. The cycle's records travel as one payload; one that is cut short or
    names no record of this layout is refused whole (counted), nothing of it applied."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block = rcs(miner, "rcs.block").Block
    sender = transport.Mirror(layout, Block(layout), "pc2")
    receiver = transport.Mirror(layout, Block(layout), "pc1")
    layout.WORLD["wp_x"].write(sender.block.buf, wp_x=-1.0)
    layout.STATUS_OUT["pp"].write(sender.block.buf, status_num=1, status=2)
    layout.PROCESSES["pc2"].write(sender.block.buf, heartbeat=1)
    push = sender.changed()
    assert [k for k, _ in push] == ["pp/status", "_world/wp_x", "_process/pc2/control"]
    payload = sender.pack(push)
    assert receiver.unpack(payload[:-1]) is None  # cut short
    assert receiver.unpack(b"\xff\xff" + payload) is None  # no such record
    assert receiver.counters.malformed == 2
    assert layout.STATUS_OUT["pp"].read(receiver.block.buf)["status_num"] == 0
    assert receiver.unpack(payload) == push
    for key, message in receiver.unpack(payload) or ():
        receiver.apply(key, message)
    assert layout.STATUS_OUT["pp"].read(receiver.block.buf)["status_num"] == 1
    assert layout.WORLD["wp_x"].read(receiver.block.buf)["wp_x"] == -1.0
    assert receiver.counters.applied == 3


def test_a_mirrored_heartbeat_is_stamped_with_the_receivers_clock(miner: ModuleType) -> None:
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block = rcs(miner, "rcs.block").Block
    contract = rcs(miner, "rcs.contract")
    sender = transport.Mirror(layout, Block(layout), "pc2")
    receiver = transport.Mirror(layout, Block(layout), "pc1")
    layout.PROCESSES["pc2"].write(sender.block.buf, heartbeat=5, beat_ns=123, state=2)
    (message,) = [m for k, m in sender.changed() if k == "_process/pc2/control"]
    assert receiver.apply("_process/pc2/control", message, now_ns=987_654)
    record = layout.PROCESSES["pc2"].read(receiver.block.buf)
    assert (record["heartbeat"], record["beat_ns"]) == (5, 987_654)
    receiver.mark_dead("pc2")
    assert layout.PROCESSES["pc2"].read(receiver.block.buf)["state"] == contract.DEAD
    assert list(receiver.changed()) == []  # the mark is local: never sent as pc2's record
    # nobody else's idea of a process overrides its own control record
    layout.PROCESSES["pc1"].write(sender.block.buf, state=contract.DEAD)
    (message,) = [m for k, m in sender.changed() if k == "_process/pc1/control"]
    assert not receiver.apply("_process/pc1/control", message)
    assert layout.PROCESSES["pc1"].read(receiver.block.buf)["state"] != contract.DEAD


def test_the_configuration_keeps_zenoh_out_of_dev_shm_and_off_multicast(miner: ModuleType) -> None:
    zt = rcs(miner, "rcs.zenoh_transport")
    config = zt.config_json(zt.Options(("tcp/127.0.0.1:1",), (), 700))
    assert config["transport/shared_memory/enabled"] is False
    assert config["scouting/multicast/enabled"] is False
    assert config["transport/link/tx/lease"] == 700
    before, mapped = shm_files(), shm_mapped()
    mirror = rcs(miner, "rcs.transport").Mirror(
        rcs(miner, "layout"), rcs(miner, "rcs.block").Block(rcs(miner, "layout"))
    )
    port = free_port()
    node = zt.ZenohTransport(mirror, zt.Options((f"tcp/127.0.0.1:{port}",), (), 1000))
    try:
        assert listening({port}) == {port}
        assert shm_mapped() - mapped == set(), "Zenoh maps shared memory of its own"
    finally:
        node.close()
    assert shm_files() - before == set()
    assert listening({port}) == set()


def test_a_push_the_congested_network_dropped_is_repaired_within_the_refresh_interval(
    miner: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A free-running push may be dropped (CongestionControl.DROP: a controller never waits
    for the network), and a record that does not change again (a DONE its supervisor waits
    for) would then never arrive. Within REFRESH_INTERVAL the node sends what it wrote
    again, and the receiver takes it; taking a repeat of what it has counts nothing."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block, zt = rcs(miner, "rcs.block").Block, rcs(miner, "rcs.zenoh_transport")
    block = Block(layout)
    node = zt.ZenohTransport(
        transport.Mirror(layout, block, "pc2"),
        zt.Options(listen=(f"tcp/127.0.0.1:{free_port()}",)),
        "pc2",
    )
    puts: list[bytes] = []

    class Congested:  # what is put: the test loses the first on the way
        def put(self, payload: bytes) -> None:
            puts.append(payload)

    node._publisher = Congested()
    now = [1000.0]
    monkeypatch.setattr(zt.time, "monotonic", lambda: now[0])
    node._next_refresh = now[0] + zt.REFRESH_INTERVAL
    try:
        layout.STATUS_OUT["pp"].write(block.buf, status_num=1, status=2)  # pp DONE #1
        node.push()
        assert len(puts) == 1
        puts.clear()  # ... dropped: pc1 never gets it
        for _ in range(9):  # nothing changes in the next 0.9 s: nothing is sent
            now[0] += zt.REFRESH_INTERVAL / 10
            node.push()
        assert puts == []
        now[0] += zt.REFRESH_INTERVAL / 10 + 0.001
        node.push()
        assert len(puts) == 1
        receiver = transport.Mirror(layout, Block(layout), "pc1")
        messages = dict(receiver.unpack(puts[0]) or [])
        assert receiver.apply("pp/status", messages["pp/status"])
        assert layout.STATUS_OUT["pp"].read(receiver.block.buf)["status_num"] == 1
        assert not receiver.apply("pp/status", messages["pp/status"])  # the next refresh
        assert receiver.counters.late == 0
    finally:
        node.close()


@contextmanager
def lockstep_pair(miner: ModuleType, log: Any = None) -> Iterator[tuple[Any, Any]]:
    """pc2's lockstep node and an observer's (a coordinator's) on loopback, each on a block
    of its own, both joined; closed after."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block, zt = rcs(miner, "rcs.block").Block, rcs(miner, "rcs.zenoh_transport")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    process = zt.ZenohTransport(
        transport.Mirror(layout, Block(layout), "pc2"),
        zt.Options(listen=(endpoint,)),
        "pc2",
        ("pp",),
        block_when_congested=True,
        log=log,
    )
    observer = zt.ZenohTransport(
        transport.Mirror(layout, Block(layout)),
        zt.Options(connect=(endpoint,)),
        block_when_congested=True,
    )
    try:
        assert process.wait(lambda: len(process.joined) == 2, 10.0)
        assert observer.wait(lambda: len(observer.joined) == 2, 10.0)
        yield process, observer
    finally:
        observer.close()
        process.close()


def test_a_step_request_arrives_after_the_records_sent_before_it(miner: ModuleType) -> None:
    """Lockstep relies on it: what a coordinator wrote (a scenario's command) must be in a
    process's block when the step it sends next arrives, though they come through two
    subscribers (zenoh-python would run each subscriber's callback in a thread of its own).
    A cycle's requests go as one message; each process takes its own out of it."""
    layout, zt = rcs(miner, "layout"), rcs(miner, "rcs.zenoh_transport")
    record, seen, taken = layout.COMMAND_IN["pp"], [], []
    names = list(layout.PROCESSES)
    with lockstep_pair(miner) as (process, observer):
        process_block, observer_block = process.mirror.block, observer.mirror.block
        for number in range(1, 301):
            record.write(observer_block.buf, command_num=number, command=3)
            observer.push()
            # pc1's request says module 1, pc2's module 2; each names the cycle `number`
            observer.send_steps(
                {
                    n: zt.step_request(i + 1, i + 1, True, [number] * len(names))
                    for i, n in enumerate(names)
                }
            )
            assert process.wait(lambda: bool(process.steps), 10.0)
            taken += process.steps
            process.steps.clear()
            seen.append(record.read(process_block.buf)["command_num"])
    assert seen == list(range(1, 301))
    first = [zt.STEP.unpack_from(request, 0)[1] for request in taken]  # b"s", first, ...
    assert first == [names.index("pc2") + 1] * 300, "pc2's own request, once a message"


def test_a_process_waiting_for_its_step_is_not_woken_by_pushes_and_applies_them_with_it(
    miner: ModuleType,
) -> None:
    """A lockstep process waiting for its step (`eager` off, as `serve` sets it) is woken
    by the step, not by each push of another node (a wake-up a push, and its CPU, on every
    cycle): its `ready` is asked a few times (the 0.2 s stop checks), not once a push; what
    the pushes carried is in its block, in order, when the step has come."""
    layout, zt = rcs(miner, "layout"), rcs(miner, "rcs.zenoh_transport")
    record, asked = layout.COMMAND_IN["pp"], []
    names = list(layout.PROCESSES)
    with lockstep_pair(miner) as (process, observer):
        process_block, observer_block = process.mirror.block, observer.mirror.block

        def stepped() -> bool:
            asked.append(record.read(process_block.buf)["command_num"])
            return bool(process.steps)

        process.eager = False
        waiting = ThreadPoolExecutor(1).submit(process.wait, stepped, 10.0)
        wait_for(lambda: bool(asked), "the process waiting", 10.0)
        for number in range(1, 41):  # one at a time, while it waits (about 0.2 s)
            record.write(observer_block.buf, command_num=number, command=3)
            observer.push()
            time.sleep(0.005)
        observer.send_steps({"pc2": zt.step_request(0, 0, True, [0] * len(names))})
        assert waiting.result(10.0)
    assert asked[-1] == 40, "every push applied, the last one last, with the step"
    assert len(asked) < 10, f"woken {len(asked)} times for 40 pushes and a step"


def test_a_wait_for_heartbeats_is_woken_by_the_push_that_brings_the_last_of_them(
    miner: ModuleType,
) -> None:
    """A wait that names the heartbeats it needs (a coordinator's answers, a lockstep
    process's records to read) is not woken by each push before the one that brings the
    last of them: its `ready` is asked a few times (the 0.2 s stop checks), not once a
    push; each push is applied, in order, when it is."""
    layout = rcs(miner, "layout")
    control, asked = layout.PROCESSES["pc1"], []
    with lockstep_pair(miner) as (process, observer):
        process_block, observer_block = process.mirror.block, observer.mirror.block

        def answered() -> bool:
            beat = control.read(process_block.buf)["heartbeat"]
            asked.append(beat)
            return beat >= 40

        waiting = ThreadPoolExecutor(1).submit(process.wait, answered, 20.0, {"pc1": 40})
        wait_for(lambda: bool(asked), "the process waiting", 10.0)
        for beat in range(1, 41):  # pc1's heartbeat, one push each (as an observer relays)
            control.write(observer_block.buf, heartbeat=beat)
            observer.push()
            time.sleep(0.005)
        assert waiting.result(20.0)
    assert asked[-1] == 40
    assert len(asked) < 10, f"woken {len(asked)} times for 40 pushes"


def test_a_malformed_step_request_is_counted_for_its_sender_and_never_run(
    miner: ModuleType,
) -> None:
    """A step message that is not whole requests of this layout (cut short, a request of
    another size) is refused whole: no step is run from it, it is counted as malformed for
    the node that sent it (`ctl status`'s counters), said in one line; a good one after it
    is taken."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    zt = rcs(miner, "rcs.zenoh_transport")
    said: list[str] = []
    report: dict[str, int] = {}
    names = list(layout.PROCESSES)
    good = zt.step_request(0, 0, True, [0] * len(names))
    index = names.index("pc2")
    with lockstep_pair(miner, said.append) as (process, observer):
        process.report, sender = report, observer.node
        key = f"{zt.prefix(layout)}/{transport.STEP_KEY}/{sender}"
        for garbage in (zt.STEP_ENTRY.pack(index, len(good)) + good[:-1], b"\x01"):
            observer.session.put(key, garbage)
        assert process.wait(lambda: process.peers.get(sender, {}).get("malformed") == 2, 10.0)
        observer.send_steps({"pc2": good})
        assert process.wait(lambda: bool(process.steps), 10.0)
    assert list(process.steps) == [good], "only the good request is taken"
    assert report["net_malformed"] == 2
    assert said == [
        f"pc2: a malformed step request from {sender} ({len(good) + 3} bytes, not whole "
        f"requests of layout {layout.LAYOUT_HASH[:8]}): refused, no step run (1 from "
        f"{sender} so far)"
    ]


def test_a_node_of_another_layout_is_named_and_ignored(miner: ModuleType) -> None:
    """Hosts built from other specs share no key (the layout hash is in every key); a token
    of the same system with another hash is reported once, in one line."""
    import types

    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block, zt = rcs(miner, "rcs.block").Block, rcs(miner, "rcs.zenoh_transport")
    other = types.SimpleNamespace(**vars(layout))
    other.LAYOUT_HASH = "0123456789abcdef" * 2
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    said: list[str] = []
    ours_block, theirs_block = Block(layout), Block(layout)
    ours = zt.ZenohTransport(
        transport.Mirror(layout, ours_block), zt.Options(listen=(endpoint,)), log=said.append
    )
    theirs = zt.ZenohTransport(
        transport.Mirror(other, theirs_block), zt.Options(connect=(endpoint,))
    )
    try:
        assert ours.wait(lambda: ours.mirror.counters.foreign >= 1, 10.0)
        layout.WORLD["pose_x"].write(theirs_block.buf, pose_x=5.0)
        theirs.push()
        # Nothing can say "it will never come": a window for the foreign record to arrive
        # (it must not be applied). Load can only make this pass for want of the record,
        # never fail: it is not a wait for something to happen, so no condition replaces it.
        time.sleep(0.3)
        ours.pull()
    finally:
        theirs.close()
        ours.close()
    assert len(said) == 1
    assert said[0].endswith(
        "runs layout 01234567, not " + layout.LAYOUT_HASH[:8] + ": ignored (rebuild every "
        "host from the same specs)"
    )
    assert ours.mirror.counters.applied == 0
    assert layout.WORLD["pose_x"].read(ours_block.buf)["pose_x"] == 0.0


def test_a_malformed_push_is_counted_per_peer_never_applied_and_said_once(
    miner: ModuleType,
) -> None:
    """A push that is not whole records of this layout, injected on loopback under a
    peer's name: counted for that peer and in the process's control-record counters (what
    `ctl status` shows), nothing of it applied, one line naming the peer (a second within
    10 s counted, not said again); the peer's good push after it is applied."""
    layout, transport = rcs(miner, "layout"), rcs(miner, "rcs.transport")
    Block, zt = rcs(miner, "rcs.block").Block, rcs(miner, "rcs.zenoh_transport")
    ctl = rcs(miner, "rcs.operate.ctl")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    said: list[str] = []
    ours_block, theirs_block = Block(layout), Block(layout)
    ours = zt.ZenohTransport(
        transport.Mirror(layout, ours_block, "pc1"),
        zt.Options(listen=(endpoint,)),
        "pc1",
        log=said.append,
    )
    report = dict.fromkeys(ctl.NETWORK_NAMES, 0)
    ours.report = report
    theirs = zt.ZenohTransport(
        transport.Mirror(layout, theirs_block, "pc2"), zt.Options(connect=(endpoint,)), "pc2"
    )
    try:
        assert ours.wait(lambda: "pc2" in ours.joined, 10.0)
        ours.wait(lambda: "pc2" in ours.synced, 2.0)  # pc2's first (full) push, if any
        before = bytes(ours_block.buf)
        key = f"{zt.prefix(layout)}/{transport.PUSH_KEY}/pc2"
        for garbage in (b"\x07\x00not a record", b"\xff" * 40):
            theirs.session.put(key, garbage)
        assert ours.wait(lambda: ours.peers.get("pc2", {}).get("malformed") == 2, 10.0)
        assert bytes(ours_block.buf) == before, "nothing of a malformed push is applied"
        layout.WORLD["pose_x"].write(theirs_block.buf, pose_x=5.0)
        theirs.push()
        assert ours.wait(lambda: layout.WORLD["pose_x"].read(ours_block.buf)["pose_x"] == 5.0, 10.0)
    finally:
        theirs.close()
        ours.close()
    assert len(said) == 1, said
    assert said[0].startswith("pc1: a malformed push from pc2 (14 bytes, not whole records")
    assert said[0].endswith("refused whole, nothing applied (1 from pc2 so far)")
    assert ours.peers["pc2"]["malformed"] == 2 and ours.peers["pc2"]["applied"] >= 1
    assert report["net_malformed"] == 2 and report["net_applied"] >= 1
    lines = ctl.network_lines(
        {"processes": {"pc1": {"network": {k.removeprefix("net_"): v for k, v in report.items()}}}}
    )
    assert len(lines) == 1 and lines[0].endswith(", 2 malformed (refused)"), lines


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--transport", "zenoh", "--connect", "127.0.0.1:7447"], "is not PROTO/HOST:PORT"),
        (["--transport", "zenoh", "--listen", "tcp/127.0.0.1:99999"], "port 99999"),
        (["--connect", "tcp/127.0.0.1:7447"], "go with --transport zenoh"),
    ],
)
def test_a_bad_endpoint_is_one_line_and_exit_2(args: list[str], message: str) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "miner", "pc2", *args],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert message in done.stderr.splitlines()[-1]
    assert "Traceback" not in done.stderr


def test_a_port_in_use_or_nobody_to_attach_to_is_one_line_and_exit_1() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        done = subprocess.run(
            [sys.executable, "-m", "miner", "pc2", "--transport", "zenoh", "--cycles", "1"]
            + ["--shm", f"rcsgen_zenoh_{os.getpid()}_inuse", "--listen", f"tcp/127.0.0.1:{port}"],
            cwd=PACKAGE.parent,
            env={**os.environ, "PYTHONPATH": str(HOOKS)},
            capture_output=True,
            text=True,
            timeout=60,
        )
    assert done.returncode == 1
    assert done.stderr.splitlines() == [
        f"pc2: zenoh: Can not create a new TCP listener bound to tcp/127.0.0.1:{port}: "
        f"[127.0.0.1:{port}: Address already in use (os error 98)"
    ]
    nobody = ctl("--connect", f"tcp/127.0.0.1:{free_port()}", "status")
    assert nobody.returncode == 1
    (line,) = nobody.stderr.splitlines()
    assert line.startswith("ctl: error: no process of miner (layout ")
    assert line.endswith("within 5 s: is it running with --transport zenoh?")


# ---------------------------------------------------------------- processes on two "hosts"


def ctl(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "miner", "ctl", *args],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.parametrize("name", ["console_refusal", "operator_refuses"])
def test_an_operator_modules_answers_travel_over_zenoh(name: str) -> None:
    """The inspection workstation behind Zenoh: the answer records the console's events
    and the scripted person write in the coordinator's block reach the operator module,
    and its channels' statuses come back: the golden trace, nothing left behind."""
    before = shm_files()
    system = ROOT / "specs" / "inspection"
    scenario = load_scenario(system / "scenarios" / f"{name}.yaml")
    harness = open_harness(scenario, ROOT / "generated" / "inspection", True, "zenoh")
    try:
        result = run(scenario, harness)
    finally:
        harness.close()
    golden = ROOT / "tests" / "golden" / "inspection" / f"{name}.jsonl"
    assert result.trace == read_trace(golden)
    assert shm_files() - before == set()


# Four of the miner's scenarios, each another kind of traffic between the hosts: the box
# cut (the README's), around a pillar (the path planner on pc2 planning most), an operator's
# HALT mid-run, and an ERROR climbing the hierarchy. The other seven differ from these in
# the plant's events, which cross the hosts as the same buffers; every scenario's trace is
# compared in shared memory, in one process and in lockstep (test_golden). All eleven over
# Zenoh took about a minute of the suite.
ZENOH_SCENARIOS = ["around_pillar", "box_cut", "operator_halt", "stalled_tread"]


@pytest.mark.parametrize("name", ZENOH_SCENARIOS)
def test_lockstep_over_zenoh_leaves_the_golden_trace(name: str) -> None:
    """pc1 and pc2 each on a block of their own, connected only through Zenoh, stepped by a
    coordinator on the network: the trace equals the one-process golden trace, and
    afterwards nothing is left in /dev/shm, listening or running."""
    before = shm_files()
    scenario = load_scenario(HOOKS / "scenarios" / f"{name}.yaml")
    harness = open_harness(scenario, PACKAGE, processes=True, transport="zenoh")
    port = int(harness.launcher.listen.rsplit(":", 1)[1])
    children = [c.popen for c in harness.launcher.children.values()]
    # each process listens where the launcher said, and pc2 connects to pc1 as configured
    # (retried until it connects), not only through the gossip of the launcher's node
    own = {name: int(at.rsplit(":", 1)[1]) for name, at in harness.launcher.child_listen.items()}
    pc2 = harness.launcher.children["pc2"].popen.args
    try:
        assert listening({port, *own.values()}) == {port, *own.values()}
        assert ("--connect", harness.launcher.child_listen["pc1"]) in zip(
            pc2, pc2[1:], strict=False
        )
        result = run(scenario, harness)
    finally:
        harness.close()
    assert result.trace == read_trace(ROOT / "tests" / "golden" / f"{name}.jsonl")
    cycles = len(result.trace)
    assert any(line.startswith(f"pc2: stopped, {cycles} cycles") for line in harness.summary())
    assert all(child.poll() is not None for child in children)
    assert shm_files() - before == set()
    assert listening({port, *own.values()}) == set()


@pytest.fixture
def two_hosts() -> Iterator[dict[str, object]]:
    """pc2 (the path planner) listening, pc1 connecting to it: paced, each on its own
    segment named after this test run; stopped and cleaned up afterwards."""
    pid = os.getpid()
    ports = {"pc2": free_port(), "pc1": free_port()}
    segments = {name: f"rcsgen_zenoh_{pid}_{name}" for name in ports}
    env = {**os.environ, "PYTHONPATH": str(HOOKS)}
    command = [sys.executable, "-m", "miner"]
    hosts = {}
    hosts["pc2"] = subprocess.Popen(
        [*command, "pc2", "--transport", "zenoh", "--shm", segments["pc2"]]
        + ["--listen", f"tcp/127.0.0.1:{ports['pc2']}"],
        cwd=PACKAGE.parent,
        env=env,
        stdout=subprocess.DEVNULL,
    )
    hosts["pc1"] = subprocess.Popen(
        [*command, "pc1", "--transport", "zenoh", "--shm", segments["pc1"]]
        + ["--listen", f"tcp/127.0.0.1:{ports['pc1']}"]
        + ["--connect", f"tcp/127.0.0.1:{ports['pc2']}"],
        cwd=PACKAGE.parent,
        env=env,
        stdout=subprocess.DEVNULL,
    )
    try:
        yield {"hosts": hosts, "ports": ports, "segments": segments}
    finally:
        for host in hosts.values():
            if host.poll() is None:
                host.send_signal(signal.SIGCONT)
                host.terminate()
        for host in hosts.values():
            try:
                host.wait(10)
            except subprocess.TimeoutExpired:
                host.kill()
                host.wait()
        block = import_package(PACKAGE, HOOKS)
        unlink = rcs(block, "rcs.block").unlink
        for name in segments.values():  # a killed host could not remove its own
            unlink(name)


def test_two_hosts_exchange_buffers_and_a_lost_host_puts_its_dependants_in_safe_state(
    miner: ModuleType, two_hosts: dict[str, object]
) -> None:
    """vg (pc1) commands pp (pc2) over Zenoh; a partition of pc2 (SIGSTOP) is reported in
    pc1's control record and vg goes to its safe state; pc2 continued re-joins; pc2 killed
    is lost again. Afterwards nothing is left behind."""
    layout = rcs(miner, "layout")
    blocks = rcs(miner, "rcs.block")
    contract = rcs(miner, "rcs.contract")
    hosts = two_hosts["hosts"]
    segments = two_hosts["segments"]
    ports = set(two_hosts["ports"].values())
    before = shm_files()

    def attach(name: str) -> object:
        return wait_for(attached(blocks, layout, segments[name]), f"{name}'s segment")

    pc1, pc2 = attach("pc1"), attach("pc2")
    try:
        # INIT rippled from vg (pc1) to pp (pc2) and pp's DONE came back into pc1's block
        def pp_done_in(block: object) -> bool:
            status = read_whole(layout.STATUS_OUT["pp"], block.buf)
            return status["status"] == contract.DONE and status["status_num"] >= 1

        wait_for(lambda: pp_done_in(pc2), "pp's INIT done on pc2")
        wait_for(lambda: pp_done_in(pc1), "pp's status mirrored on pc1")
        assert read_whole(layout.COMMAND_IN["pp"], pc2.buf)["command_num"] >= 1  # written by vg
        # an operator's console on a third "host", attached through Zenoh to pc2 only
        status = ctl("--connect", f"tcp/127.0.0.1:{two_hosts['ports']['pc2']}", "status")
        assert status.returncode == 0, status.stderr
        lines = status.stdout.splitlines()
        assert lines[0] == f"miner on zenoh tcp/127.0.0.1:{two_hosts['ports']['pc2']}"
        assert any(line.startswith("process pc1: running") for line in lines), status.stdout
        (pp,) = [line.split() for line in lines if line.split()[:1] == ["pp"]]
        assert pp[1:4] == ["INIT", "1", "DONE"], status.stdout
        at_pc1 = f"tcp/127.0.0.1:{two_hosts['ports']['pc1']}"
        refused = ctl("--connect", at_pc1, "stop", "pp")  # the access levels hold across hosts
        assert refused.returncode == 1 and "needs override on pp" in refused.stderr
        stop = ctl("--connect", at_pc1, "--role", "engineer", "stop", "pp")
        assert stop.returncode == 0, stop.stderr
        wait_for(lambda: layout.MODE_IN["pp"].read(pc2.buf)["dont_run"], "pp STOPped on pc2")
        lost_bit = 1 << list(layout.PROCESSES).index("pc2")

        def pc2_lost() -> bool:
            return bool(read_whole(layout.PROCESSES["pc1"], pc1.buf)["lost"] & lost_bit)

        assert not pc2_lost()
        hosts["pc2"].send_signal(signal.SIGSTOP)  # a partition: pc2 silent, its link open
        wait_for(pc2_lost, "pc1 reports pc2 lost")
        # halt_all: vg, co and sec in their safe state; co's HALT then runs vg's HALT table,
        # and the root reports ERROR(LOST) (docs/semantics.md, "Fail safe")
        wait_for(
            lambda: layout.STATUS_OUT["sec"].read(pc1.buf)["status"] == contract.ERROR,
            "the root, sec, reports ERROR",
        )
        sec = read_whole(layout.STATUS_OUT["sec"], pc1.buf)
        assert (sec["status"], sec["error_num"]) == (contract.ERROR, 1)  # LOST_SUBORDINATE
        hosts["pc2"].send_signal(signal.SIGCONT)
        wait_for(lambda: not pc2_lost(), "pc2 re-joins")
        hosts["pc2"].send_signal(signal.SIGKILL)
        hosts["pc2"].wait(10)
        wait_for(pc2_lost, "pc1 reports the killed pc2 lost")
        hosts["pc1"].terminate()
        assert hosts["pc1"].wait(15) == 0
    finally:
        pc1.close()
        pc2.close()
    assert not rcs(miner, "rcs.block").exists(segments["pc1"])  # pc1 removed its own
    rcs(miner, "rcs.block").unlink(segments["pc2"])
    assert shm_files() - before == set()
    assert listening(ports) == set()


def test_a_latch_or_force_made_on_any_host_holds_on_the_host_that_writes_the_actuator(
    miner: ModuleType, two_hosts: dict[str, object]
) -> None:
    """An operator's node on a third "host" (connected to pc2 only) sends BOX_CUT; while pc1
    drives the miner, the operator forces boom_rate_cmd and then latches every actuator on
    their own block: the override travels to pc1, whose modules hold the forced value and
    then the safe values (the actuator fields in pc1's block, the writer's), and to pc2; a
    reset there releases them on pc1. Then pc2 is cut off (SIGSTOP): pc1, the writer, latches
    every actuator itself, and pc2, back, receives pc1's latches."""
    layout = rcs(miner, "layout")
    block_module, override = rcs(miner, "rcs.block"), rcs(miner, "rcs.override")
    launcher_module, zenoh_transport = (
        rcs(miner, "rcs.operate.launcher"),
        rcs(miner, "rcs.zenoh_transport"),
    )
    hosts, segments = two_hosts["hosts"], two_hosts["segments"]
    safe = {f: ("SAFE", v) for f, v in layout.SAFE_VALUES.items()}

    def attach(name: str) -> object:
        return wait_for(attached(block_module, layout, segments[name]), f"{name}'s segment")

    def world(block: object, field: str) -> object:
        return read_whole(layout.WORLD[field], block.buf)[field]

    def moving(block: object) -> bool:
        return any(world(block, f) != v for f, v in layout.SAFE_VALUES.items())

    def at_safe(block: object) -> bool:
        return override.overrides(layout, block.buf) == safe and not moving(block)

    pc1, pc2 = attach("pc1"), attach("pc2")
    at_pc2 = f"tcp/127.0.0.1:{two_hosts['ports']['pc2']}"
    operator = zenoh_transport.Attached(layout, zenoh_transport.Options(connect=(at_pc2,)))
    mine = operator.block.buf
    try:
        send = launcher_module.parse_send(layout, "sec.BOX_CUT:depth=1.5")
        wait_for(lambda: launcher_module.give(send, layout, mine), "sec ready for BOX_CUT")
        wait_for(lambda: moving(pc1), "pc1 drives the miner", deadline=60)
        override.force(layout, mine, "boom_rate_cmd", 0.25)
        wait_for(lambda: world(pc1, "boom_rate_cmd") == 0.25, "the force holds on pc1")
        beat = read_whole(layout.PROCESSES["pc1"], pc1.buf)["heartbeat"]
        wait_for(lambda: layout.PROCESSES["pc1"].read(pc1.buf)["heartbeat"] > beat + 5, "pc1")
        assert world(pc1, "boom_rate_cmd") == 0.25, "pc1's module does not overwrite it"
        assert override.overrides(layout, pc1.buf) == {"boom_rate_cmd": ("FORCED", 0.25)}
        override.latch_safe(layout, mine, layout.SAFE_VALUES)
        wait_for(lambda: at_safe(pc1), "every actuator latched safe on pc1, the writer")
        wait_for(lambda: override.overrides(layout, pc2.buf) == safe, "and mirrored on pc2")
        beat = read_whole(layout.PROCESSES["pc1"], pc1.buf)["heartbeat"]
        wait_for(lambda: layout.PROCESSES["pc1"].read(pc1.buf)["heartbeat"] > beat + 5, "pc1")
        assert at_safe(pc1), "held while pc1 runs its BOX_CUT"
        assert override.reset(layout, mine) == list(layout.SAFE_VALUES)
        wait_for(lambda: not override.overrides(layout, pc1.buf), "released on pc1")
        assert not pc1.buf[layout.OVERRIDDEN_AT], "pc1's modules no longer look"
        hosts["pc2"].send_signal(signal.SIGSTOP)  # pc1 loses its link to pc2
        wait_for(lambda: at_safe(pc1), "pc1 latches every actuator it writes")
        hosts["pc2"].send_signal(signal.SIGCONT)
        wait_for(lambda: override.overrides(layout, pc2.buf) == safe, "pc2, back, sees them")
    finally:
        hosts["pc2"].send_signal(signal.SIGCONT)
        operator.close()
        pc1.close()
        pc2.close()


def test_one_command_runs_the_box_cut_with_the_path_planner_on_a_second_host() -> None:
    """`python -m miner --transport zenoh`: pc1 and pc2 free-running (not paced), each on a
    block of its own, connected only through Zenoh; the operator's BOX_CUT, given through
    the launcher's mirror, ends DONE at the depth of the one-process run."""
    before = shm_files()
    done = subprocess.run(
        [sys.executable, "-m", "miner", "--transport", "zenoh", "--fast"]
        + ["--shm", f"rcsgen_zenoh_{os.getpid()}_launch"]
        + ["--set", "map=maps/box_cut.map", "--set", "seed=7"]
        + ["--send", "sec.BOX_CUT:depth=1.5", "--until-done", "--report", "depth_cut"],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == ["sec DONE #2", "depth_cut = 1.5"], done.stdout
    assert any(line.startswith("pc2: stopped, ") for line in lines), done.stdout
    assert shm_files() - before == set()


def test_the_monitor_attaches_through_zenoh(
    miner: ModuleType, two_hosts: dict[str, object]
) -> None:
    """`rcsgen monitor --connect`: the live screen over a block mirrored through Zenoh shows
    the modules of both hosts, and its keys act on a module on the other host."""
    import asyncio

    from rcsgen.tools.monitor import Monitor

    layout = rcs(miner, "layout")
    endpoint = f"tcp/127.0.0.1:{two_hosts['ports']['pc1']}"

    async def drive() -> list[str]:
        app = Monitor(layout, "unused", interval=0.1, role="engineer", connect=(endpoint,))
        # attached only once both running processes had sent everything they wrote, so the
        # first screen is whole (pp's command, written on pc1, with pp's status, from pc2)
        assert app.ctl.attached.net.synced == {"pc1", "pc2"}
        assert app.ctl.modules()["pp"]["command"] == "INIT"
        seen = []
        async with app.run_test(size=(160, 40)) as pilot:
            await until(  # pp (on pc2) has reported its INIT
                pilot, lambda: app.ctl.modules()["pp"].get("status") == "DONE", "pp's INIT DONE"
            )
            seen.append(app.ctl.modules()["pp"].get("status"))
            while app.selected() != "pp":
                await pilot.press("down")
            await pilot.press("s")  # stop pp, on pc2, from here
            message = app.query_one("#message")
            await until(pilot, lambda: str(message.render()) == "pp: STOP", "pp: STOP said")
            seen.append(app.sub_title)
        return seen

    status, title = asyncio.run(drive())
    assert status == "DONE"
    assert title == f"miner on zenoh {endpoint} as engineer"
    block = rcs(miner, "rcs.block").Block(layout, two_hosts["segments"]["pc2"], create=False)
    try:
        wait_for(lambda: layout.MODE_IN["pp"].read(block.buf)["dont_run"], "pp STOPped on pc2")
    finally:
        block.close()


# ---------------------------------------------------------------- a cut link


RELAY = ROOT / "tests" / "support" / "tcp_relay.py"


@pytest.fixture
def through_a_relay() -> Iterator[dict[str, object]]:
    """pc2 listening; pc1 reaching it only through a TCP relay (tests/support/tcp_relay.py), the
    "network" that the test cuts and mends while both hosts keep running. pc1 does not
    listen, so pc2 has no other way to it."""
    pid = os.getpid()
    port = free_port()
    segments = {name: f"rcsgen_zenoh_{pid}_cut_{name}" for name in ("pc1", "pc2")}
    env = {**os.environ, "PYTHONPATH": str(HOOKS)}
    command = [sys.executable, "-m", "miner"]
    running: dict[str, subprocess.Popen[str]] = {}
    try:
        running["pc2"] = subprocess.Popen(
            [*command, "pc2", "--transport", "zenoh", "--shm", segments["pc2"]]
            + ["--listen", f"tcp/127.0.0.1:{port}"],
            cwd=PACKAGE.parent,
            env=env,
            stdout=subprocess.DEVNULL,
        )
        running["relay"] = subprocess.Popen(
            [sys.executable, str(RELAY), str(port)], stdout=subprocess.PIPE, text=True
        )
        assert running["relay"].stdout is not None
        relay_port = int(running["relay"].stdout.readline())
        running["pc1"] = subprocess.Popen(
            [*command, "pc1", "--transport", "zenoh", "--shm", segments["pc1"]]
            + ["--connect", f"tcp/127.0.0.1:{relay_port}"],
            cwd=PACKAGE.parent,
            env=env,
            stdout=subprocess.DEVNULL,
        )
        yield {"running": running, "ports": {port, relay_port}, "segments": segments}
    finally:
        for each in running.values():
            if each.poll() is None:
                each.terminate()
        for each in running.values():
            try:
                each.wait(10)
            except subprocess.TimeoutExpired:
                each.kill()
                each.wait()
            if each.stdout is not None:
                each.stdout.close()
        unlink = rcs(import_package(PACKAGE, HOOKS), "rcs.block").unlink
        for name in segments.values():
            unlink(name)


def test_a_cut_link_is_detected_contained_and_mended(
    miner: ModuleType, through_a_relay: dict[str, object]
) -> None:
    """The link between the hosts goes silent (no connection closed, neither host stopped):
    pc1 reports pc2 lost after its heartbeat timeout, vg goes to its safe state, and pc1,
    which writes every actuator, latches them all at their safe values in its own block
    (a process that loses its link latches what it writes); pc2 sees pc1's token go (its
    control record DEAD in pc2's block). While the link is out
    nobody re-joins by another way; when it is back, both re-join. Afterwards nothing is
    left in /dev/shm, listening or running."""
    layout = rcs(miner, "layout")
    block_module, contract = rcs(miner, "rcs.block"), rcs(miner, "rcs.contract")
    running: dict[str, subprocess.Popen[str]] = through_a_relay["running"]
    segments: dict[str, str] = through_a_relay["segments"]
    ports: set[int] = through_a_relay["ports"]
    before = shm_files()

    def attach(name: str) -> object:
        return wait_for(attached(block_module, layout, segments[name]), f"{name}'s segment")

    pc1, pc2 = attach("pc1"), attach("pc2")
    lost_bit = 1 << list(layout.PROCESSES).index("pc2")

    def pc2_lost_on_pc1() -> bool:
        return bool(read_whole(layout.PROCESSES["pc1"], pc1.buf)["lost"] & lost_bit)

    def pc1_state_on_pc2() -> int:
        return int(read_whole(layout.PROCESSES["pc1"], pc2.buf)["state"])

    override = rcs(miner, "rcs.override")

    def latched_safe(block: object) -> bool:
        safe = {f: ("SAFE", v) for f, v in layout.SAFE_VALUES.items()}
        world = {f: read_whole(layout.WORLD[f], block.buf)[f] for f in layout.SAFE_VALUES}
        return override.overrides(layout, block.buf) == safe and world == layout.SAFE_VALUES

    try:
        wait_for(
            lambda: layout.STATUS_OUT["pp"].read(pc1.buf)["status"] == contract.DONE,
            "pp's INIT done, mirrored on pc1 through the relay",
        )
        assert pc1_state_on_pc2() == contract.RUNNING
        for _ in range(2):  # cut and mended twice: the second cut finds a mended link
            running["relay"].send_signal(signal.SIGUSR1)  # the cable is pulled
            wait_for(pc2_lost_on_pc1, "pc1 reports pc2 lost")
            wait_for(  # halt_all: the root reports ERROR(LOST) (docs/semantics.md, "Fail safe")
                lambda: layout.STATUS_OUT["sec"].read(pc1.buf)["status"] == contract.ERROR,
                "the root, sec, reports ERROR",
            )
            sec = read_whole(layout.STATUS_OUT["sec"], pc1.buf)
            assert (sec["status"], sec["error_num"]) == (contract.ERROR, 1)  # LOST_SUBORDINATE
            wait_for(lambda: latched_safe(pc1), "pc1 latches every actuator it writes")
            wait_for(lambda: pc1_state_on_pc2() == contract.DEAD, "pc2 sees pc1's token go")
            assert all(each.poll() is None for each in running.values())  # nobody stopped
            for _ in range(10):  # while it is out, no way around it
                time.sleep(0.1)
                assert pc2_lost_on_pc1() and pc1_state_on_pc2() == contract.DEAD
            running["relay"].send_signal(signal.SIGUSR2)  # the cable is back
            wait_for(lambda: not pc2_lost_on_pc1(), "pc1 sees pc2 again")
            wait_for(lambda: pc1_state_on_pc2() == contract.RUNNING, "pc2 sees pc1 again")
        for name in ("pc1", "pc2", "relay"):
            running[name].terminate()
            assert running[name].wait(15) == 0
    finally:
        pc1.close()
        pc2.close()
    assert not any(block_module.exists(name) for name in segments.values())
    assert shm_files() - before == set()
    assert listening(ports) == set()
