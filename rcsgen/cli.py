"""Command line: `rcsgen validate | build | run | up | ctl | monitor | graph | doc | new | trace
| prove`.

Each command parses its arguments, makes one call into the API (`rcsgen.api`) or a tool,
and renders what came back; how a command ends (its exit code), reads the options it shares
and prints is `rcsgen.terminal`'s, which says what the exit codes mean. A new command is one
block here: `@main.command()`, its options, and a body of a few lines.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from . import api
from .cli_prove import prove
from .cli_trace import trace_group
from .compiler.diagnostics import Diagnostics, SpecError, counted
from .terminal import (
    CHECK,
    GENERATED,
    SPEC_PATHS,
    SYSTEM_DIR,
    Commands,
    Exit,
    Number,
    Progress,
    Session,
    cycle_progress,
    error,
    exec_package,
    help_first,
    interrupted,
    note,
    output_dir_option,
    output_file,
    page_option,
    report,
    reporting,
    require_system,
    run_summary,
    scaffolded,
    specs_or_default,
    systems_in,
    wants_help,
    write_or_print,
)
from .tools.report import Options


@click.group(cls=Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rcsgen")
def main() -> None:
    """Generate NIST RCS controllers (QQ1-style Python) from declared state tables."""


@main.command()
@SPEC_PATHS
@click.option(
    "--connect",
    is_flag=True,
    help="Also connect to each declared I/O device and read every bound point (E458).",
)
@reporting
def validate(paths: tuple[Path, ...], connect: bool, opts: Options) -> None:
    """Check specs (schema and semantics) and their scenarios; report every problem found.
    With --connect, also ask each declared I/O device whether every bound point is there."""
    progress = Progress(opts)
    front = api.validate(specs_or_default(paths), progress, connect=connect)
    progress.done()
    if report(front.diagnostics, opts).fails:
        raise Exit(1)
    note(opts, f"ok: {', '.join(s.name for s in front.systems)}")


@main.command()
@SPEC_PATHS
@output_dir_option("generated")
@CHECK
@reporting
def build(paths: tuple[Path, ...], output: Path, check: bool, opts: Options) -> None:
    """Generate the Python packages of the systems found in SPECS (default: specs/)."""
    from .compiler.back_end import write  # here: `validate` does not render

    session, progress, failed = Session(opts), Progress(opts), "build failed: nothing was written"
    front = api.check(specs_or_default(paths), progress)
    session.add(front.diagnostics)
    if not session.fails:
        plan, problems = write.plan_build(front.systems, output, progress)
        session.add(problems)
    progress.done()
    if session.fails or check:
        session.finish(failed)
    if check:
        if plan.stale:  # stdout holds the diagnostics in a machine format: the diff, stderr
            click.echo(write.unified_diff(plan, output), nl=False, err=opts.fmt != "text")
            stale = f"{counted(len(plan.write), 'file')} to write, {len(plan.delete)} to delete"
            raise Exit(1, f"{output} is stale: {stale}; run `rcsgen build` to update it")
        note(opts, f"{output} is current ({plan.unchanged} files)")
        return
    try:
        progress(f"writing {len(plan.write)} files, deleting {len(plan.delete)}")
        write.apply(plan)
    except SpecError as problem:  # the disk refused: everything was undone
        session.add(problem.diagnostics)
    progress.done()
    session.finish(failed)
    built = f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged"
    note(opts, f"built {', '.join(s.name for s in front.systems)} into {output}: {built}")


@main.command()
@click.argument("scenario", type=click.Path(path_type=Path, dir_okay=False))
@click.option(
    "--generated",
    type=click.Path(path_type=Path),
    default=None,
    help="Run the package `rcsgen build` put here, after checking it is current (by "
    "default the system is built in memory from its specs).",
)
@click.option(
    "--trace",
    "trace_path",
    type=click.Path(dir_okay=False),
    default=None,
    callback=output_file,
    help="Trace file to write [default: traces/<scenario>.jsonl]; gzipped if it ends in .gz.",
)
@click.option(
    "--record",
    type=click.Path(dir_okay=False),
    default=None,
    callback=output_file,
    help="Re-record this golden trace file (review the diff before committing it).",
)
@click.option(
    "--golden",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="Compare the trace with this golden trace; exit 1 at the first differing cycle.",
)
@click.option(
    "--processes",
    is_flag=True,
    help="Run every process as its own OS process, in lockstep (the same trace).",
)
@click.option("-v", "--verbose", is_flag=True, help="Show a failing hook's Python traceback.")
@reporting
def run(
    scenario: Path,
    generated: Path | None,
    trace_path: Path | None,
    record: Path | None,
    golden: Path | None,
    processes: bool,
    verbose: bool,
    opts: Options,
) -> None:
    """Run a scenario on its system (built from the specs) and check its outcome."""
    import tempfile

    from .tools.scenario import runs
    from .tools.scenario import session as session_of

    session, not_run = Session(opts), "run failed: nothing was run"
    checked = session_of.check(scenario)
    for found in checked.diagnostics:
        session.add(found)
    spec, system = checked.scenario, checked.system
    if session.fails or spec is None or system is None:
        session.finish(not_run)
        raise Exit(1)  # (a system that does not build always has an error)
    trace_path = trace_path or Path("traces") / f"{spec.name}.jsonl"
    line = Progress(opts)
    # With a machine format, stdout holds only the diagnostics: what hooks print goes to stderr.
    hooks_out = sys.stderr if opts.fmt != "text" else sys.stdout
    with tempfile.TemporaryDirectory(prefix="rcsgen-run-") as scratch:
        package, stale = session_of.package(system, generated, Path(scratch))
        if stale:
            session.add(stale)
            session.finish(not_run)
        progress = cycle_progress(line, spec.max_cycles)
        ran = session_of.execute(spec, package, processes, progress, hooks_out, trace_path)
    line.done()
    if ran.signal is not None:
        interrupted(ran, ran.signal, spec.name, trace_path)
    if ran.failed is not None:
        problem, cycle = ran.failed
        session.add([runs.run_error(problem, system, cycle, package.resolve())])
        if verbose and runs.details(problem):
            click.echo(runs.details(problem).rstrip("\n"), err=True)
        session.finish()
        raise Exit(1)
    assert ran.result is not None  # (else it failed or was interrupted)
    result, machine = ran.result, opts.fmt != "text"
    problems = session_of.write_traces(result.trace, [trace_path, *([record] if record else [])])
    unmet = runs.unmet_expectations(spec, result, ran.final_world)
    if not opts.quiet:
        for text in run_summary(result, trace_path, record, unmet=len(unmet)):
            click.echo(text, err=machine)
    problems.extend(unmet)
    if golden is not None:
        differences = runs.golden_differences(golden, result.trace, spec.name)
        problems.extend(differences)
        if not differences and not opts.quiet:  # a match is said too: silence reads as skipped
            same = f"identical, cycle for cycle ({len(result.trace)} lines)"
            click.echo(f"golden    {golden}: {same}", err=machine)
    session.add(problems)
    session.finish()


# `--help` is not click's for these two: after SYSTEM_DIR it is the package's (its options are
# the ones that matter), before it this command's.
PASS_THROUGH = {"ignore_unknown_options": True, "help_option_names": []}
OPTIONS = click.argument("options", nargs=-1, type=click.UNPROCESSED)


@main.command(context_settings=PASS_THROUGH)
@SYSTEM_DIR
@GENERATED
@OPTIONS
@click.pass_context
def up(ctx: click.Context, system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Start a built system: every process as its own OS process, paced, until Ctrl-C.

    OPTIONS go to `python -m <system>` (e.g. `--cycles 100`, `--restart`, `--shm NAME`,
    one PROCESS, `--deploy FILE HOST` for one host of several; `--help` lists them). The
    package is checked first: one built from other specs than SYSTEM_DIR's is refused
    (E418), as `rcsgen run --generated` refuses it.
    """
    help_first(ctx, system_dir)
    if not wants_help(options) and (system_dir / "system.yaml").is_file():
        errors, stale = api.stale(system_dir, generated)
        if report(errors, Options()).fails:
            raise error("the specs do not build: nothing was started")
        if stale:
            report(Diagnostics(stale), Options())
            raise error("nothing was started")
    exec_package(system_dir, generated, list(options), ctx)


@main.command(context_settings=PASS_THROUGH)
@SYSTEM_DIR
@GENERATED
@OPTIONS
@click.pass_context
def ctl(ctx: click.Context, system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Operate a running system: status, stop/run, step, simulate, slow, send, wait.

    OPTIONS go to `python -m <system> ctl` (e.g. `status --watch`, `send sb BOX_CUT
    depth=1.5`, `step co 5`; `--help` lists them): the console the generated package carries.
    """
    help_first(ctx, system_dir)
    exec_package(system_dir, generated, ["ctl", *options], ctx)


@main.command()
@SYSTEM_DIR
@GENERATED
@click.option("--shm", default=None, help="The segment [default: the launcher's].")
@click.option(
    "--role",
    envvar="RCS_ROLE",
    default=None,
    help="The operator role whose access levels apply (system.yaml `operators`) [$RCS_ROLE].",
)
@click.option(
    "--connect",
    multiple=True,
    metavar="PROTO/HOST:PORT",
    help="Attach through Zenoh to a host of a system run with --transport zenoh.",
)
@click.option(
    "--world",
    default="",
    metavar="FIELD,...",
    help="The world fields shown under the modules [default: every one].",
)
def monitor(
    system_dir: Path,
    generated: Path,
    shm: str | None,
    role: str | None,
    connect: tuple[str, ...],
    world: str,
) -> None:
    """Watch and operate a running system in a live terminal screen (rcsgen[monitor]).

    Keys act on the selected module: s stop, r run, n single-step, i simulate on/off,
    + / - slow down / speed up every process, c send a command, a answer the module's
    request, q quit. What they may do is the role's access level on the module.
    """
    try:
        from .tools.monitor import Monitor
    except ImportError:
        raise error("the monitor needs textual: pip install 'rcsgen[monitor]'") from None
    from .runtime.block import BlockError
    from .runtime.operate.ctl import CtlError
    from .runtime.operate.startup import default_segment, segment_problem
    from .runtime.transport import TransportError
    from .tools.harness import import_layout

    require_system(system_dir, "monitor")
    package_dir = generated / api.system_name(system_dir)
    if not (package_dir / "layout.py").is_file():
        raise error(f"no generated package at {package_dir}; run `rcsgen build` first")
    layout = import_layout(package_dir)
    segment = shm or default_segment(layout)
    if not connect and segment_problem(segment):
        raise error(segment_problem(segment), 2)
    fields = tuple(f for f in world.split(",") if f) or None
    try:
        app = Monitor(layout, segment, role=role, connect=connect, world=fields)
    except CtlError as problem:
        raise error(str(problem), problem.code) from None
    except (BlockError, TransportError, ValueError) as problem:
        raise error(str(problem)) from None
    app.run()


# ---------------------------------------------------------------- pictures and the reference


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
@page_option("stdout", "Write to this file")
def graph_command(paths: tuple[Path, ...], picture: str, fmt: str, output: Path | None) -> None:
    """Draw the hierarchy, a state graph or the execution order of the system in SPECS."""
    from .tools import graph

    systems = systems_in(paths)
    if len(systems) != 1:
        names = ", ".join(s.name for s in systems)
        raise error(f"SPECS hold {len(systems)} systems ({names}): name one system directory", 2)
    try:
        text = graph.render(graph.picture(systems[0], picture), fmt)
    except graph.GraphError as problem:
        raise error(str(problem), 2 if str(problem).startswith("unknown") else 1) from None
    write_or_print(text, output)


@main.command("doc")
@SPEC_PATHS
@output_dir_option("docs/reference", file_okay=False)
@CHECK
def doc_command(paths: tuple[Path, ...], output: Path, check: bool) -> None:
    """Write the Markdown reference of the systems in SPECS: one page per controller."""
    from .compiler.back_end import write
    from .tools import reference

    systems = systems_in(paths)
    plan, problems = reference.plan(systems, output)
    if report(problems, Options()).fails:
        raise Exit(1, "doc failed: nothing was written")
    if check:
        if plan.stale:
            click.echo(write.unified_diff(plan, output), nl=False)
            shown = " ".join(str(p) for p in paths) or "specs/"
            stale = f"{counted(len(plan.write), 'page')} to write, {len(plan.delete)} to delete"
            again = f"run `rcsgen doc {shown} -o {output}` to update it"
            raise Exit(1, f"{output} is stale: {stale}; {again}")
        click.echo(f"{output} is current ({plan.unchanged} pages)")
        return
    write.apply(plan)
    names = ", ".join(s.name for s in systems)
    done = f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged"
    click.echo(f"wrote the reference of {names} into {output}: {done}")


# ---------------------------------------------------------------- new specs


@main.group("new")
def new_group() -> None:
    """Start a system or a controller from the QQ1 template: files that validate cleanly."""


@new_group.command("system")
@click.argument("name")
@click.option(
    "--specs",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("specs"),
    show_default=True,
    help="Where the system's directory goes.",
)
@click.option("--root", default="top", show_default=True, help="The root controller's mnemonic.")
@click.option(
    "--period",
    type=Number(0, 3600, above=True),
    default=0.1,
    show_default=True,
    help="Cycle period, seconds.",
)
@click.option("--title", default="", help="One-line human name [default: the name].")
def new_system(name: str, specs: Path, root: str, period: float, title: str) -> None:
    """SPECS/NAME/: system.yaml, the root controller and a first scenario."""
    from .tools.scaffold import new_system as scaffold

    scaffolded(lambda: scaffold(specs, name, root, period, title))
    click.echo(f"next: rcsgen validate {specs / name} && rcsgen build {specs}")


@new_group.command("controller")
@SYSTEM_DIR
@click.argument("name")
@click.option("--supervisor", default=None, help="The controller that commands it.")
@click.option("--process", default=None, help="The process it runs in [default: its supervisor's].")
def new_controller(
    system_dir: Path, name: str, supervisor: str | None, process: str | None
) -> None:
    """SYSTEM_DIR/NAME.yaml, added to its supervisor's subordinates and to a process."""
    from .tools.scaffold import new_controller as scaffold

    scaffolded(lambda: scaffold(system_dir, name, supervisor, process))


main.add_command(trace_group)  # rcsgen trace ...: rcsgen/cli_trace.py
main.add_command(prove)  # rcsgen prove: rcsgen/cli_prove.py
