"""Periodicity diagnostics of a paced process (rcsgen/runtime/loop.py `Periodicity`, fed by
the `Pacer`): lateness p99, period error, throttled warnings, on a fake clock."""

from __future__ import annotations

import pytest

from rcsgen.runtime.loop import Pacer, Periodicity


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
    assert lines[0].startswith("p1: 1 wake-up(s) more than 5 ms late (the last 6.0 ms")
    assert lines[1].startswith("p1: 1000 wake-up(s)")  # the 10 s after the first line
    assert periodicity.warnings == 2


def test_an_unpaced_process_measures_nothing() -> None:
    periodicity = Periodicity("p1", 0.0)
    pacer = Pacer(0.0, periodicity=periodicity)
    pacer.wait()
    assert periodicity.count == 0 and periodicity.p99() == 0.0
    assert periodicity.line() == "p1: periodicity: no paced wake-up"
