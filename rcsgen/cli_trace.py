"""`rcsgen trace changes | lines | coverage | show | mine | sea | station`: the commands that read
traces.

A group of its own, registered on `rcsgen.cli.main`; each command parses, loads its traces
(and the specs that recorded them, `terminal.trace_system`), calls one tool and renders.
"""

from __future__ import annotations

from pathlib import Path

import click

from .compiler.diagnostics import SpecError
from .terminal import (
    SPECS,
    TRACE,
    Exit,
    error,
    load_trace,
    page_option,
    report,
    trace_system,
    write_or_print,
)
from .tools.report import Options


@click.group("trace")
def trace_group() -> None:
    """Look at traces: an HTML timeline, the changes only, rule coverage, the mine."""


@trace_group.command("changes")
@TRACE
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
@click.option(
    "--from", "first", type=click.IntRange(min=0), default=None, help="First cycle shown."
)
@click.option("--to", "last", type=click.IntRange(min=0), default=None, help="Last cycle shown.")
@click.option(
    "--every-cycle", is_flag=True, help="Do not fold cycles that change alike into one entry."
)
@SPECS
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
    from .tools import traces
    from .tools.traces import changes

    found = load_trace(trace_path)
    try:
        chosen = traces.select(found, list(modules))
    except traces.TraceError as problem:
        raise error(str(problem), 2) from None
    lanes = traces.lanes(found, trace_system(specs, [found], required=False))
    colour = {"ERROR": "red", "DONE": "green", "EXECUTING": "blue"}
    for line in changes.timeline(found, lanes, chosen, world, first, last, not every_cycle):
        if line.startswith("cycle "):
            click.secho(line, bold=True)
            continue
        for status, fg in colour.items():
            line = line.replace(f"-> {status} ", f"-> {click.style(status, fg=fg)} ")
        click.echo(line)


@trace_group.command("lines")
@TRACE
@page_option("stdout", "Write them to this file")
def trace_lines(trace_path: Path, output: Path | None) -> None:
    """Print TRACE's cycles as whole lines, one JSON object each (a trace is stored as a
    whole line every 200 cycles and the changes in between): for jq, diff or a script."""
    from .tools import traces

    try:
        found = traces.full_lines(trace_path)
    except traces.TraceError as problem:
        raise error(str(problem)) from None
    write_or_print("".join(f"{line}\n" for line in found), output)


@trace_group.command("coverage")
@click.argument(
    "trace_paths", metavar="TRACES...", nargs=-1, required=True, type=click.Path(path_type=Path)
)
@SPECS
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["text", "json"]),
    default="text",
    show_default=True,
    help="A summary, the rules that never fired and the time per state, or one JSON object.",
)
def trace_coverage(trace_paths: tuple[Path, ...], specs: Path | None, fmt: str) -> None:
    """Which rules of which state tables fired in TRACES, which never did, and the time
    each module spent in each state."""
    from .tools.traces import coverage

    found = [load_trace(path) for path in trace_paths]
    system = trace_system(specs, found, required=True)
    assert system is not None
    result = coverage.measure(system, found)
    click.echo(coverage.to_json(result) if fmt == "json" else coverage.to_text(result), nl=False)


@trace_group.command("show")
@TRACE
@page_option("the trace's path with .html")
@SPECS
def trace_show(trace_path: Path, output: Path | None, specs: Path | None) -> None:
    """Write TRACE as one self-contained HTML page: swim-lanes, world plots, a cursor."""
    from .tools import traces
    from .tools.traces import view as trace_view

    found = load_trace(trace_path)
    system = trace_system(specs, [found], required=False)
    name, period = (system.name, system.cycle_period) if system else (None, None)
    page = trace_view.render(found, traces.lanes(found, system), name, period)
    write_or_print(page, output or traces.beside(trace_path, ".html"))


@trace_group.command("mine")
@TRACE
@page_option("the trace's path with .mine.html")
@SPECS
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
    from .tools import traces
    from .tools.traces import mine as mine_view

    found = load_trace(trace_path)
    system = trace_system(specs, [found], required=True)
    assert system is not None
    try:
        page, result = mine_view.page_for(
            found, system, specs or Path("specs"), trace_path, scenario
        )
    except SpecError as problem:
        report(problem.diagnostics, Options())
        raise Exit(1) from None
    except mine_view.MineError as problem:
        raise error(str(problem)) from None
    if result.mismatch:
        click.echo(
            f"warning: the replayed cut differs from the trace at {result.mismatch}", err=True
        )
    write_or_print(page, output or traces.beside(trace_path, ".mine.html"))


@trace_group.command("sea")
@TRACE
@page_option("the trace's path with .sea.html")
@SPECS
@click.option(
    "--scenario",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="The scenario that recorded TRACE, for its keel map and route settings [default: "
    "the system's scenarios/<trace name>.yaml, as `rcsgen run` names traces].",
)
def trace_sea(
    trace_path: Path, output: Path | None, specs: Path | None, scenario: Path | None
) -> None:
    """Write a submarine TRACE as an HTML replay of its transit among the ice keels."""
    from .tools import traces
    from .tools.traces import sea as sea_view

    found = load_trace(trace_path)
    system = trace_system(specs, [found], required=True)
    assert system is not None
    try:
        page = sea_view.page_for(found, system, specs or Path("specs"), trace_path, scenario)
    except SpecError as problem:
        report(problem.diagnostics, Options())
        raise Exit(1) from None
    except sea_view.SeaError as problem:
        raise error(str(problem)) from None
    write_or_print(page, output or traces.beside(trace_path, ".sea.html"))


@trace_group.command("station")
@TRACE
@page_option("the trace's path with .station.html")
@SPECS
def trace_station(trace_path: Path, output: Path | None, specs: Path | None) -> None:
    """Write an inspection-workstation TRACE as an HTML replay of the part on the CMM."""
    from .tools import traces
    from .tools.traces import station as station_view

    found = load_trace(trace_path)
    system = trace_system(specs, [found], required=True)
    assert system is not None
    try:
        page = station_view.render(found, system)
    except station_view.StationError as problem:
        raise error(str(problem)) from None
    write_or_print(page, output or traces.beside(trace_path, ".station.html"))
