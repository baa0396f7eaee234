"""Time per state (issue 26 item 6; rcs/state_time.py): the loop counts, for every controller,
the cycles its process has run with it in each state, in the block; `ctl status` shows each
controller's share of cycles per state since start. The oracle is the trace: a trace line is
written after each cycle with every module's state, so the counts must be the trace's
states counted, module by module and state by state."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from rcsgen.runtime.block import Block
from rcsgen.runtime.operate.ctl import main
from rcsgen.runtime.state_time import shares, totals
from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import load_scenario, run

ROOT = Path(__file__).resolve().parent.parent
PLATOON = ROOT / "specs" / "platoon"


def block_counts(harness: Harness) -> dict[str, dict[str, int]]:
    """Each controller's cycles per state, as a reader finds them in the block."""
    layout = harness.layout
    found = {}
    for module, record in layout.TIME_IN_STATE.items():
        heartbeat = layout.PROCESSES[layout.PLACEMENT[module]].read(harness.buf)["heartbeat"]
        found[module] = totals(dict(record.read(harness.buf)), heartbeat)
    return found


def test_the_counts_are_the_states_the_trace_shows_and_ctl_status_shows_their_shares(capsys):
    scenario = load_scenario(PLATOON / "scenarios" / "spot_report.yaml")
    with Harness.build(PLATOON, send_init=True) as harness:
        before = block_counts(harness)
        result = run(scenario, harness)
        lines = [json.loads(line)["modules"] for line in result.trace]
        layout = harness.layout
        counted = block_counts(harness)
        assert set(counted) == {m for m in layout.MODULES if "/" not in m}  # no channel
        for module, counts in counted.items():
            seen = Counter(line[module]["state"] for line in lines)
            grew = {s: n - before[module][s] for s, n in counts.items()}
            assert {s: n for s, n in grew.items() if n} == dict(seen), module
        assert dict(Counter(line["pl"]["state"] for line in lines))["DECIDE"] == 7
        name = f"rcsgen_statetime_{id(harness)}"
        block = Block(layout, name)
        try:
            block.buf[: layout.SIZE] = harness.buf[: layout.SIZE]
            assert main(harness.package.__name__, ["--shm", name, "status"]) == 0
            text = capsys.readouterr().out
            assert (
                main(harness.package.__name__, ["--shm", name, "status", "--format", "json"]) == 0
            )
            snapshot = json.loads(capsys.readouterr().out)
        finally:
            block.close()
    pl = counted["pl"]
    total = sum(pl.values())
    expected = ", ".join(f"{s} {share:g}%" for s, share in shares(pl).items())
    assert f"time in state pl ({total} cycles): {expected}" in text.splitlines()
    assert snapshot["modules"]["pl"]["time_in_state"] == shares(pl)
    assert abs(sum(shares(pl).values()) - 100.0) < 0.5
    assert "time_in_state" not in snapshot["modules"]["ldr/pl"]


def test_shares_are_of_the_counted_cycles_and_leave_out_states_never_entered():
    assert shares({"NOP": 0, "S0": 0}) == {}
    assert shares({"NOP": 1, "S0": 0, "S1": 3}) == {"NOP": 25.0, "S1": 75.0}


def test_the_open_interval_runs_to_the_heartbeat_and_a_paused_clock_has_none():
    record = {"state": 2, "since": 10, "NOP": 3, "S0": 1, "S1": 4}
    assert totals(record, 15) == {"NOP": 3, "S0": 1, "S1": 9}
    assert totals({**record, "state": -1}, 15) == {"NOP": 3, "S0": 1, "S1": 4}


def test_a_restarted_process_keeps_the_counts_and_closes_what_it_left_open():
    """A clock made again over the block (a restarted process) takes the counts up, adds
    the interval left open up to the last heartbeat, and counts on from its new cycle 0."""
    from rcsgen.runtime.state_time import StateClock

    with Harness.build(PLATOON, send_init=True) as harness:
        harness.cycle(12)
        record = harness.layout.TIME_IN_STATE["pl"]
        heartbeat = harness.layout.PROCESSES["command"].read(harness.buf)["heartbeat"]
        was = totals(dict(record.read(harness.buf)), heartbeat)
        again = StateClock(record, harness.buf, heartbeat)
        assert totals(dict(record.read(harness.buf)), 0) == was
        again.tick(harness.buf, 1, 0)  # S0 from the new run's cycle 0, for 5 cycles
        assert totals(dict(record.read(harness.buf)), 5) == {**was, "S0": was["S0"] + 5}


def test_each_module_tells_its_clock_as_it_writes_its_status_and_the_loop_looks_at_none():
    """A generated module changes its state only in a cycle that writes its status record,
    and tells its clock (`on_state`) as it does: the loop reads no module's state after a
    cycle, and after every cycle each clock is at its module's state, from the cycle it
    entered it (the trace's counts: the first test)."""
    with Harness.load(ROOT / "generated" / "miner", ROOT / "specs" / "miner", "pc1") as harness:
        harness.command("co", "SUMP_SHEAR_CUSP")
        harness.cycle(3)
        process = harness.processes["pc1"]
        looked: Counter[str] = Counter()

        class Watched:  # a module whose state a look of the loop would read, counted
            def __init__(self, name: str, module: object) -> None:
                self.name, self.module = name, module

            @property
            def state(self) -> int:
                looked[self.name] += 1
                return int(self.module.state)

        timed = dict(process.timed)
        process.timed = {n: (clock, Watched(n, m)) for n, (clock, m) in timed.items()}
        assert timed and not process._looked  # every module of pc1 tells its clock
        changed: Counter[str] = Counter()
        for _ in range(60):
            before = {n: int(m.state) for n, (_, m) in timed.items()}
            harness.cycle()
            for name, (clock, module) in timed.items():
                assert clock.state == module.state, name
                changed[name] += before[name] != module.state
        assert sum(changed.values()) > 0, "no module changed state: nothing was tested"
        assert not looked, looked
