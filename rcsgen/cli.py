"""Command line: `rcsgen validate`, `rcsgen build`, `rcsgen run`.

Exit codes follow Click: 0 clean, 1 the specs (or generated/) have a problem, 2 misuse.
Diagnostics go to stderr as `file:line:col: error[CODE]: message`, sorted by position; with
`--format json`, `validate` and `build` print them instead as one JSON array on stdout (every
other message then goes to stderr), for editors and CI.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import click

from .compiler import write
from .compiler.diagnostics import Diagnostic, Diagnostics, SpecError, to_json
from .compiler.frontend import compile_paths
from .compiler.loader import decode, read_bytes

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


def report(
    diags: Diagnostics, strict: bool = False, fmt: str = "text", acknowledged: bool = False
) -> bool:
    """Print every diagnostic (text on stderr, or a JSON array on stdout); True to fail.
    With `acknowledged`, the warnings the specs acknowledge are shown too (they never fail)."""
    active = list(diags)  # sorted, each distinct diagnostic once
    shown = active
    if acknowledged:
        shown = sorted({*active, *diags.acknowledged}, key=Diagnostic.sort_key)
    if fmt == "json":
        click.echo(to_json(shown))
        return _fails(active, strict)
    for diag in shown:
        click.echo(diag.render(_source_line(diag)), err=True)
    errors = sum(d.severity == "error" for d in active)
    warnings = len(active) - errors
    if errors or warnings:
        click.echo(f"{errors} error(s), {warnings} warning(s)", err=True)
    return bool(errors or (strict and warnings))


def _fails(diags: Iterable[Diagnostic], strict: bool) -> bool:
    return any(d.severity == "error" or strict for d in diags)


SPEC_PATHS = click.argument(
    "paths",
    nargs=-1,
    # Existence and readability are checked by the front end, as located diagnostics.
    type=click.Path(path_type=Path, exists=False, readable=False),
    metavar="[SPECS]...",
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


SHOW_ACKNOWLEDGED = click.option(
    "--show-acknowledged",
    is_flag=True,
    help="Also show the warnings the specs acknowledge (allow:, first_match), with reasons.",
)


@main.command()
@SPEC_PATHS
@click.option("--strict", is_flag=True, help="Fail on warnings too.")
@FORMAT
@SHOW_ACKNOWLEDGED
def validate(paths: tuple[Path, ...], strict: bool, fmt: str, show_acknowledged: bool) -> None:
    """Check specs (schema and semantics) and report every problem found."""
    front = compile_paths(list(paths) or [Path("specs")])
    if report(front.diagnostics, strict, fmt, show_acknowledged):
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
def run(scenario: Path, generated: Path, trace_path: Path | None, record: Path | None) -> None:
    """Run a scenario on the generated system and summarise it."""
    from .tools import scenario as scenarios
    from .tools.harness import Harness

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
    harness = scenarios.open_harness(spec, package)

    def progress(h: Harness) -> None:
        if h.cycles % 100 == 0:
            busy = [m for m in h.modules if h.status(m).status == "EXECUTING"]
            phases = "  ".join(f"{m} {h.sent(m).command}/{h.status(m).state}" for m in busy)
            click.echo(f"  cycle {h.cycles:>6}  {phases}", err=True)

    result = scenarios.run(spec, harness, progress)
    trace_path = trace_path or Path("traces") / f"{spec.name}.jsonl"
    scenarios.write_trace(trace_path, result.trace)
    if record is not None:
        scenarios.write_trace(record, result.trace)
    _summarise(result, trace_path, record)
    if spec.stop_when_done and result.final.get("status") != "DONE":
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
