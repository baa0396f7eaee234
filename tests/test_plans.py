"""Plans (issue 14, item 6): a planner's steps stepped through, replanned up to a count.

The fixture `tests/fixtures/language/plans` has one executor whose planner makes `wanted`
steps; each test drives it through the harness and reads its status buffer, or builds a
changed copy of it and reads the diagnostics.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.back_end import emit
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness

PLANS = Path(__file__).resolve().parent / "fixtures" / "language" / "plans"


@pytest.fixture
def exe():
    with Harness.build(PLANS) as h:
        yield h


def plan(h: Harness) -> dict[str, int]:
    return h.status("exe").plans["legs"]


def test_the_table_steps_through_the_plan_and_finishes_past_the_last_step(exe: Harness) -> None:
    exe.command("exe", "GO")
    exe.cycle(1)  # S0: plan
    assert plan(exe) == {"replans_left": 2, "step": 0, "steps": 3}
    outs = []
    for _ in range(3):
        exe.cycle(1)
        outs.append(exe.world["out"])
    assert outs == [10, 11, 12]
    assert plan(exe) == {"replans_left": 2, "step": 3, "steps": 3}
    exe.cycle(1)
    assert exe.status("exe").status == "DONE"
    controller = exe.controller("exe")
    assert controller.plan_legs_done is True
    assert (controller.plan_legs_n, controller.plan_legs_size, controller.plan_legs_last) == (
        0,
        0.0,
        False,
    ), "past the last step every field reads as none"


def test_a_failed_step_is_replanned_until_no_replans_are_left(exe: Harness) -> None:
    exe.command("exe", "GO")
    exe.cycle(2)  # planned, and step 0 carried out
    exe.world["fail"] = True
    exe.cycle(1)
    assert plan(exe) == {"replans_left": 1, "step": 0, "steps": 3}
    assert exe.controller("exe").plan_legs_n == 20, "the replan's steps"
    exe.cycle(1)
    assert plan(exe)["replans_left"] == 0
    exe.cycle(1)
    assert exe.status("exe").status == "ERROR", "no replans left: the table fails"
    exe.command("exe", "GO")  # a new command plans again, with every replan
    exe.world["fail"] = False
    exe.cycle(2)
    assert plan(exe) == {"replans_left": 2, "step": 1, "steps": 3}
    assert exe.world["out"] == 10


@pytest.mark.parametrize(
    ("wanted", "message"),
    [
        (5, "hook `plan_legs` of `exe` returned 5 steps, more than the plan's capacity "
         "(a list of at most 4 steps, each a tuple (int, finite float, bool)) "
         "(rule GO/S0/1, cycle 1)"),
        (-1, "hook `plan_legs` of `exe` returned step 0 as (1, 2.0); a plan is a list of at "
         "most 4 steps, each a tuple (int, finite float, bool) (rule GO/S0/1, cycle 1)"),
    ],
)  # fmt: skip
def test_a_plan_too_long_or_of_the_wrong_shape_is_one_line_error(
    exe: Harness, wanted: int, message: str
) -> None:
    exe.world["wanted"] = wanted
    exe.command("exe", "GO")
    with pytest.raises(Exception, match=r"^hook") as raised:
        exe.cycle(1)
    assert type(raised.value).__name__ == "HookError"
    assert str(raised.value) == message
    assert "\n" not in str(raised.value)


def test_the_generated_executor_reads_like_a_hand_written_table() -> None:
    front = compile_paths([PLANS])
    text = emit.render_all(front.systems)["plans/exe.py"]
    assert "            elif state == S1 and self.plan_legs_done:" not in text  # several rules
    for line in (
        "            if self.plan_legs_done:",
        "                self.world_out = self.plan_legs_n",
        "                self.plan_legs_go(self.plan_legs_step + 1)  # advance: legs",
        "            self.plan_legs_replans_left = 2  # plan: legs, from no steps",
        "                returned = within(",
        '                    HOOK_DEADLINES["plan_legs"],',
        "                    hooks.plan_legs,",
        '        problem = plan_problem(steps, "ifb", 4)',
    ):
        assert line in text.splitlines(), line


def _changed(tmp_path: Path, old: str, new: str) -> list[tuple[str, str]]:
    copy = tmp_path / "plans"
    shutil.copytree(PLANS, copy)
    spec = copy / "exe.yaml"
    text = spec.read_text(encoding="utf-8")
    assert old in text
    spec.write_text(text.replace(old, new), encoding="utf-8")
    front = compile_paths([copy])
    return [(d.code, f"{d.message} / {d.hint}") for d in front.diagnostics]


@pytest.mark.parametrize(
    ("old", "new", "code", "words"),
    [
        ("set: {world.out: legs.n}", "set: {world.out: legs.m}", "E290",
         "plan `legs` has no step field or property `m`"),
        ("do: [plan: legs]", "do: [plan: leg]", "E292", "did you mean"),
        ("steps: {n: int,", "steps: {step: int,", "E291", "step field `step`"),
        ("planner: plan_legs", "planner: plan_leg", "E294",
         "planner `plan_leg` of plan `legs` is not defined"),
        ("args: [world.wanted, legs.steps]", "args: [legs.size, legs.steps]", "E293",
         "argument 1 of planner `plan_legs` is a float, but the function's parameter is "
         "annotated `int`"),
        ("world.fail and legs.replans_left > 0", "world.fail", "W309",
         "can `replan: legs` when no replans are left"),
    ],
)  # fmt: skip
def test_mistakes_in_plans_are_located_diagnostics(
    tmp_path: Path, old: str, new: str, code: str, words: str
) -> None:
    found = _changed(tmp_path, old, new)
    assert any(c == code and words in m for c, m in found), found


def test_an_every_cycle_plan_action_is_refused(tmp_path: Path) -> None:
    found = _changed(tmp_path, "commands:", "every_cycle:\n  - do: [advance: legs]\ncommands:")
    assert [c for c, _ in found] == ["E295"]
    assert "a plan is stepped through by a command's table" in found[0][1]


def test_the_analysis_reads_done_as_past_the_last_step() -> None:
    """`legs.done` and `not legs.done and ...` are exclusive and, with the replans left
    bounded by 0..2, `> 0` and `== 0` cover every case: the fixture is clean under
    --strict, so no counter-example shows a replan count below 0."""
    front = compile_paths([PLANS])
    assert not list(front.diagnostics)


def test_a_stand_in_must_declare_its_controller_s_plans(tmp_path: Path) -> None:
    """The stand-in writes the controller's status buffer, which holds each plan's step."""
    copy = tmp_path / "plans"
    shutil.copytree(PLANS, copy)
    system = copy / "system.yaml"
    system.write_text(
        system.read_text(encoding="utf-8") + "\nstand_ins: {exe: exe_sim}\n", encoding="utf-8"
    )
    (copy / "exe_sim.yaml").write_text(
        "controller: exe_sim\ntitle: Executor stand-in\n"
        "commands:\n  GO:\n    states:\n      S0:\n        - do: [report: DONE]\n",
        encoding="utf-8",
    )
    found = [(d.code, d.message) for d in compile_paths([copy]).diagnostics]
    assert ("E236", "stand-in `exe_sim` and `exe` declare different plans") in found, found


def test_a_replan_that_may_run_out_can_be_acknowledged_on_its_rule(tmp_path: Path) -> None:
    found = _changed(
        tmp_path,
        "        - when: not legs.done and world.fail and legs.replans_left > 0\n",
        "        - when: not legs.done and world.fail\n"
        "          allow: [{code: W309, reason: the planner never fails twice here}]\n",
    )
    codes = [c for c, _ in found]
    assert "W309" not in codes
    # rule 3 (no replans left) now never fires: rule 2 takes every such cycle first
    assert any(c == "W512" and "rule 3 of GO S1 never fires" in m for c, m in found), found


def test_rcsgen_run_names_the_plan_action_of_a_plan_that_does_not_fit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    copy = tmp_path / "plans"
    shutil.copytree(PLANS, copy)
    (copy / "scenarios").mkdir()
    (copy / "scenarios" / "long.yaml").write_text(
        "scenario: long\ntitle: A plan too long\nmax_cycles: 20\nstop_when_done: exe\n"
        "events:\n  - cycle: 1\n    set: {wanted: 6}\n    command: exe.GO\n",
        encoding="utf-8",
    )
    monkeypatch.chdir(copy)
    result = CliRunner().invoke(main, ["run", "scenarios/long.yaml"], catch_exceptions=False)
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    assert (
        "exe.yaml:21:22: error[E421]: hook `plan_legs` of `exe` returned 6 steps, more than "
        "the plan's capacity" in result.output
    )
    assert "= hint: a planner returns a list of steps" in result.output


TABLE = """    states:
      S0:
        - do: [plan: legs]
          next: S1
      S1:
        - when: {first}
          do: [report: DONE]
        - when: {second}
          do: [advance: legs]
        - when: {third}
          do: [report: ERROR]
"""


def _table(tmp_path: Path, first: str, second: str, third: str) -> list[tuple[str, str]]:
    text = (PLANS / "exe.yaml").read_text(encoding="utf-8")
    states = text[text.index("    states:\n") :]
    return _changed(tmp_path, states, TABLE.format(first=first, second=second, third=third))


def test_the_analysis_shows_a_real_overlap_of_done_with_a_step(tmp_path: Path) -> None:
    """Done and at step 1 or later: both hold once the last step is passed (step 3 of 3)."""
    found = _table(tmp_path, "legs.done", "legs.step >= 1", "legs.step < 1 and not legs.done")
    overlaps = [m for c, m in found if c == "E501"]
    assert len(overlaps) == 1, found
    assert "legs.step=1" in overlaps[0] and "(legs.steps - legs.step)=0" in overlaps[0]


def test_the_analysis_shows_no_plan_it_cannot_have(tmp_path: Path) -> None:
    """No steps at all and at step 1 or later cannot both hold (the step is never past the
    steps): not an E501 with a made-up counter-example; at most "cannot prove" (W502).
    Done and not done are exclusive and cover every plan: only the real overlap of rules 2
    and 3 (not done, the step failing) is reported, and no wait (W503)."""
    found = _table(tmp_path, "legs.steps == 0", "legs.step >= 1", "legs.done")
    pair = [m for c, m in found if c in ("E501", "W502") and "rules 1 and 2" in m]
    assert len(pair) == 1 and pair[0].startswith("cannot prove rules 1 and 2"), found
    assert "both hold if (legs.steps)=0" in pair[0], "shown as the spec names it"
    found = _table(tmp_path / "b", "legs.done", "not legs.done and world.fail", "not legs.done")
    assert [c for c, _ in found if c in ("E501", "W502", "W503")] == ["E501"], found


def test_the_analysis_knows_a_plan_holds_at_most_its_capacity(tmp_path: Path) -> None:
    """At the last possible step (4 of capacity 4) the plan is done: `legs.step >= 4 and not
    legs.done` never holds, so it overlaps nothing and never fires (W512), and no
    counter-example shows a step 4 with steps after it."""
    found = _table(tmp_path, "legs.done", "legs.step >= 4 and not legs.done", "not legs.done")
    assert [c for c, _ in found if c in ("E501", "W502")] == [], found
    assert any(c == "W512" and "rule 2 of GO S1 never fires" in m for c, m in found), found


# ---------------------------------------------------------------- the console


def test_ctl_status_shows_where_the_executor_is_in_its_plan() -> None:
    """The submarine as OS processes, its mission sent: `ctl status` says which step of the
    route cc is on, of how many, and how many replans are left (text and JSON)."""
    import importlib

    from conftest import REPO, wait_for
    from test_ctl import Running

    from rcsgen.tools.harness import import_package

    package, specs = REPO / "generated" / "submarine", REPO / "specs" / "submarine"
    layout = importlib.import_module(f"{import_package(package, specs).__name__}.layout")
    running = Running(package, specs, layout, "--send", "cc.RUN_MISSION")  # paced: 1 s a cycle

    def route() -> dict[str, int]:
        return running.module("cc")["plans"]["route"]  # type: ignore[index, no-any-return]

    try:
        wait_for(lambda: route()["steps"] > 0, "cc's route planned", 60)
        plan = route()
        assert plan["steps"] > 1 and 0 <= plan["step"] < plan["steps"], plan
        assert plan["replans_left"] == 2, "no replan on an open passage"
        text = running.ctl("status").stdout.splitlines()
        shown = [line for line in text if line.startswith("plan cc.route: ")]
        assert len(shown) == 1, text
        step, steps = shown[0].split("step ")[1].split(",")[0].split(" of ")
        assert int(steps) == plan["steps"] and 0 <= int(step) < int(steps), shown
        assert shown[0].endswith(", 2 replans left"), shown
    finally:
        running.stop()
