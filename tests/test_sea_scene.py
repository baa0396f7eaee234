"""The sea view's scene and plan (rcsgen/tools/traces/sea.py) from hooks and a trace made by
hand, in the unit tier: the keels from the sonar simulator's hook state, the route and its
alternates from the planner's, the haven from the HAVEN constant; the frame around all of
it with its margin; the plan view's SVG (keels, route, waypoints, track, haven) at the
frame's scale; the page data; a trace or system the view cannot draw, in one line.
test_sea_view draws the submarine's golden traces through its real hooks."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from rcsgen.tools.traces import sea
from rcsgen.tools.traces.read import Trace


def system(tmp_path: Path, sonar: bool = True) -> Any:
    tag = tmp_path.name
    (tmp_path / f"sonar_{tag}.py").write_text(
        "def keels(settings):\n    return [(100, 200, 50), ('0', 0, 10.5)]\n"
    )
    (tmp_path / f"plan_{tag}.py").write_text(
        "class M:\n    route = [(0, 0), (1000, 0)]\n    alternates = {'A': (500, 300)}\n"
        "def mission(settings):\n    return M()\n"
    )
    controllers = [
        SimpleNamespace(
            hooks_state="keels" if sonar else None,
            hooks=("ping",),
            hooks_module=f"sonar_{tag}",
            plans=(),
            constants=(("RANGE", "9"),),
        ),
        SimpleNamespace(
            hooks_state="mission",
            hooks=(),
            hooks_module=f"plan_{tag}",
            plans=("transit",),
            constants=(("OTHER", "1"), ("HAVEN", "250.0")),
        ),
    ]
    return SimpleNamespace(name="sub", cycle_period=0.5, controllers=controllers)


def trace(**world: list[Any]) -> Trace:
    column = {
        "command": ["INIT", "GO"],
        "command_num": [1, 2],
        "status": ["DONE", "EXECUTING"],
        "status_num": [1, 2],
        "state": ["S0", "S1"],
        "rule": [None, None],
    }
    base = {"pos_x": [0.0, 500.0], "pos_y": [0.0, 100.0], "announcement": ["", "ice ahead"]}
    modules = ["cc", "helm", "prop", "sm", "x"]
    return Trace("t.jsonl", [1, 2], modules, dict.fromkeys(modules, column), base | world)


def test_the_scene_is_the_runs_own_keels_route_and_haven(tmp_path: Path) -> None:
    found = sea.scene(system(tmp_path), tmp_path, {"map": "m"})
    assert found == sea.Scene(
        keels=[(100.0, 200.0, 50.0), (0.0, 0.0, 10.5)],
        route=[(0.0, 0.0), (1000.0, 0.0)],
        alternates=[(500.0, 300.0)],
        haven=250.0,
    )
    deaf = tmp_path / "deaf"
    deaf.mkdir()
    with pytest.raises(sea.SeaError) as error:
        sea.scene(system(deaf, sonar=False), deaf, {})
    assert str(error.value) == (
        "system sub has no ice keels to draw: the sea view needs a simulator whose hooks keep "
        "the keels (hooks_state) and ping them (a `ping` hook)"
    )


def test_the_plan_is_drawn_in_a_frame_around_the_track_keels_and_route(tmp_path: Path) -> None:
    found = sea.Scene([(100.0, 200.0, 50.0)], [(0.0, 0.0), (1000.0, 0.0)], [(500.0, 300.0)], 250.3)
    f = sea.frame(trace(), found)
    # x from 0 to 1000, y from 0 to 200; 400 m of margin and the widest keel's 50 around
    assert (f.x0, f.y1, f.scale, f.width, f.height) == (-450.0, 650.0, 0.4, 760, 440)
    assert f.px(100.0, 200.0) == (220.0, 180.0)
    drawn = sea.svg(trace(), found, f)
    assert drawn == (
        '<svg id="sea" width="760" height="440" viewBox="0 0 760 440">'
        '<rect class="water" width="760" height="440"/>'
        '<g id="keels"><circle class="keel" cx="220.0" cy="180.0" r="20.0"/></g>'
        '<polyline id="route" points="180.0,260.0 580.0,260.0"/>'
        '<circle class="waypoint" cx="180.0" cy="260.0" r="4"/>'
        '<circle class="waypoint" cx="580.0" cy="260.0" r="4"/>'
        '<circle class="alternate" cx="380.0" cy="140.0" r="4"/>'
        '<polyline id="track" points="180.0,260.0 380.0,220.0"/>'
        '<rect id="haven" width="200.2" height="200.2"/>'  # 2 x 250.3 m at 0.4 px/m
        '<g id="ship"><path d="M 0 -9 L 5 6 L 0 3 L -5 6 Z"/></g></svg>'
    )
    no_haven = sea.svg(trace(), sea.Scene([], [], [], None), f)
    assert '<rect id="haven" width="0.0" height="0.0"/>' in no_haven


def test_the_page_data_and_a_trace_the_view_cannot_draw(tmp_path: Path) -> None:
    found = sea.Scene([(100.0, 200.0, 50.0)], [], [], None)
    t = trace(depth=[10, float("inf")])
    f = sea.frame(t, found)
    data = sea.payload(t, SimpleNamespace(name="sub", cycle_period=0.5), found, f, "transit")  # type: ignore[arg-type]
    assert data["world"] == {
        "pos_x": [0.0, 500.0],
        "pos_y": [0.0, 100.0],
        "depth": [10.0, None],
        "announcement": [0, 0, 1, 1],  # runs over the page's strings
    }
    assert data["strings"][:2] == ["", "ice ahead"]
    # the command controller's, ship maneuver's, helm's and propulsion's, in that order
    assert [c["module"] for c in data["controllers"]] == ["cc", "sm", "helm", "prop"]
    assert {k: data[k] for k in ("source", "system", "scenario", "period", "speed", "n")} == {
        "source": "t.jsonl",
        "system": "sub",
        "scenario": "transit",
        "period": 0.5,
        "speed": 50,
        "n": 2,
    }
    assert data["frame"] == {"x0": f.x0, "y1": f.y1, "scale": f.scale} and data["haven"] is None
    short = trace()
    del short.world["pos_y"]
    with pytest.raises(sea.SeaError) as error:
        sea.render(short, system(tmp_path), tmp_path, {})
    assert str(error.value) == (
        "t.jsonl lacks the world fields the sea view needs: pos_y; add them to the scenario's "
        "`trace: world:` list and run it again"
    )


def test_a_page_is_drawn_from_the_trace_and_the_hooks_of_the_system_that_ran(
    tmp_path: Path,
) -> None:
    folder = tmp_path / f"s_{tmp_path.name}"
    folder.mkdir()
    (folder / "system.yaml").write_text("system: sub\n")
    sub = system(folder)
    sub.source = f"{folder.name}/system.yaml"
    page = sea.page_for(trace(), sub, tmp_path, tmp_path / "t.jsonl", None)
    assert "<title>t.jsonl · sub: the transit among the ice</title>" in page
    assert '<svg id="sea" width="760" height=' in page  # the plan, drawn in the page
    assert '"scenario":""' in page and '"haven":250.0' in page
    alone = sea.render(trace(), sub, folder, {})  # no scenario named: none said
    assert '"scenario":""' in alone


def test_figure_33s_displays_are_drawn_for_the_script_to_turn_and_fill() -> None:
    """The four displays beside the plan, each a DIAL-wide square: the hull in profile on
    its level line (the script turns `hull` by the bubble angle), the compass card with its
    course mark and heading needle (north up), the sonar's beams from the bow at the
    bottom's middle, each drawn out to DIAL - 20 px at its angle (0: straight up to the
    surface line's height), and the depth gauge (surface, bottom, order, ship)."""
    sonar = sea.Sonar(["a", "b", "c"], [-30.0, 0.0, 20.0], 800.0)
    drawn = sea.displays(sea.Scene([], [], [], None, sonar=sonar))
    assert drawn == (
        '<svg id="bubble" class="display" width="150" height="150">'
        '<line class="level" x1="8" y1="75.0" x2="142" y2="75.0"/>'
        '<g id="hull" transform="translate(75.0 75.0)">'
        '<path d="M -55 0 Q -50 -9 -20 -9 L 35 -9 Q 58 -8 60 0 Q 58 8 35 9 L -20 9 '
        'Q -50 9 -55 0 Z"/><rect x="-2" y="-20" width="14" height="11"/></g>'
        '<text id="bubble-text" x="75.0" y="142"></text></svg>'
        '<svg id="compass" class="display" width="150" height="150">'
        '<circle class="card" cx="75.0" cy="75.0" r="63.0"/><text x="75.0" y="18">N</text>'
        '<line id="course-mark" x1="75.0" y1="12.0" x2="75.0" y2="22.0"/>'
        '<line id="heading-needle" x1="75.0" y1="75.0" x2="75.0" y2="18.0"/>'
        '<text id="speed-text" x="75.0" y="103.0"></text></svg>'
        '<svg id="sonar" class="display" width="150" height="150">'
        '<line class="beam" id="beam-0" data-angle="-30.0" x1="75.0" y1="140" x2="10.0" '
        'y2="27.4"/>'
        '<line class="beam" id="beam-1" data-angle="0.0" x1="75.0" y1="140" x2="75.0" '
        'y2="10.0"/>'
        '<line class="beam" id="beam-2" data-angle="20.0" x1="75.0" y1="140" x2="119.5" '
        'y2="17.8"/></svg>'
        '<svg id="depth-gauge" class="display" width="150" height="150">'
        '<line class="surface" x1="20" y1="10" x2="130" y2="10"/>'
        '<line id="depth-bottom" x1="20" x2="130" y1="0" y2="0"/>'
        '<line id="depth-order" x1="20" x2="130" y1="0" y2="0"/>'
        '<path id="depth-ship" d="M 55.0 0 l 40 0 l -6 -5 l -28 0 Z"/>'
        '<text id="depth-text" x="75.0" y="146"></text></svg>'
    )
    # without the sonar's beams (hooks that name none) the sonar display is empty
    plain = sea.displays(sea.Scene([], [], [], None))
    assert '<svg id="sonar" class="display" width="150" height="150"></svg>' in plain
    assert "beam" not in plain


def test_without_keels_the_frame_is_the_track_and_route_with_the_margin_alone() -> None:
    """No keel: nothing widens the frame beyond the margin (400 m) around the track and the
    route: x from -400 to 1400 m (1,800 m over 760 px), y from -400 to 500 m."""
    found = sea.Scene([], [(0.0, 0.0), (1000.0, 0.0)], [], None)
    f = sea.frame(trace(), found)
    assert (f.x0, f.y1, round(f.scale, 6), f.width, f.height) == (-400.0, 500.0, 0.422222, 760, 380)


@pytest.mark.parametrize(
    ("angles", "pixels"),
    [
        ([0.0], 130),  # dead ahead: DIAL - 20, nothing to keep inside the sides
        ([-90.0, 90.0], 65.0),  # abeam: its end 10 px inside a side, 65 px from the bow
        ([-39.0, 0.0, 39.0], 103.3),  # the submarine's
        ([-10.0, 10.0], 130),  # narrow: the full DIAL - 20
    ],
)
def test_a_full_range_beam_is_drawn_as_long_as_the_widest_stays_inside(
    angles: list[float], pixels: float
) -> None:
    assert sea.Sonar(["f"] * len(angles), angles, 800.0).pixels == pixels
