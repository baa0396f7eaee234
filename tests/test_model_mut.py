"""The input model (front_end/model.py): what a spec leaves out, each default a user gets
when a key is omitted, as the later stages (the reference, the generated code) read it."""

from __future__ import annotations

import textwrap

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.front_end.loader import load_text
from rcsgen.compiler.front_end.model import (
    ControllerSpec,
    Located,
    build_controller,
    build_io,
    build_operators,
    build_properties,
)


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


SYSTEM = """\
    system: s
    title: S
    cycle_period: 0.1
    processes:
      p: {modules: [co]}
      q: {modules: [other]}
    operators:
      segment_group: rcs
    io:
      plc:
        protocol: modbus_tcp
        address: 127.0.0.1:5020
        timeout: 0.5
        process: q
        points:
          on_cmd: {coil: 0}
    """


def test_a_device_s_process_and_the_segment_group_are_kept_where_written() -> None:
    """The optional `process:` of an io device and `operators: {segment_group:}` reach the
    model with their values and where they are written (a later check points there)."""
    data = load_text(textwrap.dedent(SYSTEM), "system.yaml")
    top = Span("system.yaml", 1, 1)
    (plc,) = build_io(data, top).values()
    assert plc.process == Located("q", Span("system.yaml", 14, 14))
    assert build_operators(data, top).segment_group == Located("rcs", Span("system.yaml", 8, 18))


def test_a_property_keeps_its_form_and_an_omitted_doc_is_empty() -> None:
    """`properties:`: an invariant (`always`) or a response (`whenever`, `then`, `within`),
    each part where it is written; a property without `doc:` has an empty one."""
    text = """\
        properties:
          - name: safe
            always: not on
          - name: answers
            doc: Each request is answered.
            whenever: asked
            then: answered
            within: 3
        """
    data = load_text(textwrap.dedent(text), "co.yaml")
    safe, answers = build_properties(data, Span("co.yaml", 1, 1))
    assert (safe.name, safe.doc, safe.span) == (
        Located("safe", Span("co.yaml", 2, 11)),
        "",
        Span("co.yaml", 2, 5),
    )
    assert (safe.always, safe.whenever, safe.then, safe.within) == (
        Located("not on", Span("co.yaml", 3, 13)),
        None,
        None,
        None,
    )
    assert (answers.doc, answers.always, answers.whenever, answers.then, answers.within) == (
        "Each request is answered.",
        None,
        Located("asked", Span("co.yaml", 6, 15)),
        Located("answered", Span("co.yaml", 7, 11)),
        Located(3, Span("co.yaml", 8, 13)),
    )
