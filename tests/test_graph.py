"""`rcsgen graph`: the hierarchy, state graphs and execution order, read from the IR.

The pictures are checked as graphs (nodes, edges, labels), their Mermaid and DOT text for
what a reader needs, SVG through Graphviz where it is installed, and every bad input as a
one-line error.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import rcsgen

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools import graph

REPO = Path(__file__).resolve().parent.parent
MINER = REPO / "specs" / "miner"
needs_dot = pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz is not installed: apt-get install graphviz"
)


@pytest.fixture(scope="module")
def system():
    front = compile_paths([MINER])
    assert not front.diagnostics.errors
    return front.systems[0]


def test_hierarchy_has_every_module_by_level_with_simulators_and_stand_ins(system):
    picture = graph.hierarchy(system)
    nodes = {n.id.removeprefix("m_"): n for n in picture.nodes}
    assert set(nodes) == {c.name for c in system.controllers}
    levels = [nodes[m].level for m in ("sec", "sb", "co", "cc", "bm")]
    assert levels == [1, 2, 3, 4, 5]
    assert nodes["mine"].kind == "simulator" and nodes["mine"].cluster == "p_pc1_sim"
    assert nodes["cr_sim"].kind == "stand_in"
    commands = {(e.source, e.target) for e in picture.edges if e.kind == "command"}
    assert ("m_co", "m_cc") in commands and ("m_vg", "m_tc") in commands
    assert ("m_cr_sim", "m_cr") in {(e.source, e.target) for e in picture.edges}
    assert [c.id for c in picture.clusters] == ["p_pc1", "p_pc1_sim", "p_pc2"]
    # in dot, a stand-in is a plain dashed box, a simulator a rounded dashed one
    shapes = {
        line.split('"')[1]: line for line in graph.to_dot(picture).splitlines() if "[shape=" in line
    }
    assert 'shape=box, style="filled,dashed"' in shapes["m_cr_sim"]
    assert 'shape=box, style="rounded,filled,dashed"' in shapes["m_mine"]
    assert 'shape=box, style="rounded,filled"' in shapes["m_co"]
    # a command edge solid blue, a stand-in's dashed grey
    dot = graph.to_dot(picture).splitlines()
    assert '  "m_sb" -> "m_co" [color="#1f6feb", penwidth=1.5];' in dot
    assert '  "m_cr_sim" -> "m_cr" [style=dashed, color="#888888", label="stands in for"];' in dot


def test_hierarchy_mermaid_colours_levels_and_marks_simulators(system):
    text = graph.to_mermaid(graph.hierarchy(system))
    assert text.startswith('---\ntitle: "miner: Continuous mining machine"\n---\nflowchart TB\n')
    assert 'subgraph p_pc1["pc1: Command-first order' in text
    assert "  m_sb --> m_co\n" in text
    assert 'm_mine(["mine<br/>Mine (simulated environment)"])' in text
    assert "m_cr_sim -.->" in text
    assert re.search(r"classDef level1 fill:#ffd6a5", text)
    assert re.search(r"class m_sec level1\n", text)
    assert re.search(r"class m_sb level2\n", text)
    assert "stroke-dasharray" in text.split("classDef simulator", 1)[1].splitlines()[0]


def test_state_graph_is_figure_4_guards_actions_and_priorities(system):
    co = system.controller("co")
    picture = graph.states(co, "SUMP_SHEAR_CUSP")
    command = next(k for k in co.commands if k.name == "SUMP_SHEAR_CUSP")
    rules = [r for s in command.states for r in s.rules]
    assert len([e for e in picture.edges if e.kind == "rule"]) == len(rules)
    by_label = {e.label[0]: e for e in picture.edges if e.kind == "rule"}
    halt = by_label["[2] too_much_loose_coal()"]
    assert halt.source == halt.target == "s_SUMP_SHEAR_CUSP_S2"  # stays in S2
    assert halt.label[1:] == ("/ send cc.HALT",)
    pop = by_label["[1] world.popped_out_of_shear"]
    assert pop.target == "s_SUMP_SHEAR_CUSP_S1"
    done = next(e for e in picture.edges if e.target.endswith("__DONE"))
    assert done.source == "s_SUMP_SHEAR_CUSP_S4" and done.label[-1] == "/ report DONE"
    states = {n.id: n.label[0] for n in picture.nodes if n.kind == "state"}
    assert states["s_SUMP_SHEAR_CUSP_S2"] == "S2 (first match)"
    first = next(e for e in picture.edges if e.source.endswith("__start"))
    assert first.target == "s_SUMP_SHEAR_CUSP_S0"


def test_a_controllers_picture_holds_init_and_halt_and_every_cycle_rules(system):
    picture = graph.states(system.controller("co"))
    assert [c.label for c in picture.clusters][:2] == ["INIT", "HALT"]
    oi = graph.states(system.controller("oi"))
    assert oi.clusters[0].id == "s_every_cycle"
    assert any("world.tail_request" in " ".join(e.label) for e in oi.edges)
    assert [c.label for c in oi.clusters][-2:] == [
        "ENTER_GOAL(x: float, y: float)",
        "TAIL_IN_POSITION",
    ]
    for whole in (picture, oi):  # every command's states drawn, each edge between two of them
        ids = {n.id for n in whole.nodes}
        assert all(e.source in ids and e.target in ids for e in whole.edges), whole.name
        assert {c.id for c in whole.clusters} <= {n.cluster for n in whole.nodes}


def test_labels_are_escaped_for_mermaid_and_dot(system):
    co = system.controller("co")
    mermaid = graph.to_mermaid(graph.states(co, "INITIAL_APPROACH_FACE"))
    assert "world.cutter_current #gt; CUTTER_THRESHOLD" in mermaid
    assert "world.cutter_current > " not in mermaid
    dot = graph.to_dot(graph.states(co, "INITIAL_APPROACH_FACE"))
    assert "world.cutter_current > CUTTER_THRESHOLD\\l" in dot
    assert graph._mermaid_text('a "b" | c # d') == "a #quot;b#quot; #124; c #35; d"
    assert graph._dot_text('say "hi" \\') == 'say \\"hi\\" \\\\'


def test_round_trip_command_first_takes_one_cycle_down_and_a_cycle_per_level_up(system):
    process = system.processes[0]
    chain = graph.thread(system, process, None)
    # the deepest thread, first in execution order
    assert chain == ["sec", "sb", "co", "cc", "bm"]
    assert graph.round_trip(process, chain) == [
        ("command", "sec", "sb", 1, 1),
        ("command", "sb", "co", 1, 1),
        ("command", "co", "cc", 1, 1),
        ("command", "cc", "bm", 1, 1),
        ("status", "bm", "cc", 1, 2),
        ("status", "cc", "co", 2, 3),
        ("status", "co", "sb", 3, 4),
        ("status", "sb", "sec", 4, 5),
    ]
    # Status-first order (the paper's alternative): the command needs a cycle per level.
    upside_down = replace(process, modules=tuple(reversed(process.modules)))
    hops = graph.round_trip(upside_down, chain)
    assert [h[4] for h in hops] == [2, 3, 4, 5, 5, 5, 5, 5]
    assert graph.thread(system, process, "tc") == ["sec", "sb", "co", "vg", "tc"]


def test_order_picture_has_a_cluster_per_cycle_and_message_edges(system):
    picture = graph.picture(system, "order")
    assert [c.label for c in picture.clusters] == [f"cycle {n}" for n in range(1, 6)]
    kinds = [(e.kind, e.source, e.target) for e in picture.edges if e.kind != "then"]
    assert ("status", "x1_bm", "x2_cc") in kinds and ("status", "x3_co", "x4_sb") in kinds
    assert picture.nodes[-1].id == "x5_sec"  # the round trip ends when sec reads the status
    assert "sec sb co cc bm cd sj" in " ".join(picture.nodes[0].label)


def test_same_specs_give_the_same_bytes(system):
    again = compile_paths([MINER]).systems[0]
    for name in ("hierarchy", "co", "order:tc"):
        for render in (graph.to_mermaid, graph.to_dot):
            assert render(graph.picture(system, name)) == render(graph.picture(again, name))


@needs_dot
def test_svg_is_drawn_by_graphviz(system):
    svg = graph.to_svg(graph.picture(system, "co.SUMP_SHEAR_CUSP"))
    assert svg.lstrip().startswith("<?xml") and "<svg" in svg
    assert "too_much_loose_coal()" in svg and "S2 (first match)" in svg


def test_cli_prints_mermaid_of_the_hierarchy():
    result = rcsgen("graph", MINER)
    assert result.exit_code == 0, result.output
    assert "flowchart TB" in result.stdout and "m_sb --> m_co" in result.stdout
    assert "warning" not in result.output  # warnings are validate's business


def test_cli_writes_dot_to_a_file(tmp_path):
    out = tmp_path / "co.dot"
    result = rcsgen("graph", MINER, "-p", "co.SUMP_SHEAR_CUSP", "--format", "dot", "-o", out)
    assert result.exit_code == 0, result.output
    assert out.read_text(encoding="utf-8").startswith('digraph "co_SUMP_SHEAR_CUSP" {')


@pytest.mark.parametrize(
    ("picture", "message"),
    [
        ("hierachy", "error: unknown picture `hierachy` for system miner"),
        ("co.SUMP", "error: unknown picture `co.SUMP`: co has the commands INIT, HALT,"),
        ("order:nobody", "error: unknown picture `order:nobody`"),
    ],
)
def test_cli_unknown_picture_is_one_line_exit_2(picture, message):
    result = rcsgen("graph", MINER, "-p", picture)
    assert result.exit_code == 2
    assert result.output.startswith(message) and result.output.count("\n") == 1


def test_cli_svg_without_graphviz_names_the_package(monkeypatch):
    monkeypatch.setattr(graph.shutil, "which", lambda name: None)
    result = rcsgen("graph", MINER, "--format", "svg")
    assert result.exit_code == 1
    assert result.output.count("\n") == 1
    assert "install the `graphviz` package" in result.output


def test_cli_bad_specs_fail_with_their_diagnostics(tmp_path):
    result = rcsgen("graph", tmp_path / "nowhere")
    assert result.exit_code == 1
    assert "error[E010]" in result.output


@pytest.mark.parametrize(
    ("picture", "command"),
    [
        ("hierarchy", "rcsgen graph specs/miner"),
        ("co.SUMP_SHEAR_CUSP", "rcsgen graph specs/miner -p co.SUMP_SHEAR_CUSP"),
    ],
)
def test_readme_embeds_the_current_pictures(system, picture, command):
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    block = "```mermaid\n" + graph.to_mermaid(graph.picture(system, picture)) + "```"
    assert block in readme, f"README.md's {picture} is stale: paste the output of `{command}`"


def test_each_level_has_a_colour_of_its_own_and_a_deeper_one_wraps_round():
    """Fills as Graphviz and Mermaid read them (`#rrggbb`): one per level of the hierarchy, a
    level past the palette taking the first again; a step as its controller's level; a
    simulator and a stand-in each apart from every level and from each other."""

    def fill(kind: str, level: int = 0) -> str:
        return graph._fill(graph.Node("n", ("n",), kind, level=level))

    levels = [fill("controller", level) for level in range(1, len(graph.LEVEL_FILLS) + 2)]
    every = [*levels, fill("simulator"), fill("stand_in"), fill("state"), fill("final")]
    assert all(re.fullmatch("#[0-9a-f]{6}", colour) for colour in every + [fill("note")])
    assert len(set(levels[:-1])) == len(graph.LEVEL_FILLS) and levels[-1] == levels[0]
    assert [fill("step", level) for level in range(1, 4)] == levels[:3]
    assert len({*levels, fill("simulator"), fill("stand_in")}) == len(graph.LEVEL_FILLS) + 2
    assert len({fill("state"), fill("final"), fill("note")}) == 3


def test_levels_end_on_a_loop_of_clients_or_supervisors():
    """A loop (two operator modules each the other's client, two modules each the other's
    supervisor) still ends: each module a level once, the walk never going round again."""
    from types import SimpleNamespace

    def system(*modules: tuple[str, tuple[str, ...], str | None]) -> SimpleNamespace:
        made = [SimpleNamespace(name=n, clients=c, supervisor=s) for n, c, s in modules]
        return SimpleNamespace(controllers=made)

    assert graph.levels(system(("a", ("b",), None), ("b", ("a",), None))) == {"b": 1, "a": 2}
    assert graph.levels(system(("a", (), "b"), ("b", (), "a"))) == {"b": 1, "a": 2}


def test_an_order_pictures_note_wraps_the_execution_order_at_48_characters():
    platoon = compile_paths([REPO / "specs" / "platoon"]).systems[0]
    note = graph.picture(platoon, "order:alpha").nodes[0]
    assert note.label == (
        "pa runs, every cycle:",
        "alpha alpha_loco alpha_drive alpha_rsta",  # 39 characters: with alpha_pan, 49
        "alpha_pan alpha_motion alpha_sensor",
    )
