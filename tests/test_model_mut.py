"""The input model (front_end/model.py) beyond what compiling a spec shows: the default of
each key a spec leaves out, where each value is written, and durations in each unit."""

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
    duration_in_cycles,
    duration_seconds,
    exact_cycles,
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


def test_a_duration_in_each_unit_is_whole_cycles_rounded_up() -> None:
    """Seconds (a number or `s`), `ms` and `cycles`, at a period: cycles rounded up, at
    least one (a limit is never shorter than asked); a float's noise (0.3 / 0.1) is not a
    cycle more."""
    cases = [(2, 0.5, 4), (0.3, 0.1, 3), ("500 ms", 0.1, 5), ("250 ms", 0.1, 3)]
    cases += [("20 cycles", 0.1, 20), ("1 cycle", 0.1, 1), ("0 s", 0.1, 1), ("1.5 s", 1, 2)]
    cases += [("2s", 0.5, 4), ("1001 ms", 1, 2)]
    assert [duration_in_cycles(value, period) for value, period, _ in cases] == [
        cycles for _, _, cycles in cases
    ]


def test_a_duration_in_seconds_and_in_exact_cycles() -> None:
    """`duration_seconds`: cycles are periods, ms thousandths; `exact_cycles`: rounded up
    (0 stays 0) and whether exact, to one part in a million of the cycles."""
    seconds = [(3, 3.0), ("20 cycles", 2.0), ("500 ms", 0.5), ("2 s", 2.0), (" 1.5 s ", 1.5)]
    assert [
        duration_seconds(value, 0.1 if "cycle" in str(value) else 1) for value, _ in seconds
    ] == [want for _, want in seconds]
    exact = [("20 cycles", 0.1, (20, True)), ("2.5 cycles", 0.1, (3, False))]
    exact += [(0.3, 0.1, (3, True)), ("250 ms", 0.1, (3, False)), (0, 0.1, (0, True))]
    exact += [("1000 ms", 0.3, (4, False)), (1000.0000001, 1, (1000, True))]
    exact += [(1.0000015, 1, (2, False))]
    assert [exact_cycles(value, period) for value, period, _ in exact] == [
        want for _, _, want in exact
    ]
