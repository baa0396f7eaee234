"""The HALT and ERROR bounds as `rcsgen prove` prints them (rcsgen/tools/prove_report.py
`bounds_text`), from bounds made by hand, in the unit tier: one block per root that has
subordinates, each leaf's cycle k and the cycle its actuators are safe, `never` for a bound
not reached and `-` for none, the path, and where an ERROR stops. test_prove_text reads the
same lines from real proofs (z3, slower)."""

from __future__ import annotations

from types import SimpleNamespace

from rcsgen.compiler.prove import INFINITE
from rcsgen.compiler.prove.system import Bound
from rcsgen.tools.prove_report import bounds_text


def test_each_roots_halt_bounds_and_each_leafs_error_bound_are_one_line_each() -> None:
    halt = [
        Bound("sup", "arm", 3, ("sup", "exe", "arm"), safe=4),
        Bound("sup", "pln", INFINITE, ("sup", "pln")),
        Bound("lone", "lone", 0, ("lone",), safe=0),  # a root alone: no block of its own
        Bound("cc", "helm", 12, ("cc", "helm"), safe=None),
    ]
    error = [
        Bound("arm", "arm", 2, ("arm", "exe", "sup")),
        Bound("pln", "pln", INFINITE, ("pln", "sup"), blocked="exe"),
    ]
    lines = bounds_text(SimpleNamespace(halt=halt, error=error))  # type: ignore[arg-type]
    assert lines == [
        "  HALT given to cc reaches (cycle k; actuators safe by cycle):",
        "    helm     k=12     safe=-      via cc > helm",
        "  HALT given to sup reaches (cycle k; actuators safe by cycle):",
        "    arm      k=3      safe=4      via sup > exe > arm",
        "    pln      k=never  safe=-      via sup > pln",
        "  ERROR of a leaf reaches its root (cycle d):",
        "    arm      d=2      via arm > exe > sup",
        "    pln      d=never  via pln > sup (stops at exe)",
    ]


def test_no_bounds_no_lines() -> None:
    lone = [Bound("lone", "lone", 0, ("lone",))]
    assert bounds_text(SimpleNamespace(halt=lone, error=[])) == []  # type: ignore[arg-type]


def test_a_hop_is_a_cycle_per_process_crossed_and_one_more_per_host() -> None:
    """system.hop, the cycles a bound counts per link: 0 to a module run after the sender
    in its process, 1 to one run before it or in another process (or not placed), one more
    only where a deployment puts the two processes on different hosts."""
    from rcsgen.compiler.prove.system import hop

    place = {"sup": ("a", 0), "arm": ("a", 1), "pln": ("b", 0), "exe": ("c", 0)}
    hosts = {"a": "pc1", "b": "pc1", "c": "pc2"}
    assert [hop(place, "sup", r, {}) for r in ("arm", "pln", "exe", "nowhere")] == [0, 1, 1, 1]
    assert hop(place, "arm", "sup", {}) == 1
    assert [hop(place, "sup", r, hosts) for r in ("arm", "pln", "exe")] == [0, 1, 2]
    assert hop(place, "exe", "sup", hosts) == 2


def test_each_module_is_placed_in_its_process_at_its_place_in_the_lockstep_order() -> None:
    """adapter.placement, what hop reads: (process, position), counted from 0 across the
    processes in the order system.yaml lists them."""
    from rcsgen.compiler.prove.adapter import placement

    processes = [
        SimpleNamespace(name="a", modules=["top", "sub"]),
        SimpleNamespace(name="b", modules=["arm"]),
    ]
    assert placement(SimpleNamespace(processes=processes)) == {  # type: ignore[arg-type]
        "top": ("a", 0),
        "sub": ("a", 1),
        "arm": ("b", 2),
    }
