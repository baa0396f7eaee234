"""Prove report: the front end's systems -> proofs, replays, diagnostics and the text a
person reads (per controller the states explored, per leaf the HALT and ERROR bounds, the
world assumptions each command finishes under, each counter-example cycle by cycle)."""

from __future__ import annotations

from pathlib import Path

from ..compiler.diagnostics import Diagnostics
from ..compiler.frontend import Frontend
from ..compiler.ir import IRSystem
from ..compiler.prove import INFINITE, diagnostics, prove_front, trace_text
from ..compiler.prove.handshake import prove_handshake
from ..compiler.prove.properties import Finding
from ..compiler.prove.system import SystemProof
from .prove_smv import write_smv
from .replay import replay_all


def _cycles(value: int | None) -> str:
    if value is None:
        return "-"
    return "never" if value == INFINITE else str(value)


def bounds_text(proof: SystemProof) -> list[str]:
    """The HALT bounds of every leaf below each root that has subordinates, and how long
    an ERROR of each leaf takes to reach its root."""
    lines = []
    starts = sorted({b.start for b in proof.halt if b.path[-1] != b.start})
    for start in starts:
        lines.append(f"  HALT given to {start} reaches (cycle k; actuators safe by cycle):")
        for b in proof.halt:
            if b.start == start:
                lines.append(
                    f"    {b.leaf:<8} k={_cycles(b.cycles):<6} safe={_cycles(b.safe):<6} "
                    f"via {' > '.join(b.path)}"
                )
    if proof.error:
        lines.append("  ERROR of a leaf reaches its root (cycle d):")
        for b in proof.error:
            where = f" (stops at {b.blocked})" if b.blocked else ""
            lines.append(
                f"    {b.start:<8} d={_cycles(b.cycles):<6} via {' > '.join(b.path)}{where}"
            )
    return lines


def _counter_example(proof: SystemProof, system: IRSystem, f: Finding) -> list[str]:
    """A finding's counter-example, cycle by cycle; for one no run shows (the execution
    order's W704), the order of the processes its controller runs in."""
    if f.trace:
        return [f"  counter-example of {f.code} in {f.controller} ({f.verdict}):"] + [
            trace_text(proof, f)
        ]
    order = [
        f"{p.name}: {' > '.join(p.modules)}" for p in system.processes if f.controller in p.modules
    ]
    return [
        f"  {f.code} in {f.controller} ({f.verdict}): no run, the execution order shows it: "
        + ("; ".join(order) or "none")
    ]


def run_prove(
    front: Frontend,
    out: Path | None,
    replay: bool,
    hosts: dict[str, str] | None = None,
    smv: Path | None = None,
) -> tuple[list[str], Diagnostics, int]:
    """Prove, replay, and report: (text lines, diagnostics, violated findings shown);
    `hosts`: process -> host, from a deployment file (one more cycle per host crossed);
    `smv`: write each controller's model as SMV into `smv/<system>/` (`--export smv`)."""
    result = prove_front(front, hosts)
    if smv is not None:
        for proof, system in zip(result.proofs, front.systems, strict=True):
            write_smv(proof, system.properties, smv / system.name)
    proven, said = prove_handshake()
    first = diagnostics(result)
    acknowledged = {(d.span, d.code) for d in first.acknowledged}
    lines: list[str] = []
    for proof, system in zip(result.proofs, front.systems, strict=True):
        directory = front.directories[system.name]
        shown = {i for i, f in enumerate(proof.findings) if (f.span, f.code) not in acknowledged}
        if replay:
            target = out / system.name if out is not None else directory / "counterexamples"
            replay_all(proof, system, directory, target if shown else None, shown)
            for i, f in enumerate(proof.findings):
                if i not in shown:
                    f.verdict = "violated" if f.certain else "undecided"
        else:
            for f in proof.findings:
                f.verdict = "undecided"
                f.replay = "not replayed"
        lines.append(
            f"{system.name}: {len(proof.controllers)} controllers; a lost process: {proof.reaction}"
        )
        for name, r in proof.controllers.items():
            lines.append(
                f"  {name:<10} {r.states:>7} states {r.transitions:>8} transitions "
                f"{r.seconds * 1000:>7.0f} ms ({r.cpu * 1000:.0f} ms CPU)"
                + ("" if r.complete else "  (too large: undecided)")
            )
        lines.append("  execution order (the HALT bounds below follow it):")
        lines += [f"    {p.name}: {' > '.join(p.modules)}" for p in system.processes]
        lines += bounds_text(proof)
        for name, r in proof.controllers.items():
            for command, needs in r.assumptions.items():
                lines.append(f"  {name} {command} finishes if eventually " + "; or ".join(needs))
        for prop, holds in proof.properties:
            lines.append(
                f"  property {prop.name} ({prop.controller}): "
                + {True: "holds", False: "does not hold (W709)", None: "undecided (too large)"}[
                    holds
                ]
                + f": {prop.text}"
            )
        for i in sorted(shown):
            lines += _counter_example(proof, system, proof.findings[i])
        lines += [f"  note: {n}" for n in proof.notes]
        if proven is False:
            proof.notes.append(said)
        lines.append(f"  handshake: {said}")
    diags = diagnostics(result)
    violated = sum(
        1
        for proof in result.proofs
        for f in proof.findings
        if f.verdict == "violated" and (f.span, f.code) not in acknowledged
    )
    return lines, diags, violated
