"""Hook checks: a controller's hooks, hook-state factory and planners against its hooks module.

The module is read with `ast` (hooks.py says what a function's definition promises), never
imported: each declared hook must exist as a plain function (E213, E240), take the arguments
the spec passes (E214) and return what its `returns:` names (E241); the factory takes the
run's settings; each planner takes its plan's arguments (E294). The parameters' annotated
types are kept (`HookContracts`) for the checker to compare with the arguments' types where
each hook is called (E242, E293).
"""

from __future__ import annotations

import ast
import os
from dataclasses import dataclass
from pathlib import Path

from ..diagnostics import Diagnostics, SpecError, counted
from ..front_end import loader, model
from ..front_end.model import ControllerSpec, Located
from ..types import Annotation, Type, annotation_fits, hook_words
from . import hooks
from .naming import is_keyword


def _hook_module_file(directory: Path, module: str) -> Path | None:
    base = directory.joinpath(*module.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if os.path.lexists(candidate):  # whatever it is: reading it says what is wrong
            return candidate
    return None


# hook -> (its parameters' annotated types, file:line)
HookContracts = dict[str, tuple[list[Annotation | None], str]]


def check_hooks_module(
    spec: ControllerSpec, directory: Path, world: dict[str, Type], diags: Diagnostics
) -> HookContracts:
    """Each declared hook exists in the user's module as a plain function that fits its
    declaration (read, never imported): arity (E214), kind (E240), results (E241). Returns
    each hook's parameter annotations, for the checker to compare with its argument types."""
    contracts: HookContracts = {}
    if not spec.hooks and spec.hooks_state is None and not spec.plans:
        return contracts
    if spec.hooks_module is None:
        _no_hooks_module(spec, diags)
        return contracts
    read = _read_module(spec.hooks_module, directory, diags)
    if read is None:
        return contracts
    path, tree = read
    module = _Module(
        spec.hooks_module.value,
        path.name,
        {
            node.name: node
            for node in tree.body
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        },
        spec.hooks_state is not None,
    )
    if spec.hooks_state is not None:
        _check_factory(spec.hooks_state, module, diags)
    for hook in spec.hooks.values():
        if is_keyword(hook.name):
            continue  # E228 (naming.py): no function is named so; one error, not E213 too
        node = _check_hook(hook, spec, world, module, diags)
        if node is not None:
            params = hooks.param_types(node)[module.stateful :]
            contracts[hook.name] = (params, f"{module.file}:{node.lineno}")
    for plan in spec.plans.values():
        node = module.functions.get(plan.planner.value)
        if _check_planner(plan, node, module.stateful, module.name, module.file, diags) and node:
            contracts[f"plan:{plan.name}"] = (
                hooks.param_types(node)[module.stateful :],
                f"{module.file}:{node.lineno}",
            )
    return contracts


@dataclass(frozen=True)
class _Module:
    """A hooks module as read: its dotted name, its file's name, its functions, and
    whether its hooks receive the hook state first."""

    name: str
    file: str
    functions: dict[str, hooks.Function]
    stateful: bool


def _no_hooks_module(spec: ControllerSpec, diags: Diagnostics) -> None:
    """E215 at the first hook, the hook-state factory or the first planner."""
    if spec.hooks:
        first, what = next(iter(spec.hooks.values())).span, "hooks"
    elif spec.hooks_state is not None:
        first, what = spec.hooks_state.span, "a hook-state factory"
    else:
        first, what = next(iter(spec.plans.values())).planner.span, "a planner"
    diags.error(
        first,
        "E215",
        f"`{spec.name}` declares {what} but no `hooks_module`",
        "add `hooks_module: <package>.<module>`, a Python module in the system directory",
    )


def _read_module(
    declared: Located, directory: Path, diags: Diagnostics
) -> tuple[Path, ast.Module] | None:
    """The hooks module's file and syntax tree (parsed and compiled, never run), or None
    after E212 (not found, unreadable, not Python)."""
    module = str(declared.value)
    path = _hook_module_file(directory, module)
    if path is None:
        diags.error(
            declared.span,
            "E212",
            f"hooks module `{module}` not found",
            f"create {Path(*module.split('.')).with_suffix('.py')} next to system.yaml",
        )
        return None
    try:
        source = loader.read_bytes(path, str(path), loader.MAX_BYTES)
        tree = ast.parse(loader.decode(source, str(path)), filename=str(path))
        compile(tree, str(path), "exec", dont_inherit=True)  # what only compiling finds
    except SpecError as error:
        reason = next(iter(error.diagnostics)).message
        diags.error(
            declared.span,
            "E212",
            f"hooks module `{module}` cannot be read ({path.name}): {reason}",
        )
        return None
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        diags.error(
            declared.span,
            "E212",
            f"hooks module `{module}` cannot be read: {str(exc) or type(exc).__name__}",
        )
        return None
    return path, tree


def _check_factory(factory: Located, module: _Module, diags: Diagnostics) -> None:
    """The hook-state factory is a plain function of one argument, the run's settings."""
    name = factory.value
    node = module.functions.get(name)
    if node is None:
        diags.error(
            factory.span,
            "E213",
            f"hook-state factory `{name}` is not defined in `{module.name}`",
            f"add `def {name}(settings): ...` to {module.file}",
        )
    elif hooks.kind_problem(node):
        diags.error(
            factory.span,
            "E240",
            f"hook-state factory `{name}` is {hooks.kind_problem(node)}",
            f"make it a plain `def {name}(settings):` ({module.file}:{node.lineno})",
        )
    elif not _takes(node, 1):
        diags.error(
            factory.span,
            "E214",
            f"hook-state factory `{name}` is called with one argument (the run's "
            f"settings) but `{module.name}.{name}` takes {_positional(node)}",
            f"define it as `def {name}(settings):` ({module.file}:{node.lineno})",
        )


def _check_hook(
    hook: model.Hook,
    spec: ControllerSpec,
    world: dict[str, Type],
    module: _Module,
    diags: Diagnostics,
) -> hooks.Function | None:
    """One hook: defined (E213), plain (E240), callable with its arguments (E214), its
    results as `returns:` says (E241). Its function, unless one of the first three fails."""
    node = module.functions.get(hook.name)
    where = module.file
    if node is None:
        args = ", ".join(f"a{i}" for i in range(len(hook.args)))
        diags.error(
            hook.span,
            "E213",
            f"hook `{hook.name}` is not defined in `{module.name}`",
            f"add `def {hook.name}({args}): ...` to {where}",
        )
        return None
    if hooks.kind_problem(node):
        diags.error(
            hook.span,
            "E240",
            f"hook `{hook.name}` is {hooks.kind_problem(node)}",
            f"make it a plain `def {hook.name}(...)` ({where}:{node.lineno})",
        )
        return None
    given = len(hook.args) + module.stateful  # the hook state comes first
    if not _takes(node, given):
        diags.error(
            hook.span,
            "E214",
            f"hook `{hook.name}` is called with {counted(given, 'argument')}"
            f"{' (the hook state, then its args)' if module.stateful else ''} but "
            f"`{module.name}.{hook.name}` takes {_positional(node)}",
            "make `args:` match the function's parameters",
        )
        return None
    targets = [_target_type(t.value, spec, world) for t in hook.returns]
    for problem in _return_problems(hook.name, node, targets, [t.value for t in hook.returns]):
        diags.error(hook.span, "E241", problem, f"see {where}:{node.lineno}")
    return node


def _check_planner(
    plan: model.Plan,
    node: hooks.Function | None,
    stateful: bool,
    module: str,
    where: str,
    diags: Diagnostics,
) -> bool:
    """A plan's planner is a plain function of the hooks module that takes its arguments
    (the hook state first, if any): E294. Whether it is."""
    name = plan.planner.value
    given = len(plan.args) + stateful
    if node is None:
        args = ", ".join(["state"] * stateful + [f"a{i}" for i in range(len(plan.args))])
        diags.error(
            plan.planner.span,
            "E294",
            f"planner `{name}` of plan `{plan.name}` is not defined in `{module}`",
            f"add `def {name}({args}): ...` returning a list of steps to {where}",
        )
    elif hooks.kind_problem(node):
        diags.error(
            plan.planner.span,
            "E294",
            f"planner `{name}` of plan `{plan.name}` is {hooks.kind_problem(node)}",
            f"make it a plain `def {name}(...)` ({where}:{node.lineno})",
        )
    elif not _takes(node, given):
        diags.error(
            plan.planner.span,
            "E294",
            f"planner `{name}` of plan `{plan.name}` is called with {counted(given, 'argument')}"
            f"{' (the hook state, then its args)' if stateful else ''} but "
            f"`{module}.{name}` takes {_positional(node)}",
            "make the plan's `args:` match the function's parameters",
        )
    else:
        return True
    return False


def _positional(node: hooks.Function) -> int:
    return len([*node.args.posonlyargs, *node.args.args])


def _takes(node: hooks.Function, given: int) -> bool:
    """Whether the function can be called with `given` positional arguments."""
    positional = _positional(node)
    required = positional - len(node.args.defaults)
    return required <= given and (node.args.vararg is not None or given <= positional)


def _target_type(target: str, spec: ControllerSpec, world: dict[str, Type]) -> Type | None:
    if target.startswith("world."):
        return world.get(target.removeprefix("world."))
    local = spec.locals.get(target)
    return local.type if local else None


def _ordinal(n: int) -> str:
    return {1: "1st", 2: "2nd", 3: "3rd"}.get(n, f"{n}th")


def _return_problems(
    name: str, node: hooks.Function, types: list[Type | None], targets: list[str]
) -> list[str]:
    """How the function's return annotation and literal returns contradict `returns:`."""
    want = len(targets)
    if want == 0:
        return []  # the result is ignored
    named = "one target" if want == 1 else f"{want} targets"
    promised = hooks.returns(node)
    found = [] if promised is None else _annotation_problems(name, promised, types, targets)
    counts = hooks.literal_return_counts(node)
    if not counts:
        found.append(f"hook `{name}` never returns a value, but `returns:` names {named}")
    for line, count in counts:
        if count == 0:
            found.append(f"hook `{name}` returns nothing at line {line}; `returns:` names {named}")
        elif count is not None and want > 1 and count != want:
            found.append(
                f"hook `{name}` returns {counted(count, 'value')} at line {line}; `returns:` "
                f"names {named}"
            )
        elif count is not None and want == 1 and count > 1:
            found.append(
                f"hook `{name}` returns a tuple of {count} at line {line}; `returns:` names one "
                "target"
            )
    return found


def _annotation_problems(
    name: str, promised: hooks.Returns, types: list[Type | None], targets: list[str]
) -> list[str]:
    """How a hook's return annotation contradicts `returns:`: the number of values, or the
    type of one (the first contradiction of the number only)."""
    want = len(targets)
    named = "one target" if want == 1 else f"{want} targets"
    if promised.count == 0:
        return [f"hook `{name}` is annotated `-> None`, but `returns:` names {named}"]
    if want == 1 and not promised.scalar:
        return [
            f"hook `{name}` is annotated to return a tuple, but `returns:` names one "
            f"target, `{targets[0]}`, which would be assigned the whole tuple"
        ]
    if want > 1 and promised.scalar:
        return [f"hook `{name}` is annotated to return one value, but `returns:` names {named}"]
    if promised.count is not None and want > 1 and promised.count != want:
        return [
            f"hook `{name}` is annotated to return {promised.count} values, but "
            f"`returns:` names {named}"
        ]
    every = promised.types * want if promised.count is None else promised.types
    return [
        f"hook `{name}` returns {_a(value)} as its {_ordinal(index)} value "
        f"(by its annotation), but `{targets[index - 1]}` is {_a(target)}"
        for index, (value, target) in enumerate(zip(every, types, strict=False), start=1)
        if value is not None and target is not None and not annotation_fits(target, value)
    ]


def _a(kind: Type | Annotation) -> str:
    return hook_words(kind)
