"""Check: the input model -> semantic diagnostics and, when clean, the emit-ready IR.

Resolves every name (subordinates, commands, states, world fields, params, locals,
predicates, hooks), checks the hierarchy (one supervisor each, no cycles, every module
in exactly one process) and each state table (S0 present, targets defined, every state
reachable), and types every expression. All problems are collected before failing.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

from ..runtime import contract
from . import expr as X
from . import ir, naming
from .diagnostics import Diagnostics, Span, known_names_hint
from .model import (
    At,
    CallHook,
    Command,
    ControllerSpec,
    Report,
    Rule,
    Send,
    SetWorld,
    State,
    SystemSpec,
)

ENTRY_STATE = "S0"


def check_system(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> ir.IRSystem | None:
    """Check a system and its controllers; the IR, or None when there were errors."""
    naming.check_spec(system, controllers, diags)  # identifier and text policy (E228, E6xx)
    by_name = _index_controllers(controllers, diags)
    stand_ins = {k: a.value for k, a in system.stand_ins.items()}
    _check_processes(system, by_name, set(stand_ins.values()), diags)
    supervisors = _check_hierarchy(by_name, diags)
    simulators = _check_simulators(system, by_name, diags)
    _check_stand_ins(system, by_name, diags)
    world = {name: f.type for name, f in system.world.items()}
    for spec in by_name.values():
        _check_world_access(spec, world, diags)
        _check_names(spec, by_name, diags)
        _check_hooks_module(spec, system.directory, diags)
    before = len(diags.errors)
    if before:  # names must resolve before tables can be checked meaningfully
        return None
    world_fields = [
        ir.IRWorldField(f.name, f.type, f.initial, f.doc) for f in system.world.values()
    ]
    order = [m for p in system.processes for m in (a.value for a in p.modules)]
    replaced_by = {stand_in: name for name, stand_in in stand_ins.items()}
    lowered = []
    for name in [*order, *sorted(replaced_by)]:
        buffers = replaced_by.get(name, name)  # a stand-in runs in its controller's buffers
        lowering = _Lowering(
            by_name[name],
            by_name,
            system,
            supervisors.get(buffers),
            name in simulators or name in replaced_by,
            diags,
        )
        lowered.append(lowering.lower(buffers))
    if len(diags.errors) > before:
        return None
    processes = []
    for p in system.processes:
        modules = [a.value for a in p.modules]
        replaces = {
            name: (stand_in, [m for m in modules if m in _subtree(name, by_name)])
            for name, stand_in in sorted(stand_ins.items())
            if name in modules
        }
        roots = [m for m in modules if m not in supervisors]
        processes.append(ir.IRProcess(p.name, p.doc, modules, roots, replaces))
    return ir.IRSystem(
        name=system.name,
        title=system.title,
        doc=system.doc,
        source=system.display,
        cycle_period=system.cycle_period,
        world=world_fields,
        controllers=lowered,
        processes=processes,
        layout=ir.plan_layout(lowered, world_fields),
        hook_modules=sorted({c.hooks_module for c in lowered if c.hooks_module}),
        sources=sorted([system.display, *(c.display for c in controllers)]),
    )


# ---------------------------------------------------------------- system-wide checks


def _index_controllers(
    controllers: list[ControllerSpec], diags: Diagnostics
) -> dict[str, ControllerSpec]:
    by_name: dict[str, ControllerSpec] = {}
    for spec in controllers:
        stem = Path(spec.display).stem
        if stem != spec.name:
            diags.error(
                spec.name_span,
                "E222",
                f"controller `{spec.name}` is declared in `{Path(spec.display).name}`",
                f"name the file `{spec.name}.yaml` so each controller is found by its mnemonic",
            )
        if spec.name in by_name:
            diags.error(
                spec.name_span,
                "E221",
                f"controller `{spec.name}` is declared twice",
                f"first declared in {by_name[spec.name].display}",
            )
            continue
        by_name[spec.name] = spec
    return by_name


def _check_processes(
    system: SystemSpec, by_name: dict[str, ControllerSpec], stand_ins: set[str], diags: Diagnostics
) -> dict[str, str]:
    placement: dict[str, str] = {}
    for process in system.processes:
        for module in process.modules:
            if module.value in stand_ins:
                diags.error(
                    module.span,
                    "E233",
                    f"stand-in `{module.value}` cannot be listed in a process",
                    "a stand-in runs in its controller's place when a run simulates it",
                )
            elif module.value not in by_name:
                diags.error(
                    module.span,
                    "E211",
                    f"process `{process.name}` runs `{module.value}`, which has no controller spec",
                    known_names_hint("controllers", by_name, module.value),
                )
            elif module.value in placement:
                diags.error(
                    module.span,
                    "E210",
                    f"module `{module.value}` is mapped to more than one process "
                    f"(`{placement[module.value]}` and `{process.name}`)",
                    "each module runs in exactly one process",
                )
            else:
                placement[module.value] = process.name
    for name, spec in sorted(by_name.items()):
        if name not in placement and name not in stand_ins:
            diags.error(
                spec.name_span,
                "E209",
                f"module `{name}` is not mapped to any process",
                f"add `{name}` to a process's `modules:` in {system.display}",
            )
    return placement


def _check_hierarchy(by_name: dict[str, ControllerSpec], diags: Diagnostics) -> dict[str, str]:
    """Each controller's supervisor; reports unknown subordinates, two supervisors, cycles."""
    supervisor: dict[str, str] = {}
    for name, spec in by_name.items():
        for sub in spec.subordinates:
            if sub.value not in by_name:
                diags.error(
                    sub.span,
                    "E201",
                    f"unknown subordinate `{sub.value}` of `{name}`",
                    known_names_hint("controllers", by_name, sub.value),
                )
            elif sub.value in supervisor:
                diags.error(
                    sub.span,
                    "E202",
                    f"`{sub.value}` has two supervisors: `{supervisor[sub.value]}` and `{name}`",
                    "in RCS each controller has exactly one supervisor",
                )
            else:
                supervisor[sub.value] = name
    for name in sorted(by_name):  # walk up from each module; meeting itself is a cycle
        seen, at = [name], supervisor.get(name)
        while at is not None and at not in seen:
            seen.append(at)
            at = supervisor.get(at)
        if at == name:
            chain = " -> ".join(reversed([*seen, name]))
            spec = by_name[name]
            span = next(s.span for s in by_name[supervisor[name]].subordinates if s.value == name)
            diags.error(
                span, "E203", f"cycle in the hierarchy: {chain}", f"{spec.name} commands itself"
            )
    return supervisor


def _check_simulators(
    system: SystemSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> set[str]:
    for sim in system.simulators:
        if sim.value not in by_name:
            diags.error(
                sim.span,
                "E223",
                f"simulator `{sim.value}` has no module spec",
                known_names_hint("controllers", by_name, sim.value),
            )
    return {s.value for s in system.simulators}


def _subtree(name: str, by_name: dict[str, ControllerSpec]) -> set[str]:
    """A controller and everything below it in the hierarchy."""
    found, todo = set(), [name]
    while todo:
        at = todo.pop()
        if at in found or at not in by_name:
            continue
        found.add(at)
        todo.extend(s.value for s in by_name[at].subordinates)
    return found


def _command_signature(spec: ControllerSpec) -> dict[str, dict[str, str]]:
    return {n: {p: t.type for p, t in c.params.items()} for n, c in spec.commands.items()}


def _check_stand_ins(
    system: SystemSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> None:
    """A stand-in replaces a controller and its subtree: same commands, no subordinates."""
    for name, stand_in in system.stand_ins.items():
        if name not in by_name:
            diags.error(
                stand_in.span,
                "E234",
                f"`{name}` has a stand-in but no controller spec",
                known_names_hint("controllers", by_name, name),
            )
            continue
        sim = by_name.get(stand_in.value)
        if sim is None:
            diags.error(
                stand_in.span,
                "E234",
                f"stand-in `{stand_in.value}` has no controller spec",
                known_names_hint("controllers", by_name, stand_in.value),
            )
            continue
        if sim.subordinates:
            diags.error(
                sim.subordinates[0].span,
                "E235",
                f"stand-in `{sim.name}` has subordinates",
                f"it replaces `{name}` and everything below it, so it commands nobody",
            )
        wanted, got = _command_signature(by_name[name]), _command_signature(sim)
        for command in sorted(set(wanted) ^ set(got)):
            diags.error(
                sim.name_span,
                "E236",
                f"stand-in `{sim.name}` and `{name}` differ in command {command}",
                "a stand-in accepts exactly its controller's commands and parameters",
            )
        for command in sorted(set(wanted) & set(got)):
            if wanted[command] != got[command]:
                diags.error(
                    sim.commands[command].span,
                    "E236",
                    f"{command} of stand-in `{sim.name}` has other parameters than `{name}`'s",
                    f"`{name}` takes {wanted[command] or 'no parameters'}",
                )


def _check_world_access(spec: ControllerSpec, world: dict[str, str], diags: Diagnostics) -> None:
    for item in [*spec.world_reads, *spec.world_writes]:
        if item.value not in world:
            diags.error(
                item.span,
                "E104",
                f"undeclared world field `{item.value}`",
                known_names_hint("world fields", world, item.value),
            )


def _check_names(
    spec: ControllerSpec, by_name: dict[str, ControllerSpec], diags: Diagnostics
) -> None:
    """Names that would collide in the generated module or class."""
    if naming.is_keyword(spec.name) or spec.name in naming.FIXED_MODULES:
        diags.error(spec.name_span, "E228", f"`{spec.name}` cannot name a controller module")
    methods = {naming.command_method(c): c for c in spec.commands}
    methods.update({m: m for m in ("init", "halt")})
    for command in spec.commands.values():
        if naming.command_method(command.name) in naming.FIXED_METHODS:
            diags.error(
                command.span, "E228", f"command `{command.name}` collides with a QQ1 method"
            )
    taken_attrs = {s.value for s in spec.subordinates}
    for kind, names in (("predicate", spec.predicates), ("hook", spec.hooks)):
        for name, item in names.items():
            span = item.span
            clash = (
                naming.is_keyword(name)
                or name in naming.FIXED_METHODS
                or name in methods
                or name.startswith(naming.ATTRIBUTE_PREFIXES)
                or any(name.startswith(f"{sub}_") for sub in taken_attrs)
            )
            if clash and kind == "predicate":
                diags.error(span, "E228", f"predicate name `{name}` collides with a generated name")
            elif naming.is_keyword(name):
                diags.error(span, "E228", f"hook name `{name}` is a Python keyword")
    for name in spec.locals:
        for command in spec.commands.values():
            if name in command.params:
                diags.error(
                    command.params[name].span,
                    "E228",
                    f"parameter `{name}` of {command.name} has the name of a local",
                    "rename one of them",
                )
    param_types: dict[str, tuple[str, str]] = {}
    for command in spec.commands.values():
        for param in command.params.values():
            if param.name in param_types and param_types[param.name][0] != param.type:
                first_type, first_command = param_types[param.name]
                diags.error(
                    param.span,
                    "E230",
                    f"parameter `{param.name}` is {param.type} here but {first_type} in "
                    f"{first_command}",
                    "commands of one controller share a parameter slot per name: use one type",
                )
            param_types.setdefault(param.name, (param.type, command.name))


def _hook_module_file(directory: Path, module: str) -> Path | None:
    base = directory.joinpath(*module.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _check_hooks_module(spec: ControllerSpec, directory: Path, diags: Diagnostics) -> None:
    """Each declared hook exists in the user's module with a fitting signature (by reading it)."""
    if not spec.hooks and spec.hooks_state is None:
        return
    if spec.hooks_module is None:
        first = next(iter(spec.hooks.values()), spec.hooks_state)
        diags.error(
            first.span,
            "E215",
            f"`{spec.name}` declares hooks but no `hooks_module`",
            "add `hooks_module: <package>.<module>`, a Python module in the system directory",
        )
        return
    module = spec.hooks_module.value
    path = _hook_module_file(directory, module)
    if path is None:
        diags.error(
            spec.hooks_module.span,
            "E212",
            f"hooks module `{module}` not found",
            f"create {Path(*module.split('.')).with_suffix('.py')} next to system.yaml",
        )
        return
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    except (
        SyntaxError,
        ValueError,
        UnicodeDecodeError,
        OSError,
        RecursionError,
        MemoryError,
    ) as exc:
        diags.error(
            spec.hooks_module.span,
            "E212",
            f"hooks module `{module}` cannot be read: {str(exc) or type(exc).__name__}",
        )
        return
    functions = {
        node.name: node
        for node in tree.body
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
    }
    stateful = spec.hooks_state is not None
    if stateful:
        factory = functions.get(spec.hooks_state.value)
        if factory is None:
            diags.error(
                spec.hooks_state.span,
                "E213",
                f"hook-state factory `{spec.hooks_state.value}` is not defined in `{module}`",
                f"add `def {spec.hooks_state.value}(settings): ...` to {path.name}",
            )
    for hook in spec.hooks.values():
        node = functions.get(hook.name)
        if node is None:
            args = ", ".join(f"a{i}" for i in range(len(hook.args)))
            diags.error(
                hook.span,
                "E213",
                f"hook `{hook.name}` is not defined in `{module}`",
                f"add `def {hook.name}({args}): ...` to {path.name}",
            )
            continue
        positional = [*node.args.posonlyargs, *node.args.args]
        required = len(positional) - len(node.args.defaults)
        given = len(hook.args) + stateful  # the hook state comes first
        fits = required <= given and (node.args.vararg is not None or given <= len(positional))
        if not fits:
            diags.error(
                hook.span,
                "E214",
                f"hook `{hook.name}` is called with {given} argument(s)"
                f"{' (the hook state, then its args)' if stateful else ''} but "
                f"`{module}.{hook.name}` takes {len(positional)}",
                "make `args:` match the function's parameters",
            )


# ---------------------------------------------------------------- per-controller lowering


def default_table(command: str, subordinates: list[str], span: Span) -> Command:
    """QQ1's INIT/HALT table: pass the command to every subordinate, wait for all DONE."""
    if not subordinates:
        states = {
            ENTRY_STATE: State(
                ENTRY_STATE, [Rule("", None, [Report("DONE", span)], None, span)], span
            )
        }
    else:
        sends = [Send(sub, command, {}, span) for sub in subordinates]
        wait = " and ".join(f"{sub}.status == DONE" for sub in subordinates)
        states = {
            ENTRY_STATE: State(
                ENTRY_STATE,
                [Rule(f"send {command} to every subordinate", None, sends, At("S1", span), span)],
                span,
            ),
            "S1": State(
                "S1",
                [
                    Rule(
                        "every subordinate is done",
                        At(wait, span),
                        [Report("DONE", span)],
                        None,
                        span,
                    )
                ],
                span,
            ),
        }
    doc = {"INIT": "Initialise this controller and its subordinates.", "HALT": "Halt all actions."}
    return Command(command, doc[command], {}, states, span, generated=True)


class _Lowering:
    """Checks one controller's tables and expressions and builds its IR."""

    def __init__(
        self,
        spec: ControllerSpec,
        by_name: dict[str, ControllerSpec],
        system: SystemSpec,
        supervisor: str | None,
        simulator: bool,
        diags: Diagnostics,
    ):
        self.spec, self.by_name, self.system, self.diags = spec, by_name, system, diags
        self.supervisor, self.simulator = supervisor, simulator
        self.subs = [s.value for s in spec.subordinates]
        self.commands = self._with_defaults(spec)
        self.writable = {w.value for w in spec.world_writes}
        sub_commands = {sub: frozenset(self._with_defaults(by_name[sub])) for sub in self.subs}
        self.base_scope = X.Scope(
            world=system.world_types,
            world_access=frozenset(a.value for a in [*spec.world_reads, *spec.world_writes]),
            locals={n: v.type for n, v in spec.locals.items()},
            constants={n: c.value for n, c in spec.constants.items()},
            predicates=frozenset(spec.predicates),
            subordinates=sub_commands,
        )

    def _with_defaults(self, spec: ControllerSpec) -> dict[str, Command]:
        subs = [s.value for s in spec.subordinates]
        commands = {
            name: spec.commands.get(name) or default_table(name, subs, spec.span)
            for name in contract.BUILTIN_COMMANDS
        }
        commands.update((n, c) for n, c in spec.commands.items() if n not in commands)
        return commands

    def scope_for(self, command: Command | None) -> X.Scope:
        params = {p.name: p.type for p in command.params.values()} if command else {}
        scope = X.Scope(**{**self.base_scope.__dict__, "params": params, "used_predicates": set()})
        return scope

    def compile(self, item: At, scope: X.Scope, expect: str | None) -> str:
        tree = X.compile_expr(item.value, item.span, scope, self.diags, expect)
        return X.to_python(tree, naming.attribute) if tree is not None else "..."

    # ------------------------------------------------------------ tables

    def lower(self, buffers: str) -> ir.IRController:
        spec = self.spec
        state_names: list[str] = [ENTRY_STATE]
        commands = []
        for code, command in enumerate(self.commands.values(), start=1):
            for state in command.states:
                if state not in state_names:
                    state_names.append(state)
            commands.append(self.lower_command(command, code))
        predicates = self.lower_predicates()
        self.check_module_names()
        hooks_module = spec.hooks_module.value if spec.hooks_module else None
        world = {f.name: f for f in self.system.world.values()}
        reads = _unique(a.value for a in [*spec.world_reads, *spec.world_writes])
        return ir.IRController(
            name=spec.name,
            title=spec.title,
            doc=spec.doc,
            source=spec.display,
            supervisor=self.supervisor,
            simulator=self.simulator,
            subordinates=[self.lower_sub(sub) for sub in self.subs],
            commands=commands,
            params=_params(self.commands.values()),
            locals=[ir.IRLocal(v.name, v.type, v.initial, v.doc) for v in spec.locals.values()],
            constants=[(n, repr(c.value)) for n, c in spec.constants.items()],
            predicates=predicates,
            hooks_module=hooks_module,
            hooks=sorted(spec.hooks),
            world_reads=[_world_ir(world[n]) for n in reads],
            world_writes=[_world_ir(world[a.value]) for a in spec.world_writes],
            states=state_names,
            every_cycle=self.lower_every_cycle(),
            hooks_state=spec.hooks_state.value if spec.hooks_state else None,
            buffers=buffers,
        )

    def lower_every_cycle(self) -> list[ir.IRRule]:
        scope = self.scope_for(None)
        rules = []
        for index, rule in enumerate(self.spec.every_cycle):
            if rule.next is not None:
                self.diags.error(
                    rule.next.span,
                    "E232",
                    "an every_cycle rule cannot change state",
                    "every_cycle rules run whatever the command; move `next` into a table",
                )
            if index and self.spec.every_cycle[index - 1].when is None:
                self.diags.warning(rule.span, "W301", "this every_cycle rule never fires")
            rules.append(self.lower_rule_body(rule, scope))
        return _live(rules)

    def check_module_names(self) -> None:
        """Every module-level name of the generated controller module must be unique."""
        spec = self.spec
        taken: dict[str, str] = {n: "a status or runtime name" for n in naming.RUNTIME_NAMES}
        for sub in self.subs:
            up = sub.upper()
            for suffix in ("_COMMAND", "_COMMAND_AT", "_STATUS_AT", "_MODE_AT", "_PERF_AT"):
                taken[up + suffix] = "a layout name"
            for command in self._with_defaults(self.by_name[sub]):
                taken[naming.sub_command_const(sub, command)] = f"the code of {sub}'s {command}"
        up = spec.name.upper()
        for suffix in ("_COMMAND", "_COMMAND_AT", "_STATUS_AT", "_MODE_AT", "_PERF_AT"):
            taken[up + suffix] = "a layout name"
        taken.update(_world_layout_names(tuple(self.system.world)))
        for index in range(1, len(spec.world_writes) + 1):
            taken[f"WORLD_OUT_{index}"] = taken[f"WORLD_OUT_{index}_AT"] = "a generated name"
        named: list[tuple[str, str, Span]] = [
            (c.name, "command", c.span) for c in self.commands.values() if not c.generated
        ]
        named += [(n, "constant", c.span) for n, c in spec.constants.items()]
        for command in self.commands.values():
            named += [(s.name, "state", s.span) for s in command.states.values()]
        for name in contract.BUILTIN_COMMANDS:
            taken.setdefault(name, "a command")
        states_seen: set[str] = set()
        for name, kind, span in named:
            if kind == "state":
                if name in states_seen:
                    continue  # the same state name in several tables is one constant
                states_seen.add(name)
            if name in taken and not (kind == "command" and name in contract.BUILTIN_COMMANDS):
                self.diags.error(
                    span,
                    "E228",
                    f"{kind} `{name}` collides with {taken[name]} in the generated module",
                    "rename it",
                )
            taken.setdefault(name, f"a {kind}")

    def lower_sub(self, sub: str) -> ir.IRSub:
        commands = self._with_defaults(self.by_name[sub])
        return ir.IRSub(
            sub,
            [(naming.sub_command_const(sub, n), code) for code, n in enumerate(commands, start=1)],
            _params(commands.values()),
        )

    def lower_predicates(self) -> list[tuple[str, str, str]]:
        lowered, calls = [], {}
        for name, item in self.spec.predicates.items():
            scope = self.scope_for(None)
            lowered.append(
                (name, self.compile(item, scope, X.BOOL), " ".join(str(item.value).split()))
            )
            calls[name] = set(scope.used_predicates)
        for name in calls:  # a predicate that reaches itself would recurse forever at run time
            seen, todo = set(), list(calls[name])
            while todo:
                at = todo.pop()
                if at == name:
                    self.diags.error(
                        self.spec.predicates[name].span, "E229", f"predicate `{name}` calls itself"
                    )
                    break
                if at not in seen:
                    seen.add(at)
                    todo.extend(calls.get(at, ()))
        return lowered

    def lower_command(self, command: Command, code: int) -> ir.IRCommand:
        scope = self.scope_for(command)
        self.check_states(command)
        states = [
            ir.IRState(
                state.name, _live([self.lower_rule(command, state, r, scope) for r in state.rules])
            )
            for state in command.states.values()
        ]
        return ir.IRCommand(
            name=command.name,
            code=code,
            doc=command.doc,
            method=naming.command_method(command.name),
            params=[ir.IRParam(p.name, p.type, p.doc) for p in command.params.values()],
            states=states,
            generated=command.generated,
        )

    def check_states(self, command: Command) -> None:
        states = command.states
        if "NOP" in states:
            self.diags.error(states["NOP"].span, "E227", "`NOP` is reserved for the idle state")
        if ENTRY_STATE not in states:
            self.diags.error(
                command.span,
                "E216",
                f"command {command.name} has no `S0` state",
                "S0 is where every new command starts",
            )
            return
        edges: dict[str, list[str]] = {s: [] for s in states}
        for state in states.values():
            for rule in state.rules:
                if rule.next is None:
                    continue
                if rule.next.value not in states:
                    self.diags.error(
                        rule.next.span,
                        "E206",
                        f"transition to undefined state `{rule.next.value}` in {command.name}",
                        known_names_hint(f"states of {command.name}", states, rule.next.value),
                    )
                else:
                    edges[state.name].append(rule.next.value)
        reached, todo = {ENTRY_STATE}, [ENTRY_STATE]
        while todo:
            for target in edges[todo.pop()]:
                if target not in reached:
                    reached.add(target)
                    todo.append(target)
        for name, state in states.items():
            if name not in reached:
                self.diags.error(
                    state.span,
                    "E207",
                    f"state `{name}` of {command.name} is unreachable from S0",
                    "add a rule with `next: " + name + "` or remove the state",
                )

    def lower_rule(self, command: Command, state: State, rule: Rule, scope: X.Scope) -> ir.IRRule:
        index = state.rules.index(rule)
        if index and state.rules[index - 1].when is None and not command.generated:
            self.diags.warning(
                rule.span,
                "W301",
                f"this rule of {command.name} {state.name} never fires",
                "the rule before it has no `when`, so it always fires first",
            )
        return self.lower_rule_body(rule, scope)

    def lower_rule_body(self, rule: Rule, scope: X.Scope) -> ir.IRRule:
        """A rule's guard, actions and next state, checked and printed."""
        guard = operand = None
        if rule.when is not None and rule.when.value is not True:
            tree = X.compile_expr(rule.when.value, rule.when.span, scope, self.diags, X.BOOL)
            if tree is not None:
                guard = X.to_python(tree, naming.attribute)
                operand = X.to_python_conjunct(tree, naming.attribute)
        actions = [self.lower_action(a, scope) for a in rule.actions]
        reports = [a for a in rule.actions if isinstance(a, Report)]
        if reports and rule.next is not None:
            self.diags.error(
                rule.next.span,
                "E226",
                "a rule that reports DONE or ERROR cannot name a next state",
                "reporting ends the command: the state becomes NOP",
            )
        next_state = "NOP" if reports else (rule.next.value if rule.next else None)
        return ir.IRRule(
            rule.doc, guard, operand, [a for a in actions if a is not None], next_state
        )

    def lower_action(self, action: object, scope: X.Scope) -> ir.IRAction | None:
        if isinstance(action, Send):
            return self.lower_send(action, scope)
        if isinstance(action, SetWorld):
            pairs = []
            for assign in action.assignments:
                target_type = self.target_type(assign.target)
                if target_type is not None:
                    value = self.compile(assign.value, scope, target_type)
                    pairs.append((naming.target_attribute(assign.target.value), value))
            return ir.IRSet(pairs)
        if isinstance(action, Report):
            return ir.IRReport(action.status)
        if isinstance(action, CallHook):
            hook = self.spec.hooks.get(action.hook)
            if hook is None:
                self.diags.error(
                    action.span,
                    "E208",
                    f"call of undeclared hook `{action.hook}`",
                    known_names_hint("hooks", self.spec.hooks, action.hook),
                )
                return None
            args = ["self.hook_state"] if self.spec.hooks_state else []
            args += [self.compile(a, scope, None) for a in hook.args]
            targets = [
                naming.target_attribute(t.value)
                for t in hook.returns
                if self.target_type(t) is not None
            ]
            return ir.IRCall(hook.name, args, targets)
        raise TypeError(action)

    def target_type(self, target: At) -> str | None:
        """The type of an assignable name (`world.<field>` or a local), or None after an error."""
        text = str(target.value)
        if text.startswith("world."):
            name = text.removeprefix("world.")
            if name not in self.system.world:
                self.diags.error(
                    target.span,
                    "E104",
                    f"undeclared world field `{name}`",
                    known_names_hint("world fields", self.system.world, name),
                )
                return None
            if name not in self.writable:
                self.diags.error(
                    target.span,
                    "E219",
                    f"`{self.spec.name}` writes world field `{name}` without declaring it",
                    f"add `{name}` to `world: writes:`",
                )
                return None
            return self.system.world[name].type
        if text in self.spec.locals:
            return self.spec.locals[text].type
        self.diags.error(
            target.span,
            "E220",
            f"cannot assign `{text}`: not a local or `world.<field>`",
            known_names_hint("locals", self.spec.locals, text),
        )
        return None

    def lower_send(self, send: Send, scope: X.Scope) -> ir.IRSend | None:
        if send.sub not in self.subs:
            self.diags.error(
                send.span,
                "E205",
                f"`{self.spec.name}` sends to `{send.sub}`, which is not one of its subordinates",
                known_names_hint("subordinates", self.subs, send.sub),
            )
            return None
        commands = self._with_defaults(self.by_name[send.sub])
        command = commands.get(send.command)
        if command is None:
            self.diags.error(
                send.span,
                "E204",
                f"`{send.sub}` does not declare command `{send.command}`",
                known_names_hint(f"commands of {send.sub}", commands, send.command),
            )
            return None
        args = []
        for name, value in send.args.items():
            param = command.params.get(name)
            if param is None:
                self.diags.error(
                    send.arg_spans.get(name, value.span),
                    "E218",
                    f"`{send.sub}.{send.command}` has no parameter `{name}`",
                    known_names_hint("parameters", command.params, name),
                )
                continue
            args.append((f"self.{send.sub}_arg_{name}", self.compile(value, scope, param.type)))
        missing = [p for p in command.params if p not in send.args]
        if missing:
            self.diags.error(
                send.span,
                "E217",
                f"`{send.sub}.{send.command}` needs parameter(s) {', '.join(missing)}",
                "give them under `with:`",
            )
        return ir.IRSend(send.sub, naming.sub_command_const(send.sub, send.command), args)


@lru_cache(maxsize=8)
def _world_layout_names(fields: tuple[str, ...]) -> dict[str, str]:
    """The layout's names of the world fields: the same for every controller, made once."""
    names = {}
    for name in fields:
        names[f"WORLD_{name.upper()}"] = names[f"WORLD_{name.upper()}_AT"] = "a layout name"
    return names


def _live(rules: list[ir.IRRule]) -> list[ir.IRRule]:
    """The rules that can fire: none after one without a guard (W301 reported them)."""
    for index, rule in enumerate(rules):
        if rule.guard is None:
            return rules[: index + 1]
    return rules


def _params(commands: Iterable[Command]) -> list[ir.IRParam]:
    """One slot per parameter name across a controller's commands, in declaration order."""
    slots: dict[str, ir.IRParam] = {}
    for command in commands:
        for p in command.params.values():
            slots.setdefault(p.name, ir.IRParam(p.name, p.type, p.doc))
    return list(slots.values())


def _world_ir(f: object) -> ir.IRWorldField:
    return ir.IRWorldField(f.name, f.type, f.initial, f.doc)  # type: ignore[attr-defined]


def _unique(items: Iterable[str]) -> list[str]:
    return list(dict.fromkeys(items))


class Scopes:
    """The scopes the checker types a checked system's expressions in, for analyses: one
    controller's predicates (`command` None) or one command's table. Built once each."""

    def __init__(self, system: SystemSpec, controllers: list[ControllerSpec]):
        self.system = system
        self.by_name = {c.name: c for c in controllers}
        self._lowerings: dict[str, _Lowering] = {}

    def scope(self, name: str, command: Command | None) -> X.Scope:
        lowering = self._lowerings.get(name)
        if lowering is None:
            spec = self.by_name[name]
            lowering = _Lowering(spec, self.by_name, self.system, None, False, Diagnostics())
            self._lowerings[name] = lowering
        return lowering.scope_for(command)
