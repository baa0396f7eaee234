"""Part 8: the same buffers over Zenoh on loopback, against shared memory.

1. One buffer hop: this process writes pp's command and sends it, an echo process (its
   own block, over Zenoh; or attached to the same segment, polling) answers with pp's
   status; the round trip, halved. Zenoh: the runtime's own `ZenohTransport` on both
   sides (the receiver blocks until something arrives); shared memory: the echo polls the
   record flat out, so its figure is the floor of a hop. Beside them, Zenoh alone: the
   same payload (one push of pp's command) between bare zenoh-python sessions configured
   as a node is, each end's callback handing the sample to its waiting thread through a
   queue as the runtime's does, and no rcsgen code: what the runtime adds is the
   difference (bench/prototypes/zenoh_hop_ab.py takes it apart).
2. Records per second one process sends (world fields, a push per round of the float
   fields, each push one Zenoh message; every push sent and none dropped, as in lockstep)
   and how many arrive.
3. The two-host miner in lockstep (`LaunchedHarness(transport="zenoh")`: pc1 and pp's pc2
   on blocks of their own, stepped by a coordinator on the network) against the same
   over one segment (pipes) and in one process: wall time per system cycle, the versions
   taking turns and ending each round in the same state (bench_lockstep.race).
4. A chain of 16 controllers over 2, 4 and 8 hosts in lockstep, Zenoh against pipes.
5. Detection on two free-running paced hosts (pc2 listening, pc1 connecting through a TCP
   relay, tests/support/tcp_relay.py): time from a cut of the link (the relay delivers nothing
   more, closes nothing), from SIGSTOP of pc2 (a frozen host) and from SIGKILL of pc2 to
   pc1's control record saying pc2 is lost; from the link mended and from SIGCONT to pc2
   re-joined; and over a soak, pc1's overruns.

    python bench/bench_zenoh.py [--hops N] [--cycles N] [--soak S] [--json PATH]
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import queue
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

from bench_lockstep import CHAIN, Driver, race, stats
from common import ROOT, read_whole, write_json

from rcsgen.runtime import contract
from rcsgen.tools import scenario as scenarios
from rcsgen.tools.harness import Harness, LaunchedHarness, generate, import_package

PACKAGE = ROOT / "generated" / "miner"
HOOKS = ROOT / "specs" / "miner"
SCENARIO = HOOKS / "scenarios" / "sump_shear_cusp.yaml"
SPLITS = (2, 4, 8)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def modules(package: ModuleType) -> tuple[ModuleType, ModuleType, ModuleType, ModuleType]:
    name = package.__name__
    return tuple(
        importlib.import_module(f"{name}.{m}")
        for m in ("layout", "rcs.block", "rcs.transport", "rcs.zenoh_transport")
    )  # type: ignore[return-value]


def percentile(values: list[int], share: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(share * len(ordered)))]


# ---------------------------------------------------------------- 1, 2: hop and rate


BARE_END = b"end"  # the bare echo's last message: it leaves


def bare_session(zt: ModuleType, options: object) -> tuple[object, queue.SimpleQueue[bytes]]:
    """A zenoh-python session configured as a node is (`config_json`), and the queue its
    subscriber's callback hands each sample to."""
    import zenoh

    config = zenoh.Config()
    for key, value in zt.config_json(options).items():
        config.insert_json5(key, json.dumps(value))
    return zenoh.open(config), queue.SimpleQueue()


def bare_echo(where: str) -> None:
    """The far end of the bare hop: every message back as it came, until BARE_END."""
    import zenoh

    _, _, _, zt = modules(import_package(PACKAGE, HOOKS))
    session, inbox = bare_session(zt, zt.Options(connect=(where,)))
    block = zenoh.CongestionControl.BLOCK
    pong = session.declare_publisher("bench/pong", congestion_control=block)
    session.declare_subscriber("bench/ping", lambda sample: inbox.put(sample.payload.to_bytes()))
    while (data := inbox.get(timeout=60)) != BARE_END:
        pong.put(data)
    session.close()


def bare_round_trips(zt: ModuleType, where: str, data: bytes, count: int) -> list[int]:
    """The bare hop's round trips (`count` after 50 to warm up), once the echo answers."""
    import zenoh

    session, inbox = bare_session(zt, zt.Options(listen=(where,)))
    block = zenoh.CongestionControl.BLOCK
    session.declare_subscriber("bench/pong", lambda sample: inbox.put(sample.payload.to_bytes()))
    ping = session.declare_publisher("bench/ping", congestion_control=block)
    try:
        for _ in range(150):  # until the echo is connected and answers (30 s at most)
            ping.put(b"hello")
            try:
                inbox.get(timeout=0.2)
                break
            except queue.Empty:
                pass
        else:
            raise SystemExit("zenoh alone: the echo did not answer within 30 s")
        time.sleep(0.3)  # the answers to the other hellos, then none
        while not inbox.empty():
            inbox.get_nowait()
        rtts = []
        for number in range(count + 50):
            began = time.perf_counter_ns()
            ping.put(data)
            inbox.get(timeout=10.0)
            if number >= 50:
                rtts.append(time.perf_counter_ns() - began)
        ping.put(BARE_END)
    finally:
        session.close()
    return rtts


def echo(kind: str, where: str, count: int) -> None:
    """The far end: answer each new pp command with pp's status (status_num = its number)."""
    if kind == "bare":
        bare_echo(where)
        return
    layout, block_mod, transport, zt = modules(import_package(PACKAGE, HOOKS))
    command, status = layout.COMMAND_IN["pp"], layout.STATUS_OUT["pp"]
    if kind == "shm":
        block = block_mod.Block(layout, where, create=False)
        seen = 0
        while seen < count:
            try:
                number = command.read(block.buf)["command_num"]
            except Exception:  # noqa: BLE001 - a torn read: look again
                continue
            if number != seen:
                seen = number
                status.write(block.buf, status_num=number)
        block.close()
        return
    block = block_mod.Block(layout)
    net = zt.ZenohTransport(
        transport.Mirror(layout, block), zt.Options(connect=(where,)), block_when_congested=True
    )
    seen = 0
    while seen < count:
        net.wait(lambda seen=seen: command.read(block.buf)["command_num"] != seen, 30.0)
        seen = command.read(block.buf)["command_num"]
        status.write(block.buf, status_num=seen)
        net.push()
    time.sleep(0.5)
    net.close()
    block.close()


def echoed(status: object, buf: memoryview, number: int) -> bool:
    try:
        return status.read(buf)["status_num"] == number  # type: ignore[attr-defined]
    except Exception:  # noqa: BLE001 - StaleRead: being written, look again
        return False


def hops(count: int) -> dict[str, dict[str, float]]:
    package = import_package(PACKAGE, HOOKS)
    layout, block_mod, transport, zt = modules(package)
    command, status = layout.COMMAND_IN["pp"], layout.STATUS_OUT["pp"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HOOKS), *sys.path])}
    results = {}
    for kind in ("shm", "bare", "zenoh"):
        if kind == "bare":
            where = f"tcp/127.0.0.1:{free_port()}"
            child = subprocess.Popen(
                [sys.executable, __file__, "--echo", kind, where, "0"], env=env
            )
            try:
                rtts = bare_round_trips(
                    zt, where, bare_payload(layout, block_mod, transport), count
                )
                child.wait(30)
            finally:
                if child.poll() is None:
                    child.kill()
                    child.wait()
            results[kind] = summary(rtts)
            print("hop over zenoh alone done", file=sys.stderr)
            continue
        if kind == "shm":
            where = f"rcsgen_bench_zenoh_{os.getpid()}"
            block = block_mod.Block(layout, where, create=True)
            net = None
        else:
            where = f"tcp/127.0.0.1:{free_port()}"
            block = block_mod.Block(layout)
            net = zt.ZenohTransport(
                transport.Mirror(layout, block),
                zt.Options(listen=(where,)),
                block_when_congested=True,
            )
        child = subprocess.Popen(
            [sys.executable, __file__, "--echo", kind, where, str(count + 50)], env=env
        )
        try:
            rtts = []
            if net is not None:  # the echo's node is up when its token arrives
                net.wait(lambda net=net: len(net.joined) > 1, 30.0)  # itself and the echo
                time.sleep(0.5)
            for number in range(1, count + 51):
                began = time.perf_counter_ns()
                command.write(block.buf, command_num=number)
                if net is None:
                    while not echoed(status, block.buf, number):
                        pass
                else:
                    net.push()
                    if not net.wait(
                        lambda n=number, block=block: status.read(block.buf)["status_num"] == n,
                        10.0,
                    ):
                        raise SystemExit(f"zenoh: no echo of #{number}")
                if number > 50:  # the first ones warm up
                    rtts.append(time.perf_counter_ns() - began)
            child.wait(30)
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
            if net is not None:
                net.close()
            block.close()
        results[kind] = summary(rtts)
        print(f"hop over {kind} done", file=sys.stderr)
    return results


def summary(rtts: list[int]) -> dict[str, float]:
    """A hop's figures from its round trips: each halved."""
    return {
        "median_ns": statistics.median(rtts) / 2,
        "p99_ns": percentile(rtts, 0.99) / 2,
        "round_trips": len(rtts),
    }


def bare_payload(layout: ModuleType, block_mod: ModuleType, transport: ModuleType) -> bytes:
    """What the runtime's hop carries: one push of pp's command, as `Mirror.pack` makes it."""
    block = block_mod.Block(layout)
    try:
        mirror = transport.Mirror(layout, block)
        mirror.changed()  # the records as a block starts: not this push
        layout.COMMAND_IN["pp"].write(block.buf, command_num=1)
        return bytes(mirror.pack(mirror.changed(slow=False)))
    finally:
        block.close()


def rate(messages: int) -> dict[str, float]:
    """One process sends world fields (each changed, a push per round of them) flat out to
    another node; the records it sent per second, and those that arrived."""
    package = import_package(PACKAGE, HOOKS)
    layout, block_mod, transport, zt = modules(package)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sender_block, receiver_block = block_mod.Block(layout), block_mod.Block(layout)
    # As lockstep nodes: every push goes (no 5 ms coalescing) and waits rather than drops,
    # so the figure is what one process sustains, none lost.
    receiver = zt.ZenohTransport(
        transport.Mirror(layout, receiver_block),
        zt.Options(listen=(endpoint,)),
        block_when_congested=True,
    )
    sender = zt.ZenohTransport(
        transport.Mirror(layout, sender_block),
        zt.Options(connect=(endpoint,)),
        block_when_congested=True,
    )
    try:
        receiver.wait(lambda: len(receiver.joined) > 1, 10.0)
        sender.wait(lambda: len(sender.joined) > 1, 10.0)
        time.sleep(0.5)
        floats = [n for n, v in layout.WORLD_INITIAL.items() if isinstance(v, float)]
        began = time.perf_counter()
        for number in range(messages):
            name = floats[number % len(floats)]
            layout.WORLD[name].write(sender_block.buf, **{name: float(number)})
            if number % len(floats) == len(floats) - 1:
                sender.push()  # one push per "cycle" of every float field
        sender.push()
        sent_s = time.perf_counter() - began
        receiver.wait(lambda: receiver.mirror.counters.applied >= messages, 5.0)
        arrived_s = time.perf_counter() - began
        applied = receiver.mirror.counters.applied
    finally:
        sender.close()
        receiver.close()
    return {
        "messages": messages,
        "sent_per_s": sender.mirror.counters.sent / sent_s,
        "arrived": applied,
        "arrived_per_s": applied / arrived_s,
    }


# ---------------------------------------------------------------- 3, 4: lockstep


def miner(cycles: int, rounds: int) -> dict[str, object]:
    scenario = scenarios.load_scenario(SCENARIO)
    events, stop = list(scenario.events), scenario.stop_when_done or "sb"

    def open_versions() -> dict[str, object]:
        opened: dict[str, object] = {}
        try:
            opened["one process"] = scenarios.open_harness(scenario, PACKAGE)
            opened["shm"] = scenarios.open_harness(scenario, PACKAGE, processes=True)
            opened["zenoh"] = scenarios.open_harness(
                scenario, PACKAGE, processes=True, transport="zenoh"
            )
        except BaseException:
            for harness in opened.values():
                harness.close()  # type: ignore[attr-defined]
            raise
        return opened

    samples = race(open_versions, lambda: Driver(events, stop), cycles, rounds)
    return {key: stats(values) for key, values in samples.items()}


def chain(cycles: int, rounds: int) -> list[dict[str, object]]:
    import synthetic

    results = []
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-bench-zenoh-"))
    try:
        for count in SPLITS:
            spec = synthetic.write(CHAIN, scratch / f"p{count}", processes=count, fan_out=1)
            out, name = generate(spec)
            package_dir = out / name
            root = synthetic.name(0)
            run = scenarios.Event(cycle=1, command=(root, "RUN"))

            def open_versions(package_dir: Path = package_dir) -> dict[str, object]:
                one = Harness.load(package_dir, send_init=True)
                try:
                    shm = LaunchedHarness(package_dir)
                    try:
                        zenoh = LaunchedHarness(package_dir, transport="zenoh")
                    except BaseException:
                        shm.close()
                        raise
                except BaseException:
                    one.close()
                    raise
                return {"one process": one, "shm": shm, "zenoh": zenoh}

            def driver(run: scenarios.Event = run, root: str = root) -> Driver:
                return Driver([run], root)

            samples = race(open_versions, driver, cycles, rounds)
            shutil.rmtree(out, ignore_errors=True)
            results.append(
                {"hosts": count, **{key: stats(values) for key, values in samples.items()}}
            )
            print(f"chain over {count} hosts done", file=sys.stderr)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return results


# ---------------------------------------------------------------- 5: detection


def detection(runs: int, soak: float) -> dict[str, object]:
    package = import_package(PACKAGE, HOOKS)
    layout, block_mod, _, _ = modules(package)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(HOOKS), *sys.path])}
    lost_bit = 1 << list(layout.PROCESSES).index("pc2")
    found: dict[str, list[float]] = {
        "cut_s": [],
        "mend_s": [],
        "partition_s": [],
        "rejoin_s": [],
        "kill_s": [],
    }
    soaked: dict[str, object] = {}
    for run in range(runs):
        ports = {"pc2": free_port(), "pc1": free_port()}
        names = {p: f"rcsgen_bench_zenoh_{os.getpid()}_{run}_{p}" for p in ports}
        base = [sys.executable, "-m", "miner"]
        relay = subprocess.Popen(
            [sys.executable, str(ROOT / "tests" / "support" / "tcp_relay.py"), str(ports["pc2"])],
            stdout=subprocess.PIPE,
            text=True,
        )
        assert relay.stdout is not None
        relay_port = int(relay.stdout.readline())
        hosts = {
            "pc2": subprocess.Popen(
                [*base, "pc2", "--transport", "zenoh", "--shm", names["pc2"]]
                + ["--listen", f"tcp/127.0.0.1:{ports['pc2']}"],
                cwd=PACKAGE.parent,
                env=env,
                stdout=subprocess.DEVNULL,
            ),
            "pc1": subprocess.Popen(
                [*base, "pc1", "--transport", "zenoh", "--shm", names["pc1"]]
                + ["--connect", f"tcp/127.0.0.1:{relay_port}"],
                cwd=PACKAGE.parent,
                env=env,
                stdout=subprocess.DEVNULL,
            ),
        }
        block = None
        try:
            end = time.monotonic() + 30
            while block is None and time.monotonic() < end:
                try:
                    block = block_mod.Block(layout, names["pc1"], create=False)
                except block_mod.BlockError:
                    time.sleep(0.05)
            assert block is not None, "pc1 did not start"

            def lost(block: object = block) -> bool:
                return bool(layout.PROCESSES["pc1"].read(block.buf)["lost"] & lost_bit)

            def until(condition, limit: float = 30.0) -> float:
                began = time.perf_counter()
                while not settled(condition):
                    if time.perf_counter() - began > limit:
                        raise SystemExit("detection: gave up waiting")
                    time.sleep(0.001)
                return time.perf_counter() - began

            def settled(condition) -> bool:
                """The condition, or False for a record caught mid-write (polled again)."""
                try:
                    return bool(condition())
                except contract.StaleRead:
                    return False

            until(lambda block=block: layout.STATUS_OUT["pp"].read(block.buf)["status"] == 2)
            if run == 0 and soak > 0:
                time.sleep(soak)
                record = read_whole(layout.PROCESSES["pc1"], block.buf)
                soaked = {
                    "seconds": soak,
                    "cycles": record["heartbeat"],
                    "overruns": record["overruns"],
                    "late_wakeups": record["late_wakeups"],
                    "pc2_lost_during": bool(record["lost"] & lost_bit),
                }
            time.sleep(0.5)
            relay.send_signal(signal.SIGUSR1)
            found["cut_s"].append(until(lost))
            relay.send_signal(signal.SIGUSR2)
            found["mend_s"].append(until(lambda: not lost()))
            time.sleep(0.5)
            hosts["pc2"].send_signal(signal.SIGSTOP)
            found["partition_s"].append(until(lost))
            hosts["pc2"].send_signal(signal.SIGCONT)
            found["rejoin_s"].append(until(lambda: not lost()))
            time.sleep(0.5)
            hosts["pc2"].send_signal(signal.SIGKILL)
            found["kill_s"].append(until(lost))
        finally:
            if block is not None:
                block.close()
            for host in hosts.values():
                if host.poll() is None:
                    host.send_signal(signal.SIGCONT)
                    host.terminate()
                try:
                    host.wait(10)
                except subprocess.TimeoutExpired:
                    host.kill()
                    host.wait()
            relay.terminate()
            relay.wait(10)
            relay.stdout.close()
            for name in names.values():
                block_mod.unlink(name)
        print(f"detection run {run + 1}/{runs} done", file=sys.stderr)
    return {
        "heartbeat_timeout_s": layout.HEARTBEAT_TIMEOUT,
        "period_s": 0.1,
        **{key: {"median": statistics.median(v), "max": max(v)} for key, v in found.items()},
        "runs": runs,
        "soak": soaked,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hops", type=int, default=2000)
    parser.add_argument("--messages", type=int, default=60_000)
    parser.add_argument("--cycles", type=int, default=500)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--soak", type=float, default=30.0)
    parser.add_argument("--parts", default="hop,rate,miner,chain,detection")
    parser.add_argument("--echo", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    if args.echo:
        echo(args.echo[0], args.echo[1], int(args.echo[2]))
        return 0
    started = time.perf_counter()
    parts = args.parts.split(",")
    results: dict[str, object] = {"cycles_per_round": args.cycles, "rounds": args.rounds}
    if "hop" in parts:
        results["hop"] = hops(args.hops)
    if "rate" in parts:
        results["rate"] = rate(args.messages)
    if "miner" in parts:
        results["miner"] = miner(args.cycles, args.rounds)
    if "chain" in parts:
        results["chain"] = chain(args.cycles, args.rounds)
    if "detection" in parts:
        results["detection"] = detection(args.runs, args.soak)
    results["seconds"] = time.perf_counter() - started
    write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
