"""Model: one controller over its subordinates' proven contracts -> every reachable state.

The explicit-state engine (no dependency). A state is the controller's command, table state,
status and time in the state, and for each subordinate the last command sent to it and the
status the controller reads for it (`EXECUTING` until the echo of the last number, then
what it reports), which processes are lost, and two flags the properties read: whether a
subordinate has answered ERROR during the current command, and whether the current command
is HALT. One transition is one cycle, as the generated code runs it (docs/semantics.md
sections 2-4): between cycles the environment may send a new command from above, any
subordinate still executing may answer with what its contract allows, and a process below
may be lost (the runtime's reaction, `lost.py`); then the controller runs its every_cycle
rules and its table, the first rule whose guard holds firing, guards over world fields,
locals, parameters and hook results free within the analysis's regions.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from itertools import product
from typing import Any, NamedTuple

from ..solver import Key
from .adapter import DONE, ERROR, EXECUTING, NOT_READY, Choice, RuleView, Skeleton
from .lost import DirectReaction

NOP = "NOP"
LIMIT = 400_000  # the most states one model may have; more is "too large" (undecided)


class State(NamedTuple):
    command: str | None  # None: no command yet
    state: str  # table state, or NOP
    status: str
    ticks: int  # cycles in the state (capped at its largest `after:`), 0 when untimed
    # per subordinate: (last sent, status read, sent during the current command)
    subs: tuple[tuple[str | None, str, bool], ...]
    lost: tuple[str, ...] = ()
    errored: bool = False  # a subordinate answered ERROR during the current command
    halted: bool = False  # the current command from above is HALT


class Edge(NamedTuple):
    """One cycle: what happened before it and what the controller did in it."""

    new: str | None  # a new command from above, read this cycle
    answers: tuple[tuple[str, str], ...]  # (sub, DONE|ERROR) answered before this cycle
    lost: str | None  # a process lost before this cycle
    safe_state: bool  # the runtime put the controller in its safe state (a loss)
    rules: tuple[str, ...]  # the rules that fired (every_cycle first)
    sends: tuple[tuple[str, str], ...]
    report: str | None
    unsafe: tuple[str, ...]  # actuator fields set to a value that may not be safe
    safe: tuple[str, ...]  # actuator fields set to their safe value
    certain: bool  # every guard choice was decided ("yes"), not only possible
    valuation: tuple[tuple[Key, Any], ...]  # atoms that make the choices so
    views: tuple[str, ...]  # the status it read for each subordinate this cycle


class Step(NamedTuple):
    """What the controller's own cycle did, from a state the environment has set."""

    rules: tuple[str, ...]
    sends: tuple[tuple[str, str], ...]
    report: str | None
    unsafe: tuple[str, ...]
    safe: tuple[str, ...]
    certain: bool
    valuation: tuple[tuple[Key, Any], ...]
    views: tuple[str, ...]


@dataclass
class Graph:
    """The reachable states and their transitions."""

    skeleton: Skeleton
    initial: State
    edges: dict[State, list[tuple[Edge, State]]] = field(default_factory=dict)
    parent: dict[State, tuple[State, Edge] | None] = field(default_factory=dict)
    complete: bool = True  # False: LIMIT states reached, exploration stopped

    def path_to(self, target: State) -> list[tuple[Edge, State]]:
        """The shortest run from the initial state to `target`."""
        path: list[tuple[Edge, State]] = []
        at = target
        while (step := self.parent.get(at)) is not None:
            previous, edge = step
            path.append((edge, at))
            at = previous
        return list(reversed(path))


@dataclass(frozen=True)
class Contract:
    """What a subordinate promises, per command: the statuses it can end that command
    with. Assumed of every subordinate: a command it runs ends (assume-guarantee)."""

    outcomes: dict[str, tuple[str, ...]]

    def of(self, command: str) -> tuple[str, ...]:
        return self.outcomes.get(command, (DONE, ERROR))


class Model:
    """The controller's transitions, computed on demand."""

    def __init__(
        self,
        skeleton: Skeleton,
        contracts: dict[str, Contract],
        reaction: DirectReaction,
        new_commands: bool = True,
    ) -> None:
        self.sk = skeleton
        self.contracts = contracts
        self.reaction = reaction
        self.lossy = reaction.candidates(skeleton.name) if skeleton.subs else ()
        self.effects = {p: reaction.effect(skeleton.name, p) for p in self.lossy}
        self.new_commands = new_commands
        self.sub_index = {s: i for i, s in enumerate(skeleton.subs)}
        self._news_seen: set[Any] = set()
        self._steps: dict[Any, list[tuple[Step, State]]] = {}

    def initial(self) -> State:
        return State(None, NOP, NOT_READY, 0, tuple((None, NOT_READY, False) for _ in self.sk.subs))

    # ------------------------------------------------------------ one cycle

    def successors(self, s: State) -> list[tuple[Edge, State]]:
        out: list[tuple[Edge, State]] = []
        news: list[str | None] = [None]
        if self.new_commands and (s.subs, s.lost) not in self._news_seen:
            # a new command from above leads to the same states from every state with these
            # subordinates: its edges are taken once
            self._news_seen.add((s.subs, s.lost))
            news += self.sk.commands
        losses: list[str | None] = [None, *(p for p in self.lossy if p not in s.lost)]
        options = []
        for index, (sent, view, _) in enumerate(s.subs):
            sub = self.sk.subs[index]
            if view == EXECUTING and sent is not None and not self._in_lost(sub, s.lost):
                options.append([None, *self.contracts[sub].of(sent)])
            else:
                options.append([None])
        for new in news:
            for lost in losses:
                for answers in product(*options):
                    out += self._cycle(s, new, lost, answers)
        return out

    def _in_lost(self, sub: str, lost: tuple[str, ...]) -> bool:
        return self.reaction.process_of(sub) in lost

    def _cycle(
        self, s: State, new: str | None, lost: str | None, answers: tuple[str | None, ...]
    ) -> list[tuple[Edge, State]]:
        subs = [
            (sent, view if answer is None else answer, fresh)
            for (sent, view, fresh), answer in zip(s.subs, answers, strict=True)
        ]
        answered = tuple((self.sk.subs[i], a) for i, a in enumerate(answers) if a is not None)
        # an ERROR counts for the current command only if it answers a command it sent
        errored = s.errored or any(a == ERROR and s.subs[i][2] for i, a in enumerate(answers))
        command, state, status, ticks, halted = s.command, s.state, s.status, s.ticks, s.halted
        lost_now = s.lost
        safe_state = False
        pre_sends: list[tuple[str, str]] = []
        if lost is not None:
            lost_now = tuple(sorted({*s.lost, lost}))
            effect = self.effects[lost]
            for sub in effect.errors:
                i = self.sub_index[sub]
                subs[i] = (subs[i][0], ERROR, subs[i][2])
                errored = True
            if effect.safe_state:  # HALT to every subordinate, NOP, ERROR (LOST)
                safe_state = True
                pre_sends = [(sub, "HALT") for sub in self.sk.subs]
                subs = [("HALT", EXECUTING, True) for _ in subs]
                state, status, ticks = NOP, ERROR, 0
        if new is not None:  # check_if_new_command
            command, state, status, ticks = new, "S0", EXECUTING, 0
            halted, errored = new == "HALT", False
            subs = [(sent, view, False) for sent, view, _ in subs]
        pre = (command, state, status, ticks, tuple(subs), lost_now, errored, halted)
        steps = self._steps.get(pre)
        if steps is None:
            steps = self._steps[pre] = self._step(*pre)
        return [
            (
                Edge(
                    new,
                    answered,
                    lost,
                    safe_state,
                    step.rules,
                    (*pre_sends, *step.sends),
                    step.report,
                    step.unsafe,
                    step.safe,
                    step.certain,
                    step.valuation,
                    step.views,
                ),
                target,
            )
            for step, target in steps
        ]

    def _step(
        self,
        command: str | None,
        state: str,
        status: str,
        ticks: int,
        subs_in: tuple[tuple[str | None, str, bool], ...],
        lost_now: tuple[str, ...],
        errored: bool,
        halted: bool,
    ) -> list[tuple[Step, State]]:
        """The controller's own cycle from a state the environment has set."""
        subs = list(subs_in)
        views = tuple(view for _, view, _ in subs)
        fixed: dict[Key, Any] = {}
        for sub, (sent, view, _) in zip(self.sk.subs, subs, strict=True):
            fixed[("status", sub)] = view
            fixed[("command", sub)] = sent if sent is not None else "NONE"
        fixed[("time", "ticks")] = ticks
        results: list[tuple[Step, State]] = []
        every = self.sk.every
        every_choices = self.sk.choices(every, fixed) if every else (Choice(None, True, ()),)
        for first in every_choices:
            sends: list[tuple[str, str]] = []
            fired: list[str] = []
            report: str | None = None
            unsafe: list[str] = []
            safe: list[str] = []
            st, stat = state, status
            local_fixed = dict(fixed)
            if first.rule is not None:
                rule = every[first.rule]
                self._act(rule, fired, sends, unsafe, safe, local_fixed)
                if rule.report:
                    report, st, stat = rule.report, NOP, rule.report
            table = None
            if command is not None and st != NOP and stat == EXECUTING:
                table = self.sk.tables.get(command, {}).get(st)
            table_choices = (
                self.sk.choices(table, local_fixed) if table else (Choice(None, True, ()),)
            )
            for second in table_choices:
                sends2, fired2 = list(sends), list(fired)
                unsafe2, safe2 = list(unsafe), list(safe)
                st2, stat2, report2 = st, stat, report
                if table is not None and second.rule is not None:
                    rule = table[second.rule]
                    self._act(rule, fired2, sends2, unsafe2, safe2, dict(local_fixed))
                    if rule.report:
                        report2, st2, stat2 = rule.report, NOP, rule.report
                    elif rule.next_state is not None:
                        st2 = rule.next_state
                new_subs = list(subs)
                for sub, cmd in sends2:
                    new_subs[self.sub_index[sub]] = (cmd, EXECUTING, True)
                limit = self.sk.timers.get((command, st2), ()) if command else ()
                if st2 == st and limit and table is not None:
                    ticks2 = min(ticks + 1, max(limit))
                else:
                    ticks2 = 0
                step = Step(
                    tuple(fired2),
                    tuple(sends2),
                    report2,
                    tuple(unsafe2),
                    tuple(safe2),
                    first.certain and second.certain,
                    (*first.valuation, *second.valuation),
                    views,
                )
                target = State(
                    command, st2, stat2, ticks2, tuple(new_subs), lost_now, errored, halted
                )
                results.append((step, target))
        return results

    @staticmethod
    def _act(
        rule: RuleView,
        fired: list[str],
        sends: list[tuple[str, str]],
        unsafe: list[str],
        safe: list[str],
        fixed: dict[Key, Any],
    ) -> None:
        fired.append(rule.id)
        for sub, cmd in rule.sends:
            sends.append((sub, cmd))
            fixed[("command", sub)] = cmd  # the local copy a later guard reads
        for name, is_safe in rule.actuators:
            (safe if is_safe else unsafe).append(name)


def explore(model: Model, start: State | None = None, limit: int = LIMIT) -> Graph:
    """Every state reachable from `start` (the initial state), breadth first."""
    first = start or model.initial()
    graph = Graph(model.sk, first)
    graph.parent[first] = None
    todo = deque([first])
    while todo:
        s = todo.popleft()
        found = model.successors(s)
        graph.edges[s] = found
        for _, t in found:
            if t not in graph.parent:
                if len(graph.parent) >= limit:
                    graph.complete = False
                    return graph
                graph.parent[t] = (s, _)
                todo.append(t)
    return graph
