"""`rcsgen prove`'s graph algorithms on graphs made by hand, in the unit tier (no spec, no
solver): the strongly connected components a command can go round in
(rcsgen/compiler/prove/properties.py `_sccs`, which W702 and W703 read) and the worst-case
cycles to a goal (`_worst`, every HALT and ERROR bound): a cycle spent waiting for a
subordinate's answer is the subordinate's time, not the table's, and the bound goes on
through the state's other edges."""

from __future__ import annotations

import itertools
from typing import Any

from rcsgen.compiler.prove.adapter import DONE, EXECUTING, RuleView, Skeleton
from rcsgen.compiler.prove.model import Edge, Graph, State
from rcsgen.compiler.prove.properties import INFINITE, _fair, _sccs, _worst, motion


def state(name: str, subs: tuple[tuple[str | None, str, bool], ...] = ()) -> State:
    return State("GO", name, EXECUTING, 0, subs)


def edge(report: str | None = None, rules: tuple[str, ...] = ()) -> Edge:
    return Edge(None, (), None, False, rules, (), report, (), (), True, (), ())


def test_a_ring_of_three_states_is_one_component_and_a_tail_into_it_is_its_own() -> None:
    """a -> b -> c -> a is one component however deep the walk goes before it closes;
    d, which only leads into the ring, is a component alone."""
    a, b, c, d = (state(n) for n in "abcd")
    succ: dict[State, list[tuple[Edge, State]]] = {
        d: [(edge(), a)],
        a: [(edge(), b)],
        b: [(edge(), c)],
        c: [(edge(), a)],
    }
    found = sorted(sorted(s.state for s in component) for component in _sccs(succ))
    assert found == [["a", "b", "c"], ["d"]]


def _bound(graph: Graph, start: State) -> tuple[int, list[Any]]:
    begin = state("begin")
    graph.parent = {begin: None, start: (begin, edge())}
    return _worst(
        graph,
        [(begin, edge(), start)],
        lambda e: e.report == DONE,
        lambda e: e.report is not None and e.report != DONE,
    )


def test_a_cycle_spent_waiting_for_a_subordinate_is_not_the_tables_and_its_other_edges_count() -> (
    None
):
    """In S1 the controller waits for sub's answer to MOVE (a self-loop while sub executes)
    or, the answer come, reports DONE: two cycles from the start, not INFINITE - the wait
    is sub's time (its own bound), and the edge listed after it is still followed."""
    waiting = state("S1", (("MOVE", EXECUTING, True),))
    graph = Graph(None, waiting)  # type: ignore[arg-type]  # _worst reads no skeleton
    graph.edges = {waiting: [(edge(), waiting), (edge(DONE, ("GO/S1/1",)), state("done"))]}
    cycles, run = _bound(graph, waiting)
    assert cycles == 2
    assert [e.report for e, _ in run] == [None, DONE]
    # the same self-loop while no subordinate is awaited is the table going round for ever
    idle = state("S1")
    graph.edges = {idle: [(edge(), idle), (edge(DONE), state("done"))]}
    assert _bound(graph, idle)[0] == INFINITE


def test_a_new_command_or_a_loss_is_no_cycle_of_the_table_and_its_other_edges_count() -> None:
    """A bound counts the table's own cycles: an edge that brings a new command from above
    or a lost process (listed first here) is not followed, the DONE edge after it is."""
    s1 = state("S1")
    for interrupted in (edge()._replace(new="HALT"), edge()._replace(lost="q")):
        graph = Graph(None, s1)  # type: ignore[arg-type]
        graph.edges = {s1: [(interrupted, state("halted")), (edge(DONE), state("done"))]}
        cycles, run = _bound(graph, s1)
        assert cycles == 2
        assert [(e.new, e.lost, e.report) for e, _ in run] == [
            (None, None, None),
            (None, None, DONE),
        ]


def test_the_run_that_shows_an_unbounded_start_ends_where_it_fails() -> None:
    """The first start that never reaches the goal decides the bound (INFINITE) and its run:
    here it reports ERROR into S2; the run stops there, not carried on through S2's later
    cycles that another start's search came across."""
    begin, s2, s3 = state("begin"), state("S2"), state("S3")
    graph = Graph(None, begin)  # type: ignore[arg-type]
    graph.parent = {begin: None}
    graph.edges = {s3: [(edge(), s2)], s2: [(edge(DONE), state("done"))]}
    failing = edge("ERROR", ("GO/S1/1",))
    cycles, run = _worst(
        graph,
        [(begin, failing, s2), (begin, edge(), s3)],
        lambda e: e.report == DONE,
        lambda e: e.report is not None and e.report != DONE,
    )
    assert cycles == INFINITE
    assert [(e.report, t.state) for e, t in run] == [("ERROR", "S2")]


def test_the_bound_is_the_longest_way_to_the_goal_not_the_first_edge_listed() -> None:
    """S1 can report DONE at once (listed first) or go on to S2 and report there: the bound
    is the worse of the two, three cycles from the start, and the run shows that way."""
    s1, s2 = state("S1"), state("S2")
    graph = Graph(None, s1)  # type: ignore[arg-type]
    graph.edges = {s1: [(edge(DONE), state("done")), (edge(), s2)], s2: [(edge(DONE), s1)]}
    cycles, run = _bound(graph, s1)
    assert cycles == 3
    assert [(e.report, t.state) for e, t in run] == [(None, "S1"), (None, "S2"), (DONE, "S1")]


def test_a_wait_longer_than_pythons_stack_is_bounded_not_an_internal_error() -> None:
    """`after: 6000 cycles` before a HALT makes its actuators safe is a chain of 6000 states
    (one per cycle waited): the bound walks it whole, 6001 cycles, as deep as it is, where a
    recursive walk stopped with RecursionError (an internal error of `rcsgen prove`)."""
    waits = [state(f"S0+{n}") for n in range(6000)]
    graph = Graph(None, waits[0])  # type: ignore[arg-type]
    graph.edges = {s: [(edge(), t)] for s, t in itertools.pairwise(waits)}
    graph.edges[waits[-1]] = [(edge(DONE), state("done"))]
    cycles, run = _bound(graph, waits[0])
    assert cycles == 6001
    assert len(run) == 6001
    assert [t.state for _, t in run[-2:]] == ["S0+5999", "done"]


def view(rid: str, sends: Any = (), actuators: Any = (), world_sets: Any = ()) -> RuleView:
    """A rule made by hand: what it sends, the actuators it sets ((field, safe)), and the
    world fields it sets."""
    return RuleView(
        rid, None, None, "", tuple(sends), None, None, tuple(actuators),  # type: ignore[arg-type]
        world_sets=frozenset(world_sets),
    )  # fmt: skip


def skeleton(name: str, rules: dict[str, Any], subs: Any = (), operator: bool = False) -> Any:
    """A controller made by hand: one state S0 per command, holding the command's rules."""
    tables = {command: {"S0": list(found)} for command, found in rules.items()}
    return Skeleton(
        name, tuple(rules), tuple(subs), tables, [], frozenset(), {}, {}, {}, (), operator
    )


def test_a_motion_command_is_one_that_moves_something_itself_or_below() -> None:
    """motion(): a command that sets an actuator unsafe, or sends one that does, is motion,
    whatever else the same rule does after it (a stop sent after a move, an actuator set
    unsafe before a stop is sent); one that only sets actuators safe and sends stopping
    commands is not. A command that does neither is motion for the checks of W701 (idle:
    it does nothing to stop) but not for the actuators' (idle False), where one that sets a
    world output that is no actuator is. INIT and HALT never are; an operator's are all."""
    sub = skeleton(
        "sub",
        {
            "STOP": [view("STOP/S0/1", actuators=[("drive", True)])],
            "MOVE": [view("MOVE/S0/1", actuators=[("drive", False)])],
            "WAIT": [view("WAIT/S0/1")],
            "NOTE": [view("NOTE/S0/1", world_sets=["note"])],
        },
    )
    top = skeleton(
        "top",
        {
            "GO": [view("GO/S0/1", sends=[("sub", "MOVE"), ("sub", "STOP")])],
            "LAMP": [view("LAMP/S0/1", actuators=[("lamp", False)], sends=[("sub", "STOP")])],
            "PARK": [view("PARK/S0/1", actuators=[("lamp", True)], sends=[("sub", "STOP")])],
            "ASK": [view("ASK/S0/1", sends=[("op", "CHECK")])],
            "INIT": [view("INIT/S0/1", actuators=[("lamp", False)])],
            "HALT": [view("HALT/S0/1", sends=[("sub", "MOVE")])],
        },
        subs=("sub", "op"),
    )
    op = skeleton("op", {"CHECK": [view("CHECK/S0/1")]}, operator=True)
    sk_of = {"top": top, "sub": sub, "op": op}
    assert dict(motion(sk_of)) == {
        ("top", "GO"): True,
        ("top", "LAMP"): True,
        ("top", "PARK"): False,
        ("top", "ASK"): True,
        ("sub", "STOP"): False,
        ("sub", "MOVE"): True,
        ("sub", "WAIT"): True,
        ("sub", "NOTE"): True,
        ("op", "CHECK"): True,
    }
    actuating = motion(sk_of, idle=False)
    assert {key for key, moves in actuating.items() if not moves} == {
        ("top", "PARK"),
        ("sub", "STOP"),
        ("sub", "WAIT"),
    }
    # INIT and HALT never move; a command not in the map is motion unless told otherwise
    assert [actuating["sub", c] for c in ("INIT", "HALT", "SPIN")] == [False, False, True]
    assert [actuating.get(("sub", c)) for c in ("INIT", "HALT", "SPIN")] == [False, False, True]
    assert [actuating.get(("sub", "SPIN"), d) for d in (False, None)] == [False, True]


def test_a_loop_is_fair_only_if_no_subordinate_owes_it_an_answer_and_no_time_runs_out() -> None:
    """_fair: S1 waiting for sub's answer to MOVE, sending nothing, cannot go round for ever
    (sub answers); resending MOVE each cycle it can, and so can a loop where sub is idle in
    one of its states. A single timed state before its `after:` threshold cannot stay (the
    rule fires); at the threshold, or across two states, it can."""
    sk = skeleton("top", {"GO": []}, subs=("sub",))
    busy = (("MOVE", EXECUTING, True),)
    waiting = State("GO", "S1", EXECUTING, 0, busy)
    resend = edge()._replace(sends=(("sub", "MOVE"),))
    assert not _fair(sk, [waiting], [(waiting, edge(), waiting)])
    assert _fair(sk, [waiting], [(waiting, resend, waiting)])
    idle = State("GO", "S2", EXECUTING, 0, (("MOVE", DONE, True),))
    assert _fair(sk, [waiting, idle], [(waiting, edge(), idle), (idle, edge(), waiting)])
    timed = skeleton("top", {"GO": []})
    timed.timers = {("GO", "S1"): (3, 5)}
    early, due = State("GO", "S1", EXECUTING, 4, ()), State("GO", "S1", EXECUTING, 5, ())
    assert not _fair(timed, [early], [(early, edge(), early)])
    assert _fair(timed, [due], [(due, edge(), due)])
    assert _fair(timed, [early, state("S2")], [(early, edge(), state("S2"))])


def test_an_edge_out_of_the_states_asked_about_is_passed_over_and_the_next_one_followed() -> None:
    """_sccs walks only the states it is given: a's edge to `gone` (a state left out,
    listed first) is passed over, its edge to b still followed, so a and b are one
    component."""
    a, b, gone = state("a"), state("b"), state("gone")
    succ: dict[State, list[tuple[Edge, State]]] = {
        a: [(edge(), gone), (edge(), b)],
        b: [(edge(), a)],
    }
    assert [sorted(s.state for s in component) for component in _sccs(succ)] == [["a", "b"]]
