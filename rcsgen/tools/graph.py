"""Graph: an IR system -> a neutral graph of one picture -> Mermaid, DOT or SVG text.

Three pictures, each read from the IR into the same plain `Graph` (nodes, edges, clusters):

- `hierarchy`: every module, coloured by level, processes as clusters, simulators and
  stand-ins marked (the paper's Figures 5 and 8);
- a controller's state graphs (`co`, or one command `co.SUMP_SHEAR_CUSP`): states as nodes,
  rules as edges labelled with the guard's spec text and the actions, INIT and HALT
  included (Figure 4);
- `order` (or `order:<module>`): one command's round trip down a thread of the hierarchy
  and its status back up, cycle by cycle, in the process's execution order (Figures 6, 7).

Each format is a small renderer of that graph. Output depends on the specs alone: the same
specs give the same bytes. SVG is drawn by Graphviz's `dot`, where it is installed.
"""

from __future__ import annotations

import shutil
import subprocess
import textwrap
from dataclasses import dataclass

from ..compiler.diagnostics import counted
from ..compiler.ir import (
    IRAction,
    IRCall,
    IRCommand,
    IRController,
    IRPlanAction,
    IRProcess,
    IRReport,
    IRRule,
    IRSend,
    IRSet,
    IRSystem,
)

FORMATS = ("mermaid", "dot", "svg")
# Fill colours by level (1 = a root of the hierarchy), then for modules outside it.
LEVEL_FILLS = ("#ffd6a5", "#fdffb6", "#caffbf", "#9bf6ff", "#a0c4ff", "#bdb2ff", "#ffc6ff")
SIMULATOR_FILL = "#eeeeee"
STAND_IN_FILL = "#ffffff"
LABEL_WIDTH = 38  # characters per line of an edge label's guard


class GraphError(Exception):
    """A picture that cannot be drawn: an unknown name, or Graphviz missing for SVG."""


# ---------------------------------------------------------------- the neutral graph


@dataclass(frozen=True)
class Node:
    id: str
    label: tuple[str, ...]  # lines; the first is the name
    kind: str  # controller, simulator, stand_in, state, start, final, step, note
    cluster: str | None = None
    level: int = 0  # a controller's level in the hierarchy (1 = root); 0 when none


@dataclass(frozen=True)
class Edge:
    source: str
    target: str
    label: tuple[str, ...] = ()
    kind: str = "command"  # command, stand_in, rule, then, message, status


@dataclass(frozen=True)
class Cluster:
    id: str
    label: str
    parent: str | None = None


@dataclass(frozen=True)
class Graph:
    name: str
    title: str
    direction: str  # TB or LR
    nodes: tuple[Node, ...]
    edges: tuple[Edge, ...]
    clusters: tuple[Cluster, ...] = ()


# ---------------------------------------------------------------- pictures from the IR


def levels(system: IRSystem) -> dict[str, int]:
    """Each controller's level: 1 for a module without a supervisor, its supervisor's + 1
    (an operator module's: its deepest client's + 1)."""
    found: dict[str, int] = {}
    by_name = {c.name: c for c in system.controllers}

    def level(name: str, seen: frozenset[str] = frozenset()) -> int:
        clients = [c for c in by_name[name].clients if c in by_name and c not in seen]
        if name not in found and clients:  # an operator module: below its deepest client
            found[name] = max(level(c, seen | {name}) for c in clients) + 1
        if name not in found:
            sup = by_name[name].supervisor
            ok = sup is not None and sup in by_name and sup not in seen
            found[name] = level(sup, seen | {name}) + 1 if ok and sup else 1
        return found[name]

    for controller in system.controllers:
        level(controller.name)
    return found


def _module_node(c: IRController, level: int, cluster: str | None, stand_in: bool) -> Node:
    kind = "stand_in" if stand_in else "simulator" if c.simulator else "controller"
    return Node(f"m_{c.name}", (c.name, c.title), kind, cluster, level)


def hierarchy(system: IRSystem) -> Graph:
    """Every module of every process (clusters), supervisor -> subordinate edges; each
    process's simulators in a cluster of their own, laid out in rows."""
    level = levels(system)
    stand_ins = {si: rep for p in system.processes for rep, (si, _) in p.stand_ins.items()}
    nodes: list[Node] = []
    edges: list[Edge] = []
    clusters: list[Cluster] = []
    drawn: set[str] = set()
    for process in system.processes:
        cluster = f"p_{process.name}"
        clusters.append(Cluster(cluster, _first_line(process.name, process.doc)))
        names = [*process.modules, *sorted(si for si, _ in process.stand_ins.values())]
        names = [n for n in names if n not in drawn]
        drawn.update(names)
        simulators = [n for n in names if system.controller(n).simulator and n not in stand_ins]
        if simulators:
            clusters.append(Cluster(f"{cluster}_sim", "simulators", cluster))
        for name in names:
            where = f"{cluster}_sim" if name in simulators else cluster
            controller = system.controller(name)
            nodes.append(_module_node(controller, level[name], where, name in stand_ins))
        # simulators have no supervisor: rows of them, as deep as the hierarchy
        depth = max([level[n] for n in names if n not in simulators] or [1])
        per_row = -(-len(simulators) // depth)
        edges += [
            Edge(f"m_{a}", f"m_{b}", (), "layout")
            for a, b in zip(simulators, simulators[per_row:], strict=False)
        ]
    for c in system.controllers:  # modules no process runs
        if c.name not in drawn:
            nodes.append(_module_node(c, level[c.name], None, c.name in stand_ins))
    edges += [
        Edge(f"m_{c.name}", f"m_{sub.name}", (), "command")
        for c in system.controllers
        if c.name not in stand_ins
        for sub in c.subordinates
    ]
    edges += [
        Edge(f"m_{si}", f"m_{rep}", ("stands in for",), "stand_in")
        for si, rep in sorted(stand_ins.items())
    ]
    title = f"{system.name}: {system.title}"
    name = f"{system.name}_hierarchy"
    return Graph(name, title, "TB", tuple(nodes), tuple(edges), tuple(clusters))


def action_text(action: IRAction) -> str:
    """An action as one line of spec-like text: `send vg.TRAM_TO_XY(x: world.goal_x)`."""
    if isinstance(action, IRSend):
        args = ", ".join(f"{a.param}: {a.value.text}" for a in action.args)
        return f"send {action.sub}.{action.command}" + (f"({args})" if args else "")
    if isinstance(action, IRSet):
        return "set " + ", ".join(f"{a.target} = {a.value.text}" for a in action.assignments)
    if isinstance(action, IRReport):
        reason = action.reason_name
        return f"report {action.status}" + (f" ({reason})" if reason else "")
    if isinstance(action, IRPlanAction):
        return f"{action.verb} {action.plan}"
    assert isinstance(action, IRCall)
    return f"call {action.hook}"


def rule_label(rule: IRRule, numbered: bool) -> tuple[str, ...]:
    """An edge's label: `[n]` when the state has several rules, the guard, then the actions."""
    guard = rule.guard.text if rule.guard is not None else "always"
    lines = wrap_guard(guard)
    if numbered:
        lines[0] = f"[{rule.id.index}] {lines[0]}"
    return (*lines, *(f"/ {action_text(a)}" for a in rule.actions))


def wrap_guard(text: str, width: int = LABEL_WIDTH) -> list[str]:
    """A guard on lines of about `width` characters, broken before `and` and `or`."""
    words = text.split()
    clauses: list[str] = []
    for word in words:
        if clauses and word not in ("and", "or"):
            clauses[-1] += " " + word
        else:
            clauses.append(word)
    lines: list[str] = []
    for clause in clauses:
        if lines and len(lines[-1]) + 1 + len(clause) <= width:
            lines[-1] += " " + clause
        else:
            lines.append(clause)
    return lines or [text]


def reported(rule: IRRule) -> str | None:
    """The status a rule reports (it ends the command), or None."""
    return next((a.status for a in rule.actions if isinstance(a, IRReport)), None)


def _command_picture(command: IRCommand, cluster: str | None) -> tuple[list[Node], list[Edge]]:
    prefix = f"s_{command.name}"
    start = Node(f"{prefix}__start", ("start",), "start", cluster)
    nodes, edges = [start], []
    if command.states:
        edges.append(Edge(start.id, f"{prefix}_{command.states[0].name}", (), "then"))
    finals: list[str] = []
    for state in command.states:
        label = state.name + (" (first match)" if state.name in command.first_match else "")
        nodes.append(Node(f"{prefix}_{state.name}", (label,), "state", cluster))
        numbered = len(state.rules) > 1
        for rule in state.rules:
            status = reported(rule)
            if status is not None:
                target = f"{prefix}__{status}"
                if status not in finals:
                    finals.append(status)
            else:
                target = f"{prefix}_{rule.next_state or state.name}"
            edges.append(Edge(f"{prefix}_{state.name}", target, rule_label(rule, numbered), "rule"))
    for status in sorted(finals):
        nodes.append(Node(f"{prefix}__{status}", (status,), "final", cluster))
    return nodes, edges


def states(controller: IRController, command: str | None = None) -> Graph:
    """A controller's state graphs: every command's (INIT and HALT too), or one command's."""
    chosen = [c for c in controller.commands if command is None or c.name == command]
    nodes: list[Node] = []
    edges: list[Edge] = []
    clusters: list[Cluster] = []
    if command is None and controller.every_cycle:
        clusters.append(Cluster("s_every_cycle", "every cycle, before the command's table"))
        node = Node("s__every_cycle", ("each cycle",), "state", "s_every_cycle")
        nodes.append(node)
        numbered = len(controller.every_cycle) > 1
        edges += [
            Edge(node.id, node.id, rule_label(rule, numbered), "rule")
            for rule in controller.every_cycle
        ]
    for cmd in chosen:
        cluster = None if command is not None else f"c_{cmd.name}"
        if cluster is not None:
            params = ", ".join(f"{p.name}: {p.type.label}" for p in cmd.params)
            clusters.append(Cluster(cluster, cmd.name + (f"({params})" if params else "")))
        more_nodes, more_edges = _command_picture(cmd, cluster)
        nodes += more_nodes
        edges += more_edges
    name = f"{controller.name}_{command}" if command else controller.name
    title = f"{controller.name}.{command}" if command else f"{controller.name}: {controller.title}"
    return Graph(name, title, "TB", tuple(nodes), tuple(edges), tuple(clusters))


def thread(system: IRSystem, process: IRProcess, module: str | None) -> list[str]:
    """A root-to-module path of the hierarchy within a process: to `module`, or to the
    deepest module (the first in execution order among equals)."""
    order = {name: i for i, name in enumerate(process.modules)}
    supervisors = {c.name: c.supervisor for c in system.controllers}

    def path(name: str) -> list[str]:
        chain = [name]
        while (sup := supervisors.get(chain[-1])) is not None and sup in order:
            if sup in chain:
                break
            chain.append(sup)
        return chain[::-1]

    if module is not None:
        return path(module)
    return max((path(m) for m in process.modules), key=lambda p: (len(p), -order[p[-1]]))


def round_trip(process: IRProcess, chain: list[str]) -> list[tuple[str, str, str, int, int]]:
    """The hops of a command down `chain` and its status back up: (kind, from, to, the cycle
    the sender runs, the cycle the receiver first sees it). The command is read by the
    chain's first module in cycle 1; a message reaches a module later in the execution
    order in the same cycle, and an earlier one in the next."""
    order = {name: i for i, name in enumerate(process.modules)}
    hops = []
    cycle = 1
    for sup, sub in zip(chain, chain[1:], strict=False):
        seen = cycle if order[sub] > order[sup] else cycle + 1
        hops.append(("command", sup, sub, cycle, seen))
        cycle = seen
    for sub, sup in zip(chain[::-1], chain[::-1][1:], strict=False):
        seen = cycle if order[sup] > order[sub] else cycle + 1
        hops.append(("status", sub, sup, cycle, seen))
        cycle = seen
    return hops


def execution_order(system: IRSystem, process: IRProcess, module: str | None = None) -> Graph:
    """A command's round trip down a thread and back, one cluster per cycle; inside a cycle
    the thread's modules run in the process's execution order (`then` edges)."""
    chain = thread(system, process, module)
    hops = round_trip(process, chain)
    level = levels(system)
    cycles = max([1, *(h[4] for h in hops)])
    in_order = [m for m in process.modules if m in chain]
    devices = ", ".join(process.io)
    order_text = " ".join(process.modules)
    if process.io:  # the I/O module around the controllers (rcs/io_cycle.py)
        order_text = f"[I/O in: {devices}] {order_text} [I/O out: {devices}]"
    note = Node("o_note", (f"{process.name} runs, every cycle:", *_wrap(order_text, 48)), "note")
    nodes = [note]
    edges: list[Edge] = []
    clusters = []
    messages = {(f"x{c1}_{a}", f"x{c2}_{b}"): kind for kind, a, b, c1, c2 in hops}
    previous = note.id
    last = hops[-1][2] if hops else chain[0]  # the round trip ends when it reads the status
    for cycle in range(1, cycles + 1):
        clusters.append(Cluster(f"o_cycle{cycle}", f"cycle {cycle}"))
        running = in_order if cycle < cycles else in_order[: in_order.index(last) + 1]
        steps = [(name, (name, system.controller(name).title), level[name]) for name in running]
        if process.io:  # inputs read first; outputs written last (not in a cut-short cycle)
            steps.insert(0, ("io_in", ("I/O in", f"{devices}: inputs to the world"), 0))
            if cycle < cycles or running == in_order:
                steps.append(("io_out", ("I/O out", f"{devices}: outputs to the device"), 0))
        for name, text, depth in steps:
            node = Node(f"x{cycle}_{name}", text, "step", f"o_cycle{cycle}", depth)
            nodes.append(node)
            if (previous, node.id) not in messages:
                edges.append(Edge(previous, node.id, (), "then"))
            previous = node.id
    for kind, a, b, c1, c2 in hops:
        label = "command" if kind == "command" else "status"
        edges.append(Edge(f"x{c1}_{a}", f"x{c2}_{b}", (label,), kind))
    title = (
        f"{system.name} {process.name}: a command's round trip {' > '.join(chain)} and back, "
        f"{counted(cycles, 'cycle')}"
    )
    name = f"{system.name}_{process.name}_order"
    return Graph(name, title, "TB", tuple(nodes), tuple(edges), tuple(clusters))


def _first_line(name: str, doc: str) -> str:
    line = doc.strip().splitlines()[0] if doc.strip() else ""
    return f"{name}: {line}" if line else name


def _wrap(text: str, width: int) -> list[str]:
    return textwrap.wrap(text, width, break_long_words=False) or [text]


# ---------------------------------------------------------------- choosing a picture


def picture_names(system: IRSystem) -> list[str]:
    """Every picture `picture()` draws for a system, as the command line names them."""
    names = ["hierarchy", "order"]
    names += [f"order:{p.name}" for p in system.processes]
    names += [f"order:{m}" for p in system.processes for m in p.modules]
    for c in system.controllers:
        names += [c.name, *(f"{c.name}.{k.name}" for k in c.commands)]
    return names


def picture(system: IRSystem, name: str) -> Graph:
    """The picture a name asks for: `hierarchy`, `order`, `order:<process or module>`, a
    controller (`co`: all its state graphs) or one command (`co.SUMP_SHEAR_CUSP`)."""
    if name == "hierarchy":
        return hierarchy(system)
    if name == "order" or name.startswith("order:"):
        return _order(system, name)
    controller_name, _, command = name.partition(".")
    controller = next((c for c in system.controllers if c.name == controller_name), None)
    if controller is None:
        raise GraphError(_unknown(system, name))
    if command and all(k.name != command for k in controller.commands):
        names = ", ".join(k.name for k in controller.commands)
        raise GraphError(f"unknown picture `{name}`: {controller.name} has the commands {names}")
    return states(controller, command or None)


def _order(system: IRSystem, name: str) -> Graph:
    """`order` (the first process), `order:<process>` or `order:<module>` (its round trip)."""
    what = name.partition(":")[2]
    process = next((p for p in system.processes if p.name == what), None)
    if process is not None or not what:
        return execution_order(system, process or system.processes[0])
    process = next((p for p in system.processes if what in p.modules), None)
    if process is None:
        raise GraphError(_unknown(system, name))
    return execution_order(system, process, what)


def _unknown(system: IRSystem, name: str) -> str:
    import difflib

    close = difflib.get_close_matches(name, picture_names(system), n=1)
    hint = f"; did you mean `{close[0]}`?" if close else ""
    return (
        f"unknown picture `{name}` for system {system.name}: use hierarchy, order, "
        f"order:<module>, a controller (`{system.controllers[0].name}`) or one of its "
        f"commands (`{system.controllers[0].name}.{system.controllers[0].commands[-1].name}`)"
        f"{hint}"
    )


# ---------------------------------------------------------------- renderers


def _fill(node: Node) -> str:
    if node.kind == "simulator":
        return SIMULATOR_FILL
    if node.kind == "stand_in":
        return STAND_IN_FILL
    if node.kind in ("controller", "step") and node.level:
        return LEVEL_FILLS[(node.level - 1) % len(LEVEL_FILLS)]
    return {"state": "#e8f0fe", "final": "#d9ead3", "note": "#fffbe6"}.get(node.kind, "#ffffff")


def _mermaid_text(text: str) -> str:
    """Text inside a quoted Mermaid label: characters Mermaid or HTML would read, escaped."""
    out = []
    for char in text:
        code = {"#": "#35;", '"': "#quot;", "<": "#lt;", ">": "#gt;", "&": "#amp;", "|": "#124;"}
        out.append(code.get(char, char))
    return "".join(out)


def _mermaid_label(lines: tuple[str, ...]) -> str:
    return '"' + "<br/>".join(_mermaid_text(line) for line in lines) + '"'


MERMAID_SHAPES = {
    "start": ("((", "))"),
    "final": ("(((", ")))"),
    "simulator": ("([", "])"),
    "stand_in": ("[/", "/]"),
    "state": ("(", ")"),
    "note": (">", "]"),
}
MERMAID_ARROWS = {"then": "-->", "rule": "-->", "command": "-->", "stand_in": "-.->"}
MERMAID_ARROWS |= {"layout": "~~~"}
MERMAID_LINKS = {  # as the DOT renderer colours them
    "then": "stroke:#888888",
    "command": "stroke:#1f6feb,stroke-width:1.5px",
    "status": "stroke:#2da44e,stroke-width:2px",
    "stand_in": "stroke:#888888",
}
MERMAID_ARROWS |= {"status": "==>"}


def to_mermaid(graph: Graph, title: bool = True) -> str:
    """A Mermaid flowchart, as GitHub and GitLab render it in Markdown; the graph's title
    above it unless `title` is False (a page whose heading says it already)."""
    out = []
    if title:
        quoted = graph.title.replace("\\", "\\\\").replace('"', '\\"')
        out += ["---", f'title: "{quoted}"', "---"]
    out.append(f"flowchart {graph.direction}")

    def node_line(node: Node, indent: str) -> str:
        opening, closing = MERMAID_SHAPES.get(node.kind, ("[", "]"))
        return f"{indent}{node.id}{opening}{_mermaid_label(node.label)}{closing}"

    children: dict[str | None, list[Cluster]] = {}
    for cluster in graph.clusters:
        children.setdefault(cluster.parent, []).append(cluster)

    def emit(cluster: Cluster, depth: int) -> None:
        indent = "  " * depth
        out.append(f"{indent}subgraph {cluster.id}[{_mermaid_label((cluster.label,))}]")
        for child in children.get(cluster.id, []):
            emit(child, depth + 1)
        out.extend(node_line(n, indent + "  ") for n in graph.nodes if n.cluster == cluster.id)
        out.append(f"{indent}end")

    out.extend(node_line(n, "  ") for n in graph.nodes if n.cluster is None)
    for cluster in children.get(None, []):
        emit(cluster, 1)
    styles: dict[str, list[int]] = {}  # edge kind -> link indices (invisible links count)
    for index, edge in enumerate(graph.edges):
        arrow = MERMAID_ARROWS.get(edge.kind, "-->")
        label = f"|{_mermaid_label(edge.label)}|" if edge.label else ""
        out.append(f"  {edge.source} {arrow}{label} {edge.target}")
        styles.setdefault(edge.kind, []).append(index)
    classes: dict[str, list[str]] = {}
    for node in graph.nodes:
        key = f"level{node.level}" if node.kind in ("controller", "step") else node.kind
        classes.setdefault(key, []).append(node.id)
    for key, ids in sorted(classes.items()):
        node = next(n for n in graph.nodes if n.id == ids[0])
        dash = ",stroke-dasharray:4 3" if node.kind in ("simulator", "stand_in") else ""
        out.append(f"  classDef {key} fill:{_fill(node)},stroke:#555,color:#111{dash}")
        out.append(f"  class {','.join(ids)} {key}")
    for kind, indices in sorted(styles.items()):
        if kind in MERMAID_LINKS:
            out.append(f"  linkStyle {','.join(map(str, indices))} {MERMAID_LINKS[kind]}")
    return "\n".join(out) + "\n"


def _dot_text(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def _dot_label(lines: tuple[str, ...], left: bool = False) -> str:
    if left:
        return '"' + "".join(_dot_text(line) + "\\l" for line in lines) + '"'
    return '"' + "\\n".join(_dot_text(line) for line in lines) + '"'


DOT_SHAPES = {
    "controller": 'shape=box, style="rounded,filled"',
    "step": 'shape=box, style="rounded,filled"',
    "simulator": 'shape=box, style="rounded,filled,dashed"',
    "stand_in": 'shape=box, style="filled,dashed"',
    "state": 'shape=ellipse, style="filled"',
    "start": 'shape=circle, style="filled", fillcolor="#333333", width=0.2, label=""',
    "final": 'shape=doublecircle, style="filled"',
    "note": 'shape=note, style="filled"',
}
DOT_EDGES = {
    "then": 'color="#888888"',
    "stand_in": 'style=dashed, color="#888888"',
    "command": 'color="#1f6feb", penwidth=1.5',
    "status": 'color="#2da44e", penwidth=1.5',
    "rule": 'color="#333333"',
    "layout": "style=invis",
}


def to_dot(graph: Graph) -> str:
    """A Graphviz digraph."""
    out = [
        f'digraph "{_dot_text(graph.name)}" {{',
        f"  rankdir={graph.direction};",
        f"  label={_dot_label((graph.title,))}; labelloc=t; fontname=Helvetica;",
        '  node [fontname=Helvetica, fontsize=11, color="#555555"];',
        "  edge [fontname=Helvetica, fontsize=9];",
    ]
    order_edges = graph.name.endswith("_order")

    def node_line(node: Node, indent: str) -> str:
        attrs = DOT_SHAPES.get(node.kind, 'shape=box, style="filled"')
        if "label=" not in attrs:
            attrs += f", label={_dot_label(node.label)}"
        if "fillcolor=" not in attrs:  # the start dot is dark whatever its level
            attrs += f', fillcolor="{_fill(node)}"'
        return f'{indent}"{node.id}" [{attrs}];'

    children: dict[str | None, list[Cluster]] = {}
    for cluster in graph.clusters:
        children.setdefault(cluster.parent, []).append(cluster)

    def emit(cluster: Cluster, depth: int) -> None:
        indent = "  " * depth
        out.append(f'{indent}subgraph "cluster_{cluster.id}" {{')
        out.append(f"{indent}  label={_dot_label((cluster.label,))};")
        out.append(f'{indent}  style="rounded"; color="#999999";')
        for child in children.get(cluster.id, []):
            emit(child, depth + 1)
        out.extend(node_line(n, indent + "  ") for n in graph.nodes if n.cluster == cluster.id)
        out.append(f"{indent}}}")

    out.extend(node_line(n, "  ") for n in graph.nodes if n.cluster is None)
    for cluster in children.get(None, []):
        emit(cluster, 1)
    for edge in graph.edges:
        attrs = DOT_EDGES.get(edge.kind, "")
        if edge.label:
            attrs += f"{', ' if attrs else ''}label={_dot_label(edge.label, edge.kind == 'rule')}"
        if order_edges and edge.kind == "status":
            attrs += ", constraint=false"
        out.append(f'  "{edge.source}" -> "{edge.target}" [{attrs}];')
    out.append("}")
    return "\n".join(out) + "\n"


def dot_program() -> str | None:
    return shutil.which("dot")


def to_svg(graph: Graph) -> str:
    """SVG drawn by Graphviz's `dot`; GraphError naming the package when it is missing."""
    program = dot_program()
    if program is None:
        raise GraphError(
            "SVG needs Graphviz's `dot`, which is not installed: install the `graphviz` "
            "package (apt-get install graphviz, brew install graphviz), or use --format "
            "mermaid or dot"
        )
    done = subprocess.run(
        [program, "-Tsvg"], input=to_dot(graph), capture_output=True, text=True, check=False
    )
    if done.returncode != 0:
        first = (done.stderr.strip().splitlines() or ["no message"])[0]
        raise GraphError(f"Graphviz's dot failed: {first}")
    return done.stdout


def render(graph: Graph, fmt: str) -> str:
    if fmt == "mermaid":
        return to_mermaid(graph)
    if fmt == "dot":
        return to_dot(graph)
    if fmt == "svg":
        return to_svg(graph)
    raise GraphError(f"unknown format `{fmt}`: use {', '.join(FORMATS)}")
