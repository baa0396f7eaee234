"""`rcsgen trace mine`: the paper's animation, replayed from a miner trace and its coal map.

The replay runs the mine simulator's own cut over the traced pose, boom and drum, so it
must end where the run ended (the trace's depth of cut) and cut only the face of the
middle entry, never a pillar. The page is checked in headless Chromium, playing too.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import rcsgen
from support.browser import load, needs_chromium

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import read_trace
from rcsgen.tools.traces import mine as mine_view
from rcsgen.tools.traces import read as traces

REPO = Path(__file__).resolve().parent.parent
MINER = REPO / "specs" / "miner"
GOLDEN = REPO / "tests" / "golden"
SETTINGS = {"map": "maps/box_cut.map", "seed": "7"}


def read_by_the_script() -> set[str]:
    """The world fields the mine view's script reads by name (`get("tail_in_position", ...)`)."""
    from importlib import resources

    own = resources.files("rcsgen.tools.traces").joinpath("assets", "mine_view.html")
    return set(re.findall(r'\b(?:get|number)\("([a-z_]+)"', own.read_text("utf-8")))


def page_data(page: str) -> dict:
    return json.loads(
        re.search(r'id="mine-data" type="application/json">(.*?)</script>', page).group(1)
    )


@pytest.fixture(scope="module")
def system():
    return compile_paths([MINER]).systems[0]


@pytest.fixture(scope="module")
def hooks(system):
    controller = mine_view.mine_controller(system)
    assert (controller.name, controller.hooks_state) == ("mine", "new_mine")
    return mine_view.import_hooks(MINER, controller.hooks_module)


def test_replay_ends_where_the_run_ended_and_cuts_only_the_face(hooks):
    trace = traces.load(GOLDEN / "box_cut.jsonl")
    result = mine_view.replay(trace, hooks, "new_mine", SETTINGS)
    assert result.mismatch is None
    assert (result.x0, result.y0, result.cell, result.rows, result.columns) == (
        -16.0,
        -11.375,
        0.25,
        91,
        104,
    )
    cut = {cell for _, cell, _ in result.cuts}
    rows = {cell // result.columns for cell in cut}
    columns = {cell % result.columns for cell in cut}
    assert rows == set(range(39, 52))  # the middle entry, 3.25 m: no pillar is touched
    assert min(columns) == 72  # the face, 2 m inby
    final = {cell: h for _, cell, h in result.cuts}
    floor = sorted(c % result.columns for c, h in final.items() if h <= hooks.FACE_MIN)
    # cut to the floor (at most a cusp left) from the old face to the new one, 1.5 m deeper
    assert -16.0 + (max(floor) + 1) * 0.25 == 2.0 + trace.world["depth_cut"][-1]


def test_replay_notices_a_trace_of_another_map(hooks, tmp_path):
    lines = read_trace(GOLDEN / "sump_shear_cusp.jsonl")
    records = [json.loads(line) for line in lines]
    for record in records[80:]:
        record["world"]["depth_cut"] = 9.0
    path = tmp_path / "other.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    result = mine_view.replay(traces.load(path), hooks, "new_mine", SETTINGS)
    assert result.mismatch is not None and result.mismatch.startswith("cycle 81: ")


def test_a_trace_without_the_pose_is_refused(hooks):
    trace = traces.load(GOLDEN / "sump_shear_cusp.jsonl")
    del trace.world["true_heading"]
    with pytest.raises(mine_view.MineError, match="lacks the world fields .*: true_heading;"):
        mine_view.replay(trace, hooks, "new_mine", SETTINGS)


def test_a_system_without_a_coal_map_is_refused():
    chain = compile_paths([REPO / "tests" / "fixtures" / "semantics" / "chain"]).systems[0]
    with pytest.raises(mine_view.MineError, match="has no coal map to draw"):
        mine_view.mine_controller(chain)


def test_cli_writes_the_replay_beside_the_trace(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    copy = tmp_path / "pop_out.jsonl"
    copy.write_bytes((GOLDEN / "pop_out.jsonl").read_bytes())
    result = rcsgen("trace", "mine", copy)
    assert result.exit_code == 0, result.output
    page = (tmp_path / "pop_out.mine.html").read_text(encoding="utf-8")
    data = page_data(page)
    assert data["scenario"] == "pop_out" and data["mismatch"] is None
    assert set(data["world"]) == read_by_the_script()  # the golden traces every one
    assert [c["module"] for c in data["controllers"]] == ["sec", "sb", "co", "cc", "cr", "vg", "wm"]
    assert page == rcsgen_page(copy, tmp_path)  # same trace, same bytes


def rcsgen_page(trace: Path, tmp_path: Path) -> str:
    assert rcsgen("trace", "mine", trace, "-o", tmp_path / "again.html").exit_code == 0
    return (tmp_path / "again.html").read_text(encoding="utf-8")


def test_cli_refuses_a_trace_without_the_fields(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    records = [json.loads(line) for line in read_trace(GOLDEN / "box_cut.jsonl")]
    for record in records:
        del record["world"]["true_x"]
    path = tmp_path / "box_cut.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    result = rcsgen("trace", "mine", path)
    assert result.exit_code == 1 and result.output.count("\n") == 1
    assert result.output.startswith(f"error: {path} lacks the world fields the mine replay needs")


@needs_chromium
def test_replay_in_a_browser_shows_the_cut_and_plays(tmp_path, system):
    trace = traces.load(GOLDEN / "box_cut.jsonl")
    page, _ = mine_view.render(trace, traces.lanes(trace, system), system, MINER, SETTINGS)
    path = tmp_path / "box_cut.mine.html"
    path.write_text(page, encoding="utf-8")
    still = load(f"{path.as_uri()}#cycle=140", tmp_path, "box_cut_mine_cycle140")
    body = still.body()
    assert still.console == [], still.console
    assert body.get("data-ready") == "1" and "data-error" not in body
    assert body["data-cycle"] == "140" and int(body["data-cut-cells"]) > 20
    # the shared player's controls and clock (the system's 0.1 s cycle: 14.0 s)
    assert '<button id="prev"' in still.dom and '<select id="speed">' in still.dom
    assert re.search(r'<span id="clock">cycle 140 of \d+ · 14\.0 s</span>', still.dom)
    assert '<option value="4" selected="">4×</option>' in still.dom  # the mine's default speed
    assert '<g id="machine"' in still.dom and '<g id="machine-section"' in still.dom
    assert 'class="drum"' in still.dom and 'class="cells"' in still.dom
    assert still.screenshot is not None and still.screenshot.stat().st_size > 20_000
    played = load(f"{path.as_uri()}#play", tmp_path, "playing", budget_ms=1500, screenshot=False)
    assert played.console == [], played.console
    assert int(played.body()["data-cycle"]) > 20  # 1.5 s of virtual time at 4x: it moved
    assert played.body()["data-playing"] == "1"


def test_the_mine_view_is_on_the_replay_views_shared_shell(system):
    """One player for the mine, the sea and the station views (player.py's shell): the
    mine page carries the shell's player script verbatim, and the mine view's own asset
    has no player of its own (no slider, no timer, no address parsing)."""
    from importlib import resources

    assets = resources.files("rcsgen.tools.traces").joinpath("assets")
    shell = assets.joinpath("replay_shell.html").read_text("utf-8")
    player = shell[shell.index("// The player:") : shell.rindex("</script>")]
    trace = traces.load(GOLDEN / "box_cut.jsonl")
    page, _ = mine_view.render(trace, traces.lanes(trace, system), system, MINER, SETTINGS)
    assert player in page and page.count("// The player:") == 1
    assert set(page_data(page)["world"]) == read_by_the_script()  # the golden traces every one
    own = assets.joinpath("mine_view.html").read_text("utf-8")
    for part in ("slider", "setTimeout", "location.hash", "<header", "JSON.parse"):
        assert part not in own, part
    assert "function frame(i)" in own


def test_text_from_the_run_cannot_close_the_pages_script(system):
    """The page's data is JSON inside a <script> element: a scenario name (or any string of
    the run) holding `</script>` is escaped there, and reads back the same."""
    trace = traces.load(GOLDEN / "box_cut.jsonl")
    name = "cut</script><script>alert(1)</script>"
    page, _ = mine_view.render(trace, traces.lanes(trace, system), system, MINER, SETTINGS, name)
    template = page.split('id="mine-data" type="application/json">', 1)
    data = template[1].split("</script>", 1)[0]
    assert "</" not in data
    assert json.loads(data)["scenario"] == name
    assert set(json.loads(data)["world"]) == read_by_the_script()  # the golden traces each
