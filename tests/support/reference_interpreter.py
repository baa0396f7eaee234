"""A reference interpreter of one controller's documented semantics (docs/semantics.md).

Written from the documentation, independently of the generator: it reads the spec as plain
YAML data (`yaml.safe_load`), evaluates guards and values with its own small evaluator over
Python's `ast`, and never calls rcsgen. tests/test_differential.py runs it side by side with
the generated code and compares every cycle.

It lives in tests/, not in the package: it is a test oracle. Shipping a second implementation
of the semantics would invite using it, and the oracle must stay free to be simple and slow.

Covered: the command-number handshake (a new number starts the table at S0 with EXECUTING),
subordinate status (EXECUTING until the echo of the last number sent), the first rule whose
guard holds fires (`next` then actions in order), `report` ends the command (state NOP),
sends number each command, world fields copied in at the start and written out at the end
of a cycle, locals, parameters, constants, predicates, default INIT/HALT tables, time in a
state (`after:`, `for:`; docs/semantics.md "Time in a state"), results and reasons (own
and subordinates'; docs/semantics.md "Results and reasons"), `let` values, conditional
expressions and pure functions (docs/spec.md section 13), enumerations (held by value name;
a bare name no parameter, local or constant has is a value name), strings, and plans
(docs/semantics.md "Plans"; the planner is a Python function the test gives).
Not covered: modes, every_cycle rules, hooks.
"""

from __future__ import annotations

import ast
import math
import operator
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

STATUSES = ("NOT_READY", "EXECUTING", "DONE", "ERROR")
_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv,
    ast.Mod: operator.mod,
}
_COMPARE = {
    ast.Eq: operator.eq,
    ast.NotEq: operator.ne,
    ast.Lt: operator.lt,
    ast.LtE: operator.le,
    ast.Gt: operator.gt,
    ast.GtE: operator.ge,
}


def default_table(command: str, subordinates: list[str]) -> dict[str, list[dict]]:
    """docs/semantics.md section 5, written out as a state table."""
    if not subordinates:
        return {"S0": [{"do": [{"report": "DONE"}]}]}
    return {
        "S0": [{"do": [{"send": f"{sub}.{command}"} for sub in subordinates], "next": "S1"}],
        "S1": [
            {
                "when": " and ".join(f"{sub}.status == DONE" for sub in subordinates),
                "do": [{"report": "DONE"}],
            }
        ],
    }


@dataclass
class Block:
    """What the reference and the test share: the buffers the controller reads and writes."""

    command_num: int = 0
    command: str = "NONE"
    args: dict[str, Any] = field(default_factory=dict)
    sub_status: dict[str, tuple[int, str]] = field(default_factory=dict)  # sub -> (num, status)
    sub_reason: dict[str, str] = field(default_factory=dict)  # sub -> the reason it reports
    sub_results: dict[str, dict[str, Any]] = field(default_factory=dict)  # sub -> its results
    world: dict[str, Any] = field(default_factory=dict)


@dataclass
class SubCommand:
    command: str = "NONE"
    number: int = 0
    args: dict[str, Any] = field(default_factory=dict)


class Controller:
    """One controller, cycle by cycle."""

    def __init__(
        self,
        spec: dict,
        subs: dict[str, dict],
        world: dict[str, dict],
        period: float = 0.01,
        planners: dict[str, Callable[..., Any]] | None = None,
    ) -> None:
        self.spec = spec
        self.planners = planners or {}
        # each plan: its steps, the current step, the replans left (docs/semantics.md "Plans")
        self.plans = {name: {"list": [], "step": 0, "left": 0} for name in spec.get("plans") or {}}
        self.period = period
        self.time = 0  # cycles the table has run in the current state, before this one
        self.held: dict[tuple[str, str, int], int] = {}  # `for:` rule -> cycles its when held
        self.subs = list(spec.get("subordinates") or [])
        self.sub_specs = subs
        access = spec.get("world") or {}
        self.reads = list(
            dict.fromkeys([*(access.get("reads") or []), *(access.get("writes") or [])])
        )
        self.writes = list(access.get("writes") or [])
        self.constants = dict(spec.get("constants") or {})
        self.predicates = dict(spec.get("predicates") or {})
        self.functions = dict(spec.get("functions") or {})
        self.names: dict[str, Any] = {}  # `let` values of this cycle, or a function's arguments
        self.locals = {n: v["initial"] for n, v in (spec.get("locals") or {}).items()}
        self.tables = {
            "INIT": default_table("INIT", self.subs),
            "HALT": default_table("HALT", self.subs),
        }
        self.spec_commands: dict[str, Any] = dict(spec.get("commands") or {})
        for name, command in self.spec_commands.items():
            self.tables[name] = command["states"]
        self.params = self._param_types()
        self.result_types = {
            name: _kind(result)
            for command in (spec.get("commands") or {}).values()
            for name, result in (command.get("results") or {}).items()
        }
        self.results = {name: _zero(kind) for name, kind in self.result_types.items()}
        self.reason = "NONE"
        self.sub_reason = {sub: "NONE" for sub in self.subs}
        self.sub_result_types = {
            sub: {
                name: _kind(result)
                for command in (subs[sub].get("commands") or {}).values()
                for name, result in (command.get("results") or {}).items()
            }
            for sub in self.subs
        }
        self.sub_results: dict[str, dict[str, Any]] = {sub: {} for sub in self.subs}
        # status buffer and local copies
        self.status_num, self.status, self.state = 0, "NOT_READY", "NOP"
        self.command_num, self.command, self.args = 0, "NONE", {}
        self.sent = {sub: SubCommand(args=self._slots(subs[sub])) for sub in self.subs}
        self.sub_view = {sub: "NOT_READY" for sub in self.subs}
        self.world: dict[str, Any] = {}
        del world  # initial values live in the block

    @staticmethod
    def _slots(spec: dict) -> dict[str, Any]:
        """A subordinate's parameter slots in its command buffer, all zero at first."""
        slots = {}
        for command in (spec.get("commands") or {}).values():
            for name, param in (command.get("params") or {}).items():
                slots.setdefault(name, _zero(_kind(param)))
        return slots

    def _param_types(self) -> dict[str, str]:
        types = {}
        for command in (self.spec.get("commands") or {}).values():
            for name, param in (command.get("params") or {}).items():
                types[name] = _kind(param)
        return types

    # ------------------------------------------------------------ one cycle

    def run_cycle(self, block: Block) -> None:
        # pre_process: command, subordinate statuses, world
        self.command_num, self.command = block.command_num, block.command
        self.args = {p: block.args.get(p, _zero(t)) for p, t in self.params.items()}
        for sub in self.subs:
            number, status = block.sub_status.get(sub, (0, "NOT_READY"))
            echoed = number == self.sent[sub].number
            self.sub_view[sub] = status if echoed else "EXECUTING"
            # a reason only with an ERROR, results only for the last command sent
            reason = block.sub_reason.get(sub, "NONE")
            self.sub_reason[sub] = reason if echoed and status == "ERROR" else "NONE"
            results = block.sub_results.get(sub, {})
            self.sub_results[sub] = {
                name: results.get(name, _zero(kind)) if echoed else _zero(kind)
                for name, kind in self.sub_result_types[sub].items()
            }
        self.world = {name: block.world[name] for name in self.reads}
        # check_if_new_command
        if self.command_num != self.status_num:
            self.status_num, self.state, self.status = self.command_num, "S0", "EXECUTING"
            self.time, self.held = 0, {}
            self.reason = "NONE"
            self.results = {name: _zero(kind) for name, kind in self.result_types.items()}
        # decision_process
        table = self.tables.get(self.command)
        entered = self.state
        self.names = {}
        if table is not None:  # named values first, in order, each seeing those before it
            lets = (self.spec.get("commands") or {}).get(self.command, {}).get("let") or {}
            for name, text in lets.items():
                self.names[name] = self.value(text)
        if table is not None and self.state in table:
            rules = table[self.state]
            for index, rule in enumerate(rules):  # every `for:` counts, whichever rule fires
                if "for" in rule:
                    key = (self.command, self.state, index)
                    self.held[key] = self.held.get(key, 0) + 1 if self.holds(rule["when"]) else 0
            for index, rule in enumerate(rules):
                if self.may_fire(rule, (self.command, self.state, index)):
                    self.fire(rule)
                    break
        if table is not None:  # time passes in a state only while its table runs
            if self.state != entered:
                self.time, self.held = 0, {}
            else:
                self.time += 1
        # post_process: world out
        for name in self.writes:
            block.world[name] = self.world[name]

    def may_fire(self, rule: dict, key: tuple[str, str, int]) -> bool:
        """`when` holds; `for:` it has held longer than that; `after:` the state has lasted."""
        if "when" in rule and not self.holds(rule["when"]):
            return False
        if "for" in rule and self.held.get(key, 0) <= self.cycles(rule["for"]):
            return False
        return "after" not in rule or self.time >= self.cycles(rule["after"])

    def cycles(self, duration: object) -> int:
        """A duration in cycles: `N cycles`, or seconds rounded up to whole cycles."""
        if isinstance(duration, int | float):
            seconds = float(duration)
        else:
            number, unit = re.fullmatch(r"([0-9.]+)\s*(s|ms|cycles?)", str(duration)).groups()
            if unit.startswith("cycle"):
                return int(number)
            seconds = float(number) / (1000 if unit == "ms" else 1)
        count = seconds / self.period
        return round(count) if abs(count - round(count)) < 1e-6 else math.ceil(count)

    def fire(self, rule: dict) -> None:
        if "next" in rule:
            self.state = rule["next"]
        for action in rule.get("do") or []:
            if "send" in action:
                sub, _, command = action["send"].partition(".")
                values = {k: self.value(v) for k, v in (action.get("with") or {}).items()}
                previous = self.sent[sub]
                args = {**previous.args, **values}
                self.sent[sub] = SubCommand(command, previous.number + 1, args)
            elif "set" in action:
                for target, text in action["set"].items():
                    value = self.value(text)
                    if target.startswith("world."):
                        self.world[target.removeprefix("world.")] = value
                    elif target.startswith("result."):
                        name = target.removeprefix("result.")
                        kind = self.result_types[name]
                        self.results[name] = float(value) if kind == "float" else value
                    else:
                        self.locals[target] = value
            elif "report" in action:
                self.status, self.state = action["report"], "NOP"
                if "reason" in action:
                    self.reason = self._reason(action["reason"])
            elif "advance" in action:
                plan = self.plans[action["advance"]]
                plan["step"] = min(plan["step"] + 1, len(plan["list"]))
            else:
                kind = "plan" if "plan" in action else "replan"
                self.make_plan(action[kind], kind)

    def _reason(self, reason: str) -> str:
        """A report's reason: its own, or a subordinate's passed up by name (`fx.reason`),
        which reads NONE unless it is LOST or one of the current command's reasons."""
        if not reason.endswith(".reason"):
            return reason
        passed = self.sub_reason[reason.removesuffix(".reason")]
        own = self.spec_commands.get(self.command, {}).get("reasons") or []
        return passed if passed == "LOST" or passed in own else "NONE"

    def make_plan(self, name: str, kind: str) -> None:
        """`plan:` (every replan left, from no steps) or `replan:` (one fewer), then the
        planner's steps from step 0; a wrong plan, or a replan with none left, raises."""
        declared, plan = self.spec["plans"][name], self.plans[name]
        if kind == "plan":
            plan.update({"list": [], "step": 0, "left": declared.get("replans", 0)})
        elif plan["left"] == 0:
            raise ValueError(f"plan {name}: no replans left")
        else:
            plan["left"] -= 1
        args = [self.value(a) for a in declared.get("args") or []]
        steps = self.planners[declared["planner"]](*args)
        fields = list(declared["steps"].values())
        if len(steps) > declared["capacity"] or any(len(s) != len(fields) for s in steps):
            raise ValueError(f"plan {name}: {steps!r} does not fit")
        plan.update({"list": [tuple(s) for s in steps], "step": 0})

    # ------------------------------------------------------------ expressions

    def holds(self, guard: object) -> bool:
        return bool(self.value(guard))

    def value(self, source: object) -> Any:
        if isinstance(source, bool | int | float):
            return source
        tree = ast.parse(" ".join(str(source).split()), mode="eval")
        return self.eval(tree.body)

    def eval(self, node: ast.AST, sub_commands: str | None = None) -> Any:
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.BoolOp):
            values = [self.eval(v) for v in node.values]
            return all(values) if isinstance(node.op, ast.And) else any(values)
        if isinstance(node, ast.UnaryOp):
            operand = self.eval(node.operand)
            if isinstance(node.op, ast.Not):
                return not operand
            return -operand if isinstance(node.op, ast.USub) else +operand
        if isinstance(node, ast.BinOp):
            return _BINARY[type(node.op)](self.eval(node.left), self.eval(node.right))
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            sub = next(
                (_sub_command(o, self.subs) for o in operands if _sub_command(o, self.subs)), None
            )
            values = [self.eval(o, sub) for o in operands]
            return all(
                _COMPARE[type(op)](a, b)
                for op, a, b in zip(node.ops, values, values[1:], strict=False)
            )
        if isinstance(node, ast.Name):
            return self.name(node.id, sub_commands)
        if isinstance(node, ast.Attribute):
            if isinstance(node.value, ast.Name) and node.value.id in self.plans:
                return self.plan_value(node.value.id, node.attr)
            if isinstance(node.value, ast.Attribute):  # <sub>.result.<name>
                sub = node.value.value.id  # type: ignore[attr-defined]
                return self.sub_results[sub][node.attr]
            base = node.value.id  # type: ignore[attr-defined]
            if base == "world":
                return self.world[node.attr]
            if node.attr == "reason":
                return self.sub_reason[base]
            return self.sub_view[base] if node.attr == "status" else self.sent[base].command
        if isinstance(node, ast.IfExp):
            return self.eval(node.body) if self.eval(node.test) else self.eval(node.orelse)
        if isinstance(node, ast.Call):
            name = node.func.id  # type: ignore[attr-defined]
            if name in self.functions:  # evaluated with only its arguments (and constants)
                function = self.functions[name]
                args = [self.eval(a) for a in node.args]
                saved, self.names = self.names, dict(zip(function["params"], args, strict=True))
                try:
                    result = self.value(function["body"])
                finally:
                    self.names = saved
                return float(result) if function["returns"] == "float" else result
            if name in self.predicates:
                return self.holds(self.predicates[name])
            args = [self.eval(a) for a in node.args]
            return {"abs": abs, "min": min, "max": max}[name](*args)
        raise ValueError(f"not in the expression language: {ast.dump(node)}")

    def plan_value(self, name: str, attr: str) -> Any:
        """`<plan>.<attr>`: a property, or the current step's field (none once done)."""
        plan = self.plans[name]
        steps, step = plan["list"], plan["step"]
        properties = {
            "step": step,
            "steps": len(steps),
            "done": step >= len(steps),
            "replans_left": plan["left"],
        }
        if attr in properties:
            return properties[attr]
        fields = self.spec["plans"][name]["steps"]
        index = list(fields).index(attr)
        return steps[step][index] if step < len(steps) else _zero(fields[attr])

    def name(self, name: str, sub_commands: str | None) -> Any:
        if sub_commands is not None:
            return name  # compared with <sub>.command: a command name
        if name in STATUSES:
            return name
        if name in self.names:
            return self.names[name]
        if name in self.args:
            return self.args[name]
        if name in self.locals:
            return self.locals[name]
        return self.constants.get(name, name)  # else an enumeration's value name

    # ------------------------------------------------------------ what a trace shows

    def trace(self) -> dict[str, Any]:
        return {
            "state": self.state,
            "status": self.status,
            "status_num": self.status_num,
            "sent": {
                s: (c.command, c.number, dict(sorted(c.args.items()))) for s, c in self.sent.items()
            },
            "locals": dict(self.locals),
            "reason": self.reason,
            "results": dict(self.results),
            "plans": {
                name: (p["step"], len(p["list"]), p["left"]) for name, p in self.plans.items()
            },
        }


def _sub_command(node: ast.AST, subs: list[str]) -> str | None:
    """The subordinate whose command or reason `node` reads: compared with names."""
    if (
        isinstance(node, ast.Attribute)
        and node.attr in ("command", "reason")
        and isinstance(node.value, ast.Name)
        and node.value.id in subs
    ):
        return node.value.id
    return None


def _kind(declaration: dict) -> str:
    """A declaration's type; an enumeration's as `enum:<its first value>`."""
    if declaration["type"] == "enum":
        return f"enum:{declaration['values'][0]}"
    return str(declaration["type"])


def _zero(kind: str) -> Any:
    """A value before anything is set: false, 0, 0.0, the first value, the empty string."""
    if kind.startswith("enum:"):
        return kind.removeprefix("enum:")
    return {"bool": False, "int": 0, "float": 0.0, "str": ""}[kind]
