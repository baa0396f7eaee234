"""The codes no corpus case can reach, each reported where it is made.

The corpus (`tests/cases/invalid/`) holds a failing system per code of the specs; these
codes are about what is around the specs (the output directory, a scenario's place, a trace
file) or guard a state a schema-valid spec cannot reach. `test_corpus.py`'s registry test
requires each code to be tested somewhere: here.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from conftest import REPO

from rcsgen.compiler.back_end import write
from rcsgen.compiler.checks.check import check_system
from rcsgen.compiler.diagnostics import Diagnostics, known_names_hint
from rcsgen.compiler.front_end.loader import load_file
from rcsgen.compiler.front_end.model import build_controller, build_system
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import check_scenario
from rcsgen.tools.scenario.runs import golden_differences

TINY = REPO / "tests" / "cases" / "valid" / "tiny"


def test_e216_a_command_without_s0_is_refused_by_the_checker(tmp_path: Path) -> None:
    """The schema requires S0 in every table; a model built otherwise (the library's
    callers, a future front end) still meets the checker's E216, at the command."""
    system = build_system(load_file(TINY / "system.yaml", "system.yaml"), TINY, "system.yaml")
    top = build_controller(load_file(TINY / "top.yaml", "top.yaml"), "top.yaml")
    sub = build_controller(load_file(TINY / "sub.yaml", "sub.yaml"), "sub.yaml")
    move = sub.commands["MOVE"]
    move.states = {"S1": move.states["S0"]}
    diags = Diagnostics()
    assert check_system(system, [top, sub], diags) is None
    assert [(d.code, d.message) for d in diags] == [("E216", "command MOVE has no `S0` state")]
    assert diags.items[0].span == move.span


def test_e302_an_output_path_through_a_linked_folder_is_refused(tmp_path: Path) -> None:
    """A folder inside a system's package that is a link out of the output directory: its
    files would land elsewhere, so the build refuses (E302) and writes nothing."""
    front = compile_paths([TINY])
    out = tmp_path / "out"
    plan, problems = write.plan_build(front.systems, out)
    assert not problems.errors
    write.apply(plan)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    shutil.rmtree(out / "tiny" / "rcs")
    (out / "tiny" / "rcs").symlink_to(elsewhere, target_is_directory=True)
    _, problems = write.plan_build(front.systems, out)
    codes = {d.code for d in problems}
    assert codes == {"E302"}, [d.render() for d in problems]
    assert all("leaves the output directory" in d.message for d in problems)
    assert list(elsewhere.iterdir()) == []


def test_e403_a_scenario_outside_any_system_is_refused(tmp_path: Path) -> None:
    scenario = tmp_path / "lost.yaml"
    scenario.write_text("scenario: lost\ntitle: Nowhere\nmax_cycles: 3\n", encoding="utf-8")
    checked, diags = check_scenario(scenario)
    assert checked is None
    assert [(d.code, d.span.line) for d in diags] == [("E403", 1)]
    assert "no system.yaml above" in diags.items[0].message


def test_e419_a_golden_trace_that_is_not_a_trace(tmp_path: Path) -> None:
    golden = tmp_path / "golden.jsonl"
    golden.write_text("this is not JSON\n", encoding="utf-8")
    found = golden_differences(golden, ['{"cycle": 0}'], "go")
    assert [d.code for d in found] == ["E419"]
    assert found[0].message.startswith("cannot read golden trace: not a trace: Expecting value")
    assert found[0].span.line == 1  # (the line that does not read)
    missing = golden_differences(tmp_path / "absent.jsonl", ['{"cycle": 0}'], "go")
    assert [d.code for d in missing] == ["E419"]
    assert "absent.jsonl" in missing[0].span.file


def test_a_hint_names_the_near_name_else_the_declared_ones() -> None:
    assert known_names_hint("plans", ["legs", "route"], "leg") == "did you mean `legs`?"
    assert known_names_hint("plans", ["legs", "route"], "xyz") == "declared plans: `legs`, `route`"
    assert known_names_hint("plans", [], "xyz") == "no plans are declared"
    many = [f"n{i}" for i in range(10)]
    assert known_names_hint("locals", many) == (
        "declared locals: " + ", ".join(f"`n{i}`" for i in range(8)) + " and 2 more"
    )
