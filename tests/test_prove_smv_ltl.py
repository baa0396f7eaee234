"""`rcsgen prove --export smv`'s properties (rcsgen/tools/prove_smv.py) as LTL, in the unit
tier: each kind of atom as the DEFINE it names, `not`/`and`/`or` and the constants, an
invariant (after every cycle but the safe state's) and a response within k cycles (ended by
the runtime's cycles and by a new command), each written out for a property made by hand.
test_prove runs the export on real proofs."""

from __future__ import annotations

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.ir import IRPropAtom, IRProperty, IRPropExpr, PropKind
from rcsgen.tools.prove_smv import _set, ltl


def atom(kind: PropKind, module: str, value: str) -> IRPropExpr:
    return IRPropExpr("atom", IRPropAtom(kind, module, value))


def prop(then: IRPropExpr, whenever: IRPropExpr | None = None, within: int = 0) -> IRProperty:
    return IRProperty("p", "sup", Span("sup.yaml"), "as written", then, whenever, within)


def test_each_atom_is_the_define_it_names() -> None:
    shown = {
        PropKind.STATE: ("sup", "S1", "state_S1"),
        PropKind.COMMAND: ("sup", "RUN", "command_RUN"),
        PropKind.STATUS: ("sup", "DONE", "status_DONE"),
        PropKind.SUB_STATUS: ("arm", "ERROR", "arm_status_ERROR"),
        PropKind.SUB_COMMAND: ("arm", "MOVE", "arm_command_MOVE"),
        PropKind.SENT: ("arm", "HALT", "sent_arm_HALT"),
        PropKind.WRITES: ("", "world.speed", "writes_world_speed"),
    }
    for kind, (module, value, define) in shown.items():
        assert ltl(prop(atom(kind, module, value))) == f"G ((c != 0 & !safe_state) -> {define})"


def test_conditions_and_responses_keep_proves_meaning() -> None:
    done = atom(PropKind.STATUS, "sup", "DONE")
    err = atom(PropKind.SUB_STATUS, "arm", "ERROR")
    both = IRPropExpr("and", args=(done, IRPropExpr("not", args=(err,))))
    either = IRPropExpr("or", args=(done, IRPropExpr("true"), IRPropExpr("false")))
    assert ltl(prop(both)) == "G ((c != 0 & !safe_state) -> (status_DONE & !(arm_status_ERROR)))"
    assert ltl(prop(either)) == "G ((c != 0 & !safe_state) -> (status_DONE | TRUE | FALSE))"
    assert ltl(prop(done, err)) == "G ((c != 0 & !runtime & arm_status_ERROR) -> status_DONE)"
    assert ltl(prop(done, err, 1)) == (
        "G ((c != 0 & !runtime & arm_status_ERROR) -> "
        "(status_DONE | X (runtime | new_command | status_DONE)))"
    )
    assert ltl(prop(done, err, 3)) == (
        "G ((c != 0 & !runtime & arm_status_ERROR) -> (status_DONE | X (runtime | new_command"
        " | status_DONE | X (runtime | new_command | status_DONE | X (runtime | new_command"
        " | status_DONE)))))"
    )


def test_a_set_of_cycles_is_written_as_smv_reads_it() -> None:
    assert _set([3, 1, 2]) == "{3, 1, 2}"
    assert _set([]) == "{0}"  # no cycle: the one before the first
