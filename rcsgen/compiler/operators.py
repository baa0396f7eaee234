"""Operators: the system's `operators:` model -> its checks (E245-E249) and access table.

The second paper's access matrix (Figure 29): each operator role may monitor every module
and is granted, module by module, the right to respond to the module's requests, to
command it, or to override it; each level includes the ones before it (the levels are the
runtime contract's `ACCESS_LEVELS`). Requests (Figure 30; the mining paper's conveyor tail)
are open while a bool world field is true and are answered by sending a command.
"""

from __future__ import annotations

from ..runtime.contract import ACCESS_LEVELS, BUILTIN_COMMANDS
from .diagnostics import Diagnostics, known_names_hint
from .model import ControllerSpec, Operators, Request


def access(operators: Operators, modules: list[str]) -> dict[str, dict[str, int]]:
    """Each role -> module -> its level's index in ACCESS_LEVELS, for the modules above
    monitor (a module a role does not list is monitored only)."""
    table: dict[str, dict[str, int]] = {}
    for role in operators.roles.values():
        granted: dict[str, int] = {}
        for level, listed in role.grants.items():
            names = modules if [m.value for m in listed] == ["all"] else [m.value for m in listed]
            for module in names:
                granted[module] = max(granted.get(module, 0), ACCESS_LEVELS.index(level))
        table[role.name] = {m: granted[m] for m in modules if m in granted}
    return table


def check(
    operators: Operators,
    by_name: dict[str, ControllerSpec],
    supervisors: dict[str, str],
    world: dict[str, str],
    diags: Diagnostics,
) -> None:
    """Every module a role or request names exists; a role commands only modules no
    controller commands (E245-E247); requests are answerable (E248, E249)."""
    for role in operators.roles.values():
        for level, listed in role.grants.items():
            for module in listed:
                if module.value == "all":
                    continue
                if module.value not in by_name:
                    diags.error(
                        module.span,
                        "E245",
                        f"role `{role.name}` is granted `{level}` on unknown module "
                        f"`{module.value}`",
                        known_names_hint("modules", by_name, module.value),
                    )
                elif level == "command" and module.value in supervisors:
                    boss = supervisors[module.value]
                    diags.error(
                        module.span,
                        "E246",
                        f"role `{role.name}` may not `command` `{module.value}`: "
                        f"`{boss}` commands it",
                        f"an operator commands a module out of its supervisor's turn only by "
                        f"overriding it: grant `override` on `{module.value}` (and `{boss}`)",
                    )
    for request in operators.requests.values():
        if request.by.value not in by_name:
            diags.error(
                request.by.span,
                "E245",
                f"request `{request.name}` is made by unknown module `{request.by.value}`",
                known_names_hint("modules", by_name, request.by.value),
            )
        field_type = world.get(request.open_while.value)
        if field_type != "bool":
            problem = "an unknown world field" if field_type is None else f"a {field_type}"
            diags.error(
                request.open_while.span,
                "E247",
                f"request `{request.name}` is open while `{request.open_while.value}`, "
                f"{problem}; it must be a bool world field",
                known_names_hint("world fields", world, request.open_while.value)
                if field_type is None
                else "",
            )
        _check_answer(request, by_name, supervisors, diags)


def _check_answer(
    request: Request,
    by_name: dict[str, ControllerSpec],
    supervisors: dict[str, str],
    diags: Diagnostics,
) -> None:
    module, _, command = request.answer.value.partition(".")
    at = request.answer.span
    spec = by_name.get(module)
    if spec is None:
        diags.error(
            at,
            "E248",
            f"request `{request.name}` is answered by unknown module `{module}`",
            known_names_hint("modules", by_name, module),
        )
        return
    commands = spec.commands
    if command in BUILTIN_COMMANDS or command not in commands:
        diags.error(
            at,
            "E248",
            f"request `{request.name}` is answered by `{module}.{command}`, "
            f"which is not a command of `{module}`",
            known_names_hint(f"commands of `{module}`", sorted(commands), command),
        )
        return
    if commands[command].params:
        diags.error(
            at,
            "E249",
            f"request `{request.name}` is answered by `{module}.{command}`, which takes "
            f"parameters ({', '.join(commands[command].params)})",
            "an answer is one key press: use a command without parameters",
        )
    elif module in supervisors:
        diags.error(
            at,
            "E249",
            f"request `{request.name}` is answered by `{module}.{command}`, but "
            f"`{supervisors[module]}` commands `{module}`",
            "answer through a module no controller commands (an operator interface), so "
            "the answer never fights its supervisor's commands",
        )
