"""Runs: what goes wrong while a generated system runs -> one located diagnostic each.

A hook that raises or returns values that do not fit its `returns:` makes the generated code
raise `HookError` (`rcs.contract`), naming the module, the hook and the rule that called
it; here it becomes one diagnostic at the spec's `call:` line with the cycle (E420, E421;
E423 for a hook interrupted at its deadline, or that returned past it).
Anything else a module raises (an int overflowing its 64 bits, a division by a variable
that was 0) is E422 at the module's spec. The Python traceback is kept for `-v`.
After the run: an expectation not met (E416), a difference from a golden trace (E417), a
trace that cannot be read or written (E419), and a `--generated` package that is not what
the specs make (E418).
"""

from __future__ import annotations

import traceback
from pathlib import Path
from types import TracebackType
from typing import Any

from ...compiler.back_end.write import Plan
from ...compiler.diagnostics import Diagnostic, Span, SpecError, counted
from ...compiler.frontend import display_path
from ...compiler.ir import IRCall, IRController, IRLoadPlan, IRSystem
from ...runtime.contract import HookError, HookOverrun
from .devices import DeviceStartError
from .run import RunResult, Scenario, final_value, first_difference, read_trace


def _controller(system: IRSystem | None, name: str) -> IRController | None:
    if system is None:
        return None
    return next((c for c in system.controllers if c.name == name), None)


def _spec_span(controller: IRController | None, fallback: Span) -> Span:
    """Where the controller's spec starts (its commands' tables are located in it)."""
    if controller is None or not controller.commands:
        return fallback
    span = controller.commands[0].span
    return Span(span.file)


def _call_span(controller: IRController | None, rule: str, hook: str) -> Span | None:
    """The `call:` of `hook` in the rule `rule` (a RuleId as text, or `hooks_state`)."""
    if controller is None:
        return None
    if rule == "hooks_state":
        return controller.hooks_state_span
    for ir_rule in controller.rules():
        if str(ir_rule.id) != rule:
            continue
        for action in ir_rule.actions:
            if isinstance(action, IRCall) and action.hook == hook and action.span is not None:
                return action.span
            if (
                isinstance(action, IRLoadPlan)
                and action.planner == hook
                and action.span is not None
            ):
                return action.span
        return ir_rule.span
    return None


def _generated_module(error: BaseException, package: Path | None) -> str | None:
    """The generated controller module the innermost frame of the package belongs to."""
    if package is None:
        return None
    found = None
    tb: TracebackType | None = error.__traceback__
    while tb is not None:
        path = Path(tb.tb_frame.f_code.co_filename)
        if path.parent == package and path.stem not in ("__init__", "__main__", "layout"):
            found = path.stem
        tb = tb.tb_next
    return found


def _hooks_import(
    error: BaseException, controller: IRController | None, package: Path | None
) -> str:
    """`file:line` where importing a controller's hooks module failed (the deepest line of
    a module's own code, run by the import, outside the generated package), '' when the
    error did not come from that import."""
    if controller is None or not controller.hooks_module or package is None:
        return ""
    frames = list(traceback.walk_tb(error.__traceback__))
    importing = [
        index
        for index, (frame, _) in enumerate(frames)
        if Path(frame.f_code.co_filename).parent == package and frame.f_code.co_name == "<module>"
    ]
    if not importing:
        return ""
    after = [
        (frame, line)
        for frame, line in frames[importing[-1] + 1 :]
        if frame.f_code.co_name == "<module>" and not frame.f_code.co_filename.startswith("<")
    ]
    if not after:  # the import statement itself failed: the module is not there
        return (
            f"{Path(frames[importing[-1]][0].f_code.co_filename).name}:{frames[importing[-1]][1]}"
        )
    frame, line = after[-1]
    return f"{display_path(Path(frame.f_code.co_filename))}:{line}"


def run_error(
    error: BaseException,
    system: IRSystem | None,
    cycle: int,
    package: Path | None = None,
    fallback: Span | None = None,
) -> Diagnostic:
    """One diagnostic for an exception raised while cycle `cycle` ran (0: at start-up)."""
    where = fallback or Span("<run>")
    when = f"cycle {cycle}" if cycle else "start-up"
    if isinstance(error, DeviceStartError):
        return Diagnostic(
            error.plc.span,
            "E428",
            str(error),
            "install what the soft PLC needs (`pip install 'rcsgen[modbus]'`, `[opcua]`); its "
            "own error is the line quoted",
        )
    if isinstance(error, HookError):  # one class in rcsgen and every package (contract.shared)
        module, hook, rule = error.module, error.hook, error.rule
        controller = _controller(system, module)
        span = _call_span(controller, rule, hook) or _spec_span(controller, where)
        problem = error.problem()
        called = "made by `hooks_state`" if rule == "hooks_state" else f"rule {rule}"
        if isinstance(error.__cause__, HookOverrun):
            return Diagnostic(
                span,
                "E423",
                f"{problem} ({called}, {when})",
                "make the hook return sooner, or declare a longer `deadline:` for it "
                "(docs/spec.md section 6)",
            )
        if error.raised:
            return Diagnostic(
                span,
                "E420",
                f"{problem} ({called}, {when})",
                "the hook's own traceback: run again with -v",
            )
        why = str(getattr(error, "why", ""))
        hint = "make the function return what `returns:` names, in that order and of those types"
        if why.startswith("was not called"):
            hint = "replan only while `<plan>.replans_left > 0` (W309), and fail otherwise"
        elif why:
            hint = "a planner returns a list of steps, each a tuple of the plan's step fields"
        return Diagnostic(span, "E421", f"{problem} ({called}, {when})", hint)
    failed_in = _generated_module(error, package)
    controller = _controller(system, failed_in) if failed_in else None
    text = f"{type(error).__name__}: {error}" if str(error) else type(error).__name__
    failed_import = _hooks_import(error, controller, package)
    if controller is not None and controller.hooks_module and failed_import:
        return Diagnostic(
            controller.hooks_module_span or _spec_span(controller, where),
            "E422",
            f"hooks module `{controller.hooks_module}` of `{controller.name}` failed to import "
            f"({failed_import}, {when}): {text}",
            "the module runs when the package starts: install what it imports, or fix the "
            "line named; run again with -v for the Python traceback",
        )
    subject = f"module `{failed_in}`" if failed_in else "the run"
    return Diagnostic(
        _spec_span(controller, where),
        "E422",
        f"{subject} failed in {when}: {text}",
        "run again with -v for the Python traceback",
    )


def details(error: BaseException) -> str:
    """The traceback `-v` shows: for a hook, the hook's own (where it raised)."""
    cause = error.__cause__ if isinstance(error, HookError) else error
    if cause is None:
        return ""
    return "".join(traceback.format_exception(type(cause), cause, cause.__traceback__))


# ---------------------------------------------------------------- after the run


def unmet_expectations(
    scenario: Scenario, result: RunResult, world: dict[str, Any]
) -> list[Diagnostic]:
    """E416 for each expectation of the scenario the run did not meet, at its line; `world`
    holds the world fields at the end of the run."""
    found = [
        Diagnostic(
            span,
            "E427",
            message,
            "a lost device must drive the safe state within its timeout + 1 cycle "
            "(docs/io.md, Faults)",
        )
        for span, message in result.device_failures
    ]
    for expected in scenario.expect:
        if expected.what == "status":
            final = result.final
            actual: Any = final.get("status")
            if expected.met(actual):
                continue
            stop = scenario.stop_when_done
            if actual == "EXECUTING":
                got = f"it was still executing after {counted(result.cycles, 'cycle')} (max_cycles)"
            else:
                got = f"it finished {actual} (state {final.get('state')}) in cycle {result.cycles}"
            message = f"expected `{stop}` to finish {expected.wanted()}; {got}"
        elif expected.what == "cycles":
            if expected.met(result.cycles):
                continue
            one = expected.value == 1 or (expected.low, expected.high) in ((1, None), (None, 1))
            message = (
                f"expected the run to take {expected.wanted()} {'cycle' if one else 'cycles'}; "
                f"it took {result.cycles}"
            )
        else:
            actual = final_value(expected.what, world, result.statuses)
            if expected.met(actual):
                continue
            if isinstance(actual, bool):
                shown = str(actual).lower()
            elif isinstance(actual, str):  # an enum's value name, a string's text
                shown = actual if actual.isidentifier() else repr(actual)
            else:
                shown = f"{actual:g}"
            message = f"expected `{expected.what}` {expected.wanted()} at the end; it was {shown}"
        found.append(
            Diagnostic(
                expected.span,
                "E416",
                message,
                "if the scenario is meant to end this way, change its `expect:`",
            )
        )
    return found


def golden_differences(golden: Path, trace: list[str], name: str) -> list[Diagnostic]:
    """E417 at the golden file's line of the first differing cycle (E419: unreadable)."""
    shown = display_path(golden)
    try:
        expected = read_trace(golden)
    except SpecError as error:
        return [
            Diagnostic(d.span, "E419", f"cannot read golden trace: {d.message}", d.hint)
            for d in error.diagnostics
        ]
    try:
        mismatch = first_difference(expected, trace)
    except (ValueError, TypeError) as exc:  # not JSON lines
        return [Diagnostic(Span(shown), "E419", f"golden trace is not a trace: {exc}")]
    if mismatch is None:
        return []
    line = next(
        (
            number
            for number, text in enumerate(expected, start=1)
            if f'"cycle":{mismatch.cycle},' in text
        ),
        min(len(expected), len(trace)) + 1,
    )
    return [
        Diagnostic(
            Span(shown, line),
            "E417",
            f"the run differs from the golden trace: {mismatch}",
            f"review the difference; to accept it: rcsgen run <scenario> --record {shown}",
        )
    ]


def stale_package(
    plan: Plan, generated: Path, system: str, instead: str = "drop --generated to build in memory"
) -> Diagnostic | None:
    """E418 naming the files of `generated/<system>` that differ from what the specs make."""
    root = generated / system
    changed = sorted(
        p.relative_to(root).as_posix()
        for p in [*plan.write, *plan.delete]
        if p.is_relative_to(root)
    )
    if not changed:
        return None
    shown = ", ".join(changed[:6]) + (f" and {len(changed) - 6} more" if len(changed) > 6 else "")
    return Diagnostic(
        Span(display_path(root)),
        "E418",
        f"`{display_path(root)}` is stale: {shown} "
        f"{'differs' if len(changed) == 1 else 'differ'} from what the specs make",
        f"run `rcsgen build -o {display_path(generated)}`, or {instead}",
    )
