"""Property-based fuzzing of scenario files: whatever a scenario file holds, checking it
gives located diagnostics or a Scenario that runs - never a traceback.

Hypothesis writes random scenario files for the tiny system: documents built from the
scenario keys and from near-misses (misspelt keys and names, values of every YAML type:
YAML 1.1 booleans, huge and negative integers, floats for ints, lists and mappings where
scalars go, cycles out of range and out of order, supervised modules, unknown stand-ins),
dumped as YAML and sometimes mangled as text. For every file:

- `check_scenario` returns; every diagnostic names the file, with line >= 1 and col >= 1;
- a scenario it accepts runs (at most RUN_CYCLES cycles) without raising;
- every CLI_EVERY-th accepted file also goes through `rcsgen run` in-process: exit 0 or 1,
  no traceback.

SCENARIO_FUZZ_EXAMPLES examples (200 by default, derandomized); `make fuzz` runs 2,000 with
fresh randomness.
"""

from __future__ import annotations

import dataclasses
import os
import random
import shutil
import time
from collections import Counter
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from conftest import REPO
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rcsgen.cli import main
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import check_scenario, open_harness, run

TINY = REPO / "tests" / "cases" / "valid" / "tiny"
EXAMPLES = int(os.environ.get("SCENARIO_FUZZ_EXAMPLES", "200"))
DERANDOMIZE = os.environ.get("FUZZ_RANDOM", "") == ""
RUN_CYCLES = 60
CLI_EVERY = 20  # accepted scenarios

KEYS = ["scenario", "title", "doc", "process", "max_cycles", "stop_when_done", "settings"]
KEYS += ["simulate", "trace", "report", "expect", "events"]
NEAR_KEYS = ["scenaro", "max_cycle", "stop_when", "event", "expects", "Title", "simulates"]
EVENT_KEYS = ["cycle", "doc", "command", "with", "set", "mode", "overrides"]
NAMES = ["top", "sub", "tpo", "sbu", "Top", "", "p", "q", "level", "flag", "lvl", "x", "y"]
COMMANDS = ["top.GO", "sub.MOVE", "top.INIT", "sub.HALT", "top.GOO", "shopp.GO", "top", "GO"]
COMMANDS += ["sub.move", ".GO", "top.", "a.b.C"]
SCALARS: list[object] = [
    True, False, None, 0, 1, -1, 2, 3, 50, 2**63, -(2**63) - 1, 2**64, 10**30, 0.5, -2.5,
    1e308, "no", "yes", "on", "off", "true", "1", "high", "", " ", "DONE", "ERROR", "\u2028",
]  # fmt: skip
MODE_KEYS = ["dont_run", "single_step", "single_step_num", "simulate", "dont-run"]


def _scalar(rnd: random.Random) -> object:
    return rnd.choice(SCALARS + NAMES)


def _value(rnd: random.Random, depth: int = 0) -> object:
    """Any YAML value, mostly scalars."""
    roll = rnd.random()
    if depth > 2 or roll < 0.7:
        return _scalar(rnd)
    if roll < 0.85:
        return [_value(rnd, depth + 1) for _ in range(rnd.randint(0, 3))]
    return {
        rnd.choice(NAMES + KEYS) or "k": _value(rnd, depth + 1) for _ in range(rnd.randint(0, 3))
    }


def _mapping(rnd: random.Random, keys: list[str], values: list[object]) -> dict[str, object]:
    return {rnd.choice(keys): rnd.choice(values) for _ in range(rnd.randint(0, 3))}


def _event(rnd: random.Random) -> object:
    if rnd.random() < 0.05:
        return _value(rnd)
    event: dict[str, object] = {}
    if rnd.random() < 0.9:
        event["cycle"] = rnd.choice([1, 2, 3, 5, 10, 40, 0, -1, 1000, 2.5, "3", None])
    for key in rnd.sample(EVENT_KEYS[1:], rnd.randint(1, 3)):
        if key == "command":
            event[key] = rnd.choice(COMMANDS)
        elif key == "with":
            event[key] = _mapping(rnd, ["x", "y", "depth", "X"], SCALARS)
        elif key == "set":
            event[key] = _mapping(rnd, ["level", "flag", "lvl", "count"], SCALARS)
        elif key == "mode":
            event[key] = {rnd.choice(NAMES): _mapping(rnd, MODE_KEYS, SCALARS)}
        elif key == "overrides":
            event[key] = rnd.choice([True, False, "yes", 1])
        else:
            event[key] = _value(rnd)
    if rnd.random() < 0.1:
        event[rnd.choice(["comand", "sett", "cycles"])] = _value(rnd)
    return event


def near_valid_scenario(rnd: random.Random) -> dict[str, object]:
    """A scenario of the right shape (it passes the schema) with names, types and cycles
    drawn from right and wrong ones: the semantic checks and the run get exercised."""
    pick = rnd.choice
    names = ["top", "top", "top", "sub", "sub", "sub", "tpo", "sbu"]
    wrong = rnd.random() < 0.5  # half of them have a mistake or two, half none
    doc: dict[str, object] = {"scenario": "go", "title": "fuzzed"}
    doc["max_cycles"] = pick([5, 20, 50, 400])
    if rnd.random() < 0.3:
        doc["process"] = pick(["p", "q"]) if wrong else "p"
    if rnd.random() < 0.6:
        doc["stop_when_done"] = pick(names) if wrong else pick(["top", "sub"])
    if wrong and rnd.random() < 0.2:
        doc["simulate"] = [pick(names)]
    fields = ["level", "flag"] + (["lvl"] if wrong else [])
    if rnd.random() < 0.4:
        doc["trace"] = {"world": rnd.sample(fields, rnd.randint(1, 2))}
    if rnd.random() < 0.3:
        doc["report"] = {"phases": pick(names) if wrong else "top", "figures": [pick(fields)]}
    if rnd.random() < 0.4:
        figure = pick(fields)
        value = pick([True, False]) if figure == "flag" else pick([0.0, 2.5, {"min": 1}])
        doc["expect"] = pick(
            [
                {"status": pick(["DONE", "ERROR"])},
                {"cycles": {"max": rnd.randint(1, 60)}},
                {"figures": {figure: pick([0.0, True, {"min": 1}]) if wrong else value}},
            ]
        )
    events = []
    cycle = 1
    for _ in range(rnd.randint(0, 4)):
        cycle = max(1, cycle + rnd.randint(-1, 8))
        event: dict[str, object] = {"cycle": pick([cycle, 600]) if wrong else cycle}
        roll = rnd.random()
        if roll < 0.5:
            event["command"] = pick(["top.GO", "sub.MOVE", "top.HALT", "sub.INIT"])
            if wrong and rnd.random() < 0.3:
                event["command"] = pick(["top.GOO", "tpo.GO", "sub.MOVEE"])
            if event["command"].startswith("sub."):
                event["overrides"] = not wrong or rnd.random() < 0.5
            if event["command"] == "sub.MOVE":
                event["with"] = {"x": pick([1.0, 2, -3.5])}
                if wrong:
                    event["with"] = {pick(["x", "y"]): pick([1.0, True, 2**70, "no"])}
        elif roll < 0.8:
            field = pick(["level", "flag"] + (["lvl"] if wrong else []))
            event["set"] = {field: pick([True, False]) if field == "flag" else pick([2.5, 3])}
            if wrong and rnd.random() < 0.5:
                event["set"] = {field: pick([True, 2.5, 3, 2**64])}
        else:
            event["mode"] = {pick(names): {pick(["dont_run", "single_step"]): rnd.random() < 0.5}}
        events.append(event)
    doc["events"] = events
    return doc


def random_scenario(rnd: random.Random) -> dict[str, object]:
    """A scenario document: near-valid (60%), or wild: any keys and values of any type."""
    if rnd.random() < 0.6:
        return near_valid_scenario(rnd)
    doc: dict[str, object] = {"scenario": rnd.choice(["go", "go", "Go", "../x", "", 3])}
    for key in rnd.sample(KEYS[1:], rnd.randint(2, len(KEYS) - 1)):
        if key == "max_cycles":
            doc[key] = rnd.choice([5, 20, 50, 0, -3, 10**9, 2.5, "50"])
        elif key in ("process", "stop_when_done"):
            doc[key] = rnd.choice(NAMES)
        elif key == "settings":
            doc[key] = _mapping(rnd, ["seed", "map", "scale", "a b"], SCALARS + [[1], {"a": 1}])
        elif key == "simulate":
            doc[key] = [rnd.choice(NAMES) for _ in range(rnd.randint(0, 2))]
        elif key == "trace":
            doc[key] = {"world": [rnd.choice(NAMES) for _ in range(rnd.randint(0, 3))]}
        elif key == "report":
            doc[key] = {"phases": rnd.choice(NAMES), "figures": [rnd.choice(NAMES)]}
        elif key == "expect":
            doc[key] = rnd.choice(
                [
                    {"status": rnd.choice(["DONE", "ERROR", "done", True])},
                    {"cycles": {"min": rnd.randint(0, 9), "max": rnd.randint(-1, 60)}},
                    {"figures": {rnd.choice(NAMES) or "f": rnd.choice([*SCALARS, {"min": 1}])}},
                ]
            )
        elif key == "events":
            doc[key] = [_event(rnd) for _ in range(rnd.randint(0, 5))]
        else:
            doc[key] = _value(rnd)
    if rnd.random() < 0.1:
        doc[rnd.choice(NEAR_KEYS)] = _value(rnd)
    return doc


def mangle(text: str, rnd: random.Random) -> str:
    """A text-level mistake: a deleted, duplicated or re-indented line, inserted syntax."""
    lines = text.split("\n")
    at = rnd.randrange(len(lines))
    kind = rnd.choice(["delete", "duplicate", "indent", "insert", "tab"])
    if kind == "delete":
        del lines[at]
    elif kind == "duplicate":
        lines.insert(at, lines[at])
    elif kind == "indent":
        lines[at] = "  " + lines[at]
    elif kind == "tab":
        lines[at] = "\t" + lines[at].lstrip()
    else:
        col = rnd.randint(0, len(lines[at]))
        piece = rnd.choice([": ", "- ", "{", "[", "&a ", "*a", "!!str ", "---", "#", "\x00", "'"])
        lines[at] = lines[at][:col] + piece + lines[at][col:]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory):
    """The tiny system with a scenarios/ directory, its IR and a built package."""
    root = tmp_path_factory.mktemp("scenario-fuzz")
    system_dir = root / "sys"
    shutil.copytree(TINY, system_dir)
    (system_dir / "scenarios").mkdir()
    front = compile_paths([system_dir])
    assert not front.diagnostics.errors
    result = CliRunner().invoke(main, ["build", str(system_dir), "-o", str(root / "gen")])
    assert result.exit_code == 0, result.output
    return system_dir, front.systems[0], root / "gen"


def test_random_scenario_files_never_end_in_a_traceback(tiny, capsys) -> None:
    system_dir, system, generated = tiny
    path = system_dir / "scenarios" / "fuzz.yaml"
    stats: Counter[str] = Counter()
    start = time.perf_counter()

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=DERANDOMIZE,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(salt=st.integers(min_value=0, max_value=2**32))
    def one(salt: int) -> None:
        rnd = random.Random(salt)
        text = yaml.safe_dump(random_scenario(rnd), sort_keys=False, allow_unicode=True)
        if rnd.random() < 0.25:
            text = mangle(text, rnd)
        path.write_bytes(text.encode("utf-8", "surrogatepass"))
        stats["files"] += 1
        scenario, diags = check_scenario(path, system)
        for d in diags:
            assert Path(d.span.file).resolve() == path.resolve(), d.render()
            assert d.span.line >= 1 and d.span.col >= 1 and d.message, d.render()
        if scenario is None:
            stats["rejected"] += 1
            stats.update(f"code {d.code}" for d in diags.errors)
            return
        stats["accepted"] += 1
        bounded = dataclasses.replace(scenario, max_cycles=min(scenario.max_cycles, RUN_CYCLES))
        run(bounded, open_harness(bounded, generated / system.name))  # must not raise
        if stats["accepted"] % CLI_EVERY == 0:
            args = ["run", str(path), "--generated", str(generated), "-q", "--trace", os.devnull]
            result = CliRunner().invoke(main, args)
            if result.exception is not None and not isinstance(result.exception, SystemExit):
                raise result.exception
            assert result.exit_code in (0, 1), result.output
            assert "Traceback" not in result.output
            stats["cli runs"] += 1

    one()
    elapsed = time.perf_counter() - start
    codes = sorted(k.removeprefix("code ") for k in stats if k.startswith("code "))
    assert stats["files"] >= EXAMPLES
    assert stats["accepted"] and stats["rejected"]  # neither all fatal nor all harmless
    assert len(codes) >= 15, codes  # the mistakes reach the checks, not only the schema
    with capsys.disabled():
        print(
            f"\nscenario fuzz: {stats['files']} random scenario files, tracebacks=0, "
            f"{stats['accepted']} accepted and run, {stats['rejected']} rejected with located "
            f"diagnostics ({len(codes)} distinct codes), {stats['cli runs']} CLI runs, "
            f"{elapsed:.1f} s"
        )
