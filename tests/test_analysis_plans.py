"""The analysis of guards on a plan (`legs.step`, `legs.steps`, `legs.done`,
`legs.replans_left`): a plan's step and the steps after it add up to at most its capacity,
and the solver keeps to the valuations that can happen (tables.within_capacity). The plans
fixture (tests/fixtures/language/plans, capacity 4, 2 replans) is clean; read without that
invariant, or with it upside down, its tables would look dead (W508) and its commands
unable to finish (E504)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths

PLANS = Path(__file__).resolve().parent / "fixtures" / "language" / "plans"


def findings(directory: Path) -> list[str]:
    front = compile_paths([directory])
    return [d.render() for d in [*front.diagnostics, *front.diagnostics.acknowledged]]


def test_a_plans_guards_are_decided_within_its_capacity(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    shutil.copytree(PLANS, tmp_path / "plans")
    monkeypatch.chdir(tmp_path)
    assert findings(Path("plans")) == []
    # a command asking whether the plan holds more steps than its capacity: both rules
    # can be reached (steps <= 4 always, the other rule is never needed but not a dead
    # state), the command finishes either way
    exe = Path("plans/exe.yaml")
    exe.write_text(
        exe.read_text(encoding="utf-8")
        + "  PEEK:\n"
        + "    states:\n"
        + "      S0:\n"
        + "        - when: legs.steps > 4\n"
        + "          do: [report: ERROR]\n"
        + "        - when: legs.steps <= 4\n"
        + "          do: [report: DONE]\n",
        encoding="utf-8",
    )
    assert findings(Path("plans")) == []
