"""Timers: is a counter-example's run possible under its `for:` rules' hold times? (z3)

The explicit engine counts the time in a state (`after:`) exactly, up to its largest
threshold, but leaves a `for:` rule's counter free: it lets the rule fire in any cycle its
`when` can hold, since counting up to `for: 5 s` (50 cycles) per rule would multiply the
states by the hold time. A run the model finds may so fire a `for:` rule before its `when`
can have held long enough. z3 (the optional extra `rcsgen[prove]`) decides it over the
run: per cycle a free boolean (`when` held) and the counter the generated code keeps
(docs/semantics.md, "Time in a state": reset by a new command, one more in each cycle the
state runs with `when` held, else 0), and the rule firing only with the counter above its
hold; a rule of the state that did not fire although tried before the one that did had its
guard false then. An impossible run makes the finding undecided, with why, before any
replay; without z3 the runs are not checked, and `prove` says so in one line.
"""

from __future__ import annotations

from typing import Any

from .adapter import table_rules
from .handshake import EXTRA, z3_or_none
from .model import NOP, Edge, State
from .properties import rule_view

Run = list[tuple[Edge, State]]


def timed(sk: Any, trace: Run) -> bool:
    """Whether the run fires a `for:` rule (only such a run is asked about)."""
    return any(
        rule_view(sk, r).hold is not None for edge, _ in trace for r in table_rules(edge.rules)
    )


def feasible(sk: Any, trace: Run) -> tuple[bool | None, str]:
    """(True, '') when the run is possible under its hold times, (False, why) when it is not,
    (None, how to get z3) without z3."""
    if not timed(sk, trace):
        return True, ""
    z3 = z3_or_none()
    if z3 is None:
        return None, f"the hold times (`for:`) of counter-examples need z3: install {EXTRA}"
    solver = z3.Solver()
    counters: dict[str, Any] = {}  # rule id -> its counter after the last cycle it ran
    before: State | None = None
    fired_late: list[str] = []
    for index, (edge, after) in enumerate(trace, start=1):
        if edge.new is not None:
            counters = {}  # check_if_new_command resets every counter
        command = after.command if edge.new is not None else (before.command if before else None)
        state = "S0" if edge.new is not None else (before.state if before else NOP)
        table = sk.tables.get(command or "", {}).get(state, []) if not edge.safe_state else []
        fired = table_rules(edge.rules)
        fired_late += _cycle(z3, solver, counters, table, fired[-1] if fired else None, index)
        before = after
    if solver.check() == z3.unsat:
        return False, (
            "impossible under its hold times (z3): "
            + ", ".join(fired_late)
            + " fires before its `when` can have held that long"
        )
    return True, ""


def _cycle(
    z3: Any, solver: Any, counters: dict[str, Any], table: list[Any], last: str | None, index: int
) -> list[str]:
    """One cycle of a state's table: every `for:` counter of it counts (generated code:
    at the top of the state's block), the rule that fired had its counter above its hold,
    the ones tried before it did not fire. Returns the `for:` rule that fired, if any."""
    ids = [rule.id for rule in table]
    tried = ids.index(last) if last in ids else len(ids)  # the rules tried before it
    fired = []
    for position, rule in enumerate(table):
        if rule.hold is None:
            continue
        held = z3.Bool(f"when_{index}_{rule.id}")
        previous = counters.get(rule.id, z3.IntVal(0))
        counter = z3.Int(f"held_{index}_{rule.id}")
        solver.add(counter == z3.If(held, previous + 1, 0))
        counters[rule.id] = counter
        if rule.id == last:
            solver.add(held, counter > rule.hold)
            fired.append(f"{rule.id} (for: {rule.hold} cycles) in cycle {index}")
        elif position < tried:
            solver.add(z3.Not(z3.And(held, counter > rule.hold)))  # tried, did not fire
    return fired
