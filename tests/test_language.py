"""The language of issue 14, items 1-3: time in a state, results and reasons, expressions.

Each feature is tested where it shows: its meaning cycle by cycle through the harness on
the fixtures in tests/fixtures/language/, what the analysis makes of it (tests/test_analysis.py's
`spec` fixture), and that a table not using it generates exactly the code it did before.
The differential test (tests/test_differential.py) runs the features against the reference
interpreter too.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import REPO
from test_analysis import at, found, spec  # noqa: F401  (the `spec` fixture)

from rcsgen.compiler.back_end import emit
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness

FIXTURES = Path(__file__).resolve().parent / "fixtures" / "language"


# ---------------------------------------------------------------- time


@pytest.fixture
def timed():
    with Harness.build(FIXTURES / "timed") as h:
        yield h


def test_after_fires_once_the_state_has_lasted_that_many_cycles(timed: Harness) -> None:
    """`after: 3 cycles` in S0: the command arrives in cycle 1 (S0's first), so the rule
    fires in cycle 4, three cycles later; not before."""
    timed.command("rudder", "CENTER")
    seen = []
    for _ in range(5):
        timed.step("rudder")
        seen.append(timed.status("rudder").status)
    assert seen == ["EXECUTING", "EXECUTING", "EXECUTING", "DONE", "DONE"]


def test_a_new_command_starts_the_time_again(timed: Harness) -> None:
    """Two cycles into CENTER a new CENTER arrives: its S0 waits its three cycles afresh."""
    timed.command("rudder", "CENTER")
    timed.step("rudder")
    timed.step("rudder")
    number = timed.command("rudder", "CENTER")
    for _ in range(3):
        timed.step("rudder")
        assert timed.status("rudder").status == "EXECUTING"
    timed.step("rudder")
    assert (timed.status("rudder").status, timed.status("rudder").number) == ("DONE", number)


def _into_s1(h: Harness) -> None:
    """helm ICE_MANEUVER: S0 sends CENTER and moves to S1; the rudder is done at once."""
    h.command("helm", "ICE_MANEUVER")
    h.step("helm")
    h.reply("rudder", "DONE")
    assert h.status("helm").state == "S1"


def test_for_fires_when_the_condition_has_held_the_whole_duration(timed: Harness) -> None:
    """`for: 0.5 s` at 0.1 s a cycle: ice seen in 5 cycles in a row is not enough; the rule
    fires in the cycle it has held for 5 cycles after the first sighting (the 6th)."""
    _into_s1(timed)
    timed.world["ice_ahead"] = True
    states = []
    for _ in range(6):
        timed.step("helm")
        states.append(timed.status("helm").state)
    assert states == ["S1"] * 5 + ["S2"]
    assert timed.sent("rudder").command == "HARD_OVER"


def test_for_starts_again_when_the_condition_breaks(timed: Harness) -> None:
    """Four cycles of ice, one without, then ice again: the count starts from the break."""
    _into_s1(timed)
    for ice in [True] * 4 + [False] + [True] * 5:
        timed.world["ice_ahead"] = ice
        timed.step("helm")
    assert timed.status("helm").state == "S1"
    timed.step("helm")
    assert timed.status("helm").state == "S2"


@pytest.fixture
def watch():
    with Harness.build(FIXTURES / "watch") as h:
        yield h


def test_for_on_an_every_cycle_rule_counts_whatever_the_command(watch: Harness) -> None:
    """`for: 0.3 s` (3 cycles) every cycle: ice seen 3 cycles is not enough, the 4th raises
    the alarm, and a command arriving meanwhile does not start the count again."""
    watch.world["ice_ahead"] = True
    alarms = []
    for cycle in range(4):
        if cycle == 2:
            watch.command("watch", "LOOK")
        watch.step("watch")
        alarms.append(watch.world["alarm"])
    assert alarms == [False, False, False, True]


def test_for_on_an_every_cycle_rule_starts_again_when_the_condition_breaks(
    watch: Harness,
) -> None:
    """Three cycles of ice, one without, three again: no alarm; a fourth raises it."""
    for ice in [True] * 3 + [False] + [True] * 3:
        watch.world["ice_ahead"] = ice
        watch.step("watch")
        assert watch.world["alarm"] is False
    watch.step("watch")
    assert watch.world["alarm"] is True


def test_after_counts_from_entering_the_state_not_the_command(timed: Harness) -> None:
    """S2 times out 2 s (20 cycles) after it was entered, whatever S1 took before."""
    _into_s1(timed)
    timed.world["ice_ahead"] = True
    for _ in range(6):
        timed.step("helm")
    assert timed.status("helm").state == "S2"  # the rudder now works on HARD_OVER
    for _ in range(20):
        timed.step("helm")
        assert timed.status("helm").status == "EXECUTING"
    timed.step("helm")
    assert (timed.status("helm").status, timed.status("helm").rule) == (
        "ERROR",
        "ICE_MANEUVER/S2/3",
    )
    assert timed.sent("rudder").command == "CENTER"


def test_time_is_counted_in_the_process_s_period(tmp_path: Path) -> None:
    """A process with its own cycle_period counts `after: 1 s` in its own cycles."""
    source = FIXTURES / "timed"
    target = tmp_path / "timed"
    target.mkdir()
    for path in source.glob("*.yaml"):
        text = path.read_text(encoding="utf-8")
        if path.name == "system.yaml":
            text = text.replace("[helm, rudder]", "[helm, rudder]\n    cycle_period: 0.5")
        (target / path.name).write_text(text, encoding="utf-8")
    with Harness.build(target) as h:
        _into_s1(h)
        h.world["ice_ahead"] = False
        for _ in range(6):  # `after: 3 s` at 0.5 s: 6 cycles after S1's first
            h.step("helm")
        assert h.status("helm").status == "EXECUTING"
        h.step("helm")
        assert h.status("helm").status == "DONE"


def test_cycle_period_is_the_process_s_and_only_a_table_reading_it_has_it(tmp_path: Path) -> None:
    """CYCLE_PERIOD in an expression is the seconds per cycle of the controller's process
    (0.5 s where the process has its own period, not the system's 0.1 s); a controller whose
    expressions do not read it does not define it."""
    source = FIXTURES / "watch"
    target = tmp_path / "watch"
    target.mkdir()
    for path in source.glob("*.yaml"):
        text = path.read_text(encoding="utf-8")
        if path.name == "system.yaml":
            text = text.replace("[watch]", "[watch]\n    cycle_period: 0.5")
            text = text.replace(
                "processes:",
                "  seen_for:\n    type: float\n    initial: 0.0\n    doc: Seconds of ice.\n\n"
                "processes:",
            )
        else:
            text = text.replace("writes: [alarm]", "writes: [alarm, seen_for]")
            text = text.replace(
                "do: [set: {world.alarm: true}]",
                "do: [set: {world.alarm: true, world.seen_for: world.seen_for + CYCLE_PERIOD}]",
            )
        (target / path.name).write_text(text, encoding="utf-8")
    with Harness.build(target) as h:
        h.world["ice_ahead"] = True
        for _ in range(3):  # `for: 0.3 s` at 0.5 s a cycle: one cycle, so the second fires
            h.step("watch")
        assert (h.world["alarm"], h.world["seen_for"]) == (True, 1.0)
    front = compile_paths([target, FIXTURES / "timed"])
    assert not front.diagnostics.errors
    code = emit.render_all(front.systems)
    assert "CYCLE_PERIOD = 0.5  # seconds per cycle of its process" in code["watch/watch.py"]
    assert "CYCLE_PERIOD" not in code["timed/helm.py"]


def test_timed_code_reads_like_a_hand_written_table(tmp_path: Path) -> None:
    """The counters are spelled where a C programmer would keep them: one line per `for:`
    at the top of its state, the time in the rule's test with the duration as a comment,
    and the time kept up to date once at the end of the table."""
    front = compile_paths([FIXTURES / "timed"])
    assert not front.diagnostics.errors
    helm = emit.render_all(front.systems)["timed/helm.py"]
    assert (
        "self.held_ice_maneuver_s1_2 = (\n"
        "                self.held_ice_maneuver_s1_2 + 1 if self.world_ice_ahead else 0\n"
        "            )"
    ) in helm
    assert "elif self.held_ice_maneuver_s1_2 > 5:  # for: 0.5 s = 5 cycles" in helm
    assert "elif self.ticks >= 20:  # after: 2 s = 20 cycles" in helm
    assert (
        "        if self.state != state:  # a new state, or the command ended: time starts again\n"
        "            self.ticks = 0\n"
        "            self.held_ice_maneuver_s1_2 = 0\n"
        "        else:\n"
        "            self.ticks += 1\n"
    ) in helm


def test_tables_without_time_generate_what_they_did_before() -> None:
    """The feature costs nothing where it is not used: every package, rendered now, is the
    committed one byte for byte, and of the miner's modules only the tram (its time-out is
    `after: 6 s`) keeps time; the others have no counter at all."""
    front = compile_paths([REPO / "specs"])
    assert not front.diagnostics.errors
    files = emit.render_all(front.systems)
    for rel, text in files.items():
        assert (REPO / "generated" / rel).read_text(encoding="utf-8") == text, rel
        if rel.startswith("miner/") and rel != "miner/tc.py":
            assert "self.ticks" not in text and "held_" not in text, rel
    assert "self.ticks >= 60:  # after: 6 s = 60 cycles" in files["miner/tc.py"]


# ---------------------------------------------------------------- time in the analysis


def test_a_time_out_ends_a_wait_so_it_is_not_a_wait(spec) -> None:  # noqa: F811
    """A state whose only way out is a time-out is not W503: time passes. A `for:` whose
    condition may never come is still a wait, shown without the time."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - after: 2 s
                next: S1
            S1:
              - when: world.hot
                for: 1 s
                do: [report: DONE]
        """
    )
    assert found(diags, "W503", "W508", "W512") == [
        (at("    |S1:"), "W503", "GO S1 waits when world.hot=false: no rule fires then")
    ]


def test_a_time_out_beside_a_condition_overlaps_it(spec) -> None:  # noqa: F811
    """Both can hold in one cycle, so rule order decides: E501, with the time it takes."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO]
                next: S1
            S1:
              - when: a.status == DONE
                do: [report: DONE]
              - when: a.status == ERROR
                do: [report: ERROR]
              - after: 3 cycles
                do: [report: ERROR]
        """
    )
    assert found(diags, "E501") == [
        (
            at("        - |after: 3 cycles"),
            "E501",
            "rules 1 and 3 of GO S1 can both fire: both hold when a.status=DONE, cycles_in_state=3",
        ),
        (
            at("        - |after: 3 cycles"),
            "E501",
            "rules 2 and 3 of GO S1 can both fire: both hold when a.status=ERROR, "
            "cycles_in_state=3",
        ),
    ]


def test_a_guard_that_waits_for_time_is_never_dead(spec) -> None:  # noqa: F811
    """`after:` alone, or after an exclusive guard, can always fire: no W508/W512."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.hot
                do: [report: DONE]
              - when: not world.hot
                after: 10 cycles
                do: [report: ERROR]
        """
    )
    assert found(diags) == []


# ---------------------------------------------------------------- results and reasons


@pytest.fixture
def results():
    with Harness.build(FIXTURES / "results") as h:
        yield h


def _status(h: Harness, module: str) -> dict:
    """The whole status buffer of `module`, its results and error_num included."""
    return dict(h.layout.STATUS_OUT[module].read(h.buf))


def test_a_result_is_read_while_the_subordinate_keeps_executing(results: Harness) -> None:
    """The helm reports at_goal while it goes on holding station (Figure 18): the mission
    reads it in a guard, and reports its own result with DONE."""
    results.world["answer"] = 1  # the operator clamps at once
    results.command("mission", "GO")
    results.cycle(4)
    assert results.status("mission").status == "EXECUTING"
    results.world["distance"] = 0.5
    results.cycle(1)
    helm = _status(results, "helm")
    assert (helm["status"], helm["result_at_goal"], helm["result_course_error"]) == (1, True, 0.5)
    assert results.status("mission").status == "EXECUTING"  # it runs before the helm
    results.cycle(1)
    mission = _status(results, "mission")
    assert (mission["status"], mission["error_num"], mission["result_legs"]) == (2, 0, 5)


def test_a_reason_tells_refused_from_timed_out(results: Harness) -> None:
    """The operator refuses: fx says REFUSED, the mission OPERATOR_REFUSED. Nobody
    answers: fx times out after 2 s, TIMED_OUT, and the mission says NO_OPERATOR."""
    layout = results.package.fx
    results.world["answer"] = 2
    results.command("mission", "GO")
    results.cycle(2)
    assert _status(results, "fx")["error_num"] == layout.REASON_REFUSED == 2
    assert (
        _status(results, "mission")["error_num"] == results.package.mission.REASON_OPERATOR_REFUSED
    )
    assert results.sent("helm").command == "HALT"
    results.world["answer"] = 0
    results.command("mission", "GO")
    results.cycle(1)
    assert _status(results, "mission")["error_num"] == 0  # a new command: no reason yet
    results.cycle(19)
    assert results.status("fx").status == "EXECUTING"  # 2 s = 20 cycles after CLAMP arrived
    results.cycle(1)
    assert (results.status("fx").status, _status(results, "fx")["error_num"]) == ("ERROR", 3)
    assert results.status("mission").status == "EXECUTING"  # it reads fx one cycle later
    results.cycle(1)
    assert _status(results, "mission")["error_num"] == results.package.mission.REASON_NO_OPERATOR


def test_results_of_an_earlier_command_are_not_read_before_the_echo(results: Harness) -> None:
    """A supervisor reads a result (and a reason) only once the subordinate has echoed the
    last command sent: before that they read as none, never as the last command's."""
    results.world["answer"] = 1
    results.world["distance"] = 0.5
    results.command("mission", "GO")
    results.cycle(3)
    assert _status(results, "helm")["result_at_goal"] is True
    results.command("mission", "GO")
    results.step("mission")  # sends a new TRANSIT; helm has not run yet
    results.step("mission")
    mission = results.controller("mission")
    assert mission.helm_status_num != mission.helm_command_num
    assert mission.helm_result_at_goal is False
    assert results.status("mission").state == "S1"


def test_lost_is_the_runtime_s_safe_state_reason() -> None:
    """`LOST` names the error_num the runtime reports when a subordinate's process is lost."""
    from rcsgen.compiler.expressions import BUILTIN_REASONS
    from rcsgen.runtime.loop import LOST_SUBORDINATE

    assert BUILTIN_REASONS.index("LOST") == LOST_SUBORDINATE
    assert BUILTIN_REASONS.index("NONE") == 0


def _with_mission(tmp_path: Path, states: str) -> list:
    """The results fixture with the mission's GO table replaced: the mission's diagnostics."""
    target = tmp_path / "results"
    target.mkdir(parents=True)
    for path in (FIXTURES / "results").glob("*.yaml"):
        (target / path.name).write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    (target / "mission.yaml").write_text(
        "controller: mission\ntitle: Mission\nsubordinates: [helm, fx]\ncommands:\n"
        "  GO:\n    states:\n      S0:\n        - do: [send: fx.CLAMP]\n          next: S1\n"
        f"      S1:\n{states}",
        encoding="utf-8",
    )
    front = compile_paths([target])
    found = [*front.diagnostics, *front.diagnostics.acknowledged]
    return [d for d in found if d.span.file.endswith("mission.yaml")]


def test_a_reason_comes_only_with_error_in_the_analysis(tmp_path: Path) -> None:
    """`fx.reason == REFUSED` cannot hold with `fx.status == DONE`: no false overlap; with
    `fx.status == ERROR` it can, and the counter-example names the reason."""
    apart = _with_mission(
        tmp_path / "a",
        "        - when: fx.status == DONE\n          do: [report: DONE]\n"
        "        - when: fx.reason == REFUSED\n          do: [report: ERROR]\n"
        "        - when: fx.status == ERROR and fx.reason != REFUSED\n"
        "          do: [report: ERROR]\n",
    )
    assert [d.code for d in apart] == []
    overlap = _with_mission(
        tmp_path / "b",
        "        - when: fx.status == ERROR\n          do: [report: ERROR]\n"
        "        - when: fx.reason == TIMED_OUT\n          do: [report: ERROR]\n"
        "        - when: fx.status == DONE\n          do: [report: DONE]\n",
    )
    assert [(d.code, d.message) for d in overlap] == [
        (
            "E501",
            "rules 1 and 2 of GO S1 can both fire: both hold when fx.status=ERROR, "
            "fx.reason=TIMED_OUT",
        ),
        (  # and, since a reason comes only with ERROR, rule 1 always fires first
            "W512",
            "rule 2 of GO S1 never fires: whenever its guard holds, an earlier rule (1) fires "
            "first",
        ),
    ]


# ---------------------------------------------------------------- expressions


@pytest.mark.parametrize(
    ("text", "python", "kind"),
    [
        ("x if b else 2.5", "x if b else 2.5", "float"),
        ("(x if b else 1) + 1", "(x if b else 1) + 1", "int"),
        ("1 if b else 2 if x > 1 else 3", "1 if b else 2 if x > 1 else 3", "int"),
        ("(1 if b else 2) if x > 1 else 3", "(1 if b else 2) if x > 1 else 3", "int"),
        ("b if x > 0 or b else not b", "b if x > 0 or b else not b", "bool"),
    ],
)
def test_a_conditional_expression_is_typed_and_printed_back(text: str, python: str, kind: str):
    """`a if c else b`: both values of one type (an int and a float make a float), printed
    with the parentheses Python needs and no others."""
    from rcsgen.compiler.diagnostics import Diagnostics, Span
    from rcsgen.compiler.expressions import Scope, compile_expr, to_python

    diags = Diagnostics()
    from rcsgen.compiler.types import BOOL, INT

    scope = Scope(locals={"x": INT, "b": BOOL})
    tree = compile_expr(text, Span("t", 1, 1), scope, diags)
    assert tree is not None, [d.message for d in diags]
    assert (to_python(tree, lambda ref: ref.name), str(tree.type)) == (python, kind)


def test_a_conditional_of_constants_folds() -> None:
    """`LIMIT if FAST else 1` with constants is a constant: a guard of it can be W302."""
    from rcsgen.compiler.diagnostics import Diagnostics, Span
    from rcsgen.compiler.expressions import Scope, compile_expr, fold

    constants = {"FAST": False, "LIMIT": 4}
    tree = compile_expr(
        "LIMIT if FAST else 1", Span("t", 1, 1), Scope(constants=constants), Diagnostics()
    )
    assert tree is not None and fold(tree, constants) == 1


@pytest.fixture
def steering():
    with Harness.build(FIXTURES / "expressions") as h:
        yield h


@pytest.mark.parametrize(
    ("heading", "goal", "rudder", "status"),
    [
        (0.0, 350.0, -20.0, "EXECUTING"),  # the error wraps to -10: order 2 * -10
        (350.0, 10.0, 30.0, "EXECUTING"),  # +20 across north: clamped at 30
        (10.0, 11.5, 0.0, "DONE"),  # within 2 degrees: on course
        (179.0, -179.0, 0.0, "DONE"),  # -358 wraps to +2: on the edge of on course
        (179.0, -178.0, 6.0, "EXECUTING"),  # -357 wraps to +3
    ],
)
def test_named_values_and_functions_compute_the_order(
    steering: Harness, heading: float, goal: float, rudder: float, status: str
) -> None:
    steering.world["heading"] = heading
    steering.world["goal_heading"] = goal
    steering.world["rudder"] = 99.0
    steering.command("helm", "STEER")
    steering.step("helm")
    assert (steering.world["rudder"], steering.status("helm").status) == (rudder, status)


def test_let_and_functions_read_like_hand_written_code() -> None:
    """A function is a module-level `def`; the named values are locals of the table's
    method, computed first; guards read them by name."""
    front = compile_paths([FIXTURES / "expressions"])
    helm = emit.render_all(front.systems)["expressions/helm.py"]
    assert (
        "def wrap(a: float) -> float:\n"
        '    """An angle in degrees folded into -180..180.\n\n'
        "    Pure function: a - 360.0 if a > 180.0 else (a + 360.0 if a < -180.0 else a)\n"
        '    """\n'
        "    return a - 360.0 if a > 180.0 else a + 360.0 if a < -180.0 else a\n"
    ) in helm
    assert (
        "        state = self.state\n"
        "        # Named values (let), computed once a cycle before the rules.\n"
        "        error = wrap(self.world_goal_heading - self.world_heading)\n"
        "        order = clamp(GAIN * error, MAX_RUDDER)\n"
        "        if state == S0:\n"
        "            if -ON_COURSE <= error <= ON_COURSE:\n"
    ) in helm


def test_the_analysis_sees_through_let_functions_and_conditionals(tmp_path: Path) -> None:
    """The fixture's guards are exclusive and complete: nothing is reported. Changed to
    overlap, the counter-example is a real heading difference, found through `let`, the
    function and its conditional (-358 degrees wraps to +2)."""
    assert not list(compile_paths([FIXTURES / "expressions"]).diagnostics)
    target = tmp_path / "expressions"
    target.mkdir()
    for path in (FIXTURES / "expressions").glob("*.yaml"):
        text = path.read_text(encoding="utf-8")
        text = text.replace(
            "- when: error < -ON_COURSE or error > ON_COURSE", "- when: error > 1.0"
        )
        (target / path.name).write_text(text, encoding="utf-8")
    found = [(d.code, d.message) for d in compile_paths([target]).diagnostics]
    assert found == [
        (
            "W503",
            "STEER S0 waits when (world.goal_heading - world.heading)=-180.0: no rule fires then",
        ),
        (
            "E501",
            "rules 1 and 2 of STEER S0 can both fire: both hold when "
            "(world.goal_heading - world.heading)=-358.0",
        ),
    ]


def test_a_comparison_through_min_is_decided_exactly(spec) -> None:  # noqa: F811
    """min/max of a variable are decided exactly (issue 26 item 4): `min(level, 5) > 3`
    and `level < 2` never hold at once (no W502), and the gap between them, where no rule
    fires, is a wait (W503) shown with a level in it."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: cap(world.level) > 3.0
                do: [report: DONE]
              - when: world.level < 2.0
                do: [report: ERROR]
        """,
        top_level="""
        functions:
          cap:
            params: {v: float}
            returns: float
            body: min(v, 5.0)
        """,
    )
    assert [d.code for d in diags] == ["W503"]
    assert "world.level" in diags[0].message, diags[0].message


@pytest.mark.parametrize("fixture", ["timed", "results", "expressions"])
def test_each_fixture_is_clean_under_strict(fixture: str) -> None:
    """The fixtures show the features as a user would write them: no error, no warning
    that is not acknowledged with its reason (what `--strict` requires)."""
    front = compile_paths([FIXTURES / fixture])
    assert [d.render() for d in front.diagnostics] == []
    assert front.systems


def test_the_reference_pages_show_results_reasons_lets_and_functions(tmp_path: Path) -> None:
    """`rcsgen doc` documents what a supervisor may read and what a table computes."""
    from rcsgen.tools import reference

    pages = {}
    for fixture in ("results", "expressions"):
        pages.update(reference.render(compile_paths([FIXTURES / fixture]).systems[0]))
    helm = next(
        text for name, text in pages.items() if name.endswith("helm.md") and "TRANSIT" in text
    )
    assert "| `result.at_goal` | bool | Within a metre of the goal. |" in helm
    assert "It can fail for: `LOST_TRACK`." in helm
    mission = next(text for name, text in pages.items() if name.endswith("mission.md"))
    assert "report ERROR (OPERATOR_REFUSED)" in mission
    steering = next(
        text for name, text in pages.items() if name.endswith("helm.md") and "STEER" in text
    )
    assert "| `error` | `wrap(world.goal_heading - world.heading)` |" in steering
    assert "| function | `clamp(x: float, limit: float)` -> float |" in steering


def test_a_stand_in_has_its_controller_s_results_and_reasons(tmp_path: Path) -> None:
    """A stand-in writes its controller's status buffer, so it declares the same results
    and reasons: another reason is E236, as another parameter is."""
    target = tmp_path / "results"
    target.mkdir()
    for path in (FIXTURES / "results").glob("*.yaml"):
        (target / path.name).write_text(path.read_text(encoding="utf-8"), encoding="utf-8")
    system = target / "system.yaml"
    system.write_text(
        system.read_text(encoding="utf-8") + "stand_ins: {fx: fx_sim}\n", encoding="utf-8"
    )
    fx = (target / "fx.yaml").read_text(encoding="utf-8")
    (target / "fx_sim.yaml").write_text(
        fx.replace("controller: fx", "controller: fx_sim")
        .replace("TIMED_OUT]", "NO_ANSWER]")
        .replace("reason: TIMED_OUT}", "reason: NO_ANSWER}"),
        encoding="utf-8",
    )
    found = [(d.code, d.message) for d in compile_paths([target]).diagnostics]
    assert found == [
        ("E236", "CLAMP of stand-in `fx_sim` has other parameters, results or reasons than `fx`'s")
    ]
