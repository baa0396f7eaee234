"""`rcsgen trace station`: the inspection workstation replayed from a trace: the station (the
fixture plate, the part, the probe in the CMM's head, what the operator is asked) cycle by
cycle, and the time line of who worked when (planner, fixturing, tooling, operator, CMM).

The time line is drawn into the page as SVG, so what a person sees is checked in the file:
one blue bar per feature the CMM inspected, the planner's bar inside the workcell's first
inspection. The page is also loaded in headless Chromium, at a cycle and playing, and its
screenshot kept (and looked at).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from conftest import rcsgen
from support.browser import load, needs_chromium

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces import station as station_view

REPO = Path(__file__).resolve().parent.parent
GOLDEN = REPO / "tests" / "golden" / "inspection"


@pytest.fixture(scope="module")
def system():
    return compile_paths([REPO / "specs" / "inspection"]).systems[0]


def bars(page: str, kind: str) -> list[tuple[str, int, int]]:
    """The time line's bars of a command: (lane, first cycle, last cycle)."""
    found = re.findall(
        rf'<rect class="bar {kind}" data-lane="(\w+)" data-first="(\d+)" data-last="(\d+)"', page
    )
    return [(lane, int(first), int(last)) for lane, first, last in found]


def spans(lines: list[dict], module: str, command: str) -> list[tuple[int, int]]:
    """The runs of cycles `module` is EXECUTING `command`, from the trace itself."""
    out: list[tuple[int, int]] = []
    for line in lines:
        row = line["modules"][module]
        if row["command"] == command and row["status"] == "EXECUTING":
            if out and out[-1][1] == line["cycle"] - 1 and out[-1][2] == row["command_num"]:
                out[-1] = (out[-1][0], line["cycle"], row["command_num"])
            else:
                out.append((line["cycle"], line["cycle"], row["command_num"]))
    return [(first, last) for first, last, _ in out]


def test_the_time_line_has_a_bar_per_feature_and_the_planner_inside_the_first_part(system):
    trace = traces.load(GOLDEN / "guardian_lot.jsonl")
    page = station_view.render(trace, system)
    lines = [json.loads(ln) for ln in traces.full_lines(GOLDEN / "guardian_lot.jsonl")]
    features = bars(page, "INSPECT_FEATURE")
    assert [(f, last) for _, f, last in features] == spans(lines, "cmm", "INSPECT_FEATURE")
    assert len(features) == 10 and {lane for lane, _, _ in features} == {"CMM"}, "5 a part"
    touches = bars(page, "GO_TO_POINT")
    assert [(f, last) for _, f, last in touches] == spans(lines, "prim", "GO_TO_POINT")
    assert len(touches) == 20 and {lane for lane, _, _ in touches} == {"probe"}, "2 a feature"
    assert all(any(f <= t and u <= last for _, f, last in features) for _, t, u in touches)
    (planned_first, planned_second) = bars(page, "PLAN_JOB")
    inspections = spans(lines, "wc", "JOB")[1:]  # the workcell's jobs after initForInspect
    assert planned_first[0] == "planner" and planned_second[0] == "planner"
    first, last = inspections[0]
    assert first <= planned_second[1] and planned_second[2] <= last, "W1 inside W2's part 0"
    asked = bars(page, "PLACE_PART")
    assert {lane for lane, _, _ in asked} == {"fixturing", "operator"}


def test_the_station_follows_the_fixturing_and_tooling_commands(system):
    trace = traces.load(GOLDEN / "rejected_part.jsonl")
    found = station_view.station(trace)
    fx = trace.columns["fx"]
    placed = next(
        i
        for i in range(len(trace))
        if fx["command"][i] == "PLACE_PART" and fx["status"][i] == "DONE"
    )
    assert found["part"][placed - 1] == "none" and found["part"][placed] == "on the fixture"
    reseated = [i for i, p in enumerate(found["part"]) if p == "re-seated"]
    assert reseated and all(fx["command"][i] == "REFIXTURE_PART" for i in reseated)
    assert found["part"][-1] == "unloaded", "the rejected part is unloaded"
    assert found["plate"][-1] == "mounted" and found["probe"][-1] == "loaded"


def test_cli_writes_the_view_beside_the_trace_and_refuses_another_system(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    copy = tmp_path / "guardian_lot.jsonl"
    copy.write_bytes((GOLDEN / "guardian_lot.jsonl").read_bytes())
    result = rcsgen("trace", "station", copy)
    assert result.exit_code == 0, result.output
    page = (tmp_path / "guardian_lot.station.html").read_text(encoding="utf-8")
    assert 'id="station-data"' in page and 'id="timeline"' in page
    assert rcsgen("trace", "station", copy, "-o", tmp_path / "again.html").exit_code == 0
    assert (tmp_path / "again.html").read_text(encoding="utf-8") == page
    sub = REPO / "tests" / "golden" / "submarine" / "rudder_jam.jsonl"
    refused = rcsgen("trace", "station", sub, "-o", tmp_path / "no.html")
    assert refused.exit_code == 1 and refused.output.count("\n") == 1, refused.output
    assert "is not a trace of an inspection workstation" in refused.output
    assert not (tmp_path / "no.html").exists()


@needs_chromium
def test_the_view_in_a_browser_shows_the_part_measured_at_a_cycle_and_plays(tmp_path, system):
    trace = traces.load(GOLDEN / "rejected_part.jsonl")
    path = tmp_path / "rejected_part.station.html"
    path.write_text(station_view.render(trace, system), encoding="utf-8")
    prim = trace.columns["prim"]
    measuring = next(
        trace.cycles[i]
        for i in range(len(trace))
        if prim["command"][i] == "GO_TO_POINT" and prim["status"][i] == "EXECUTING"
    )
    still = load(f"{path.as_uri()}#cycle={measuring}", tmp_path, "rejected_part_station")
    body = still.body()
    assert still.console == [], still.console
    assert body.get("data-ready") == "1" and body["data-cycle"] == str(measuring)
    assert body["data-part"] == "on the fixture" and body["data-measuring"] == "1"
    assert re.search(r'<rect id="part" class="part measuring"[^>]*visibility="visible"', still.dom)
    assert re.search(r'<line id="probe"[^>]*visibility="visible"', still.dom)
    assert "<td>cmm</td><td>INSPECT_FEATURE</td><td>TOUCHING</td>" in still.dom
    assert "<td>prim</td><td>GO_TO_POINT</td><td>APPROACHING</td>" in still.dom
    assert still.screenshot is not None and still.screenshot.stat().st_size > 10_000
    start = load(f"{path.as_uri()}#cycle=1", tmp_path, "station_start", screenshot=False)
    assert start.body()["data-part"] == "none"
    assert re.search(r'<rect id="plate"[^>]*visibility="hidden"', start.dom)
    played = load(
        f"{path.as_uri()}#play", tmp_path, "station_playing", budget_ms=1500, screenshot=False
    )
    assert played.console == [], played.console
    assert int(played.body()["data-cycle"]) > 5


def test_everything_the_time_line_draws_lies_inside_its_picture(system):
    """No lane, bar, label or axis figure is cut off at the picture's edge."""
    page = station_view.render(traces.load(GOLDEN / "guardian_lot.jsonl"), system)
    svg = page[page.index('<svg id="timeline"') :]
    svg = svg[: svg.index("</svg>")]
    width, height = map(
        int, re.match(r'<svg id="timeline" width="(\d+)" height="(\d+)"', svg).groups()
    )
    assert f'viewBox="0 0 {width} {height}"' in svg
    drawn = 0
    for tag in re.findall(r"<(?:rect|line|text)\b[^>]*>", svg):
        at = {
            k: float(v) for k, v in re.findall(r'\b(x|y|x1|y1|x2|y2|width|height)="([-\d.]+)"', tag)
        }
        bottom = max(at.get("y", 0) + at.get("height", 0), at.get("y1", 0), at.get("y2", 0))
        right = max(at.get("x", 0) + at.get("width", 0), at.get("x1", 0), at.get("x2", 0))
        assert 0 < bottom <= height and 0 <= right <= width, tag
        drawn += 1
    assert drawn > 30  # the five lanes, their labels, the bars and the axis


def test_the_requests_line_names_every_open_request_with_its_client(system):
    """What the operator is asked, cycle by cycle: each open request as `TASK (for client)`,
    two at once side by side (fixturing and tooling both ask in the first part)."""
    trace = traces.load(GOLDEN / "guardian_lot.jsonl")
    data = station_view.payload(trace, system)
    runs = data["requests"]  # (first cycle index, text) pairs, the text in the string table
    said = [
        (first, data["strings"][text]) for first, text in zip(runs[::2], runs[1::2], strict=True)
    ]
    assert (5, "MOUNT_FIXTURE_PLATE (for fx)") in said
    assert (50, "PLACE_PART (for fx), LOAD_PROBE (for tl)") in said
    assert data["strings"][runs[1]] == ""  # nothing asked before
