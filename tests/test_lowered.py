"""What lowering decides for a controller module, read from the IR `compile_paths` returns
(rcsgen/compiler/back_end/lower.py): the enumeration values its tables name, whether from a
guard, an assigned value, a sent argument or a predicate (each becomes a module constant of
its index, so one left out is a NameError when the rule runs); the contract's names it
imports; a subordinate's reason codes, made when a report passes its reason up; a guard that
is always true lowered to none; a process's own period and real-time settings; which
every_cycle rules raise `world_set`. One small system of two controllers, in process."""

from __future__ import annotations

import dataclasses
import inspect
import itertools
from pathlib import Path

import pytest

from rcsgen.compiler import ir
from rcsgen.compiler.frontend import compile_paths

SYSTEM = """\
system: pair
title: A supervisor and a device
cycle_period: 0.1

world:
  level: {type: float, initial: 0.0, doc: Sensed level.}

processes:
  p:
    modules: [top, dev]
"""
TOP = """\
controller: top
title: Top
subordinates: [dev]
commands:
  GO:
    doc: Run the device; fail for its reason when it fails.
    reasons: [REFUSED, WORN, BLOCKED]
    states:
      S0:
        - do: [{send: dev.RUN, with: {how: FAST}}]
          next: S1
      S1:
        - when: dev.status == ERROR
          do: [{report: ERROR, reason: dev.reason}]
        - when: dev.status == DONE
          do: [report: DONE]
"""
DEV = """\
controller: dev
title: Device
locals:
  mode: {type: enum, values: [IDLE, SLOW, FAST, JAMMED], initial: IDLE, doc: Its mode.}
predicates:
  stuck: mode == JAMMED
commands:
  RUN:
    doc: Run as told; jam when the level is high.
    reasons: [WORN, BLOCKED]
    params:
      how: {type: enum, values: [IDLE, SLOW, FAST, JAMMED], doc: How fast.}
    states:
      S0:
        - when: stuck()
          do: [{report: ERROR, reason: BLOCKED}]
        - when: not stuck() and how == SLOW
          do: [set: {mode: FAST}, report: DONE]
        - when: not stuck() and how != SLOW
          do: [report: DONE]
"""


@pytest.fixture(scope="module")
def lowered(tmp_path_factory: pytest.TempPathFactory) -> dict[str, ir.IRController]:
    root = tmp_path_factory.mktemp("pair")
    for name, text in (("system", SYSTEM), ("top", TOP), ("dev", DEV)):
        (root / f"{name}.yaml").write_text(text)
    out = compile_paths([root])
    assert [d.code for d in out.diagnostics.items] == []
    (system,) = out.systems
    return {c.name: c for c in system.controllers}


def test_every_enumeration_value_the_tables_name_is_a_constant_of_its_index(lowered) -> None:
    # SLOW in a guard, FAST assigned, JAMMED in a predicate; top sends FAST to dev; IDLE
    # (an initial value only) is named by no table
    assert lowered["dev"].enum_values == (("SLOW", 1), ("FAST", 2), ("JAMMED", 3))
    assert lowered["top"].enum_values == (("FAST", 2),)


def test_a_module_imports_the_status_names_it_reports_and_compares(lowered) -> None:
    top, dev = lowered["top"], lowered["dev"]
    assert {"DONE", "ERROR", "NOP"} <= set(top.runtime_names)
    assert {"DONE", "ERROR", "NOP"} <= set(dev.runtime_names)
    assert "HookError" not in dev.runtime_names  # no hook called, no factory
    assert list(top.runtime_names) == sorted(
        top.runtime_names,
        key=lambda n: (0 if n.isupper() else 1 if n[:1].isupper() else 2, n.lower()),
    )


def test_a_reason_passed_up_gives_the_supervisor_its_subordinates_reason_codes(lowered) -> None:
    (sub,) = lowered["top"].subordinates
    assert sub.name == "dev"
    assert sub.reasons == (
        ("DEV_REASON_NONE", 0),
        ("DEV_REASON_LOST", 1),
        ("DEV_REASON_WORN", 2),
        ("DEV_REASON_BLOCKED", 3),
    )
    assert sub.commands == (("DEV_INIT", 1), ("DEV_HALT", 2), ("DEV_RUN", 3))
    assert lowered["dev"].reasons == (
        ("REASON_NONE", 0),
        ("REASON_LOST", 1),
        ("REASON_WORN", 2),
        ("REASON_BLOCKED", 3),
    )


def test_a_supervisor_that_reads_no_reason_gets_no_reason_codes(tmp_path: Path) -> None:
    failing = (
        "        - when: dev.status == ERROR\n          do: [{report: ERROR, reason: dev.reason}]\n"
    )
    assert failing in TOP
    for name, text in (("system", SYSTEM), ("top", TOP.replace(failing, "")), ("dev", DEV)):
        (tmp_path / f"{name}.yaml").write_text(text)
    out = compile_paths([tmp_path], analyse=False)
    assert [d.code for d in out.diagnostics.items] == []
    (system,) = out.systems
    top = next(c for c in system.controllers if c.name == "top")
    assert top.subordinates[0].reasons == ()
    assert "ERROR" not in top.runtime_names  # it neither reports nor compares ERROR now


def test_a_process_keeps_its_own_cycle_period(tmp_path: Path) -> None:
    """A process's `cycle_period:` overrides the system's, for it and for CYCLE_PERIOD in its
    controllers' expressions."""
    system = SYSTEM.replace(
        "    modules: [top, dev]\n", "    modules: [top, dev]\n    cycle_period: 0.05\n"
    )
    dev = DEV.replace(
        "        - when: stuck()\n", "        - when: stuck() and CYCLE_PERIOD < 0.07\n"
    )
    for name, text in (("system", system), ("top", TOP), ("dev", dev)):
        (tmp_path / f"{name}.yaml").write_text(text)
    out = compile_paths([tmp_path], analyse=False)
    assert [d.code for d in out.diagnostics.items] == []
    (lowered,) = out.systems
    assert [(p.name, p.cycle_period) for p in lowered.processes] == [("p", 0.05)]
    controllers = {c.name: c for c in lowered.controllers}
    assert dict(controllers["dev"].constants)["CYCLE_PERIOD"].startswith("0.05  #")


def compiled_systems(
    root: Path, system: str = SYSTEM, top: str = TOP, dev: str = DEV
) -> list[ir.IRSystem]:
    """The pair, edited, compiled without a finding (the analysis left out)."""
    for name, text in (("system", system), ("top", top), ("dev", dev)):
        (root / f"{name}.yaml").write_text(text)
    out = compile_paths([root], analyse=False)
    assert [d.code for d in out.diagnostics.items] == []
    return out.systems


def compiled(
    root: Path, system: str = SYSTEM, top: str = TOP, dev: str = DEV
) -> dict[str, ir.IRController]:
    (lowered,) = compiled_systems(root, system, top, dev)
    return {c.name: c for c in lowered.controllers}


def test_a_guard_that_is_always_true_is_lowered_to_none(tmp_path: Path) -> None:
    """A `when` that reads only constants and is true (folded by the checker) costs nothing
    at run time: the rule is lowered with no guard, as a rule with no `when`, while the
    guards that read inputs stay."""
    top = TOP.replace("subordinates: [dev]\n", "subordinates: [dev]\nconstants:\n  SPARE: 2\n")
    top = top.replace(
        "        - do: [{send: dev.RUN, with: {how: FAST}}]\n",
        "        - when: SPARE > 1\n          do: [{send: dev.RUN, with: {how: FAST}}]\n",
    )
    go = compiled(tmp_path, top=top)["top"].commands[-1]
    assert go.name == "GO"
    (sends,) = go.states[0].rules
    assert sends.guard is None
    assert all(r.guard is not None for r in go.states[1].rules)


def test_a_process_keeps_its_realtime_settings_in_order(tmp_path: Path) -> None:
    """A process's `realtime:` settings reach its lowered process (what the process module
    declares and applies as it starts), sorted by name whatever the spec's order."""
    system = SYSTEM.replace(
        "    modules: [top, dev]\n",
        "    modules: [top, dev]\n    realtime: {gc: freeze, cpus: [0]}\n",
    )
    (lowered,) = compiled_systems(tmp_path, system=system)
    assert [list(p.realtime.items()) for p in lowered.processes] == [
        [("cpus", [0]), ("gc", "freeze")]
    ]


def test_only_the_every_cycle_rules_that_set_a_world_field_raise_the_world_set_flag(
    tmp_path: Path,
) -> None:
    """An every_cycle rule records no code when it fires, so one that writes a world output
    raises `world_set` for post_process; a rule that only sends a command writes no world
    field and raises nothing."""
    top = TOP.replace(
        "subordinates: [dev]\n",
        "subordinates: [dev]\nworld:\n  reads: [level]\n  writes: [level]\n"
        "every_cycle:\n  - when: world.level > 5.0\n    do: [send: dev.HALT]\n"
        "  - do: [set: {world.level: world.level + 1.0}]\n",
    )
    lowered = compiled(tmp_path, top=top)["top"]
    sends, fills = lowered.every_cycle
    assert lowered.io is not None
    assert lowered.io.world_set_rules == (fills.id,)
    assert "world_set" in lowered.io.slots


def test_a_rules_time_is_shown_as_written_and_in_cycles_one_cycle_singular(
    tmp_path: Path,
) -> None:
    """A timed rule's comment in the generated table gives its `for:`/`after:` as the spec
    writes it and the whole cycles it counts (`1 cycle`, `3 cycles`); an untimed rule none."""
    top = TOP.replace(
        "        - when: dev.status == DONE\n",
        "        - when: dev.status == DONE\n          for: 1 cycle\n          after: 0.3 s\n",
    ).replace(
        "        - when: dev.status == ERROR\n",
        "        - when: dev.status == ERROR\n          after: 0.1\n",
    )
    go = compiled(tmp_path, top=top)["top"].commands[-1]
    assert [r.timing for r in go.states[1].rules] == [
        "after: 0.1 s = 1 cycle",
        "for: 1 cycle = 1 cycle, after: 0.3 s = 3 cycles",
    ]
    assert go.states[0].rules[0].timing == ""
    assert [r.guard_operand for r in go.states[1].rules] == [  # (cycles in the state: ticks)
        "self.dev_status == ERROR and self.ticks >= 1",
        "self.held_go_s1_2 > 1 and self.ticks >= 3",
    ]


def test_a_rule_whose_guard_reads_a_subordinates_error_names_it_as_the_cause(lowered) -> None:
    """`dev.status == ERROR` in a guard makes dev the rule's cause (its reason is passed up,
    docs/semantics.md "Reasons survive"); `dev.status == DONE` names no cause."""
    go = lowered["top"].commands[-1]
    assert go.name == "GO"
    assert [(r.guard.text if r.guard else None, r.cause_of) for r in go.states[1].rules] == [
        ("dev.status == ERROR", "dev"),
        ("dev.status == DONE", ""),
    ]


@pytest.mark.parametrize(("period", "deadline"), [(0.1, 1.0), (0.5, 2.5)])
def test_a_hook_that_declares_no_deadline_gets_five_periods_and_at_least_a_second(
    tmp_path: Path, period: float, deadline: float
) -> None:
    """docs/spec.md, a hook's `deadline`: 5 cycle periods of its process, at least 1 s."""
    dev = DEV.replace(
        "predicates:\n",
        "hooks_module: pair_hooks\nhooks:\n  gauge:\n    doc: Read the gauge.\n"
        "    args: []\n    returns: [mode]\npredicates:\n",
    )
    dev = dev.replace("[set: {mode: FAST}, report: DONE]", "[call: gauge, report: DONE]")
    (tmp_path / "pair_hooks.py").write_text("def gauge():\n    return 1\n")
    system = SYSTEM.replace("cycle_period: 0.1", f"cycle_period: {period}")
    assert compiled(tmp_path, system=system, dev=dev)["dev"].hook_calls == (
        ("gauge", deadline, "e4"),
    )


SPECS = Path(__file__).resolve().parent.parent / "specs"


def test_every_dataclass_of_the_ir_is_frozen() -> None:
    """docs/architecture.md: the IR is frozen dataclasses; the back end and the tools only
    read it, and a value one of them changed would change every later reader's output."""
    classes = [
        c
        for _, c in inspect.getmembers(ir, inspect.isclass)
        if c.__module__ == ir.__name__ and dataclasses.is_dataclass(c)
    ]
    assert len(classes) > 30
    assert [c.__name__ for c in classes if not c.__dataclass_params__.frozen] == []
    # and every IR object a build makes, walked from the system down (inspection: operators,
    # plans, hooks, world and I/O), is of a frozen class
    (system,) = compile_paths([SPECS / "inspection"], analyse=False).systems
    seen: set[int] = set()
    kinds: set[str] = set()
    todo: list[object] = [system]
    while todo:
        value = todo.pop()
        if id(value) in seen:
            continue
        seen.add(id(value))
        if isinstance(value, dict):
            todo += [*value.keys(), *value.values()]
        elif isinstance(value, (list, tuple)):
            todo += value
        elif dataclasses.is_dataclass(value) and type(value).__module__ == ir.__name__:
            assert type(value).__dataclass_params__.frozen, type(value).__name__
            kinds.add(type(value).__name__)
            todo += [getattr(value, f.name) for f in dataclasses.fields(value)]
    assert {"IRSystem", "IRController", "IRCommand", "IRRule", "Layout", "Buffer"} <= kinds


def _buffers(value: object) -> list[ir.Buffer]:
    """Every Buffer held anywhere in a layout's fields."""
    if isinstance(value, ir.Buffer):
        return [value]
    if isinstance(value, dict):
        value = list(value.values())
    elif dataclasses.is_dataclass(value):
        value = [getattr(value, f.name) for f in dataclasses.fields(value)]
    if isinstance(value, (list, tuple)):
        return [b for v in value for b in _buffers(v)]
    return []


def test_the_layouts_buffer_list_holds_each_of_its_buffers_once_in_block_order() -> None:
    """all_buffers (the layout's hash, the layout module's table) lists every buffer of the
    block: each module's, each operator's own and each of its channels', the world's, ...
    once, by offset, none overlapping the next (inspection has an operator with channels)."""
    (system,) = compile_paths([SPECS / "inspection"], analyse=False).systems
    layout = system.layout
    assert layout.operators and all(o.channels for o in layout.operators.values())
    listed = layout.all_buffers()
    assert sorted(map(id, listed)) == sorted(map(id, _buffers(layout)))
    assert len({id(b) for b in listed}) == len(listed)
    for before, after in itertools.pairwise(listed):
        assert before.offset + before.size <= after.offset, (before.const, after.const)


def test_an_operator_module_imports_its_own_buffers_from_the_layout() -> None:
    """module_io.operator_io: an operator module imports its mode and perf offsets and each
    client's command, status and answer offsets; with results (ood's), the status and answer
    records' own structs too - each a buffer the layout has (submarine: eoow and ood)."""
    (system,) = compile_paths([SPECS / "submarine"], analyse=False).systems
    operators = {c.name: c for c in system.controllers if c.is_operator}
    consts = {b.const for b in system.layout.all_buffers()}
    for c in operators.values():
        assert c.io is not None
        assert {name.removesuffix("_AT") for name in c.io.imports} <= consts
    ood = operators["ood"].io
    assert ood is not None and ood.imports == (
        "OOD_MODE_AT",
        "OOD_PERF_AT",
        "OOD_SM_ANSWER",
        "OOD_SM_ANSWER_AT",
        "OOD_SM_COMMAND_AT",
        "OOD_SM_STATUS",
        "OOD_SM_STATUS_AT",
    )


def test_a_report_passes_a_subordinates_reason_up_or_gives_its_own_or_none(lowered) -> None:
    """`report: ERROR, reason: dev.reason` names dev and maps each of dev's reasons to top's
    (no constant of its own: the template sets error_num from dev's); `reason: BLOCKED` is
    its own constant; a plain `report: DONE` carries no reason at all."""
    go, run = lowered["top"].commands[-1], lowered["dev"].commands[-1]
    passed_up, done = (r.actions for r in go.states[1].rules)
    assert passed_up == (
        ir.IRReport(
            "ERROR",
            reason="",
            reason_name="dev.reason",
            reason_of="dev",
            reason_map=(
                ("DEV_REASON_LOST", "REASON_LOST"),
                ("DEV_REASON_WORN", "REASON_WORN"),
                ("DEV_REASON_BLOCKED", "REASON_BLOCKED"),
            ),
            reason_of_attribute="self.dev_error_num",
        ),
    )
    assert done == (
        ir.IRReport(
            "DONE", reason_name="", reason="", reason_of="", reason_map=(), reason_of_attribute=""
        ),
    )
    assert run.states[0].rules[0].actions == (
        ir.IRReport(
            "ERROR",
            reason_name="BLOCKED",
            reason="REASON_BLOCKED",
            reason_of="",
            reason_map=(),
            reason_of_attribute="",
        ),
    )


def test_a_reason_passed_up_maps_each_of_the_subordinates_reasons_to_the_same_name(
    lowered,
) -> None:
    """`report: ERROR, reason: dev.reason`: dev's LOST, WORN and BLOCKED become top's own
    codes of the same name (E272 makes sure GO declares each); anything else is NONE."""
    maps = {
        a.reason_map
        for command in lowered["top"].commands
        for state in command.states
        for rule in state.rules
        for a in rule.actions
        if isinstance(a, ir.IRReport) and a.reason_of == "dev"
    }
    assert maps == {
        (
            ("DEV_REASON_LOST", "REASON_LOST"),
            ("DEV_REASON_WORN", "REASON_WORN"),
            ("DEV_REASON_BLOCKED", "REASON_BLOCKED"),
        )
    }


def test_a_functions_doc_opens_its_docstring_in_the_generated_module() -> None:
    """`functions: target: doc: ...`: the doc is what a reader of pln.py meets first, then
    the body it computes (the doc was read and dropped before)."""
    root = Path(__file__).resolve().parent.parent
    (system,) = compile_paths([root / "specs" / "cell"], analyse=False).systems
    (pln,) = [c for c in system.controllers if c.name == "pln"]
    (target,) = pln.functions
    doc = "Where move `step` takes the part, mm along the rail (the cell's job)."
    assert (target.name, target.doc) == ("target", doc)
    generated = (root / "generated" / "cell" / "pln.py").read_text()
    assert f'def target(step: int) -> float:\n    """{doc}\n\n    Pure function: 20.0' in generated


def test_only_a_controller_that_declares_reasons_records_a_cause(lowered, tmp_path: Path) -> None:
    """docs/semantics.md "Reasons survive": top (reasons declared) has a `cause` field and
    its rule on dev's ERROR records dev; without reasons, neither (its ERROR has no reason)."""
    assert (lowered["top"].cause, lowered["dev"].cause) == (True, True)
    top = TOP.replace("    reasons: [REFUSED, WORN, BLOCKED]\n", "").replace(
        "[{report: ERROR, reason: dev.reason}]", "[report: ERROR]"
    )
    for name, text in (("system", SYSTEM), ("top", top), ("dev", DEV)):
        (tmp_path / f"{name}.yaml").write_text(text)
    out = compile_paths([tmp_path], analyse=False)
    assert [d.code for d in out.diagnostics.items] == []
    plain = next(c for c in out.systems[0].controllers if c.name == "top")
    assert plain.cause is False
    assert [r.cause_of for r in plain.commands[-1].states[1].rules] == ["", ""]


def test_every_dataclass_of_the_ir_module_is_declared_frozen() -> None:
    """The cheap half of the test above: each dataclass ir.py declares is frozen."""
    classes = [
        c
        for _, c in inspect.getmembers(ir, inspect.isclass)
        if c.__module__ == ir.__name__ and dataclasses.is_dataclass(c)
    ]
    assert "IRPropAtom" in {c.__name__ for c in classes}
    assert [c.__name__ for c in classes if not c.__dataclass_params__.frozen] == []


@pytest.mark.parametrize(
    ("periods", "timeout"),
    [((0.01,), 0.5), ((0.01, 0.04), 0.5), ((0.1, 0.02), 1.0), ((0.25,), 2.5)],
)
def test_the_default_heartbeat_timeout_is_ten_of_the_longest_periods_at_least_half_a_second(
    periods: tuple[float, ...], timeout: float
) -> None:
    from rcsgen.compiler.back_end.lower import default_heartbeat_timeout

    processes = [ir.IRProcess(f"p{n}", period, "", (), ()) for n, period in enumerate(periods)]
    assert default_heartbeat_timeout(processes) == pytest.approx(timeout)
