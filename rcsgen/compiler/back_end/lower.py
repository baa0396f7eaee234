"""Lower: checked system -> frozen IR (names printed as Python, codes fixed, layout planned).

Reads the typed trees `check` kept; nothing here reports a diagnostic. Every expression
becomes an `IRExpr` (tree, spec text, Python text); what a controller module imports from
the runtime contract is computed from the references its rules make, not from its text.
The layout places every module's buffers, then the world fields, each on 8 bytes.
"""

from __future__ import annotations

import functools
import hashlib
import struct
from collections.abc import Iterable, Mapping
from dataclasses import replace

from ...runtime.contract import (
    ANSWER_FIELDS,
    COMMAND_HEAD_FIELDS,
    HEADER,
    MODE_FIELDS,
    OVERRIDE_HEAD_FIELDS,
    OVERRIDES_FIELDS,
    PACE_FIELDS,
    PERF_FIELDS,
    PROCESS_FIELDS,
    STARTUP_TIMEOUT,
    STATUS_FIELDS,
)
from ...runtime.io_points import ADDRESS_BYTES, DEVICE_FIELDS
from .. import expressions as expr
from .. import ir
from ..checks import naming, operators
from ..checks.tables import (
    Action,
    Assign,
    CallHook,
    CheckedCommand,
    CheckedController,
    CheckedPredicate,
    CheckedRule,
    CheckedSystem,
    PlanAction,
    Report,
    Send,
    Target,
    one_line,
    untimed,
)
from ..diagnostics import Span
from ..expressions import RefKind
from ..front_end.model import (
    ENTRY_STATE,
    Command,
    ControllerSpec,
    Located,
    Plan,
    PlanVerb,
    Typed,
    duration_in_cycles,
    duration_seconds,
)
from ..types import BOOL, INT, Str, Type
from . import module_io
from .module_io import align

# What every controller module imports from the runtime contract, whatever its tables say.
ALWAYS_IMPORTED = ("EXECUTING", "NO_RULE", "PERF", "STATUS")


def lower_system(checked: CheckedSystem, sources: Mapping[str, str]) -> ir.IRSystem:
    """The IR of a checked system; `sources` maps each spec's display path to the path the
    generated headers name it by (relative to the specs root)."""
    spec = checked.spec
    world = tuple(_world_field(f) for f in spec.world.values())
    links = {name: link for link, name in enumerate(cause_modules(checked), start=1)}
    controllers = tuple(
        _ControllerLowering(c, checked, sources[c.spec.display], links).lower()
        for c in checked.controllers.values()
    )
    devices = checked.io.devices
    processes = tuple(
        ir.IRProcess(
            p.name,
            p.cycle_period,
            p.doc,
            p.modules,
            p.roots,
            dict(p.stand_ins),
            dict(p.watchdog),
            tuple(d.name for d in devices if d.process == p.name),
            dict(sorted(p.realtime.items())),
            dict(p.module_spans),
        )
        for p in checked.processes
    )
    layout = plan_layout(
        spec.name, (p.name for p in processes), controllers, world, [d.name for d in devices]
    )
    placement = module_io.Placement.of(processes, controllers)
    controllers = tuple(
        replace(
            c,
            io=module_io.operator_io(c)
            if c.is_operator
            else module_io.controller_io(c, layout, placement),
        )
        for c in controllers
    )
    source = sources[spec.display]
    return ir.IRSystem(
        name=spec.name,
        title=spec.title,
        doc=spec.doc,
        source=source,
        cycle_period=spec.cycle_period,
        heartbeat_timeout=spec.heartbeat_timeout or default_heartbeat_timeout(processes),
        startup_timeout=spec.startup_timeout or STARTUP_TIMEOUT,
        world=world,
        controllers=controllers,
        processes=processes,
        layout=layout,
        name_span=spec.name_span,
        sources=tuple(sorted({source, *(c.source for c in controllers)})),
        access=operators.access(
            spec.operators, [c.name for c in controllers if c.buffers == c.name]
        ),
        role_holders={
            r.name: (tuple(u.value for u in r.users), tuple(g.value for g in r.groups))
            for r in spec.operators.roles.values()
            if r.members
        },
        segment_group=spec.operators.segment_group.value
        if spec.operators.segment_group is not None
        else None,
        requests=tuple(
            ir.IRRequest(r.name, r.doc, r.by.value, r.open_while.value, *r.answer.value.split("."))
            for r in spec.operators.requests.values()
        ),
        writes=module_io.process_writes(processes, controllers, layout, placement, world, devices),
        actuated_by={
            f.name: min(placement.world_writers[f.name])
            for f in world
            if f.actuator and placement.world_writers.get(f.name)
        },
        settings=tuple(spec.settings.items()) if spec.settings is not None else None,
        io=devices,
        io_dependents=dict(checked.io.dependents),
        io_spans={
            **{d.name: d.span for d in spec.io.values()},
            **{f"{d.name}.{p.field}": p.span for d in spec.io.values() for p in d.points},
        },
    )


def default_heartbeat_timeout(processes: Iterable[ir.IRProcess]) -> float:
    """Ten of the longest cycle periods, at least half a second."""
    return max(0.5, 10 * max(p.cycle_period for p in processes))


class _ControllerLowering:
    def __init__(
        self,
        checked: CheckedController,
        system: CheckedSystem,
        source: str,
        links: Mapping[str, int],
    ):
        self.checked, self.system, self.source = checked, system, source
        self.links = links  # module -> its link number in a cause (cause_modules, from 1)
        self.spec = checked.spec
        # each predicate's expression, printed where a guard or a value calls it
        self.inline = {p.name: p.tree for p in checked.predicates.values()}
        # reasons survive: a controller that declares reasons keeps the cause of its ERROR
        self.cause = bool(reason_codes(self.spec)) and not self.spec.is_operator
        runs_in = checked.buffers  # a stand-in runs in its controller's process
        self.period = next(
            (p.cycle_period for p in system.processes if runs_in in p.modules),
            system.spec.cycle_period,
        )

    def lower(self) -> ir.IRController:
        c, spec = self.checked, self.spec
        self.next_code = 1  # table rules are numbered in order, from 1
        commands = tuple(self.command(command) for command in c.commands.values())
        rules = c.rules()
        lets = [let.tree for command in c.commands.values() for let in command.lets]
        world = self.system.spec.world
        reads = dict.fromkeys(a.value for a in [*spec.world_reads, *spec.world_writes])
        return ir.IRController(
            name=spec.name,
            title=spec.title,
            doc=spec.doc,
            source=self.source,
            supervisor=c.supervisor,
            simulator=c.simulator,
            subordinates=tuple(self.sub(sub) for sub in c.subordinates),
            commands=commands,
            params=_param_slots(command.source for command in c.commands.values()),
            locals=tuple(
                ir.IRLocal(v.name, v.type, v.initial, v.doc) for v in spec.locals.values()
            ),
            constants=self.constants(),
            predicates=tuple(
                ir.IRPredicate(p.name, self.expression(p.tree, p.text))
                for p in c.predicates.values()
            ),
            hooks_module=self.hooks_module(rules),
            hooks=tuple(sorted(spec.hooks)),
            world_reads=tuple(_world_field(world[n]) for n in reads),
            world_writes=tuple(_world_field(world[a.value]) for a in spec.world_writes),
            states=self.states(),
            every_cycle=tuple(self.rule(rule) for rule in c.every_cycle),
            hooks_state=_value(spec.hooks_state),
            hooks_state_on_restart=spec.hooks_state_on_restart,
            buffers=c.buffers,
            runtime_names=_runtime_names(
                rules, c.predicates.values(), spec.hooks_state is not None, lets
            ),
            hooks_state_span=_span(spec.hooks_state),
            hooks_module_span=_span(spec.hooks_module),
            timed=any(command.timed for command in commands),
            functions=tuple(
                ir.IRFunction(f.name, f.params, f.returns, self.expression(f.tree, f.text), f.doc)
                for f in c.functions.values()
            ),
            results=tuple(
                ir.IRParam(name, kind) for name, kind in naming.result_types(spec).items()
            ),
            reasons=tuple((naming.reason_const(r), code) for r, code in reason_codes(spec).items()),
            counters=_counters(commands),
            every_cycle_counters=self.every_cycle_counters(),
            enum_values=_enum_values([*_trees(rules, c.predicates.values()), *lets]),
            plans=tuple(_plan(p) for p in spec.plans.values()),
            kind=spec.kind,
            clients=c.clients,
            hook_calls=self.hook_calls(rules),
            instance=ir.IRInstance(i.instance, i.template, i.member)
            if (i := spec.instance)
            else None,
            cause=self.cause,
        )

    def every_cycle_counters(self) -> tuple[ir.IRCounter, ...]:
        """The counters of its `for:` every_cycle rules."""
        return tuple(self.counter(r) for r in self.checked.every_cycle if r.hold is not None)

    def states(self) -> tuple[str, ...]:
        """Every state name of its tables, S0 first (code = index + 1)."""
        states = [ENTRY_STATE]
        for command in self.checked.commands.values():
            states += [s for s in command.states if s not in states]
        return tuple(states)

    def hooks_module(self, rules: Iterable[CheckedRule]) -> str | None:
        """Its hooks module, imported only when a rule calls a hook or a planner, or hook
        state is kept."""
        spec = self.spec
        uses_hooks = spec.hooks_state is not None or any(
            isinstance(a, CallHook)
            or (isinstance(a, PlanAction) and a.kind is not PlanVerb.ADVANCE)
            for r in rules
            for a in r.actions
        )
        return _value(spec.hooks_module) if uses_hooks else None

    def hook_calls(self, rules: Iterable[CheckedRule]) -> tuple[tuple[str, float, str | None], ...]:
        """Each hook and planner the tables call, by name: its deadline (docs/spec.md section
        6: its `deadline:` in seconds, else DEFAULT_DEADLINE_PERIODS cycle periods of the
        controller's process, and at least MIN_DEFAULT_DEADLINE) and the kinds of its
        `returns:` (None for a planner, whose plan is checked, or a hook with no targets)."""
        default = max(DEFAULT_DEADLINE_PERIODS * self.period, MIN_DEFAULT_DEADLINE)
        found: dict[str, tuple[float, str | None]] = {}
        for rule in rules:
            for action in rule.actions:
                if isinstance(action, CallHook):
                    kinds = "".join(t.type.hook_kind for t in action.targets) or None
                    found[action.hook.name] = (self.seconds(action.hook.deadline, default), kinds)
                elif isinstance(action, PlanAction) and action.kind is not PlanVerb.ADVANCE:
                    plan = action.plan
                    found[plan.planner.value] = (self.seconds(plan.deadline, default), None)
        return tuple((name, *found[name]) for name in sorted(found))

    def seconds(self, declared: Located | None, default: float) -> float:
        if declared is None:
            return round(default, 6)
        return round(duration_seconds(declared.value, self.period), 6)

    def constants(self) -> tuple[tuple[str, str], ...]:
        """The spec's constants, then CYCLE_PERIOD if an expression reads it (its period)."""
        spec, scope = self.spec, self.checked.scope
        found = [(n, repr(item.value)) for n, item in spec.constants.items()]
        given = naming.CYCLE_PERIOD
        if given in scope.used_constants and given not in spec.constants:
            found.append((given, f"{scope.constants[given]!r}  # seconds per cycle of its process"))
        return tuple(found)

    def sub(self, sub: str) -> ir.IRSub:
        commands = self.checked.sub_commands[sub]
        consts = tuple(
            (naming.sub_command_const(sub, name), code)
            for code, name in enumerate(commands, start=1)
        )
        params = _param_slots(self.system.controllers[sub].spec.commands.values())
        timeout = self.spec.echo_timeouts.get(sub)
        echo = None if timeout is None else duration_in_cycles(timeout.value, self.period)
        read = self.sub_reads.get(sub, set())
        sub_spec = self.system.controllers[sub].spec
        reasons: tuple[tuple[str, int], ...] = ()
        if (RefKind.SUB_REASON, "reason") in read or sub in self.reasons_passed:
            reasons = tuple(
                (naming.sub_reason_const(sub, r), code)
                for r, code in reason_codes(sub_spec).items()
            )
        results = tuple(
            ir.IRParam(name, kind)
            for name, kind in naming.result_types(sub_spec).items()
            if (RefKind.SUB_RESULT, name) in read
        )
        channel = ir.channel_key(sub, self.spec.name) if sub_spec.is_operator else ""
        policy = self.spec.on_lost.get(sub)
        continued = policy is not None and policy.value == "continue"
        caused = self.cause and sub in self.causes
        if caused and not reasons:  # its link names its reason
            reasons = tuple(
                (naming.sub_reason_const(sub, r), code)
                for r, code in reason_codes(sub_spec).items()
            )
        return ir.IRSub(
            sub,
            consts,
            params,
            echo,
            reasons,
            results,
            channel,
            continued,
            link=self.links[sub],
            caused=caused,
            chained=caused and bool(reason_codes(sub_spec)) and not sub_spec.is_operator,
        )

    @functools.cached_property
    def reasons_passed(self) -> set[str]:
        """The subordinates whose reason a report passes up (`reason: <sub>.reason`)."""
        return {
            action.reason.removesuffix(".reason")
            for rule in self.checked.rules()
            for action in rule.actions
            if isinstance(action, Report) and action.reason and action.reason.endswith(".reason")
        }

    @functools.cached_property
    def sub_reads(self) -> dict[str, set[tuple[RefKind, str]]]:
        """What the controller's guards, values, `let` values and predicates read of each
        subordinate (its owner's name -> kind and name), the trees walked once."""
        trees = _trees(self.checked.rules(), self.checked.predicates.values())
        trees += [let.tree for command in self.checked.commands.values() for let in command.lets]
        found: dict[str, set[tuple[RefKind, str]]] = {}
        for tree in trees:
            for ref in expr.refs(tree):
                found.setdefault(ref.owner, set()).add((ref.kind, ref.name))
        return found

    @functools.cached_property
    def causes(self) -> set[str]:
        """The subordinates whose ERROR some rule's guard tests as its cause."""
        return {cause_of(r.guard) for r in self.checked.rules()}

    def command(self, command: CheckedCommand) -> ir.IRCommand:
        source = command.source
        return ir.IRCommand(
            name=command.name,
            code=command.code,
            doc=source.doc,
            method=naming.command_method(command.name),
            params=tuple(ir.IRParam(p.name, p.type, p.doc) for p in source.params.values()),
            states=tuple(
                ir.IRState(
                    s.name,
                    s.span,
                    tuple(self.rule(r, self.code()) for r in s.rules),
                    tuple(self.counter(r) for r in s.rules if r.hold is not None),
                )
                for s in command.states.values()
            ),
            generated=command.generated,
            span=source.span,
            first_match=tuple(item.value for item in source.first_match),
            timed=any(
                r.after is not None or r.hold is not None
                for s in command.states.values()
                for r in s.rules
            ),
            lets=tuple((let.name, self.expression(let.tree, let.text)) for let in command.lets),
            results=tuple(
                ir.IRParam(r.name, r.type, r.doc, _bound(r.low, r.type), _bound(r.high, r.type))
                for r in source.results.values()
            ),
            reasons=tuple(str(r.value) for r in source.reasons),
            text=str(source.text.value) if source.text else "",
        )

    def counter(self, rule: CheckedRule) -> ir.IRCounter:
        """The counter of a `for:` rule, counting the cycles its `when` held."""
        assert rule.guard is not None  # `when and held > N` (check._timed_guard)
        when, timers = untimed(rule.guard)
        assert when is not None
        text = one_line(rule.source.when.value) if rule.source.when else ""
        counter = next(t.left for t in timers if isinstance(t, expr.Compare))
        assert isinstance(counter, expr.Ref) and counter.kind == RefKind.HELD
        return ir.IRCounter(counter.name, self.expression(when, text))

    def code(self) -> int:
        self.next_code += 1
        return self.next_code - 1

    def rule(self, rule: CheckedRule, code: int = 0) -> ir.IRRule:
        guard = operand = None
        if not rule.unconditional and rule.guard is not None:
            text = rule.guard_text or ""
            tested = rule.guard
            if rule.hold is not None:
                # its counter already counts the cycles `when` held: test only the timers
                rest = untimed(rule.guard)[1]
                tested = rest[0] if len(rest) == 1 else expr.BoolOp(BOOL, "and", rest)
            python, operand = expr.to_python_and_conjunct(tested, naming.attribute, self.inline)
            guard = ir.IRExpr(rule.guard, text, python)
        return ir.IRRule(
            id=rule.id,
            span=rule.span,
            doc=rule.source.doc,
            guard=guard,
            guard_operand=operand,
            actions=tuple(self.action(a) for a in rule.actions),
            next_state=rule.next_state,
            code=code,
            timing=rule.timing,
            cause_of=cause_of(rule.guard) if self.cause else "",
        )

    def action(self, action: Action) -> ir.IRAction:
        match action:
            case Send():
                return self.send(action)
            case Assign():
                return ir.IRSet(
                    tuple(
                        ir.IRAssign(
                            target.text,
                            _attribute(target),
                            self.expression(tree, action.text(target)),
                        )
                        for target, tree in action.assignments
                    )
                )
            case Report():
                return self.report(action)
            case PlanAction():
                return self.plan_action(action)
            case CallHook():
                kinds = tuple(t.type for t in action.targets)
                return ir.IRCall(
                    action.hook.name,
                    self.hook_arguments(action.args),
                    tuple(_attribute(t) for t in action.targets),
                    kinds="".join(kind.hook_kind for kind in kinds),
                    span=action.span,
                )
        raise TypeError(f"unknown action {action!r}")

    def send(self, action: Send) -> ir.IRSend:
        sub = action.sub
        args = tuple(
            ir.IRArg(
                param,
                naming.sub_arg_attribute(sub, param),
                self.expression(tree, action.text(param)),
            )
            for param, tree in action.args
        )
        return ir.IRSend(
            sub,
            action.command,
            naming.sub_command_const(sub, action.command),
            args,
            command_attribute=naming.sub_attribute(sub, "_command"),
            number_attribute=naming.sub_attribute(sub, "_command_num"),
        )

    def report(self, action: Report) -> ir.IRReport:
        if action.reason and action.reason.endswith(".reason"):  # passed up, by name
            sub = action.reason.removesuffix(".reason")
            pairs = tuple(
                (naming.sub_reason_const(sub, r), naming.reason_const(r)) for r in action.passes
            )
            return ir.IRReport(
                action.status,
                reason_name=action.reason,
                reason_of=sub,
                reason_map=pairs,
                reason_of_attribute=naming.sub_attribute(sub, "_error_num"),
            )
        reason = naming.reason_const(action.reason) if action.reason else ""
        return ir.IRReport(action.status, reason=reason, reason_name=action.reason or "")

    def plan_action(self, action: PlanAction) -> ir.IRLoadPlan | ir.IRAdvance:
        plan = action.plan.name
        if action.kind is PlanVerb.ADVANCE:
            return ir.IRAdvance(
                plan,
                go=f"self.{naming.plan_method(plan, 'go')}",
                step=f"self.{naming.plan_attribute(plan, 'step')}",
            )
        return ir.IRLoadPlan(
            plan,
            planner=action.plan.planner.value,
            replan=action.kind is PlanVerb.REPLAN,
            args=self.hook_arguments(action.args),
            span=action.span,
            replans=action.plan.replans,
            load=f"self.{naming.plan_method(plan, 'load')}",
            replans_left=f"self.{naming.plan_attribute(plan, 'replans_left')}",
        )

    def hook_arguments(self, args: tuple[expr.Expr, ...]) -> tuple[str, ...]:
        """A hook's or a planner's arguments as Python: the hook state first, if any."""
        state = ("self.hook_state",) if self.spec.hooks_state else ()
        return state + tuple(expr.to_python(a, naming.attribute, self.inline) for a in args)

    def expression(self, tree: expr.Expr, text: str) -> ir.IRExpr:
        return ir.IRExpr(tree, text, expr.to_python(tree, naming.attribute, self.inline))


# A hook's or planner's deadline when it declares none: this many cycle periods of its
# controller's process, and never less than MIN_DEFAULT_DEADLINE seconds (docs/decisions.md:
# the deadline stops an endless hook; keeping time is the watchdog's).
DEFAULT_DEADLINE_PERIODS = 5
MIN_DEFAULT_DEADLINE = 1.0


def _attribute(target: Target) -> str:
    return naming.target_attribute(target.kind, target.name)


def _runtime_names(
    rules: Iterable[CheckedRule],
    predicates: Iterable[CheckedPredicate],
    factory: bool = False,
    lets: Iterable[expr.Expr] = (),
) -> tuple[str, ...]:
    """The contract's names a controller module uses: its status comparisons, reports and
    NOP (a report ends the command), the hook-call checks, besides those every module
    needs."""
    used = set(ALWAYS_IMPORTED) | ({"HookError"} if factory else set())
    rules = list(rules)
    trees = [*_trees(rules, predicates), *lets]
    for rule in rules:
        for action in rule.actions:
            if isinstance(action, Report):
                used |= {action.status, "NOP"}
            elif isinstance(action, PlanAction) and action.kind is not PlanVerb.ADVANCE:
                used |= {"HookError", "plan_problem"}
    for tree in trees:
        used |= {ref.name for ref in expr.refs(tree) if ref.kind == RefKind.STATUS}
    return tuple(sorted(used, key=naming.import_order))


def _trees(rules: Iterable[CheckedRule], predicates: Iterable[CheckedPredicate]) -> list[expr.Expr]:
    """Every typed tree of a controller: predicates, guards, sent and assigned values, hook
    arguments."""
    trees: list[expr.Expr] = [p.tree for p in predicates]
    for rule in rules:
        if rule.guard is not None:
            trees.append(rule.guard)
        for action in rule.actions:
            if isinstance(action, Send):
                trees += [tree for _, tree in action.args]
            elif isinstance(action, Assign):
                trees += [tree for _, tree in action.assignments]
            elif isinstance(action, CallHook | PlanAction):
                trees += list(action.args)
    return trees


def cause_of(guard: expr.Expr | None) -> str:
    """The subordinate whose ERROR `guard` requires, '' for none: the first of its `and`
    terms that reads `<sub>.status == ERROR` (docs/semantics.md, "Reasons survive")."""
    if guard is None:
        return ""
    terms = guard.values if isinstance(guard, expr.BoolOp) and guard.op == "and" else (guard,)
    for term in terms:
        if isinstance(term, expr.Compare) and term.ops == ("==",):
            pair = (term.left, term.comparators[0])
            subs = [
                r.owner for r in pair if isinstance(r, expr.Ref) and r.kind == RefKind.SUB_STATUS
            ]
            error = [r for r in pair if isinstance(r, expr.Ref) and r.kind == RefKind.STATUS]
            if subs and error and error[0].name == "ERROR":
                return subs[0]
    return ""


def cause_modules(system: CheckedSystem) -> list[str]:
    """The modules a cause's link numbers (from 1): every module with buffers of its own,
    in the system's order (the layout's CAUSE_MODULES)."""
    return [name for name, c in system.controllers.items() if c.buffers == name]


def reason_codes(spec: ControllerSpec) -> dict[str, int]:
    """A controller's reasons and their codes in `error_num`: NONE 0, LOST 1, then its
    declared reasons from 2 (none at all when it declares none)."""
    declared = naming.declared_reasons(spec)
    if not declared:
        return {}
    return {name: code for code, name in enumerate((*expr.BUILTIN_REASONS, *declared))}


def _param_slots(commands: Iterable[Command]) -> tuple[ir.IRParam, ...]:
    """One slot per parameter name across a controller's commands, in declaration order."""
    slots: dict[str, ir.IRParam] = {}
    for command in commands:
        for p in command.params.values():
            slots.setdefault(p.name, ir.IRParam(p.name, p.type, p.doc))
    return tuple(slots.values())


def _value(item: Located | None) -> str | None:
    return None if item is None else str(item.value)


def _span(item: Located | None) -> Span | None:
    return None if item is None else item.span


def _counters(commands: Iterable[ir.IRCommand]) -> tuple[str, ...]:
    """Every `for:` counter attribute of the tables, in table order."""
    return tuple(
        counter.attribute
        for command in commands
        for state in command.states
        for counter in state.counters
    )


def _enum_values(trees: Iterable[expr.Expr]) -> tuple[tuple[str, int], ...]:
    """The enumeration values the trees name, each once: (value name, index), by index."""
    pairs = {pair for tree in trees for pair in expr.enum_constants(tree)}
    return tuple(sorted(pairs, key=lambda pair: (pair[1], pair[0])))


def _plan(p: Plan) -> ir.IRPlan:
    return ir.IRPlan(
        p.name,
        p.doc,
        p.planner.value,
        tuple(ir.IRParam(n, t) for n, t in p.steps.items()),
        p.capacity,
        p.replans,
        tuple(one_line(a.value) for a in p.args),
    )


def _world_field(f: Typed) -> ir.IRWorldField:
    safe = None
    if f.actuator:
        safe = f.safe if f.safe is not None else f.type.zero
    return ir.IRWorldField(f.name, f.type, f.initial, f.doc, f.actuator, safe, f.ground_truth)


# ---------------------------------------------------------------- layout


# A buffer's field: its name, struct code and, for a string, its capacity (else 0).
FieldShape = tuple[str, str, int]


def _shape(fields: Iterable[tuple[str, str]]) -> list[FieldShape]:
    """A runtime contract's buffer fields (name, code): none of them is a string."""
    return [(name, code, 0) for name, code in fields]


def _bound(given: Located | None, kind: Type) -> float | None:
    """A task result's `min` or `max` as a number of its type (None: not given)."""
    if given is None:
        return None
    return int(given.value) if kind == INT else float(given.value)


def _typed(name: str, kind: Type) -> FieldShape:
    """A field that holds a value of spec type `kind`."""
    return name, kind.code, kind.size if isinstance(kind, Str) else 0


def _buffer(const: str, offset: int, fields: Iterable[FieldShape]) -> ir.Buffer:
    """A buffer at `offset`: its sequence word, then `fields`."""
    slots, at = [], offset
    for name, code, text in [("seq", "Q", 0), *fields]:
        slots.append(ir.Slot(name, code, at, text))
        at += struct.calcsize("<" + code)
    return ir.Buffer(const, offset, tuple(slots))


def plan_layout(
    system: str,
    processes: Iterable[str],
    controllers: Iterable[ir.IRController],
    world: Iterable[ir.IRWorldField],
    devices: Iterable[str] = (),
) -> ir.Layout:
    """Place the header, each process's control record, every module's buffers, then the
    world fields, each buffer on 8 bytes, and hash the result.

    A stand-in (controller simulator) has no buffers of its own: it uses its controller's.
    """
    controllers = tuple(controllers)
    at = align(HEADER.size)
    process_records, pacing = {}, {}
    for name in processes:
        buffer = _buffer(f"PROCESS_{name.upper()}", at, _shape(PROCESS_FIELDS))
        process_records[name] = buffer
        at = align(at + buffer.size)
        pace = _buffer(f"PACE_{name.upper()}", at, _shape(PACE_FIELDS))
        pacing[name] = pace
        at = align(at + pace.size)
    modules, operators = {}, {}
    for c in controllers:
        if c.buffers != c.name:
            continue
        prefix = c.name.upper()
        params = [_typed(f"arg_{p.name}", p.type) for p in c.params]
        if c.is_operator:
            operators[c.name], at = _operator_buffers(c, at, params)
            continue
        results = [_typed(f"result_{r.name}", r.type) for r in c.results]
        results += [_typed(name, INT) for p in c.plans for name in p.status_fields]
        if c.cause:  # the chain of subordinates' errors its ERROR comes from (rcs/contract.py)
            results.append(("cause", "Q", 0))
        parts = {
            "command": [*_shape(COMMAND_HEAD_FIELDS), *params],
            "status": [*_shape(STATUS_FIELDS), *results],
            "mode": _shape(MODE_FIELDS),
            "perf": _shape(PERF_FIELDS),
        }
        made = {}
        for part, fields in parts.items():
            made[part] = _buffer(f"{prefix}_{part.upper()}", at, fields)
            at = align(at + made[part].size)
        modules[c.name] = ir.ModuleBuffers(**made)
    world_buffers = []
    for f in world:
        buffer = _buffer(f"WORLD_{f.name.upper()}", at, [_typed(f.name, f.type)])
        world_buffers.append(buffer)
        at = align(at + buffer.size)
    # Overrides: one flag, then each world field's override record (rcs/override.py).
    overrides = _buffer("OVERRIDES", at, _shape(OVERRIDES_FIELDS))
    at = align(at + overrides.size)
    override_fields = []
    for f in world:
        fields = [*_shape(OVERRIDE_HEAD_FIELDS), _typed(f.name, f.type)]
        buffer = _buffer(f"OVERRIDE_{f.name.upper()}", at, fields)
        override_fields.append(buffer)
        at = align(at + buffer.size)
    # I/O devices (rcs/io_cycle.py): each one's record, its state and counts, after the rest.
    io = {}
    for name in devices:
        shape = [(f, "q", 0) for f in DEVICE_FIELDS[:-1]]
        shape.append((DEVICE_FIELDS[-1], f"{ADDRESS_BYTES}s", ADDRESS_BYTES))  # its address
        io[name] = _buffer(f"IO_{name.upper()}", at, shape)
        at = align(at + io[name].size)
    # Time in each state (rcs/state_time.py): per controller and stand-in, the state it is in
    # and the process cycle it entered it, then the cycles of its process spent in each state
    # code (NOP first) before that, after everything else.
    state_time = {}
    for c in controllers:
        if c.is_operator:
            continue
        shape = [("state", "q", 0), ("since", "Q", 0)]
        shape += [(state, "Q", 0) for state in ("NOP", *c.states)]
        state_time[c.name] = _buffer(f"TIME_{c.name.upper()}", at, shape)
        at = align(at + state_time[c.name].size)
    layout = ir.Layout(
        process_records,
        modules,
        tuple(world_buffers),
        at,
        "",
        pacing,
        operators,
        overrides,
        tuple(override_fields),
        io,
        state_time,
    )
    return replace(layout, hash=layout_hash(system, layout))


def _operator_buffers(
    c: ir.IRController, at: int, params: list[FieldShape]
) -> tuple[ir.OperatorBuffers, int]:
    """An operator module's mode and performance buffers, then each client's channel (its
    command, status and answer record), from `at`; and the offset after them."""
    prefix = c.name.upper()
    own = {}
    for part, shape in (("mode", MODE_FIELDS), ("perf", PERF_FIELDS)):
        own[part] = _buffer(f"{prefix}_{part.upper()}", at, _shape(shape))
        at = align(at + own[part].size)
    channels = {}
    # what the person records with a DONE: in the answer record, copied to the status
    results = [_typed(f"result_{r.name}", r.type) for r in c.results]
    for client in c.clients:
        parts = {  # its command in, its status out, the answer to its request
            "command": [*_shape(COMMAND_HEAD_FIELDS), *params],
            "status": [*_shape(STATUS_FIELDS), *results],
            "answer": [*_shape(ANSWER_FIELDS), *results],
        }
        made = {}
        for part, fields in parts.items():
            const = f"{prefix}_{client.upper()}_{part.upper()}"
            made[part] = _buffer(const, at, fields)
            at = align(at + made[part].size)
        channels[client] = ir.Channel(**made)
    return ir.OperatorBuffers(own["mode"], own["perf"], channels), at


def layout_hash(system: str, layout: ir.Layout) -> str:
    """The layout's identity: every buffer, field, type and offset, and the system's name."""
    text = [f"rcsgen block v1 system={system} size={layout.size}"]
    for buffer in layout.all_buffers():
        fields = " ".join(f"{s.name}:{s.code}@{s.offset}" for s in buffer.slots)
        text.append(f"{buffer.const} {fields}")
    digest = hashlib.sha256("\n".join(text).encode("ascii")).hexdigest()
    return digest[:32]
