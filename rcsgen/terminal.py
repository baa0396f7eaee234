"""What every command of `rcsgen` shares: how it ends, reads its options and prints.

Exit codes follow Click: 0 clean, 1 the specs, scenarios or output have a problem (or a run
did not end as expected), 2 misuse, 3 a bug in rcsgen (one line; RCSGEN_TRACEBACK=1 shows
the traceback), 128 + N a run stopped by signal N (143: any command stopped by SIGTERM,
which cleans up as Ctrl-C does). A command ends early by raising `Exit`,
the one way out with a code (`error` makes the usual `error: ...` one). Diagnostics go to
stderr as `file:line:col: error[CODE]: message`, sorted by position, after the user's
selection (`--select`, `--ignore`, `[tool.rcsgen]`: see tools/report.py and
tools/config.py); with `--format json|sarif|github` they go to stdout instead, as one
document, and every other message to stderr, for editors and CI.
"""

from __future__ import annotations

import functools
import os
import shutil
import signal
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TextIO

import click
from click.shell_completion import CompletionItem

from . import api
from .compiler.codes import CODES, WARNING_CODES
from .compiler.diagnostics import Diagnostic, Diagnostics, SpecError
from .compiler.front_end.loader import decode, read_bytes
from .runtime import contract
from .tools import config
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
    from .compiler.ir import IRSystem
    from .tools.scenario.run import RunResult
    from .tools.scenario.session import Ran
    from .tools.traces.read import Trace


class Exit(Exception):
    """The end of a command: its exit code, and the last line it says on stderr (none when
    everything was said already). The command group prints the line and exits."""

    def __init__(self, code: int, line: str = "") -> None:
        super().__init__(line)
        self.code, self.line = code, line


def error(message: str, code: int = 1) -> Exit:
    """`error: ...` on stderr and the exit code (1 bad input, 2 misuse): `raise error(...)`."""
    return Exit(code, f"error: {message}")


class Terminated(SystemExit):
    """SIGTERM, raised where the command was: its `finally` blocks and undo steps run (a
    build's scratch removed, a half-applied write taken back), exit 143."""


def _terminated(signum: int, _frame: object) -> NoReturn:
    os.write(2, f"stopped by {signal.Signals(signum).name}\n".encode())
    raise Terminated(128 + signum)


class Commands(click.Group):
    """A click group whose commands end by raising `Exit`; SIGTERM ends one as Ctrl-C
    does, cleaning up (a command that runs a system installs its own handler)."""

    def invoke(self, ctx: click.Context) -> Any:
        before = signal.signal(signal.SIGTERM, _terminated)
        try:
            return super().invoke(ctx)
        except Exit as end:
            if end.line:
                click.echo(end.line, err=True)
            ctx.exit(end.code)
        finally:
            signal.signal(signal.SIGTERM, before)


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


class Session:
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
        """Report the end (the summary, or every diagnostic in a machine format); `Exit` 1
        (saying `failure`) when something failed."""
        if self.opts.fmt != "text" or self.opts.statistics:
            result = report(self.diags, self.opts)
        else:
            result = outcome(self.diags, self.opts)
            if not self.opts.quiet and summary(result):
                click.echo(summary(result), err=True)
        if result.fails:
            raise Exit(1, failure)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("rcsgen")
    except PackageNotFoundError:
        return "unknown"


def note(opts: Options, message: str) -> None:
    """A line for the user, unless quiet: on stdout, or stderr when stdout holds the
    diagnostics (JSON, SARIF, GitHub)."""
    if not opts.quiet:
        click.echo(message, err=opts.fmt != "text")


if TYPE_CHECKING:  # generic in recent click's annotations; subscripted only for mypy
    _FloatParam = click.ParamType[float, Any]
else:
    _FloatParam = click.ParamType


class Number(_FloatParam):
    """A finite number within bounds (`nan`, `inf` and what lies outside are usage errors),
    as every numeric option of the console is (rcs/operate/ctl.py `number`)."""

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


def output_dir(ctx: click.Context, param: click.Parameter, raw: str) -> Path:
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


def output_file(ctx: click.Context, param: click.Parameter, raw: str | None) -> Path | None:
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


def complete_codes(
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
        except ConfigError as problem:
            raise click.UsageError(str(problem)) from None
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
        except (Exit, click.exceptions.Exit, click.ClickException, KeyboardInterrupt):
            raise
        except OSError as problem:  # the machine refused (a full /tmp, a vanished directory)
            where = f": `{problem.filename}`" if problem.filename else ""
            raise error(f"{problem.strerror or problem}{where}") from None
        except Exception as bug:  # a bug in rcsgen: say so in one line, exit 3
            if os.environ.get("RCSGEN_TRACEBACK"):
                raise
            raise Exit(
                3,
                f"internal error (a bug in rcsgen; please report it): "
                f"{type(bug).__name__}: {bug}\n"
                "set RCSGEN_TRACEBACK=1 to see where it happened",
            ) from None

    options = [
        click.option(
            "--select",
            multiple=True,
            callback=_codes,
            shell_complete=complete_codes,
            metavar="CODES",
            help="Show only these warnings (codes or prefixes: W503,W5). Errors always show.",
        ),
        click.option(
            "--ignore",
            multiple=True,
            callback=_codes,
            shell_complete=complete_codes,
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


# ---------------------------------------------------------------- options several commands take

GENERATED = click.option(
    "--generated",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("generated"),
    show_default=True,
    help="Where `rcsgen build` put the system packages.",
)
SYSTEM_DIR = click.argument("system_dir", type=click.Path(path_type=Path, file_okay=False))
CHECK = click.option(
    "--check", is_flag=True, help="Write nothing; print a diff and exit 1 if stale."
)
TRACE = click.argument("trace_path", metavar="TRACE", type=click.Path(path_type=Path))
SPECS = click.option(
    "--specs",
    type=click.Path(path_type=Path),
    default=None,
    help="The specs the trace was recorded from [default: specs/, when it is there].",
)


def output_dir_option(
    default: str, file_okay: bool = True
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """-o/--output: the directory each system gets a folder of (`<output>/<system>/`)."""
    return click.option(
        "-o",
        "--output",
        type=click.Path(file_okay=file_okay),
        default=default,
        show_default=True,
        callback=output_dir,
        help="Output directory; each system gets <output>/<system>/.",
    )


def page_option(
    default: str, what: str = "The page to write"
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """-o/--output: the one file a command writes."""
    return click.option(
        "-o",
        "--output",
        type=click.Path(path_type=Path, dir_okay=False),
        default=None,
        help=f"{what} [default: {default}].",
    )


# ---------------------------------------------------------------- what commands print


def specs_or_default(paths: tuple[Path, ...]) -> list[Path]:
    """The SPECS arguments, or specs/ when none is given."""
    return list(paths) or [Path("specs")]


def write_or_print(text: str, output: Path | None) -> None:
    """`text` into the file `output` (and a line saying so on stderr), or on stdout."""
    if output is None:
        click.echo(text, nl=False)
        return
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        output.write_text(text, encoding="utf-8")
    except OSError as problem:
        raise error(f"cannot write {output}: {problem.strerror or problem}") from None
    click.echo(f"wrote {output} ({len(text.encode('utf-8')):,} bytes)", err=True)


def cycle_progress(line: Progress, max_cycles: int) -> Callable[[Any], None]:
    """What a run shows on its progress line every tenth cycle: the cycle, and each busy
    module's command and state."""

    def progress(h: Any) -> None:
        if line.enabled and h.cycles % 10 == 0:
            busy = [m for m in h.modules if h.status(m).status == "EXECUTING"]
            phases = "  ".join(f"{m} {h.sent(m).command}/{h.status(m).state}" for m in busy)
            line(f"cycle {h.cycles}/{max_cycles}  {phases or 'every module idle'}")

    return progress


def run_summary(
    result: RunResult, trace_path: Path, record: Path | None, unmet: int = 0
) -> Iterator[str]:
    """The lines of a run's summary."""
    spec = result.scenario
    yield f"scenario  {spec.name}: {spec.title}"
    if spec.stop_when_done:
        final = result.final
        status = contract.status_text(
            final["status"], final.get("reason"), str(final.get("cause", ""))
        )
        yield f"result    {spec.stop_when_done} {status} (state {final['state']})"
        for name, value in (final.get("results") or {}).items():
            yield f"          result.{name} {value}"  # as the figures below show values
    yield f"cycles    {result.cycles}"
    if result.phase_cycles:
        yield f"phases    cycles per {spec.phases_of} command:"
        for phase, count in result.phase_cycles.items():
            yield f"            {phase:<26} {count:>6}"
    for name, value in result.figures.items():
        figure = f"{value:.3f}" if isinstance(value, float) else str(value)
        yield f"{name.replace('_', ' '):<9} {figure}"
    for line in result.device_checks:  # a run against soft PLCs: each fault's safe state
        yield f"device    {line}"
    slowest = sorted(result.max_cycle_ns.items(), key=lambda item: -item[1])
    yield "max cycle time per module (us):"
    for row in range(0, len(slowest), 6):
        cells = "  ".join(f"{m} {ns / 1000:.1f}" for m, ns in slowest[row : row + 6])
        yield f"            {cells}"
    if spec.expect:
        wanted = "; ".join(f"{e.what} {e.wanted()}" for e in spec.expect)
        verdict = "met" if not unmet else f"{unmet} of {len(spec.expect)} not met"
        yield f"expected  {wanted}: {verdict}"
    yield f"trace     {trace_path} ({len(result.trace)} lines)"
    if record is not None:
        yield f"recorded  {record}: review `git diff {record}` before committing"


def require_system(system_dir: Path, command: str) -> None:
    """Exit 2 unless `system_dir` holds a system.yaml: the commands that act on a running
    system take its spec directory first (`rcsgen ctl status` takes `status` for it)."""
    if not (system_dir / "system.yaml").is_file():
        raise error(
            f"no system.yaml in {system_dir}: give the system's spec directory first, "
            f"as in `rcsgen {command} specs/miner ...`",
            2,
        )


def exec_package(
    system_dir: Path, generated: Path, argv: list[str], ctx: click.Context | None = None
) -> None:
    """Replace this process by `python -m <system> ARGV`, the package and hooks on its path
    (with `--help` in ARGV: this command's usage first, then the package's help)."""
    require_system(system_dir, ctx.info_name if ctx is not None and ctx.info_name else "up")
    name = api.system_name(system_dir)
    package = generated / name
    if not (package / "__main__.py").is_file():
        raise error(f"no generated package at {package}; run `rcsgen build` first")
    path = [str(generated.resolve()), str(system_dir.resolve())]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*path, *sys.path])}
    if ctx is not None and wants_help(argv):
        click.echo(f"{ctx.get_usage()}\n(OPTIONS are `python -m {name}`'s, below)\n")
        sys.stdout.flush()
    os.execve(sys.executable, [sys.executable, "-m", name, *argv], env)


def wants_help(options: tuple[str, ...] | list[str]) -> bool:
    return any(o in ("-h", "--help") for o in options)


# ---------------------------------------------------------------- what several commands do


def interrupted(ran: Ran, signum: int, name: str, trace_path: Path) -> NoReturn:
    """A run stopped by SIGINT or SIGTERM: the trace so far, ended by a line saying so, where
    it was, and exit 130 or 143 (128 + the signal, as a shell reports it)."""
    import signal

    from .tools.scenario.session import write_interrupted

    signal_name = signal.Signals(signum).name
    if ran.harness is None:
        raise Exit(
            128 + signum,
            f"interrupted by {signal_name} while starting: no cycle ran, no trace written",
        )
    wrote = write_interrupted(ran, trace_path, signal_name)
    cycle = len(ran.lines) + 1
    click.echo(f"interrupted by {signal_name} in cycle {cycle} of {name}: {wrote}", err=True)
    for summary_line in getattr(ran.harness, "summary", list)():
        click.echo(summary_line)
    raise Exit(128 + signum)


def help_first(ctx: click.Context, system_dir: Path) -> None:
    """`rcsgen up --help` (no SYSTEM_DIR yet): this command's help."""
    if str(system_dir) in ("-h", "--help"):
        click.echo(ctx.get_help())
        raise Exit(0)


def systems_in(paths: tuple[Path, ...]) -> list[IRSystem]:
    """The systems in SPECS (default specs/); on an error in the specs, its diagnostics and
    exit 1. Warnings are `validate`'s business: pictures and pages do not repeat them."""
    front = api.check(specs_or_default(paths))
    if report(Diagnostics(front.diagnostics.errors), Options()).fails:
        raise Exit(1)
    return front.systems


def scaffolded(action: Callable[[], Any]) -> None:
    from .tools.scaffold import ScaffoldError

    try:
        written = action()
    except ScaffoldError as problem:
        for diagnostic in problem.diagnostics:
            click.echo(diagnostic.render(), err=True)
        raise error(str(problem), problem.code) from None
    for path in written.created:
        click.echo(f"created {path}")
    for path in written.edited:
        click.echo(f"edited  {path}")


def load_trace(path: Path) -> Trace:
    from .tools import traces

    try:
        found = traces.load(path)
    except traces.TraceError as problem:
        raise error(str(problem)) from None
    if found.interrupted == traces.CUT:
        click.echo(
            f"note: {path}'s last line was written only in part (its run was killed "
            f"while writing it): its {len(found):,} whole cycles are read",
            err=True,
        )
    return found


def _recorded_by_named(paths: list[Path], found: list[Trace]) -> IRSystem | None:
    """The system that recorded the traces, checking only the systems whose files name every
    module they hold (`recording.systems_naming`), in order; None if none of them builds
    and fits (the caller then checks every system, and says what is wrong)."""
    from .tools import traces
    from .tools.traces.read import module_of
    from .tools.traces.recording import systems_naming

    modules = {module_of(m) for one in found for m in one.modules}
    for directory in systems_naming(paths, modules):
        front = api.check([directory], analyse=False)  # (its structure is all a view needs)
        if not front.diagnostics.errors:
            fits, _ = traces.recorded_by(front.systems, found)
            if fits is not None:
                return fits
    return None


def trace_system(specs: Path | None, found: list[Trace], required: bool) -> IRSystem | None:
    """The system that recorded the traces, from --specs (or specs/ when it is there): its
    execution order, levels, titles and rules. None when no specs are at hand and they are
    not `required`; a one-line error when the traces do not fit them."""
    from .tools import traces

    if specs is None and not Path("specs").is_dir():
        if required:
            raise error(
                "no specs/ here: name the specs the trace was recorded from with --specs", 2
            )
        return None
    paths = (specs,) if specs is not None else ()
    fits = _recorded_by_named(specs_or_default(paths), found)
    if fits is not None:
        return fits
    systems = systems_in(paths)  # every system: what is wrong with the specs, or the trace
    fits, problem = traces.recorded_by(systems, found)
    if fits is not None or (specs is None and not required):
        return fits  # (None: a trace of other specs, shown without them)
    raise error(problem or f"no system in {specs or 'specs'} ran the trace")
