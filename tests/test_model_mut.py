"""The input model (front_end/model.py) of what a spec leaves out: each default a user gets
when a key is omitted, as the later stages (the reference, the generated code) read it."""

from __future__ import annotations

import textwrap

from rcsgen.compiler.front_end.loader import load_text
from rcsgen.compiler.front_end.model import ControllerSpec, build_controller


def controller(text: str) -> ControllerSpec:
    return build_controller(load_text(textwrap.dedent(text), "co.yaml"), "co.yaml")


BARE = """\
    controller: co
    title: Bare
    locals:
      n: {type: int}
      b: {type: bool}
    commands:
      GO:
        params: {x: {type: float}}
        results: {r: {type: int}}
        states:
          S0:
            - do: [report: DONE]
    """


def test_what_a_controller_leaves_out_is_empty_not_made_up() -> None:
    """No `doc:` anywhere: every doc is empty (the reference shows an empty cell), a local
    without `initial:` starts false (0 for a number), with no span of its own."""
    co = controller(BARE)
    go = co.commands["GO"]
    typed = [*co.locals.values(), *go.params.values(), *go.results.values()]
    assert [(t.name, t.doc, t.initial, t.initial_span) for t in typed] == [
        ("n", "", False, None),
        ("b", "", False, None),
        ("x", "", False, None),
        ("r", "", False, None),
    ]
    assert (co.doc, go.doc, go.states["S0"].rules[0].doc) == ("", "", "")
    assert co.hooks_state_on_restart == "refuse"
