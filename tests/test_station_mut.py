"""The station view's time line on a trace made here (tests/test_station_view.py draws the
golden runs): which runs of work become bars, and the SVG a person sees, element by element."""

from __future__ import annotations

import re
from types import SimpleNamespace

import pytest

from rcsgen.tools.traces import station
from rcsgen.tools.traces.read import Trace


def column(commands: list[str], statuses: list[str]) -> dict[str, list[object]]:
    return {"command": commands, "status": statuses, "state": ["S"] * len(commands)}


@pytest.fixture
def trace() -> Trace:
    busy = "EXECUTING"
    return Trace(
        "t",
        [10, 11, 12, 13],
        ["cmm", "fx", "op/fx"],
        {  # INIT and HALT are no work; a new command is a new bar; DONE ends one
            "cmm": column(
                ["INIT", "INSPECT_FEATURE", "INSPECT_FEATURE", "HALT"], ["DONE", busy, busy, busy]
            ),
            "fx": column(["A", "A", "B", "B"], [busy, busy, busy, "DONE"]),
            "op/fx": column(["NOP", "NOP", "NOP", "PLACE_PART"], ["DONE", "DONE", "DONE", busy]),
        },
    )


def test_a_bar_is_a_run_of_one_command_executing_and_init_or_halt_is_none(trace: Trace) -> None:
    assert station.bars(trace) == [
        station.Bar(1, 0, 1, "A"),
        station.Bar(1, 2, 2, "B"),
        station.Bar(3, 3, 3, "PLACE_PART"),  # the operator's lane: every op/ channel
        station.Bar(4, 1, 2, "INSPECT_FEATURE"),
    ]


def test_the_time_line_draws_each_lane_and_bar_to_scale(trace: Trace) -> None:
    """720 pixels for 4 cycles: 180 a cycle, after the 70 of the labels; a lane 18 high,
    and 14 under the six for the axis."""
    lanes = "".join(
        f'<text class="label" x="0" y="{18 * i + 13}">{label}</text>'
        f'<line class="lane" x1="70" y1="{18 * i + 18}" x2="790" y2="{18 * i + 18}"/>'
        for i, label in enumerate(["planner", "fixturing", "tooling", "operator", "CMM", "probe"])
    )
    assert station.timeline(trace, station.bars(trace)) == (
        '<svg id="timeline" width="790" height="122" viewBox="0 0 790 122">'
        + lanes
        + '<rect class="bar A" data-lane="fixturing" data-first="10" data-last="11" x="70.0" '
        'y="21" width="360.0" height="12"><title>A 10–11</title></rect>'
        '<rect class="bar B" data-lane="fixturing" data-first="12" data-last="12" x="430.0" '
        'y="21" width="180.0" height="12"><title>B 12–12</title></rect>'
        '<rect class="bar PLACE_PART" data-lane="operator" data-first="13" data-last="13" '
        'x="610.0" y="57" width="180.0" height="12"><title>PLACE_PART 13–13</title></rect>'
        '<rect class="bar INSPECT_FEATURE" data-lane="CMM" data-first="11" data-last="12" '
        'x="250.0" y="75" width="360.0" height="12"><title>INSPECT_FEATURE 11–12</title></rect>'
        '<text class="axis" x="70" y="120">cycle 10</text>'
        '<text class="axis end" x="790" y="120">13</text>'
        '<line id="cursor" x1="70" y1="0" x2="70" y2="108"/></svg>'
    )


def test_a_bar_shorter_than_a_pixel_is_drawn_a_pixel_wide() -> None:
    """1,440 cycles on 720 pixels: a one-cycle bar would be half a pixel, and is drawn one."""
    n = 1440
    trace = Trace(
        "t",
        list(range(n)),
        ["cmm"],
        {"cmm": column(["INIT"] * (n - 1) + ["HOME"], ["EXECUTING"] * n)},
    )
    [bar] = station.bars(trace)
    assert bar == station.Bar(4, n - 1, n - 1, "HOME")
    assert 'x="789.5" y="75" width="1.0" height="12"' in station.timeline(trace, [bar])


def test_the_station_follows_the_commands_as_they_complete() -> None:
    """The plate is mounted from EQUIP_SETUP's DONE on; the part is on the fixture from
    PLACE_PART's DONE, re-seated while REFIXTURE_PART runs and back when it is DONE,
    unloaded at UNLOAD_PART's DONE; the probe is in the head from LOAD_PROBE's DONE on."""
    fx = [
        ("EQUIP_SETUP", "EXECUTING"),
        ("EQUIP_SETUP", "DONE"),
        ("PLACE_PART", "EXECUTING"),
        ("PLACE_PART", "DONE"),
        ("REFIXTURE_PART", "EXECUTING"),
        ("REFIXTURE_PART", "DONE"),
        ("UNLOAD_PART", "EXECUTING"),
        ("UNLOAD_PART", "DONE"),
        ("NOP", "DONE"),
    ]
    tl = [("LOAD_PROBE", "EXECUTING")] * 2 + [("LOAD_PROBE", "DONE")] + [("NOP", "DONE")] * 6
    trace = Trace(
        "t",
        list(range(9)),
        ["fx", "tl"],
        {
            "fx": column([c for c, _ in fx], [s for _, s in fx]),
            "tl": column([c for c, _ in tl], [s for _, s in tl]),
        },
    )
    assert station.station(trace) == {
        "plate": ["none"] + ["mounted"] * 8,
        "part": ["none"] * 3
        + ["on the fixture", "re-seated", "on the fixture", "on the fixture"]
        + ["unloaded"] * 2,
        "probe": ["none"] * 2 + ["loaded"] * 7,
    }
    assert station.done_at(trace, "fx", "PLACE_PART") == [i == 3 for i in range(9)]


def test_the_page_data_holds_the_requests_results_and_panel_as_runs_of_its_strings() -> None:
    def asking(command: str, states: list[str]) -> dict[str, list[object]]:
        return {"command": [command] * 3, "status": ["EXECUTING"] * 3, "state": states}

    idle = column(["NOP"] * 3, ["DONE"] * 3)
    results = [None, {"measured": 2, "failed": 0}, {"measured": 2, "failed": 1}]
    columns = {
        "fx": idle,
        "tl": idle,
        "op/fx": asking("PLACE_PART", ["S0", "ASKING", "ASKING"]),
        "op/tl": asking("LOAD_PROBE", ["S0", "S0", "ASKING"]),
        "ms": column(["M"] * 3, ["DONE"] * 3) | {"result": results},
    }
    trace = Trace("t", [5, 6, 7], sorted(columns), columns)
    data = station.payload(trace, SimpleNamespace(name="insp", cycle_period=0.1))  # type: ignore[arg-type]
    strings = data.pop("strings")

    def said(runs: list[int]) -> list[tuple[int, object]]:
        return [(at, strings[i]) for at, i in zip(runs[::2], runs[1::2], strict=True)]

    assert said(data.pop("requests")) == [
        (0, ""),
        (1, "PLACE_PART (for fx)"),
        (2, "PLACE_PART (for fx), LOAD_PROBE (for tl)"),
    ]
    assert {k: said(v) for k, v in data.pop("results").items()} == {
        "ms.measured": [(0, "None"), (1, "2")],
        "ms.failed": [(0, "None"), (1, "0"), (2, "1")],
    }
    assert [c["module"] for c in data.pop("controllers")] == ["ms", "fx", "tl"]  # PANEL's order
    assert {k: said(v) for k, v in data.pop("station").items()} == {
        "plate": [(0, "none")],
        "part": [(0, "none")],
        "probe": [(0, "none")],
    }
    assert data == {
        "source": "t",
        "system": "insp",
        "period": 0.1,
        "speed": 10,
        "n": 3,
        "cycles": [5, 6, 7],
        "lanes": {"label": 70, "width": 720},
    }


def test_each_lane_shows_its_own_modules_work() -> None:
    rows = ["jp", "fx", "tl", "op/fx", "op/tl", "cmm", "prim", "wc"]  # wc: on no lane
    busy = column(["WORK"], ["EXECUTING"])
    trace = Trace("t", [1], sorted(rows), {row: busy for row in rows})
    lanes = [(station.LANES[bar.lane][0], bar.first) for bar in station.bars(trace)]
    assert lanes == [
        ("planner", 0),
        ("fixturing", 0),
        ("tooling", 0),
        ("operator", 0),  # op/fx
        ("operator", 0),  # op/tl
        ("CMM", 0),
        ("probe", 0),
    ]


def test_the_page_draws_a_bar_on_each_lane_and_a_trace_without_the_station_is_refused() -> None:
    """The whole page from a trace made here: every lane's work a bar on its own lane, the
    station's plate, part and probe in its data; a trace without fixturing, tooling and the
    CMM is refused in one line naming what it lacks."""
    fx = ["EQUIP_SETUP", "PLACE_PART", "REFIXTURE_PART", "REFIXTURE_PART", "UNLOAD_PART"]
    fx_status = ["DONE", "DONE", "EXECUTING", "DONE", "DONE"]
    work = column(["WORK"] * 5, ["EXECUTING"] * 5)
    columns = {row: work for row in ("jp", "tl", "op/fx", "cmm", "prim")}
    columns["fx"] = column(fx, fx_status)
    columns["ms"] = column(["M"] * 5, ["DONE"] * 5) | {"result": [{"measured": 1}] * 5}
    trace = Trace("run.jsonl", list(range(5)), sorted(columns), columns)
    system = SimpleNamespace(name="insp", cycle_period=0.1)
    page = station.render(trace, system)  # type: ignore[arg-type]
    drawn = re.findall(r'<rect class="bar (\w+)" data-lane="(\w+)"', page)
    assert drawn == [
        ("WORK", "planner"),
        ("REFIXTURE_PART", "fixturing"),
        ("WORK", "tooling"),
        ("WORK", "operator"),
        ("WORK", "CMM"),
        ("WORK", "probe"),
    ]
    assert "<title>run.jsonl · insp: the part on the CMM</title>" in page
    assert station.STATION in page and page.count('<svg id="timeline"') == 1
    lacking = Trace("t", [1], ["cmm"], {"cmm": work})
    with pytest.raises(station.StationError) as refused:
        station.render(lacking, system)  # type: ignore[arg-type]
    assert str(refused.value) == (
        "t is not a trace of an inspection workstation: it has no fx, tl (the station view "
        "reads fixturing, tooling and the CMM)"
    )


def test_a_bar_starts_where_its_first_cycle_is_to_a_tenth_of_a_pixel() -> None:
    """7 cycles on 720 pixels: a bar from the second cycle starts 102.857... pixels after
    the labels' 70, drawn at 172.9, and is as wide (102.9)."""
    work = column(["INIT", "WORK"] + ["INIT"] * 5, ["DONE", "EXECUTING"] + ["DONE"] * 5)
    trace = Trace("t", list(range(7)), ["cmm"], {"cmm": work})
    svg = station.timeline(trace, station.bars(trace))
    assert 'x="172.9" y="75" width="102.9" height="12"' in svg
