"""What `rcsgen run` says when a run fails (rcsgen/tools/scenario/runs.py `run_error`), word for
word and where, in the unit tier: a hook that raised (E420), returned what its `returns:` does
not name or a planner's wrong steps (E421), overran its deadline (E423), the run itself failing
(E422) and a soft PLC that did not start (E428). Each error is made as the generated code
raises it, against the inspection workstation's IR: the span is the `call:` in the spec the
person opens, or the rule, or the spec file, as much as is known."""

from __future__ import annotations

import traceback
from pathlib import Path

import pytest

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.runtime.contract import HookError, HookOverrun
from rcsgen.tools.scenario.devices import DeviceStartError
from rcsgen.tools.scenario.model import SoftPlc
from rcsgen.tools.scenario.runs import details, run_error

SPECS = Path(__file__).resolve().parent.parent / "specs"
RAISED = "the hook's own traceback: run again with -v"
RETURNS = "make the function return what `returns:` names, in that order and of those types"


def at(spec: str, line_has: str, word: str, after: str = "") -> str:
    """`specs/<spec>:line:col` of `word` in the first line holding `line_has` (after the
    first line holding `after`, if given): where the person reads it, found in the spec's
    text, so an edit elsewhere in the spec does not move what the test expects."""
    lines = (SPECS / spec).read_text().splitlines()
    start = next(n for n, line in enumerate(lines) if after in line) if after else 0
    n = next(n for n in range(start, len(lines)) if line_has in lines[n])
    return f"specs/{spec}:{n + 1}:{lines[n].index(word, lines[n].index(line_has)) + 1}"


CONVERT = at("inspection/wc.yaml", "- call: native_job", "native_job")


@pytest.fixture(scope="module")
def inspection() -> IRSystem:
    front = compile_paths([SPECS / "inspection"])
    assert not front.diagnostics.errors
    return front.systems[0]


def said(error: BaseException, system: IRSystem | None, cycle: int, **how) -> tuple[str, ...]:
    d = run_error(error, system, cycle, **how)
    return (str(d.span), d.code, d.message, d.hint)


def hook_error(module: str, hook: str, rule: str, cause: BaseException | None = None, **kw):
    error = HookError(module, hook, rule, 6, **kw)
    error.__cause__ = cause
    return error


def test_a_hook_that_raised_is_located_at_its_call(inspection: IRSystem) -> None:
    error = hook_error("wc", "native_job", "JOB/S0/1", ValueError("bad"))
    assert said(error, inspection, 7) == (
        CONVERT,
        "E420",
        "hook `native_job` of `wc` raised ValueError: bad (rule JOB/S0/1, cycle 7)",
        RAISED,
    )
    every = hook_error("cmm_sim", "probe", "every_cycle/2", RuntimeError("x"))
    assert said(every, inspection, 1)[:3] == (
        at("inspection/cmm_sim.yaml", "- call: probe", "probe"),
        "E420",
        "hook `probe` of `cmm_sim` raised RuntimeError: x (rule every_cycle/2, cycle 1)",
    )
    factory = hook_error("ms", "make", "hooks_state", RuntimeError("x"))
    assert said(factory, inspection, 0)[:3] == (
        at("inspection/ms.yaml", "hooks_state:", "new_program"),
        "E420",
        "hook `make` of `ms` raised RuntimeError: x (made by `hooks_state`, start-up)",
    )


def test_a_hook_not_found_at_its_call_falls_back_to_its_rule_then_its_spec(
    inspection: IRSystem,
) -> None:
    other = hook_error("ms", "judge", "MEASURE_PART/S0/1", ValueError("bad"))
    first_rule = at("inspection/ms.yaml", "- doc:", "doc", after="  MEASURE_PART:")
    assert said(other, inspection, 7)[0] == first_rule  # the rule
    unknown_rule = hook_error("ms", "judge", "MEASURE_PART/S9/1", ValueError("bad"))
    assert said(unknown_rule, inspection, 7)[0] == "specs/inspection/ms.yaml:1:1"
    nobody = hook_error("nobody", "judge", "X/S0/1", ValueError("bad"))
    assert said(nobody, inspection, 7, fallback=Span("s.yaml", 3, 1))[0] == "s.yaml:3:1"
    assert said(nobody, None, 7)[0] == "<run>:1:1"


def test_a_hook_that_overran_its_deadline(inspection: IRSystem) -> None:
    error = hook_error("wc", "native_job", "JOB/S0/1", HookOverrun(0.01, 0.05, True))
    assert said(error, inspection, 7) == (
        CONVERT,
        "E423",
        "hook `native_job` of `wc` did not return within its deadline of 0.01 s: interrupted "
        "after 0.05 s (rule JOB/S0/1, cycle 7)",
        "make the hook return sooner, or declare a longer `deadline:` for it "
        "(docs/spec.md section 6)",
    )


def test_a_hook_that_returned_the_wrong_thing_and_a_planners_wrong_steps(
    inspection: IRSystem,
) -> None:
    wrong = hook_error("wc", "native_job", "JOB/S0/1", result=3, kinds="fi")
    assert said(wrong, inspection, 7) == (
        CONVERT,
        "E421",
        "hook `native_job` of `wc` returned 3; its `returns:` needs a tuple of 2 values "
        "(finite float, int) (rule JOB/S0/1, cycle 7)",
        RETURNS,
    )
    # cmm's planner, `touch_points`, plans a feature's points (`plan: points`)
    no_replans = hook_error(
        "cmm", "touch_points", "INSPECT_FEATURE/S0/1", why="was not called: none left"
    )
    assert said(no_replans, inspection, 3) == (
        at("inspection/cmm.yaml", "[plan: points]", "points"),
        "E421",
        "hook `touch_points` of `cmm` was not called: none left (rule INSPECT_FEATURE/S0/1, "
        "cycle 3)",
        "replan only while `<plan>.replans_left > 0` (W309), and fail otherwise",
    )
    steps = hook_error(
        "cmm", "touch_points", "INSPECT_FEATURE/S0/1", why="returned a step of 4 fields"
    )
    assert said(steps, inspection, 3)[2:] == (
        "hook `touch_points` of `cmm` returned a step of 4 fields (rule INSPECT_FEATURE/S0/1, "
        "cycle 3)",
        "a planner returns a list of steps, each a tuple of the plan's step fields",
    )


def test_the_run_failing_and_a_plc_that_did_not_start() -> None:
    assert said(ValueError("boom"), None, 0) == (
        "<run>:1:1",
        "E422",
        "the run failed in start-up: ValueError: boom",
        "run again with -v for the Python traceback",
    )
    assert said(KeyError(), None, 3)[2] == "the run failed in cycle 3: KeyError"
    plc = SoftPlc("pumps", None, Span("s.yaml", 9, 5))
    assert said(DeviceStartError(plc, "no module named pymodbus"), None, 0) == (
        "s.yaml:9:5",
        "E428",
        "the soft PLC of device `pumps` did not start: no module named pymodbus",
        "install what the soft PLC needs (`pip install 'rcsgen[modbus]'`, `[opcua]`); its own "
        "error is the line quoted",
    )


def test_a_generated_module_that_failed_is_named_at_its_spec(
    inspection: IRSystem, tmp_path: Path
) -> None:
    """The innermost frame in the generated package that is a controller's module names
    it (not the package's __init__, __main__ or layout, nor a file outside the package):
    E422 at that controller's spec."""
    package = tmp_path / "inspection"
    package.mkdir()
    files = {  # ms calls into each of the package's other files, the last one fails
        "ms": "def step():\n    loop()\n",
        "__main__": "def loop():\n    offset(0)\n",
        "layout": "def offset(n):\n    return divide(8, n)\n",
        "__init__": "def divide(a, b):\n    return a // b\n",
    }
    namespace: dict[str, object] = {}
    for name, text in files.items():  # each compiled under its file's name, as imported
        path = package / f"{name}.py"
        path.write_text(text)
        exec(compile(text, str(path), "exec"), namespace)
    with pytest.raises(ZeroDivisionError) as raised:
        namespace["step"]()  # type: ignore[operator]
    assert said(raised.value, inspection, 7, package=package) == (
        "specs/inspection/ms.yaml:1:1",
        "E422",
        "module `ms` failed in cycle 7: ZeroDivisionError: integer division or modulo by zero",
        "run again with -v for the Python traceback",
    )
    assert said(raised.value, inspection, 7)[2] == (  # no package known: the run
        "the run failed in cycle 7: ZeroDivisionError: integer division or modulo by zero"
    )


def test_a_hooks_module_that_failed_to_import_is_named_at_its_line(
    inspection: IRSystem, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A generated module's import of its hooks module failed in the hooks module's own code:
    E422 at the spec's `hooks:` line naming the module-level line that failed (the deepest
    outside the package, not a function it called nor the import machinery); the import
    statement itself failing (no such module) names the generated module's line."""
    package, hooks = tmp_path / "inspection", tmp_path / "hooks"
    package.mkdir()
    hooks.mkdir()
    broken = "def load():\n    raise ImportError('no numpy')\n\nLIMIT = load()\n"
    (hooks / "broken_ms_hooks.py").write_text(broken)
    monkeypatch.syspath_prepend(str(hooks))
    monkeypatch.chdir(tmp_path)

    def failed(text: str) -> tuple[str, ...]:
        with pytest.raises(ImportError) as raised:
            exec(compile(text, str(package / "ms.py"), "exec"), {})
        return said(raised.value, inspection, 0, package=package)

    assert failed("STATES = 3\nimport broken_ms_hooks\n") == (
        at("inspection/ms.yaml", "hooks_module:", "inspection_hooks.ms"),
        "E422",
        "hooks module `inspection_hooks.ms` of `ms` failed to import (hooks/broken_ms_hooks.py:4, "
        "start-up): ImportError: no numpy",
        "the module runs when the package starts: install what it imports, or fix the line "
        "named; run again with -v for the Python traceback",
    )
    assert failed("STATES = 3\nimport no_such_hooks_module\n")[2] == (
        "hooks module `inspection_hooks.ms` of `ms` failed to import (ms.py:2, start-up): "
        "ModuleNotFoundError: No module named 'no_such_hooks_module'"
    )


def test_verbose_shows_the_hooks_own_traceback() -> None:
    try:
        raise ValueError("deep inside the hook")
    except ValueError as cause:
        error = hook_error("wc", "native_job", "JOB/S0/1", cause)
        python_says = "".join(traceback.format_exception(cause))
    shown = details(error)
    assert shown == python_says  # the hook's own traceback, as Python prints it: nothing added
    assert shown.startswith("Traceback (most recent call last):\n")
    assert shown.endswith("ValueError: deep inside the hook\n")
    assert "test_verbose_shows_the_hooks_own_traceback" in shown
    assert details(hook_error("wc", "native_job", "JOB/S0/1", result=3, kinds="f")) == ""
    assert details(KeyError("k")).endswith("KeyError: 'k'\n")


def test_a_planner_that_raised_is_located_at_its_load() -> None:
    [submarine] = compile_paths([SPECS / "submarine"]).systems
    error = hook_error("cc", "plan_route", "RUN_MISSION/TRANSIT/3", ValueError("no route"))
    assert said(error, submarine, 12)[:3] == (
        at("submarine/cc.yaml", "- replan: route", "route"),  # its rule's own `load:`
        "E420",
        "hook `plan_route` of `cc` raised ValueError: no route (rule RUN_MISSION/TRANSIT/3, "
        "cycle 12)",
    )
