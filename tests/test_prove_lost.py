"""`rcsgen prove`'s lost processes (rcsgen/compiler/prove/lost.py): the layout the runtime's
`reaction` reads, rebuilt from the IR; which processes below a supervisor its model loses
(never its own); and what each loss does to it - the safe state under `halt_all`, the
subordinate read as ERROR under `on_lost: continue`, the actuators latched safe. On a
three-level system split over two processes, top and sub in p, leaf in q."""

from __future__ import annotations

from pathlib import Path

import test_prove_catalogue as catalogue

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove.adapter import skeleton
from rcsgen.compiler.prove.lost import Effect, RuntimeReaction, layout_view
from rcsgen.compiler.prove.model import Model

SYSTEM = """\
system: three
title: Three levels over two processes
cycle_period: 0.1
world:
  pos: {type: float, initial: 0.0}
  drive: {type: float, initial: 0.0, actuator: true, safe: 0.0}
  lamp: {type: bool, initial: false, actuator: true, safe: false}
processes:
  p:
    modules: [top, sub]
  q:
    modules: [leaf]
"""
TOP = catalogue.TOP + catalogue.WAITS
SUB = """\
controller: sub
title: Sub
subordinates: [leaf]
world:
  writes: [drive]
commands:
  MOVE:
    states:
      S0:
        - do: [{set: {world.drive: 1.0}}, send: leaf.LIGHT]
          next: S1
      S1:
        - when: leaf.status == DONE
          do: [{set: {world.drive: 0.0}}, {report: DONE}]
        - when: leaf.status == ERROR
          do: [{set: {world.drive: 0.0}}, {report: ERROR}]
"""
LEAF = """\
controller: leaf
title: Leaf
world:
  reads: [pos]
  writes: [lamp]
commands:
  LIGHT:
    states:
      S0:
        - do: [{set: {world.lamp: true}}, {report: DONE}]
"""


def reaction_of(directory: Path, sub: str = SUB) -> tuple[object, RuntimeReaction]:
    directory.mkdir()
    for name, text in (("system", SYSTEM), ("top", TOP), ("sub", sub), ("leaf", LEAF)):
        (directory / f"{name}.yaml").write_text(text)
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    return system, RuntimeReaction(system)


def test_the_layout_as_the_runtime_reads_it(tmp_path: Path) -> None:
    system, _ = reaction_of(tmp_path / "three")
    view = vars(layout_view(system))
    assert view["PLACEMENT"] == {"top": "p", "sub": "p", "leaf": "q"}
    assert view["SUBORDINATES"] == {"top": ("sub",), "sub": ("leaf",), "leaf": ()}
    assert view["ON_LOST_CONTINUE"] == {}
    assert sorted(view["MODULES"]) == ["leaf", "sub", "top"]
    assert view["SAFE_VALUES"] == {"drive": 0.0, "lamp": False}
    assert view["ACTUATED_BY"] == {"drive": "p", "lamp": "q"}
    assert view["SIMULATORS"] == ()


def test_the_losses_a_supervisor_plays_are_the_other_processes_below_it(tmp_path: Path) -> None:
    _, reaction = reaction_of(tmp_path / "three")
    assert reaction.subtree("top") == ["top", "sub", "leaf"]
    assert reaction.process_of("sub") == "p" and reaction.process_of("nobody") is None
    # sub runs in top's own process: only q's loss is played, never p's (its own)
    assert reaction.candidates("top") == ("q",)
    assert reaction.candidates("sub") == ("q",)
    assert reaction.candidates("leaf") == ()


def test_under_halt_all_every_supervisor_above_goes_safe(tmp_path: Path) -> None:
    _, reaction = reaction_of(tmp_path / "three")
    every = frozenset({"drive", "lamp"})
    assert reaction.effect("top", "q") == Effect(True, (), every)
    assert reaction.effect("sub", "q") == Effect(True, (), every)


def test_under_on_lost_continue_the_loss_is_contained(tmp_path: Path) -> None:
    contained = SUB.replace(
        "subordinates: [leaf]\n", "subordinates: [leaf]\non_lost: {leaf: continue}\n"
    )
    system, reaction = reaction_of(tmp_path / "three", contained)
    assert vars(layout_view(system))["ON_LOST_CONTINUE"] == {"sub": ("leaf",)}
    # sub reads leaf as ERROR (LOST); only q's actuator is latched; nobody goes safe
    assert reaction.effect("sub", "q") == Effect(False, ("leaf",), frozenset({"lamp"}))
    assert reaction.effect("top", "q") == Effect(False, (), frozenset({"lamp"}))


def test_two_processes_lost_together_read_every_contained_subordinate_as_error(
    tmp_path: Path,
) -> None:
    """Model.lost_effects: leaf in q and leaf2 in r, both `on_lost: continue` under sub; with
    q and r lost at once sub reads both as ERROR (each loss adds its own), none latched."""
    directory = tmp_path / "four"
    directory.mkdir()
    texts = {
        "system": SYSTEM.replace("[leaf]\n", "[leaf]\n  r:\n    modules: [leaf2]\n"),
        "top": TOP,
        "sub": SUB.replace(
            "[leaf]\n", "[leaf, leaf2]\non_lost: {leaf: continue, leaf2: continue}\n"
        )
        .replace("send: leaf.LIGHT]", "send: leaf.LIGHT, send: leaf2.LIGHT]")
        .replace("leaf.status == DONE", "leaf.status == DONE and leaf2.status == DONE")
        .replace("leaf.status == ERROR", "leaf.status == ERROR or leaf2.status == ERROR"),
        "leaf": LEAF,
        "leaf2": LEAF.replace("leaf", "leaf2")
        .replace("  writes: [lamp]\n", "")
        .replace("{set: {world.lamp: true}}, ", ""),
    }
    for name, text in texts.items():
        (directory / f"{name}.yaml").write_text(text)
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    system = front.systems[0]
    controller = next(c for c in system.controllers if c.name == "sub")
    sk = skeleton(system, controller, frozenset({"drive", "lamp"}))
    model = Model(sk, {}, RuntimeReaction(system))
    assert sk.subs == ("leaf", "leaf2") and model.lossy == ("q", "r")
    assert model.lost_effects(("q",)) == (frozenset(), (0,))
    assert model.lost_effects(("q", "r")) == (frozenset(), (0, 1))
