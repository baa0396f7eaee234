"""`rcsgen trace sea`: the second paper's animation (4.9) and Figure 19, replayed from a
submarine trace, its keel map and its route.

The plan view is drawn into the page as SVG, so what a person sees is checked in the file:
every keel of the run's map where it is, the route's waypoints and alternates, the track
the submarine sailed, clear of every keel as drawn, and the moving haven around the ship.
The page is also loaded in headless Chromium, at a cycle and playing.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
from conftest import rcsgen
from support.browser import load, needs_chromium

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import read_trace
from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces import sea as sea_view

REPO = Path(__file__).resolve().parent.parent
SUBMARINE = REPO / "specs" / "submarine"
GOLDEN = REPO / "tests" / "golden" / "submarine"


@pytest.fixture(scope="module")
def system():
    return compile_paths([SUBMARINE]).systems[0]


def circles(page: str, kind: str) -> list[tuple[float, float, float]]:
    found = re.findall(
        rf'<circle class="{kind}" cx="([-\d.]+)" cy="([-\d.]+)" r="([\d.]+)"/>', page
    )
    return [(float(x), float(y), float(r)) for x, y, r in found]


def polyline(page: str, name: str) -> list[tuple[float, float]]:
    points = re.search(rf'<polyline id="{name}" points="([^"]*)"/>', page)
    assert points, f"no polyline {name}"
    return [tuple(map(float, p.split(","))) for p in points.group(1).split()]  # type: ignore[misc]


def data(page: str) -> dict:
    return json.loads(
        re.search(r'id="sea-data" type="application/json">(.*?)</script>', page).group(1)
    )


def keel_file(name: str) -> list[tuple[float, float, float]]:
    rows = []
    for line in (SUBMARINE / "maps" / name).read_text().splitlines():
        words = line.split("#", 1)[0].split()
        if words:
            rows.append(tuple(map(float, words)))
    return rows  # type: ignore[return-value]


def test_the_transit_is_drawn_among_the_keels_it_kept_clear_of(system):
    trace = traces.load(GOLDEN / "ice_transit.jsonl")
    settings = {"route": "maps/bering.route", "keels": "maps/bering.keels"}
    page = sea_view.render(trace, system, SUBMARINE, settings, "ice_transit")
    keels, d = circles(page, "keel"), data(page)
    scale, x0, y1 = d["frame"]["scale"], d["frame"]["x0"], d["frame"]["y1"]
    # every keel of the run's map, where the map puts it, at its size
    expected = [
        ((x - x0) * scale, (y1 - y) * scale, r * scale) for x, y, r in keel_file("bering.keels")
    ]
    assert len(keels) == len(expected) > 5
    for (cx, cy, r), (ex, ey, er) in zip(keels, expected, strict=True):
        assert abs(cx - ex) <= 0.1 and abs(cy - ey) <= 0.1 and abs(r - er) <= 0.1
    # the route: its waypoints, and the dashed line through them
    route = [
        line.split("#")[0].split()
        for line in (SUBMARINE / "maps" / "bering.route").read_text().splitlines()
    ]
    waypoints = [w for w in route if w]
    assert len(circles(page, "waypoint")) == len(waypoints) == len(polyline(page, "route"))
    # the track: one point a cycle, north up (the ship sails north: y on the page falls)
    track = polyline(page, "track")
    assert len(track) == len(trace)
    assert track[-1][1] < track[0][1]
    # as drawn, it crosses no keel, and passes the nearest one by about the measured clearance
    nearest = (
        min(math.dist((px, py), (cx, cy)) - r for px, py in track for cx, cy, r in keels) / scale
    )
    assert nearest > 100.0
    assert abs(nearest - min(trace.world["min_clearance"])) < 2.0  # pixel rounding
    # the moving haven: a box of the spec's size, moved by the page per cycle
    assert d["haven"] == 300.0
    assert re.search(rf'<rect id="haven" width="{round(600 * scale, 1)}"', page)
    assert len(d["world"]["haven_x"]) == len(trace)


def test_generated_fractal_keels_are_drawn_by_their_outlines_clear_of_the_track(system):
    """`fractal_ice`: the keels the run's `ice_seed` generates are drawn as the outlines the
    sonar saw (polygons, not circles), and the track passes them by the measured
    clearance."""
    trace = traces.load(GOLDEN / "fractal_ice.jsonl")
    settings = {"route": "maps/strait.route", "keels": "maps/open_sea.keels", "ice_seed": "4"}
    found = sea_view.scene(system, SUBMARINE, settings)
    page = sea_view.render(trace, system, SUBMARINE, settings, "fractal_ice")
    assert circles(page, "keel") == [] and len(found.outlines) >= 4
    drawn = re.findall(r'<polygon class="keel" points="([^"]*)"/>', page)
    assert len(drawn) == len(found.outlines)
    d = data(page)
    scale, x0, y1 = d["frame"]["scale"], d["frame"]["x0"], d["frame"]["y1"]
    for points, outline in zip(drawn, found.outlines, strict=True):
        pixels = [tuple(map(float, p.split(","))) for p in points.split()]
        assert len(pixels) == len(outline) == 48
        for (px, py), (x, y) in zip(pixels, outline, strict=True):
            assert abs(px - (x - x0) * scale) <= 0.1 and abs(py - (y1 - y) * scale) <= 0.1
    # the nearest the drawn track comes to a drawn outline's point: no nearer than the
    # clearance the simulator measured to the outline's edges (less pixel rounding)
    track = polyline(page, "track")
    outline_points = [tuple(map(float, p.split(","))) for ps in drawn for p in ps.split()]
    nearest = min(math.dist(t, o) for t in track[::5] for o in outline_points) / scale
    assert nearest >= min(trace.world["min_clearance"]) - 2.0


def test_cli_writes_the_view_beside_the_trace_and_the_same_bytes_twice(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    copy = tmp_path / "fire_under_ice.jsonl"
    copy.write_bytes((GOLDEN / "fire_under_ice.jsonl").read_bytes())
    result = rcsgen("trace", "sea", copy)
    assert result.exit_code == 0, result.output
    page = (tmp_path / "fire_under_ice.sea.html").read_text(encoding="utf-8")
    d = data(page)
    assert d["scenario"] == "fire_under_ice"
    assert [c["module"] for c in d["controllers"]] == ["cc", "sm", "helm", "prop"]
    assert "ENGINE ROOM FIRE, ALL HANDS ON EABS" in d["strings"]
    assert rcsgen("trace", "sea", copy, "-o", tmp_path / "again.html").exit_code == 0
    assert (tmp_path / "again.html").read_text(encoding="utf-8") == page


def test_cli_refuses_a_trace_without_the_position_in_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    records = [json.loads(line) for line in read_trace(GOLDEN / "rudder_jam.jsonl")]
    for record in records:
        del record["world"]["pos_x"]
    path = tmp_path / "rudder_jam.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    result = rcsgen("trace", "sea", path)
    assert result.exit_code == 1 and result.output.count("\n") == 1
    assert result.output.startswith(
        f"error: {path} lacks the world fields the sea view needs: pos_x"
    )


def test_a_system_without_keels_is_refused():
    chain = compile_paths([REPO / "tests" / "fixtures" / "semantics" / "chain"]).systems[0]
    with pytest.raises(sea_view.SeaError, match="has no ice keels to draw"):
        sea_view.scene(chain, REPO, {})


def beam_angles() -> list[float]:
    """Each sonar beam's angle off the centre line, as system.yaml's field docs say it."""
    text = (SUBMARINE / "system.yaml").read_text()
    found = re.findall(r"sonar_\d\d: .*?Sonar beam \d+, ([-+]\d+) degrees", text)
    return [float(a) for a in found]


FIRE_UNDER_ICE = {"route": "maps/bering.route", "keels": "maps/bering.keels"}


def test_figure_33_s_displays_beside_the_ice_map(system):
    """Section 4.9: beside the ice map, the bubble angle, the speed and heading, the current
    sonar detection and the depth: every beam drawn at its angle off the bow with the ranges
    the trace holds for it, and the depth display's scale deep enough for the bottom."""
    trace = traces.load(GOLDEN / "fire_under_ice.jsonl")
    page = sea_view.render(trace, system, SUBMARINE, FIRE_UNDER_ICE, "fire_under_ice")
    d = data(page)
    angles = beam_angles()
    assert len(angles) == 14
    drawn = re.findall(r'<line class="beam" id="beam-(\d+)" data-angle="([-\d.]+)"', page)
    assert [(int(n), float(a)) for n, a in drawn] == list(enumerate(angles))
    assert d["sonar"]["angles"] == angles and d["sonar"]["reach"] == 900.0
    # at full range the outermost beams (±39°) end 10 px inside the 150 px display's sides,
    # not past them (they were drawn 130 px long whatever their angle)
    assert d["sonar"]["pixels"] == 103.3
    ends = [float(x) for x in re.findall(r'<line class="beam" [^>]* x2="([-\d.]+)"', page)]
    assert len(ends) == 14 and min(ends) == pytest.approx(10, abs=0.1)
    assert max(ends) == pytest.approx(140, abs=0.1)
    for n, ranges in enumerate(d["sonar"]["ranges"]):
        assert ranges == trace.world[f"sonar_{n:02d}"]
    assert any(r < 900.0 for ranges in d["sonar"]["ranges"] for r in ranges)  # ice seen
    for name in ("bubble", "depth", "depth_cmd", "bottom_depth", "speed", "heading", "course"):
        assert d["world"][name] == trace.world[name]
    assert d["deepest"] == max(trace.world["bottom_depth"])
    for display in ("bubble", "compass", "sonar", "depth-gauge"):
        assert f'<svg id="{display}" class="display"' in page
    # a trace without the beams (the open-sea fire) has no sonar data for the display
    plain = traces.load(GOLDEN / "engine_room_fire.jsonl")
    open_sea = {"route": "maps/open_sea.route", "keels": "maps/open_sea.keels"}
    assert data(sea_view.render(plain, system, SUBMARINE, open_sea))["sonar"] is None


def attribute(dom: str, element: str, name: str) -> str:
    tag = re.search(rf'<[a-z]+ [^>]*id="{element}"[^>]*>', dom)
    assert tag, f"no element {element}"
    value = re.search(rf' {name}="([^"]*)"', tag.group(0))
    assert value, f"{element} has no {name}: {tag.group(0)}"
    return value.group(1)


@needs_chromium
def test_the_view_in_a_browser_shows_the_ship_at_a_cycle_and_plays(tmp_path, system):
    trace = traces.load(GOLDEN / "fire_under_ice.jsonl")
    path = tmp_path / "fire_under_ice.sea.html"
    page = sea_view.render(trace, system, SUBMARINE, FIRE_UNDER_ICE, "fire_under_ice")
    path.write_text(page, encoding="utf-8")
    still = load(f"{path.as_uri()}#cycle=930", tmp_path, "fire_under_ice_sea_930")
    body, dom = still.body(), still.dom
    assert still.console == [], still.console
    assert body.get("data-ready") == "1" and body["data-cycle"] == "930"
    assert "ENGINE ROOM FIRE, ALL HANDS ON EABS" in dom  # the announcement, in the fire
    assert re.search(
        r'<g id="ship" transform="translate\([-\d.]+ [-\d.]+\) rotate\([-\d.]+\)"', dom
    )
    assert re.search(
        r'<rect id="haven" width="[\d.]+" height="[\d.]+" x="[-\d.]+" y="[-\d.]+"', dom
    )
    # the panel: at cycle 930 the ship is slowing and coming up, the shift to the EPM asked
    assert "<td>sm</td><td>PREP_EMERGENCY_VENT</td><td>SLOWING</td>" in dom
    assert "<td>prop</td><td>SHIFT_TO_EPM</td><td>ASKED</td>" in dom
    # Figure 33's displays at that cycle, from the trace's fields
    i = trace.cycles.index(930)
    bubble, depth = trace.world["bubble"][i], trace.world["depth"][i]
    assert bubble > 5.0  # bow up, coming to periscope depth
    assert attribute(dom, "hull", "transform") == f"translate(75 75) rotate({-bubble:.1f})"
    assert f"{bubble:.1f}° bow up" in dom
    heading = trace.world["heading"][i]
    assert attribute(dom, "heading-needle", "transform") == f"rotate({heading:.1f} 75 75)"
    deepest = max(trace.world["bottom_depth"])
    y = 10 + 120 * depth / (deepest * 1.1)
    assert attribute(dom, "depth-ship", "transform") == f"translate(0 {y:.1f})"
    ice = 0
    full = (75 - 10) / math.sin(math.radians(39.0))  # the ±39° beams kept inside the display
    for n, angle in enumerate(beam_angles()):  # each beam out to its range, at its angle
        reach = full * trace.world[f"sonar_{n:02d}"][i] / 900.0
        x2 = 75 + reach * math.sin(math.radians(angle))
        y2 = 140 - reach * math.cos(math.radians(angle))
        assert float(attribute(dom, f"beam-{n}", "x2")) == pytest.approx(x2, abs=0.06)
        assert float(attribute(dom, f"beam-{n}", "y2")) == pytest.approx(y2, abs=0.06)
        ice += trace.world[f"sonar_{n:02d}"][i] < 900.0
    assert ice == 3 == len(re.findall(r'class="beam ice"', dom))
    assert still.screenshot is not None and still.screenshot.stat().st_size > 10_000
    played = load(
        f"{path.as_uri()}#play", tmp_path, "sea_playing", budget_ms=1500, screenshot=False
    )
    assert played.console == [], played.console
    assert int(played.body()["data-cycle"]) > 20
