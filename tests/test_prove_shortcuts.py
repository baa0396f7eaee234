"""The prover's shortcuts decide as the long way does (rcsgen/compiler/prove: a property
whose monitor never changes checked in one pass over the model instead of a search over
model and monitor; a state's remembered hash; the collector off while proving)."""

from __future__ import annotations

import copy
import gc
import pickle
from dataclasses import replace
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRPropAtom, IRPropExpr, PropKind
from rcsgen.compiler.prove import user
from rcsgen.compiler.prove.model import State
from rcsgen.compiler.prove.system import prove

SPECS = Path(__file__).resolve().parents[1] / "specs"


@pytest.fixture(scope="module")
def submarine():
    front = compile_paths([SPECS / "submarine"])
    system = front.systems[0]
    return system, prove(system, only="sm")


def _run(found):
    return None if found is None else (found.message, found.span, found.trace)


def test_a_property_without_a_monitor_finds_the_searchs_first_violation_and_run(submarine):
    """Invariants and same-cycle responses over every state and subordinate command of
    sm's model (2,055 states): the one pass and the search give the same finding and the
    same shortest run, the deep ones included."""
    system, proof = submarine
    graph = proof.graphs["sm"]
    sk = graph.skeleton
    base = next(p for p in system.properties if p.controller == "sm")
    atoms = [IRPropAtom(PropKind.STATE, "sm", st) for cmd in sk.tables.values() for st in cmd]
    atoms += [IRPropAtom(PropKind.SUB_COMMAND, sub, "HALT") for sub in sk.subs]
    atoms += [IRPropAtom(PropKind.STATUS, "sm", "ERROR")]
    checked, deepest = 0, 0
    for atom in atoms:
        never = IRPropExpr("not", args=(IRPropExpr("atom", atom),))
        for prop in (
            replace(base, whenever=None, then=never),
            replace(base, whenever=IRPropExpr("atom", atom), within=0, then=IRPropExpr("false")),
        ):
            fast, slow = user.check(graph, prop, system), user.search(graph, prop, system)
            assert _run(fast) == _run(slow), (atom, prop.within)
            checked += 1
            deepest = max(deepest, len(fast.trace) if fast else 0)
    assert checked >= 20 and deepest >= 3  # not only first-cycle violations


def test_a_states_remembered_hash_is_tuples_and_never_leaves_the_process():
    s = State("GO", "S1", "EXECUTING", 0, (("MOVE", "EXECUTING", True),))
    assert hash(s) == tuple.__hash__(s)
    assert "_hash" in s.__dict__
    again = pickle.loads(pickle.dumps(s))
    assert again == s and type(again) is State and "_hash" not in again.__dict__
    assert copy.deepcopy(s) == s and s._replace(ticks=1).ticks == 1


@pytest.mark.parametrize("was_on", [True, False])
def test_proving_leaves_the_garbage_collector_as_it_found_it(submarine, was_on):
    system, _ = submarine
    (gc.enable if was_on else gc.disable)()
    try:
        prove(system, only="rudder")
        assert gc.isenabled() is was_on
    finally:
        gc.enable()
