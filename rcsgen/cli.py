"""Command line: `rcsgen validate`, `rcsgen build`, `rcsgen run`.

Exit codes follow Click: 0 clean, 1 the specs (or generated/) have a problem, 2 misuse.
Diagnostics go to stderr as `file:line:col: error[CODE]: message`, sorted by position; with
`--format json`, `validate` and `build` print them instead as one JSON array on stdout (every
other message then goes to stderr), for editors and CI.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import click

from .compiler import write
from .compiler.diagnostics import Diagnostic, Diagnostics, SpecError
from .compiler.frontend import compile_paths
from .compiler.ir import IRSystem
from .compiler.loader import decode, read_bytes
from .tools import config, runs
from .tools.config import Config, ConfigError
from .tools.report import (
    FORMATS,
    Options,
    Outcome,
    code_prefix_problem,
    outcome,
    render_text,
    shown,
    statistics,
    summary,
    to_github,
    to_json,
    to_sarif,
)

if TYPE_CHECKING:
    from .tools.scenario import RunResult


@functools.cache
def _source_lines(file: str) -> list[str] | None:
    """The lines of a file a diagnostic names (read safely: it may be a FIFO or a device)."""
    try:
        return decode(read_bytes(Path(file), file), file).splitlines()
    except SpecError:
        return None


def _source_line(diag: Diagnostic) -> str | None:
    lines = _source_lines(diag.span.file)
    if lines is None or not 0 < diag.span.line <= len(lines):
        return None
    return lines[diag.span.line - 1]


def report(diags: Diagnostics, opts: Options) -> Outcome:
    """Print the diagnostics the options select, in their format; what was found.

    Text goes to stderr (a summary line after it, unless quiet); JSON, SARIF and GitHub
    annotations go to stdout, where CI reads them."""
    active, acknowledged = shown(diags, opts)
    result = outcome(diags, opts)
    every = sorted({*active, *acknowledged}, key=Diagnostic.sort_key)
    if opts.fmt == "json":
        click.echo(to_json(every))
    elif opts.fmt == "sarif":
        click.echo(to_sarif(every, _version()))
    elif opts.fmt == "github":
        if every:
            click.echo(to_github(every))
    elif opts.statistics:
        for line in statistics(every):
            click.echo(line, err=True)
    else:
        style = click.style if opts.color else None
        for diag in every:
            click.echo(render_text(diag, _source_line(diag), style), err=True, color=opts.color)
    if opts.fmt == "text" and not opts.quiet and summary(result):
        click.echo(summary(result), err=True)
    return result


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rcsgen")
    except PackageNotFoundError:
        return "unknown"


def _note(opts: Options, message: str) -> None:
    """A line for the user, unless quiet: on stdout, or stderr when stdout holds the
    diagnostics (JSON, SARIF, GitHub)."""
    if not opts.quiet:
        click.echo(message, err=opts.fmt != "text")


SPEC_PATHS = click.argument(
    "paths",
    nargs=-1,
    # Existence and readability are checked by the front end, as located diagnostics.
    type=click.Path(path_type=Path, exists=False, readable=False),
    metavar="[SPECS]...",
)


def _codes(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> tuple[str, ...]:
    """Comma-separated warning codes or prefixes, each of them valid."""
    codes = tuple(c.strip().upper() for v in values for c in v.split(",") if c.strip())
    for code in codes:
        problem = code_prefix_problem(code)
        if problem:
            raise click.BadParameter(problem, ctx=ctx, param=param)
    return codes


def reporting(command: Callable[..., None]) -> Callable[..., None]:
    """The options every command reports diagnostics with; the command receives `opts`."""

    @functools.wraps(command)
    def with_options(
        *args: object,
        select: tuple[str, ...],
        ignore: tuple[str, ...],
        strict: bool | None,
        fmt: str,
        quiet: bool,
        statistics: bool,
        show_acknowledged: bool,
        color: str,
        isolated: bool,
        **kwargs: object,
    ) -> None:
        try:
            found = Config() if isolated else config.load(Path.cwd())
        except ConfigError as error:
            raise click.UsageError(str(error)) from None
        if statistics and fmt != "text":
            raise click.UsageError("--statistics prints text; it cannot be combined with --format")
        opts = Options(
            select=select or found.select,
            ignore=(*found.ignore, *ignore),
            strict=bool(found.strict) if strict is None else strict,
            fmt=fmt,
            quiet=quiet,
            statistics=statistics,
            show_acknowledged=show_acknowledged,
            color=_colour(color),
        )
        command(*args, opts=opts, **kwargs)

    options = [
        click.option(
            "--select",
            multiple=True,
            callback=_codes,
            metavar="CODES",
            help="Show only these warnings (codes or prefixes: W503,W5). Errors always show.",
        ),
        click.option(
            "--ignore",
            multiple=True,
            callback=_codes,
            metavar="CODES",
            help="Do not show these warnings (codes or prefixes, comma-separated).",
        ),
        click.option("--strict/--no-strict", default=None, help="Fail on warnings too."),
        click.option(
            "--format",
            "fmt",
            type=click.Choice(FORMATS),
            default="text",
            show_default=True,
            help="Text on stderr; JSON, SARIF 2.1.0 or GitHub annotations on stdout.",
        ),
        click.option("-q", "--quiet", is_flag=True, help="Print diagnostics only."),
        click.option("--statistics", is_flag=True, help="Count diagnostics per code instead."),
        click.option(
            "--show-acknowledged",
            is_flag=True,
            help="Also show the warnings the specs acknowledge (allow:, first_match).",
        ),
        click.option(
            "--color",
            type=click.Choice(["auto", "always", "never"]),
            default="auto",
            show_default=True,
            help="Colour the text (auto: on a terminal, unless NO_COLOR is set).",
        ),
        click.option("--isolated", is_flag=True, help="Ignore [tool.rcsgen] in pyproject.toml."),
    ]
    for option in reversed(options):
        with_options = option(with_options)
    return with_options


def _colour(choice: str) -> bool:
    if choice != "auto":
        return choice == "always"
    if os.environ.get("NO_COLOR"):
        return False
    if os.environ.get("FORCE_COLOR"):
        return True
    return sys.stderr.isatty() and os.environ.get("TERM") != "dumb"


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="rcsgen")
def main() -> None:
    """Generate NIST RCS controllers (QQ1-style Python) from declared state tables."""


@main.command()
@SPEC_PATHS
@reporting
def validate(paths: tuple[Path, ...], opts: Options) -> None:
    """Check specs (schema and semantics) and report every problem found."""
    front = compile_paths(list(paths) or [Path("specs")])
    if report(front.diagnostics, opts).fails:
        sys.exit(1)
    _note(opts, f"ok: {', '.join(s.name for s in front.systems)}")


@main.command()
@SPEC_PATHS
@click.option(
    "-o",
    "--output",
    type=click.Path(path_type=Path),
    default=Path("generated"),
    show_default=True,
    help="Output directory; each system gets <output>/<system>/.",
)
@click.option("--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale.")
@reporting
def build(paths: tuple[Path, ...], output: Path, check: bool, opts: Options) -> None:
    """Generate the Python packages of the systems found in SPECS (default: specs/)."""
    front = compile_paths(list(paths) or [Path("specs")])
    diags = front.diagnostics
    if not outcome(diags, opts).fails:
        plan, problems = write.plan_build(front.systems, output)
        diags = Diagnostics([*diags.items, *problems.items], diags.acknowledged)
    if report(diags, opts).fails:
        click.echo("build failed: nothing was written", err=True)
        sys.exit(1)
    machine = opts.fmt != "text"  # stdout holds the diagnostics; everything else: stderr
    if check:
        if plan.stale:
            click.echo(write.unified_diff(plan, output), nl=False, err=machine)
            click.echo(
                f"{output} is stale: {len(plan.write)} file(s) to write, "
                f"{len(plan.delete)} to delete; run `rcsgen build` to update it",
                err=True,
            )
            sys.exit(1)
        _note(opts, f"{output} is current ({plan.unchanged} files)")
        return
    try:
        write.apply(plan)
    except SpecError as error:  # the disk refused: everything was undone
        report(error.diagnostics, opts)
        click.echo("build failed: nothing was written", err=True)
        sys.exit(1)
    _note(
        opts,
        f"built {', '.join(s.name for s in front.systems)} into {output}: "
        f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged",
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
@click.option("-v", "--verbose", is_flag=True, help="Show a failing hook's Python traceback.")
@reporting
def run(
    scenario: Path,
    generated: Path,
    trace_path: Path | None,
    record: Path | None,
    verbose: bool,
    opts: Options,
) -> None:
    """Run a scenario on the generated system and summarise it."""
    from .tools import scenario as scenarios
    from .tools.harness import Harness

    try:
        spec = scenarios.load_scenario(scenario)
    except SpecError as error:
        report(error.diagnostics, opts)
        sys.exit(1)
    system_name = _system_name(spec.system_dir)
    package = generated / system_name
    if not (package / "__init__.py").is_file():
        click.echo(f"error: no generated package at {package}; run `rcsgen build` first", err=True)
        sys.exit(1)
    front = compile_paths([spec.system_dir])  # the IR: where each rule and hook call is
    system = front.systems[0] if front.systems else None
    try:
        harness = scenarios.open_harness(spec, package)
    except Exception as error:  # a hook-state factory, or a module that cannot be made
        _run_failed(error, system, 0, package, opts, verbose)

    def progress(h: Harness) -> None:
        if h.cycles % 100 == 0:
            busy = [m for m in h.modules if h.status(m).status == "EXECUTING"]
            phases = "  ".join(f"{m} {h.sent(m).command}/{h.status(m).state}" for m in busy)
            click.echo(f"  cycle {h.cycles:>6}  {phases}", err=True)

    try:
        result = scenarios.run(spec, harness, progress)
    except Exception as error:  # a hook, or a module's own code, in the cycle being run
        _run_failed(error, system, harness.cycles + 1, package, opts, verbose)
    trace_path = trace_path or Path("traces") / f"{spec.name}.jsonl"
    scenarios.write_trace(trace_path, result.trace)
    if record is not None:
        scenarios.write_trace(record, result.trace)
    _summarise(result, trace_path, record)
    if spec.stop_when_done and result.final.get("status") != "DONE":
        sys.exit(1)


def _run_failed(
    error: Exception,
    system: IRSystem | None,
    cycle: int,
    package: Path,
    opts: Options,
    verbose: bool,
) -> NoReturn:
    """Report what stopped a run as one diagnostic (and the traceback with -v); exit 1."""
    diagnostic = runs.run_error(error, system, cycle, package.resolve())
    report(Diagnostics([diagnostic]), opts)
    if verbose and runs.details(error):
        click.echo(runs.details(error).rstrip("\n"), err=True)
    sys.exit(1)


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
