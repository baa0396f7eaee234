"""The names the generated code always has are refused to a spec, each one (E228), in words a
user can act on: a state, constant or command named like a runtime name of the controller
module (`NOP`, `SEQ_WORDS`, `READ_TRIES`, ...), a predicate named like an attribute or method of
every controller class (`resume`, `ticks`, `buf`, ...), a world field whose layout name is one
the layout module always has (`initial` -> `WORLD_INITIAL`). A name missing from the checker's
lists would build a package where the spec's name silently replaces the runtime's.

The lists are written out here on purpose: they are the behaviour (a name the checker stops
refusing is a change a user sees), not a copy of rcsgen/compiler/checks/naming.py's tables."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from test_check_messages import SYSTEM, TANK, said

from rcsgen.compiler.back_end import emit
from rcsgen.compiler.frontend import compile_paths

# every upper-case module-level name a generated controller module takes from the runtime
RUNTIME = (
    "DONE",
    "ERROR",
    "EXECUTING",
    "FACTORY_DEADLINE",
    "INPUTS",
    "INPUTS_AT",
    "NOP",
    "NOT_READY",
    "NO_RULE",
    "PERF",
    "READ_TRIES",
    "SEQ_WORDS",
    "STATUS",
)
# attributes and methods of every generated controller class (lower case: a predicate's name)
CLASS = (
    "buf",
    "command",
    "command_num",
    "cycles",
    "dont_run",
    "error_num",
    "every_cycle",
    "hook_state",
    "last_cycle_ns",
    "max_cycle_ns",
    "min_cycle_ns",
    "read_inputs",
    "resume",
    "rule",
    "safe_state",
    "simulate",
    "single_step",
    "single_step_num",
    "stale_reads",
    "state",
    "status",
    "status_dirty",
    "status_num",
    "status_seq",
    "ticks",
)
# ... and the QQ1 methods and the attributes the checker names apart ("a generated name")
GENERATED = ("perf_seq", "perf_single_step_num", "run_cycle", "world_set")


def errors(found: list[tuple[str, str, str]]) -> list[tuple[str, str, str]]:
    return [f for f in found if f[0] == "E228"]


def test_a_state_named_like_a_runtime_name_is_refused(tmp_path, monkeypatch) -> None:
    states = "".join(f"      {name}:\n        - do: [report: DONE]\n" for name in RUNTIME)
    many = "  MANY:\n    doc: Many states.\n    states:\n      S0:\n        - do: [report: DONE]\n"
    tank = TANK.replace("  HALT:\n", many + states + "  HALT:\n")
    found = errors(said(tmp_path, monkeypatch, SYSTEM, tank))
    assert found == [
        (
            "E228",
            f"state `{name}` collides with a status or runtime name in the generated module",
            "rename it",
        )
        for name in RUNTIME
    ]


def test_a_predicate_named_like_a_controllers_attribute_is_refused(tmp_path, monkeypatch) -> None:
    names = CLASS + GENERATED
    predicates = "predicates:\n" + "".join(f"  {n}: world.level > 2.0\n" for n in names)
    tank = TANK.replace("commands:\n", predicates + "\ncommands:\n")
    found = errors(said(tmp_path, monkeypatch, SYSTEM, tank))
    assert found == [
        (
            "E228",
            f"predicate `{name}` becomes `{name}` in the generated class of `tank`, which is "
            "already an attribute or method every controller has",
            "rename one of them",
        )
        for name in CLASS
    ] + [
        ("E228", f"predicate name `{name}` collides with a generated name", "")
        for name in GENERATED
    ]


@pytest.mark.parametrize("field", ["initial", "writers"])
def test_a_world_field_named_like_a_layout_name_is_refused(tmp_path, monkeypatch, field) -> None:
    extra = f"world:\n  {field}: {{type: float, initial: 0.0, doc: A field.}}\n"
    found = errors(said(tmp_path, monkeypatch, SYSTEM.replace("world:\n", extra), TANK))
    assert found == [
        (
            "E228",
            f"world field `{field}` becomes `WORLD_{field.upper()}` in the generated layout "
            "module, which is already a name the layout module always has",
            "rename one of them",
        )
    ]


# Names the generated code once had and no longer has (the QQ1 cycle is one method,
# `run_cycle`, its four steps comments in it; no `SEQ`, `SEQS` or `MODE` is imported): a
# spec's to take, as states, constants, commands, predicates and functions.
FREED_STATES = ("MODE", "SEQ")
FREED_CONSTANTS = ("SEQS", "SEQS_AT")
FREED_COMMANDS = ("PRE_PROCESS", "CHECK_IF_NEW_COMMAND", "DECISION_PROCESS", "POST_PROCESS")
FREED_PREDICATES = ("cycle_start",)
FREED_FUNCTIONS = ("is_real", "is_integer", "buf", "command")


def test_names_the_generated_code_does_not_have_are_the_specs(tmp_path, monkeypatch) -> None:
    states = "".join(f"      {name}:\n        - next: SEQ\n" for name in FREED_STATES[:1])
    states += "".join(f"      {name}:\n        - do: [report: DONE]\n" for name in FREED_STATES[1:])
    commands = "".join(
        f"  {name}:\n    doc: A command.\n    states:\n      S0:\n        - do: [report: DONE]\n"
        for name in FREED_COMMANDS
    )
    many = "  MANY:\n    doc: Many states.\n    states:\n      S0:\n        - next: MODE\n"
    head = "constants:\n" + "".join(f"  {name}: 1\n" for name in FREED_CONSTANTS)
    head += "predicates:\n" + "".join(f"  {n}: world.level > 2.0\n" for n in FREED_PREDICATES)
    head += "functions:\n" + "".join(
        f"  {n}: {{params: {{x: float}}, returns: float, body: x + 1.0}}\n" for n in FREED_FUNCTIONS
    )
    tank = TANK.replace("  HALT:\n", many + states + commands + "  HALT:\n")
    tank = tank.replace("commands:\n", head + "\ncommands:\n", 1)
    assert said(tmp_path, monkeypatch, SYSTEM, tank) == []
    [system] = compile_paths([Path(".")], analyse=False).systems
    tree = ast.parse(emit.render_all([system])["tank/tank.py"])
    assigned = [t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets]
    imported = [
        a.name for node in tree.body if isinstance(node, ast.ImportFrom) for a in node.names
    ]
    for name in (*FREED_STATES, *FREED_CONSTANTS, *FREED_COMMANDS):
        assert assigned.count(name) == 1 and name not in imported, name
    functions = [node.name for node in tree.body if isinstance(node, ast.FunctionDef)]
    assert functions == list(FREED_FUNCTIONS)
    [cls] = [node for node in tree.body if isinstance(node, ast.ClassDef)]
    methods = [node.name for node in cls.body if isinstance(node, ast.FunctionDef)]
    for name in (*(c.lower() for c in FREED_COMMANDS), *FREED_PREDICATES):
        assert methods.count(name) == 1, name


def test_a_process_whose_pacing_record_has_a_controllers_name_is_refused(
    tmp_path, monkeypatch
) -> None:
    """Process `command`'s pacing record is `PACE_COMMAND_AT` in the layout, and so is
    controller `pace`'s command buffer: the layout module assigned it twice, and the
    process's slow-down was read from the controller's command buffer."""
    (tmp_path / "system.yaml").write_text(
        SYSTEM.replace("  p:\n    modules: [tank]", "  command:\n    modules: [pace]")
    )
    (tmp_path / "pace.yaml").write_text(TANK.replace("controller: tank", "controller: pace"))
    monkeypatch.chdir(tmp_path)
    found = compile_paths([Path(".")], analyse=False).diagnostics.items
    assert [(d.code, d.message, d.hint) for d in found] == [
        (
            "E228",
            "process `command` becomes `PACE_COMMAND_AT` in the generated layout module, which "
            "is already controller `pace` (pace.yaml:1:13)",
            "rename one of them",
        )
    ]
