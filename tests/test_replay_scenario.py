"""A counter-example of `rcsgen prove` written as the scenario that replays it
(rcsgen/tools/replay.py's events and scenario_text): cycle by cycle the command from above
with its parameters, the subordinates' answers (an ERROR with the reason the model chose),
the world values that made the choices, the other modules of its process held; why it
cannot be replayed when a process is lost; and the file a person runs with `rcsgen run`
is a valid scenario of the system. No solver and no generated code run here."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pytest
import yaml
from test_prove_text import edge  # an Edge where nothing happens but what is given

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.compiler.prove.model import Edge, State
from rcsgen.compiler.prove.properties import Finding
from rcsgen.compiler.types import BOOL, FLOAT, INT, Str
from rcsgen.tools.replay import _free, events, scenario_text
from rcsgen.tools.scenario.check import check_scenario

MINER = Path(__file__).resolve().parent.parent / "specs" / "miner"


@pytest.fixture(scope="module")
def miner() -> IRSystem:
    return compile_paths([MINER]).systems[0]


AFTER = State("REPOSITION", "S1", "EXECUTING", 0, ())


def finding(*edges: Edge) -> Finding:
    trace = [(e, AFTER) for e in edges]
    return Finding(
        "W702", "co", "REPOSITION", "S1", 1, Span("co.yaml", 3, 1), "it never ends", "", trace
    )


def test_each_cycle_of_a_counter_example_is_an_event(miner) -> None:
    found, why = events(
        miner,
        finding(
            edge(
                new="REPOSITION",
                valuation=(
                    (("param", "x"), Fraction(5, 2)),
                    (("param", "y"), Fraction(4, 1)),
                    (("world", "true_x"), Fraction(1, 4)),
                    (("local", "n"), 3),  # a local is the controller's own: not set
                ),
            ),
            edge(),  # nothing happened: no event
            edge(
                answers=(("vg", "ERROR"), ("cr", "DONE"), ("cc", "ERROR")),
                valuation=(
                    (("reason", "vg"), "BLOCKED"),
                    (("reason", "cc"), "NONE"),
                    (("world", "loose_coal"), True),
                    (("world", "seam"), "COAL"),
                ),
            ),
        ),
    )
    assert why == ""
    co_process = next(p for p in miner.processes if "co" in p.modules)
    held = {m: {"dont_run": True} for m in co_process.modules if m != "co"}
    first = {
        "cycle": 1,
        "command": "co.REPOSITION",
        "doc": "the command from above",
        "with": {"x": 2.5, "y": 4},  # a whole Fraction an int, another a float
        "overrides": True,  # co has a supervisor: the scenario stands in for it
        "set": {"true_x": 0.25},
    }
    if held:
        first["mode"] = held
    assert found == [
        first,
        {
            "cycle": 3,
            "reply": {"vg": "ERROR(BLOCKED)", "cr": "DONE", "cc": "ERROR"},
            "set": {"loose_coal": True, "seam": "COAL"},
        },
    ]


def test_a_parameter_the_model_left_free_is_zero_or_false(miner) -> None:
    found, _ = events(miner, finding(edge(new="REPOSITION")))
    assert found[0]["with"] == {"x": 0, "y": 0}
    # each kind of parameter: false, the empty text, zero (of the scenario's own types)
    free = [_free(kind) for kind in (BOOL, Str(8), INT, FLOAT)]
    assert free == [False, "", 0, 0] and [type(v) for v in free] == [bool, str, int, int]


def test_a_lost_process_cannot_be_replayed_and_says_when(miner) -> None:
    _, why = events(miner, finding(edge(), edge(lost="pc2"), edge(lost="pc3")))
    assert why == "process pc3 is lost in cycle 3, which a replay cannot do"


def test_the_written_scenario_is_one_the_system_runs(miner, tmp_path) -> None:
    text = scenario_text(
        miner,
        finding(
            edge(new="REPOSITION", valuation=((("param", "x"), Fraction(3, 1)),)),
            edge(answers=(("vg", "DONE"),)),
            edge(),
        ),
        "w702_co",
    )
    assert text.startswith(
        "# yaml-language-server: $schema=../../../rcsgen/compiler/schemas/scenario.schema.json\n"
        "# Written by `rcsgen prove`: the counter-example of W702, cycle by cycle.\n"
    )
    data = yaml.safe_load(text)
    assert {k: data[k] for k in ("scenario", "title", "doc", "max_cycles")} == {
        "scenario": "w702_co",
        "title": "rcsgen prove: W702 in co",
        "doc": "it never ends",
        "max_cycles": 3,
    }
    assert data["process"] == next(p.name for p in miner.processes if "co" in p.modules)
    assert [e["cycle"] for e in data["events"]] == [1, 2]
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "system.yaml").write_bytes((MINER / "system.yaml").read_bytes())
    path = tmp_path / "scenarios" / "w702_co.yaml"
    path.write_text(text, encoding="utf-8")
    _, diags = check_scenario(path, miner)
    assert [d.render() for d in diags.errors] == []
