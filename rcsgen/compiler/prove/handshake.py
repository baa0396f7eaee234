"""Handshake: the command-number handshake's invariant, proven by induction with z3.

The numbers are unbounded, so an explicit search cannot cover them; z3 (the optional extra
`rcsgen[prove]`) does. The transition relation is the generated code's (docs/semantics.md
section 3, templates/controller.py.j2): the supervisor's send (`<sub>_command_num += 1`, then
post_process numbering it after an operator's command that came meanwhile), an operator's
override (`ctl send --override`), the subordinate's cycle (a number unlike its echo is a new
command: echo it, EXECUTING; else it may report DONE or ERROR) and the supervisor's read
(EXECUTING until the echo of the last number sent). The invariant - the echo never runs
ahead of the command buffer, the supervisor's last number is what the buffer holds or less,
and the number of a new send is above every echo so far - is checked to hold initially and
to be kept by every transition; so a stale DONE (an echo of an older number) is never read
as the answer to the last command.
"""

from __future__ import annotations

from typing import Any

EXTRA = "rcsgen[prove]"


def z3_or_none() -> Any:
    """The z3 module, or None without the extra (the prover's one import of it)."""
    try:
        import z3
    except ImportError:
        return None
    return z3


def prove_handshake(renumber: bool = True) -> tuple[bool | None, str]:
    """(True, how) when the invariant is proven, (False, the counter-example) when a
    transition breaks it, (None, why) when z3 is not installed. `renumber=False` proves
    the protocol without post_process's numbering after an operator's command (a test's
    seeded bug: it must fail)."""
    z3 = z3_or_none()
    if z3 is None:
        return None, f"the handshake invariant needs z3: install {EXTRA} (z3-solver)"
    b, w, sent, e, s = z3.Ints("buffer written sent echo status")
    b2, w2, sent2, e2, s2 = z3.Ints("buffer2 written2 sent2 echo2 status2")
    executing, done, error = 1, 2, 3

    def inv(b: Any, w: Any, sent: Any, e: Any, s: Any) -> Any:
        return z3.And(
            e <= b,
            w == sent,
            sent <= b,
            e >= 0,
            z3.Or(s == executing, s == done, s == error, s == 0),
        )

    local = sent + 1  # the send: `<sub>_command_num += 1` ...
    numbered = z3.If(b != w, b + 1, local) if renumber else local  # post_process
    send = z3.And(sent2 == numbered, b2 == numbered, w2 == numbered, e2 == e, s2 == s)
    operator = z3.And(b2 == b + 1, w2 == w, sent2 == sent, e2 == e, s2 == s)
    sub_new = z3.And(b != e, e2 == b, s2 == executing, b2 == b, w2 == w, sent2 == sent)
    sub_same = z3.And(
        b == e, e2 == e, z3.Or(s2 == s, s2 == done, s2 == error), b2 == b, w2 == w, sent2 == sent
    )
    step = z3.Or(send, operator, sub_new, sub_same)
    solver = z3.Solver()
    # initially: every number 0, NOT_READY
    solver.push()
    solver.add(z3.Not(inv(z3.IntVal(0), z3.IntVal(0), z3.IntVal(0), z3.IntVal(0), z3.IntVal(0))))
    if solver.check() != z3.unsat:
        return False, "the initial state breaks the invariant"
    solver.pop()
    # kept by every transition
    solver.add(inv(b, w, sent, e, s), step, z3.Not(inv(b2, w2, sent2, e2, s2)))
    if solver.check() != z3.unsat:
        return False, f"a transition breaks the invariant: {solver.model()}"
    # a new send's number is above every echo: the old answer reads EXECUTING
    fresh = z3.Solver()
    fresh.add(inv(b, w, sent, e, s), send, z3.Not(e2 < sent2))
    if fresh.check() != z3.unsat:
        return False, f"a send can be numbered like an old echo: {fresh.model()}"
    return True, "the handshake invariant holds for unbounded command numbers (z3, by induction)"
