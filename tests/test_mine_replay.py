"""The mine page's replay (rcsgen/tools/traces/mine.py) over a trace made by hand and a
mine whose cut is a rule of thumb, in the unit tier: the map's size from its cells, the cells
the drum cut cycle by cycle (a drum that has not moved is not cut again), where the replayed
depth of cut first disagrees with the trace's, and the page's data (the map as text, the
standing coal, the machine, the world's series, the top four levels' panel). test_mine_view
replays the miner's golden traces through the real mine hooks."""

from __future__ import annotations

import re
from types import SimpleNamespace
from typing import Any

import pytest

from rcsgen.tools.traces import mine, player
from rcsgen.tools.traces.read import Lane, Trace


class Mine:
    def __init__(self, settings: dict[str, str]) -> None:
        self.x0, self.y0 = 100.0, -2.0
        self.seam = {(0, 0): 1.0, (0, 1): 1.0, (1, 0): 1.0, (1, 2): 0.5}
        self.settings = settings


def cut_coal(m: Mine, x: float, y: float, angle: float, on: bool) -> tuple[Any, ...]:
    """Cuts the cell under the drum to a third when the drum turns; depth 0.1 m."""
    if not on:
        return None, None, 0.0, None
    m.seam[(int(y), int(x))] = 1 / 3
    return None, None, 0.1, None


HOOKS = SimpleNamespace(make=Mine, cut_coal=cut_coal, CELL=0.5, DRUM_RADIUS=0.6)


def trace(**world: list[Any]) -> Trace:
    base = {
        "true_x": [0.0, 0.0, 0.0, 1.0],
        "true_y": [0.0, 0.0, 0.0, 0.0],
        "true_heading": [0.0] * 4,
        "boom_angle_true": [0.0, 0.0, 0.0, 5.0],
        "drum_on_cmd": [False, True, True, True],  # cycle 12: the same drum, cut once
        "depth_cut": [0.0, 0.1, 0.1, 0.2],
    }
    column = {
        "command": ["INIT", "CUT", "CUT", "CUT"],
        "command_num": [1, 2, 2, 2],
        "status": ["DONE", "EXECUTING", "EXECUTING", "EXECUTING"],
        "status_num": [1, 2, 2, 2],
        "state": ["S0", "S1", "S1", "S1"],
        "rule": [None] * 4,
    }
    return Trace(
        "m.jsonl", [10, 11, 12, 13], ["co", "cd"], {"co": column, "cd": column}, base | world
    )


def test_the_replay_cuts_the_cells_under_the_drum_and_finds_the_first_disagreement() -> None:
    result = mine.replay(trace(), HOOKS, "make", {"map": "m"})  # type: ignore[arg-type]
    assert (result.x0, result.y0, result.cell, result.rows, result.columns) == (
        100.0,
        -2.0,
        0.5,
        2,
        3,
    )
    assert result.seam == {(0, 0): 1.0, (0, 1): 1.0, (1, 0): 1.0, (1, 2): 0.5}  # as it began
    assert result.cuts == [(1, 0, 0.3333), (3, 1, 0.3333)]  # (cycle index, r * columns + c)
    moved = trace(true_y=[0.0, 0.0, 0.0, 1.0], true_x=[0.0, 0.0, 0.0, 2.0])
    second_row = mine.replay(moved, HOOKS, "make", {})  # type: ignore[arg-type]
    assert second_row.cuts == [(1, 0, 0.3333), (3, 5, 0.3333)]  # row 1, column 2 of 3
    assert result.mismatch == (
        "cycle 13: the replayed depth of cut is 0.1 m, the trace's 0.2 m; was the trace "
        "recorded with another map (--scenario)?"
    )
    agreeing = trace(depth_cut=[0.0, 0.1, 0.1, 0.1])
    assert mine.replay(agreeing, HOOKS, "make", {}).mismatch is None  # type: ignore[arg-type]
    untraced = {k: v for k, v in trace().world.items() if k != "depth_cut"}
    plain = trace()
    plain.world = untraced
    assert mine.replay(plain, HOOKS, "make", {}).mismatch is None  # type: ignore[arg-type]
    bare = SimpleNamespace(make=Mine, cut_coal=cut_coal)  # no CELL: a quarter metre
    assert mine.replay(trace(), bare, "make", {}).cell == 0.25  # type: ignore[arg-type]

    def barren(settings: dict[str, str]) -> Mine:
        made = Mine(settings)
        made.seam = {}
        return made

    empty = SimpleNamespace(make=barren, cut_coal=cut_coal)  # no coal at all: one cell
    got = mine.replay(trace(), empty, "make", {})  # type: ignore[arg-type]
    assert (got.rows, got.columns) == (1, 1)


def test_a_trace_without_the_drums_fields_is_refused_naming_them() -> None:
    short = trace()
    short.world = {k: v for k, v in short.world.items() if k not in ("true_y", "drum_on_cmd")}
    with pytest.raises(mine.MineError) as error:
        mine.replay(short, HOOKS, "make", {})  # type: ignore[arg-type]
    assert str(error.value) == (
        "m.jsonl lacks the world fields the mine replay needs: true_y, drum_on_cmd; add them "
        "to the scenario's `trace: world:` list and run it again"
    )


def test_the_page_data_holds_the_map_the_machine_and_the_top_levels() -> None:
    t = trace(loose_coal=[0, 1, 2, float("nan")], jack_down=[True, False, True, True])
    result = mine.replay(t, HOOKS, "make", {})  # type: ignore[arg-type]
    system = SimpleNamespace(name="miner", title="The miner", cycle_period=0.1)
    lanes = [Lane("co", level=2), Lane("cd", level=5), Lane("sim", level=1, simulator=True)]
    data = mine.payload(t, lanes, result, HOOKS, system, "box_cut")  # type: ignore[arg-type]
    assert data["map"] == {
        "x0": 100.0,
        "y0": -2.0,
        "cell": 0.5,
        "rows": 2,
        "columns": 3,
        "cells": "##.#.#",
        "standing": {"5": 0.5},  # only what is not whole
        "cuts": [1, 0, 0.3333, 3, 1, 0.3333],
    }
    assert data["machine"] == {
        "drum_radius": 0.6,
        "drum_half_width": 1.6,
        "drum_height": 0.4,
        "roof_angle": 30.0,
        "floor_angle": -10.0,
        "seam": 2.0,
    }
    bare = SimpleNamespace(make=Mine, cut_coal=cut_coal)  # the hooks declare no sizes
    assert mine.payload(t, lanes, result, bare, system, "")["machine"] == {  # type: ignore[arg-type]
        "drum_radius": 0.5,
        "drum_half_width": 1.6,
        "drum_height": 0.4,
        "roof_angle": 30.0,
        "floor_angle": -10.0,
        "seam": 2.0,
    }
    assert data["world"]["jack_down"] == [1, 0, 1, 1]
    assert data["world"]["loose_coal"] == [0.0, 1.0, 2.0, None]
    assert data["world"]["drum_on_cmd"] == [0, 1, 1, 1]
    assert list(data["world"]) == [*mine.REQUIRED, "loose_coal", "depth_cut", "jack_down"]
    assert [c["module"] for c in data["controllers"]] == ["co"]  # level 5 and simulators not
    assert {k: data[k] for k in ("source", "system", "title", "scenario", "period", "n")} == {
        "source": "m.jsonl",
        "system": "miner",
        "title": "The miner",
        "scenario": "box_cut",
        "period": 0.1,
        "n": 4,
    }
    assert data["cycles"] == [10, 11, 12, 13] and data["speed"] == 4
    assert data["mismatch"] == result.mismatch


def test_the_replay_page_holds_its_data_where_no_text_can_close_its_script() -> None:
    page = player.page("mine", "run <1> · miner", {}, {"said": "</script><b>", "n": 2})
    assert "<title>run &lt;1&gt; · miner</title>" in page
    assert '{"n":2,"said":"<\\/script><b>"}' in page
    assert "{{" not in page


@pytest.mark.parametrize("view", ["mine", "sea", "station"])
def test_a_views_own_comment_stays_out_of_its_page(view: str) -> None:
    """Each view's asset opens with a comment for its maintainers; the page holds its style,
    body and script, never a piece of that comment (only the shell's own comment)."""
    page = player.page(view, "t", {}, {})
    shell = player._asset(player.SHELL)
    assert page.count("-->") == shell.count("-->")
    assert "part of the replay page" not in page


@pytest.mark.parametrize("view", ["mine", "sea", "station"])
def test_a_views_style_and_script_reach_the_page_whole_in_the_shells_slots(view: str) -> None:
    """A view's `<style>` and `<script>` blocks go into the shell's slots as they are: not a
    character of their tags, not one of their text lost."""
    asset = player._asset(f"{view}_view.html")
    style = asset[asset.index("<style>\n") + len("<style>\n") : asset.index("\n</style>")]
    script = asset[asset.index("<script>\n") + len("<script>\n") : asset.index("\n</script>")]
    page = player.page(view, "t", {}, {})
    shell = player._asset(player.SHELL)
    before_style = shell[: shell.index("{{STYLE}}")].rsplit("\n", 2)[-2]
    assert f"\n{before_style}\n{style}\n</style>\n</head>\n" in page
    assert f'\n"use strict";\n{script}\n</script>\n' in page
    assert page.count("<style>") == 1 and page.count("</style>") == 1


def test_the_page_carries_every_world_field_its_script_reads_and_no_other() -> None:
    """The mine view's script reads world fields by name (`get("tail_in_position", i, 0)`,
    `number("coal_mined", ...)`): each must be one the payload carries (REQUIRED or SHOWN),
    and a trace holding them all has each on its page."""
    script = player._asset("mine_view.html")
    read = set(re.findall(r'\b(?:get|number)\("([a-z_]+)"', script))
    assert read == {*mine.REQUIRED, *mine.SHOWN}
    every = {name: [0.5, 1.5, 1.5, 2.0] for name in mine.SHOWN}
    t = trace(**every, drum_on_cmd=[False] * 4)
    result = mine.replay(t, HOOKS, "make", {})  # type: ignore[arg-type]
    system = SimpleNamespace(name="miner", title="The miner", cycle_period=0.1)
    data = mine.payload(t, [], result, HOOKS, system, "")  # type: ignore[arg-type]
    assert list(data["world"]) == [*mine.REQUIRED, *mine.SHOWN]
    assert data["world"]["tail_in_position"] == [0.5, 1.5, 1.5, 2.0]


def test_a_replay_page_refuses_data_that_is_not_finite_rather_than_write_nan() -> None:
    """The page parses its data with JSON.parse, which has no NaN or Infinity: the payloads
    make every number finite or null (view.number), and a NaN that got past is refused."""
    with pytest.raises(ValueError, match="Out of range float values are not JSON compliant"):
        player.page("mine", "t", {}, {"n": float("nan")})


def test_the_machine_takes_each_size_the_hooks_declare() -> None:
    t = trace()
    sized = SimpleNamespace(make=Mine, cut_coal=cut_coal, CELL=0.5, DRUM_RADIUS=0.7)
    sized.DRUM_HALF_WIDTH, sized.DRUM_HEIGHT, sized.ROOF_ANGLE, sized.FLOOR_ANGLE = 1.5, 0.5, 25, -5
    result = mine.replay(t, sized, "make", {})  # type: ignore[arg-type]
    system = SimpleNamespace(name="miner", title="The miner", cycle_period=0.1)
    data = mine.payload(t, [], result, sized, system, "")  # type: ignore[arg-type]
    assert data["machine"] == {
        "drum_radius": 0.7,
        "drum_half_width": 1.5,
        "drum_height": 0.5,
        "roof_angle": 25.0,
        "floor_angle": -5.0,
        "seam": 2.0,
    }


def test_a_block_is_cut_out_of_its_asset_with_both_of_its_tags_and_nothing_else() -> None:
    inside, rest = player._block("<p>a</p>\n<style>\nb { }\n</style>\n<p>c</p>", "style")
    assert (inside, rest) == ("b { }", "<p>a</p>\n\n<p>c</p>")
