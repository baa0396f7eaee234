"""The picture renderers and builders of `rcsgen graph` on small hand-made graphs and specs:
every node shape, edge style and nesting of clusters in DOT and Mermaid as a reader gets
them (tests/test_graph.py checks the miner's pictures), and the corners of the builders."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools import graph
from rcsgen.tools.graph import Cluster, Edge, Graph, Node

REPO = Path(__file__).resolve().parent.parent

EVERY_KIND = Graph(
    "g_order",
    'A "title"',
    "LR",
    nodes=(
        Node("a", ("a", "first"), "controller", "c1", 1),
        Node("b", ("b",), "step", "c2", 9),  # level 9: the fills start again
        Node("s", ("sim",), "simulator", "c1"),
        Node("i", ("in",), "stand_in"),
        Node("st", ("S0 <x>",), "state"),
        Node("f", ("DONE",), "final"),
        Node("o", ("start",), "start"),
        Node("n", ("note",), "note"),
        Node("z", ("odd",), "other"),
    ),
    edges=(
        Edge("a", "b", ("go", "/ x"), "rule"),
        Edge("a", "s", (), "command"),
        Edge("b", "a", ("status",), "status"),
        Edge("s", "i", (), "layout"),
        Edge("i", "a", ("stands in for",), "stand_in"),
        Edge("o", "st", (), "then"),
        Edge("st", "f", (), "weird"),
    ),
    clusters=(Cluster("c1", "outer"), Cluster("c2", "inner", "c1")),
)

DOT = r"""digraph "g_order" {
  rankdir=LR;
  label="A \"title\""; labelloc=t; fontname=Helvetica;
  node [fontname=Helvetica, fontsize=11, color="#555555"];
  edge [fontname=Helvetica, fontsize=9];
  "i" [shape=box, style="filled,dashed", label="in", fillcolor="#ffffff"];
  "st" [shape=ellipse, style="filled", label="S0 <x>", fillcolor="#e8f0fe"];
  "f" [shape=doublecircle, style="filled", label="DONE", fillcolor="#d9ead3"];
  "o" [shape=circle, style="filled", fillcolor="#333333", width=0.2, label=""];
  "n" [shape=note, style="filled", label="note", fillcolor="#fffbe6"];
  "z" [shape=box, style="filled", label="odd", fillcolor="#ffffff"];
  subgraph "cluster_c1" {
    label="outer";
    style="rounded"; color="#999999";
    subgraph "cluster_c2" {
      label="inner";
      style="rounded"; color="#999999";
      "b" [shape=box, style="rounded,filled", label="b", fillcolor="#fdffb6"];
    }
    "a" [shape=box, style="rounded,filled", label="a\nfirst", fillcolor="#ffd6a5"];
    "s" [shape=box, style="rounded,filled,dashed", label="sim", fillcolor="#eeeeee"];
  }
  "a" -> "b" [color="#333333", label="go\l/ x\l"];
  "a" -> "s" [color="#1f6feb", penwidth=1.5];
  "b" -> "a" [color="#2da44e", penwidth=1.5, label="status", constraint=false];
  "s" -> "i" [style=invis];
  "i" -> "a" [style=dashed, color="#888888", label="stands in for"];
  "o" -> "st" [color="#888888"];
  "st" -> "f" [];
}
"""

MERMAID = """\
---
title: "A \\"title\\""
---
flowchart LR
  i[/"in"/]
  st("S0 #lt;x#gt;")
  f((("DONE")))
  o(("start"))
  n>"note"]
  z["odd"]
  subgraph c1["outer"]
    subgraph c2["inner"]
      b["b"]
    end
    a["a<br/>first"]
    s(["sim"])
  end
  a -->|"go<br/>/ x"| b
  a --> s
  b ==>|"status"| a
  s ~~~ i
  i -.->|"stands in for"| a
  o --> st
  st --> f
  classDef final fill:#d9ead3,stroke:#555,color:#111
  class f final
  classDef level1 fill:#ffd6a5,stroke:#555,color:#111
  class a level1
  classDef level9 fill:#fdffb6,stroke:#555,color:#111
  class b level9
  classDef note fill:#fffbe6,stroke:#555,color:#111
  class n note
  classDef other fill:#ffffff,stroke:#555,color:#111
  class z other
  classDef simulator fill:#eeeeee,stroke:#555,color:#111,stroke-dasharray:4 3
  class s simulator
  classDef stand_in fill:#ffffff,stroke:#555,color:#111,stroke-dasharray:4 3
  class i stand_in
  classDef start fill:#ffffff,stroke:#555,color:#111
  class o start
  classDef state fill:#e8f0fe,stroke:#555,color:#111
  class st state
  linkStyle 1 stroke:#1f6feb,stroke-width:1.5px
  linkStyle 4 stroke:#888888
  linkStyle 2 stroke:#2da44e,stroke-width:2px
  linkStyle 5 stroke:#888888
"""


def test_dot_draws_every_kind_of_node_edge_and_nested_cluster() -> None:
    """Shapes and fills per kind (the start dot dark), rule labels left-aligned, status
    edges of an order picture left out of the ranking, layout edges invisible."""
    assert graph.to_dot(EVERY_KIND) == DOT
    assert graph.render(EVERY_KIND, "dot") == DOT


def test_dot_ranks_status_edges_outside_an_order_picture() -> None:
    other = replace(EVERY_KIND, name="g_states")
    status = next(line for line in graph.to_dot(other).splitlines() if '"b" -> "a"' in line)
    assert status == '  "b" -> "a" [color="#2da44e", penwidth=1.5, label="status"];'


def test_mermaid_draws_every_kind_of_node_edge_and_nested_cluster() -> None:
    """Shapes per kind, labels escaped, classes per level and kind, link styles by index."""
    assert graph.to_mermaid(EVERY_KIND) == MERMAID
    assert graph.render(EVERY_KIND, "mermaid") == MERMAID
    untitled = graph.to_mermaid(EVERY_KIND, title=False)
    assert untitled == MERMAID.split("---\n", 2)[2]


def test_render_refuses_an_unknown_format_and_reports_a_failing_dot(monkeypatch) -> None:
    with pytest.raises(graph.GraphError, match=r"^unknown format `png`: use mermaid, dot, svg$"):
        graph.render(EVERY_KIND, "png")
    # a `dot` that fails (Python given -Tsvg): its first line of complaint, one line
    monkeypatch.setattr(graph, "dot_program", lambda: sys.executable)
    with pytest.raises(graph.GraphError) as caught:
        graph.render(EVERY_KIND, "svg")
    message = str(caught.value)
    assert message.startswith("Graphviz's dot failed: ") and "\n" not in message
    assert "-T" in message
    monkeypatch.setattr(graph, "dot_program", lambda: None)
    with pytest.raises(graph.GraphError, match="install the `graphviz` package"):
        graph.to_svg(EVERY_KIND)


# ---------------------------------------------------------------- builders


@pytest.fixture(scope="module")
def miner():
    return compile_paths([REPO / "specs" / "miner"]).systems[0]


def test_guards_wrap_before_and_or_within_the_width() -> None:
    assert graph.wrap_guard("a and b or c", width=7) == ["a and b", "or c"]
    assert graph.wrap_guard("a and b or c", width=6) == ["a", "and b", "or c"]
    assert graph.wrap_guard("x > 1 and y < 2") == ["x > 1 and y < 2"]  # fits in 38
    assert graph.wrap_guard("long_name_one and long_name_two", width=31) == [
        "long_name_one and long_name_two"
    ]
    assert graph.wrap_guard("long_name_one and long_name_two", width=30) == [
        "long_name_one",
        "and long_name_two",
    ]
    assert graph.wrap_guard("   ") == ["   "]


def action_texts(system) -> set[str]:
    rules = [r for c in system.controllers for k in c.commands for s in k.states for r in s.rules]
    rules += [r for c in system.controllers for r in c.every_cycle]
    return {graph.action_text(a) for r in rules for a in r.actions}


def test_every_action_reads_as_spec_text(miner) -> None:
    texts = action_texts(miner)
    assert {"send cc.HALT", "report DONE", "call haul", "report ERROR"} <= texts
    assert any(t.startswith("send vg.TRAM_TO_XY(x: ") and ", y: " in t for t in texts)
    assert any(t.startswith("set world.") and " = " in t for t in texts)
    submarine = action_texts(compile_paths([REPO / "specs" / "submarine"]).systems[0])
    assert {"plan route", "advance route", "replan route", "report ERROR (BLOCKED)"} <= submarine
    inspection = action_texts(compile_paths([REPO / "specs" / "inspection"]).systems[0])
    assert {"report ERROR (MACHINE_FAULT)", "report ERROR (fx.reason)"} <= inspection


def test_picture_names_are_every_picture_the_command_line_draws(miner) -> None:
    names = graph.picture_names(miner)
    assert names[:2] == ["hierarchy", "order"]
    assert {"order:pc1", "order:pc2", "order:co", "co", "co.SUMP_SHEAR_CUSP"} <= set(names)
    assert len(names) == len(set(names))
    for name in names:
        assert graph.picture(miner, name).nodes, name


def test_order_pictures_by_process_or_module(miner) -> None:
    by_process = graph.picture(miner, "order:pc2")
    assert by_process.name == "miner_pc2_order"
    assert by_process.title.startswith("miner pc2: a command's round trip ")
    assert graph.picture(miner, "order").name == "miner_pc1_order"  # the first process
    module = graph.picture(miner, "order:tc")
    assert "sec > sb > co > vg > tc" in module.title
    with pytest.raises(graph.GraphError) as caught:
        graph.picture(miner, "order:tx")
    assert "did you mean `order:tc`?" in str(caught.value)
    with pytest.raises(graph.GraphError) as caught:
        graph.picture(miner, "zz")
    assert str(caught.value).startswith(
        "unknown picture `zz` for system miner: use hierarchy, order, order:<module>, a "
        "controller (`"
    )
    assert "did you mean" not in str(caught.value)


def test_an_order_picture_wraps_each_cycle_in_the_fieldbus_io() -> None:
    """A process with fieldbus devices reads them first and writes them last every cycle
    (rcs/io_cycle.py); the last cycle, cut short when the status is read, writes nothing."""
    [hil] = compile_paths([REPO / "specs" / "miner_hil"]).systems
    picture = graph.picture(hil, "order")
    assert picture.nodes[0].label == (
        "pc1 runs, every cycle:",
        "[I/O in: plc, conveyor] sec sb co cc bm cd sj cr",
        "gh cv ct vg tc wm [I/O out: plc, conveyor]",
    )
    steps = {n.id: (n.label, n.level, n.cluster) for n in picture.nodes}
    assert steps["x1_io_in"] == (("I/O in", "plc, conveyor: inputs to the world"), 0, "o_cycle1")
    assert steps["x4_io_out"] == (
        ("I/O out", "plc, conveyor: outputs to the device"),
        0,
        "o_cycle4",
    )
    assert [n.id for n in picture.nodes if n.cluster == "o_cycle5"] == ["x5_io_in", "x5_sec"]
    then = [(e.source, e.target) for e in picture.edges if e.kind == "then"]
    assert ("o_note", "x1_io_in") in then and ("x1_io_in", "x1_sec") in then
    assert ("x1_io_out", "x2_io_in") in then


def test_dot_draws_the_start_as_a_dark_dot_and_the_note_as_a_note() -> None:
    """Figure 4's start dot and the order picture's note, as Graphviz is told to draw them."""
    lines = graph.to_dot(EVERY_KIND).splitlines()
    start = next(line for line in lines if line.startswith('  "o" ['))
    assert (
        start == '  "o" [shape=circle, style="filled", fillcolor="#333333", width=0.2, label=""];'
    )
    note = next(line for line in lines if line.startswith('  "n" ['))
    assert note == '  "n" [shape=note, style="filled", label="note", fillcolor="#fffbe6"];'
