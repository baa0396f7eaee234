"""Command line: `rcsgen validate`, `build`, `run`, `graph`, `doc` and `trace`.

Exit codes follow Click: 0 clean, 1 the specs (or generated/) have a problem, 2 misuse.
Diagnostics go to stderr as `file:line:col: error[CODE]: message`, sorted by position; with
`--format json`, `validate` and `build` print them instead as one JSON array on stdout (every
other message then goes to stderr), for editors and CI.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import click

from .compiler import write
from .compiler.diagnostics import Diagnostic, Diagnostics, to_json
from .compiler.frontend import compile_paths
from .compiler.ir import IRSystem

if TYPE_CHECKING:
    from .tools.scenario import RunResult
    from .tools.traces import Trace


def _source_line(diag: Diagnostic) -> str | None:
    try:
        lines = Path(diag.span.file).read_text(encoding="utf-8").splitlines()
        return lines[diag.span.line - 1] if 0 < diag.span.line <= len(lines) else None
    except (OSError, UnicodeDecodeError):
        return None


def report(diags: Diagnostics, strict: bool = False, fmt: str = "text") -> bool:
    """Print every diagnostic (text on stderr, or a JSON array on stdout); True to fail."""
    shown = list(diags)  # sorted, each distinct diagnostic once
    if fmt == "json":
        click.echo(to_json(shown))
        return _fails(shown, strict)
    for diag in shown:
        click.echo(diag.render(_source_line(diag)), err=True)
    errors = sum(d.severity == "error" for d in shown)
    warnings = len(shown) - errors
    if errors or warnings:
        click.echo(f"{errors} error(s), {warnings} warning(s)", err=True)
    return bool(errors or (strict and warnings))


def _fails(diags: Iterable[Diagnostic], strict: bool) -> bool:
    return any(d.severity == "error" or strict for d in diags)


SPEC_PATHS = click.argument(
    "paths", nargs=-1, type=click.Path(path_type=Path, exists=False), metavar="[SPECS]..."
)
FORMAT = click.option(
    "--format",
    "fmt",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
    help="Diagnostics as text on stderr, or as one JSON array on stdout (editors, CI).",
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rcsgen")
def main() -> None:
    """Generate NIST RCS controllers (QQ1-style Python) from declared state tables."""


@main.command()
@SPEC_PATHS
@click.option("--strict", is_flag=True, help="Fail on warnings too.")
@FORMAT
def validate(paths: tuple[Path, ...], strict: bool, fmt: str) -> None:
    """Check specs (schema and semantics) and report every problem found."""
    front = compile_paths(list(paths) or [Path("specs")])
    if report(front.diagnostics, strict, fmt):
        sys.exit(1)
    names = ", ".join(s.name for s in front.systems)
    click.echo(f"ok: {names}", err=fmt == "json")


@main.command()
@SPEC_PATHS
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Output directory; each system gets <output>/<system>/.",
)
@click.option("--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale.")
@click.option("--strict", is_flag=True, help="Fail on warnings too.")
@FORMAT
def build(paths: tuple[Path, ...], output: Path, check: bool, strict: bool, fmt: str) -> None:
    """Generate the Python packages of the systems found in SPECS (default: specs/)."""
    front = compile_paths(list(paths) or [Path("specs")])
    quiet = fmt == "json"  # stdout holds one JSON array; every other message goes to stderr
    if (report if not quiet else _fails)(front.diagnostics, strict):
        if quiet:
            report(front.diagnostics, strict, fmt)
        click.echo("build failed: nothing was written", err=True)
        sys.exit(1)
    plan, problems = write.plan_build(front.systems, output)
    # In JSON, one array holds them all; as text, the front end's were printed above.
    diags = Diagnostics([*front.diagnostics.items, *problems.items] if quiet else problems.items)
    if report(diags, fmt=fmt):
        click.echo("build failed: nothing was written", err=True)
        sys.exit(1)
    if check:
        if plan.stale:
            click.echo(write.unified_diff(plan, output), nl=False, err=quiet)
            click.echo(
                f"{output} is stale: {len(plan.write)} file(s) to write, "
                f"{len(plan.delete)} to delete; run `rcsgen build` to update it",
                err=True,
            )
            sys.exit(1)
        click.echo(f"{output} is current ({plan.unchanged} files)", err=quiet)
        return
    write.apply(plan)
    click.echo(
        f"built {', '.join(s.name for s in front.systems)} into {output}: "
        f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged",
        err=quiet,
    )


@main.command()
@click.argument("scenario", type=click.Path(path_type=Path, dir_okay=False))
@click.option(
    "--generated",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Where `rcsgen build` put the system packages.",
)
@click.option(
    "--trace",
    "trace_path",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Trace file to write [default: traces/<scenario>.jsonl].",
)
@click.option(
    "--record",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Re-record this golden trace file (review the diff before committing it).",
)
@click.option(
    "--processes",
    is_flag=True,
    help="Run every process as its own OS process, in lockstep (the same trace).",
)
def run(
    scenario: Path,
    generated: Path,
    trace_path: Path | None,
    record: Path | None,
    processes: bool,
) -> None:
    """Run a scenario on the generated system and summarise it."""
    from .compiler.diagnostics import SpecError
    from .tools import scenario as scenarios
    from .tools.harness import AnyHarness

    try:
        spec = scenarios.load_scenario(scenario)
    except SpecError as error:
        report(error.diagnostics)
        sys.exit(1)
    system_name = _system_name(spec.system_dir)
    package = generated / system_name
    if not (package / "__init__.py").is_file():
        click.echo(f"error: no generated package at {package}; run `rcsgen build` first", err=True)
        sys.exit(1)
    signal.signal(signal.SIGTERM, _interrupt)  # stops like Ctrl-C: processes and segment
    try:
        harness = scenarios.open_harness(spec, package, processes)
    except KeyboardInterrupt:  # what had started is stopped and removed already
        click.echo("interrupted while starting: no trace written", err=True)
        sys.exit(130)

    def progress(h: AnyHarness) -> None:
        if h.cycles % 100 == 0:
            busy = [m for m in h.modules if h.status(m).status == "EXECUTING"]
            phases = "  ".join(f"{m} {h.sent(m).command}/{h.status(m).state}" for m in busy)
            click.echo(f"  cycle {h.cycles:>6}  {phases}", err=True)

    interrupted = False
    try:
        result = scenarios.run(spec, harness, progress)
    except KeyboardInterrupt:
        interrupted = True
    finally:  # a second signal must not cut the stop short (the segment would be left)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        harness.close()
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if interrupted:
        click.echo(f"interrupted at cycle {harness.cycles}: no trace written", err=True)
        for line in getattr(harness, "summary", list)():
            click.echo(line)
        sys.exit(130)
    trace_path = trace_path or Path("traces") / f"{spec.name}.jsonl"
    scenarios.write_trace(trace_path, result.trace)
    if record is not None:
        scenarios.write_trace(record, result.trace)
    _summarise(result, trace_path, record)
    if spec.stop_when_done and result.final.get("status") != "DONE":
        sys.exit(1)


@main.command(context_settings={"ignore_unknown_options": True})
@click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False))
@click.option(
    "--generated",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Where `rcsgen build` put the system packages.",
)
@click.argument("options", nargs=-1, type=click.UNPROCESSED)
def up(system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Start a built system: every process as its own OS process, paced, until Ctrl-C.

    OPTIONS go to `python -m <system>` (e.g. `--cycles 100`, `--restart`, `--shm NAME`,
    one PROCESS, `--help`).
    """
    _exec_package(system_dir, generated, list(options))


@main.command(context_settings={"ignore_unknown_options": True})
@click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False))
@click.option(
    "--generated",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Where `rcsgen build` put the system packages.",
)
@click.argument("options", nargs=-1, type=click.UNPROCESSED)
def ctl(system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Operate a running system: status, stop/run, step, simulate, slow, send, wait.

    OPTIONS go to `python -m <system> ctl` (e.g. `status --watch`, `send sb BOX_CUT
    depth=1.5`, `step co 5`, `--help`): the console the generated package carries.
    """
    _exec_package(system_dir, generated, ["ctl", *options])


@main.command()
@click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False))
@click.option(
    "--generated",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Where `rcsgen build` put the system packages.",
)
@click.option("--shm", default=None, help="The segment [default: the launcher's].")
def monitor(system_dir: Path, generated: Path, shm: str | None) -> None:
    """Watch and operate a running system in a live terminal screen (rcsgen[monitor]).

    Keys act on the selected module: s stop, r run, n single-step, i simulate on/off,
    + / - slow down / speed up every process, c send a command, q quit.
    """
    import importlib

    try:
        from .tools.monitor import Monitor
    except ImportError:
        fail("the monitor needs textual: pip install 'rcsgen[monitor]'")
    from .runtime.block import BlockError
    from .tools.harness import import_package

    if not (system_dir / "system.yaml").is_file():
        fail(f"no system.yaml in {system_dir}", 2)
    name = _system_name(system_dir)
    package_dir = generated / name
    if not (package_dir / "layout.py").is_file():
        fail(f"no generated package at {package_dir}; run `rcsgen build` first")
    layout = importlib.import_module(f"{import_package(package_dir.resolve()).__name__}.layout")
    segment = shm or f"rcs_{layout.SYSTEM}_{layout.LAYOUT_HASH[:8]}"
    try:
        app = Monitor(layout, segment)
    except BlockError as error:
        fail(str(error))
    app.run()


def _exec_package(system_dir: Path, generated: Path, argv: list[str]) -> NoReturn:
    """Replace this process by `python -m <system> ARGV`, the package and hooks on its path."""
    if not (system_dir / "system.yaml").is_file():
        click.echo(f"error: no system.yaml in {system_dir}", err=True)
        sys.exit(2)
    name = _system_name(system_dir)
    package = generated / name
    if not (package / "__main__.py").is_file():
        click.echo(f"error: no generated package at {package}; run `rcsgen build` first", err=True)
        sys.exit(1)
    path = [str(generated.resolve()), str(system_dir.resolve())]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*path, *sys.path])}
    os.execve(sys.executable, [sys.executable, "-m", name, *argv], env)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _system_name(system_dir: Path) -> str:
    from .compiler.loader import load_file

    data = load_file(system_dir / "system.yaml", "system.yaml")
    return str(data["system"]) if isinstance(data, dict) else system_dir.name


def _summarise(result: RunResult, trace_path: Path, record: Path | None) -> None:
    spec = result.scenario
    click.echo(f"scenario  {spec.name}: {spec.title}")
    if spec.stop_when_done:
        final = result.final
        click.echo(f"result    {spec.stop_when_done} {final['status']} (state {final['state']})")
    click.echo(f"cycles    {result.cycles}")
    if result.phase_cycles:
        click.echo(f"phases    cycles per {spec.phases_of} command:")
        for phase, count in result.phase_cycles.items():
            click.echo(f"            {phase:<26} {count:>6}")
    for name, value in result.figures.items():
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        click.echo(f"{name.replace('_', ' '):<9} {shown}")
    slowest = sorted(result.max_cycle_ns.items(), key=lambda item: -item[1])
    click.echo("max cycle time per module (us):")
    for row in range(0, len(slowest), 6):
        cells = "  ".join(f"{m} {ns / 1000:.1f}" for m, ns in slowest[row : row + 6])
        click.echo(f"            {cells}")
    click.echo(f"trace     {trace_path} ({len(result.trace)} lines)")
    if record is not None:
        click.echo(f"recorded  {record}: review `git diff {record}` before committing")


# ---------------------------------------------------------------- pictures and the reference


def fail(message: str, code: int = 1) -> NoReturn:
    """One line on stderr, `error: ...`, and the exit code (1 bad input, 2 misuse)."""
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def _systems(paths: tuple[Path, ...]) -> list[IRSystem]:
    """The systems in SPECS (default specs/); on an error in the specs, its diagnostics and
    exit 1. Warnings are `validate`'s business: pictures and pages do not repeat them."""
    front = compile_paths(list(paths) or [Path("specs")])
    if report(Diagnostics(front.diagnostics.errors)):
        sys.exit(1)
    return front.systems


def _one_system(paths: tuple[Path, ...]) -> IRSystem:
    """The one system in SPECS (default specs/), or a one-line error and exit."""
    systems = _systems(paths)
    if len(systems) != 1:
        names = ", ".join(s.name for s in systems)
        fail(f"SPECS hold {len(systems)} systems ({names}): name one system directory", 2)
    return systems[0]


def _write_or_print(text: str, output: Path | None) -> None:
    if output is None:
        click.echo(text, nl=False)
        return
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(text, encoding="utf-8")
    except OSError as error:
        fail(f"cannot write {output}: {error.strerror or error}")
    click.echo(f"wrote {output} ({len(text.encode('utf-8')):,} bytes)", err=True)


@main.command("graph")
@SPEC_PATHS
@click.option(
    "-p",
    "--picture",
    default="hierarchy",
    show_default=True,
    help="hierarchy; order or order:<module> (a command's round trip down to that module, "
    "cycle by cycle); a controller (co: all its state graphs) or one command "
    "(co.SUMP_SHEAR_CUSP).",
)
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["mermaid", "dot", "svg"]),
    default="mermaid",
    show_default=True,
    help="Mermaid and DOT are text; SVG is drawn by Graphviz's dot.",
)
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Write to this file [default: stdout].",
)
def graph_command(paths: tuple[Path, ...], picture: str, fmt: str, output: Path | None) -> None:
    """Draw the hierarchy, a state graph or the execution order of the system in SPECS."""
    from .tools import graph

    system = _one_system(paths)
    try:
        text = graph.render(graph.picture(system, picture), fmt)
    except graph.GraphError as error:
        fail(str(error), 2 if str(error).startswith("unknown") else 1)
    _write_or_print(text, output)


@main.command("doc")
@SPEC_PATHS
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("docs/reference"),
    show_default=True,
    help="Output directory; each system gets <output>/<system>/.",
)
@click.option("--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale.")
def doc_command(paths: tuple[Path, ...], output: Path, check: bool) -> None:
    """Write the Markdown reference of the systems in SPECS: one page per controller."""
    from .tools import reference

    systems = _systems(paths)
    plan, problems = reference.plan(systems, output)
    if report(problems):
        click.echo("doc failed: nothing was written", err=True)
        sys.exit(1)
    if check:
        if plan.stale:
            click.echo(write.unified_diff(plan, output), nl=False)
            shown = " ".join(str(p) for p in paths) or "specs/"
            click.echo(
                f"{output} is stale: {len(plan.write)} page(s) to write, {len(plan.delete)} to "
                f"delete; run `rcsgen doc {shown} -o {output}` to update it",
                err=True,
            )
            sys.exit(1)
        click.echo(f"{output} is current ({plan.unchanged} pages)")
        return
    write.apply(plan)
    click.echo(
        f"wrote the reference of {', '.join(s.name for s in systems)} into {output}: "
        f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged"
    )


# ---------------------------------------------------------------- traces


@main.group("trace")
def trace_group() -> None:
    """Look at traces: an HTML timeline, the changes only, rule coverage, the mine."""


TRACE_ARG = click.argument("trace_path", metavar="TRACE", type=click.Path(path_type=Path))
SPECS_OPTION = click.option(
    "--specs",
    type=click.Path(path_type=Path),
    default=None,
    help="The specs the trace was recorded from [default: specs/, when it is there].",
)


def _load_trace(path: Path) -> Trace:
    from .tools import traces

    try:
        return traces.load(path)
    except traces.TraceError as error:
        fail(str(error))


def _trace_system(specs: Path | None, found: list[Trace], required: bool) -> IRSystem | None:
    """The system that recorded the traces, from --specs (or specs/ when it is there): its
    execution order, levels, titles and rules. None when no specs are at hand and they are
    not `required`; a one-line error when the traces do not fit them."""
    from .tools import traces

    if specs is None and not Path("specs").is_dir():
        if required:
            fail("no specs/ here: name the specs the trace was recorded from with --specs", 2)
        return None
    systems = _systems((specs,) if specs is not None else ())
    problems = []
    for system in systems:
        try:
            for one in found:
                traces.check_against(system, one)
            return system
        except traces.TraceError as error:
            problems.append(str(error))
    if specs is None and not required:
        return None  # a trace of other specs: shown without them
    fail(problems[0] if len(problems) == 1 else f"no system in {specs or 'specs'} ran the trace")


@trace_group.command("changes")
@TRACE_ARG
@click.option(
    "-m",
    "--module",
    "modules",
    multiple=True,
    help="Only these modules (repeat, or separate with commas).",
)
@click.option(
    "--world",
    type=click.Choice(["discrete", "all", "none"]),
    default="discrete",
    show_default=True,
    help="World fields: bool and int ones, every one (floats drift every cycle), or none.",
)
@click.option("--from", "first", type=int, default=None, help="First cycle shown.")
@click.option("--to", "last", type=int, default=None, help="Last cycle shown.")
@click.option(
    "--every-cycle", is_flag=True, help="Do not fold cycles that change alike into one entry."
)
@SPECS_OPTION
def trace_changes(
    trace_path: Path,
    modules: tuple[str, ...],
    world: str,
    first: int | None,
    last: int | None,
    every_cycle: bool,
    specs: Path | None,
) -> None:
    """Print only what changed, cycle by cycle: commands, statuses, states, rules fired."""
    from .tools import changes, traces

    found = _load_trace(trace_path)
    try:
        chosen = traces.select(found, list(modules))
    except traces.TraceError as error:
        fail(str(error), 2)
    system = _trace_system(specs, [found], required=False)
    lanes = traces.lanes(found, system)
    colour = {"ERROR": "red", "DONE": "green", "EXECUTING": "blue"}
    for line in changes.timeline(found, lanes, chosen, world, first, last, not every_cycle):
        if line.startswith("cycle "):
            click.secho(line, bold=True)
            continue
        for status, fg in colour.items():
            line = line.replace(f"-> {status} ", f"-> {click.style(status, fg=fg)} ")
        click.echo(line)


@trace_group.command("coverage")
@click.argument(
    "trace_paths", metavar="TRACES...", nargs=-1, required=True, type=click.Path(path_type=Path)
)
@SPECS_OPTION
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
    help="A summary and the rules that never fired, or one JSON object.",
)
def trace_coverage(trace_paths: tuple[Path, ...], specs: Path | None, fmt: str) -> None:
    """Which rules of which state tables fired in TRACES, and which never did."""
    from .tools import coverage

    found = [_load_trace(path) for path in trace_paths]
    system = _trace_system(specs, found, required=True)
    assert system is not None
    result = coverage.measure(system, found)
    click.echo(coverage.to_json(result) if fmt == "json" else coverage.to_text(result), nl=False)


@trace_group.command("show")
@TRACE_ARG
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="The page to write [default: the trace's path with .html].",
)
@SPECS_OPTION
def trace_show(trace_path: Path, output: Path | None, specs: Path | None) -> None:
    """Write TRACE as one self-contained HTML page: swim-lanes, world plots, a cursor."""
    from .tools import trace_view, traces

    found = _load_trace(trace_path)
    system = _trace_system(specs, [found], required=False)
    lanes = traces.lanes(found, system)
    page = trace_view.render(
        found, lanes, system.name if system else None, system.cycle_period if system else None
    )
    _write_or_print(page, output or trace_path.with_suffix(".html"))


@trace_group.command("mine")
@TRACE_ARG
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="The page to write [default: the trace's path with .mine.html].",
)
@SPECS_OPTION
@click.option(
    "--scenario",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="The scenario that recorded TRACE, for its map setting [default: the system's "
    "scenarios/<trace name>.yaml, as `rcsgen run` names traces].",
)
def trace_mine(
    trace_path: Path, output: Path | None, specs: Path | None, scenario: Path | None
) -> None:
    """Write a miner TRACE as an HTML replay of the machine in the mine (coal map, cut, pose)."""
    from .compiler.diagnostics import SpecError
    from .compiler.frontend import find_system_dirs
    from .tools import mine_view, traces
    from .tools.scenario import load_scenario

    found = _load_trace(trace_path)
    system = _trace_system(specs, [found], required=True)
    assert system is not None
    where = [specs] if specs is not None else [Path("specs")]
    system_dir = next(
        d for d in find_system_dirs(where, Diagnostics()) if d.name == system.source.split("/")[0]
    )
    if scenario is None:
        guess = system_dir / "scenarios" / f"{trace_path.stem}.yaml"
        scenario = guess if guess.is_file() else None
    settings: dict[str, str] = {}
    if scenario is not None:
        try:
            settings = load_scenario(scenario).settings
        except SpecError as error:
            report(error.diagnostics)
            sys.exit(1)
    try:
        page, result = mine_view.render(
            found,
            traces.lanes(found, system),
            system,
            system_dir,
            settings,
            scenario.stem if scenario is not None else "",
        )
    except mine_view.MineError as error:
        fail(str(error))
    if result.mismatch:
        click.echo(
            f"warning: the replayed cut differs from the trace at {result.mismatch}", err=True
        )
    _write_or_print(page, output or trace_path.with_suffix(".mine.html"))
