"""Command line: `rcsgen validate`, `build`, `run`, `graph`, `doc` and `trace`.

Exit codes follow Click: 0 clean, 1 the specs, scenarios or output have a problem (or a run
did not end as expected), 2 misuse, 3 a bug in rcsgen (one line; RCSGEN_TRACEBACK=1 shows
the traceback). Diagnostics go to stderr as
`file:line:col: error[CODE]: message`, sorted by position, after the user's selection
(`--select`, `--ignore`, `[tool.rcsgen]`: see tools/report.py and tools/config.py); with
`--format json|sarif|github` they go to stdout instead, as one document, and every other
message to stderr, for editors and CI.
"""

from __future__ import annotations

import contextlib
import functools
import os
import shutil
import signal
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

import click
from click.shell_completion import CompletionItem

from .compiler.back_end import write
from .compiler.codes import CODES, WARNING_CODES
from .compiler.diagnostics import Diagnostic, Diagnostics, Span, SpecError
from .compiler.front_end.loader import decode, read_bytes
from .compiler.frontend import compile_paths, display_path
from .compiler.ir import IRSystem
from .runtime import contract
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
from .tools.scenario_check import check_scenario, check_system_scenarios

if TYPE_CHECKING:
    from .tools.scenario import RunResult
    from .tools.traces import Trace


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
    line = lines[diag.span.line - 1]
    if len(line) > 120 and diag.span.col <= 100:  # a trace line: the start is enough
        return line[:100] + " ..."
    return line if len(line) <= 120 else None


def report(diags: Diagnostics, opts: Options, text_summary: bool = True) -> Outcome:
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
    if opts.fmt == "text" and text_summary and not opts.quiet and summary(result):
        click.echo(summary(result), err=True)
    return result


class Progress:
    """A progress line for long builds and runs, on stderr.

    On a terminal: one line, rewritten in place at most ten times a second and erased when
    done. Elsewhere (a CI log): nothing for the first seconds, then a line every few seconds,
    so a short run prints none. Never with -q or a machine format; never an empty line."""

    def __init__(
        self,
        opts: Options,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
        after: float = 2.0,
    ) -> None:
        self.stream = stream or sys.stderr
        self.enabled = not opts.quiet and opts.fmt == "text" and not opts.statistics
        self.tty = self.enabled and self.stream.isatty()
        self.clock, self.after = clock, after
        self.start = self.last = clock()
        self.shown = False

    def __call__(self, text: str) -> None:
        text = " ".join(text.split())
        if not self.enabled or not text:
            return
        now = self.clock()
        if self.tty:
            if now - self.last >= 0.1 or not self.shown:
                width = shutil.get_terminal_size((80, 24)).columns - 1
                self.stream.write("\r\x1b[K" + text[:width])
                self.stream.flush()
                self.shown, self.last = True, now
        elif now - self.start >= self.after and now - self.last >= self.after:
            self.stream.write(f"  {text}\n")
            self.stream.flush()
            self.last = now

    def done(self) -> None:
        """Erase the line (on a terminal)."""
        if self.shown:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self.shown = False


class _Session:
    """The diagnostics of a run: printed as they come as text (the user sees the specs'
    warnings before the run), reported once at the end in the machine formats."""

    def __init__(self, opts: Options) -> None:
        self.opts = opts
        self.diags = Diagnostics()

    def add(self, diags: Diagnostics | list[Diagnostic]) -> None:
        found = diags if isinstance(diags, Diagnostics) else Diagnostics(list(diags))
        self.diags.items += found.items
        self.diags.acknowledged += found.acknowledged
        if self.opts.fmt == "text" and not self.opts.statistics:
            report(found, self.opts, text_summary=False)

    @property
    def fails(self) -> bool:
        return outcome(self.diags, self.opts).fails

    def finish(self, failure: str = "") -> None:
        """Report the end (the summary, or every diagnostic in a machine format); exit 1
        when something failed."""
        if self.opts.fmt != "text" or self.opts.statistics:
            result = report(self.diags, self.opts)
        else:
            result = outcome(self.diags, self.opts)
            if not self.opts.quiet and summary(result):
                click.echo(summary(result), err=True)
        if result.fails:
            if failure:
                click.echo(failure, err=True)
            sys.exit(1)


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


class Number(click.ParamType):
    """A finite number within bounds (`nan`, `inf` and what lies outside are usage errors),
    as every numeric option of the console is (rcs/ctl.py `number`)."""

    name = "number"

    def __init__(self, low: float, high: float, above: bool = False) -> None:
        self.low, self.high, self.above = low, high, above

    def convert(
        self, value: Any, param: click.Parameter | None, ctx: click.Context | None
    ) -> float:
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = float("nan")
        lower = number > self.low if self.above else number >= self.low
        if not (lower and number <= self.high):  # NaN fails both
            bound = "more than" if self.above else "at least"
            self.fail(
                f"{value!r} is not a number {bound} {self.low:g} and at most {self.high:g}",
                param,
                ctx,
            )
        return number


def _output_dir(ctx: click.Context, param: click.Parameter, raw: str) -> Path:
    """An output directory a command may fill: not the empty string (which would mean the
    working directory) and not the working directory itself, whose files are the user's."""
    if not raw.strip():
        raise click.BadParameter("an empty path: name the output directory", ctx=ctx, param=param)
    value = Path(raw)
    if value.resolve() == Path.cwd().resolve():
        raise click.BadParameter(
            f"{raw!r} is the working directory: name a directory of its own (e.g. generated)",
            ctx=ctx,
            param=param,
        )
    return value


def _output_file(ctx: click.Context, param: click.Parameter, raw: str | None) -> Path | None:
    """An output file's path: not the empty string."""
    if raw is not None and not raw.strip():
        raise click.BadParameter("an empty path: name the file", ctx=ctx, param=param)
    return None if raw is None else Path(raw)


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


def _complete_codes(
    ctx: click.Context, param: click.Parameter, incomplete: str
) -> list[CompletionItem]:
    """Shell completion of --select/--ignore: the warning codes (after the last comma), each
    with its title."""
    done, _, last = incomplete.rpartition(",")
    prefix = f"{done}," if done else ""
    return [
        CompletionItem(prefix + code, help=CODES[code].title)
        for code in sorted(WARNING_CODES)
        if code.startswith(last.upper())
    ]


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
        _source_lines.cache_clear()  # files may have changed since a previous command
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
        try:
            command(*args, opts=opts, **kwargs)
        except (click.exceptions.Exit, click.ClickException, KeyboardInterrupt):
            raise
        except OSError as error:  # the machine refused (a full /tmp, a vanished directory)
            where = f": `{error.filename}`" if error.filename else ""
            reason = error.strerror or str(error)
            click.echo(f"error: {reason}{where}", err=True)
            sys.exit(1)
        except Exception as error:  # a bug in rcsgen: say so in one line, exit 3
            if os.environ.get("RCSGEN_TRACEBACK"):
                raise
            click.echo(
                f"internal error (a bug in rcsgen; please report it): "
                f"{type(error).__name__}: {error}\n"
                "set RCSGEN_TRACEBACK=1 to see where it happened",
                err=True,
            )
            sys.exit(3)

    options = [
        click.option(
            "--select",
            multiple=True,
            callback=_codes,
            shell_complete=_complete_codes,
            metavar="CODES",
            help="Show only these warnings (codes or prefixes: W503,W5). Errors always show.",
        ),
        click.option(
            "--ignore",
            multiple=True,
            callback=_codes,
            shell_complete=_complete_codes,
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
    """Check specs (schema and semantics) and their scenarios; report every problem found."""
    progress = Progress(opts)
    front = compile_paths(list(paths) or [Path("specs")], progress)
    progress.done()
    diags = front.diagnostics
    for system in front.systems:  # the scenarios of each system that builds
        found = check_system_scenarios(front.directories[system.name], system)
        diags = Diagnostics([*diags.items, *found.items], diags.acknowledged)
    if report(diags, opts).fails:
        sys.exit(1)
    _note(opts, f"ok: {', '.join(s.name for s in front.systems)}")


@main.command()
@SPEC_PATHS
@click.option(
    "-o",
    "--output",
    type=click.Path(),
    default="generated",
    show_default=True,
    callback=_output_dir,
    help="Output directory; each system gets <output>/<system>/.",
)
@click.option("--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale.")
@reporting
def build(paths: tuple[Path, ...], output: Path, check: bool, opts: Options) -> None:
    """Generate the Python packages of the systems found in SPECS (default: specs/)."""
    session = _Session(opts)
    progress = Progress(opts)
    front = compile_paths(list(paths) or [Path("specs")], progress)
    session.add(front.diagnostics)
    if not session.fails:
        plan, problems = write.plan_build(front.systems, output, progress)
        session.add(problems)
    progress.done()
    failed = "build failed: nothing was written"
    if session.fails:
        session.finish(failed)
    machine = opts.fmt != "text"  # stdout holds the diagnostics; everything else: stderr
    if check:
        session.finish()
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
        progress(f"writing {len(plan.write)} files, deleting {len(plan.delete)}")
        write.apply(plan)
    except SpecError as error:  # the disk refused: everything was undone
        session.add(error.diagnostics)
    progress.done()
    session.finish(failed)
    _note(
        opts,
        f"built {', '.join(s.name for s in front.systems)} into {output}: "
        f"{len(plan.write)} written, {len(plan.delete)} deleted, {plan.unchanged} unchanged",
    )


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
    callback=_output_file,
    help="Trace file to write [default: traces/<scenario>.jsonl].",
)
@click.option(
    "--record",
    type=click.Path(dir_okay=False),
    default=None,
    callback=_output_file,
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
    from .tools import scenario as scenarios
    from .tools.harness import AnyHarness

    session = _Session(opts)
    system_dir = scenarios.find_system_dir(scenario)
    system = None
    if system_dir is not None:  # else the scenario check reports E403
        front = compile_paths([system_dir])
        session.add(front.diagnostics)
        system = front.systems[0] if front.systems and not front.diagnostics.errors else None
    spec = None
    if system is not None or system_dir is None:
        spec, found = check_scenario(scenario, system)
        session.add(found)
    if session.fails or spec is None or system is None:
        session.finish("run failed: nothing was run")
        sys.exit(1)  # (a system that does not build always has an error)

    line = Progress(opts)

    def progress(h: AnyHarness) -> None:
        if line.enabled and h.cycles % 10 == 0:
            busy = [m for m in h.modules if h.status(m).status == "EXECUTING"]
            phases = "  ".join(f"{m} {h.sent(m).command}/{h.status(m).state}" for m in busy)
            line(f"cycle {h.cycles}/{spec.max_cycles}  {phases or 'every module idle'}")

    failed: tuple[Exception, int] | None = None
    # SIGINT and SIGTERM stop the run where it is (the processes and the segment too) and
    # keep the trace so far; `caught` says which came, even if a hook swallowed it.
    caught: list[int] = []

    def interrupt(signum: int, frame: object) -> None:
        caught.append(signum)
        raise KeyboardInterrupt

    trace_path = trace_path or Path("traces") / f"{spec.name}.jsonl"
    lines: list[str] = []
    started: AnyHarness | None = None
    # With a machine format, stdout holds only the diagnostics: what hooks print goes to stderr.
    hooks_out = sys.stderr if opts.fmt != "text" else sys.stdout
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
    with tempfile.TemporaryDirectory(prefix="rcsgen-run-") as scratch:
        package = _package(system, generated, Path(scratch), session)
        with contextlib.redirect_stdout(hooks_out):
            try:
                harness = started = scenarios.open_harness(spec, package, processes)
            except KeyboardInterrupt:  # what had started is stopped and removed already
                caught.append(caught[0] if caught else signal.SIGINT)
            except Exception as error:  # a hook-state factory, or a module that cannot be made
                if not caught:
                    failed = (error, 0)
            else:
                try:
                    result = scenarios.run(spec, harness, progress, lines)
                    final_world = harness.world.snapshot()
                except KeyboardInterrupt:
                    caught.append(caught[0] if caught else signal.SIGINT)
                except Exception as error:  # a hook, or a module's own code, in this cycle
                    if not caught:  # (else a hook turned the interruption into its error)
                        failed = (error, harness.cycles + 1)
                finally:  # a second signal must not cut the stop short (the segment stays)
                    signal.signal(signal.SIGINT, signal.SIG_IGN)
                    signal.signal(signal.SIGTERM, signal.SIG_IGN)
                    harness.close()
            signal.signal(signal.SIGINT, signal.default_int_handler)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
    line.done()
    if caught:
        _interrupted(caught[0], spec.name, lines, trace_path, started)
    if failed is not None:
        _run_failed(failed[0], system, failed[1], package, session, verbose)
    problems = Diagnostics()
    for path in [trace_path, *([record] if record is not None else [])]:
        try:
            scenarios.write_trace(path, result.trace)
        except OSError as exc:
            where = Span(display_path(path))
            problems.error(where, "E419", f"cannot write trace `{path}`: {exc.strerror or exc}")
    unmet = runs.unmet_expectations(spec, result, final_world)
    if not opts.quiet:
        _summarise(result, trace_path, record, machine=opts.fmt != "text", unmet=len(unmet))
    problems.extend(unmet)
    if golden is not None:
        differences = runs.golden_differences(golden, result.trace, spec.name)
        problems.extend(differences)
        if not differences and not opts.quiet:  # a match is said too: silence reads as skipped
            click.echo(
                f"golden    {golden}: identical, cycle for cycle ({len(result.trace)} lines)",
                err=opts.fmt != "text",
            )
    session.add(problems)
    session.finish()


def PACKAGE_COMMAND(command: Callable[..., None]) -> Callable[..., None]:  # noqa: N802
    """The arguments of the commands that hand over to a built system's `python -m`."""
    for decorate in reversed(
        [
            click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False)),
            click.option(
                "--generated",
                type=click.Path(path_type=Path, file_okay=False),
                default=Path("generated"),
                show_default=True,
                help="Where `rcsgen build` put the system packages.",
            ),
            click.argument("options", nargs=-1, type=click.UNPROCESSED),
        ]
    ):
        command = decorate(command)
    return command


# `--help` is not click's for these two: after SYSTEM_DIR it is the package's (its options are
# the ones that matter), before it this command's.
PASS_THROUGH = {"ignore_unknown_options": True, "help_option_names": []}


@main.command(context_settings=PASS_THROUGH)
@PACKAGE_COMMAND
@click.pass_context
def up(ctx: click.Context, system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Start a built system: every process as its own OS process, paced, until Ctrl-C.

    OPTIONS go to `python -m <system>` (e.g. `--cycles 100`, `--restart`, `--shm NAME`,
    one PROCESS, `--deploy FILE HOST` for one host of several; `--help` lists them). The
    package is checked first: one built from other specs than SYSTEM_DIR's is refused
    (E418), as `rcsgen run --generated` refuses it.
    """
    _help_first(ctx, system_dir)
    if not _wants_help(options):
        _refuse_stale(system_dir, generated)
    _exec_package(system_dir, generated, list(options), ctx)


@main.command(context_settings=PASS_THROUGH)
@PACKAGE_COMMAND
@click.pass_context
def ctl(ctx: click.Context, system_dir: Path, generated: Path, options: tuple[str, ...]) -> None:
    """Operate a running system: status, stop/run, step, simulate, slow, send, wait.

    OPTIONS go to `python -m <system> ctl` (e.g. `status --watch`, `send sb BOX_CUT
    depth=1.5`, `step co 5`; `--help` lists them): the console the generated package carries.
    """
    _help_first(ctx, system_dir)
    _exec_package(system_dir, generated, ["ctl", *options], ctx)


def _wants_help(options: tuple[str, ...] | list[str]) -> bool:
    return any(o in ("-h", "--help") for o in options)


def _help_first(ctx: click.Context, system_dir: Path) -> None:
    """`rcsgen up --help` (no SYSTEM_DIR yet): this command's help."""
    if str(system_dir) in ("-h", "--help"):
        click.echo(ctx.get_help())
        ctx.exit(0)


def _refuse_stale(system_dir: Path, generated: Path) -> None:
    """E418 (exit 1) unless `generated` holds exactly what SYSTEM_DIR's specs make; the specs'
    errors (exit 1) if they do not build."""
    if not (system_dir / "system.yaml").is_file():
        return  # said by _exec_package
    front = compile_paths([system_dir])
    if report(Diagnostics(front.diagnostics.errors), Options()).fails:
        fail("the specs do not build: nothing was started")
    plan, problems = write.plan_build(front.systems, generated)
    other = "--generated DIR where the package of these specs is"
    stale = [runs.stale_package(plan, generated, s.name, other) for s in front.systems]
    found = [*problems.errors, *(d for d in stale if d is not None)]
    if found:
        report(Diagnostics(found), Options())
        fail("nothing was started")


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
    "world",
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
    import importlib

    try:
        from .tools.monitor import Monitor
    except ImportError:
        fail("the monitor needs textual: pip install 'rcsgen[monitor]'")
    from .runtime.block import BlockError
    from .runtime.transport import TransportError
    from .tools.harness import import_package

    if not (system_dir / "system.yaml").is_file():
        fail(f"no system.yaml in {system_dir}", 2)
    name = _system_name(system_dir)
    package_dir = generated / name
    if not (package_dir / "layout.py").is_file():
        fail(f"no generated package at {package_dir}; run `rcsgen build` first")
    layout = importlib.import_module(f"{import_package(package_dir.resolve()).__name__}.layout")
    segment = shm or f"rcs_{layout.SYSTEM}_{layout.LAYOUT_HASH[:8]}"
    from .runtime.ctl import CtlError
    from .runtime.startup import segment_problem

    if not connect and segment_problem(segment):
        fail(segment_problem(segment), 2)
    fields = tuple(f for f in world.split(",") if f) or None
    try:
        app = Monitor(layout, segment, role=role, connect=connect, world=fields)
    except CtlError as error:
        fail(str(error), error.code)
    except (BlockError, TransportError, ValueError) as error:
        fail(str(error))
    app.run()


def _exec_package(
    system_dir: Path, generated: Path, argv: list[str], ctx: click.Context | None = None
) -> NoReturn:
    """Replace this process by `python -m <system> ARGV`, the package and hooks on its path
    (with `--help` in ARGV: this command's usage first, then the package's help)."""
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
    if ctx is not None and _wants_help(argv):
        click.echo(f"{ctx.get_usage()}\n(OPTIONS are `python -m {name}`'s, below)\n")
        sys.stdout.flush()
    os.execve(sys.executable, [sys.executable, "-m", name, *argv], env)


def _interrupted(
    signum: int, name: str, lines: list[str], trace_path: Path, harness: object
) -> NoReturn:
    """A run stopped by SIGINT or SIGTERM: the trace so far, ended by a line saying so, where
    it was, and exit 130 or 143 (128 + the signal, as a shell reports it)."""
    from .tools import scenario as scenarios

    signal_name = signal.Signals(signum).name
    if harness is None:
        click.echo(
            f"interrupted by {signal_name} while starting: no cycle ran, no trace written", err=True
        )
        sys.exit(128 + signum)
    ran = len(lines)
    try:
        scenarios.write_trace(
            trace_path, [*lines, scenarios.interrupted_line(ran + 1, signal_name)]
        )
        wrote = (
            f"{trace_path} holds cycles 1-{ran} and a last line saying so"
            if ran
            else f"{trace_path} holds only a line saying so"
        )
    except OSError as error:
        wrote = f"cannot write trace `{trace_path}`: {error.strerror or error}"
    click.echo(f"interrupted by {signal_name} in cycle {ran + 1} of {name}: {wrote}", err=True)
    for summary_line in getattr(harness, "summary", list)():
        click.echo(summary_line)
    sys.exit(128 + signum)


def _system_name(system_dir: Path) -> str:
    from .compiler.front_end.loader import load_file

    data = load_file(system_dir / "system.yaml", "system.yaml")
    return str(data["system"]) if isinstance(data, dict) else system_dir.name


def _package(system: IRSystem, generated: Path | None, scratch: Path, session: _Session) -> Path:
    """The package to run: the system rendered now into `scratch`, or the one in
    `generated`, refused (E418) unless it is exactly what the specs make."""
    if generated is None:
        from .tools.harness import write_package

        return write_package(system, scratch)
    plan, problems = write.plan_build([system], generated)
    stale = runs.stale_package(plan, generated, system.name)
    if problems.errors or stale is not None:
        session.add([*problems.items, *([stale] if stale else [])])
        session.finish("run failed: nothing was run")
    return generated / system.name


def _run_failed(
    error: Exception,
    system: IRSystem | None,
    cycle: int,
    package: Path,
    session: _Session,
    verbose: bool,
) -> NoReturn:
    """Report what stopped a run as one diagnostic (and the traceback with -v); exit 1."""
    session.add([runs.run_error(error, system, cycle, package.resolve())])
    if verbose and runs.details(error):
        click.echo(runs.details(error).rstrip("\n"), err=True)
    session.finish()
    sys.exit(1)


def _summarise(
    result: RunResult,
    trace_path: Path,
    record: Path | None,
    machine: bool = False,
    unmet: int = 0,
) -> None:
    """The run's summary: on stdout, or stderr when stdout holds the diagnostics."""
    spec = result.scenario

    def echo(text: str) -> None:
        click.echo(text, err=machine)

    echo(f"scenario  {spec.name}: {spec.title}")
    if spec.stop_when_done:
        final = result.final
        shown = contract.status_text(final["status"], final.get("reason"))
        echo(f"result    {spec.stop_when_done} {shown} (state {final['state']})")
        for name, value in (final.get("results") or {}).items():
            echo(f"          result.{name} {value}")  # as the figures below show values
    echo(f"cycles    {result.cycles}")
    if result.phase_cycles:
        echo(f"phases    cycles per {spec.phases_of} command:")
        for phase, count in result.phase_cycles.items():
            echo(f"            {phase:<26} {count:>6}")
    for name, value in result.figures.items():
        shown = f"{value:.3f}" if isinstance(value, float) else str(value)
        echo(f"{name.replace('_', ' '):<9} {shown}")
    slowest = sorted(result.max_cycle_ns.items(), key=lambda item: -item[1])
    echo("max cycle time per module (us):")
    for row in range(0, len(slowest), 6):
        cells = "  ".join(f"{m} {ns / 1000:.1f}" for m, ns in slowest[row : row + 6])
        echo(f"            {cells}")
    if spec.expect:
        wanted = "; ".join(f"{e.what} {e.wanted()}" for e in spec.expect)
        verdict = "met" if not unmet else f"{unmet} of {len(spec.expect)} not met"
        echo(f"expected  {wanted}: {verdict}")
    echo(f"trace     {trace_path} ({len(result.trace)} lines)")
    if record is not None:
        echo(f"recorded  {record}: review `git diff {record}` before committing")


# ---------------------------------------------------------------- pictures and the reference


def fail(message: str, code: int = 1) -> NoReturn:
    """One line on stderr, `error: ...`, and the exit code (1 bad input, 2 misuse)."""
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def _systems(paths: tuple[Path, ...]) -> list[IRSystem]:
    """The systems in SPECS (default specs/); on an error in the specs, its diagnostics and
    exit 1. Warnings are `validate`'s business: pictures and pages do not repeat them."""
    front = compile_paths(list(paths) or [Path("specs")])
    if report(Diagnostics(front.diagnostics.errors), Options()).fails:
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


@main.command()
@SPEC_PATHS
@click.option(
    "--counterexamples",
    "out",
    type=click.Path(path_type=Path, file_okay=False),
    default=None,
    help="Write each counter-example as a scenario here [default: <system>/counterexamples/].",
)
@click.option("--no-replay", is_flag=True, help="Do not replay counter-examples (all undecided).")
@click.option(
    "--deploy",
    "deploy_file",
    type=click.Path(path_type=Path, dir_okay=False),
    default=None,
    help="A deployment file of the one system given: the HALT and ERROR bounds count one "
    "more cycle per host a command or a status crosses.",
)
@reporting
def prove(
    paths: tuple[Path, ...],
    out: Path | None,
    no_replay: bool,
    deploy_file: Path | None,
    opts: Options,
) -> None:
    """Prove properties of the running hierarchy; print counter-examples as traces and
    scenarios (exit 1 on a violated property, with --strict also on an undecided one)."""
    from .runtime.deploy import DeployError
    from .runtime.deploy import load as load_deployment
    from .tools.prove_report import run_prove

    session = _Session(opts)
    front = compile_paths(list(paths) or [Path("specs")])
    session.add(front.diagnostics)
    if session.fails:
        session.finish("prove failed: the specs do not build")
    hosts = None
    if deploy_file is not None:
        if len(front.systems) != 1:
            fail(f"--deploy is the deployment of one system; the specs hold {len(front.systems)}")
        system = front.systems[0]
        try:
            deployment = load_deployment(
                str(deploy_file), system.name, [p.name for p in system.processes]
            )
        except DeployError as error:  # located, with its code (E430-E439), as `--deploy` runs
            click.echo(str(error), err=True)
            sys.exit(2)
        hosts = {p: h.name for h in deployment.hosts.values() for p in h.processes}
    lines, diags, violated = run_prove(front, out, not no_replay, hosts)
    session.add(diags)
    if opts.fmt == "text" and not opts.quiet:
        for line in lines:
            click.echo(line, err=True)
    if violated:
        session.finish()
        click.echo(f"prove: {violated} property violation(s)", err=True)
        sys.exit(1)
    session.finish("prove: undecided findings fail with --strict")
    _note(opts, f"proven: {', '.join(s.name for s in front.systems)}")


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
    type=click.Path(file_okay=False),
    default="docs/reference",
    show_default=True,
    callback=_output_dir,
    help="Output directory; each system gets <output>/<system>/.",
)
@click.option("--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale.")
def doc_command(paths: tuple[Path, ...], output: Path, check: bool) -> None:
    """Write the Markdown reference of the systems in SPECS: one page per controller."""
    from .tools import reference

    systems = _systems(paths)
    plan, problems = reference.plan(systems, output)
    if report(problems, Options()).fails:
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


@main.group("new")
def new_group() -> None:
    """Start a system or a controller from the QQ1 template: files that validate cleanly."""


def _scaffolded(action: Callable[[], Any]) -> None:
    from .tools.scaffold import ScaffoldError

    try:
        written = action()
    except ScaffoldError as error:
        for diagnostic in error.diagnostics:
            click.echo(diagnostic.render(), err=True)
        fail(str(error), error.code)
    for path in written.created:
        click.echo(f"created {path}")
    for path in written.edited:
        click.echo(f"edited  {path}")


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

    _scaffolded(lambda: scaffold(specs, name, root, period, title))
    click.echo(f"next: rcsgen validate {specs / name} && rcsgen build {specs}")


@new_group.command("controller")
@click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False))
@click.argument("name")
@click.option("--supervisor", default=None, help="The controller that commands it.")
@click.option("--process", default=None, help="The process it runs in [default: its supervisor's].")
def new_controller(
    system_dir: Path, name: str, supervisor: str | None, process: str | None
) -> None:
    """SYSTEM_DIR/NAME.yaml, added to its supervisor's subordinates and to a process."""
    from .tools.scaffold import new_controller as scaffold

    _scaffolded(lambda: scaffold(system_dir, name, supervisor, process))


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
@click.option(
    "--from", "first", type=click.IntRange(min=0), default=None, help="First cycle shown."
)
@click.option("--to", "last", type=click.IntRange(min=0), default=None, help="Last cycle shown.")
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
            report(error.diagnostics, Options())
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
