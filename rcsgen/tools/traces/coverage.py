"""Coverage: traces + the IR -> which rules of which state tables fired, and which never did,
and the time each module spent in each state of each command (the second paper's support
facility: % of execution time per state).

Every table rule (INIT and HALT too) is counted; `every_cycle` rules are not, since the
status buffer records only table rules. A module that ran as its stand-in (`simulate:`)
is credited to the stand-in's tables. Text for people, JSON for tools.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from ...compiler.diagnostics import counted
from ...compiler.ir import IRSystem
from .read import Trace, check_against, runs_as


@dataclass
class RuleCount:
    module: str
    rule: str  # the rule id, COMMAND/STATE/n
    where: str  # file:line, the file as diagnostics show it
    guard: str  # spec text; "always" for an unconditional rule
    doc: str
    cycles: int = 0  # cycles it fired in, over all traces
    traces: list[str] = field(default_factory=list)  # the traces it fired in


@dataclass
class Coverage:
    system: str
    traces: list[str]
    rules: list[RuleCount]  # in the system's order: controller by controller, code order
    ran: dict[str, list[str]]  # controller -> the traces that ran it
    # controller -> `COMMAND/STATE` (`idle` for NOP) -> cycles it was there, over all traces
    states: dict[str, dict[str, int]] = field(default_factory=dict)
    periods: dict[str, float] = field(default_factory=dict)  # controller -> its cycle period, s

    @property
    def fired(self) -> int:
        return sum(1 for r in self.rules if r.cycles)

    def modules(self) -> list[str]:
        return list(dict.fromkeys(r.module for r in self.rules))


def measure(system: IRSystem, traces: list[Trace]) -> Coverage:
    """Count, for every table rule of `system`, the cycles and traces it fired in."""
    counts: dict[tuple[str, str], RuleCount] = {}
    for controller in system.controllers:
        for rule in controller.table_rules():
            guard = rule.guard.text if rule.guard is not None else "always"
            where = f"{rule.span.file}:{rule.span.line}"
            count = RuleCount(controller.name, str(rule.id), where, guard, rule.doc)
            counts[(controller.name, str(rule.id))] = count
    ran: dict[str, list[str]] = {c.name: [] for c in system.controllers}
    states: dict[str, dict[str, int]] = {}
    periods = {m: p.cycle_period for p in system.processes for m in p.modules}
    for trace in traces:
        process = check_against(system, trace)
        for module, table in runs_as(process, trace).items():
            ran[table].append(trace.name)
            columns = trace.columns[module]
            spent = states.setdefault(table, {})
            for command, state in zip(columns["command"], columns["state"], strict=True):
                where = "idle" if state == "NOP" else f"{command}/{state}"
                spent[where] = spent.get(where, 0) + 1
            fired: dict[str, int] = {}
            for rule_id in trace.columns[module]["rule"]:
                if rule_id is not None:
                    fired[rule_id] = fired.get(rule_id, 0) + 1
            for rule_id, cycles in fired.items():
                count = counts[(table, rule_id)]
                count.cycles += cycles
                count.traces.append(trace.name)
    periods = {
        c.name: periods.get(c.name, periods.get(c.buffers, system.cycle_period))
        for c in system.controllers
    }
    return Coverage(
        system.name, [t.name for t in traces], list(counts.values()), ran, states, periods
    )


def _percent(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f}%" if whole else "-"


def to_text(coverage: Coverage) -> str:
    """A summary line, a table per module, then every rule that never fired with its guard."""
    total = len(coverage.rules)
    out = [
        f"rule coverage of {coverage.system} over {counted(len(coverage.traces), 'trace')}: "
        f"{coverage.fired} of {total} table rules fired ({_percent(coverage.fired, total)})",
        "",
        f"{'module':<8} {'rules':>5} {'fired':>5} {'':>6}  ran in",
    ]
    for module in coverage.modules():
        rules = [r for r in coverage.rules if r.module == module]
        fired = sum(1 for r in rules if r.cycles)
        ran = len(coverage.ran[module])
        where = counted(ran, "trace") if ran else "no trace"
        out.append(
            f"{module:<8} {len(rules):>5} {fired:>5} {_percent(fired, len(rules)):>6}  {where}"
        )
    never = [r for r in coverage.rules if not r.cycles]
    if never:
        out += ["", "never fired:"]
        for module in coverage.modules():
            missed = [r for r in never if r.module == module]
            if not missed:
                continue
            note = "" if coverage.ran[module] else "  (not run by any trace)"
            out.append(f"  {module}{note}")
            width = max(len(r.rule) for r in missed)
            for r in missed:
                out.append(f"    {r.rule:<{width}}  {r.where}  {r.guard}")
    out += time_per_state(coverage)
    return "\n".join(out) + "\n"


def time_per_state(coverage: Coverage) -> list[str]:
    """Per module that ran, each state it spent cycles in (most first): the cycles, the
    seconds at its cycle period, and the share of the module's traced cycles. A cycle
    counts for the state a trace line shows, the one the module is in after that cycle."""
    out = ["", "time per state (cycles, seconds, share of the module's traced cycles):"]
    width = max((len(s) for spent in coverage.states.values() for s in spent), default=0)
    for module in coverage.modules():
        spent = coverage.states.get(module)
        if not spent:
            continue
        total = sum(spent.values())
        period = coverage.periods.get(module, 0.0)
        out.append(f"  {module}")
        for where, cycles in sorted(spent.items(), key=lambda item: (-item[1], item[0])):
            seconds = f"{cycles * period:.1f} s"
            out.append(
                f"    {where:<{width}}  {cycles:>7}  {seconds:>9}  {_percent(cycles, total):>6}"
            )
    return out


def to_json(coverage: Coverage) -> str:
    """One JSON object: the totals, and per module its rules with what fired where."""
    data = {
        "system": coverage.system,
        "traces": coverage.traces,
        "rules": len(coverage.rules),
        "fired": coverage.fired,
        "modules": [
            {
                "module": module,
                "ran_in": coverage.ran[module],
                "time_per_state": {
                    where: {
                        "cycles": cycles,
                        "seconds": round(cycles * coverage.periods.get(module, 0.0), 6),
                    }
                    for where, cycles in coverage.states.get(module, {}).items()
                },
                "rules": [
                    {
                        "rule": r.rule,
                        "where": r.where,
                        "guard": r.guard,
                        "doc": r.doc,
                        "cycles": r.cycles,
                        "traces": r.traces,
                    }
                    for r in coverage.rules
                    if r.module == module
                ],
            }
            for module in coverage.modules()
        ],
    }
    return json.dumps(data, indent=2, sort_keys=True) + "\n"
