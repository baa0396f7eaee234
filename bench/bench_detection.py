"""Part 7: how long the runtime takes to notice a lost subordinate: the detection bounds.

On tests/fixtures/runtime/duo: a supervisor `top` in process p1 commanding an `arm` in
process p2, cycle period 0.02 s, heartbeat_timeout 0.3 s, arm's echo timeout 5 cycles.

1. Heartbeat loss -> safe state. The system runs as two OS processes, paced, under the
   launcher; top holds arm (RUN, arm in S1). p2 is killed (SIGKILL); p1 stops hearing its
   heartbeat and top goes to its safe state: HALT to arm, status ERROR with error_num 1
   (subordinate lost). Measured on the wall clock from the kill to ERROR appearing in
   top's status buffer (polled every 0.5 ms), over `--runs` runs. The launcher is not
   polled meanwhile: its poll would mark p2 DEAD at once, which is the other path (run
   with `--watched` too: the launcher polls every 0.05 s as `python -m <system>` does).
2. The subordinate echo timeout. (a) In one process (the harness on p1 alone, arm never
   runs): cycles from the cycle in which top sent MOVE to the cycle at whose end top
   reports ERROR, which should be the declared limit. (b) The same paced over two OS
   processes with p2 stopped (SIGSTOP: alive, silent): p1 cycles (its heartbeat counter)
   and wall time from the send to ERROR, before the heartbeat timeout could fire.

Every launched system is stopped, its segment removed, on the way out.

    python bench/bench_detection.py [--runs N] [--json PATH]
"""

from __future__ import annotations

import argparse
import importlib
import os
import shutil
import signal
import statistics
import sys
import threading
import time
from types import ModuleType

from common import ROOT, read_whole, write_json

from rcsgen.tools.harness import Harness, generate, import_package

DUO = ROOT / "tests" / "fixtures" / "runtime" / "duo"
RUNS = 10
POLL = 0.0005  # seconds between two looks at top's status
DEADLINE = 20.0  # seconds a paced system gets to react before the run gives up
ERROR = 3


def wait_for(condition, what: str, deadline: float = DEADLINE, poll: float = 0.005) -> None:
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        if condition():
            return
        time.sleep(poll)
    raise SystemExit(f"gave up waiting: {what}")


class Duo:
    """The duo system, generated once into a scratch directory."""

    def __init__(self) -> None:
        self.scratch, name = generate(DUO)
        self.dir = self.scratch / name
        self.package = import_package(self.dir, DUO)
        self.layout = self.module("layout")
        self.launcher = self.module("rcs.operate.launcher")
        self.system = self.launcher.System(
            self.dir.name,
            self.layout,
            {p: self.module(f"main_{p}").PLAN for p in self.layout.PROCESSES},
            (str(self.dir.parent), str(DUO)),
        )
        self.segments = 0

    def module(self, name: str) -> ModuleType:
        return importlib.import_module(f"{self.package.__name__}.{name}")

    def launch(self):
        """The system as OS processes, paced, both beating."""
        self.segments += 1
        launcher = self.launcher.Launcher(
            self.system, f"rcsgen_bench_detect_{os.getpid()}_{self.segments}"
        )
        launcher.start()
        try:
            buf, processes = launcher.block.buf, self.layout.PROCESSES
            wait_for(
                lambda: all(self.read(processes[p], buf)["heartbeat"] > 2 for p in ("p1", "p2")),
                "both processes running",
            )
        except BaseException:
            launcher.stop()
            raise
        return launcher

    def read(self, record, buf) -> dict:
        """A buffer the running processes write, read whole: Record.read gives up (StaleRead)
        when its writer is writing, or was descheduled mid-write, so try again."""
        return read_whole(record, buf, DEADLINE, POLL)

    def command(self, buf, module: str, command: str) -> None:
        record = self.layout.COMMAND_IN[module]
        number = self.read(record, buf)["command_num"] + 1
        names = self.layout.COMMAND_NAMES[module]
        record.write(buf, command_num=number, command=names.index(command))

    def status(self, buf, module: str) -> dict:
        return self.read(self.layout.STATUS_OUT[module], buf)

    def close(self) -> None:
        shutil.rmtree(self.scratch, ignore_errors=True)


def heartbeat_loss(duo: Duo, runs: int, watched: bool) -> list[dict[str, float]]:
    """Kill p2 while top holds arm: seconds from the kill to top's ERROR, per run."""
    layout = duo.layout
    results = []
    for _ in range(runs):
        launcher = duo.launch()
        stop_polling = threading.Event()
        poller = None
        try:
            buf = launcher.block.buf
            duo.command(buf, "top", "RUN")
            wait_for(
                lambda buf=buf: duo.status(buf, "arm").get("state") == 2, "arm holding (RUN S1)"
            )
            time.sleep(0.05)  # a few periods of the steady hold
            p2 = launcher.children["p2"].popen
            if watched:  # as `python -m <system>` does: the launcher polls its children

                def poll(stop=stop_polling, launcher=launcher) -> None:
                    while not stop.wait(0.05):
                        launcher.poll()

                poller = threading.Thread(target=poll, daemon=True)
                poller.start()
            p2.send_signal(signal.SIGKILL)
            killed = time.perf_counter()
            end = killed + DEADLINE
            while duo.status(buf, "top").get("status") != ERROR:
                if time.perf_counter() > end:
                    raise SystemExit("top never reported ERROR after p2 was killed")
                time.sleep(POLL)
            seen = time.perf_counter()
            top = duo.status(buf, "top")
            sent = duo.read(layout.COMMAND_IN["arm"], buf)
            record = duo.read(layout.PROCESSES["p1"], buf)
            results.append(
                {
                    "seconds": seen - killed,
                    "error_num": top["error_num"],
                    "halt_sent": layout.COMMAND_NAMES["arm"][sent["command"]] == "HALT",
                    "p2_reported_lost": bool(record["lost"] & 0b10),
                }
            )
        finally:
            stop_polling.set()
            if poller is not None:
                poller.join()
            launcher.stop()
    return results


def echo_in_process(duo: Duo) -> dict[str, int]:
    """Cycles from the cycle top sent MOVE (arm never runs) to the cycle top reports ERROR."""
    h = Harness(duo.package, "p1")
    h.command("top", "MOVE")
    sent_in = error_in = None
    for cycle in range(1, 100):
        h.cycle()
        if sent_in is None and h.sent("arm").number == 1:
            sent_in = cycle
        if h.status("top").status == "ERROR":
            error_in = cycle
            break
    if sent_in is None or error_in is None:
        raise SystemExit("top did not send, or never reported ERROR")
    limit = duo.module("top").ARM_ECHO_CYCLES
    return {"declared_cycles": limit, "cycles_from_send_to_error": error_in - sent_in}


def echo_stopped(duo: Duo, runs: int) -> list[dict[str, float]]:
    """p2 stopped (alive, silent): p1 cycles and seconds from top's send to its ERROR."""
    layout = duo.layout
    results = []
    for _ in range(runs):
        launcher = duo.launch()
        p2 = launcher.children["p2"].popen
        try:
            buf = launcher.block.buf
            p2.send_signal(signal.SIGSTOP)
            time.sleep(0.05)
            before = duo.read(layout.COMMAND_IN["arm"], buf)["command_num"]
            duo.command(buf, "top", "MOVE")
            end = time.monotonic() + DEADLINE
            while duo.read(layout.COMMAND_IN["arm"], buf)["command_num"] == before:
                if time.monotonic() > end:
                    raise SystemExit("top never sent MOVE's POWER")
                time.sleep(POLL)
            sent = time.perf_counter()
            beat_at_send = duo.read(layout.PROCESSES["p1"], buf)["heartbeat"]
            while duo.status(buf, "top").get("status") != ERROR:
                if time.monotonic() > end:
                    raise SystemExit("top never reported ERROR with arm silent")
                time.sleep(POLL)
            seen = time.perf_counter()
            beat_at_error = duo.read(layout.PROCESSES["p1"], buf)["heartbeat"]
            top = duo.status(buf, "top")
            results.append(
                {
                    "seconds": seen - sent,
                    "p1_cycles": beat_at_error - beat_at_send,
                    "error_num": top["error_num"],
                }
            )
        finally:
            if p2.poll() is None:
                p2.send_signal(signal.SIGCONT)
            launcher.stop()
    return results


def summary(values: list[float]) -> dict[str, float]:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=RUNS)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    started = time.perf_counter()
    duo = Duo()
    try:
        layout = duo.layout
        lost = heartbeat_loss(duo, args.runs, watched=False)
        watched = heartbeat_loss(duo, max(3, args.runs // 2), watched=True)
        in_process = echo_in_process(duo)
        stopped = echo_stopped(duo, max(3, args.runs // 2))
    finally:
        duo.close()
    results = {
        "system": str(DUO.relative_to(ROOT)),
        "cycle_period_s": duo.package.CYCLE_PERIOD,
        "heartbeat_timeout_s": layout.HEARTBEAT_TIMEOUT,
        "heartbeat_loss": {
            "runs": lost,
            "seconds": summary([r["seconds"] for r in lost]),
            "all_safe": all(
                r["error_num"] == 1 and r["halt_sent"] and r["p2_reported_lost"] for r in lost
            ),
        },
        "heartbeat_loss_watched": {
            "runs": watched,
            "seconds": summary([r["seconds"] for r in watched]),
            "all_safe": all(r["error_num"] == 1 and r["halt_sent"] for r in watched),
        },
        "echo_in_process": in_process,
        "echo_stopped": {
            "runs": stopped,
            "seconds": summary([r["seconds"] for r in stopped]),
            "p1_cycles": summary([r["p1_cycles"] for r in stopped]),
        },
        "seconds": time.perf_counter() - started,
    }
    write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
