"""Checks of a controller's tables and of a system's stand-ins and safe values
(rcsgen/compiler/checks/check.py) that the corpus shows in one form only, word for word in
their other forms: the reserved NOP, an every_cycle rule that can
never fire, a stand-in for a controller that is not there or that is not there itself, an
enum actuator whose safe value is not one of its values. One small system, edited."""

from __future__ import annotations

from dataclasses import FrozenInstanceError
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.compiler.checks import tables
from rcsgen.compiler.checks.check import check_system
from rcsgen.compiler.diagnostics import Diagnostics
from rcsgen.compiler.frontend import compile_paths

SYSTEM = """\
system: tank
title: A tank
cycle_period: 0.1

world:
  level: {type: float, initial: 0.0, doc: Sensed level.}
  pump_on: {type: bool, initial: false, actuator: true, doc: Pump motor on.}
  mode: {type: enum, values: [IDLE, RUN], initial: IDLE, actuator: true, safe: IDLE, doc: A mode.}

processes:
  p:
    modules: [tank]
"""

TANK = """\
controller: tank
title: Tank level

world:
  reads: [level]
  writes: [pump_on]

commands:
  FILL:
    doc: Pump until the level is high.
    states:
      S0:
        - when: world.level < 2.0
          do:
            - set: {world.pump_on: true}
        - when: world.level >= 2.0
          do:
            - set: {world.pump_on: false}
            - report: DONE
  HALT:
    doc: Stop the pump.
    states:
      S0:
        - do:
            - set: {world.pump_on: false}
            - report: DONE
"""


def said(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, system: str, tank: str):
    (tmp_path / "system.yaml").write_text(system)
    (tmp_path / "tank.yaml").write_text(tank)
    monkeypatch.chdir(tmp_path)
    found = compile_paths([Path(".")]).diagnostics
    return [(d.code, d.message, d.hint) for d in found.items]


def test_the_small_system_is_clean(tmp_path, monkeypatch) -> None:
    assert said(tmp_path, monkeypatch, SYSTEM, TANK) == []


@pytest.mark.parametrize(
    ("old", "new", "want"),
    [
        (
            "            - report: DONE\n",
            "            - report: DONE\n      NOP:\n        - do: [report: DONE]\n",
            ("E227", "`NOP` is reserved for the idle state", ""),
        ),
        (
            "commands:\n",
            "every_cycle:\n  - when: 1 > 2\n    do:\n      - set: {world.pump_on: false}\n\n"
            "commands:\n",
            (
                "W302",
                "this every_cycle rule never fires: its guard is always false",
                "it reads only literals and constants, and they make it false: check the "
                "constants, or delete the rule",
            ),
        ),
    ],
)
def test_a_table_written_wrong(tmp_path, monkeypatch, old: str, new: str, want) -> None:
    assert old in TANK
    found = said(tmp_path, monkeypatch, SYSTEM, TANK.replace(old, new, 1))
    assert want in found and found[0] == want, found  # (a NOP state is unreachable too)


@pytest.mark.parametrize(
    ("added", "want"),
    [
        (
            "stand_ins:\n  tnak: tank\n",
            ("E234", "`tnak` has a stand-in but no controller spec", "did you mean `tank`?"),
        ),
        (
            "stand_ins:\n  tank: tank_sim\n",
            ("E234", "stand-in `tank_sim` has no controller spec", "did you mean `tank`?"),
        ),
    ],
)
def test_a_stand_in_that_is_not_there(tmp_path, monkeypatch, added: str, want) -> None:
    assert want in said(tmp_path, monkeypatch, SYSTEM + "\n" + added, TANK)


def test_an_enum_actuators_safe_value_is_one_of_its_values(tmp_path, monkeypatch) -> None:
    system = SYSTEM.replace("safe: IDLE", "safe: STOP")
    assert said(tmp_path, monkeypatch, system, TANK) == [
        (
            "E801",
            "safe value `STOP` of `mode` is not a value of enum IDLE, RUN",
            "declared values: `IDLE`, `RUN`",
        )
    ]


@pytest.mark.parametrize(
    ("edit", "want"),
    [
        (
            ("pump_on: {type: bool, initial: false", "pump_on: {type: bool, initial: true"),
            "actuator `pump_on` starts at true, not at its safe value false (its type's zero, "
            "the default): until its writer's first cycle the machine is commanded true",
        ),
        (
            (
                "initial: IDLE, actuator: true, safe: IDLE",
                "initial: RUN, actuator: true, safe: IDLE",
            ),
            "actuator `mode` starts at RUN, not at its safe value IDLE (declared): until its "
            "writer's first cycle the machine is commanded RUN",
        ),
    ],
)
def test_an_actuator_that_starts_away_from_safe_is_w803(tmp_path, monkeypatch, edit, want) -> None:
    """Declared or the type's zero, the safe value is what an actuator starts at; a valid
    safe value only (an invalid one is E801 alone, above)."""
    assert edit[0] in SYSTEM
    found = said(tmp_path, monkeypatch, SYSTEM.replace(*edit), TANK)
    assert [(code, message) for code, message, _ in found] == [("W803", want)]


@pytest.mark.parametrize(
    ("guard", "want"),
    [
        (
            "world.level < 1e400",
            ("E102", "the literal inf is not allowed", "use a number or a string"),
        ),
        ("world.level < __x", ("E102", "dunder name `__x` is not allowed", "")),
        ("high", ("E107", "predicate `high` must be called", "write `high()`")),
        ("world", ("E108", "`world` needs a field: `world.<field>`", "")),
        (
            "world.level < 1 or 'a\\0b' == 'c'",
            ("E276", "invalid string literal: a string may not contain the NUL character", ""),
        ),
    ],
)
def test_a_guard_written_wrong(tmp_path, monkeypatch, guard: str, want) -> None:
    tank = TANK.replace("commands:\n", "predicates:\n  high: world.level > 2.0\n\ncommands:\n")
    tank = tank.replace("- when: world.level < 2.0", f"- when: {guard}", 1)  # a plain scalar
    found = said(tmp_path, monkeypatch, SYSTEM, tank)
    assert found[:1] == [want], found


@pytest.mark.parametrize(
    ("length", "shown"),
    [(39, "m" * 38 + "\\n"), (40, "m" * 37 + "...")],  # 40 characters shown whole, no more
)
def test_a_wrong_name_is_shown_escaped_and_cut_at_40_characters(
    tmp_path, monkeypatch, length: int, shown: str
) -> None:
    name = "m" * (length - 1) + "\\n"  # a line break the schema's `$` lets through
    local = f'locals:\n  "{name}": {{type: int, initial: 0, doc: A count.}}\n\ncommands:\n'
    assert said(tmp_path, monkeypatch, SYSTEM, TANK.replace("commands:\n", local, 1)) == [
        (
            "E601",
            f"`{shown}` is not a valid local name: expected a lower_case identifier (a-z, then "
            "a-z, 0-9, _)",
            "names are plain ASCII identifiers; remove the line break or other character",
        )
    ]


def test_a_function_named_like_a_name_of_the_generated_code_is_refused(
    tmp_path, monkeypatch
) -> None:
    """A function is a module function of the generated code and a `let` a local of its
    method: neither may take a name that code already uses, nor a (soft) keyword (named
    `words`, a function replaced the runtime's `words(buf)` the class calls; `held`,
    `caused`, ... alike)."""
    taken = ["self", "state", "hooks", "perf_counter_ns", "words", "held", "hook", "within"]
    taken += ["caused", "plan_problem", "decode_text", "abs", "len", "match"]
    functions = "".join(
        f"  {name}:\n    params: {{x: float}}\n    returns: float\n    body: x / 2\n"
        for name in taken
    )
    tank = TANK.replace("commands:\n", f"functions:\n{functions}\ncommands:\n", 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == [
        (
            "E262",
            f"function `{name}` cannot be named so: it is "
            + ("a Python keyword" if name == "match" else "a name the generated code uses"),
            "rename the function",
        )
        for name in taken
    ]


def test_validate_shows_the_line_and_a_caret_under_the_column(tmp_path, monkeypatch) -> None:
    """What a person reads in the terminal: the message at its place, the spec's line, a
    caret under the column, the hint, the count."""
    (tmp_path / "system.yaml").write_text(SYSTEM)
    wrong = TANK.replace("- when: world.level < 2.0", "- when: world.levle < 2.0", 1)
    (tmp_path / "tank.yaml").write_text(wrong)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["validate", "."])
    assert result.exit_code == 1
    assert result.output == (
        "tank.yaml:13:17: error[E104]: undeclared world field `levle`\n"
        "  |         - when: world.levle < 2.0\n"
        "  |                 ^\n"
        "  = hint: did you mean `level`?\n"
        "1 error, 0 warnings\n"
    )


def test_each_let_named_like_something_else_is_refused(tmp_path, monkeypatch) -> None:
    """Every `let` of a command is checked, not only those before the first refused one."""
    lets = "    let:\n      state: 1.0\n      high: 2.0\n      gap: 3.0 - world.level\n"
    tank = TANK.replace("commands:\n", "predicates:\n  high: world.level > 2.0\n\ncommands:\n")
    tank = tank.replace("    doc: Pump until the level is high.\n", "    doc: Pump.\n" + lets, 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == [
        (
            "E262",
            "`let` value `state` cannot be named so: it is a name the generated code uses",
            "rename it",
        ),
        ("E262", "`let` value `high` cannot be named so: it is a predicate", "rename it"),
    ]


def test_the_harness_given_two_systems_says_which_and_where(tmp_path, monkeypatch) -> None:
    """`harness.generate` runs one system: given a directory of two, each is named at its
    `system:` line (it raised a SpecError with no diagnostic at all)."""
    from rcsgen.compiler.diagnostics import SpecError
    from rcsgen.tools.harness import generate

    for name in ("tank", "vat"):
        (tmp_path / "two" / name).mkdir(parents=True)
        (tmp_path / "two" / name / "system.yaml").write_text(SYSTEM.replace("tank", name, 1))
        (tmp_path / "two" / name / "tank.yaml").write_text(TANK)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SpecError) as raised:
        generate(Path("two"))
    both = "`two` holds 2 systems, `tank` (two/tank/system.yaml), `vat` (two/vat/system.yaml)"
    assert [(str(d.span), d.code, d.message, d.hint) for d in raised.value.diagnostics.items] == [
        (
            f"two/{name}/system.yaml:1:9",
            "E224",
            f"{both}: the harness runs one",
            f"give one system's directory: `two/{name}`",
        )
        for name in ("tank", "vat")
    ]


def test_a_process_running_a_module_with_no_near_name_lists_the_declared_controllers(
    tmp_path, monkeypatch
) -> None:
    """E211's hint: the close name when there is one (the corpus), else every controller."""
    system = SYSTEM.replace("modules: [tank]", "modules: [tank, boiler]")
    assert said(tmp_path, monkeypatch, system, TANK) == [
        (
            "E211",
            "process `p` runs `boiler`, which has no controller spec",
            "declared controllers: `tank`",
        )
    ]


def test_each_integer_value_out_of_range_is_found_beside_a_specs_constants(
    tmp_path, monkeypatch
) -> None:
    """E110 for every value out of 64 bits, wherever it is declared: a world field's initial
    and safe values, a local's initial value, a constant, all in one system."""
    big = 2**63
    system = SYSTEM.replace(
        "processes:",
        f"  count: {{type: int, initial: {big}, doc: A count.}}\n"
        f"  limit: {{type: int, initial: -{big + 1}, actuator: true, safe: -{big + 1}, "
        "doc: A limit.}\n"
        "\nprocesses:",
    )
    tank = TANK.replace(
        "commands:\n",
        f"locals:\n  n: {{type: int, initial: {big + 2}, doc: A count.}}\n\n"
        f"constants:\n  TOP: {big + 3}\n\ncommands:\n",
        1,
    )
    found = said(tmp_path, monkeypatch, system, tank)
    assert [message for _, message, _ in found] == [
        f"integer {value} is out of range: an int is 64-bit (-{big} to {big - 1})"
        for value in (big, -big - 1, -big - 1, big + 2, big + 3)
    ]
    assert {(code, hint) for code, _, hint in found} == {
        ("E110", "use a smaller number, or a float if the value is not a count")
    }


@pytest.mark.parametrize(
    ("edit", "name"),
    [
        (("reads: [level]", "reads: [level, pressure]"), "pressure"),
        (("- set: {world.pump_on: true}", "- set: {world.flow: true}"), "flow"),
    ],
    ids=["reads", "set"],
)
def test_an_undeclared_world_field_with_no_near_name_lists_the_world_fields(
    tmp_path, monkeypatch, edit, name: str
) -> None:
    """E104's hint, in a controller's `reads:` and at a `set:`: the close name when there
    is one, else every world field declared."""
    assert said(tmp_path, monkeypatch, SYSTEM, TANK.replace(*edit, 1)) == [
        (
            "E104",
            f"undeclared world field `{name}`",
            "declared world fields: `level`, `mode`, `pump_on`",
        )
    ]


def test_a_command_name_with_a_line_break_is_refused_as_an_upper_case_identifier(
    tmp_path, monkeypatch
) -> None:
    tank = TANK.replace("  FILL:\n", '  "FILL\\n":\n', 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank)[:1] == [
        (
            "E601",
            "`FILL\\n` is not a valid command name: expected an UPPER_CASE identifier (A-Z, "
            "then A-Z, 0-9, _)",
            "names are plain ASCII identifiers; remove the line break or other character",
        )
    ]


def test_every_stand_in_is_checked_after_one_that_is_not_there(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A stand-in with no spec is reported, and the stand-ins after it are still checked."""
    added = "stand_ins:\n  tank: tank_sim\n  tnak: tnak_sim\n"
    found = said(tmp_path, monkeypatch, SYSTEM + "\n" + added, TANK)
    assert ("E234", "stand-in `tank_sim` has no controller spec", "did you mean `tank`?") in found
    assert ("E234", "`tnak` has a stand-in but no controller spec", "did you mean `tank`?") in found


def _e215(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, tank: str) -> list[tuple[int, str]]:
    (tmp_path / "system.yaml").write_text(SYSTEM)
    (tmp_path / "tank.yaml").write_text(tank)
    monkeypatch.chdir(tmp_path)
    found = compile_paths([Path(".")]).diagnostics.items
    return [(d.span.line, d.message) for d in found if d.code == "E215"]


def test_a_planner_without_a_hooks_module_is_shown_at_the_planner(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    plans = (
        "plans:\n  route:\n    doc: A route.\n    planner: plan_route\n    args: []\n"
        "    steps: {x: float}\n    capacity: 4\n\n"
    )
    tank = TANK.replace("world:\n", plans + "world:\n", 1)
    line = tank.splitlines().index("    planner: plan_route") + 1
    assert _e215(tmp_path, monkeypatch, tank) == [
        (line, "`tank` declares a planner but no `hooks_module`")
    ]


def test_a_state_factory_without_a_hooks_module_is_shown_at_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tank = TANK.replace("world:\n", "hooks_state: new_state\n\nworld:\n", 1)
    line = tank.splitlines().index("hooks_state: new_state") + 1
    found = _e215(tmp_path, monkeypatch, tank)
    assert [at for at, _ in found] == [line], found


def test_a_passed_on_reason_passes_lost_and_the_reasons_both_declare() -> None:
    """`reason: tl.reason` in MS's CALIBRATE_CMM (reasons REFUSED, TIMED_OUT, MACHINE_FAULT)
    passes on LOST and the reasons TL declares that the command declares too; any other
    code of TL's reads as NONE (docs/semantics.md, "Results and reasons")."""
    system, controllers = compile_paths([Path("specs/inspection")]).models["inspection"]
    checked = check_system(system, controllers, Diagnostics())
    assert checked is not None
    command = checked.controllers["ms"].commands["CALIBRATE_CMM"]
    passed = {
        (action.reason, action.passes)
        for state in command.states.values()
        for rule in state.rules
        for action in rule.actions
        if isinstance(action, tables.Report) and action.status == "ERROR"
    }
    assert passed == {("tl.reason", ("LOST", "REFUSED", "TIMED_OUT")), ("MACHINE_FAULT", ())}
    # a checked command is a value the back end and the prover share: it cannot be changed
    with pytest.raises(FrozenInstanceError):
        command.code = 9  # type: ignore[misc]
