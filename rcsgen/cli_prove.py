"""`rcsgen prove`: properties of the composed hierarchy, proven (docs/spec.md, section 19).

A command of its own, registered on `rcsgen.cli.main`: it parses, compiles the specs
(`api.check`), reads an optional deployment file, calls the prover's report
(`tools.prove_report.run_prove`) and renders its lines and findings.
"""

from __future__ import annotations

from pathlib import Path

import click

from . import api
from .compiler.diagnostics import counted
from .compiler.ir import IRSystem
from .terminal import SPEC_PATHS, Exit, Session, error, note, reporting, specs_or_default
from .tools.report import Options


@click.command("prove")
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
@click.option(
    "--export",
    type=click.Choice(["smv"]),
    default=None,
    help="Also write each controller's explored model, with the spec's own properties, as "
    "a NuSMV/nuXmv model into --export-dir/<system>/.",
)
@click.option(
    "--export-dir",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path("smv"),
    show_default=True,
    help="Where --export writes (one directory per system).",
)
@reporting
def prove(
    paths: tuple[Path, ...],
    out: Path | None,
    no_replay: bool,
    deploy_file: Path | None,
    export: str | None,
    export_dir: Path,
    opts: Options,
) -> None:
    """Prove properties of the running hierarchy; print counter-examples as traces and
    scenarios (exit 1 on a violated property, with --strict also on an undecided one)."""
    from .tools.prove_report import run_prove

    session = Session(opts)
    front = api.check(specs_or_default(paths))
    session.add(front.diagnostics)
    if session.fails:
        session.finish("prove failed: the specs do not build")
    hosts = None if deploy_file is None else _hosts(front.systems, deploy_file)
    smv = export_dir if export == "smv" else None
    lines, diags, violated = run_prove(front, out, not no_replay, hosts, smv)
    session.add(diags)
    if opts.fmt == "text" and not opts.quiet:
        for line in lines:
            click.echo(line, err=True)
    if violated:
        session.finish()
        raise Exit(1, f"prove: {counted(violated, 'property violation')}")
    session.finish("prove: undecided findings fail with --strict")
    note(opts, f"proven: {', '.join(s.name for s in front.systems)}")


def _hosts(systems: list[IRSystem], deploy_file: Path) -> dict[str, str]:
    """process -> host of the one system's deployment file; its located error (E430-E443,
    as `--deploy` runs) and exit 2."""
    from .runtime.operate.deploy import DeployError
    from .runtime.operate.deploy import load as load_deployment

    if len(systems) != 1:
        raise error(f"--deploy is the deployment of one system; the specs hold {len(systems)}")
    system = systems[0]
    try:
        deployment = load_deployment(
            str(deploy_file), system.name, [p.name for p in system.processes]
        )
    except DeployError as problem:
        raise Exit(2, str(problem)) from None
    return {p: h.name for h in deployment.hosts.values() for p in h.processes}
