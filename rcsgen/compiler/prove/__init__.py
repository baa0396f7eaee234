"""Prove: properties of the whole running hierarchy, proven over the IR the generator uses.

`prove_front(front)` proves every system a front end built (`system.py`, one controller at a
time over its subordinates' contracts); `diagnostics(...)` turns the findings into located,
acknowledgeable diagnostics (W701-W708, docs/diagnostics.md); `trace_text` prints a
counter-example cycle by cycle. Replaying a counter-example in the generated code is a
tool's job (`rcsgen/tools/replay.py`): this package never runs generated code.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..checks import acknowledge
from ..codes import PROVE_CODES
from ..diagnostics import Diagnostic, Diagnostics, Subject
from ..front_end.model import ControllerSpec
from ..frontend import Frontend
from .model import Edge, State
from .properties import INFINITE, Finding
from .system import SystemProof, prove

__all__ = ["Finding", "INFINITE", "ProveResult", "SystemProof", "prove_front"]


@dataclass
class ProveResult:
    proofs: list[SystemProof] = field(default_factory=list)
    specs: dict[str, list[ControllerSpec]] = field(default_factory=dict)


def prove_front(front: Frontend, hosts: dict[str, str] | None = None) -> ProveResult:
    """Prove every system of a front end's output."""
    result = ProveResult()
    for system in front.systems:
        _, controllers = front.models[system.name]
        result.proofs.append(prove(system, hosts))
        result.specs[system.name] = controllers
    return result


def diagnostics(result: ProveResult) -> Diagnostics:
    """Every finding as a warning located at its rule, state or command, acknowledgements
    (`allow:`) applied; an acknowledgement of a prove code that matches nothing is W303."""
    diags = Diagnostics()
    for proof in result.proofs:
        since = len(diags.items)
        for f in proof.findings:
            text = f.message.replace(" is violated:", f" is {f.verdict}:", 1)
            if f.replay:
                text += f" ({f.replay})"
            hint = f.hint + (f"; replay: rcsgen run {f.scenario}" if f.scenario else "")
            diags.items.append(
                Diagnostic(
                    f.span,
                    f.code,
                    text,
                    hint,
                    Subject(f.controller, f.command, f.state, f.rule),
                )
            )
        acknowledge.apply(
            result.specs.get(proof.system, []),
            diags,
            since,
            complete=True,
            checked=frozenset(PROVE_CODES),
        )
    return diags


def cycle_text(index: int, edge: Edge, state: State, subs: tuple[str, ...], who: str) -> str:
    """One cycle of a counter-example, as a line."""
    parts = []
    if edge.lost:
        parts.append(f"process {edge.lost} lost")
    if edge.recovered:
        parts.append(f"process {edge.recovered} back")
    if edge.reset:
        parts.append("the operator resets the latches")
    if edge.new:
        parts.append(f"{who} gets {edge.new}")
    parts += [f"{sub} answers {status}" for sub, status in edge.answers]
    did = []
    if edge.safe_state:
        did.append("the runtime's safe state")
    for rule in edge.rules:
        did.append(f"rule {rule}")
    did += [f"sends {sub}.{cmd}" for sub, cmd in edge.sends if not edge.safe_state]
    did += [f"sets world.{n} unsafe" for n in edge.unsafe]
    if edge.report:
        did.append(f"reports {edge.report}")
    shown = ", ".join(
        f"{k[1] if k[0] != 'world' else 'world.' + k[1]}={v}"
        for k, v in edge.valuation
        if k[0] not in ("status", "command", "time")
    )
    line = f"  cycle {index}: " + ("; ".join(parts) + " | " if parts else "")
    line += f"{who} {', '.join(did) if did else 'waits'} -> {state.state} {state.status}"
    return line + (f"  [{shown}]" if shown else "")


def trace_text(proof: SystemProof, finding: Finding) -> str:
    """A counter-example, cycle by cycle."""
    graph = proof.graphs[finding.controller]
    return "\n".join(
        cycle_text(i, e, s, graph.skeleton.subs, finding.controller)
        for i, (e, s) in enumerate(finding.trace, start=1)
    )
