"""Reasons survive (issue 26, item 3): an ERROR's cause travels up the hierarchy intact.

A supervisor whose rule requires a subordinate's ERROR records that subordinate's link
(module, reason, and the subordinate's own cause) in its status buffer's `cause` field; a
later ERROR of the same command carries it, even after the supervisor has sent the
subordinate another command (docs/semantics.md, "Reasons survive").
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from rcsgen.compiler.back_end.lower import cause_of
from rcsgen.compiler.frontend import compile_paths
from rcsgen.runtime import contract
from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import trace_line
from rcsgen.tools.traces import read as traces

# The example: fixturing's clamp times out; the cell unclamps (another command to
# fx, which ends DONE) and fails for its own reason, FIXTURING; the workstation passes that
# up. Before, the time-out was gone once the cell had sent UNCLAMP.
FX = """\
controller: fx
title: Fixturing
world:
  reads: [jam]
commands:
  CLAMP:
    reasons: [CLAMP_TIMEOUT]
    states:
      S0:
        - when: world.jam
          do: [{report: ERROR, reason: CLAMP_TIMEOUT}]
        - when: not world.jam
          do: [report: DONE]
  UNCLAMP:
    states:
      S0:
        - do: [report: DONE]
"""
CELL = """\
controller: cell
title: Workcell
subordinates: [fx]
commands:
  FIX:
    reasons: [FIXTURING]
    states:
      S0:
        - do: [send: fx.CLAMP]
          next: S1
      S1:
        - when: fx.status == ERROR
          do: [send: fx.UNCLAMP]
          next: UNDO
        - when: fx.status == DONE
          do: [report: DONE]
      UNDO:
        - when: fx.status == DONE
          do: [{report: ERROR, reason: FIXTURING}]
"""
WS = """\
controller: ws
title: Workstation
subordinates: [cell]
commands:
  RUN:
    reasons: [FIXTURING]
    states:
      S0:
        - do: [send: cell.FIX]
          next: S1
      S1:
        - when: cell.status == ERROR
          do: [{report: ERROR, reason: cell.reason}]
        - when: cell.status == DONE
          do: [report: DONE]
"""
SYSTEM = """\
system: chain
title: A reason chain
cycle_period: 0.1
world:
  jam: {type: bool, initial: true, doc: The clamp jams.}
processes:
  p:
    modules: [ws, cell, fx]
"""


@pytest.fixture
def chain(tmp_path: Path) -> Iterator[Harness]:
    for name, text in (("fx", FX), ("cell", CELL), ("ws", WS), ("system", SYSTEM)):
        (tmp_path / f"{name}.yaml").write_text(text, encoding="utf-8")
    with Harness.build(tmp_path) as h:
        yield h


def run_until_finished(h: Harness, module: str, limit: int = 40) -> None:
    for _ in range(limit):
        h.cycle()
        if h.status(module).status in contract.FINISHED and h.sent(module).number == (
            h.status(module).number
        ):
            return
    raise AssertionError(f"{module} did not finish in {limit} cycles")


def test_the_cause_survives_another_command_and_travels_up(chain: Harness) -> None:
    h = chain
    h.command("ws", "RUN")
    run_until_finished(h, "ws")
    cell, ws, fx = h.status("cell"), h.status("ws"), h.status("fx")
    assert fx.status == "DONE", "the cell has unclamped: fx's own status no longer says why"
    assert (cell.status, cell.reason, cell.cause) == ("ERROR", "FIXTURING", "fx: CLAMP_TIMEOUT")
    assert (ws.status, ws.reason) == ("ERROR", "FIXTURING")
    assert ws.cause == "cell: FIXTURING <- fx: CLAMP_TIMEOUT"
    assert contract.status_text(ws.status, ws.reason, ws.cause) == (
        "ERROR(FIXTURING <- cell: FIXTURING <- fx: CLAMP_TIMEOUT)"
    )
    line = json.loads(trace_line(h, []))["modules"]
    assert line["ws"]["cause"] == "cell: FIXTURING <- fx: CLAMP_TIMEOUT"
    assert "cause" not in line["fx"], "fx is DONE: a cause shows only with an ERROR"


def test_a_new_command_and_done_carry_no_cause(chain: Harness) -> None:
    h = chain
    h.command("ws", "RUN")
    run_until_finished(h, "ws")
    assert h.status("ws").cause
    h.world["jam"] = False
    h.command("ws", "RUN")
    h.cycle()
    assert h.layout.STATUS_OUT["ws"].read(h.buf)["cause"] == 0, "cleared with the new command"
    run_until_finished(h, "ws")
    assert h.status("ws").status == "DONE"
    for module in ("ws", "cell"):
        assert h.layout.STATUS_OUT[module].read(h.buf)["cause"] == 0, module
        assert h.status(module).cause == ""


def test_the_cause_is_in_the_status_buffer_under_its_sequence_word(chain: Harness) -> None:
    """One field of the status record, so a reader's seqlock check covers it with the
    status and reason it came with; fx, which declares no reason its ERROR could pass
    up from below, has one too, but a module without reasons has none."""
    layout = chain.layout
    for module in ("ws", "cell", "fx"):
        assert layout.STATUS_OUT[module].fields[-1] == "cause", module
    assert layout.CAUSE_MODULES == ("ws", "cell", "fx")


def test_a_trace_with_causes_reads_back_and_shows_them(chain: Harness) -> None:
    h = chain
    h.command("ws", "RUN")
    lines = []
    for _ in range(20):
        h.cycle()
        lines.append(trace_line(h, ["jam"]))
    trace = traces.parse("\n".join(lines), "t.jsonl")
    column = trace.columns["ws"]
    last = len(trace.cycles) - 1
    assert traces.status_text(column, last) == (
        "ERROR(FIXTURING <- cell: FIXTURING <- fx: CLAMP_TIMEOUT)"
    )
    assert traces.status_text(column, 0) == "EXECUTING"


def test_a_cause_on_a_module_without_reasons_is_refused() -> None:
    line = {
        "cycle": 1,
        "modules": {
            m: {
                "command": "NONE",
                "command_num": 0,
                "status": "DONE",
                "status_num": 0,
                "state": "NOP",
                "rule": None,
            }
            for m in ("a",)
        },
        "world": {},
    }
    second = json.loads(json.dumps(line))
    second["cycle"] = 2
    second["modules"]["a"]["cause"] = "b: X"
    with pytest.raises(traces.TraceError, match="has a `cause` but declares no reasons"):
        traces.parse(json.dumps(line) + "\n" + json.dumps(second), "bad.jsonl")


# ---------------------------------------------------------------- the chain's encoding


def test_a_chain_is_read_back_nearest_first_and_named() -> None:
    class Layout:
        CAUSE_MODULES = ("ws", "ms", "tl", "op", "cmm")
        REASON_NAMES = {
            "ws": ("NONE", "LOST", "REFUSED"),
            "ms": ("NONE", "LOST", "REFUSED"),
            "tl": ("NONE", "LOST", "REFUSED"),
            "op": ("NONE", "LOST", "REFUSED"),
        }

    op = contract.caused(4, 2, 0)
    tl = contract.caused(3, 2, op)
    assert contract.cause_text(Layout, tl) == "tl: REFUSED <- op: REFUSED"
    assert contract.cause_text(Layout, contract.caused(5, 0, 0)) == "cmm"
    assert contract.cause_text(Layout, 0) == ""
    assert contract.cause_text(Layout, contract.caused(9, 7, 0)) == "?9"


def test_a_full_chain_keeps_its_root() -> None:
    chain = 0
    for module in range(1, 8):  # seven levels: the first link is the root cause
        chain = contract.caused(module, module, chain)
        links = contract.cause_links(chain)
        assert len(links) == min(module, contract.CAUSE_LINKS)
        assert links[-1] == 1 << 8 | 1, "the root survives"
        assert links[0] == module << 8 | module, "the nearest is first"


@pytest.mark.parametrize(
    ("guard", "sub"),
    [
        ("fx.status == ERROR", "fx"),
        ("ERROR == fx.status", "fx"),
        ("world.jam and fx.status == ERROR", "fx"),
        ("fx.status != DONE", ""),
        ("fx.status != ERROR", ""),
        ("fx.status == ERROR or world.jam", ""),
        ("not (fx.status == ERROR)", ""),
        ("fx.status == DONE", ""),
    ],
)
def test_only_a_guard_that_requires_the_error_records_it(
    guard: str, sub: str, tmp_path: Path
) -> None:
    cell = CELL.replace("when: fx.status == ERROR\n", f"when: {guard}\n", 1)
    cell = cell.replace("subordinates: [fx]", "subordinates: [fx]\nworld:\n  reads: [jam]")
    cell = cell.replace("reasons: [FIXTURING]\n", "reasons: [FIXTURING]\n    first_match: [S1]\n")
    cell = cell.replace(  # every guard leaves fx's ERROR handled
        "          do: [report: DONE]\n",
        "          do: [report: DONE]\n        - when: fx.status == ERROR\n"
        "          do: [{report: ERROR, reason: FIXTURING}]\n",
        1,
    )
    for name, text in (("fx", FX), ("cell", cell), ("ws", WS), ("system", SYSTEM)):
        (tmp_path / f"{name}.yaml").write_text(text, encoding="utf-8")
    checked = compile_paths([tmp_path])
    assert checked.systems, checked.diagnostics
    rule = next(
        r
        for c in checked.systems[0].controllers
        if c.name == "cell"
        for r in c.rules()
        if str(r.id) == "FIX/S1/1"
    )
    assert rule.cause_of == sub
    assert rule.guard is not None and cause_of(rule.guard.tree) == sub
