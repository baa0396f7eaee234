"""Operators: the system's `operators:` and operator modules -> their checks and access table.

Checks E245-E249 (roles and requests) and E281-E284, W308 (operator modules: a person at
a screen who serves several clients, docs/spec.md section 17).

The second paper's access matrix (Figure 29): each operator role may monitor every module
and is granted, module by module, the right to respond to the module's requests, to
command it, or to override it; each level includes the ones before it (the levels are the
runtime contract's `ACCESS_LEVELS`). Requests (Figure 30; the mining paper's conveyor tail)
are open while a bool world field is true and are answered by sending a command.
"""

from __future__ import annotations

from string import Formatter

from ...runtime.contract import ACCESS_LEVELS, BUILTIN_COMMANDS
from ..diagnostics import Diagnostics, known_names_hint, number_shown
from ..front_end.model import (
    Command,
    ControllerSpec,
    Located,
    Operators,
    Request,
    SystemSpec,
    Typed,
)
from ..types import BOOL, FLOAT, INT, Type


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
    world: dict[str, Type],
    diags: Diagnostics,
) -> None:
    """Every module a role or request names exists; a role commands only modules no
    controller commands and that are not operator modules (E245-E247, E296); requests
    are answerable (E248, E249)."""
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
                elif level == "command" and by_name[module.value].is_operator:
                    diags.error(
                        module.span,
                        "E296",
                        f"role `{role.name}` may not `command` operator module "
                        f"`{module.value}`: its clients send it their tasks, and a person "
                        f"answers them",
                        f"grant `respond` on `{module.value}` to answer its requests "
                        f"(`ctl answer`)",
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
    _check_holders(operators, diags)
    for request in operators.requests.values():
        if request.by.value not in by_name:
            diags.error(
                request.by.span,
                "E245",
                f"request `{request.name}` is made by unknown module `{request.by.value}`",
                known_names_hint("modules", by_name, request.by.value),
            )
        field_type = world.get(request.open_while.value)
        if field_type != BOOL:
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


def _check_holders(operators: Operators, diags: Diagnostics) -> None:
    """Once a role names who holds it, every role must (E810): a role anyone may claim
    would hand its access to every user who can open the segment. Holders other than the
    segment's creator need the segment's group to open it at all (W811)."""
    roles = list(operators.roles.values())
    held = [r for r in roles if r.members]
    if not held:
        return
    for role in roles:
        if not role.members:
            diags.error(
                role.span,
                "E810",
                f"role `{role.name}` names no `users` or `groups`, while `{held[0].name}` "
                f"does: any user who can open the segment could claim `{role.name}`",
                f"list who holds it (`users: [...]`, `groups: [...]`), as for `{held[0].name}`",
            )
    if operators.segment_group is not None:
        return
    users: list[str] = []
    for role in held:
        users += [u.value for u in role.users if u.value not in users]
        if role.groups or len(users) > 1:
            who = f"group `{role.groups[0].value}`" if role.groups else f"user `{users[-1]}`"
            at = role.groups[0].span if role.groups else role.users[-1].span
            diags.warning(
                at,
                "W811",
                f"role `{role.name}` is held by {who}, but no `segment_group` is declared: "
                f"the segment is mode 0600, its creator's alone, so no other user can open "
                f"it to act in a role",
                "declare `operators: {segment_group: GROUP}`, the OS group whose members "
                "run the consoles (docs/access.md)",
            )
            return


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
    if spec.is_operator:
        diags.error(
            at,
            "E248",
            f"request `{request.name}` is answered by `{module}.{command}`, but `{module}` is "
            "an operator module: its tasks are answered on its channels",
            f"let the asking module send `{module}.{command}` itself and drop this request; "
            f"`ctl answer {module}/<client>` answers it",
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


# ---------------------------------------------------------------- operator modules


def check_modules(
    system: SystemSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> dict[str, tuple[str, ...]]:
    """Each operator module's clients (the controllers that list it in `subordinates`, in
    execution order); its tasks' instruction texts (E281, E282), that it declares no INIT or
    HALT (E284), is no simulator or stand-in (E283) and serves someone (W308)."""
    order = [m.value for p in system.processes for m in p.modules]
    ranked = sorted(by_name, key=lambda n: (order.index(n) if n in order else len(order), n))
    clients: dict[str, tuple[str, ...]] = {}
    for name in ranked:
        spec = by_name[name]
        if not spec.is_operator:
            continue
        clients[name] = tuple(
            c for c in ranked if any(s.value == name for s in by_name[c].subordinates)
        )
        if not clients[name]:
            diags.warning(
                spec.name_span,
                "W308",
                f"operator module `{name}` serves no client: no controller lists it in "
                "`subordinates`",
                f"add `{name}` to the subordinates of the controllers that ask its tasks",
            )
        for command in spec.commands.values():
            if command.text is None:
                continue
            if command.name in BUILTIN_COMMANDS:
                diags.error(
                    command.span,
                    "E284",
                    f"operator module `{name}` declares {command.name}, which is built in",
                    "INIT and HALT withdraw a client's open request; declare only the tasks",
                )
                continue
            _check_text(name, command, command.text, diags)
            for result in command.results.values():
                _check_range(name, command, result, diags)
    for item in [*system.simulators, *system.stand_ins.values()]:
        if item.value in clients:
            diags.error(
                item.span,
                "E283",
                f"operator module `{item.value}` cannot be a simulator or a stand-in",
                "a person answers it; script the person in a scenario's `operator:` section",
            )
    for name, item in system.stand_ins.items():
        if name in clients:
            diags.error(
                item.span,
                "E283",
                f"operator module `{name}` cannot be replaced by a stand-in",
                "a person answers it; script the person in a scenario's `operator:` section",
            )
    return clients


def instruction_fields(text: str) -> list[str]:
    """The parameter names an instruction text shows (`{name}`), in order; raises
    ValueError for a malformed text (a lone brace, a format spec, an index)."""
    found = []
    for _, field, spec, conversion in Formatter().parse(text):
        if field is None:
            continue
        if not field.isidentifier() or spec or conversion:
            shown = field + (f"!{conversion}" if conversion else "") + (f":{spec}" if spec else "")
            raise ValueError(f"`{{{shown}}}` is not `{{parameter}}`")
        found.append(field)
    return found


def _check_text(module: str, command: Command, text: Located, diags: Diagnostics) -> None:
    try:
        fields = instruction_fields(str(text.value))
    except ValueError as problem:
        diags.error(
            text.span,
            "E282",
            f"the instruction text of `{module}.{command.name}` is malformed: {problem}",
            "write `{param}` to show a parameter, `{{` and `}}` for literal braces",
        )
        return
    for field in fields:
        if field not in command.params:
            diags.error(
                text.span,
                "E281",
                f"the instruction text of `{module}.{command.name}` shows `{{{field}}}`, "
                "which is not a parameter of the task",
                known_names_hint(f"parameters of {command.name}", command.params, field)
                or "declare it under `params:`, or write `{{` for a literal brace",
            )


def _check_range(module: str, command: Command, result: Typed, diags: Diagnostics) -> None:
    """A task result's `min` and `max` (E910): only on an int or a float, of its type (an
    int's range whole), the least no greater than the greatest."""
    where = f"result `{result.name}` of `{module}.{command.name}`"
    given = [item for item in (result.low, result.high) if item is not None]
    if given and result.type not in (INT, FLOAT):
        diags.error(
            given[0].span,
            "E910",
            f"{where} has the type {result.type}: only an int or a float has a range",
            "leave `min`/`max` out: an answer is checked against its type and values",
        )
        return
    for item in given:
        if result.type == INT and isinstance(item.value, float) and not item.value.is_integer():
            diags.error(
                item.span,
                "E910",
                f"{where} is an int, but its bound {number_shown(item.value)} is not a whole "
                "number",
                "give an int result whole bounds",
            )
            return
    low, high = result.low, result.high
    if low is not None and high is not None and low.value > high.value:  # (an int exactly)
        diags.error(
            low.span,
            "E910",
            f"{where} has `min` {number_shown(low.value)} above its `max` "
            f"{number_shown(high.value)}: no answer fits",
            "swap them",
        )
