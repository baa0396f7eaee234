"""The values the tools hand from one step to the next are values: a report's options and
outcome, the configuration read from pyproject.toml, a command sent and a status read by the
harness, the neutral graph a picture is drawn from, a time line's bar, a trace's lane, what
`new` wrote, a scenario's checked parts. None can be changed by the step that receives it
(one renderer cannot alter what the next draws, a run cannot alter what the checks
approved), and each compares and hashes by its fields."""

from __future__ import annotations

import dataclasses

import pytest

from rcsgen.tools import config, graph, harness, report, scaffold
from rcsgen.tools.traces import read, station

FROZEN = [
    report.Options,
    report.Outcome,
    config.Config,
    harness.Sent,
    harness.Status,
    graph.Node,
    graph.Edge,
    graph.Cluster,
    graph.Graph,
    station.Bar,
    read.Lane,
    scaffold.Written,
]


def test_each_value_refuses_a_change_and_equal_values_are_one_key() -> None:
    # one test for them all: a mutation run tries the fastest test of a file, not each case
    for kind in FROZEN:
        value = object.__new__(kind)  # refused before any field is looked at
        first = dataclasses.fields(kind)[0].name
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, first, None)
        with pytest.raises(dataclasses.FrozenInstanceError):
            delattr(value, first)
    a = graph.Edge("x", "y", ("go",), "rule")
    assert len({a, graph.Edge("x", "y", ("go",), "rule"), graph.Edge("x", "y")}) == 2
    assert len({report.Options(), report.Options(strict=True), report.Options()}) == 2
    assert hash(report.Outcome(1, 0, 0, True)) == hash(report.Outcome(1, 0, 0, True))
