"""`rcsgen trace show`: one self-contained HTML page per trace, checked in a real browser.

The page is loaded in headless Chromium (the distribution's package): its lanes and rule
markers must be drawn, the cursor must show every module at one cycle, no console message
may appear, and a screenshot is kept in the test's directory.
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
from rcsgen.tools.traces import view as trace_view

REPO = Path(__file__).resolve().parent.parent
MINER = REPO / "specs" / "miner"
GOLDEN = REPO / "tests" / "golden"


@pytest.fixture(scope="module")
def late_tail():
    system = compile_paths([MINER]).systems[0]
    trace = traces.load(GOLDEN / "late_tail.jsonl")
    return trace, traces.lanes(trace, system), system


def data_of(page: str) -> dict:
    found = re.search(r'<script id="trace-data" type="application/json">(.*?)</script>', page, re.S)
    assert found is not None
    return json.loads(found.group(1))


def test_runs_are_run_length_encoded_with_numbers():
    table = trace_view.StringTable()
    flat = trace_view.runs(["INIT", "INIT", "HALT", "HALT", "HALT"], [1, 1, 2, 3, 3], table)
    assert flat == [0, 0, 1, 2, 1, 2, 3, 1, 3]  # start, string, number: HALT #2 then HALT #3
    assert table.values == ["INIT", "HALT"]
    assert trace_view.runs(["S1", "S1", "S2"], None, table) == [0, 2, 2, 3]


def test_page_is_self_contained_and_deterministic(late_tail):
    trace, lanes, system = late_tail
    page = trace_view.render(trace, lanes, system.name, system.cycle_period)
    assert page == trace_view.render(trace, lanes, system.name, system.cycle_period)
    assert not re.search(r"<(link|img|iframe)\b|\bsrc=|https?://(?!www\.w3\.org/2000/svg)", page)
    data = data_of(page)
    assert data["n"] == 494 and data["period"] == 0.1 and data["system"] == "miner"
    assert [lane["module"] for lane in data["lanes"]][:4] == ["sec", "sb", "co", "cc"]
    co = next(lane for lane in data["lanes"] if lane["module"] == "co")
    fired = {data["strings"][i] for i in co["rules"][1::2]}
    assert "SUMP_SHEAR_CUSP/S2/2" in fired
    assert {w["name"]: w["type"] for w in data["world"]}["tail_request"] == "bool"


def test_script_end_tags_in_the_data_cannot_close_the_script(late_tail):
    trace, lanes, _ = late_tail
    trace.world["note"] = ["</script><script>alert(1)</script>"] * len(trace)
    try:
        page = trace_view.render(trace, lanes)
    finally:
        del trace.world["note"]
    assert page.count("</script>") == 2  # the data element's and the code's own


def test_cli_writes_the_page_beside_the_trace(tmp_path, monkeypatch):
    monkeypatch.chdir(REPO)
    copy = tmp_path / "pop_out.jsonl"
    copy.write_bytes((GOLDEN / "pop_out.jsonl").read_bytes())
    result = rcsgen("trace", "show", copy)
    assert result.exit_code == 0, result.output
    page = (tmp_path / "pop_out.html").read_text(encoding="utf-8")
    assert "<title>" in page and data_of(page)["system"] == "miner"
    assert f"wrote {tmp_path / 'pop_out.html'}" in result.output


def test_cli_without_specs_still_draws_the_trace(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no specs/ here: lanes in alphabetical order, no titles
    result = rcsgen("trace", "show", GOLDEN / "pop_out.jsonl", "-o", "out.html")
    assert result.exit_code == 0, result.output
    data = data_of((tmp_path / "out.html").read_text(encoding="utf-8"))
    assert data["system"] is None and data["lanes"][0]["module"] == "bas"


@needs_chromium
def test_page_in_a_browser_draws_lanes_markers_and_the_cursor(tmp_path, late_tail):
    trace, lanes, system = late_tail
    page = tmp_path / "late_tail.html"
    page.write_text(trace_view.render(trace, lanes, system.name, 0.1), encoding="utf-8")
    shown = load(f"{page.as_uri()}#from=90&to=160&cycle=111", tmp_path, "late_tail")
    body = shown.body()
    assert shown.console == [], shown.console
    assert body.get("data-ready") == "1" and "data-error" not in body
    assert body["data-lanes"] == str(len(lanes)) and int(body["data-markers"]) > 20
    assert body["data-cursor"] == "111"
    for lane in lanes:
        assert f'<g class="lane" data-module="{lane.module}">' in shown.dom
    assert re.search(
        r'<path class="marker" data-rule="SUMP_SHEAR_CUSP/S2/2" data-cycle="111"', shown.dom
    )
    assert (
        'class="seg seg-command"' in shown.dom
        and 'class="plot" data-field="loose_coal"' in shown.dom
    )
    # the cursor's panel: cc was sent HALT #5 by co's loose-coal rule in cycle 111
    row = re.search(r'<tr data-module="cc">(.*?)</tr>', shown.dom)
    assert row is not None and "HALT #5" in row.group(1) and 'class="changed"' in row.group(1)
    assert shown.screenshot is not None and shown.screenshot.stat().st_size > 20_000
