"""Counter-examples of `rcsgen prove` replayed in the generated code (rcsgen/tools/replay.py):
through an operator module, with a text parameter, with a parameter several rules read.

An operator module answers its client on a channel of its own (`op/top`), so the replay
scripts that channel's status, and the scenario it writes says `reply: {op/top: ERROR(R)}`,
which `rcsgen run` accepts. Before, the replay stopped on KeyError 'op' and left the finding
undecided (the submarine's cc over eoow)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from rcsgen.compiler.diagnostics import counted
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import prove_front
from rcsgen.tools.replay import replay_all
from rcsgen.tools.scenario.check import check_scenario

# top starts the device and asks the person; the person's refusal leaves the device running
# (W701, violated: top should halt dev first)
DESK = {
    "system.yaml": """
system: desk
title: Desk
cycle_period: 0.1
world:
  ready: {type: bool, initial: false, doc: The work is done.}
  power: {type: float, initial: 0.0, doc: The device's power.}
processes:
  p:
    modules: [top, dev, op]
""",
    "top.yaml": """
controller: top
title: Top
subordinates: [dev, op]
locals:
  done: {type: int, initial: 0, doc: Parts of a lot worked.}
commands:
  RUN:
    doc: Start the device and ask the person, for a program (a text the model keeps opaque).
    params:
      program: {type: str, doc: The program.}
    first_match: [S1]
    states:
      S0:
        - do: [send: dev.WORK, send: op.CHECK]
          next: S1
      S1:
        - when: op.status == ERROR
          do: [report: ERROR]
        - when: dev.status == ERROR
          do: [report: ERROR]
        - when: op.status == DONE and dev.status == DONE
          do: [report: DONE]
  LOT:
    doc: The device works `parts` times; from the second part on, the person checks each.
    params:
      parts: {type: int, doc: Parts in the lot.}
    first_match: [S2]
    states:
      S0:
        - when: parts > 0
          do: [set: {done: 0}, send: dev.WORK]
          next: S1
        - when: parts <= 0
          do: [report: DONE]
      S1:
        - when: dev.status == DONE and done + 1 < parts
          do: [set: {done: done + 1}, send: dev.WORK, send: op.CHECK]
          next: S2
        - when: dev.status == DONE and done + 1 >= parts
          do: [report: DONE]
        - when: dev.status == ERROR
          do: [report: ERROR]
      S2:
        - when: op.status == ERROR
          do: [report: ERROR]
        - when: dev.status == ERROR
          do: [send: op.HALT]
          next: S3
        - when: op.status == DONE and dev.status == DONE
          do: [report: DONE]
      S3:
        - when: op.status != EXECUTING
          do: [report: ERROR]
""",
    "dev.yaml": """
controller: dev
title: Device
world:
  reads: [ready]
  writes: [power]
commands:
  WORK:
    doc: Powered until the work is done.
    allow: [{code: W503, states: [S1], reason: it works until the work is done}]
    states:
      S0:
        - do: [set: {world.power: 1.0}]
          next: S1
      S1:
        - when: world.ready
          do: [report: DONE]
""",
    "op.yaml": """
operator: op
title: Person
commands:
  CHECK:
    doc: A check.
    text: Check, then answer.
    reasons: [REFUSED]
""",
}


def _write(directory: Path, files: dict[str, str]) -> Path:
    directory.mkdir()
    for name, text in files.items():
        (directory / name).write_text(text.lstrip(), encoding="utf-8")
    return directory


@pytest.fixture(scope="module")
def desk(tmp_path_factory):
    """The system proven and every finding replayed once, its scenarios written."""
    directory = _write(tmp_path_factory.mktemp("prove") / "desk", DESK)
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    proof = prove_front(front).proofs[0]
    replay_all(proof, system, directory, directory / "scenarios")
    return system, proof


def _w701(proof, command: str):
    [finding] = [f for f in proof.findings if f.code == "W701" and f.command == command]
    return finding


def test_an_operators_answer_is_replayed_on_its_channel(desk) -> None:
    system, proof = desk
    finding = _w701(proof, "RUN")
    assert "after op reported ERROR" in finding.message
    assert (finding.verdict, finding.replay) == (
        "violated",
        f"replayed in the generated code, {counted(len(finding.trace), 'cycle')}",
    )
    data = yaml.safe_load(Path(finding.scenario).read_text(encoding="utf-8"))
    replies = [e["reply"] for e in data["events"] if "reply" in e]
    assert replies and all(set(r) == {"op/top"} for r in replies)
    assert replies[-1]["op/top"].startswith("ERROR")
    _, diags = check_scenario(Path(finding.scenario), system)
    assert [d.render() for d in diags.errors] == []


def test_a_text_parameter_is_replayed_as_an_opaque_value(desk) -> None:
    """No rule reads `program`: the model leaves it free, the replay gives it the empty text
    (before, 0, which the command refused: the replay stopped and the finding was undecided,
    as the inspection shop's INSPECT_LOT(program) was)."""
    system, proof = desk
    finding = _w701(proof, "RUN")
    assert finding.verdict == "violated", finding.replay
    data = yaml.safe_load(Path(finding.scenario).read_text(encoding="utf-8"))
    assert data["events"][0]["with"] == {"program": ""}
    _, diags = check_scenario(Path(finding.scenario), system)
    assert [d.render() for d in diags.errors] == []


def test_a_parameter_takes_one_solutions_value_for_the_whole_run(desk) -> None:
    """LOT's S0 holds with parts 1, the explicit engine's pick; S1's first rule needs
    parts >= 2 a cycle later. z3's solution for the whole run (parts fixed from the command
    on) is what the counter-example and its replay use, so the replay follows the run to
    its end (before, it departed in cycle 2 and the finding was undecided)."""
    _, proof = desk
    finding = _w701(proof, "LOT")
    params = {k[1]: v for k, v in finding.trace[0][0].valuation if k[0] == "param"}
    assert params["parts"] >= 2
    assert finding.verdict == "violated", finding.replay


def test_a_reply_to_a_channel_that_does_not_exist_is_located(tmp_path) -> None:
    directory = _write(tmp_path / "desk", DESK)
    system = compile_paths([directory]).systems[0]
    (directory / "scenarios").mkdir()
    path = directory / "scenarios" / "s.yaml"
    path.write_text(
        "scenario: s\ntitle: S\nprocess: p\nmax_cycles: 2\nevents:\n"
        "  - {cycle: 1, command: top.RUN, with: {program: p}, mode: {op: {dont_run: true}}}\n"
        "  - {cycle: 2, reply: {op/dev: ERROR(REFUSED)}}\n"
        "  - {cycle: 2, reply: {op/top: ERROR(LATE)}}\n",
        encoding="utf-8",
    )
    _, diags = check_scenario(path, system)
    found = sorted((d.code, d.span.line, d.message) for d in diags.errors)
    assert found == [
        ("E289", 7, "reply to `op/dev`: not a channel of an operator module of `desk`"),
        ("E408", 8, "`LATE` is not a reason `op` can give"),
    ]
