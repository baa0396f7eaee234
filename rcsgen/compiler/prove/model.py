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

from ...runtime.contract import NO_COMMAND_NAME
from ..analysis.solver import Key
from .adapter import DONE, ERROR, EXECUTING, NOT_READY, Choice, RuleView, Skeleton
from .lost import RuntimeReaction

NOP = "NOP"
TAKEN = 2  # a subordinate's third item: its DONE already gone on on (truthy, like True)
LEFT = 3  # the same: its answer awaited by a state left on an interrupt, never re-commanded
LIMIT = 400_000  # the most states one model may have; more is "too large" (undecided)


class _StateFields(NamedTuple):
    command: str | None  # None: no command yet
    state: str  # table state, or NOP
    status: str
    ticks: int  # cycles in the state (capped at its largest `after:`), 0 when untimed
    # per subordinate: (last sent, status read, sent during the current command); the
    # third is TAKEN (truthy) once a table rule has gone on on that command's DONE
    subs: tuple[tuple[str | None, str, bool], ...]
    lost: tuple[str, ...] = ()
    errored: bool = False  # a subordinate answered ERROR during the current command
    halted: bool = False  # the current command from above is HALT
    # actuator fields it writes that the runtime latched safe (a loss): held until an
    # explicit reset, whatever it sets - a recovery or a new command does not release them
    latched: frozenset[str] = frozenset()


class State(_StateFields):
    """A model state: its fields (`_StateFields`), hashed once. The explorer and every
    property look states up in sets and dicts tens of thousands of times per model; a tuple
    hashes its nested fields again on every lookup, this remembers the same value."""

    def __hash__(self) -> int:
        try:
            return self.__dict__["_hash"]  # type: ignore[no-any-return]
        except KeyError:
            found = self.__dict__["_hash"] = tuple.__hash__(self)
            return found

    def __reduce__(self) -> tuple[type[State], tuple[Any, ...]]:
        # rebuilt from its fields alone: a remembered hash is this process's (str hashes
        # are salted per process), never to be carried into another by pickle or copy
        return (State, tuple(self))


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
    recovered: str | None = None  # a lost process back before this cycle
    reset: bool = False  # the operator's explicit reset (`ctl reset`) released the latches
    # subordinates whose DONE the table rule that fired read, when that DONE was already
    # taken by an earlier rule of this command, or answers a command of an earlier one
    stale: tuple[str, ...] = ()


# A NamedTuple's own `__new__` is a Python function around this: the explorer makes tens of
# thousands of edges and states per model, each made directly (every field given, in order).
_new = tuple.__new__
_NONE_FIRES = (Choice(None, True, ()),)  # no rule to try: none fires, certainly


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
    stale: tuple[str, ...] = ()


@dataclass
class Graph:
    """The reachable states and their transitions."""

    skeleton: Skeleton
    initial: State
    edges: dict[State, list[tuple[Edge, State]]] = field(default_factory=dict)
    parent: dict[State, tuple[State, Edge] | None] = field(default_factory=dict)
    complete: bool = True  # False: LIMIT states reached, exploration stopped
    # what the checks derive from the finished graph and share (properties.py), by name
    derived: dict[str, Any] = field(default_factory=dict)

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
        reaction: RuntimeReaction,
        new_commands: bool = True,
    ) -> None:
        self.sk = skeleton
        self.contracts = contracts
        self.reaction = reaction
        self.lossy = reaction.candidates(skeleton.name) if skeleton.subs else ()
        self.effects = {p: reaction.effect(skeleton.name, p) for p in self.lossy}
        self.new_commands = new_commands
        self.sub_index = {s: i for i, s in enumerate(skeleton.subs)}
        self.sub_process = tuple(reaction.process_of(s) for s in skeleton.subs)
        self.writes = frozenset(skeleton.actuators)
        self._news_seen: set[Any] = set()
        self._steps: dict[Any, list[tuple[Step, State]]] = {}
        self._lost: dict[tuple[str, ...], tuple[frozenset[str], tuple[int, ...]]] = {}

    def initial(self) -> State:
        return State(None, NOP, NOT_READY, 0, tuple((None, NOT_READY, False) for _ in self.sk.subs))

    def lost_effects(self, lost: tuple[str, ...]) -> tuple[frozenset[str], tuple[int, ...]]:
        """While the processes `lost` are lost: the actuator fields it writes that their
        losses latch safe, and the subordinates (by index) whose status reads ERROR
        (`on_lost: continue`)."""
        found = self._lost.get(lost)
        if found is None:
            latched: set[str] = set()
            told: set[int] = set()
            for process in lost:
                effect = self.effects[process]
                latched |= effect.latched & self.writes
                told |= {self.sub_index[sub] for sub in effect.errors}
            found = self._lost[lost] = (frozenset(latched), tuple(sorted(told)))
        return found

    # ------------------------------------------------------------ one cycle

    def successors(self, s: State) -> list[tuple[Edge, State]]:
        """Every cycle from `s`: a loss that puts the controller in its safe state; or the
        subordinates' answers with a contained loss or a recovery (each combination); each
        with or without a new command from above, then the controller's own cycle."""
        out: list[tuple[Edge, State]] = []
        if s.latched:  # the operator's explicit reset, any cycle after a latch
            out += self._reset(s)
        events, halts = self._losses(s)
        options = []
        for index, (sent, view, _) in enumerate(s.subs):
            if view == EXECUTING and sent is not None and self.sub_process[index] not in s.lost:
                options.append((None, *self.contracts[self.sk.subs[index]].of(sent)))
            else:
                options.append((None,))
        for answers in product(*options):
            subs = [
                (sent, view if answer is None else answer, fresh)
                for (sent, view, fresh), answer in zip(s.subs, answers, strict=True)
            ]
            answered = tuple((self.sk.subs[i], a) for i, a in enumerate(answers) if a is not None)
            errored = s.errored or any(a == ERROR and s.subs[i][2] for i, a in enumerate(answers))
            for lost, recovered in events:
                out += self._environment(s, subs, answered, errored, lost, recovered)
        for process in halts:  # last: the shortest runs show a loss only where it matters
            out += self._safe_state(s, process)
        return out

    def _losses(self, s: State) -> tuple[list[tuple[str | None, str | None]], list[str]]:
        """The environment's process events from `s`: (lost, recovered) pairs - none, a
        contained loss, a recovery - and the losses that put it in its safe state."""
        events: list[tuple[str | None, str | None]] = [(None, None)]
        halts = []
        for process in self.lossy:
            if process in s.lost:
                events.append((None, process))
            elif self.effects[process].safe_state:
                halts.append(process)
            elif self.effects[process].errors:
                events.append((process, None))
        return events, halts

    def _safe_state(self, s: State, process: str) -> list[tuple[Edge, State]]:
        """`process` is lost and the runtime puts the controller in its safe state (HALT to
        every subordinate, NOP, ERROR with reason LOST), whatever was answered; every
        actuator of the system is latched safe until an explicit reset (the ones it writes
        are kept in the state). The loss itself is not kept: until the process is back
        nothing below answers, which the model already allows (an answer may come any
        cycle later), and after it the hierarchy goes on from here."""
        told = self.lost_effects(s.lost)[1]  # still read as ERROR (LOST) while lost
        subs = tuple(("HALT", ERROR if i in told else EXECUTING, True) for i in range(len(s.subs)))
        latched = s.latched | (self.effects[process].latched & self.writes)
        env = ((), process, None, True, tuple((sub, "HALT") for sub in self.sk.subs), False)
        pre = (s.command, NOP, ERROR, 0, subs, s.lost, s.errored, s.halted, latched)
        return self._edges(env, None, pre) + self._news(env, subs, s.lost, latched)

    def _reset(self, s: State) -> list[tuple[Edge, State]]:
        """The operator resets the latches (`ctl reset`, docs/semantics.md "Fail safe"):
        the fields it writes are its own again from this cycle - even while a process is
        still lost: `override.reset` releases every SAFE latch, and the reaction runs again
        only on a new fault (a loss, a watchdog trip)."""
        latched: frozenset[str] = frozenset()
        env = ((), None, None, False, (), True)
        pre = (s.command, s.state, s.status, s.ticks, s.subs, s.lost, s.errored, s.halted, latched)
        return self._edges(env, None, pre) + self._news(env, s.subs, s.lost, latched)

    def _environment(
        self,
        s: State,
        subs_in: list[tuple[str | None, str, bool]],
        answered: tuple[tuple[str, str], ...],
        errored: bool,
        lost: str | None,
        recovered: str | None,
    ) -> list[tuple[Edge, State]]:
        """A contained loss or a recovery, then the cycle without and with a new command."""
        subs = list(subs_in)
        lost_now = s.lost
        if lost is not None:
            lost_now = tuple(sorted({*s.lost, lost}))
        if recovered is not None:  # its subordinates answer again (a new command, or the old)
            lost_now = tuple(p for p in s.lost if p != recovered)
            for sub in self.effects[recovered].errors:
                i = self.sub_index[sub]
                sent, _, fresh = subs[i]
                subs[i] = (sent, NOT_READY if sent is None else EXECUTING, fresh)
        latched_now, told = self.lost_effects(lost_now)
        for i in told:  # read as ERROR (LOST) while lost
            errored = errored or subs[i][2]
            subs[i] = (subs[i][0], ERROR, subs[i][2])
        latched = s.latched | latched_now  # a recovery releases nothing: a reset does
        env = (answered, lost, recovered, False, (), False)
        frozen = tuple(subs)
        pre = (s.command, s.state, s.status, s.ticks, frozen, lost_now, errored, s.halted, latched)
        return self._edges(env, None, pre) + self._news(env, frozen, lost_now, latched)

    def _news(
        self,
        env: tuple[Any, ...],
        subs: tuple[tuple[str | None, str, bool], ...],
        lost: tuple[str, ...],
        latched: frozenset[str],
    ) -> list[tuple[Edge, State]]:
        """A new command from above (check_if_new_command): it leads to the same states
        from every state with these subordinates' commands and statuses, so its edges are
        taken once. A new command releases no latch."""
        key = (tuple((sent, view) for sent, view, _ in subs), lost, latched)
        if not self.new_commands or key in self._news_seen:
            return []
        self._news_seen.add(key)
        fresh = tuple((sent, view, False) for sent, view, _ in subs)
        out: list[tuple[Edge, State]] = []
        for new in self.sk.commands:
            out += self._edges(
                env, new, (new, "S0", EXECUTING, 0, fresh, lost, False, new == "HALT", latched)
            )
        return out

    def _edges(
        self, env: tuple[Any, ...], new: str | None, pre: tuple[Any, ...]
    ) -> list[tuple[Edge, State]]:
        answered, lost, recovered, safe_state, pre_sends, reset = env
        steps = self._steps.get(pre)
        if steps is None:
            steps = self._steps[pre] = self._step(*pre)
        return [
            (
                _new(
                    Edge,
                    (
                        new,
                        answered,
                        lost,
                        safe_state,
                        step.rules,
                        (*pre_sends, *step.sends) if pre_sends else step.sends,
                        step.report,
                        step.unsafe,
                        step.safe,
                        step.certain,
                        step.valuation,
                        step.views,
                        recovered,
                        reset,
                        step.stale,
                    ),
                ),
                target,
            )
            for step, target in steps
        ]

    def _fixed(self, subs: tuple[tuple[str | None, str, bool], ...], ticks: int) -> dict[Key, Any]:
        """The atoms a cycle fixes: each subordinate's status and last command, the time."""
        fixed: dict[Key, Any] = {("time", "ticks"): ticks}
        for sub, (sent, view, _) in zip(self.sk.subs, subs, strict=True):
            fixed[("status", sub)] = view
            fixed[("command", sub)] = sent if sent is not None else NO_COMMAND_NAME
        return fixed

    def _step(
        self,
        command: str | None,
        state: str,
        status: str,
        ticks: int,
        subs: tuple[tuple[str | None, str, bool], ...],
        lost_now: tuple[str, ...],
        errored: bool,
        halted: bool,
        latched: frozenset[str],
    ) -> list[tuple[Step, State]]:
        """The controller's own cycle from a state the environment has set: its every_cycle
        rules, then its table (each way the guards can go)."""
        views = tuple([view for _, view, _ in subs])
        fixed = self._fixed(subs, ticks)
        results: list[tuple[Step, State]] = []
        every = self.sk.every
        every_choices = self.sk.choices(every, fixed) if every else _NONE_FIRES
        for first in every_choices:
            done = _Acts()
            st, stat = state, status
            local_fixed = dict(fixed)
            if first.rule is not None:
                rule = every[first.rule]
                done.act(rule, local_fixed)
                if rule.report:
                    done.report, st, stat = rule.report, NOP, rule.report
            table = None
            if command is not None and st != NOP and stat == EXECUTING:
                table = self.sk.tables.get(command, {}).get(st)
            table_choices = self.sk.choices(table, local_fixed) if table else _NONE_FIRES
            for second in table_choices:
                acts = done.copy()
                st2, stat2 = st, stat
                new_subs = list(subs)
                stale: tuple[str, ...] = ()
                if table is not None and second.rule is not None:
                    st2, stat2, stale = self._fire(
                        table[second.rule], acts, local_fixed, st, stat, new_subs
                    )
                    if st2 not in (st, NOP):
                        _leave(table, table[second.rule], self.sk.subs, new_subs)
                for sub, cmd in acts.sends:
                    new_subs[self.sub_index[sub]] = (cmd, EXECUTING, True)
                limit = self.sk.timers.get((command, st2), ()) if command else ()
                timed = st2 == st and limit and table is not None
                step = _new(
                    Step,
                    (
                        tuple(acts.fired),
                        tuple(acts.sends),
                        acts.report,
                        tuple([n for n in acts.unsafe if n not in latched]),
                        tuple(acts.safe),
                        first.certain and second.certain,
                        (*first.valuation, *second.valuation),
                        views,
                        stale,
                    ),
                )
                target = _new(
                    State,
                    (
                        command,
                        st2,
                        stat2,
                        min(ticks + 1, max(limit)) if timed else 0,
                        tuple(new_subs),
                        lost_now,
                        errored,
                        halted,
                        latched,
                    ),
                )
                results.append((step, target))
        return results

    def _fire(
        self,
        rule: RuleView,
        acts: _Acts,
        fixed: dict[Key, Any],
        state: str,
        status: str,
        subs: list[tuple[str | None, str, bool]],
    ) -> tuple[str, str, tuple[str, ...]]:
        """The table rule that fires: its actions into `acts`; (state, status, stale DONEs)."""
        acts.act(rule, dict(fixed))
        if rule.report:
            acts.report, state, status = rule.report, NOP, rule.report
        elif rule.next_state is not None:
            state = rule.next_state
        return state, status, self._taken(rule, subs)

    def _taken(self, rule: RuleView, subs: list[tuple[str | None, str, bool]]) -> tuple[str, ...]:
        """A table rule fired reading these subordinates' DONE: each is taken (in `subs`).
        When it goes on (to another state, or reports): the ones whose DONE was stale - one
        an earlier rule of this command went on on, or the answer to a command sent before
        this command began - and a last "" when it read a new DONE too (else ())."""
        read, stale = [], []
        for i, sub in enumerate(self.sk.subs):
            sent, view, fresh = subs[i]
            if view != DONE or sent is None or ("sub_status", sub) not in rule.reads:
                continue
            read.append(sub)
            if fresh in (TAKEN, LEFT) or not fresh:
                stale.append(sub)
            subs[i] = (sent, view, TAKEN)  # type: ignore[assignment]
        goes_on = rule.report is not None or rule.next_state is not None
        if not goes_on or not stale:
            return ()
        return tuple(stale) if stale == read else (*stale, "")  # "": a new DONE read too


def _leave(
    table: list[RuleView],
    rule: RuleView,
    names: tuple[str, ...],
    subs: list[tuple[str | None, str, bool]],
) -> None:
    """A state is left on an interrupt (`rule` reads no subordinate's status: a world
    condition, a timer): the commands of this command its other rules awaited and that
    were neither answered and taken nor sent anew are LEFT - their DONE, when it comes, is
    the answer to the abandoned wait, not to anything a later state waits for."""
    if any(kind == "sub_status" for kind, _ in rule.reads):
        return
    sent_to = {sub for sub, _ in rule.sends}
    for i, name in enumerate(names):
        sent, view, fresh = subs[i]
        if fresh is not True or name in sent_to or view not in (EXECUTING, DONE):
            continue
        if any(("sub_status", name) in other.reads for other in table):
            subs[i] = (sent, view, LEFT)  # type: ignore[assignment]


@dataclass
class _Acts:
    """What the rules that fired in one cycle did, in order."""

    fired: list[str] = field(default_factory=list)
    sends: list[tuple[str, str]] = field(default_factory=list)
    unsafe: list[str] = field(default_factory=list)
    safe: list[str] = field(default_factory=list)
    report: str | None = None

    def copy(self) -> _Acts:
        return _Acts(
            list(self.fired), list(self.sends), list(self.unsafe), list(self.safe), self.report
        )

    def act(self, rule: RuleView, fixed: dict[Key, Any]) -> None:
        self.fired.append(rule.id)
        for sub, cmd in rule.sends:
            self.sends.append((sub, cmd))
            fixed[("command", sub)] = cmd  # the local copy a later guard reads
        for name, is_safe in rule.actuators:
            (self.safe if is_safe else self.unsafe).append(name)


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
