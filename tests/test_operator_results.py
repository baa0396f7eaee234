"""Operators that act (docs/spec.md section 17, "Results"; docs/semantics.md section 21): a
task's results travel with the DONE in the channel's status buffer and the client reads them
in the cycle the DONE arrives; an answer whose values do not fit the task is refused before
it reaches the client - by the console (`write_answer`, `ctl answer`), and again by the
operator module itself for an answer record written behind the console's back; the trace
records them; a scenario's scripted results are checked where they are written (E911)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from rcsgen.runtime.operate.ctl import channel_requests, main, write_answer
from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import load_scenario, run
from rcsgen.tools.scenario.check import check_scenario

DESK = Path(__file__).resolve().parent / "cases" / "valid" / "operator-results"
GOOD = {"gap": "1.5", "verdict": "REWORK", "count": "3", "ok": "true", "note": "fine"}


@pytest.fixture
def desk():
    with Harness.build(DESK) as harness:
        yield harness


def asked(desk: Harness) -> dict:
    """fx sends op.MEASURE; the operator module opens the request."""
    desk.command("fx", "CHECK")
    desk.step("fx")
    desk.step("op")
    return next(r for r in channel_requests(desk.layout, desk.buf) if r["name"] == "op/fx")


def test_the_client_reads_the_results_in_the_cycle_the_done_arrives(desk):
    request = asked(desk)
    assert request["results"] == {
        "gap": "0.0..5.0",
        "verdict": "KEEP|REWORK|SCRAP",
        "count": "1..9",
        "ok": "true|false",
        "note": "text",
    }
    write_answer(desk.layout, desk.buf, request, "DONE", results=GOOD)
    desk.step("op")
    channel = desk.status("op/fx")
    assert (channel.status, channel.results["gap"], channel.results["verdict"]) == (
        "DONE",
        1.5,
        "REWORK",
    )
    assert channel.results["note"] == "fine" and channel.results["count"] == 3
    desk.step("fx")  # the first cycle that sees the DONE reads the results with it
    fx = desk.status("fx")
    assert (fx.status, fx.results) == ("DONE", {"gap": 1.5, "reworked": True})


@pytest.mark.parametrize(
    ("results", "said"),
    [
        ({**GOOD, "gap": "5.5"}, "op.MEASURE: result gap is 5.5: above its maximum 5.0"),
        ({**GOOD, "count": "0"}, "op.MEASURE: result count is 0: below its minimum 1"),
        ({**GOOD, "count": "2.5"}, "result count is '2.5', not a whole number"),
        ({**GOOD, "verdict": "REWROK"}, "did you mean REWORK?"),
        ({**GOOD, "ok": "yes"}, "result ok is 'yes', not true or false"),
        ({**GOOD, "note": "much too long"}, "more than the 8 it holds"),
        ({k: v for k, v in GOOD.items() if k != "gap"}, "needs result gap with DONE"),
        ({**GOOD, "gapp": "1"}, "did you mean 'gap'"),
    ],
)
def test_an_answer_that_does_not_fit_is_refused_and_nothing_is_written(desk, results, said):
    request = asked(desk)
    before = bytes(desk.buf)
    with pytest.raises(ValueError, match=re.escape(said)):
        write_answer(desk.layout, desk.buf, request, "DONE", results=results)
    assert bytes(desk.buf) == before
    with pytest.raises(ValueError, match="results go with DONE only"):
        write_answer(desk.layout, desk.buf, request, "ERROR", "REFUSED", results=GOOD)
    desk.step("op")
    assert desk.status("op/fx").status == "EXECUTING"


def test_the_operator_module_refuses_an_answer_written_behind_the_consoles_back(desk, capfd):
    """An answer record out of range (no console wrote it: another tool, a bug) never
    reaches the client: the request stays open, one line on stderr, once; a good answer
    then closes it."""
    request = asked(desk)
    record = desk.layout.ANSWERS["op/fx"]
    verdict = desk.layout.ENUMS[("op/fx", "result_verdict")].index("SCRAP")
    bad = dict(result_gap=7.0, result_verdict=verdict, result_count=2, result_ok=True)
    record.write(desk.buf, command_num=request["number"], status=2, **bad)
    for _ in range(3):
        desk.step("op")
        desk.step("fx")
    assert desk.status("op/fx").status == "EXECUTING"
    assert desk.status("fx").status == "EXECUTING"
    lines = capfd.readouterr().err.splitlines()
    assert lines == [
        f"op/fx: the answer to #{request['number']} is refused: result gap is 7.0: above its "
        "maximum 5.0; the request stays open"
    ]
    record.write(desk.buf, result_verdict=len(desk.layout.ENUMS[("op/fx", "result_verdict")]))
    record.write(desk.buf, result_gap=1.0)
    desk.step("op")
    assert desk.status("op/fx").status == "EXECUTING", "an enum code past its values"
    record.write(desk.buf, result_verdict=verdict)
    desk.step("op")
    desk.step("fx")
    assert desk.status("fx").status == "DONE"
    assert desk.status("fx").results == {"gap": 1.0, "reworked": False}


def test_ctl_answer_takes_the_results_as_typed_and_refuses_a_bad_one(desk, capsys):
    """`ctl answer op/fx DONE gap=... verdict=...` on the running block: a value out of range
    is one line and exit 2, nothing written; the good answer closes the request."""
    from rcsgen.runtime.block import Block

    request = asked(desk)
    package = desk.package.__name__
    name = f"rcsgen_opres_{id(desk)}"
    block = Block(desk.layout, name)
    try:
        block.buf[: desk.layout.SIZE] = desk.buf[: desk.layout.SIZE]
        argv = ["--shm", name, "answer", "op/fx", "DONE"]
        bad = [f"{k}={v}" for k, v in {**GOOD, "gap": "-1"}.items()]
        assert main(package, [*argv, *bad]) == 2
        err = capsys.readouterr().err
        assert err == "ctl: error: op.MEASURE: result gap is -1.0: below its minimum 0.0\n"
        assert main(package, ["--shm", name, "answer", "op/fx", "gap=1", "gap=2"]) == 2
        assert "result gap is given twice" in capsys.readouterr().err
        assert main(package, ["--shm", name, "answer", "op/fx", "MAYBE"]) == 2
        assert "neither DONE nor ERROR nor NAME=VALUE" in capsys.readouterr().err
        good = [f"{k}={v}" for k, v in GOOD.items()]
        assert main(package, ["--shm", name, "answer", "op/fx", *good]) == 0  # DONE implied
        out = capsys.readouterr().out
        assert out.startswith(f"answered op/fx: MEASURE #{request['number']} DONE gap=1.5 ")
        desk.buf[: desk.layout.SIZE] = block.buf[: desk.layout.SIZE]
    finally:
        block.close()
    desk.step("op")
    desk.step("fx")
    assert desk.status("fx").results == {"gap": 1.5, "reworked": True}


def test_the_scenario_records_the_results_in_the_trace():
    scenario = load_scenario(DESK / "scenarios" / "go.yaml")
    with Harness.build(DESK, send_init=True) as harness:
        result = run(scenario, harness)
    lines = [json.loads(line) for line in result.trace]
    done = next(i for i, line in enumerate(lines) if line["modules"]["op/fx"]["status"] == "DONE")
    assert lines[done]["modules"]["op/fx"]["result"] == {
        "gap": 1.5,
        "verdict": "REWORK",
        "count": 3,
        "ok": True,
        "note": "fine",
    }
    assert lines[done + 1]["modules"]["fx"]["status"] == "DONE"
    assert lines[done + 1]["modules"]["fx"]["result"] == {"gap": 1.5, "reworked": True}


@pytest.mark.parametrize(
    ("answer", "said"),
    [
        (
            "{task: MEASURE, results: {gap: 6.0, verdict: KEEP, count: 1, ok: true, note: a}}",
            "result `gap` of MEASURE is 6.0: above its maximum 5.0",
        ),
        (
            "{task: MEASURE, results: {gap: 1.0, verdict: KEEP, count: 1, ok: true}}",
            "note not given",
        ),
        (
            "{task: MEASURE, answer: ERROR, reason: REFUSED, results: {gap: 1.0}}",
            "results given with ERROR",
        ),
        ("{task: MEASURE, results: {gapp: 1.0}}", "`gapp` is not a result of MEASURE"),
    ],
)
def test_a_scripted_answer_that_does_not_fit_is_refused_where_it_is_written(tmp_path, answer, said):
    system = tmp_path / "desk"
    system.mkdir()
    for name in ("system.yaml", "op.yaml", "fx.yaml"):
        (system / name).write_text((DESK / name).read_text())
    (system / "scenarios").mkdir()
    text = (DESK / "scenarios" / "go.yaml").read_text().splitlines()
    at = next(i for i, line in enumerate(text) if "task: MEASURE" in line)
    text[at] = f"    - {answer}"
    (system / "scenarios" / "go.yaml").write_text("\n".join(text) + "\n")
    _, diags = check_scenario(system / "scenarios" / "go.yaml")
    found = [(d.code, d.span.line, d.message) for d in diags.errors]
    assert len(found) == 1 and found[0][1] == at + 1, found
    assert found[0][0] == "E911" and said in found[0][2], found
