"""Seeds: handshake bugs planted in a copy of a system, to measure whether `rcsgen prove`
catches them (issue 23, item 6: trust the prover; tests/test_prove_seeds.py, bench/run.py).

Five kinds, each enumerated over every place of a system's specs where it applies:

- `drop-send`: one `send:` of a rule left out;
- `drop-error-branch`: a rule that handles a subordinate's ERROR (`sub.status == ERROR` in
  its guard) left out;
- `swap-order`: a supervisor and a subordinate of it swapped in their process's execution
  order (the subordinate then reads its commands a cycle late);
- `forget-echo`: a wait for a subordinate's DONE (`sub.status == DONE`) that takes "not ERROR"
  for done instead (`sub.status != ERROR`): it does not wait for the echo;
- `remove-halt`: a controller's own HALT table left out (the default one, which sends HALT
  below and sets no actuator, takes its place).

A seed is *caught* when `prove` reports, at the controller it changed (for a swap: at the
supervisor or in the system's HALT bounds), a finding the unchanged system does not have.
The YAML is rewritten whole (comments are lost; what the compiler reads is kept).
"""

from __future__ import annotations

import copy
import re
import shutil
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import yaml

from ..compiler import ir
from ..compiler.prove import properties as props
from ..compiler.prove.adapter import ERROR, EXECUTING, NOT_READY
from ..compiler.prove.properties import Finding
from ..compiler.prove.system import SystemProof, prove


@dataclass(frozen=True)
class Seed:
    kind: str
    system: str  # the system's directory name
    file: str  # the file it changes, in that directory
    controller: str  # where prove must find it (for a swap: the supervisor)
    command: str  # the command it changes ("" for a swap)
    where: str  # what it changes, in words
    text: str  # the file's new text

    def plant(self, source: Path, target: Path) -> Path:
        """A copy of the system directory `source` at `target`, with this seed in it."""
        shutil.copytree(source, target, ignore=shutil.ignore_patterns("scenarios", "counter*"))
        (target / self.file).write_text(self.text)
        return target


def _dump(data: dict[str, Any]) -> str:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=100)


def _load(path: Path) -> Any:
    return yaml.safe_load(path.read_text())


def _rules(spec: dict[str, Any]) -> Iterator[tuple[str, str, int, dict[str, Any]]]:
    """(command, state, index, rule) of every rule written in a controller's tables (a
    fragment's use is not a rule of its own)."""
    for command, body in (spec.get("commands") or {}).items():
        if not isinstance(body, dict):
            continue
        for state, rules in (body.get("states") or {}).items():
            for index, rule in enumerate(rules or []):
                if isinstance(rule, dict) and "use" not in rule:
                    yield str(command), str(state), index, rule


def _actions(rule: dict[str, Any]) -> list[Any]:
    do = rule.get("do")
    return list(do) if isinstance(do, list) else []


def _send_of(action: Any) -> str | None:
    if isinstance(action, dict) and "send" in action:
        return str(action["send"])
    return None


def seeds(directory: Path) -> list[Seed]:
    """Every seed of every kind the system in `directory` admits, in a stable order."""
    found: list[Seed] = []
    system = directory.name
    specs: dict[str, tuple[Path, dict[str, Any]]] = {}
    for path in _spec_files(directory):
        data = _load(path)
        if isinstance(data, dict) and "controller" in data:
            specs[str(data["controller"])] = (path, data)
    for name, (path, spec) in specs.items():
        subs = [
            str(s if isinstance(s, str) else next(iter(s))) for s in spec.get("subordinates") or []
        ]
        status = re.compile(
            r"\b(" + "|".join(map(re.escape, subs)) + r")\.status\s*==\s*(DONE|ERROR)\b"
        )
        for command, state, index, rule in _rules(spec):
            at = f"{name} {command}/{state}/{index + 1}"
            for i, action in enumerate(_actions(rule)):
                sent = _send_of(action)
                if sent is None:
                    continue
                changed = _copy(spec)
                target = changed["commands"][command]["states"][state][index]
                del target["do"][i]
                if not target["do"]:
                    del target["do"]
                found.append(
                    Seed(
                        "drop-send",
                        system,
                        _rel(directory, path),
                        name,
                        command,
                        f"{at}: send {sent} left out",
                        _dump(changed),
                    )
                )
            guard = str(rule.get("when", ""))
            if subs and any(m.group(2) == "ERROR" for m in status.finditer(guard)):
                changed = _copy(spec)
                del changed["commands"][command]["states"][state][index]
                found.append(
                    Seed(
                        "drop-error-branch",
                        system,
                        _rel(directory, path),
                        name,
                        command,
                        f"{at}: the ERROR branch `{guard}` left out",
                        _dump(changed),
                    )
                )
            for m in status.finditer(guard) if subs else ():
                if m.group(2) != "DONE":
                    continue
                changed = _copy(spec)
                new = guard[: m.start()] + f"{m.group(1)}.status != ERROR" + guard[m.end() :]
                changed["commands"][command]["states"][state][index]["when"] = new
                found.append(
                    Seed(
                        "forget-echo",
                        system,
                        _rel(directory, path),
                        name,
                        command,
                        f"{at}: `{m.group(0)}` read as `{m.group(1)}.status != ERROR`",
                        _dump(changed),
                    )
                )
        if "HALT" in (spec.get("commands") or {}):
            changed = _copy(spec)
            del changed["commands"]["HALT"]
            found.append(
                Seed(
                    "remove-halt",
                    system,
                    _rel(directory, path),
                    name,
                    "HALT",
                    f"{name}: its HALT table left out",
                    _dump(changed),
                )
            )
    found += _swaps(directory, specs)
    return found


def _spec_files(directory: Path) -> list[Path]:
    """The system's YAML files, and its templates' (a directory beside system.yaml that
    holds a template.yaml: a seed in a template's controller is in every instance)."""
    found = sorted(directory.glob("*.yaml"))
    for template in sorted(directory.glob("*/template.yaml")):
        found += sorted(p for p in template.parent.glob("*.yaml") if p != template)
    return found


def _instance_sub(subs: tuple[str, ...], name: str) -> str:
    """A subordinate as a seed in a template's file names it -> as its instance's
    controller has it (`<instance>_<member>`, docs/spec.md section 18)."""
    if name in subs:
        return name
    found = [s for s in subs if s.endswith(f"_{name}")]
    return found[0] if len(found) == 1 else name


def _rel(directory: Path, path: Path) -> str:
    return path.relative_to(directory).as_posix()


def instance_names(front: Any, system: str) -> dict[str, str]:
    """A template's controller (its name in the template) -> its first instance's name:
    where a seed planted in the template is proven and must be caught."""
    found: dict[str, str] = {}
    for c in front.models[system][1]:
        if c.instance is not None:
            found.setdefault(c.instance.member, c.name)
    return found


def _swaps(directory: Path, specs: dict[str, tuple[Path, dict[str, Any]]]) -> list[Seed]:
    path = directory / "system.yaml"
    system = _load(path)
    found = []
    for process, body in (system.get("processes") or {}).items():
        modules = [str(m) for m in body.get("modules") or []]
        for a, sup in enumerate(modules):
            subs = specs.get(sup, (None, {}))[1].get("subordinates") or []
            for sub in (str(s if isinstance(s, str) else next(iter(s))) for s in subs):
                if sub not in modules:
                    continue
                b = modules.index(sub)
                changed = _copy(system)
                order = list(modules)
                order[a], order[b] = order[b], order[a]
                changed["processes"][process]["modules"] = order
                found.append(
                    Seed(
                        "swap-order",
                        directory.name,
                        "system.yaml",
                        sup,
                        "",
                        f"{process}: {sup} and {sub} swapped",
                        _dump(changed),
                    )
                )
    return found


def _copy(data: Any) -> Any:
    """A spec's loaded data to change for one seed (plain dicts, lists and scalars: a deep
    copy; a YAML round trip cost 4x the whole enumeration and sorted every key)."""
    return copy.deepcopy(data)


def equivalent(seed: Seed, spec: dict[str, Any], proof: SystemProof, system: ir.IRSystem) -> str:
    """Why a seed is no handshake bug ('' when it is one), from the unchanged system's
    spec (`spec`: the seed's controller file as loaded) and proof:

    - `forget-echo` in a rule that only stops things, that subordinate among them: the
      stopping command replaces the running one (a preemption, which is safe, and its echo
      is still waited for); or where the subordinate has answered in every state of the
      model in which the rule is tried (`!= ERROR` then reads as `== DONE`);
    - `drop-error-branch` where another rule of the same state also handles that
      subordinate's ERROR (the model does not tell reasons apart, so it cannot tell which
      branch an ERROR takes), or where the subordinate cannot end any command it is sent
      with ERROR (its proven contract: nothing to handle);
    - `remove-halt` of a HALT table that sets no actuator: the default table that takes its
      place halts every subordinate and waits, which is at least as safe.
    """
    if seed.kind == "forget-echo":
        return _echo_replaced(seed, spec, proof) or _echo_answered(seed, proof)
    if seed.kind == "drop-error-branch":
        return _error_handled_elsewhere(seed, spec, proof, system)
    if seed.kind == "remove-halt":
        return _halt_sets_no_actuator(spec, system)
    if seed.kind == "drop-send":
        return _halt_stops_nothing(seed, spec, proof)
    return ""


def _halt_stops_nothing(seed: Seed, spec: dict[str, Any], proof: SystemProof) -> str:
    """A HALT sent to a subordinate on its own ERROR, where that subordinate ends no command
    it can be running there with an ERROR that leaves anything below it moving (its proven
    contract, `SystemProof.loose`): the HALT stops nothing that is not stopped already."""
    head, _, rest = seed.where.partition(": ")
    halt = re.fullmatch(r"send (\w+)\.HALT left out", rest)
    if halt is None:
        return ""
    sub = halt.group(1)
    command, state, number = head.split(" ", 1)[1].split("/")
    guard = str(spec["commands"][command]["states"][state][int(number) - 1].get("when", ""))
    graph = proof.graphs.get(seed.controller)
    if not re.search(rf"\b{sub}\.status\s*==\s*ERROR\b", guard) or graph is None:
        return ""
    sub = _instance_sub(graph.skeleton.subs, sub)
    if sub not in graph.skeleton.subs:
        return ""
    at = graph.skeleton.subs.index(sub)
    running = {
        sent
        for s in graph.edges
        if s.command == command and s.state == state and (sent := s.subs[at][0]) is not None
    }
    if not running or any((sub, cmd) in proof.loose for cmd in running):
        return ""
    return (
        f"{sub} ends none of {', '.join(sorted(running))} with an ERROR that "
        "leaves anything below it moving (its proven contract): the HALT stops nothing"
    )


def _echo_replaced(seed: Seed, spec: dict[str, Any], proof: SystemProof) -> str:
    """The rule only stops things, `sub` among them: a stopping command replaces the running
    one at once (a preemption), which is safe, and its own echo is still waited for."""
    command, state, index, sub = _rule_at(seed)
    rule = spec["commands"][command]["states"][state][index]
    sends = [s.split(".", 1) for a in _actions(rule) if (s := _send_of(a))]
    mine = proof.graphs.get(seed.controller)
    if mine is not None:
        sub = _instance_sub(mine.skeleton.subs, sub)
        sends = [[_instance_sub(mine.skeleton.subs, to), c] for to, c in sends]
    moving = props.motion({name: graph.skeleton for name, graph in proof.graphs.items()})
    if any(to == sub for to, _ in sends) and not any(moving[to, c] for to, c in sends):
        return f"the rule only stops things, {sub} among them: stopping it early is safe"
    return ""


def _echo_answered(seed: Seed, proof: SystemProof) -> str:
    """The subordinate has answered in every state of the model in which the rule is tried
    (nothing is sent to it there or since its answer): `== DONE` and `!= ERROR` then read
    the same, so the seed changes nothing."""
    command, state, _, sub = _rule_at(seed)
    graph = proof.graphs.get(seed.controller)
    if graph is None:
        return ""
    sub = _instance_sub(graph.skeleton.subs, sub)
    if sub not in graph.skeleton.subs:
        return ""
    at = graph.skeleton.subs.index(sub)
    views = {s.subs[at][1] for s in graph.edges if s.command == command and s.state == state}
    if views and not views & {EXECUTING, NOT_READY}:
        return f"{sub} has always answered when {state} is tried: `!= ERROR` reads as `== DONE`"
    return ""


def _error_handled_elsewhere(
    seed: Seed, spec: dict[str, Any], proof: SystemProof, system: ir.IRSystem
) -> str:
    command, state, index, _ = _rule_at(seed)
    rules = spec["commands"][command]["states"][state]
    guard = str(rules[index].get("when", ""))
    whys = []
    for sub in sorted(set(re.findall(r"\b(\w+)\.status\s*==\s*ERROR\b", guard))):
        why = _handled(seed, spec, proof, system, sub, rules, index, state)
        if not why:
            return ""
        whys.append(why)
    return "; ".join(whys)


def _halt_sets_no_actuator(spec: dict[str, Any], system: ir.IRSystem) -> str:
    actuators = {f.name for f in system.world if f.actuator}
    halt = spec["commands"]["HALT"]
    sets = {
        str(k).removeprefix("world.")
        for rules in (halt.get("states") or {}).values()
        for r in rules or []
        for a in _actions(r)
        if isinstance(a, dict) and isinstance(a.get("set"), dict)
        for k in a["set"]
    }
    if not sets & actuators:
        return "its HALT sets no actuator: the default HALT table is at least as safe"
    return ""


def _handled(
    seed: Seed,
    spec: dict[str, Any],
    proof: SystemProof,
    system: ir.IRSystem,
    sub: str,
    rules: list[dict[str, Any]],
    index: int,
    state: str,
) -> str:
    """Why `sub`'s ERROR needs no branch `index` of `state` ('' when it does)."""
    error = re.compile(rf"\b{re.escape(sub)}\.status\s*==\s*ERROR\b")
    others = [
        i + 1 for i, r in enumerate(rules) if i != index and error.search(str(r.get("when", "")))
    ]
    if others:
        return f"rule {others[0]} of {state} handles {sub}'s ERROR too"
    c = system.controller(seed.controller)
    mine = proof.graphs.get(seed.controller)
    sub = _instance_sub(mine.skeleton.subs, sub) if mine is not None else sub
    graph = proof.graphs.get(sub)
    if mine is None or graph is None or sub not in mine.skeleton.subs:
        return ""
    if any(s.echo_cycles for s in c.subordinates if s.name == sub):
        return ""  # no echo in time reads as ERROR
    at = mine.skeleton.subs.index(sub)
    command = seed.command
    running = {
        sent
        for s in mine.edges
        if s.command == command and s.state == state and (sent := s.subs[at][0]) is not None
    }
    ends = props.outcomes(graph)
    if not running or any(ERROR in ends.get(cmd, (ERROR,)) for cmd in running):
        return ""
    return f"{sub} cannot end {', '.join(sorted(running))} with ERROR (its proven contract)"


def _rule_at(seed: Seed) -> tuple[str, str, int, str]:
    """(command, state, 0-based index, subordinate) a rule seed names in `where`."""
    head, _, rest = seed.where.partition(": ")
    command, state, number = head.split(" ", 1)[1].split("/")
    sub = re.search(r"\b(\w+)\.status", rest)
    return command, state, int(number) - 1, sub.group(1) if sub else ""


def _key(f: Finding) -> tuple[str, str, str | None, str | None, int | None]:
    return (f.code, f.controller, f.command, f.state, f.rule)


def caught(seed: Seed, before: SystemProof, after: SystemProof) -> list[Finding]:
    """The findings that catch `seed`: at the controller it changed, not found in the
    unchanged system (each finding is told apart by code, command, state and rule)."""
    old = {_key(f) for f in before.findings}
    return [f for f in after.findings if f.controller == seed.controller and _key(f) not in old]


# The findings each kind of seed is expected to cause.
EXPECTED = {
    "drop-send": ("W702", "W703", "W704", "W707"),
    "drop-error-branch": ("W702", "W703", "W705"),
    "swap-order": ("W704",),
    "forget-echo": ("W708",),
    "remove-halt": ("W704",),
}


def _masked(seed: Seed, before: SystemProof) -> str:
    """The unchanged system's finding at the seed's place that the seed would cause too
    (so it cannot show as new): '' when there is none."""
    state = _rule_at(seed)[1] if seed.kind in ("drop-error-branch", "forget-echo") else None
    for f in before.findings:
        if f.controller != seed.controller or f.code not in EXPECTED[seed.kind]:
            continue
        if f.command == seed.command and state in (None, f.state):
            return (
                f"the unchanged system already has {f.code} at {f.controller} {f.command} {f.state}"
            )
    return ""


@dataclass
class Outcome:
    seed: Seed
    # "caught", "refused" (the build's own checks), "equivalent", "masked", "missed"
    verdict: str
    why: str  # the finding that caught it, the build's error, or why it is equivalent


def trial(directory: Path, work: Path, every: int = 1) -> list[Outcome]:
    """Plant each seed of the system in `directory` (every `every`-th of each kind, in
    order: a sample) in a copy under `work`, and prove it: whether prove catches it."""
    from ..compiler.frontend import compile_paths

    front = compile_paths([directory])
    assert not front.diagnostics.errors, "the unchanged system must build"
    system = front.systems[0]
    before = prove(system)
    loaded = {_rel(directory, p): _load(p) for p in _spec_files(directory)}
    alias = instance_names(front, system.name)
    out = []
    chosen: dict[str, int] = {}
    for n, written in enumerate(seeds(directory)):
        chosen[written.kind] = chosen.get(written.kind, -1) + 1
        if chosen[written.kind] % every:
            continue
        seed = replace(written, controller=alias.get(written.controller, written.controller))
        why = equivalent(seed, loaded[seed.file], before, system)
        if why:
            out.append(Outcome(seed, "equivalent", why))
            continue
        planted = seed.plant(directory, work / f"{n}" / directory.name)
        mutant = compile_paths([planted])
        if mutant.diagnostics.errors:
            out.append(Outcome(seed, "refused", mutant.diagnostics.errors[0].code))
        else:
            found = caught(seed, before, prove(mutant.systems[0], only=seed.controller))
            if found:
                out.append(Outcome(seed, "caught", f"{found[0].code} {found[0].message}"))
            elif masked := _masked(seed, before):
                out.append(Outcome(seed, "masked", masked))
            else:
                out.append(Outcome(seed, "missed", ""))
        shutil.rmtree(work / f"{n}")
    return out
