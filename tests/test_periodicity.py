"""Periodicity diagnostics of a paced process (rcsgen/runtime/loop.py `Periodicity`, fed by
the `Pacer`): lateness p99, period error, throttled warnings, on a fake clock."""

from __future__ import annotations

import random

import pytest

from rcsgen.runtime import contract
from rcsgen.runtime.contract import PERIODICITY_FIELDS, field_names
from rcsgen.runtime.loop import Pacer, Periodicity
from rcsgen.runtime.operate.ctl import periodicity_lines


class Clock:
    """A fake monotonic clock whose sleeps overshoot by the next of `late` (seconds)."""

    def __init__(self, late: list[float]) -> None:
        self.now, self.late = 100.0, list(late)

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds + (self.late.pop(0) if self.late else 0.0)


def paced(late: list[float], period: float = 0.01) -> tuple[Periodicity, list[str]]:
    lines: list[str] = []
    clock = Clock(late)
    periodicity = Periodicity("p1", period, lines.append)
    pacer = Pacer(period, clock, clock.sleep, periodicity=periodicity)
    for _ in range(len(late)):
        pacer.wait()
    return periodicity, lines


def test_lateness_p99_and_period_error_are_what_the_wake_ups_were() -> None:
    # 99 wake-ups 100 µs late and one 4 ms late: p99 is the 4 ms one (of 100, the 99th)
    late = [100e-6] * 99 + [4e-3]
    periodicity, lines = paced(late)
    assert periodicity.count == 100
    assert periodicity.p99() == pytest.approx(4e-3)
    assert periodicity.late_max == pytest.approx(4e-3)
    # each period is the nominal one plus the change in lateness: 100 µs once (the first,
    # from the start), 0 for 98, 3.9 ms for the last
    assert periodicity.error_max == pytest.approx(3.9e-3)
    assert periodicity.error_sum / periodicity.count == pytest.approx(4e-3 / 100)
    assert lines == []  # 4 ms is not more than half the 10 ms period
    assert "p99 4000 µs" in periodicity.line() and "100 wake-ups" in periodicity.line()


def test_late_wake_ups_warn_at_most_once_every_ten_seconds_with_their_count() -> None:
    # 10 ms period, wake-ups 6 ms late (more than half a period): the first warns, the
    # next ones within 10 s are counted into the following line
    late = [6e-3] * 1200  # the schedule keeps its boundaries: a wake-up every 10 ms, 12 s
    periodicity, lines = paced(late)
    assert len(lines) == 2, lines
    assert lines[0].startswith("p1: 1 wake-up more than 5 ms late (the last 6.0 ms")
    assert lines[1].startswith("p1: 1000 wake-ups more than")  # the 10 s after the first line
    assert periodicity.warnings == 2


def test_an_unpaced_process_measures_nothing() -> None:
    periodicity = Periodicity("p1", 0.0)
    pacer = Pacer(0.0, periodicity=periodicity)
    pacer.wait()
    assert periodicity.count == 0 and periodicity.p99() == 0.0
    assert periodicity.line() == "p1: periodicity: no paced wake-up"


def test_the_p99_from_the_histogram_is_within_a_sixteenth_of_the_exact_one() -> None:
    """The loop takes the p99 from a histogram (no sort per wake-up): against the exact
    p99 of the same window (sorted), never below it, at most 1/16 (+1 µs) above it, and
    never above the largest lateness; the window forgets the oldest wake-ups."""
    rng = random.Random(24)
    for scale in (20e-6, 300e-6, 8e-3):
        late = [rng.expovariate(1 / scale) for _ in range(6000)]
        periodicity = Periodicity("p1", 0.01, window=4096)
        for value in late:
            periodicity.add(0.0, value, 0.0)
        kept = sorted(late[-4096:])
        exact = kept[int(0.99 * len(kept))]
        assert exact <= periodicity.p99() <= exact * (1 + 1 / 16) + 1e-6, scale
        assert periodicity.p99() <= periodicity.late_max
        assert sum(periodicity.histogram) == 4096


def test_the_control_record_fields_read_back_as_the_figures_and_the_line() -> None:
    late = [100e-6] * 99 + [4e-3]
    periodicity, _ = paced(late)
    names = field_names(PERIODICITY_FIELDS)
    # the record's p99 is refreshed every 16 wake-ups: as of the 96th, before the 4 ms one
    assert dict(zip(names, periodicity.fields(), strict=True))["lateness_p99_ns"] == 100_000
    periodicity.p99()  # as the loop does once more when it stops
    values = dict(zip(names, periodicity.fields(), strict=True))
    figures = contract.periodicity(values)
    assert figures == {
        "period_ms": 10.0,
        "wakeups": 100,
        "period_error_mean_us": 40.0,
        "period_error_max_us": 3900.0,
        "lateness_p99_us": 4000.0,
        "lateness_max_us": 4000.0,
        "lateness_warnings": 0,
    }
    assert contract.periodicity_line("p1", figures) == (
        "p1: period error mean 40 µs, max 3900 µs; wake-up lateness p99 4000 µs, max "
        "4000 µs over 100 wake-ups (period 10 ms), 0 lateness warnings"
    )
    assert contract.periodicity(dict.fromkeys(values, 0)) is None  # not paced


def test_the_status_section_names_each_process_its_figures_and_slowest_module() -> None:
    """ctl status's periodicity section (its own function, `periodicity_lines`)."""
    figures = {
        "period_ms": 10.0,
        "wakeups": 100,
        "period_error_mean_us": 40.0,
        "period_error_max_us": 3900.0,
        "lateness_p99_us": 4000.0,
        "lateness_max_us": 4000.0,
        "lateness_warnings": 2,
    }
    snapshot = {
        "processes": {
            "p1": {"periodicity": figures, "last_cycle_us": 50.5, "max_cycle_us": 80.0},
            "p2": {"periodicity": None, "last_cycle_us": 5.0, "max_cycle_us": 9.0},
            "p3": {"state": "?"},
        },
        "modules": {
            "a": {"process": "p1", "max_cycle_us": 20.0},
            "b": {"process": "p1", "max_cycle_us": 35.5},
            "c": {"process": "p2", "max_cycle_us": 4.0},
        },
    }
    assert periodicity_lines(snapshot) == [
        "periodicity p1: period error mean 40 µs, max 3900 µs; wake-up lateness p99 4000 µs, "
        "max 4000 µs over 100 wake-ups (period 10 ms), 2 lateness warnings; cycle last "
        "50.5 µs, max 80 µs; slowest module b (max 35.5 µs)",
        "periodicity p2: periodicity: no paced wake-up; cycle last 5 µs, max 9 µs; slowest "
        "module c (max 4 µs)",
    ]


def test_a_paced_run_ends_its_trace_with_a_timing_record_that_trace_show_prints() -> None:
    """A scenario run against devices is paced (scenario/run.py `Pace`): it measures its
    wake-ups as a process does and its trace ends with one timing record, which the trace
    reader keeps apart from the cycles, `trace show` puts in its title and the comparison
    with a golden trace leaves out."""
    from rcsgen.tools import traces
    from rcsgen.tools.scenario.run import Pace, first_difference
    from rcsgen.tools.traces import view

    pace = Pace(0.005)
    assert pace.line(0) is None  # nothing paced yet
    for _ in range(6):
        pace.wait()
    record = pace.line(6)
    assert record is not None and traces.is_timing(record)
    cycle = '{"cycle":%d,"modules":{"m":{"command":"INIT","command_num":1,"rule":null,'
    cycle += '"state":"NOP","status":"DONE","status_num":1}},"world":{}}'
    lines = [cycle % n for n in range(1, 7)]
    assert not any(traces.is_timing(line) for line in lines)
    trace = traces.parse("\n".join([*lines, record]))
    assert len(trace) == 6 and trace.periodicity is not None
    assert trace.periodicity["wakeups"] == 5 and trace.periodicity["period_ms"] == 5.0
    assert 0 <= trace.periodicity["lateness_p99_us"] <= trace.periodicity["lateness_max_us"]
    page = view.render(trace, traces.lanes(trace, None))
    assert "paced: period error mean" in page and "over 5 wake-ups (period 5 ms)" in page
    assert first_difference(lines, [*lines, record]) is None  # timing is never the same
    with pytest.raises(traces.TraceError, match="a cycle after the run's timing record"):
        traces.parse("\n".join([*lines[:3], record, *lines[3:]]))
    with pytest.raises(traces.TraceError, match="after the cycles"):
        traces.parse("\n".join([record, *lines]))
    interrupted = traces.parse("\n".join([*lines, record, '{"cycle":7,"interrupted":"SIGINT"}']))
    assert interrupted.interrupted == "SIGINT" and interrupted.periodicity is not None
