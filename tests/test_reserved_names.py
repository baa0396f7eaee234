"""The names the generated code always has are refused to a spec, each one (E228), in words a
user can act on: a state, constant or command named like a runtime name of the controller
module (`NOP`, `SEQ`, `READ_TRIES`, ...), a predicate named like an attribute or method of
every controller class (`resume`, `ticks`, `buf`, ...), a world field whose layout name is one
the layout module always has (`initial` -> `WORLD_INITIAL`). A name missing from the checker's
lists would build a package where the spec's name silently replaces the runtime's.

The lists are written out here on purpose: they are the behaviour (a name the checker stops
refusing is a change a user sees), not a copy of rcsgen/compiler/checks/naming.py's tables."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_check_messages import SYSTEM, TANK, said

from rcsgen.compiler.frontend import compile_paths

# every upper-case module-level name a generated controller module takes from the runtime
RUNTIME = (
    "DONE",
    "ERROR",
    "EXECUTING",
    "FACTORY_DEADLINE",
    "INPUTS",
    "INPUTS_AT",
    "MODE",
    "NOP",
    "NOT_READY",
    "NO_RULE",
    "PERF",
    "READ_TRIES",
    "SEQ",
    "SEQS",
    "SEQS_AT",
    "SEQ_WORDS",
    "STATUS",
)
# attributes and methods of every generated controller class (lower case: a predicate's name)
CLASS = (
    "buf",
    "command",
    "command_num",
    "cycle_start",
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
GENERATED = (
    "check_if_new_command",
    "decision_process",
    "perf_seq",
    "perf_single_step_num",
    "post_process",
    "pre_process",
    "run_cycle",
    "world_set",
)


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


def test_a_process_whose_pacing_record_is_a_controllers_buffer_is_refused(
    tmp_path, monkeypatch
) -> None:
    # process `x_mode`'s pacing record is PACE_X_MODE_AT, controller `pace_x`'s mode buffer
    # too: the layout module would assign it twice, the pacing record at the mode's bytes
    system = SYSTEM.replace("  p:\n    modules: [tank]", "  x_mode:\n    modules: [pace_x]")
    (tmp_path / "system.yaml").write_text(system)
    (tmp_path / "pace_x.yaml").write_text(TANK.replace("controller: tank", "controller: pace_x"))
    monkeypatch.chdir(tmp_path)
    found = compile_paths([Path(".")]).diagnostics.items
    assert [(d.code, str(d.span), d.message, d.hint) for d in found] == [
        (
            "E228",
            "system.yaml:11:3",
            "process `x_mode` becomes `PACE_X_MODE_AT` in the generated layout module, which is "
            "already controller `pace_x` (pace_x.yaml:1:13)",
            "rename one of them",
        )
    ]
