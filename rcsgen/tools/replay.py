"""Replay: a counter-example of `rcsgen prove` -> an `rcsgen run` scenario, run in the
generated code, and the verdict it earns.

The scenario holds every module of the controller's process but the controller itself with
`dont_run` (they still echo commands, so the handshake is real), scripts its subordinates'
answers (`reply:`), the world values the model chose (`set:`) and the commands from above.
The replay runs it in process on the generated package and compares, cycle by cycle, the
controller's state, status and fired rule with the model's. Only a replay that follows the
counter-example to its last cycle makes a finding "violated"; one that departs (a hook
computed something else, a local the model left free) makes it "undecided", and says where.
"""

from __future__ import annotations

import os
import tempfile
from fractions import Fraction
from pathlib import Path
from typing import Any

import yaml

from ..compiler import ir
from ..compiler.diagnostics import counted
from ..compiler.frontend import real_path
from ..compiler.prove import Finding, SystemProof
from ..compiler.types import Bool, Str, Type
from .harness import Harness, import_package, write_package
from .scenario.model import find_system_dir
from .scenario.run import reply


def _value(value: Any) -> Any:
    if isinstance(value, Fraction):
        return int(value) if value.denominator == 1 else float(value)
    if isinstance(value, bool | int | float):
        return value
    return str(value)


def _free(kind: Type) -> Any:
    """A parameter the model left free: false, 0, or for a text, which the model keeps opaque
    (no rule of its run decided on its value), the empty text. Sound for a verdict: only a
    replay that follows the run to its end with this value makes the finding violated; a rule
    that compares the text and takes the other branch makes the replay depart (undecided)."""
    if isinstance(kind, Bool):
        return False
    return "" if isinstance(kind, Str) else 0


def _row(system: ir.IRSystem, client: str, sub: str) -> str:
    """The buffer through which `client` commands `sub`: an operator module answers each
    client through a channel of its own (`eoow/cc`), any other module through its own."""
    return ir.channel_key(sub, client) if system.controller(sub).is_operator else sub


def _process_of(system: ir.IRSystem, module: str) -> ir.IRProcess:
    return next(p for p in system.processes if module in p.modules)


def events(system: ir.IRSystem, finding: Finding) -> tuple[list[dict[str, Any]], str]:
    """The scenario's events for a finding's counter-example, and '' or why it cannot be
    replayed (a lost process: the harness cannot lose one)."""
    module = finding.controller
    c = system.controller(module)
    process = _process_of(system, module)
    out: list[dict[str, Any]] = []
    held = {str(m): {"dont_run": True} for m in process.modules if m != module}
    why = ""
    for index, (edge, _) in enumerate(finding.trace, start=1):
        event: dict[str, Any] = {"cycle": index}
        if index == 1 and held:
            event["mode"] = held
        if edge.lost:
            why = f"process {edge.lost} is lost in cycle {index}, which a replay cannot do"
        if edge.new:
            event["command"] = str(f"{module}.{edge.new}")
            event["doc"] = "the command from above"
            params = next((cmd.params for cmd in c.commands if cmd.name == edge.new), ())
            given = {k[1]: _value(v) for k, v in edge.valuation if k[0] == "param"}
            if params:
                event["with"] = {str(p.name): given.get(p.name, _free(p.type)) for p in params}
            if c.supervisor is not None:
                event["overrides"] = True
        if edge.answers:  # an ERROR with the reason the model chose where a rule read it
            reasons = {str(k[1]): str(v) for k, v in edge.valuation if k[0] == "reason"}
            event["reply"] = {
                _row(system, module, str(sub)): f"{status}({reasons[sub]})"
                if status == "ERROR" and reasons.get(sub, "NONE") not in ("NONE", "LOST")
                else str(status)
                for sub, status in edge.answers
            }
        world = {str(k[1]): _value(v) for k, v in edge.valuation if k[0] == "world"}
        if world:
            event["set"] = world
        if len(event) > 1:
            out.append(event)
    return out, why


def scenario_text(
    system: ir.IRSystem, finding: Finding, name: str, system_dir: str | None = None
) -> str:
    """The scenario file of a counter-example; `system_dir`: its `system:`, the system's
    directory relative to where the file is written, when that is not above it."""
    found, _ = events(system, finding)
    data: dict[str, Any] = {
        "scenario": name,
        "title": f"rcsgen prove: {finding.code} in {finding.controller}",
        "doc": str(finding.message),
        **({"system": system_dir} if system_dir is not None else {}),
        "process": str(_process_of(system, finding.controller).name),
        "max_cycles": max(1, len(finding.trace)),
        "events": found,
    }
    head = (
        "# yaml-language-server: $schema=../../../rcsgen/compiler/schemas/scenario.schema.json\n"
        f"# Written by `rcsgen prove`: the counter-example of {finding.code}, cycle by cycle.\n"
    )
    return head + yaml.safe_dump(data, sort_keys=False, width=100)


class Replayer:
    """Replays counter-examples of one system in its generated code (built once)."""

    def __init__(self, system: ir.IRSystem, system_dir: Path) -> None:
        self.system = system
        self.scratch = tempfile.TemporaryDirectory(prefix="rcsgen-prove-")
        package_dir = write_package(system, Path(self.scratch.name))
        self.package = import_package(package_dir, system_dir.resolve())

    def close(self) -> None:
        self.scratch.cleanup()

    def replay(self, finding: Finding) -> tuple[bool, str]:
        """(True, what matched) when the generated code follows the counter-example to its
        end; else (False, where it departs)."""
        found, why = events(self.system, finding)
        if why:
            return False, why
        module = finding.controller
        process = _process_of(self.system, module).name
        harness = Harness(self.package, process, send_init=True)
        try:
            pending = list(found)
            for index, (edge, state) in enumerate(finding.trace, start=1):
                while pending and pending[0]["cycle"] == index:
                    event = pending.pop(0)
                    for m, mode in event.get("mode", {}).items():
                        harness.set_mode(m, **mode)
                    harness.world.update(event.get("set", {}))
                    for sub, status in event.get("reply", {}).items():
                        reply(harness, sub, status)
                    if "command" in event:
                        harness.command(
                            module, event["command"].split(".")[1], **event.get("with", {})
                        )
                harness.cycle()
                got = harness.status(module)
                want_state = state.state
                if got.state != want_state or got.status != state.status:
                    return False, (
                        f"the generated code departs in cycle {index}: the model has "
                        f"{module} {want_state} {state.status}, the code {got.state} {got.status}"
                    )
                table_rules = [r for r in edge.rules if not r.startswith("every_cycle")]
                if table_rules and got.rule != table_rules[-1]:
                    return False, (
                        f"the generated code departs in cycle {index}: rule {table_rules[-1]} "
                        f"in the model, {got.rule or 'no rule'} in the code"
                    )
                for sub, cmd in edge.sends:
                    sent = harness.sent(_row(self.system, module, sub)).command
                    if sent != cmd:
                        return False, (
                            f"the generated code departs in cycle {index}: {module} sent "
                            f"{sent} to {sub}, not {cmd}"
                        )
        except Exception as error:  # a hook refusing the scripted values: not a verdict
            return False, f"the replay stopped: {type(error).__name__}: {error}"
        finally:
            harness.close()
        return True, f"replayed in the generated code, {counted(len(finding.trace), 'cycle')}"


def replay_all(
    proof: SystemProof,
    system: ir.IRSystem,
    system_dir: Path,
    out_dir: Path | None,
    only: set[int] | None = None,
) -> None:
    """Replay every finding (or the `only` ones, by index) of a proof: set its verdict, and
    write its scenario into `out_dir` when given."""
    replayer = Replayer(system, system_dir)
    pointer = None  # the scenarios' `system:` where the walk up from out_dir would not find it
    if out_dir is not None and find_system_dir(out_dir / "x.yaml") != real_path(system_dir):
        pointer = Path(os.path.relpath(real_path(system_dir), real_path(out_dir))).as_posix()
    try:
        names: dict[str, int] = {}
        for index, finding in enumerate(proof.findings):
            if only is not None and index not in only:
                continue
            # a run z3 found impossible under its hold times (prove/timers.py) stays so
            ok, said = (False, finding.replay) if finding.replay else replayer.replay(finding)
            finding.verdict = "violated" if ok else "undecided"
            finding.replay = said
            if out_dir is not None:
                command = (finding.command or "x").lower()
                base = f"{finding.controller}_{finding.code.lower()}_{command}"
                names[base] = names.get(base, 0) + 1
                name = base if names[base] == 1 else f"{base}_{names[base]}"
                out_dir.mkdir(parents=True, exist_ok=True)
                path = out_dir / f"{name}.yaml"
                path.write_text(scenario_text(system, finding, name, pointer), encoding="utf-8")
                finding.scenario = str(path)
    finally:
        replayer.close()
