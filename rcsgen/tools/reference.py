"""Reference: an IR system -> Markdown pages, one per controller and an index (`rcsgen doc`).

Each controller's page gives its commands and parameters, supervisor and subordinates, the
world fields it reads and writes, its constants, predicates, locals and hooks, and every
state table (INIT and HALT too) in the shape of the paper's Figure 4: state, condition,
actions, next state, beside the table's Mermaid state graph, which code hosts render. The
index draws the hierarchy and each process's execution order and lists the world model.
Pages read the same IR as the code generator, so `rcsgen doc --check` fails when they are
stale, as `rcsgen build --check` does for the code.
"""

from __future__ import annotations

from pathlib import Path

from ..compiler.back_end import write
from ..compiler.back_end.emit import MARKER
from ..compiler.diagnostics import Diagnostics
from ..compiler.ir import IRCommand, IRController, IRParam, IRRule, IRSystem
from ..compiler.types import Enum, Type
from . import graph

INDEX = "README.md"  # code hosts show a folder's README.md when it is opened
COMMAND = "rcsgen doc"


def header(source: str) -> str:
    marker = MARKER.removeprefix("# ")
    return f"<!-- {marker} from {source}. Do not edit: change the spec and run `{COMMAND}`. -->\n"


def cell(text: str) -> str:
    """Text in a Markdown table cell: pipes escaped, lines joined with <br>."""
    return "<br>".join(line.replace("|", "\\|") for line in text.splitlines()) or " "


def code(text: str) -> str:
    return f"`{text}`" if text else ""


def mermaid(picture: graph.Graph) -> str:
    return "```mermaid\n" + graph.to_mermaid(picture, title=False) + "```\n"


def link(name: str) -> str:
    return f"[{name}]({name}.md)"


def _next_state(rule: IRRule) -> str:
    status = graph.reported(rule)
    if status is not None:
        return f"**{status}** (NOP)"
    return rule.next_state or "(stays)"


def rule_table(rules: list[tuple[str, IRRule]], first_match: tuple[str, ...] = ()) -> str:
    """Figure 4's table: state, rule, condition, actions, next state (and the spec line)."""
    out = [
        "| state | rule | condition | actions | next state | line |",
        "|---|---:|---|---|---|---:|",
    ]
    previous = None
    for state, rule in rules:
        shown = state if state != previous else ""
        if shown and state in first_match:
            shown += " (first match)"
        previous = state
        condition = code(rule.guard.text) if rule.guard is not None else "always"
        if rule.doc:
            condition += f"<br>*{cell(rule.doc)}*"
        actions = "<br>".join(code(graph.action_text(a)) for a in rule.actions) or "—"
        out.append(
            f"| {shown or ' '} | {rule.id.index} | {condition} | {actions} | "
            f"{_next_state(rule)} | {rule.span.line} |"
        )
    return "\n".join(out) + "\n"


def _initial(value: object, kind: Type) -> str:
    """An initial value as the spec writes it: an enumeration's by its name."""
    return str(value) if isinstance(kind, Enum) else repr(value)


def command_section(controller: IRController, command: IRCommand) -> str:
    params = ", ".join(f"{p.name}: {p.type.label}" for p in command.params)
    out = [f"### {command.name}" + (f"({params})" if params else ""), ""]
    facts = [f"code {command.code}", f"`{controller.source}:{command.span.line}`"]
    if command.generated:
        facts.insert(1, "the default table (QQ1), generated")
    out += [" · ".join(facts), ""]
    if command.doc:
        out += [command.doc.strip(), ""]
    if command.params:
        out += ["| parameter | type | description |", "|---|---|---|"]
        out += [f"| `{p.name}` | {p.type.label} | {cell(p.doc)} |" for p in command.params]
        out.append("")
    if command.results:
        out += ["| result | type | description |", "|---|---|---|"]
        out += [f"| `result.{r.name}` | {r.type.label} | {cell(r.doc)} |" for r in command.results]
        out.append("")
    if command.reasons:
        out += ["It can fail for: " + ", ".join(f"`{r}`" for r in command.reasons) + ".", ""]
    if command.lets:
        out += ["| let | value |", "|---|---|"]
        out += [f"| `{name}` | `{cell(value.text)}` |" for name, value in command.lets]
        out.append("")
    if command.first_match:
        states = ", ".join(command.first_match)
        out += [f"In {states} the rules may overlap: the first that matches fires.", ""]
    out.append(mermaid(graph.states(controller, command.name)))
    rules = [(state.name, rule) for state in command.states for rule in state.rules]
    out.append(rule_table(rules, command.first_match))
    return "\n".join(out)


def operator_page(system: IRSystem, c: IRController, level: int) -> str:
    """An operator module's page: whom it serves, and each task with its instruction."""
    out = [header(c.source), f"# {c.name}: {c.title}", ""]
    facts = [f"system [{system.name}]({INDEX})", f"level {level}", "operator module"]
    if c.clients:
        facts.append("clients " + ", ".join(link(client) for client in c.clients))
    facts.append(f"spec `{c.source}`")
    out += [" · ".join(facts), ""]
    if c.doc.strip():
        out += [c.doc.strip(), ""]
    out += [
        "A person at a screen performs these tasks when a client asks, and answers DONE or "
        "ERROR with a reason; each client asks through its own channel "
        f"({', '.join(code(ch) for ch in c.channels) or 'none'}). INIT and HALT withdraw a "
        "client's open request.",
        "",
        "## Tasks",
        "",
    ]
    recorded = any(command.results for command in c.commands)  # a column only if any
    out += [
        "| code | task | parameters | instruction on the screen | reasons | "
        + ("results (with DONE) | " if recorded else "")
        + "description |",
        "|---:|---|---|---|---|---|" + ("---|" if recorded else ""),
    ]
    for command in c.commands:
        if not command.text:
            continue
        params = ", ".join(f"{p.name}: {p.type}" for p in command.params)
        reasons = ", ".join(code(r) for r in command.reasons)
        results = ", ".join(_result(r) for r in command.results)
        out.append(
            f"| {command.code} | {command.name} | {params} | {cell(command.text)} | "
            f"{reasons} | "
            + (f"{cell(results)} | " if recorded else "")
            + f"{cell(command.doc.strip())} |"
        )
    return "\n".join(out).rstrip("\n") + "\n"


def _result(r: IRParam) -> str:
    """A task's result as the reference shows it: `post: float 0.0..5000.0`."""
    bounds = ""
    if r.low is not None or r.high is not None:
        bounds = f" {'' if r.low is None else r.low}..{'' if r.high is None else r.high}"
    return f"{r.name}: {r.type}{bounds}"


def controller_page(system: IRSystem, controller: IRController, level: int) -> str:
    c = controller
    if c.is_operator:
        return operator_page(system, c, level)
    out = [header(c.source), f"# {c.name}: {c.title}", "", " · ".join(_facts(system, c, level))]
    out.append("")
    if c.doc.strip():
        out += [c.doc.strip(), ""]
    out += _commands(c)
    out += _subordinates(system, c)
    out += _world(c)
    out += _definitions(c)
    out += _plans(c)
    if c.every_cycle:
        out += ["## Every cycle", "", "Tried first, every cycle, before the command's table.", ""]
        out.append(rule_table([("every cycle", rule) for rule in c.every_cycle]))
    out += ["## State tables", ""]
    out += [command_section(c, command) for command in c.commands]
    return "\n".join(out).rstrip("\n") + "\n"


def _facts(system: IRSystem, c: IRController, level: int) -> list[str]:
    """The page's line under its title: system, level, stand-in, supervisor, subordinates."""
    facts = [f"system [{system.name}]({INDEX})"]
    facts.append("simulator" if c.simulator else f"level {level}")
    if c.buffers != c.name:
        facts.append(f"stands in for {link(c.buffers)} and its subtree")
    if c.supervisor:
        facts.append(f"supervisor {link(c.supervisor)}")
    if c.subordinates:
        facts.append("subordinates " + ", ".join(link(s.name) for s in c.subordinates))
    facts.append(f"spec `{c.source}`")
    return facts


def _commands(c: IRController) -> list[str]:
    out = ["## Commands", "", "| code | command | parameters | states | description |"]
    out.append("|---:|---|---|---:|---|")
    for command in c.commands:
        params = ", ".join(f"{p.name}: {p.type.label}" for p in command.params)
        anchor = command.name.lower()
        doc = command.doc.strip() + (" (generated)" if command.generated else "")
        out.append(
            f"| {command.code} | [{command.name}](#{anchor}) | {params} | "
            f"{len(command.states)} | {cell(doc)} |"
        )
    out.append("")
    return out


def _subordinates(system: IRSystem, c: IRController) -> list[str]:
    if not c.subordinates:
        return []
    out = ["## Subordinates", "", "| subordinate | commands it takes | parameters |"]
    out.append("|---|---|---|")
    for sub in c.subordinates:
        names = ", ".join(k.name for k in system.controller(sub.name).commands)
        params = ", ".join(f"{p.name}: {p.type.label}" for p in sub.params)
        out.append(f"| {link(sub.name)} | {names} | {params} |")
    out.append("")
    return out


def _world(c: IRController) -> list[str]:
    writes = {w.name for w in c.world_writes}
    fields = [(w, "write") for w in c.world_writes]
    fields += [(w, "read") for w in c.world_reads if w.name not in writes]
    if not fields:
        return []
    out = ["## World model", ""]
    out += ["Read fields are copied in by pre_process, written ones out by post_process.", ""]
    out += ["| field | type | access | description |", "|---|---|---|---|"]
    for w, access in sorted(fields, key=lambda f: (f[1] != "read", f[0].name)):
        out.append(f"| `world.{w.name}` | {w.type.label} | {access} | {cell(w.doc)} |")
    out.append("")
    return out


def _definitions(c: IRController) -> list[str]:
    if not (c.constants or c.predicates or c.locals or c.hooks or c.functions):
        return []
    rows = [f"| constant | `{n}` | `{v}` | |" for n, v in c.constants]
    rows += [f"| predicate | `{p.name}()` | `{cell(p.expr.text)}` | |" for p in c.predicates]
    rows += [
        f"| function | `{f.name}({', '.join(f'{p}: {t}' for p, t in f.params)})` "
        f"-> {f.returns} | `{cell(f.body.text)}` | |"
        for f in c.functions
    ]
    rows += [
        f"| local | `{v.name}` | {v.type.label} = `{_initial(v.initial, v.type)}` | {cell(v.doc)} |"
        for v in c.locals
    ]
    rows += [f"| hook | `{h}` | `{c.hooks_module}` | |" for h in c.hooks]
    out = ["## Constants, predicates, locals, hooks", ""]
    return out + ["| kind | name | value | description |", "|---|---|---|---|", *rows, ""]


def _plans(c: IRController) -> list[str]:
    if not c.plans:
        return []
    out = ["## Plans", ""]
    out += ["Made by `plan:`, stepped through by `advance:`, made again by `replan:`.", ""]
    out += ["| plan | planner | steps | capacity | replans | description |"]
    out += ["|---|---|---|---|---|---|"]
    for p in c.plans:
        steps = ", ".join(f"{f.name}: {f.type}" for f in p.fields)
        out.append(
            f"| `{p.name}` | `{p.planner}({', '.join(p.args)})` | {steps} | {p.capacity} "
            f"| {p.replans} | {cell(p.doc)} |"
        )
    out.append("")
    return out


def index_page(system: IRSystem) -> str:
    level = graph.levels(system)
    out = [header(system.source), f"# {system.name}: {system.title}", ""]
    if system.doc.strip():
        out += [system.doc.strip(), ""]
    out += [
        f"Cycle period {system.cycle_period:g} s · spec `{system.source}` · "
        f"{len(system.controllers)} modules",
        "",
        "## Hierarchy",
        "",
        mermaid(graph.hierarchy(system)),
        "Colour gives the level (1 at the top); simulators are grey, stand-ins white, both dashed.",
        "",
        "| module | level | title | commands | supervisor | subordinates |",
        "|---|---:|---|---|---|---|",
    ]
    for c in system.controllers:
        shown = "simulator" if c.simulator else str(level[c.name])
        commands = ", ".join(k.name for k in c.commands if not k.generated)
        subs = ", ".join(link(s.name) for s in c.subordinates)
        sup = link(c.supervisor) if c.supervisor else ""
        out.append(f"| {link(c.name)} | {shown} | {cell(c.title)} | {commands} | {sup} | {subs} |")
    out.append("")
    for process in system.processes:
        out += [f"## Process {process.name}", ""]
        if process.doc.strip():
            out += [process.doc.strip(), ""]
        order = " → ".join(process.modules)
        out += [f"Execution order, every cycle: {order}.", ""]
        for _replaced, (stand_in, subtree) in sorted(process.stand_ins.items()):
            out += [
                f"Stand-in: {link(stand_in)} can run in place of {', '.join(subtree)}.",
                "",
            ]
        out.append(mermaid(graph.execution_order(system, process)))
    out += ["## World model", "", "| field | type | initial | written by | read by | description |"]
    out.append("|---|---|---|---|---|---|")
    for w in system.world:
        writers = [c.name for c in system.controllers if w.name in {f.name for f in c.world_writes}]
        readers = [
            c.name
            for c in system.controllers
            if w.name in {f.name for f in c.world_reads} and c.name not in writers
        ]
        out.append(
            f"| `{w.name}` | {w.type.label} | `{_initial(w.initial, w.type)}` | "
            f"{', '.join(writers)} | {', '.join(readers)} | {cell(w.doc)} |"
        )
    return "\n".join(out).rstrip("\n") + "\n"


def render(system: IRSystem) -> dict[str, str]:
    """Every page of one system, by path relative to the output directory."""
    level = graph.levels(system)
    pages = {f"{system.name}/{INDEX}": index_page(system)}
    for controller in system.controllers:
        page = controller_page(system, controller, level[controller.name])
        pages[f"{system.name}/{controller.name}.md"] = page
    return pages


def plan(systems: list[IRSystem], output: Path) -> tuple[write.Plan, Diagnostics]:
    """What `rcsgen doc` writes and deletes under `output` (nothing is written)."""
    files: dict[str, str] = {}
    for system in systems:
        files.update(render(system))
    problems = Diagnostics()
    result = write.plan_outputs(files, output, [s.name for s in systems], problems, "*.md")
    return result, problems
