"""`rcsgen prove`'s view of one controller's tables (rcsgen/compiler/prove/adapter.py): each
rule's guard with its predicates, functions and `let` values inlined (what z3 reads of a
run), what it reads, the world fields and locals it writes and the values it writes them,
the actuators it sets safe or not, a `for:` rule's hold and an `after:` rule's threshold.
One controller that uses each of them, built through the front end as `rcsgen prove` does."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.expressions.nodes import Ref
from rcsgen.compiler.expressions.printer import to_python
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import timers
from rcsgen.compiler.prove.adapter import EXECUTING, Choice, RuleView, Skeleton, skeleton
from rcsgen.compiler.prove.model import Edge, State

SYSTEM = """\
system: arm
title: One arm
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  drive: {type: float, initial: 0.0, actuator: true, safe: 0.0}
  lamp: {type: bool, initial: false, actuator: true, safe: false}
  note: {type: int, initial: 0}
processes:
  p:
    modules: [arm]
"""
ARM = """\
controller: arm
title: Arm
world:
  reads: [pos]
  writes: [drive, lamp, note]
constants:
  LIMIT: 2.0
predicates:
  far: world.pos > LIMIT
functions:
  twice:
    doc: Twice x.
    params: {x: float}
    returns: float
    body: 2.0 * x
locals:
  count: {type: int, initial: 0, doc: Moves done.}
  mode: {type: enum, values: [IDLE, BUSY], initial: BUSY, doc: An enum starts as its index.}
commands:
  MOVE:
    first_match: [S0]
    let:
      goal: twice(world.pos)
    states:
      S0:
        - when: >-
            far() and not (-world.pos > goal)
            or (world.pos if count > 1 else abs(twice(world.pos))) > 9.0
          do:
            - set: {world.drive: 0.0, count: count + 1, world.note: 3}
            - report: DONE
        - when: world.pos < 1.0
          for: 3 cycles
          do: [{set: {world.drive: twice(1.5), world.lamp: true}}]
          next: S1
      S1:
        - after: 5 cycles
          do: [{set: {world.lamp: false}}, {report: DONE}]
  HALT:
    states:
      S0:
        - do: [{set: {world.drive: 0.0, world.lamp: false}}, {report: DONE}]
"""


@pytest.fixture(scope="module")
def arm(tmp_path_factory: pytest.TempPathFactory) -> Skeleton:
    directory = tmp_path_factory.mktemp("arm")
    (directory / "system.yaml").write_text(SYSTEM)
    (directory / "arm.yaml").write_text(ARM)
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    actuators = frozenset(f.name for f in system.world if f.actuator)
    return skeleton(system, system.controllers[0], actuators)


def rule(sk: Skeleton, command: str, state: str, index: int) -> RuleView:
    return sk.tables[command][state][index]


def text(tree: object) -> str | None:
    def name(ref: Ref) -> str:
        return f"{ref.kind}.{ref.name}"

    return None if tree is None else to_python(tree, name)  # type: ignore[arg-type]


def test_the_tables_in_code_order_with_rcsgens_default_init(arm: Skeleton) -> None:
    assert arm.commands == ("INIT", "HALT", "MOVE")
    assert arm.generated == frozenset({"INIT"})
    assert arm.subs == ()
    assert {c: list(states) for c, states in arm.tables.items()} == {
        "INIT": ["S0"],
        "HALT": ["S0"],
        "MOVE": ["S0", "S1"],
    }
    assert arm.actuators == ("drive", "lamp")
    assert {name: initial for name, (_, initial) in arm.locals_init.items()} == {
        "count": 0,
        "mode": 1,
    }
    assert arm.constants == {"LIMIT": 2.0}
    assert arm.every == []


def test_a_guard_with_its_predicate_function_and_let_inlined(arm: Skeleton) -> None:
    first = rule(arm, "MOVE", "S0", 0)
    assert first.id == "MOVE/S0/1"
    assert first.text == (
        "far() and not (-world.pos > goal) or (world.pos if count > 1 else "
        "abs(twice(world.pos))) > 9.0"
    )
    # far() is world.pos > LIMIT, goal is twice(world.pos), twice(x) is 2.0 * x
    assert text(first.tree) == (
        "(world.pos > const.LIMIT and not -world.pos > 2.0 * world.pos) or (world.pos if "
        "local.count > 1 else abs(2.0 * world.pos)) > 9.0"
    )
    assert first.reads == frozenset({("const", "LIMIT"), ("local", "count"), ("world", "pos")})
    assert first.guard is not None
    assert (first.report, first.next_state, first.sends, first.hold) == ("DONE", None, (), None)


def test_what_a_rule_writes_and_whether_its_actuators_are_left_safe(arm: Skeleton) -> None:
    first = rule(arm, "MOVE", "S0", 0)
    assert first.world_sets == frozenset({"drive", "note"})
    assert first.assigns == frozenset({"world.drive", "count", "world.note"})
    assert first.actuators == (("drive", True),)  # 0.0: its safe value
    assert [(k, text(v)) for k, v in first.writes] == [
        ("world.drive", "0.0"),
        ("count", "local.count + 1"),
        ("world.note", "3"),
    ]
    second = rule(arm, "MOVE", "S0", 1)
    assert second.actuators == (("drive", False), ("lamp", False))
    assert [(k, text(v)) for k, v in second.writes] == [
        ("world.drive", "2.0 * 1.5"),
        ("world.lamp", "True"),
    ]
    assert second.world_sets == frozenset({"drive", "lamp"})
    halt = rule(arm, "HALT", "S0", 0)
    assert halt.actuators == (("drive", True), ("lamp", True))
    assert halt.tree is None and halt.guard is None and halt.reads == frozenset()
    assert halt.text == ""


def test_a_for_rule_holds_and_an_after_rule_is_a_timer(arm: Skeleton) -> None:
    held = rule(arm, "MOVE", "S0", 1)
    assert held.hold == 3
    assert text(held.tree) == "world.pos < 1.0 and held.held_move_s0_2 > 3"
    assert held.next_state == "S1" and held.report is None
    timed = rule(arm, "MOVE", "S1", 0)
    assert text(timed.tree) == "time.ticks >= 5" and timed.hold is None
    assert timed.reads == frozenset({("time", "ticks")})
    assert arm.timers == {("MOVE", "S1"): (5,)}


def run(*cycles: tuple[str | None, tuple[str, ...], str]) -> list[tuple[Edge, State]]:
    """A run of arm's model: per cycle (the new command read, the rules that fired, the
    state after it)."""
    out = []
    for new, rules, state in cycles:
        edge = Edge(new, (), None, False, rules, (), None, (), (), True, (), ())
        out.append((edge, State("MOVE", state, EXECUTING, 0, ())))
    return out


def test_a_for_rule_fires_only_once_its_when_can_have_held_long_enough(arm: Skeleton) -> None:
    """timers.feasible (z3): `for: 3 cycles` fires when its counter is above 3, counted from
    the new command's cycle (1) on; a new command starts it again."""
    pytest.importorskip("z3")
    fire = ("MOVE/S0/2",)
    wait = (None, (), "S0")
    assert timers.feasible(arm, run(("MOVE", (), "S0"), wait, wait, (None, fire, "S1"))) == (
        True,
        "",
    )
    early = run(("MOVE", (), "S0"), wait, (None, fire, "S1"))
    assert timers.feasible(arm, early) == (
        False,
        "impossible under its hold times (z3): MOVE/S0/2 (for: 3 cycles) in cycle 3 fires "
        "before its `when` can have held that long",
    )
    again = run(("MOVE", (), "S0"), wait, wait, ("MOVE", (), "S0"), (None, fire, "S1"))
    assert timers.feasible(arm, again)[0] is False
    # a run that fires no `for:` rule is not asked about
    assert timers.feasible(arm, run(("MOVE", ("MOVE/S0/1",), "S0"))) == (True, "")


HOOKED = Path(__file__).parent / "cases" / "valid" / "hooked"


def test_what_a_hook_returns_into_is_written_with_a_value_prove_cannot_follow(
    tmp_path: Path,
) -> None:
    """The corpus's hooked system, its `level` made an actuator: a hook's returns are
    writes of an unknown value (None), in call order, and an actuator a hook returns into
    is never taken as set safe."""
    directory = tmp_path / "hooked"
    shutil.copytree(HOOKED, directory)
    system_yaml = directory / "system.yaml"
    system_yaml.write_text(
        system_yaml.read_text().replace(
            "    type: float\n    initial: 0.0\n",
            "    type: float\n    initial: 0.0\n    actuator: true\n    safe: 0.0\n",
            1,
        )
    )
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    top = skeleton(system, system.controller("top"), frozenset({"level"}))
    start = rule(top, "GO", "S0", 0)
    assert [(k, text(v)) for k, v in start.writes] == [
        ("n", "local.n + 1"),
        ("world.level", None),  # nudge returns it
        ("n", None),  # split returns both
        ("world.level", None),
    ]
    assert start.world_sets == frozenset({"level"})
    assert start.assigns == frozenset({"n", "world.level"})
    assert start.actuators == (("level", False), ("level", False))
    assert start.sends == (("sub", "MOVE"),) and start.next_state == "S1"
    done = rule(top, "GO", "S1", 0)
    assert done.actuators == (("level", False),)  # 2.5, not its safe 0.0
    assert top.actuators == ("level",)


def test_the_table_rule_of_a_cycle_is_told_from_its_every_cycle_rules() -> None:
    """An edge's rules are RuleId texts, the every_cycle rules first: table_rules keeps the
    table's (a command's state's rule), is_every_cycle tells them apart by the id alone."""
    from rcsgen.compiler.checks.tables import RuleId
    from rcsgen.compiler.prove.adapter import is_every_cycle, table_rules

    every, table = str(RuleId(None, None, 2)), str(RuleId("EVERY_CYCLE", "S1", 1))
    assert [is_every_cycle(r) for r in (every, table)] == [True, False]
    assert table_rules((every, table)) == [table]
    assert table_rules((every,)) == []


def test_each_for_rule_fired_too_early_is_named_with_its_cycle(arm: Skeleton) -> None:
    """timers.feasible (z3): a run that fires `for: 3 cycles` too early twice (in cycle 2,
    and again in cycle 4 after a new MOVE) names both firings, in run order."""
    pytest.importorskip("z3")
    fire = (None, ("MOVE/S0/2",), "S1")
    twice = run(("MOVE", (), "S0"), fire, ("MOVE", (), "S0"), fire)
    assert timers.feasible(arm, twice) == (
        False,
        "impossible under its hold times (z3): MOVE/S0/2 (for: 3 cycles) in cycle 2, "
        "MOVE/S0/2 (for: 3 cycles) in cycle 4 fires before its `when` can have held that long",
    )


def test_without_z3_a_run_with_a_for_rule_is_undecided_and_says_how_to_get_it(
    arm: Skeleton, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(timers, "z3_or_none", lambda: None)
    early = run(("MOVE", (), "S0"), (None, ("MOVE/S0/2",), "S1"))
    assert timers.feasible(arm, early) == (
        None,
        "the hold times (`for:`) of counter-examples need z3: install rcsgen[prove]",
    )
    assert timers.feasible(arm, run(("MOVE", ("MOVE/S0/1",), "S0"))) == (True, "")


def test_time_in_a_timed_state_counts_up_to_its_after_threshold_and_the_rule_fires_there(
    tmp_path: Path,
) -> None:
    """The model counts arm's cycles in MOVE S1 (`after: 5 cycles`) as the state's ticks, up
    to 5 and no further; S1's rule fires only at 5; untimed S0 keeps no count."""
    from rcsgen.compiler.prove.lost import RuntimeReaction
    from rcsgen.compiler.prove.model import Model, explore

    (tmp_path / "system.yaml").write_text(SYSTEM)
    (tmp_path / "arm.yaml").write_text(ARM)
    system = compile_paths([tmp_path]).systems[0]
    sk = skeleton(system, system.controllers[0], frozenset({"drive", "lamp"}))
    graph = explore(Model(sk, {}, RuntimeReaction(system)))
    ticks = {(s.state, s.ticks) for s in graph.edges if s.command == "MOVE"}
    assert sorted(ticks) == [("NOP", 0), ("S0", 0), *(("S1", n) for n in range(6))]
    fired = {
        s.ticks for s, edges in graph.edges.items() for e, _ in edges if "MOVE/S1/1" in e.rules
    }
    assert fired == {5}


def test_which_rule_can_fire_is_decided_by_the_atoms_fixed(arm: Skeleton) -> None:
    """Skeleton.choices: S1's `after: 5 cycles` rule fires at 5 cycles, certainly, and no
    rule fires at 3 (certainly); in S0 each rule can fire and so can none, each decided
    with the values that make it so (what a replay scripts); a rule without a guard always
    fires."""
    from rcsgen.compiler.analysis.tables import Atom

    s1 = arm.tables["MOVE"]["S1"]
    at = [arm.choices(s1, {("time", "ticks"): n}) for n in (3, 5)]
    assert [[(c.rule, c.certain, c.valuation) for c in cs] for cs in at] == [
        [(None, True, ())],
        [(0, True, ())],
    ]
    s0 = arm.choices(arm.tables["MOVE"]["S0"], {("time", "ticks"): 0})
    pos, held = (Atom.WORLD, "pos"), (Atom.HELD, "held_move_s0_2")
    assert [(c.rule, c.certain, dict(c.valuation)) for c in s0] == [
        (0, True, {pos: 4.5}),
        (1, True, {pos: -4.5, held: 4}),
        (None, True, {pos: -4.5, held: 3}),
    ]
    assert arm.choices(arm.tables["HALT"]["S0"], {}) == (Choice(0, True, ()),)
