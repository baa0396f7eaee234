"""The runtime's safety functions driven directly, each at its boundaries: the pacer and the
watchdog on a fake clock, liveness on heartbeats written by hand, the reaction to a loss
from the hierarchy and its policies, the control record's heartbeat, overrides and their
latches, the seqlock of a tool's read and write (issue "Fail safe", "Tests that would catch
a broken runtime"; `make mutate` measures how much of the runtime these pin down).

The times are binary fractions (periods of 0.25 s, clocks at whole seconds), so that a
boundary (a wake-up exactly one period late, a heartbeat exactly one timeout old) is hit
exactly and `>` is told from `>=`. The system is `tests/fixtures/runtime/fleet`, as in
tests/test_failsafe.py: `lead` (process pl) over `v1` (pa, halt_all) and `v2` (pb, whose
loss lead's own rules handle: on_lost: continue). Nothing here starts a process or sleeps.
"""

from __future__ import annotations

import importlib
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import pytest

from rcsgen.tools.harness import generate, import_package

FLEET = Path(__file__).resolve().parent / "fixtures" / "runtime" / "fleet"
SAFE = {"v1_drive": 0.0, "v2_drive": -0.5, "v2_brake": True}


@pytest.fixture(scope="module")
def package() -> Iterator[ModuleType]:
    scratch, name = generate(FLEET)
    yield import_package(scratch / name, FLEET)
    shutil.rmtree(scratch, ignore_errors=True)


def part(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


class Clock:
    """A fake monotonic clock and its sleep: `sleep(s)` moves it by `s` plus `oversleep`."""

    def __init__(self, now: float = 100.0) -> None:
        self.now, self.oversleep, self.slept = now, 0.0, []

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += seconds + self.oversleep


# ---------------------------------------------------------------- the pacer


def test_the_pacer_sleeps_to_each_boundary_and_counts_a_late_wake_up(package: ModuleType) -> None:
    """A cycle that ends before its boundary sleeps until it; a wake-up later than a tenth of
    a period (by default) is a late wake-up, not an overrun; the schedule stays on the
    boundaries."""
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep)
    assert (pacer.overruns, pacer.late, pacer.deadline) == (0, 0, 100.25)
    clock.now += 0.125  # a cycle of half a period
    pacer.wait()
    assert clock.slept == [0.125] and clock.now == 100.25
    assert (pacer.overruns, pacer.late, pacer.deadline) == (0, 0, 100.5)
    clock.oversleep = 0.03125  # 1/8 of a period late: more than a tenth
    pacer.wait()
    assert clock.slept[-1] == 0.25
    assert (pacer.overruns, pacer.late, pacer.deadline) == (0, 1, 100.75)
    assert pacer.behind(10) == 0.125, "remembered: 1/8 period late"
    pacer.wait()
    assert clock.slept[-1] == 0.25 - 0.03125, "the schedule stays on the boundaries"
    assert (pacer.overruns, pacer.late) == (0, 2)
    clock.oversleep = 0.0
    clock.now = pacer.deadline  # a cycle that ends exactly on its boundary
    pacer.wait()
    assert (pacer.overruns, pacer.late) == (0, 2)
    assert clock.slept[-1] == 0.0


def test_a_wake_up_at_the_late_limit_is_not_late_and_one_period_late_is_an_overrun(
    package: ModuleType,
) -> None:
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep, late_after=0.25)
    clock.oversleep = 0.0625  # exactly the limit (a quarter of a period)
    pacer.wait()
    assert (pacer.overruns, pacer.late, pacer.behind(10)) == (0, 0, 0)
    clock.oversleep = 0.25  # exactly one period late: that boundary is missed
    pacer.wait()
    assert (pacer.overruns, pacer.late) == (1, 1)
    assert pacer.deadline == 101.0, "the schedule goes on from the next boundary"
    clock.oversleep = 0.625  # two and a half periods late
    pacer.wait()
    assert (pacer.overruns, pacer.late) == (3, 2)
    assert pacer.deadline == 101.75


def test_a_wake_up_a_hair_early_is_on_schedule(package: ModuleType) -> None:
    """A sleep that ends before its boundary (a coarse clock) is neither late nor an overrun,
    and the next boundary is one period on."""
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep)
    clock.oversleep = -0.0625
    pacer.wait()
    assert (pacer.overruns, pacer.late, pacer.deadline) == (0, 0, 100.5)


def test_a_stall_past_the_boundary_counts_each_period_it_missed(package: ModuleType) -> None:
    """A cycle (or a freeze) that runs past its boundary does not sleep: each period boundary
    it ran past is an overrun, the next boundary is a period from now, and its lateness is
    remembered."""
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep)
    clock.now = pacer.deadline + 0.625  # 2.5 periods past the boundary
    pacer.wait()
    assert clock.slept == []
    assert pacer.overruns == 3
    assert pacer.deadline == clock.now + 0.25
    assert pacer.behind(10) == 2.5
    clock.now = pacer.deadline + 0.125
    pacer.wait()
    assert pacer.overruns == 4, "overruns add up"
    assert pacer.behind(10) == 3.0


def test_lateness_older_than_the_window_is_forgotten(package: ModuleType) -> None:
    """behind(window): the lateness of the cycles that started within the last `window`
    periods, in periods; one that started exactly `window` periods ago is out."""
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep)
    assert pacer.behind(10) == 0
    clock.now = pacer.deadline + 0.5  # at 100.75: two periods late
    pacer.wait()
    clock.now = pacer.deadline + 0.25  # at 101.25: one period late
    pacer.wait()
    assert pacer.behind(10) == 3.0
    pacer.now = 100.75 + 2.5 - 0.125  # the first within the window of 10 periods
    assert pacer.behind(10) == 3.0
    pacer.now = 100.75 + 2.5  # exactly 10 periods after the first
    assert pacer.behind(10) == 1.0
    assert pacer.behind(2) == 0.0
    pacer.forget()
    pacer.now = 101.25
    assert pacer.behind(10) == 0


def test_a_pacer_of_period_zero_never_sleeps(package: ModuleType) -> None:
    loop = part(package, "rcs.loop")
    clock = Clock()
    pacer = loop.Pacer(0.0, clock=clock, sleep=clock.sleep)
    clock.now += 5.0
    pacer.wait()
    assert (clock.slept, pacer.overruns, pacer.late) == ([], 0, 0)


# ---------------------------------------------------------------- the watchdog


def late_pacer(loop: ModuleType, periods: float) -> Any:
    """A pacer of period 0.25 whose recent cycles started `periods` periods late in all."""
    clock = Clock()
    pacer = loop.Pacer(0.25, clock=clock, sleep=clock.sleep)
    clock.now = pacer.deadline + periods * 0.25
    pacer.wait()
    return pacer


def test_the_watchdog_trips_at_exactly_its_lateness_limit(package: ModuleType) -> None:
    """Lateness of exactly `behind` periods in the window trips it (and starts the count
    again); a little less does not."""
    loop = part(package, "rcs.loop")
    dog = loop.Watchdog()
    assert not dog.trips(late_pacer(loop, 4.875), 0, 0.25)
    pacer = late_pacer(loop, 5.0)
    assert dog.trips(pacer, 0, 0.25)
    assert pacer.behind(10) == 0, "a trip starts the count again"
    assert not dog.trips(pacer, 0, 0.25)
    assert loop.Watchdog(behind=2.0).trips(late_pacer(loop, 2.0), 0, 0.25)
    for window, trips in ((1, False), (2, True)):
        pacer = late_pacer(loop, 5.0)
        pacer.now += 0.25  # a period later: the lateness is as old as a window of 1
        assert loop.Watchdog(window=window).trips(pacer, 0, 0.25) is trips


def test_the_watchdog_trips_on_a_cycle_one_nanosecond_past_its_limit(package: ModuleType) -> None:
    loop = part(package, "rcs.loop")
    pacer = late_pacer(loop, 0.0)
    dog = loop.Watchdog()  # 3 periods of 0.25 s: 750 ms
    assert not dog.trips(pacer, 750_000_000, 0.25)
    assert dog.trips(pacer, 750_000_001, 0.25)
    assert not dog.trips(pacer, 749_999_999, 0.25)
    long = loop.Watchdog(period_factor=1000.0)  # 250 s
    assert not long.trips(pacer, 250_000_000_000, 0.25)
    assert long.trips(pacer, 250_000_000_001, 0.25)


# ---------------------------------------------------------------- liveness


def fleet_process(package: ModuleType, name: str = "pl") -> Any:
    layout, loop = part(package, "layout"), part(package, "rcs.loop")
    block = part(package, "rcs.block").Block(layout)
    return loop.Process(part(package, f"main_{name}").PLAN, layout, block)


def beats(package: ModuleType, process: Any, name: str, **fields: Any) -> None:
    part(package, "layout").PROCESSES[name].write(process.block.buf, **fields)


def latched(package: ModuleType, process: Any) -> dict[str, Any]:
    override = part(package, "rcs.override")
    return override.overrides(part(package, "layout"), process.block.buf)


def test_a_heartbeat_exactly_one_timeout_old_is_alive_and_one_ns_older_is_lost(
    package: ModuleType,
) -> None:
    """contract.silent: lost when STOPPED or DEAD whatever the beat, or when the beat is
    older than the timeout; a process that has not beaten yet is not lost."""
    layout, silent = part(package, "layout"), part(package, "rcs.contract").silent
    pl = fleet_process(package)
    buf = pl.block.buf
    timeout = 1_000_000_000
    assert silent(layout, buf, "pa", timeout, 10**12) == (False, 0), "no beat yet"
    beats(package, pl, "pa", state=2, beat_ns=5_000_000_000, watchdog_trips=3)
    assert silent(layout, buf, "pa", timeout, 6_000_000_000) == (False, 3)
    assert silent(layout, buf, "pa", timeout, 6_000_000_001) == (True, 3)
    for state in ("STOPPED", "DEAD"):
        code = part(package, "rcs.contract").PROCESS_STATES.index(state)
        beats(package, pl, "pa", state=code)
        assert silent(layout, buf, "pa", timeout, 5_000_000_000) == (True, 3)
    beats(package, pl, "pa", state=2, beat_ns=1)
    assert silent(layout, buf, "pa", timeout, timeout + 1)[0] is False
    assert silent(layout, buf, "pa", timeout, timeout + 2)[0] is True


def test_a_slowed_process_gets_its_timeout_stretched_and_no_less(package: ModuleType) -> None:
    """An operator's slow-down (`ctl slow`) stretches the heartbeat timeout by its factor;
    a factor below 1 (or a new block's 0) leaves it as declared; a system without pacing
    records uses the timeout as declared."""
    layout, silent = part(package, "layout"), part(package, "rcs.contract").silent
    unpaced = SimpleNamespace(PROCESSES=layout.PROCESSES)  # a system without pacing records
    pl = fleet_process(package)
    buf = pl.block.buf
    beats(package, pl, "pa", state=2, beat_ns=1_000_000_000)
    at = 1_000_000_000 + 1_000_000_001  # one timeout and 1 ns later
    for slow in (0.0, 0.5, 1.0):
        layout.PACING["pa"].write(buf, slow=slow)
        assert silent(layout, buf, "pa", 1_000_000_000, at)[0] is True
        assert silent(unpaced, buf, "pa", 1_000_000_000, at)[0] is True
    layout.PACING["pa"].write(buf, slow=3.0)
    assert silent(layout, buf, "pa", 1_000_000_000, 4_000_000_000)[0] is False
    assert silent(layout, buf, "pa", 1_000_000_000, 4_000_000_001)[0] is True
    assert silent(unpaced, buf, "pa", 1_000_000_000, 4_000_000_000)[0] is True
    pl.check_liveness(1_000_000_000, 4_000_000_000, ["pa"])
    assert pl.lost == set(), "check_liveness reads the layout's pacing records"
    pl.check_liveness(1_000_000_000, 4_000_000_001, ["pa"])
    assert pl.lost == {"pa"}


def test_liveness_reacts_once_to_a_loss_and_tells_a_recovery(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """pl watching pb (lead handles v2's loss: on_lost continue): a lost pb is reacted to
    once (its actuators latched, lead told v2 is lost), its recovery told once; a process
    seen the first time with trips already counted is not reacted to."""
    pl = fleet_process(package)
    lead = pl.modules["lead"]
    beats(package, pl, "pb", state=2, beat_ns=1_000_000_000, watchdog_trips=4)
    pl.check_liveness(1_000_000_000, 1_500_000_000, ["pb"])
    assert (pl.lost, lead.v2_lost, latched(package, pl)) == (set(), False, {})
    pl.check_liveness(1_000_000_000, 2_000_000_001, ["pb"])
    assert (pl.lost, lead.v2_lost) == ({"pb"}, True)
    assert set(latched(package, pl)) == {"v2_drive", "v2_brake"}
    override = part(package, "rcs.override")
    with pytest.raises(override.OverrideError, match="writer is lost"):
        override.reset(part(package, "layout"), pl.block.buf)  # not while pb is lost
    monkeypatch.setattr(override, "writers_lost", lambda *_: {})  # released all the same, to
    override.reset(part(package, "layout"), pl.block.buf)  # see whether a check latches again
    pl.check_liveness(1_000_000_000, 2_000_000_002, ["pb"])
    assert latched(package, pl) == {}, "a loss is reacted to once"
    assert lead.v2_lost
    pl.beat()
    lost = part(package, "layout").PROCESSES["pl"].read(pl.block.buf)["lost"]
    assert lost == 1 << 2, "pb is the third process"
    beats(package, pl, "pb", beat_ns=2_000_000_000)
    pl.check_liveness(1_000_000_000, 2_000_000_003, ["pb"])
    assert (pl.lost, lead.v2_lost) == (set(), False)
    pl.beat()
    assert part(package, "layout").PROCESSES["pl"].read(pl.block.buf)["lost"] == 0


def test_a_watchdog_trip_of_another_process_is_reacted_to_and_told_for_one_cycle(
    package: ModuleType,
) -> None:
    """pb alive but reporting a new watchdog trip: pl latches pb's actuators and tells lead
    for one check; the next check (no new trip) tells lead v2 is back."""
    pl = fleet_process(package)
    lead = pl.modules["lead"]
    beats(package, pl, "pb", state=2, beat_ns=1_000_000_000, watchdog_trips=0)
    pl.check_liveness(1_000_000_000, 1_100_000_000, ["pb"])
    beats(package, pl, "pb", watchdog_trips=1)
    pl.check_liveness(1_000_000_000, 1_200_000_000, ["pb"])
    assert (pl.lost, lead.v2_lost) == (set(), True)
    assert set(latched(package, pl)) == {"v2_drive", "v2_brake"}
    pl.check_liveness(1_000_000_000, 1_300_000_000, ["pb"])
    assert lead.v2_lost is False
    beats(package, pl, "pb", watchdog_trips=2)
    pl.check_liveness(1_000_000_000, 1_400_000_000, ["pb"])
    assert lead.v2_lost is True


def test_a_process_lost_while_its_trip_count_stays_stays_lost_to_its_supervisor(
    package: ModuleType,
) -> None:
    pl = fleet_process(package)
    lead = pl.modules["lead"]
    beats(package, pl, "pb", state=2, beat_ns=1_000_000_000, watchdog_trips=1)
    pl.check_liveness(1_000_000_000, 1_100_000_000, ["pb"])
    pl.check_liveness(1_000_000_000, 2_100_000_000, ["pb"])
    pl.check_liveness(1_000_000_000, 2_200_000_000, ["pb"])
    assert (pl.lost, lead.v2_lost) == ({"pb"}, True)


def test_the_loss_of_a_halt_all_process_puts_its_supervisor_in_the_safe_state(
    package: ModuleType,
) -> None:
    """pa lost while lead runs CONVOY (v1: halt_all): every actuator latched, lead leaves
    its table, sends HALT to v1 and reports ERROR (reason LOST); react returns the fields
    it latched now."""
    layout = part(package, "layout")
    pl = fleet_process(package)
    layout.COMMAND_IN["lead"].write(pl.block.buf, command_num=2, command=3)  # CONVOY
    pl.run_cycle()
    pl.run_cycle()
    assert layout.STATE_NAMES["lead"][layout.STATUS_OUT["lead"].read(pl.block.buf)["state"]] == "S1"
    before = layout.COMMAND_IN["v1"].read(pl.block.buf)["command_num"]
    assert pl.react("pa") == ["v1_drive", "v2_drive", "v2_brake"]
    assert pl.react("pa") == []
    pl.run_cycle()
    sent = layout.COMMAND_IN["v1"].read(pl.block.buf)
    assert layout.COMMAND_NAMES["v1"][sent["command"]] == "HALT"
    assert sent["command_num"] == before + 2, "a HALT numbered on for each reaction"
    status = layout.STATUS_OUT["lead"].read(pl.block.buf)
    assert part(package, "rcs.contract").STATUS_NAMES[status["status"]] == "ERROR"
    assert status["error_num"] == part(package, "rcs.loop").LOST_SUBORDINATE
    assert layout.STATE_NAMES["lead"][status["state"]] == "NOP", "its table left"
    assert latched(package, pl) == {f: ("SAFE", v) for f, v in SAFE.items()}


# ---------------------------------------------------------------- the reaction to a loss


def test_the_reaction_to_each_process_of_the_fleet(package: ModuleType) -> None:
    layout, loop = part(package, "layout"), part(package, "rcs.loop")
    everything = ("v1_drive", "v2_drive", "v2_brake")
    assert loop.reaction(layout, "pa") == loop.Reaction(everything, ("lead",), (), False)
    assert loop.reaction(layout, "pb") == loop.Reaction(
        ("v2_drive", "v2_brake"), (), (("lead", "v2"),), True
    )
    assert loop.reaction(layout, "pl") == loop.Reaction(everything, (), (), False)


def hierarchy(**extra: Any) -> SimpleNamespace:
    """top (p1) > mid (p1) > low (p2) > low2 (p2); side (p3) alone; a stand-in placed in p2
    that is not a module."""
    return SimpleNamespace(
        PLACEMENT={"top": "p1", "mid": "p1", "low": "p2", "low2": "p2", "side": "p3", "sim": "p2"},
        SUBORDINATES={"top": ("mid",), "mid": ("low",), "low": ("low2",), "side": ()},
        MODULES=("top", "mid", "low", "low2", "side"),
        **extra,
    )


def test_a_halt_all_loss_puts_every_supervisor_up_the_chain_in_the_safe_state(
    package: ModuleType,
) -> None:
    loop = part(package, "rcs.loop")
    layout = hierarchy(SAFE_VALUES={"a": 0, "b": 1}, ACTUATED_BY={"a": "p2", "b": "p1"})
    assert loop.reaction(layout, "p2") == loop.Reaction(("a", "b"), ("mid", "top"), (), False)
    assert loop.reaction(layout, "p3") == loop.Reaction(("a", "b"), (), (), False)
    bare = hierarchy()  # a layout without actuators or policies
    assert loop.reaction(bare, "p2") == loop.Reaction((), ("mid", "top"), (), False)


def test_a_contained_loss_latches_only_its_own_actuators(package: ModuleType) -> None:
    """Every module of p2 hangs below a supervisor that continues on its loss: only p2's
    actuators are latched, and that supervisor is told; not contained when one of p2's
    modules hangs below a supervisor that does not continue."""
    loop = part(package, "rcs.loop")
    acts = {"SAFE_VALUES": {"a": 0, "b": 1}, "ACTUATED_BY": {"a": "p2", "b": "p1"}}
    layout = hierarchy(ON_LOST_CONTINUE={"mid": ("low",)}, **acts)
    assert loop.reaction(layout, "p2") == loop.Reaction(("a",), (), (("mid", "low"),), True)
    other = hierarchy(ON_LOST_CONTINUE={"top": ("low",)}, **acts)
    assert loop.reaction(other, "p2").contained is False


def test_the_safe_chain_stops_at_the_lost_process_and_at_the_root(package: ModuleType) -> None:
    """top (p2) > mid (p1) > low (p2): losing p2, mid goes safe; top, in the lost process
    itself, is not asked to."""
    loop = part(package, "rcs.loop")
    layout = SimpleNamespace(
        PLACEMENT={"top": "p2", "mid": "p1", "low": "p2"},
        SUBORDINATES={"top": ("mid",), "mid": ("low",), "low": ()},
        MODULES=("top", "mid", "low"),
        SAFE_VALUES={},
    )
    assert loop.reaction(layout, "p2").safe == ("mid",)
    layout.ON_LOST_CONTINUE = {"mid": ("low",)}
    assert loop.reaction(layout, "p2").contained is False, "top hangs below nobody"


# ---------------------------------------------------------------- the control record


def test_each_beat_writes_the_control_record_whole_two_sequence_steps_on(
    package: ModuleType,
) -> None:
    layout = part(package, "layout")
    pl = fleet_process(package)
    record = layout.PROCESSES["pl"]
    first = record.seq(pl.block.buf)
    assert first % 2 == 0 and first > 0
    pl.cycle = 7
    pl.lost = {"pa"}
    pl.beat(now_ns=123_456)
    assert record.seq(pl.block.buf) == first + 2
    values = record.read(pl.block.buf)
    assert (values["heartbeat"], values["beat_ns"], values["lost"]) == (7, 123_456, 1 << 1)
    assert values["state"] == part(package, "rcs.contract").RUNNING
    pl.lost = {"pa", "pb"}
    pl.beat(state=part(package, "rcs.contract").STOPPED)
    assert record.seq(pl.block.buf) == first + 4
    values = record.read(pl.block.buf)
    assert values["lost"] == 0b110
    assert values["state"] == part(package, "rcs.contract").STOPPED
    assert values["beat_ns"] > 123_456, "the clock's time when none is given"


def test_safe_stop_latches_the_process_s_own_actuators_or_all_when_orphaned(
    package: ModuleType,
) -> None:
    pb = fleet_process(package, "pb")
    assert pb.safe_stop() == ["v2_drive", "v2_brake"]
    assert set(latched(package, pb)) == {"v2_drive", "v2_brake"}
    pa = fleet_process(package, "pa")
    assert pa.safe_stop(everything=True) == ["v1_drive", "v2_drive", "v2_brake"]


def test_init_and_halt_go_to_the_roots_with_the_next_command_number(package: ModuleType) -> None:
    """send_init: INIT to every root; with only_idle a root that had a command keeps it.
    halt_roots: HALT, numbered on."""
    layout = part(package, "layout")
    pl = fleet_process(package)
    record, names = layout.COMMAND_IN["lead"], layout.COMMAND_NAMES["lead"]
    pl.send_init()
    assert (record.read(pl.block.buf)["command_num"], record.read(pl.block.buf)["command"]) == (
        1,
        names.index("INIT"),
    )
    pl.send_init(only_idle=True)
    assert record.read(pl.block.buf)["command_num"] == 1, "a root that had a command"
    pl.halt_roots()
    assert (record.read(pl.block.buf)["command_num"], record.read(pl.block.buf)["command"]) == (
        2,
        names.index("HALT"),
    )
    pl.send_init()
    assert record.read(pl.block.buf)["command_num"] == 3


# ---------------------------------------------------------------- overrides


def fresh(package: ModuleType) -> tuple[ModuleType, ModuleType, memoryview]:
    """The override module, the fleet's layout and a new private block's buffer."""
    layout = part(package, "layout")
    return part(package, "rcs.override"), layout, part(package, "rcs.block").Block(layout).buf


def tear(package: ModuleType, record: Any, buf: memoryview) -> None:
    """Leave `record` as a writer that died mid-write leaves it: its word odd."""
    contract = part(package, "rcs.contract")
    contract.SEQ.pack_into(buf, record.offset, contract.next_odd(record.seq(buf)))


def test_held_replaces_what_a_module_writes_by_each_override_and_skips_a_torn_one(
    package: ModuleType,
) -> None:
    """held: a forced field gets the forced value, a field without an override the module's
    own, a field whose override record is being written (odd word, or a never-written 0)
    keeps the block's value this cycle."""
    override, layout, buf = fresh(package)
    records = tuple(layout.OVERRIDE[f] for f in ("v1_drive", "v2_drive", "v2_brake"))
    out, now = (1.0, 2.0, False), (0.5, 0.75, True)
    assert override.held(buf, records, out, now) == out
    override.force(layout, buf, "v1_drive", 0.25)
    assert override.held(buf, records, out, now) == (0.25, 2.0, False)
    override.latch_safe(layout, buf, ["v2_brake"])
    assert override.held(buf, records, out, now) == (0.25, 2.0, True)
    tear(package, layout.OVERRIDE["v1_drive"], buf)
    assert override.held(buf, records, out, now) == (0.5, 2.0, True)
    part(package, "rcs.contract").SEQ.pack_into(buf, layout.OVERRIDE["v2_drive"].offset, 0)
    assert override.held(buf, records, out, now) == (0.5, 0.75, True)
    _, layout, buf = fresh(package)
    override.latch_safe(layout, buf, ["v1_drive"])  # latched at 0.0: held at 0.0
    override.force(layout, buf, "v2_drive", 3.0)
    override.unforce(layout, buf, "v2_drive")  # released: the record keeps 3.0, not held
    assert override.held(buf, records, out, now) == (0.0, 2.0, False)


def test_an_override_record_a_writer_died_in_reads_as_its_fields(package: ModuleType) -> None:
    """_state of a torn override record: its raw state and value (the next writer rewrites
    it whole), so a latch or a reset still sees what it was."""
    override, layout, buf = fresh(package)
    override.latch_safe(layout, buf, ["v2_drive"])
    record = layout.OVERRIDE["v2_drive"]
    tear(package, record, buf)
    assert override._state(record, buf) == (part(package, "rcs.contract").SAFE, -0.5)
    assert override.overrides(layout, buf) == {"v2_drive": ("SAFE", -0.5)}
    assert override.reset(layout, buf) == ["v2_drive"]
    assert record.seq(buf) % 2 == 0, "rewritten whole"
    assert override.overrides(layout, buf) == {}


def test_a_text_override_record_is_written_and_read_as_text(package: ModuleType) -> None:
    """An override of a string field stores its UTF-8 bytes NUL-padded and reads back the
    text (a trailing `X` kept, invalid bytes replaced, never an error)."""
    override, contract = part(package, "rcs.override"), part(package, "rcs.contract")
    buf = memoryview(bytearray(64))
    record = contract.Record(contract.Struct("<QQ16s"), 8, ("state", "name"))
    override._write(record, buf, contract.FORCED, "höX")
    assert record.seq(buf) == 2
    assert override._state(record, buf) == (contract.FORCED, "höX")
    record.struct.pack_into(buf, 8, 4, contract.SAFE, b"a\xff")
    assert override._state(record, buf) == (contract.SAFE, "a\ufffd")
    override._write(record, buf, contract.NO_OVERRIDE, "")
    assert record.seq(buf) == 6
    assert override._state(record, buf) == (contract.NO_OVERRIDE, "")


def test_the_override_flag_is_exactly_one_byte_one_while_any_override_holds(
    package: ModuleType,
) -> None:
    override, layout, buf = fresh(package)
    at = layout.OVERRIDDEN_AT
    override.force(layout, buf, "v1_note", 3)
    assert buf[at] == 1
    override.latch_safe(layout, buf, ["v2_brake"])
    override.unforce(layout, buf, "v1_note")
    assert buf[at] == 1, "v2_brake is still latched"
    assert override.reset(layout, buf, ["v2_brake"]) == ["v2_brake"]
    assert buf[at] == 0
    buf[at] = 1  # a transport mirrored a record: the flag is recomputed from the records
    override.mirrored(layout, buf)
    assert buf[at] == 0
    override._write(layout.OVERRIDE["mode"], buf, part(package, "rcs.contract").FORCED, 1)
    override.mirrored(layout, buf)
    assert buf[at] == 1


def test_a_latch_goes_on_past_a_field_already_latched(package: ModuleType) -> None:
    override, layout, buf = fresh(package)
    assert override.latch_safe(layout, buf, ["v2_drive"]) == ["v2_drive"]
    assert override.latch_safe(layout, buf, ["v2_drive", "v2_brake"]) == ["v2_brake"]
    override.force(layout, buf, "v1_drive", 0.0)  # forced at its safe value: not latched
    assert override.latch_safe(layout, buf, ["v1_drive"]) == ["v1_drive"]
    assert override.overrides(layout, buf)["v1_drive"] == ("SAFE", 0.0)


def test_unforce_of_a_field_not_forced_is_refused_and_changes_nothing(package: ModuleType) -> None:
    override, layout, buf = fresh(package)
    with pytest.raises(override.OverrideError, match=r"^v1_note is not forced$"):
        override.unforce(layout, buf, "v1_note")
    override.force(layout, buf, "v1_note", 4)
    override.unforce(layout, buf, "v1_note")
    assert override.overrides(layout, buf) == {}
    assert layout.WORLD["v1_note"].read(buf)["v1_note"] == 4, "the forced value stays"


@pytest.mark.parametrize(
    ("field", "value", "stored"),
    [
        ("v1_note", -(2**63), -(2**63)),
        ("v1_note", 2**63 - 1, 2**63 - 1),
        ("v1_drive", 2, 2.0),
        ("mode", "IDLE", 0),
        ("mode", "ALONE", 2),
        ("v2_brake", False, False),
    ],
)
def test_the_values_a_field_can_hold_are_forced(
    package: ModuleType, field: str, value: object, stored: object
) -> None:
    override, layout, buf = fresh(package)
    override.force(layout, buf, field, value)
    found = layout.WORLD[field].read(buf)[field]
    assert (found, type(found)) == (stored, type(stored))
    assert override.overrides(layout, buf) == {field: ("FORCED", stored)}


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("v1_note", -(2**63) - 1, "v1_note holds an int, not"),
        ("mode", 2, "mode: 2 is not one of IDLE, TOGETHER, ALONE"),
        ("v2_brake", "yes", "v2_brake holds a bool, not 'yes'"),
        ("v1_drive", None, "v1_drive holds a number, not None"),
        ("nowhere", 1, "no world field 'nowhere'"),
    ],
)
def test_a_value_a_field_cannot_hold_is_refused_by_name(
    package: ModuleType, field: str, value: object, message: str
) -> None:
    override, layout, buf = fresh(package)
    with pytest.raises(override.OverrideError, match=f"^{message}"):
        override.force(layout, buf, field, value)


# ---------------------------------------------------------------- a tool's read and write


def tool_record(package: ModuleType) -> tuple[Any, memoryview]:
    """A record (a counter, a 16-byte text, a float) at offset 8 of a 64-byte buffer."""
    contract = part(package, "rcs.contract")
    record = contract.Record(contract.Struct("<Qq16sd"), 8, ("n", "name", "x"))
    return record, memoryview(bytearray(64))


def test_a_record_never_written_is_stale_and_its_first_write_makes_it_whole(
    package: ModuleType,
) -> None:
    contract = part(package, "rcs.contract")
    record, buf = tool_record(package)
    with pytest.raises(contract.StaleRead, match="at 8 is being written"):
        record.read(buf)
    record.write(buf, n=1, name="hé", x=0.5)
    assert record.seq(buf) == 2
    assert record.read(buf) == {"n": 1, "name": "hé", "x": 0.5}
    record.write(buf, x=1.5)
    assert record.seq(buf) == 4
    assert record.read(buf) == {"n": 1, "name": "hé", "x": 1.5}, "the others kept"
    assert bytes(buf[:8]) == bytes(8) and bytes(buf[48:]) == bytes(16), "nothing outside"


def test_a_record_whose_writer_died_is_stale_until_rewritten_keeping_its_fields(
    package: ModuleType,
) -> None:
    contract = part(package, "rcs.contract")
    record, buf = tool_record(package)
    record.write(buf, n=1, name="abcdefghijk", x=0.5)
    tear(package, record, buf)
    with pytest.raises(contract.StaleRead):
        record.read(buf)
    record.write(buf, n=2)
    assert record.seq(buf) == 4
    assert record.read(buf) == {"n": 2, "name": "abcdefghijk", "x": 0.5}


def test_the_write_mark_is_odd_and_the_end_mark_one_more(package: ModuleType) -> None:
    contract = part(package, "rcs.contract")
    assert [contract.next_odd(s) for s in (0, 2, 3, 6)] == [1, 3, 3, 7]


def test_a_record_refuses_unknown_fields_and_text_that_does_not_fit(package: ModuleType) -> None:
    record, buf = tool_record(package)
    with pytest.raises(KeyError, match=r"no field zz in a buffer of"):
        record.write(buf, n=1, zz=2)
    with pytest.raises(ValueError, match="is 17 bytes: more than the 16 it holds"):
        record.write(buf, name="a" * 17)
    with pytest.raises(ValueError):
        record.write(buf, n="1")
    record.write(buf, name="a" * 16)
    assert record.read(buf)["name"] == "a" * 16
    assert record.codes() == {"n": "q", "name": "16s", "x": "d"}


# ---------------------------------------------------------------- start-up checks


def test_a_segment_name_is_checked_and_each_mistake_said(package: ModuleType) -> None:
    startup = part(package, "rcs.operate.startup")
    assert startup.segment_problem("a" * 200) == ""
    assert startup.segment_problem("x_1.b-c") == ""
    assert startup.segment_problem("") == "--shm: an empty segment name"
    assert startup.segment_problem("a" * 201) == (
        f"--shm: {'a' * 37!r}... is 201 characters: a segment name has at most 200"
    )
    assert startup.segment_problem("a/" + "b" * 38) == (
        f"--shm: {'a/' + 'b' * 38!r} is not a segment name: letters, digits, `_`, `.` and `-` "
        "only (no `/`), not starting with `.` or `-`"
    )
    assert startup.segment_problem("/" + "b" * 40).startswith(f"--shm: {'/' + 'b' * 36!r}... is")


def test_run_settings_are_parsed_once_each_and_checked_against_the_spec(
    package: ModuleType,
) -> None:
    startup = part(package, "rcs.operate.startup")
    declared = SimpleNamespace(SYSTEM="sys", SETTINGS=("speed", "depth"))
    assert startup.parse_settings(declared, ["speed=a=b", "depth="]) == {
        "speed": "a=b",
        "depth": "",
    }
    for item, message in [
        ("speed", "--set: 'speed' is not KEY=VALUE"),
        ("=1", "--set: '=1' is not KEY=VALUE"),
    ]:
        with pytest.raises(ValueError, match=f"^{message}$"):
            startup.parse_settings(declared, [item])
    with pytest.raises(ValueError, match="^--set: setting speed is given twice$"):
        startup.parse_settings(declared, ["speed=1", "speed=2"])
    with pytest.raises(ValueError, match="^--set: sys has no setting 'sped'"):
        startup.parse_settings(declared, ["sped=1"])
    assert startup.settings_problem(declared, {"depth": "1"}) == ""
    assert startup.settings_problem(declared, {"spee": "1"}) == (
        "sys has no setting 'spee' (did you mean 'speed'?); settings: speed, depth"
    )
    assert startup.settings_problem(declared, {"speed": 1}) == (  # type: ignore[dict-item]
        "setting 'speed': a setting and its value are text"
    )
    assert startup.settings_problem(declared, {2: "1"}).startswith("setting 2:")  # type: ignore[dict-item]
    deaf = SimpleNamespace(SYSTEM="sys", READS_SETTINGS=False)
    assert startup.settings_problem(deaf, {"k": "v"}) == (
        "sys reads no setting 'k': none of its controllers has a `hooks_state` factory"
    )
    assert startup.settings_problem(SimpleNamespace(SYSTEM="old"), {"k": "v"}) == ""
    assert startup.settings_problem(deaf, {}) == ""


def test_a_failure_is_reported_in_one_line_with_the_exit_code_that_says_which(
    package: ModuleType, capsys: pytest.CaptureFixture[str]
) -> None:
    startup, contract = part(package, "rcs.operate.startup"), part(package, "rcs.contract")
    hook = contract.HookError("v1", "drive", "DRIVE/S0/1", 4, result=None, kinds="f")
    assert startup.report_failure("pa", hook, package.__name__) == startup.HOOK_FAILED
    made = contract.HookError("v1", "factory", "hooks_state", 0, result=None, kinds="f")
    assert startup.report_failure("pa", made, package.__name__) == startup.START_FAILED
    assert startup.report_failure("pa", ZeroDivisionError(), package.__name__) == 5
    assert startup.report_failure("pa", KeyError("k"), package.__name__) == 5
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"pa: {hook}",
        f"pa: {made}",
        "pa: failed: ZeroDivisionError",
        "pa: failed: KeyError: 'k'",
    ]
    directory = Path(package.__file__ or "").parent.name  # what tracebacks show
    with pytest.raises(AttributeError) as failed:
        part(package, "v1").V1Controller.run_cycle(None)
    assert startup.failed_module(failed.value, directory) == "v1"
    assert startup.failed_module(failed.value, "elsewhere") is None
    assert startup.report_failure("pa", failed.value, directory) == startup.MODULE_FAILED
    with pytest.raises(TypeError) as failed_in_layout:
        part(package, "layout").initialise(None)
    assert startup.failed_module(failed_in_layout.value, directory) is None, "not a module"
    assert capsys.readouterr().err.startswith("pa: module `v1` failed: AttributeError: ")
    assert startup.ending("pa", startup.HOOK_FAILED) == (
        "pa stopped: a hook failed (exit 4; its error is above)"
    )
    assert startup.ending("pa", -9) == "pa died (exit -9)"


# ---------------------------------------------------------------- blocks and their segments

_segments = iter(range(1, 1000))


@pytest.fixture()
def segment_name() -> Iterator[str]:
    """A segment name of this test's own; whatever is left of it is removed."""
    import os

    name = f"Xrcsgen_rs_{os.getpid()}_{next(_segments)}"
    yield name
    try:
        os.unlink(f"/dev/shm/{name}")
    except FileNotFoundError:
        return


def raw_segment(package: ModuleType, name: str, data: bytes) -> None:
    """A segment holding `data`, made by something that is not rcsgen (mode 0600, as
    `shm_open` makes one)."""
    fd = os.open(f"/dev/shm/{name}", os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with open(fd, "wb") as segment:
        segment.write(data)


def test_a_named_block_belongs_to_its_creator_alone(package: ModuleType, segment_name: str) -> None:
    """A block made under a name (create is the default) is its creator's: an attached one
    closes without removing it, a disowned one too; the creator's close removes it."""
    layout, blocks = part(package, "layout"), part(package, "rcs.block")
    created = blocks.Block(layout, segment_name)
    assert blocks.exists(segment_name) and blocks.exists("/" + segment_name)
    attached = blocks.Block(layout, segment_name, create=False)
    assert attached.buf[: layout.SIZE] == created.buf[: layout.SIZE]
    attached.close()
    assert attached.shm is None
    assert blocks.exists(segment_name), "an attached process never removes the segment"
    created.disown()
    created.close()
    assert blocks.exists(segment_name), "disowned"
    again = blocks.Block(layout, segment_name, create=False)
    again.owner = True
    again.close()
    assert not blocks.exists(segment_name)
    assert blocks.unlink(segment_name) is False, "already gone"
    private = blocks.Block(layout)
    assert (private.shm, private.owner) == (None, False)
    private.close()


def test_a_named_segment_is_made_once_and_attached_only_when_there(
    package: ModuleType, segment_name: str
) -> None:
    layout, blocks = part(package, "layout"), part(package, "rcs.block")
    with pytest.raises(blocks.BlockError, match=f"^no shared-memory segment '{segment_name}': is"):
        blocks.Block(layout, segment_name, create=False)
    created = blocks.Block(layout, segment_name)
    try:
        with pytest.raises(
            blocks.BlockError, match=f"^shared-memory segment '{segment_name}' already"
        ):
            blocks.Block(layout, segment_name)
    finally:
        created.close()
    raw_segment(package, segment_name, b"x")
    assert blocks.unlink(segment_name) is True
    assert not blocks.exists(segment_name)


def test_a_segment_too_small_for_a_header_or_without_one_is_refused(
    package: ModuleType, segment_name: str
) -> None:
    layout, blocks = part(package, "layout"), part(package, "rcs.block")
    contract = part(package, "rcs.contract")
    size = contract.HEADER.size
    raw_segment(package, segment_name, bytes(size - 1))
    with pytest.raises(blocks.BlockError, match=f"has {size - 1} bytes: it is not an rcsgen"):
        blocks.Block(layout, segment_name, create=False)
    blocks.unlink(segment_name)
    raw_segment(package, segment_name, bytes(size))
    with pytest.raises(blocks.BlockError, match=r"is not an rcsgen block \(no rcsgen header\)"):
        blocks.Block(layout, segment_name, create=False)
    assert blocks.exists(segment_name), "refused, not removed"


@pytest.mark.parametrize("same", ["hash", "size"])
def test_a_segment_of_another_layout_is_refused_naming_both(
    package: ModuleType, segment_name: str, same: str
) -> None:
    """The header's layout hash and block size must both be this package's; the message
    names what the segment holds (undecodable bytes shown, never an error) and what the
    package has."""
    layout, blocks = part(package, "layout"), part(package, "rcs.block")
    contract = part(package, "rcs.contract")
    found = layout.LAYOUT_HASH.encode() if same == "hash" else b"\xff" + bytes(31)
    size = layout.SIZE + 8 if same == "hash" else layout.SIZE
    header = contract.HEADER.pack(contract.MAGIC, found, b"\xffotherX", size)
    raw_segment(package, segment_name, header + bytes(size - len(header)))
    with pytest.raises(blocks.BlockError) as refused:
        blocks.Block(layout, segment_name, create=False)
    shown = layout.LAYOUT_HASH if same == "hash" else "\ufffd" + "\0" * 31
    assert str(refused.value).startswith(
        f"segment '{segment_name}' holds layout {shown} of system '\ufffdotherX'; this "
        f"package has layout {layout.LAYOUT_HASH} of system 'fleet'"
    )


# ---------------------------------------------------------------- the paced loop, on a fake clock


class FakeTime:
    """What rcs/loop.py reads of `time`, on one fake clock in nanoseconds."""

    def __init__(self) -> None:
        self.ns = 10**12

    def perf_counter_ns(self) -> int:
        return self.ns

    monotonic_ns = perf_counter_ns

    def monotonic(self) -> float:
        return self.ns / 1e9

    def sleep(self, seconds: float) -> None:
        self.ns += round(seconds * 1e9)


def timed_plan(package: ModuleType, process: str, took: dict[int, int], **changes: Any) -> Any:
    """`process`'s plan whose first module's cycle n takes took[n] ns of the fake clock
    (`clock` is set by `fake_loop`)."""
    plan = part(package, f"main_{process}").PLAN
    name = plan.modules[0]
    real = plan.classes[name]

    class Timed:
        clock: FakeTime

        def __init__(self, buf: memoryview, settings: dict[str, str] | None) -> None:
            self.module, self.cycles, self.buf = real(buf, settings), 0, buf

        def run_cycle(self, began: int = 0) -> int:
            self.cycles += 1
            end = self.module.run_cycle(began)
            Timed.clock.ns += took.get(self.cycles, 0)
            return end

        def resume(self) -> None:
            self.module.resume()

    return plan._replace(classes={**plan.classes, name: Timed}, **changes), Timed


@pytest.fixture()
def fake_loop(package: ModuleType, monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """rcs/loop.py on a fake clock: its `time`, and every Pacer it makes."""
    import functools

    loop = part(package, "rcs.loop")
    clock = FakeTime()
    monkeypatch.setattr(loop, "time", clock)
    monkeypatch.setattr(
        loop, "Pacer", functools.partial(loop.Pacer, clock=clock.monotonic, sleep=clock.sleep)
    )
    yield loop, clock


def test_a_paced_run_keeps_the_period_and_counts_each_cycle_s_time_and_load(
    package: ModuleType, fake_loop: Any
) -> None:
    """Paced at 0.25 s: each cycle starts a period after the last; the control record gets
    the last and longest cycle times, a load warning for a cycle longer than 0.8 periods
    (exactly 0.8 is not), no overrun; the run ends STOPPED after the cycles asked for."""
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(
        package,
        "pl",
        {1: 100_000_000, 2: 200_000_000, 3: 200_000_001, 4: 50_000_000},
        cycle_period=0.25,
    )
    timed.clock = clock
    began = clock.ns
    starts: list[int] = []
    process = loop.run(plan, layout, cycles=4, on_cycle=lambda p: starts.append(clock.ns) and False)
    try:
        record = layout.PROCESSES["pl"].read(process.block.buf)
    finally:
        process.block.close()
    assert process.cycle == 4
    assert starts == [
        began + n * 250_000_000 + d
        for n, d in enumerate((100_000_000, 200_000_000, 200_000_001, 50_000_000))
    ]
    assert (record["last_cycle_ns"], record["max_cycle_ns"]) == (50_000_000, 200_000_001)
    assert (record["load_warnings"], record["overruns"], record["late_wakeups"]) == (1, 0, 0)
    assert (record["watchdog_trips"], record["heartbeat"]) == (0, 4)
    assert record["state"] == part(package, "rcs.contract").STOPPED
    assert clock.ns == began + 4 * 250_000_000, "the last cycle waits for its period too"


def test_an_unpaced_run_never_waits(package: ModuleType, fake_loop: Any) -> None:
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pl", {1: 10, 2: 10, 3: 10})
    timed.clock = clock
    began = clock.ns
    process = loop.run(plan, layout, cycles=3, pace=False)
    process.block.close()
    assert clock.ns == began + 30
    assert process.counters["load_warnings"] == 0


def test_an_operator_s_slow_down_stretches_the_period(package: ModuleType, fake_loop: Any) -> None:
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pl", {}, cycle_period=0.25)
    timed.clock = clock
    starts: list[int] = []

    def slow_from_the_second(process: Any) -> bool:
        starts.append(clock.ns)
        if process.cycle == 1:
            layout.PACING["pl"].write(process.block.buf, slow=3.0)
        return False

    process = loop.run(plan, layout, cycles=4, on_cycle=slow_from_the_second)
    process.block.close()
    gaps = [b - a for a, b in zip(starts, starts[1:], strict=False)]
    assert gaps == [250_000_000, 750_000_000, 750_000_000], "from the next boundary on"


def test_a_paced_run_trips_its_watchdog_from_the_second_cycle_and_stops_safe(
    package: ModuleType, fake_loop: Any
) -> None:
    """pl at 0.25 s: a first cycle of four periods is the start-up's; the third cycle, a
    hair over three periods, trips the watchdog once (counted after its on_cycle): pl's
    reaction latched (halt_all: every actuator) and HALT to its root."""
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pl", {1: 1_000_000_000, 3: 750_000_001}, cycle_period=0.25)
    timed.clock = clock
    trips: list[int] = []
    process = loop.run(
        plan, layout, cycles=4, on_cycle=lambda p: trips.append(p.counters["watchdog_trips"])
    )
    try:
        sent = layout.COMMAND_IN["lead"].read(process.block.buf)
        overridden = part(package, "rcs.override").overrides(layout, process.block.buf)
    finally:
        process.block.close()
    assert trips == [0, 0, 0, 1]
    assert process.counters["overruns"] == 4 + 3
    assert layout.COMMAND_NAMES["lead"][sent["command"]] == "HALT"
    assert sent["command_num"] == 2, "INIT, then HALT"
    assert set(overridden) == set(SAFE)


@pytest.mark.parametrize(("timeout", "lost"), [(None, True), (2.0, False)])
def test_a_paced_run_watches_the_others_with_the_declared_timeout(
    package: ModuleType, fake_loop: Any, timeout: float | None, lost: bool
) -> None:
    """pl's run checks pa's heartbeat after each cycle: one beat exactly 1 s and 1 ns old
    is lost with the layout's timeout (1 s), not with one of 2 s given to run."""
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pl", {}, cycle_period=0.25)
    timed.clock = clock

    def beat_pa(process: Any) -> bool:
        if process.cycle == 1:  # the next check is at the next boundary (no cycle time)
            at = process.block.buf
            layout.PROCESSES["pa"].write(
                at, state=2, beat_ns=clock.ns + 250_000_000 - 1_000_000_001
            )
        return False

    process = loop.run(plan, layout, cycles=2, on_cycle=beat_pa, heartbeat_timeout=timeout)
    process.block.close()
    assert (process.lost == {"pa"}) is lost


@pytest.mark.parametrize("orphaned", [False, True])
def test_a_stop_ends_the_run_after_its_cycle_with_the_outputs_safe(
    package: ModuleType, fake_loop: Any, orphaned: bool
) -> None:
    """A stop requested during cycle 2 ends the run after it; pa's own actuator is latched
    safe, every actuator when the launcher is gone (orphaned)."""
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pa", {}, cycle_period=0.25)
    timed.clock = clock
    stop = loop.Stop()
    assert (stop.requested, stop.orphaned, stop.process) == (False, False, None)
    stop.orphaned = orphaned

    def request(process: Any) -> bool:
        assert stop.process is process
        if process.cycle == 2:
            stop()
        return False

    process = loop.run(plan, layout, cycles=10, on_cycle=request, stop=stop)
    overridden = part(package, "rcs.override").overrides(layout, process.block.buf)
    process.block.close()
    assert stop.requested and not stop.finished.is_set()
    assert process.cycle == 2
    assert set(overridden) == (set(SAFE) if orphaned else {"v1_drive"})


def test_on_cycle_returning_true_ends_the_run_and_a_transport_carries_each_cycle(
    package: ModuleType, fake_loop: Any
) -> None:
    loop, clock = fake_loop
    layout = part(package, "layout")
    plan, timed = timed_plan(package, "pl", {})
    timed.clock = clock
    calls: list[str] = []

    class Net:
        def __init__(self, process: Any) -> None:
            calls.append(f"made {process.plan.name}")

        def pull(self) -> None:
            calls.append("pull")

        def push(self) -> None:
            calls.append("push")

        def close(self) -> None:
            calls.append("close")

    process = loop.run(
        plan, layout, cycles=5, pace=False, on_cycle=lambda p: p.cycle == 2, transport=Net
    )
    process.block.close()
    assert process.cycle == 2
    assert calls == ["made pl", "pull", "push", "pull", "push", "close"]


# ---------------------------------------------------------------- lockstep, restarts


def test_serve_runs_the_segments_it_is_sent_and_answers_each(package: ModuleType) -> None:
    import os

    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    pl = fleet_process(package)
    requests, to_process = os.pipe()
    from_process, replies = os.pipe()
    try:
        for step in ((0, 0, False), (0, 0, True), (0, 0, True)):
            os.write(to_process, loop.STEP.pack(b"s", *step))
        os.write(to_process, loop.STEP.pack(b"q", 0, 0, False))
        loop.serve(pl, requests, replies)
        assert os.read(from_process, 16) == loop.READY + loop.DONE_REPLY * 3
        assert pl.cycle == 2
        assert layout.PERFORMANCE["lead"].read(pl.block.buf)["cycles"] == 3
        record = layout.PROCESSES["pl"].read(pl.block.buf)
        assert (record["state"], record["heartbeat"]) == (loop.STOPPED, 2)
        os.write(to_process, loop.STEP.pack(b"s", 0, 0, True)[:3])  # then the coordinator goes
        os.close(to_process)
        loop.serve(pl, requests, replies)
        assert os.read(from_process, 16) == loop.READY
        assert pl.cycle == 2
    finally:
        for fd in (requests, from_process, replies):
            os.close(fd)


def test_read_exactly_gathers_the_pieces_or_gives_none_at_the_end(package: ModuleType) -> None:
    import os

    loop = part(package, "rcs.loop")
    r, w = os.pipe()
    try:
        os.write(w, b"ab")
        os.write(w, b"cd")
        assert loop._read_exactly(r, 3) == b"abc"
        os.close(w)
        assert loop._read_exactly(r, 2) is None
    finally:
        os.close(r)


def test_a_second_copy_is_refused_only_while_a_live_other_owner_runs(package: ModuleType) -> None:
    import os

    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    contract = part(package, "rcs.contract")
    block = part(package, "rcs.block").Block(layout)
    plan = part(package, "main_pl").PLAN
    record = layout.PROCESSES["pl"]
    gone = 2**22 + 1  # above Linux's largest pid: no such process
    for state, pid, refused in [
        (contract.RUNNING, os.getppid(), True),
        (contract.STARTING, os.getppid(), True),
        (contract.STOPPED, os.getppid(), False),
        (contract.RUNNING, os.getpid(), False),
        (contract.RUNNING, gone, False),
        (contract.RUNNING, 0, False),
    ]:
        record.write(block.buf, state=state, pid=pid)
        if refused:
            with pytest.raises(
                loop.DuplicateProcess, match=f"process pl is already running \\(pid {pid}\\)"
            ):
                loop.Process(plan, layout, block, restarting=True)
        else:
            loop.Process(plan, layout, block, restarting=True)
    assert loop._alive(os.getpid()) and not loop._alive(gone)


def test_a_module_with_hook_state_refuses_a_restart_once_it_has_run(package: ModuleType) -> None:
    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    block = part(package, "rcs.block").Block(layout)
    plan = part(package, "main_pa").PLAN

    class Keeps(plan.classes["v1"]):  # type: ignore[misc,name-defined]
        HOOK_STATE_ON_RESTART = "refuse"

    keeping = plan._replace(classes={**plan.classes, "v1": Keeps})
    loop.Process(keeping, layout, block, restarting=True)  # it never ran
    layout.PERFORMANCE["v1"].write(block.buf, cycles=1)
    loop.Process(plan, layout, block, restarting=True)  # a module whose state may restart
    with pytest.raises(loop.RestartRefused, match="^v1 keeps hook state outside the block"):
        loop.Process(keeping, layout, block, restarting=True)


def test_start_makes_a_block_and_inits_only_idle_roots_on_a_restart(
    package: ModuleType, segment_name: str
) -> None:
    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    plan = part(package, "main_pl").PLAN
    first = loop.start(plan, layout, segment_name)
    try:
        assert first.block.owner
        assert layout.COMMAND_IN["lead"].read(first.block.buf)["command_num"] == 1
        first.beat(part(package, "rcs.contract").STOPPED)
        again = loop.start(plan, layout, segment_name, create=False)
        assert not again.block.owner
        assert layout.COMMAND_IN["lead"].read(again.block.buf)["command_num"] == 1, "kept"
        again.block.close()
    finally:
        first.block.close()


# ---------------------------------------------------------------- the generated modules' writes


class Logged:
    """A struct of a generated module whose stores are logged: (name, offset, first value)."""

    def __init__(self, name: str, struct: Any, log: list[tuple[str, int, int]]) -> None:
        self.name, self.struct, self.log = name, struct, log

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.struct, attribute)

    def pack_into(self, buf: Any, offset: int, *values: Any) -> None:
        self.log.append((self.name, offset, values[0]))
        self.struct.pack_into(buf, offset, *values)


class LoggedWords:
    """A block's word view (rcs.contract.words) whose stores are logged: ("WORD", offset,
    value)."""

    def __init__(self, view: Any, log: list[tuple[str, int, int]]) -> None:
        self.view, self.log = view, log

    def __getitem__(self, index: int) -> int:
        return int(self.view[index])

    def __setitem__(self, index: int, value: int) -> None:
        self.log.append(("WORD", index * 8, value))
        self.view[index] = value


def test_every_buffer_a_module_writes_is_marked_odd_alone_first_and_even_after(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The seqlock of a generated module's writes (status, commands, world outputs, its
    performance record as it publishes it): the sequence word is stored odd by itself (one
    word store) before the stores that change the fields (a `pack_into`, which zeroes its
    span first), and one more (even) after them."""
    contract, layout = part(package, "rcs.contract"), part(package, "layout")
    log: list[tuple[str, int, int]] = []
    monkeypatch.setattr(contract, "PERF", Logged("PERF", contract.PERF, log))  # its publish
    for name in ("lead", "v2"):
        module = part(package, name)
        for key, value in list(vars(module).items()):
            if isinstance(value, contract.Struct):
                monkeypatch.setattr(module, key, Logged(key, value, log))
        monkeypatch.setattr(module, "words", lambda buf: LoggedWords(contract.words(buf), log))
    pl, pb = fleet_process(package, "pl"), fleet_process(package, "pb")
    layout.COMMAND_IN["lead"].write(pl.block.buf, command_num=2, command=3)  # CONVOY
    layout.COMMAND_IN["v2"].write(pb.block.buf, command_num=1, command=3)  # DRIVE
    for _ in range(2):
        pl.run_cycle()
        pb.run_cycle()
    perf = {layout.PERFORMANCE[name].offset for name in ("lead", "v2")}
    # each store of fields: a Struct's pack_into
    stores = [(n, at, i) for i, (n, at, _) in enumerate(log) if n != "WORD"]
    assert {at for n, at, _ in stores if n == "PERF"} == perf
    assert {n for n, _, _ in stores} >= {
        "STATUS",
        "V1_COMMAND",
        "V2_COMMAND",
        "PERF",
        "WORLD_OUT_1",
    }
    odd: dict[int, list[int]] = {}
    for name, at, i in stores:
        before = [s for n, o, s in log[:i] if n == "WORD" and o == at]
        after = [s for n, o, s in log[i + 1 :] if n == "WORD" and o == at]
        assert before and before[-1] % 2 == 1, f"{name}: not marked odd alone first"
        assert after and after[0] == before[-1] + 1, f"{name}: not marked even after"
        assert log[i][2] == before[-1], f"{name} stores another word with its fields"
        odd.setdefault(at, []).append(before[-1])
    for at, marks in odd.items():  # each write moves the word on: no ABA
        assert marks == sorted(set(marks)), f"the word at {at} repeats: {marks}"
    for _ in range(3):  # lead in S1, waiting: nothing new to say (the longest cycle yet
        log.clear()  # publishes its performance record, as above)
        pl.run_cycle()
        assert [n for n, _, _ in log if n not in ("WORD", "PERF")] == [], "a status unchanged"
        assert {o for _, o, _ in log} <= perf, "only the performance record's word"


def test_a_supervisor_told_its_subordinate_is_lost_sees_it_in_error(package: ModuleType) -> None:
    """lead (on_lost: continue for v2): while pb is lost, lead sees v2's status as ERROR and
    its CONVOY rules go on alone; while pb is not, v2 is still EXECUTING for lead."""
    layout = part(package, "layout")
    pl = fleet_process(package)
    names = layout.ENUMS[("", "mode")]
    layout.COMMAND_IN["lead"].write(pl.block.buf, command_num=2, command=3)  # CONVOY
    pl.run_cycle()
    pl.run_cycle()
    assert names[layout.WORLD["mode"].read(pl.block.buf)["mode"]] == "TOGETHER"
    pl.react("pb")
    pl.run_cycle()
    assert names[layout.WORLD["mode"].read(pl.block.buf)["mode"]] == "ALONE"


def test_a_supervisor_numbers_its_next_command_after_an_operator_s(package: ModuleType) -> None:
    """An operator commanded v1 directly (#7) after lead's DRIVE (#1): lead's next command
    to v1 (HALT, its safe state) is numbered after the operator's (#8), so v1 takes it as
    new."""
    layout = part(package, "layout")
    pl = fleet_process(package)
    record, names = layout.COMMAND_IN["v1"], layout.COMMAND_NAMES["v1"]
    layout.COMMAND_IN["lead"].write(pl.block.buf, command_num=2, command=3)  # CONVOY
    pl.run_cycle()
    pl.run_cycle()
    assert record.read(pl.block.buf)["command_num"] == 1
    record.write(pl.block.buf, command_num=7, command=names.index("DRIVE"))  # the operator
    pl.react("pa")
    pl.run_cycle()
    sent = record.read(pl.block.buf)
    assert (sent["command_num"], names[sent["command"]]) == (8, "HALT")


def test_a_module_s_performance_record_keeps_its_last_shortest_and_longest_cycle(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a fake clock, cycles of 30, 10 and 20 ns (from the loop's reading before the module,
    its only one, to the module's own at its end): the first, the longest yet, is published
    at once (the others wait: the record still says one cycle); once its process publishes
    (every PERF_INTERVAL), the record says last 20, shortest 10, longest 30, three
    cycles."""
    layout = part(package, "layout")
    monkeypatch.setattr(part(package, "rcs.loop"), "PERF_INTERVAL_NS", 10**18)  # only at once
    pb = fleet_process(package, "pb")
    assert pb.plan.modules == ("v2",)
    readings = iter([1000, 1030, 2000, 2010, 3000, 3020])
    monkeypatch.setattr(part(package, "v2"), "perf_counter_ns", lambda: next(readings))
    monkeypatch.setattr(part(package, "rcs.loop"), "_module_clock", lambda: next(readings))
    record = layout.PERFORMANCE["v2"]
    for _ in range(3):
        pb.run_cycle()
    perf = record.read(pb.block.buf)
    assert (perf["last_cycle_ns"], perf["min_cycle_ns"], perf["max_cycle_ns"]) == (30, 30, 30)
    assert perf["cycles"] == 1
    pb.publish()
    perf = record.read(pb.block.buf)
    assert (perf["last_cycle_ns"], perf["min_cycle_ns"], perf["max_cycle_ns"]) == (20, 10, 30)
    assert perf["cycles"] == 3


def test_a_process_publishes_its_modules_figures_every_perf_interval_and_as_it_stops(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On fake clocks: v2's cycles of 30, 10, 20, 15, 25 and 18 ns; the first publishes at
    once (the longest yet), the others wait for the beat that comes PERF_INTERVAL after the
    last publish (not a nanosecond sooner), and the STOPPED beat publishes whatever is
    left."""
    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    now = [10**12]
    monkeypatch.setattr(loop, "time", SimpleNamespace(monotonic_ns=lambda: now[0]))
    pb = fleet_process(package, "pb")  # its first beat publishes, at now
    readings = iter([1000, 1030, 2000, 2010, 3000, 3020, 4000, 4015, 5000, 5025, 6000, 6018])
    monkeypatch.setattr(part(package, "v2"), "perf_counter_ns", lambda: next(readings))
    monkeypatch.setattr(loop, "_module_clock", lambda: next(readings))
    record = layout.PERFORMANCE["v2"]

    def shown() -> tuple[int, int]:
        perf = record.read(pb.block.buf)
        return perf["cycles"], perf["last_cycle_ns"]

    for _ in range(3):
        pb.run_cycle()
    assert shown() == (1, 30)
    now[0] += loop.PERF_INTERVAL_NS - 1
    pb.run_cycle()
    assert shown() == (1, 30)
    now[0] += 1
    pb.run_cycle()
    assert shown() == (5, 25)
    pb.run_cycle()
    assert shown() == (5, 25)
    pb.beat(part(package, "rcs.contract").STOPPED)
    assert shown() == (6, 18)
    perf = record.read(pb.block.buf)
    assert (perf["min_cycle_ns"], perf["max_cycle_ns"]) == (10, 30)


def test_a_beat_stores_the_liveness_words_and_the_whole_record_every_perf_interval(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On a fake monotonic clock: each beat's state, watchdog trips, heartbeat and time are
    in the record at once, read whole (its sequence word even); a count for people
    (last_cycle_ns) waits for the beat PERF_INTERVAL after the last whole write, and a
    process reported lost, then no longer lost, is shown with that very beat, as are a new
    longest cycle and a STOPPED beat."""
    loop, layout = part(package, "rcs.loop"), part(package, "layout")
    contract = part(package, "rcs.contract")
    now = [10**12]
    monkeypatch.setattr(loop, "time", SimpleNamespace(monotonic_ns=lambda: now[0]))
    pb = fleet_process(package, "pb")  # its first beat writes the record whole, at now
    record = layout.PROCESSES["pb"]
    pb.counters["last_cycle_ns"] = 777
    pb.counters["watchdog_trips"] = 3
    now[0] += 5
    pb.run_cycle()
    shown = record.read(pb.block.buf)
    assert (shown["state"], shown["watchdog_trips"]) == (contract.RUNNING, 3)
    assert (shown["heartbeat"], shown["beat_ns"], shown["last_cycle_ns"]) == (1, now[0], 0)
    pb.lost.add("pl")  # reported lost: shown with this beat
    pb.run_cycle()
    shown = record.read(pb.block.buf)
    assert (shown["lost"], shown["heartbeat"], shown["last_cycle_ns"]) == (1, 2, 777)
    pb.counters["last_cycle_ns"] = 888
    pb.run_cycle()
    assert record.read(pb.block.buf)["last_cycle_ns"] == 777
    pb.lost.clear()  # no longer lost: shown with this beat too
    pb.run_cycle()
    shown = record.read(pb.block.buf)
    assert (shown["lost"], shown["last_cycle_ns"]) == (0, 888)
    pb.counters["last_cycle_ns"] = 999
    now[0] += loop.PERF_INTERVAL_NS - 1
    pb.run_cycle()
    assert record.read(pb.block.buf)["last_cycle_ns"] == 888
    now[0] += loop.PERF_INTERVAL_NS
    pb.run_cycle()
    assert record.read(pb.block.buf)["last_cycle_ns"] == 999
    pb.counters["last_cycle_ns"] = pb.counters["max_cycle_ns"] = 1050  # the longest yet
    pb.run_cycle()
    assert record.read(pb.block.buf)["max_cycle_ns"] == 1050
    pb.counters["last_cycle_ns"] = 1111
    pb.run_cycle()
    assert record.read(pb.block.buf)["last_cycle_ns"] == 1050
    pb.beat(contract.STOPPED)
    shown = record.read(pb.block.buf)
    assert (shown["state"], shown["heartbeat"], shown["last_cycle_ns"]) == (
        contract.STOPPED,
        8,
        1111,
    )
    assert record.seq(pb.block.buf) % 2 == 0


def test_a_module_made_again_writes_whole_over_buffers_its_predecessor_left_odd(
    package: ModuleType,
) -> None:
    """v2's process died mid-write of v2's status and performance buffers (their words odd);
    the restarted v2 takes its words up from the block and its next writes leave both whole
    again, two sequence steps on (the performance record as the new process publishes it
    with its first beat; its first cycle publishes again if it is the longest yet)."""
    layout, plan = part(package, "layout"), part(package, "main_pb").PLAN
    pb = fleet_process(package, "pb")
    buf = pb.block.buf
    layout.COMMAND_IN["v2"].write(buf, command_num=1, command=3)  # DRIVE
    pb.run_cycle()
    status, perf = layout.STATUS_OUT["v2"], layout.PERFORMANCE["v2"]
    tear(package, status, buf)
    tear(package, perf, buf)
    odd = (status.seq(buf), perf.seq(buf))
    again = part(package, "rcs.loop").Process(plan, layout, pb.block)
    layout.COMMAND_IN["v2"].write(buf, command_num=2, command=3)
    again.run_cycle()
    assert status.read(buf)["status_num"] == 2
    assert perf.read(buf)["cycles"] >= 1
    assert status.seq(buf) == odd[0] + 3
    assert perf.seq(buf) in (odd[1] + 3, odd[1] + 5)


def test_the_modules_on_a_segment_share_one_word_view_and_the_segment_closes_under_them(
    package: ModuleType, segment_name: str
) -> None:
    """Every generated module stores its sequence words through one 8-byte word view of the
    block (rcs.contract.words): the modules of a process share it, what it stores is the word
    a tool reads, and closing the block releases it, so the segment is unmapped and removed
    while the modules still exist (a view left on it would make the unmap fail)."""
    import os

    layout, plan = part(package, "layout"), part(package, "main_pb").PLAN
    block = part(package, "rcs.block").Block(layout, segment_name)
    pb = part(package, "rcs.loop").Process(plan, layout, block)
    views = {id(m.words) for m in [*pb.instances.values(), *pb.stand_ins.values()]}
    layout.COMMAND_IN["v2"].write(block.buf, command_num=1, command=3)  # DRIVE
    pb.run_cycle()
    perf = layout.PERFORMANCE["v2"]
    seq = perf.seq(block.buf)
    assert len(views) == 1 and seq % 2 == 0 and seq > 2, "one view, the buffer written whole"
    assert pb.instances["v2"].words[perf.offset >> 3] == seq
    block.close()  # no BufferError: the word view went with the block's
    assert not os.path.exists(f"/dev/shm/{segment_name}")
    with pytest.raises(ValueError, match="released"):
        pb.instances["v2"].words[0]


def test_a_private_block_s_word_view_goes_with_its_view(package: ModuleType) -> None:
    """The word view of a block view no one closes (a harness's, a test's) is dropped with
    that view, not kept (with its memory) for the life of the process."""
    import gc

    contract = part(package, "rcs.contract")
    buf = memoryview(bytearray(64))
    words = contract.words(buf)
    assert contract.words(buf) is words and len(words) == 8
    words[1] = 7
    assert contract.SEQ.unpack_from(buf, 8)[0] == 7
    key = id(buf)
    assert key in contract._Words.views
    del buf, words
    gc.collect()
    assert key not in contract._Words.views


def test_a_layout_without_pacing_records_is_watched_with_the_declared_timeout(
    package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A package built before pacing records: check_liveness uses the timeout as it is."""
    layout = part(package, "layout")
    pl = fleet_process(package)
    beats(package, pl, "pa", state=2, beat_ns=1_000_000_000)
    layout.PACING["pa"].write(pl.block.buf, slow=3.0)
    monkeypatch.delattr(layout, "PACING")
    pl.check_liveness(1_000_000_000, 2_000_000_001, ["pa"])
    assert pl.lost == {"pa"}


def test_a_trip_count_that_starts_again_is_not_a_recovery_until_it_holds(
    package: ModuleType,
) -> None:
    """pb trips (lead told v2 is lost for a cycle), then pb starts again with its trip count
    back at 0: that check tells lead nothing new; the next, with the count unchanged, tells
    it v2 is back."""
    pl = fleet_process(package)
    lead = pl.modules["lead"]
    beats(package, pl, "pb", state=2, beat_ns=1_000_000_000, watchdog_trips=0)
    pl.check_liveness(1_000_000_000, 1_100_000_000, ["pb"])
    beats(package, pl, "pb", watchdog_trips=1)
    pl.check_liveness(1_000_000_000, 1_200_000_000, ["pb"])
    assert lead.v2_lost is True
    beats(package, pl, "pb", watchdog_trips=0)
    pl.check_liveness(1_000_000_000, 1_300_000_000, ["pb"])
    assert lead.v2_lost is True
    pl.check_liveness(1_000_000_000, 1_400_000_000, ["pb"])
    assert lead.v2_lost is False


def test_override_writers_of_a_named_segment_take_its_lock(
    package: ModuleType, segment_name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """force, unforce, latch_safe and reset of a named block each take the exclusive lock on
    the segment's file (writers in several processes serialise on it)."""
    import fcntl
    import os

    override, layout = part(package, "rcs.override"), part(package, "layout")
    block = part(package, "rcs.block").Block(layout, segment_name)
    locked: list[str] = []
    real = fcntl.flock

    def flock(fd: int, operation: int) -> None:
        if operation == fcntl.LOCK_EX | fcntl.LOCK_NB:
            locked.append(os.readlink(f"/proc/self/fd/{fd}"))
        real(fd, operation)

    monkeypatch.setattr(fcntl, "flock", flock)
    try:
        override.force(layout, block.buf, "v1_note", 1, segment=segment_name)
        override.unforce(layout, block.buf, "v1_note", segment=segment_name)
        override.latch_safe(layout, block.buf, ["v2_drive"], segment=segment_name)
        override.reset(layout, block.buf, segment=segment_name)
    finally:
        block.close()
    assert locked == [f"/dev/shm/{segment_name}"] * 4


def test_refusals_of_a_latched_field_say_so_and_a_reset_releases_only_those_named(
    package: ModuleType,
) -> None:
    override, layout, buf = fresh(package)
    override.latch_safe(layout, buf, ["v2_drive", "v2_brake"])
    with pytest.raises(
        override.OverrideError, match=r"^v2_drive is latched at its safe value: reset it first$"
    ):
        override.force(layout, buf, "v2_drive", 1.0)
    with pytest.raises(
        override.OverrideError, match=r"^v2_drive is latched at its safe value: reset releases it$"
    ):
        override.unforce(layout, buf, "v2_drive")
    assert override.reset(layout, buf, ["v2_drive"]) == ["v2_drive"]
    assert override.overrides(layout, buf) == {"v2_brake": ("SAFE", True)}


def test_unlink_of_a_segment_another_removed_meanwhile_says_it_was_gone(
    package: ModuleType, segment_name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    blocks = part(package, "rcs.block")
    raw_segment(package, segment_name, b"x")

    def gone(path: str) -> None:
        real_unlink(path)
        raise FileNotFoundError(path)

    real_unlink = blocks.os.unlink
    monkeypatch.setattr(blocks.os, "unlink", gone)
    assert blocks.unlink(segment_name) is False
    assert not blocks.exists(segment_name)


def test_a_latch_rewrites_a_value_a_racing_writer_changed_and_refuses_a_non_actuator(
    package: ModuleType,
) -> None:
    override, layout, buf = fresh(package)
    assert override.latch_safe(layout, buf, ["v2_drive"]) == ["v2_drive"]
    layout.WORLD["v2_drive"].write(buf, v2_drive=2.0)  # a writer past its look at the flag
    assert override.latch_safe(layout, buf, ["v2_drive"]) == []
    assert layout.WORLD["v2_drive"].read(buf)["v2_drive"] == -0.5
    with pytest.raises(
        override.OverrideError, match="^mode is not an actuator: it has no safe value$"
    ):
        override.latch_safe(layout, buf, ["mode"])


def test_an_empty_segment_is_refused_on_attach_and_can_be_removed(package: ModuleType) -> None:
    """A segment file of size 0 (its creator has not sized it yet, or died first): attaching
    is one BlockError saying so, not mmap's ValueError; `unlink` removes it."""
    layout, blocks = part(package, "layout"), part(package, "rcs.block")
    name = f"rcsgen_empty_{os.getpid()}"
    path = f"/dev/shm/{name}"
    with open(path, "wb"):
        pass
    try:
        with pytest.raises(blocks.BlockError, match=f"segment '{name}' is empty: being created"):
            blocks.Block(layout, name, create=False)
        assert blocks.unlink(name) is True
        assert not os.path.exists(path)
        assert blocks.unlink(name) is False
    finally:
        if os.path.exists(path):
            os.remove(path)


# ---------------------------------------------------------------- echo timeouts, made again

DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"


@pytest.fixture(scope="module")
def duo() -> Iterator[ModuleType]:
    scratch, name = generate(DUO)
    yield import_package(scratch / name, DUO)
    shutil.rmtree(scratch, ignore_errors=True)


def test_a_supervisor_made_again_counts_its_echo_timeout_from_then(duo: ModuleType) -> None:
    """duo's top (process p1) sends arm POWER; arm's process p2 never runs, so it never
    echoes. p1 is made again on the same block (as a restart is) two cycles after the send:
    the new top takes up the unechoed command and counts arm's echo timeout (5 cycles) from
    then, reporting ERROR in its 6th cycle and not before, instead of failing on a count it
    never started (resume sets it)."""
    layout, loop = part(duo, "layout"), part(duo, "rcs.loop")
    status_names = part(duo, "rcs.contract").STATUS_NAMES
    plan = part(duo, "main_p1").PLAN
    block = part(duo, "rcs.block").Block(layout)
    try:
        first = loop.Process(plan, layout, block)
        move = layout.COMMAND_NAMES["top"].index("MOVE")
        layout.COMMAND_IN["top"].write(block.buf, command_num=1, command=move)
        first.run_cycle()  # S0: POWER sent to arm
        first.run_cycle()
        again = loop.Process(plan, layout, block)
        seen = []
        for _ in range(6):
            again.run_cycle()
            seen.append(status_names[layout.STATUS_OUT["top"].read(block.buf)["status"]])
        assert seen == ["EXECUTING"] * 5 + ["ERROR"]
    finally:
        block.close()
