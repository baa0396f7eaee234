"""Differential test: generated code against a reference interpreter of the semantics.

Hypothesis generates small random systems: a controller `top` with 1-3 subordinates (each
with a few commands, some with parameters), world bools, ints, an enumeration and a string,
locals (an enumeration and a string among them), a predicate, and
1-2 commands of 2-5 states whose rules have guards from a small grammar over subordinate
statuses and commands, world fields, locals, parameters and the predicate, and actions that
send, set and report, with `next` transitions. Each system is built (Harness.build) and run
for CYCLES cycles; the test plays the subordinates (seeded random replies: echo with DONE,
ERROR or EXECUTING, a stale number, or nothing), changes the world and issues new commands.
Half the systems give `top` a plan (`legs`, two step fields, capacity 4, two replans) whose
planner is a Python function of the system's hooks package, stepped through, replanned
(guarded by `legs.replans_left > 0`) and read in guards and values.
The same inputs drive tests/support/reference_interpreter.py, written from docs/semantics.md
without rcsgen. Every cycle the two must agree on state, status, status number, each
subordinate's command, number and arguments, the locals and the world.

A second run makes `s0` an operator module (docs/spec.md section 17): the test then plays
the person, writing answers (current, stale, DONE or ERROR with a reason) into the answer
record of `top`'s channel, the generated operator module runs after `top`, and the
reference feeds `top` the channel status that docs/semantics.md section 21 says the
operator module reports (the model of tests/test_operator.py).

DIFF_EXAMPLES (default 25) examples run in the tests; `make fuzz` runs more.
"""

from __future__ import annotations

import os
import random
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from support.reference_interpreter import Block, Controller
from test_operator import Channel

from rcsgen.tools.harness import Harness

EXAMPLES = int(os.environ.get("DIFF_EXAMPLES", "25"))
DERANDOMIZE = os.environ.get("FUZZ_RANDOM", "") == ""
CYCLES = 200
REPLIES = ("DONE", "DONE", "ERROR", "EXECUTING")
SIDES = ["LEFT", "RIGHT", "UP"]
TEXTS = ["", "ab", "x", "héé"]  # UTF-8: 5 bytes of 8
REPLIES_CODES = {"DONE": 2, "ERROR": 3}  # an answer record's status (contract.STATUS_NAMES)


class Draw:
    """Random choices drawn from Hypothesis, so a failing system shrinks."""

    def __init__(self, data: st.DataObject) -> None:
        self.data = data

    def int(self, low: int, high: int) -> int:
        return self.data.draw(st.integers(low, high))

    def choice(self, items: list[Any]) -> Any:
        return self.data.draw(st.sampled_from(items))

    def chance(self, percent: int) -> bool:
        return self.int(1, 100) <= percent


PASSED = ("REFUSED", "FAULT")  # the subordinates' reasons, which `top` also declares


def sub_spec(name: str, d: Draw) -> dict:
    commands = {}
    results, reasons = d.chance(50), d.chance(50)  # read by `top` as <sub>.result.v, .reason
    for command in ("A", "B", "C")[: d.int(1, 3)]:
        spec: dict = {"states": {"S0": [{"do": [{"report": "DONE"}]}]}}
        if d.chance(40):
            spec["params"] = {"k": {"type": "int"}}
        if d.chance(40):  # an enumeration and a string, passed on from top's
            spec["params"] = {**spec.get("params", {}), "e": {"type": "enum", "values": SIDES}}
            spec["params"]["s"] = {"type": "str", "size": 8}
        if results:
            spec["results"] = {"v": {"type": "int"}}
        if reasons:
            spec["reasons"] = list(PASSED)
        commands[command] = spec
    return {"controller": name, "title": f"Subordinate {name}", "commands": commands}


def sub_reasons(spec: dict) -> list[str]:
    first = next(iter(spec["commands"].values()))
    return ["NONE", "LOST", *first.get("reasons", [])] if "reasons" in first else []


def sub_results(spec: dict) -> bool:
    return "results" in next(iter(spec["commands"].values()))


PLANNER = '''
def plan_legs(k, steps):
    """abs(k) % 5 steps (n, even), n counting from k (from k + 10 on a replan)."""
    first = k if steps == 0 else k + 10
    return [(first + i, (first + i) % 2 == 0) for i in range(abs(k) % 5)]
'''


def plan_legs(k: int, steps: int) -> list[tuple[int, bool]]:
    """The planner of PLANNER, for the reference interpreter."""
    namespace: dict[str, Any] = {}
    exec(PLANNER, namespace)  # the very text the generated system's hooks module holds
    return namespace["plan_legs"](k, steps)


class Grammar:
    """Guards and values over what `top` can see."""

    def __init__(self, d: Draw, subs: dict[str, dict], sent: list[str], plan: bool) -> None:
        self.d, self.subs, self.sent, self.plan = d, subs, sent, plan

    def atom(self) -> str:
        d = self.d
        kinds = ["world_bool", "world_int", "local_int", "local_bool", "param", "predicate"]
        kinds += ["enum", "text"]
        kinds += ["plan", "plan"] if self.plan else []
        kinds += ["status", "status", "command"] if self.sent else []
        kinds += ["reason"] if any(sub_reasons(self.subs[s]) for s in self.sent) else []
        kinds += ["result"] if any(sub_results(self.subs[s]) for s in self.sent) else []
        kind = d.choice(kinds)
        if kind == "reason":
            sub = d.choice([s for s in self.sent if sub_reasons(self.subs[s])])
            compare = d.choice(["==", "!="])
            return f"{sub}.reason {compare} {d.choice(sub_reasons(self.subs[sub]))}"
        if kind == "result":
            sub = d.choice([s for s in self.sent if sub_results(self.subs[s])])
            return f"{sub}.result.v {d.choice(['<', '>=', '=='])} {d.int(-1, 3)}"
        if kind == "status":
            sub = d.choice(self.sent)
            return (
                f"{sub}.status {d.choice(['==', '!='])} {d.choice(['DONE', 'ERROR', 'EXECUTING'])}"
            )
        if kind == "command":
            sub = d.choice(self.sent)
            names = ["INIT", "HALT", *self.subs[sub]["commands"]]
            return f"{sub}.command {d.choice(['==', '!='])} {d.choice(names)}"
        if kind == "enum":
            value = d.choice(["side", "mode", "world.e0"])
            names = ["IDLE", "BUSY"] if value in ("mode", "world.e0") else SIDES
            return f"{value} {d.choice(['==', '!='])} {d.choice(names)}"
        if kind == "text":
            left = d.choice(["tag", "label", "world.t0"])
            right = d.choice(["'ab'", "'x'", "''", "tag", "label"])
            return f"{left} {d.choice(['==', '!='])} {right}"
        if kind == "plan":
            return d.choice(
                [
                    "legs.done",
                    "not legs.done",
                    "legs.even",
                    f"legs.step < {d.int(0, 3)}",
                    f"legs.n > {d.int(-1, 3)}",
                    "legs.replans_left == 0",
                    f"legs.steps >= {d.int(0, 4)}",
                ]
            )
        if kind == "world_bool":
            return d.choice(["world.b0", "not world.b0", "world.b1"])
        if kind == "local_bool":
            return d.choice(["flag", "not flag"])
        if kind == "predicate":
            return d.choice(["busy()", "not busy()"])
        compare = d.choice(["<", "<=", ">", ">=", "==", "!="])
        return f"{self.number()} {compare} {d.int(-2, 6)}"

    def number(self) -> str:
        d = self.d
        base = d.choice(["world.i0", "world.i1", "n", "g", "m", "twice(n)"])  # can hold
        shape = d.int(0, 6)
        if shape == 6:
            return f"({base} if flag else {d.int(-1, 3)})"
        if shape == 1:
            return f"{base} + {d.choice(['n', 'world.i0', 'LIMIT'])}"
        if shape == 2:
            return f"{base} % {d.int(2, 4)}"
        if shape == 3:
            return f"abs({base} - {d.int(0, 5)})"
        if shape == 4:
            return f"{d.choice(['min', 'max'])}({base}, {d.choice(['n', 'g', '2'])})"
        if shape == 5:
            return f"-{base} // {d.int(1, 3)}"
        return base

    def guard(self) -> str:
        d = self.d
        first = self.atom()
        if d.chance(40):
            return f"{first} {d.choice(['and', 'or'])} {self.atom()}"
        if d.chance(10):
            return f"not ({first} and {self.atom()})"
        return first


def top_spec(d: Draw, subs: dict[str, dict]) -> dict:
    names = list(subs)
    plan = d.chance(50)
    commands, count = {}, d.int(1, 2)
    for command in ("GO", "RUN")[:count]:
        states = [f"S{i}" for i in range(d.int(2, 5))]
        sent = sorted({d.choice(names) for _ in range(d.int(1, len(names)))})
        grammar = Grammar(d, subs, sent, plan)
        table: dict[str, list] = {}
        for index, state in enumerate(states):
            rules = []
            following = states[index + 1] if index + 1 < len(states) else None
            for _ in range(d.int(1, 3)):
                rules.append(random_rule(d, grammar, states, sent, subs))
            # every state is reachable and the last one can report
            # (first, with a guard that can hold, so the analysis can see it fire)
            anchor = {"when": grammar.atom()} if d.chance(70) else {}
            if following is not None:
                anchor["next"] = following
                if index == 0:  # the table commands what its guards test
                    anchor["do"] = [send(d, sub, subs) for sub in sent]
            else:
                anchor["do"] = [{"report": d.choice(["DONE", "DONE", "ERROR"])}]
            rules.insert(0, anchor)
            table[state] = rules
        commands[command] = {
            "params": {
                "g": {"type": "int"},
                "side": {"type": "enum", "values": SIDES},
                "tag": {"type": "str", "size": 8},
            },
            "results": {"r": {"type": "int"}},
            "reasons": ["BAD", "WORSE", *PASSED],  # a subordinate's are passed up by name
            "let": {"m": "n + g if flag else world.i0", "m2": "twice(m) - 1"},
            "states": table,
            "first_match": states,  # overlapping guards are meant: the first match wins
        }
    extra: dict = {}
    if plan:
        extra = {
            "hooks_module": "diff_hooks.top",
            "plans": {
                "legs": {
                    "planner": "plan_legs",
                    "args": ["n", "legs.steps"],
                    "steps": {"n": "int", "even": "bool"},
                    "capacity": 4,
                    "replans": 2,
                }
            },
        }
    return {
        "controller": "top",
        "title": "Top",
        "subordinates": names,
        **extra,
        "world": {"reads": ["b0", "i0"], "writes": ["b1", "i1", "e0", "t0"]},
        "locals": {
            "n": {"type": "int", "initial": d.int(-1, 2)},
            "flag": {"type": "bool", "initial": d.chance(50)},
            "mode": {
                "type": "enum",
                "values": ["IDLE", "BUSY"],
                "initial": d.choice(["IDLE", "BUSY"]),
            },
            "label": {"type": "str", "size": 8, "initial": d.choice(TEXTS)},
        },
        "constants": {"LIMIT": d.int(0, 4)},
        "predicates": {"busy": "world.b0 and n > LIMIT"},
        "functions": {
            "twice": {"params": {"v": "int"}, "returns": "int", "body": "v * 2 if v > 0 else -v"}
        },
        "commands": commands,
    }


def send(d: Draw, sub: str, subs: dict[str, dict]) -> dict:
    command = d.choice(["INIT", "HALT", *subs[sub]["commands"]])
    action: dict = {"send": f"{sub}.{command}"}
    params = subs[sub]["commands"].get(command, {}).get("params", {})
    values = {
        "k": lambda: d.choice(["n", "g + 1", "world.i0", "3"]),
        "e": lambda: d.choice(["side", "LEFT", "UP"]),
        "s": lambda: d.choice(["tag", "label", "'x'", "world.t0"]),
    }
    if params:
        action["with"] = {name: values[name]() for name in params}
    return action


def random_rule(d: Draw, grammar: Grammar, states: list[str], sent: list[str], subs) -> dict:
    rule: dict = {}
    if d.chance(85):
        rule["when"] = grammar.guard()
    actions = []
    for _ in range(d.int(0, 3)):
        kinds = ["send", "set_n", "set_flag", "set_world", "set_result", "set_typed", "report"]
        kinds += ["plan", "replan", "advance", "advance"] if grammar.plan else []
        kind = d.choice(kinds)
        if kind in ("plan", "advance"):
            actions.append({kind: "legs"})
        elif kind == "replan":  # only while replans are left: W309 otherwise
            actions.append({"replan": "legs"})
            rule["when"] = (
                f"({rule['when']}) and legs.replans_left > 0"
                if "when" in rule
                else ("legs.replans_left > 0")
            )
        elif kind == "send":
            actions.append(send(d, d.choice(sent), subs))
        elif kind == "set_n":
            values = ["n + 1", "n - 1", "0", "g", "world.i0 % 5", "m2 % 7"]
            values += ["legs.n", "legs.step + legs.steps"] if grammar.plan else []
            actions.append({"set": {"n": d.choice(values)}})
        elif kind == "set_flag":
            actions.append({"set": {"flag": d.choice(["not flag", "world.b0", "n > 2"])}})
        elif kind == "set_world":
            target = d.choice(["world.b1", "world.i1"])
            value = "not world.b1" if target == "world.b1" else d.choice(["n", "world.i1 + 1"])
            actions.append({"set": {target: value}})
        elif kind == "set_typed":  # an enumeration or a string, local or world field
            target = d.choice(["mode", "label", "world.e0", "world.t0"])
            value = {
                "mode": ["BUSY", "IDLE", "world.e0", "BUSY if flag else IDLE"],
                "label": ["tag", "'ab'", "world.t0", "label"],
                "world.e0": ["mode", "IDLE"],
                "world.t0": ["label", "tag", "'x'"],
            }[target]
            actions.append({"set": {target: d.choice(value)}})
        elif kind == "set_result":
            actions.append({"set": {"result.r": d.choice(["n", "g * 2", "world.i0"])}})
        elif not any("report" in a for a in actions):
            report: dict = {"report": d.choice(["DONE", "ERROR"])}
            if report["report"] == "ERROR" and d.chance(60):
                passing = [f"{s}.reason" for s in sent if sub_reasons(subs[s])]
                report["reason"] = d.choice(["BAD", "WORSE", *passing])
            actions.append(report)
    if d.chance(25):  # time: wait in the state, or for the guard to have held
        if "when" in rule and d.chance(50):
            rule["for"] = d.choice(["1 cycle", "2 cycles", "0.03 s"])
        else:
            rule["after"] = d.choice(["1 cycle", "3 cycles", "0.02 s", "50 ms"])
    if actions:
        rule["do"] = actions
    if not any("report" in a for a in actions) and (d.chance(50) or not rule):
        rule["next"] = d.choice(states)
    return rule


def system_files(d: Draw) -> dict[str, dict]:
    subs = {f"s{i}": sub_spec(f"s{i}", d) for i in range(d.int(1, 3))}
    system = {
        "system": "diff",
        "title": "Differential",
        "cycle_period": 0.01,
        "world": {
            "b0": {"type": "bool", "initial": d.chance(50)},
            "b1": {"type": "bool", "initial": False},
            "i0": {"type": "int", "initial": d.int(-3, 3)},
            "i1": {"type": "int", "initial": 0},
            "e0": {"type": "enum", "values": ["IDLE", "BUSY"], "initial": "IDLE"},
            "t0": {"type": "str", "size": 8, "initial": "x"},
        },
        "processes": {"p": {"modules": ["top", *subs]}},
    }
    return {"system": system, "top": top_spec(d, subs), **subs}


class _NoAliases(yaml.SafeDumper):
    """A list used twice (SIDES) is written out twice: rcsgen refuses YAML aliases."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def write_system(directory: Path, files: dict[str, dict]) -> None:
    directory.mkdir(parents=True)
    for name, data in files.items():
        text = yaml.dump(data, Dumper=_NoAliases, sort_keys=False, width=1000)
        (directory / f"{name}.yaml").write_text(text, encoding="utf-8")
    if "plans" in files["top"]:
        (directory / "diff_hooks").mkdir()
        (directory / "diff_hooks" / "__init__.py").write_text("", encoding="utf-8")
        (directory / "diff_hooks" / "top.py").write_text(PLANNER, encoding="utf-8")


def as_operator(spec: dict) -> dict:
    """A subordinate's spec made an operator module: each command a task with instruction
    text (showing its parameter), the same parameters and reasons, no table."""
    tasks = {}
    for name, command in spec["commands"].items():
        task = {k: v for k, v in command.items() if k in ("params", "reasons")}
        shown = ", ".join(f"{p}={{{p}}}" for p in command.get("params", {}))
        task["text"] = f"Do {name}" + (f" with {shown}." if shown else ".")
        tasks[name] = task
    return {"operator": spec["controller"], "title": "A person", "commands": tasks}


def generated_trace(h: Harness, subs: list[str], rows: dict[str, str]) -> dict[str, Any]:
    status = h.status("top")
    top = h.controller("top")
    sent = {s: h.sent(rows.get(s, s)) for s in subs}  # an operator's: top's channel
    return {
        "state": status.state,
        "status": status.status,
        "status_num": status.number,
        "sent": {s: (c.command, c.number, dict(sorted(c.args.items()))) for s, c in sent.items()},
        "locals": {
            "n": top.var_n,
            "flag": top.var_flag,
            "mode": ("IDLE", "BUSY")[top.var_mode],
            "label": top.var_label,
        },
        "reason": ("NONE", "LOST", "BAD", "WORSE", *PASSED)[
            h.layout.STATUS_OUT["top"].read(h.buf)["error_num"]
        ],
        "results": {"r": h.layout.STATUS_OUT["top"].read(h.buf)["result_r"]},
        "plans": {
            name: (p["step"], p["steps"], p["replans_left"]) for name, p in status.plans.items()
        },
    }


def drive(
    h: Harness,
    files: dict[str, dict],
    rnd: random.Random,
    operator: str | None = None,
    seen: set[str] | None = None,
) -> tuple[int, int]:
    """Run both for CYCLES cycles on the same inputs; the number of commands given, and of
    cycles after which `top` had a plan with steps. With `operator`, that subordinate is an
    operator module the test answers as its person."""
    subs = [n for n in files if n not in ("system", "top")]
    reference = Controller(
        files["top"],
        {s: files[s] for s in subs},
        files["system"]["world"],
        planners={"plan_legs": plan_legs},
    )
    rows = {operator: f"{operator}/top"} if operator else {}
    person = Channel()
    answer: tuple[int, str, int] = (0, "NOT_READY", 0)
    block = Block(world={n: f["initial"] for n, f in files["system"]["world"].items()})
    commands = ["INIT", "HALT", *files["top"]["commands"]]
    given = planned = 0
    for cycle in range(CYCLES):
        if cycle == 0 or rnd.random() < 0.06:  # the operator gives a new command
            command, g = rnd.choice(commands), rnd.randint(-2, 5)
            typed = {"side": rnd.choice(SIDES), "tag": rnd.choice(TEXTS)}
            args = {"g": g, **typed} if command not in ("INIT", "HALT") else {}
            block.command_num = h.command("top", command, **args)
            block.command = command
            block.args.update(args)
            given += 1
        for sub in subs:  # the subordinates answer, or not
            roll = rnd.random()
            sent = reference.sent[sub].number
            if sub == operator:
                if roll < 0.3:  # the person answers the request, or a stale one
                    number = sent if rnd.random() < 0.85 else max(sent - 1, 0)
                    status = rnd.choice(["DONE", "ERROR"])
                    reasons = sub_reasons(files[sub])
                    code = rnd.randrange(len(reasons)) if reasons and status == "ERROR" else 0
                    answer = (number, status, code)
                    h.layout.ANSWERS[rows[sub]].write(
                        h.buf, command_num=number, status=REPLIES_CODES[status], reason=code
                    )
                continue
            if roll < 0.45:
                status = rnd.choice(REPLIES)
                number = sent if rnd.random() < 0.9 else max(sent - 1, 0)
                h.reply(sub, status, number)
                block.sub_status[sub] = (number, status)
                extra: dict = {}
                reasons = sub_reasons(files[sub])
                if reasons:  # a reason with ERROR (and, from a buggy sub, with others)
                    reason = rnd.choice(reasons)
                    extra["error_num"] = reasons.index(reason)
                    block.sub_reason[sub] = reason
                if sub_results(files[sub]):
                    extra["result_v"] = block.sub_results.setdefault(sub, {})["v"] = rnd.randint(
                        -1, 3
                    )
                if extra:
                    h.layout.STATUS_OUT[sub].write(h.buf, **extra)
        for name, kind in (("b0", "bool"), ("i0", "int"), ("b1", "bool"), ("i1", "int")):
            if rnd.random() < 0.1:  # the world changes
                value = rnd.random() < 0.5 if kind == "bool" else rnd.randint(-4, 6)
                h.world[name] = value
                block.world[name] = value
        h.step("top")
        reference.run_cycle(block)
        if operator is not None:  # the operator module's cycle, after top's, as documented
            h.step(operator)
            person.cycle(
                (reference.sent[operator].number, reference.sent[operator].command), answer
            )
            block.sub_status[operator] = (person.number, person.status)
            reasons = sub_reasons(files[operator])
            block.sub_reason[operator] = reasons[person.reason] if reasons else "NONE"
            if seen is not None:
                seen.add(reference.sub_view[operator])
        want = {**reference.trace(), "world": dict(block.world)}
        got = {**generated_trace(h, subs, rows), "world": h.world.snapshot()}
        assert got == want, f"cycle {cycle + 1}: generated {got} != reference {want}"
        planned += any(steps for _, steps, _ in want["plans"].values())
    return given, planned


def test_generated_code_matches_the_reference(tmp_path_factory) -> None:
    runs = {"examples": 0, "cycles": 0, "commands": 0, "planned": 0}

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=DERANDOMIZE,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(data=st.data(), seed=st.integers(0, 2**32))
    def one(data: st.DataObject, seed: int) -> None:
        files = system_files(Draw(data))
        directory = tmp_path_factory.mktemp("diff") / "diff"
        write_system(directory, files)
        with Harness.build(directory) as h:
            given, planned = drive(h, files, random.Random(seed))
        runs["commands"] += given
        runs["planned"] += planned
        runs["examples"] += 1
        runs["cycles"] += CYCLES

    one()
    assert runs["examples"] >= EXAMPLES
    assert runs["planned"] > 0 or EXAMPLES < 10, "no system stepped through a plan"
    print(
        f"\ndifferential: {runs['examples']} systems, {runs['cycles']} cycles, "
        f"{runs['commands']} commands, {runs['planned']} cycles with a plan, 0 differences"
    )


def test_a_client_of_an_operator_module_matches_the_reference(tmp_path_factory) -> None:
    """`s0` an operator module: `top`'s table, its channel and the person's answers agree
    with the reference interpreter fed the documented operator cycle, every cycle."""
    runs = {"examples": 0}
    seen: set[str] = set()  # what top saw of its channel

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=DERANDOMIZE,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(data=st.data(), seed=st.integers(0, 2**32))
    def one(data: st.DataObject, seed: int) -> None:
        files = system_files(Draw(data))
        assume(not sub_results(files["s0"]))  # a task has no results
        directory = tmp_path_factory.mktemp("diff") / "diff"
        write_system(directory, {**files, "s0": as_operator(files["s0"])})
        with Harness.build(directory) as h:
            drive(h, files, random.Random(seed), operator="s0", seen=seen)
        runs["examples"] += 1

    one()
    assert runs["examples"] >= EXAMPLES
    assert {"EXECUTING", "DONE", "ERROR"} <= seen, seen
