"""Reading traces, the terminal changes timeline and rule coverage (`rcsgen trace ...`).

The golden traces of the miner's scenarios are the realistic input; broken traces are made
by editing copies. Every bad input is one line and an exit code, never a traceback.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import rcsgen

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import read_trace
from rcsgen.tools.traces import changes, coverage, stored
from rcsgen.tools.traces import read as traces

REPO = Path(__file__).resolve().parent.parent
MINER = REPO / "specs" / "miner"
GOLDEN = REPO / "tests" / "golden"
# The miner's golden traces (other systems' goldens are `<system>_<scenario>.jsonl`).
MINER_GOLDEN = sorted(GOLDEN / f"{p.stem}.jsonl" for p in (MINER / "scenarios").glob("*.yaml"))


@pytest.fixture(scope="module")
def system():
    return compile_paths([MINER]).systems[0]


@pytest.fixture(scope="module")
def pop_out():
    return traces.load(GOLDEN / "pop_out.jsonl")


def lines_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in read_trace(path)]  # (full lines)


def write_lines(path: Path, records: list[dict]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    return path


# ---------------------------------------------------------------- reading


def test_load_gives_columns_per_module_and_world(pop_out):
    assert len(pop_out) == 620 and pop_out.cycles[:3] == [1, 2, 3]
    assert "co" in pop_out.modules and pop_out.modules == sorted(pop_out.modules)
    co = pop_out.columns["co"]
    i = pop_out.cycles.index(248)
    assert (co["command"][i], co["state"][i], co["rule"][i]) == (
        "SUMP_SHEAR_CUSP",
        "S1",
        "SUMP_SHEAR_CUSP/S2/1",
    )
    assert pop_out.world["popped_out_of_shear"][i] is True


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "is empty: a trace has one JSON line per cycle"),
        ("not json\n", ":1: not a trace line: Expecting value"),
        ('{"a": 1}\n', ":1: not a trace line (no `cycle` number)"),
        # (a line of changes only, with no full line before it to change)
        ('{"cycle": 1}\n', ":1: not a trace line (no `modules` object, nor a full line before"),
        (
            '{"cycle": 1, "modules": {"co": {"command": "INIT"}}}\n',
            "module co has no `command_num`",
        ),
    ],
)
def test_not_a_trace_is_one_line(tmp_path, text, message):
    path = tmp_path / "bad.jsonl"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(traces.TraceError) as caught:
        traces.load(path)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_cycles_must_increase_and_modules_stay(tmp_path):
    records = lines_of(GOLDEN / "sump_shear_cusp.jsonl")[:3]
    with pytest.raises(traces.TraceError, match=r":2: cycle 1 after cycle 1"):
        traces.load(write_lines(tmp_path / "a.jsonl", [records[0], records[0]]))
    del records[1]["modules"]["co"]
    with pytest.raises(traces.TraceError, match=r":2: modules differ from the first line's \(co\)"):
        traces.load(write_lines(tmp_path / "b.jsonl", records))
    with pytest.raises(traces.TraceError, match="no trace file at"):
        traces.load(tmp_path / "missing.jsonl")


def test_a_module_unchanged_since_its_last_line_is_read_as_a_changed_one(tmp_path):
    """The reader reuses a module's checked values while its object repeats (most modules,
    most cycles): the columns must still hold one value per cycle, the same as a plain read,
    and a line where the object changes is checked again whole."""
    records = lines_of(GOLDEN / "sump_shear_cusp.jsonl")[:40]
    loaded = traces.load(write_lines(tmp_path / "a.jsonl", records))
    for module in loaded.modules:
        for name, column in loaded.columns[module].items():
            plain = [r["modules"][module].get(name, "") for r in records]
            assert column == plain, (module, name)
    for name, series in loaded.world.items():
        assert series == [r["world"][name] for r in records], name
    records[30]["modules"]["co"] = dict(records[29]["modules"]["co"])
    del records[31]["modules"]["co"]["state"]  # co repeats at 31, then loses a field
    with pytest.raises(traces.TraceError, match=r":32: module co has no `state`"):
        traces.load(write_lines(tmp_path / "b.jsonl", records))
    records = lines_of(GOLDEN / "sump_shear_cusp.jsonl")[:3]
    records[2]["world"]["zz_unknown"] = 1
    with pytest.raises(traces.TraceError, match=r":3: world fields differ"):
        traces.load(write_lines(tmp_path / "c.jsonl", records))


def test_lanes_follow_the_execution_order_with_levels(system, pop_out):
    lanes = traces.lanes(pop_out, system)
    assert [lane.module for lane in lanes] == [m for p in system.processes for m in p.modules]
    by_name = {lane.module: lane for lane in lanes}
    assert (by_name["sec"].level, by_name["sb"].level, by_name["bm"].level) == (1, 2, 5)
    assert by_name["mine"].simulator and by_name["mine"].level == 0
    assert [lane.module for lane in traces.lanes(pop_out, None)] == pop_out.modules


def test_a_stand_in_run_is_shown_and_counted_as_the_stand_in(system):
    trace = traces.load(GOLDEN / "cr_simulated.jsonl")
    lanes = {lane.module: lane for lane in traces.lanes(trace, system)}
    assert lanes["cr"].runs_as == "cr_sim" and lanes["cr"].simulator
    assert "gh" not in lanes


def test_a_trace_of_other_specs_is_refused(tmp_path, system):
    records = lines_of(GOLDEN / "sump_shear_cusp.jsonl")[:2]
    for record in records:
        record["modules"]["zz"] = record["modules"].pop("css")
    odd = traces.load(write_lines(tmp_path / "odd.jsonl", records))
    with pytest.raises(traces.TraceError, match="module `zz` is not in system miner"):
        traces.check_against(system, odd)
    records = lines_of(GOLDEN / "sump_shear_cusp.jsonl")[:2]
    records[0]["modules"]["co"]["rule"] = "SUMP_SHEAR_CUSP/S9/1"
    stale = traces.load(write_lines(tmp_path / "stale.jsonl", records))
    with pytest.raises(traces.TraceError, match=r"co fired rule `SUMP_SHEAR_CUSP/S9/1`"):
        traces.check_against(system, stale)


# ---------------------------------------------------------------- changes


def test_changes_show_what_changed_and_fold_repeats(system, pop_out):
    lanes = traces.lanes(pop_out, system)
    text = list(changes.timeline(pop_out, lanes, ["co", "cc"], first=246, last=253))
    assert text == [
        "cycle 247",
        "  world  popped_out_of_shear false -> true",
        "cycle 248",
        "  co     state S2 -> S1  fired SUMP_SHEAR_CUSP/S2/1",
        "  cc     command SHEAR #8 -> SHEAR_CORRECT #9  status EXECUTING #8 -> EXECUTING #9  "
        "state S2 -> S1  fired SHEAR_CORRECT/S0/1",
        "cycle 253",
        "  world  popped_out_of_shear true -> false",
    ]
    first = list(changes.timeline(pop_out, lanes, ["sec"], world="none", last=1))
    assert first == [
        "cycle 1",
        "  sec  command INIT #1  status EXECUTING #1  state S1  fired INIT/S0/1",
    ]


def test_changes_fold_cycles_that_change_alike(system):
    # the shuttle car is late: the loose-coal HALT is re-sent every cycle for 78 cycles
    trace = traces.load(GOLDEN / "shuttle_car.jsonl")
    lanes = traces.lanes(trace, system)
    folded = list(changes.timeline(trace, lanes, ["bm"], world="none", first=356, last=433))
    assert folded == [
        "cycle 356",
        "  bm  command HALT #8 -> HALT #9  status DONE #8 -> DONE #9  fired HALT/S0/1",
        "  ... the same each cycle through cycle 433 (78 cycles)",
    ]
    every = list(changes.timeline(trace, lanes, ["bm"], "none", 356, 433, merge=False))
    assert len(every) == 2 * 78
    # a shorter run of it in late_tail: the fold ends where the gauge drops below the limit
    trace = traces.load(GOLDEN / "late_tail.jsonl")
    halts = list(changes.timeline(trace, traces.lanes(trace, system), ["bm"], "none", 112, 116))
    assert halts[-1] == "  ... the same each cycle through cycle 116 (5 cycles)"
    assert halts[1] == (
        "  bm  command HALT #5 -> HALT #6  status DONE #5 -> DONE #6  fired HALT/S0/1"
    )


def test_changes_world_fields(pop_out):
    discrete = changes.world_fields(pop_out, "discrete")
    assert "popped_out_of_shear" in discrete and "drum_on_cmd" in discrete
    assert "true_x" not in discrete and "loose_coal" not in discrete
    assert "boom_angle" in changes.world_fields(pop_out, "all")
    assert changes.world_fields(pop_out, "none") == []
    with pytest.raises(ValueError, match=r"^world fields: `al` is not one of discrete, all, none$"):
        changes.world_fields(pop_out, "al")  # not a silent "discrete"


# ---------------------------------------------------------------- coverage


def test_coverage_counts_every_table_rule_of_the_miner(system):
    found = [traces.load(p) for p in MINER_GOLDEN]
    result = coverage.measure(system, found)
    assert len(result.rules) == sum(len(c.table_rules()) for c in system.controllers)
    rules = {(r.module, r.rule): r for r in result.rules}
    pop = rules[("co", "SUMP_SHEAR_CUSP/S2/1")]
    assert pop.cycles == 1 and pop.traces == [str(GOLDEN / "pop_out.jsonl")]
    assert pop.where.endswith("specs/miner/co.yaml:216")
    assert rules[("co", "SUMP_SHEAR_CUSP/S2/2")].traces == [
        str(GOLDEN / "late_tail.jsonl"),
        str(GOLDEN / "shuttle_car.jsonl"),
    ]
    assert rules[("tc", "FAST_FORWARD/S0/1")].cycles == 0
    assert rules[("cr_sim", "SUMP/S0/1")].traces == [str(GOLDEN / "cr_simulated.jsonl")]
    assert result.ran["cr"] == [str(p) for p in MINER_GOLDEN if "cr_sim" not in p.name]
    text = coverage.to_text(result)
    assert text.startswith(f"rule coverage of miner over 11 traces: {result.fired} of ")
    assert "  co\n    INITIAL_APPROACH_FACE/S1/2      " in text
    data = json.loads(coverage.to_json(result))
    assert data["fired"] == result.fired and data["rules"] == len(result.rules)
    co = next(m for m in data["modules"] if m["module"] == "co")
    assert {"rule", "where", "guard", "doc", "cycles", "traces"} == set(co["rules"][0])


def test_coverage_gives_the_time_per_state_of_each_module() -> None:
    """Issue 26, item 6 (the paper's support facility: % of execution time per state): every
    traced cycle of a module is counted once, in the state (of its command) the trace shows."""
    path = GOLDEN / "inspection" / "nominal_inspection.jsonl"
    trace = traces.load(path)
    system = compile_paths([REPO / "specs" / "inspection"]).systems[0]
    result = coverage.measure(system, [trace])
    ws = result.states["ws"]
    assert sum(ws.values()) == len(trace.cycles)
    column = trace.columns["ws"]
    measuring = sum(
        1
        for command, state in zip(column["command"], column["state"], strict=True)
        if (command, state) == ("INSPECT_PART", "MEASURING")
    )
    assert ws["INSPECT_PART/MEASURING"] == measuring > 0
    assert ws["idle"] == column["state"].count("NOP")
    assert max(ws, key=ws.__getitem__) == "INSPECT_PART/MEASURING"  # where ws spends most
    text = coverage.to_text(result)
    section = text.split("time per state", 1)[1].splitlines()
    line = next(row for row in section if row.strip().startswith("INSPECT_PART/MEASURING"))
    period = system.processes[0].cycle_period
    assert line.split()[1:] == [
        str(measuring),
        f"{measuring * period:.1f}",
        "s",
        f"{100 * measuring / len(trace.cycles):.1f}%",
    ]
    data = json.loads(coverage.to_json(result))
    spent = next(m for m in data["modules"] if m["module"] == "ws")["time_per_state"]
    assert spent["INSPECT_PART/MEASURING"] == {
        "cycles": measuring,
        "seconds": round(measuring * period, 6),
    }


def made_up_coverage() -> coverage.Coverage:
    """Three modules in rule order: `a` run by no trace, `b` with every rule fired (its
    states tied at 2 cycles inserted out of order, its period with a 7th decimal), `c` run
    with one rule missed and no known period."""
    rule = coverage.RuleCount
    return coverage.Coverage(
        "made",
        ["t1", "t2"],
        [
            rule("a", "INIT/S0/1", "a.yaml:3", "always", "start"),
            rule("b", "GO/S0/1", "b.yaml:5", "always", "go", 3, ["t1", "t2"]),
            rule("c", "GO/S0/1", "c.yaml:7", "ready", "wait", 1, ["t2"]),
            rule("c", "GO/S0/10", "c.yaml:9", "x > 1 and y", "far"),
        ],
        {"a": [], "b": ["t1", "t2"], "c": ["t2"]},
        {"b": {"GO/S1": 2, "GO/S0": 2, "idle": 5}, "c": {"GO/S0": 4}},
        {"a": 0.5, "b": 0.1234567},
    )


def test_coverage_text_says_what_never_fired_and_where_each_module_spent_its_cycles() -> None:
    """The text view whole: the per-module table (a module no trace ran says so), the rules
    that never fired per module (a module that missed none left out), the states most
    cycles first (ties by name), a module without a known period at 0 s."""
    assert coverage.to_text(made_up_coverage()) == (
        "rule coverage of made over 2 traces: 2 of 4 table rules fired (50.0%)\n"
        "\n"
        "module   rules fired         ran in\n"
        "a            1     0   0.0%  no trace\n"
        "b            1     1 100.0%  2 traces\n"
        "c            2     1  50.0%  1 trace\n"
        "\n"
        "never fired:\n"
        "  a  (not run by any trace)\n"
        "    INIT/S0/1  a.yaml:3  always\n"
        "  c\n"
        "    GO/S0/10  c.yaml:9  x > 1 and y\n"
        "\n"
        "time per state (cycles, seconds, share of the module's traced cycles):\n"
        "  b\n"
        "    idle         5      0.6 s   55.6%\n"
        "    GO/S0        2      0.2 s   22.2%\n"
        "    GO/S1        2      0.2 s   22.2%\n"
        "  c\n"
        "    GO/S0        4      0.0 s  100.0%\n"
    )
    empty = coverage.to_text(coverage.Coverage("none", [], [], {}))
    assert empty.startswith("rule coverage of none over 0 traces: 0 of 0 table rules fired (-)\n")


def test_coverage_json_holds_each_modules_rules_and_seconds_per_state() -> None:
    text = coverage.to_json(made_up_coverage())
    assert text.startswith('{\n  "fired": 2,\n  "modules": [\n    {\n      "module": "a",')
    data = json.loads(text)
    assert (data["system"], data["traces"], data["rules"], data["fired"]) == (
        "made",
        ["t1", "t2"],
        4,
        2,
    )
    by = {m["module"]: m for m in data["modules"]}
    assert list(by) == ["a", "b", "c"]
    assert [m["ran_in"] for m in by.values()] == [[], ["t1", "t2"], ["t2"]]
    assert by["a"]["time_per_state"] == {}
    assert by["b"]["time_per_state"]["GO/S0"] == {"cycles": 2, "seconds": 0.246913}
    assert by["c"]["time_per_state"] == {"GO/S0": {"cycles": 4, "seconds": 0.0}}
    assert by["c"]["rules"] == [
        {
            "rule": "GO/S0/1",
            "where": "c.yaml:7",
            "guard": "ready",
            "doc": "wait",
            "cycles": 1,
            "traces": ["t2"],
        },
        {
            "rule": "GO/S0/10",
            "where": "c.yaml:9",
            "guard": "x > 1 and y",
            "doc": "far",
            "cycles": 0,
            "traces": [],
        },
    ]


def test_coverage_adds_up_the_cycles_of_every_trace_given() -> None:
    """A rule's cycles are the sum over the traces (the same trace twice: twice its count),
    each trace it fired in named; an unconditional rule's guard reads `always`."""
    trace = traces.load(GOLDEN / "cell" / "plan_ahead.jsonl")
    system = compile_paths([REPO / "specs" / "cell"]).systems[0]
    once = {(r.module, r.rule): r.cycles for r in coverage.measure(system, [trace]).rules}
    twice = coverage.measure(system, [trace, trace])
    assert sum(once.values()) > 0
    assert {(r.module, r.rule): r.cycles for r in twice.rules} == {
        key: 2 * cycles for key, cycles in once.items()
    }
    init = next(r for r in twice.rules if (r.module, r.rule) == ("sup", "INIT/S0/1"))
    assert (init.guard, init.traces) == ("always", [trace.name, trace.name])


# ---------------------------------------------------------------- command line


def test_cli_changes_and_coverage(monkeypatch):
    monkeypatch.chdir(REPO)
    shown = rcsgen("trace", "changes", "tests/golden/pop_out.jsonl", "-m", "co", "--to", "5")
    assert shown.exit_code == 0, shown.output
    assert shown.output.splitlines()[:2] == [
        "cycle 1",
        "  co     command INIT #1  status EXECUTING #1  state S1  fired INIT/S0/1",
    ]
    report = rcsgen("trace", "coverage", *(str(p) for p in MINER_GOLDEN))
    assert report.exit_code == 0 and "never fired:" in report.output
    as_json = rcsgen("trace", "coverage", "tests/golden/box_cut.jsonl", "--format", "json")
    assert json.loads(as_json.output)["traces"] == ["tests/golden/box_cut.jsonl"]


def test_cli_lines_prints_every_cycle_whole(monkeypatch, tmp_path):
    """`rcsgen trace lines` expands a stored trace: each cycle a whole line, as the golden
    comparison reads it; `-o` writes them to a file (which reads as the same trace)."""
    monkeypatch.chdir(REPO)
    shown = rcsgen("trace", "lines", "tests/golden/pop_out.jsonl")
    assert shown.exit_code == 0, shown.output
    assert shown.stdout.splitlines() == read_trace(GOLDEN / "pop_out.jsonl")
    whole = tmp_path / "whole.jsonl"
    written = rcsgen("trace", "lines", "tests/golden/pop_out.jsonl", "-o", whole)
    assert written.exit_code == 0 and whole.read_text(encoding="utf-8") == shown.stdout
    again, before = traces.load(whole), traces.load(GOLDEN / "pop_out.jsonl")
    assert (again.cycles, again.columns, again.world) == (
        before.cycles,
        before.columns,
        before.world,
    )


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (["changes", "missing.jsonl"], 1, "error: no trace file at missing.jsonl"),
        (["changes", "README.md"], 1, "error: README.md:1: not a trace line: Expecting value"),
        (["changes", "tests/golden/pop_out.jsonl", "-m", "cx"], 2, "error: unknown module `cx`"),
        (["coverage", "missing.jsonl"], 1, "error: no trace file at missing.jsonl"),
        (["show", "README.md"], 1, "error: README.md:1: not a trace line"),
        (["lines", "missing.jsonl"], 1, "error: no trace file at missing.jsonl"),
        (["lines", "README.md"], 1, "error: README.md is not a trace: Expecting value"),
    ],
)
def test_cli_bad_input_is_one_line(monkeypatch, args, code, message):
    monkeypatch.chdir(REPO)
    result = rcsgen("trace", *args)
    assert result.exit_code == code
    assert result.output.startswith(message) and result.output.count("\n") == 1


def test_cli_coverage_needs_specs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = rcsgen("trace", "coverage", GOLDEN / "box_cut.jsonl")
    assert result.exit_code == 2
    assert result.output == (
        "error: no specs/ here: name the specs the trace was recorded from with --specs\n"
    )
    again = rcsgen("trace", "coverage", GOLDEN / "box_cut.jsonl", "--specs", MINER)
    assert again.exit_code == 0, again.output


def test_docs_report_the_current_coverage_of_the_scenarios(system):
    found = [traces.load(p) for p in MINER_GOLDEN]
    result = coverage.measure(system, found)
    total = len(result.rules)
    line = f"**{result.fired} of {total} table rules fired ({100 * result.fired / total:.1f}%)**"
    miner = (REPO / "docs" / "miner.md").read_text(encoding="utf-8")
    assert line in miner, (
        "docs/miner.md's coverage section is stale: update it from\n"
        "  rcsgen trace coverage tests/golden/*.jsonl"
    )


def test_starts_mark_every_change_and_the_page_looks_only_there(pop_out):
    """Trace.starts holds, per module, the cycles where its line's object changed: its
    values change nowhere else, and the page's run-length encoding from those cycles alone
    is the one made by looking at every cycle."""
    from rcsgen.tools.traces import view

    for module in pop_out.modules:
        starts, col = pop_out.starts[module], pop_out.columns[module]
        assert starts[0] == 0 and starts == sorted(set(starts))
        rows = list(zip(*col.values(), strict=True))
        changed = [i for i in range(1, len(rows)) if rows[i] != rows[i - 1]]
        assert set(changed) <= set(starts), module
        for name, numbers in (("command", col["command_num"]), ("state", None)):
            every = view.runs(col[name], numbers, view.StringTable())
            only = view.runs(col[name], numbers, view.StringTable(), str, starts)
            assert every == only, (module, name)


def test_a_line_repeating_the_modules_text_reads_as_if_decoded_whole(tmp_path):
    """The reader decodes only the rest of a line whose `"modules":{...}` text is the last
    line's (three lines in four of a long run): the golden trace as written (compact) must
    give what the same lines give spaced out (never taken that way); odd shapes (a `world`
    key nested in a module's result, a second `modules` key, a broken rest) decoded whole."""
    compact = GOLDEN / "around_pillar.jsonl"
    records = lines_of(compact)
    fast = traces.load(compact)
    slow = traces.load(write_lines(tmp_path / "spaced.jsonl", records))
    assert (fast.cycles, fast.modules, fast.world) == (slow.cycles, slow.modules, slow.world)
    assert fast.columns == slow.columns and fast.starts == slow.starts

    def compact_lines(rows):
        text = "".join(json.dumps(r, separators=(",", ":")) + "\n" for r in rows)
        (tmp_path / "odd.jsonl").write_text(text, encoding="utf-8")
        return tmp_path / "odd.jsonl"

    rows = [dict(records[i]) for i in range(4)]
    rows[2]["modules"] = rows[1]["modules"]  # the same text twice, then a bad world
    rows[2]["world"] = []
    with pytest.raises(traces.TraceError, match=r":3: world fields differ"):
        traces.load(compact_lines(rows))
    rows = [dict(records[i]) for i in range(3)]
    rows[2]["modules"] = rows[1]["modules"]
    text = compact_lines(rows).read_text("utf-8").splitlines()
    text[2] = text[2][:-1] + ',"modules":{}}'  # a second `modules` key: JSON keeps the last
    (tmp_path / "twice.jsonl").write_text("\n".join(text) + "\n", encoding="utf-8")
    with pytest.raises(traces.TraceError, match=r":3: modules differ"):
        traces.load(tmp_path / "twice.jsonl")


# ---------------------------------------------------------------- the stored form


def _line(cycle: int, modules: dict, world: dict, **more) -> str:
    return stored.dumps({"cycle": cycle, "modules": modules, "world": world, **more})


def test_the_stored_form_expands_to_every_line_byte_for_byte():
    """Full lines -> stored -> full lines is the identity, whatever changes: a value, its
    type alone (1, 1.0, true), null, a member of a nested object, a member that appears or
    goes (`cause`, `overrides`), a nested object replaced by a value; the first line and
    every KEYFRAME-th cycle are full lines, a cycle where nothing changed is its number, and
    a line without modules (a timing record) is kept as it is."""
    co = {"command": "GO", "command_num": 1, "rule": None, "state": "S1", "status": "DONE"}
    co |= {"status_num": 1, "reason": "NONE", "result": {"n": 0}}
    rows = [
        _line(1, {"co": co}, {"a": 1, "b": "x"}),
        _line(2, {"co": co}, {"a": 1, "b": "x"}),  # nothing changed
        _line(3, {"co": co | {"rule": "GO/S1/1"}}, {"a": 1.0, "b": "x"}),  # 1 -> 1.0
        _line(4, {"co": co | {"cause": "cd"}}, {"a": True, "b": None}),
        _line(5, {"co": co | {"result": {"n": 1, "m": 2}}}, {"a": True, "b": None}),
        _line(6, {"co": co | {"result": {"n": 3}}}, {"a": 0, "b": None}, overrides={"a": "SAFE"}),
        _line(7, {"co": co | {"result": 5}}, {"a": 0, "b": "é"}),
        _line(8, {"co": co | {"result": {}}}, {"a": 0, "b": "é"}),
        '{"cycle":8,"periodicity":{"period_ms":50.0}}',
    ]
    kept = list(stored.condensed(rows, keyframe=4))
    assert list(stored.expanded(kept)) == rows
    assert kept[0] == rows[0] and kept[3] == rows[3] and kept[7] == rows[7]  # cycles 1, 4, 8
    assert kept[1] == '{"cycle":2}' and kept[8] == rows[8]
    assert (
        kept[2] == '{"cycle":3,"changed":{"modules":{"co":{"rule":"GO/S1/1"}},"world":{"a":1.0}}}'
    )
    assert json.loads(kept[4])["removed"] == [["modules", "co", "cause"]]
    assert json.loads(kept[5]) == {
        "cycle": 6,
        "changed": {
            "modules": {"co": {"result": {"n": 3}}},
            "overrides": {"a": "SAFE"},
            "world": {"a": 0},
        },
        "removed": [["modules", "co", "result", "m"]],
    }
    assert json.loads(kept[6])["removed"] == [["overrides"]]
    # read alike (the reader refuses a `result` that is not an object: up to cycle 6)
    a, b = traces.parse_lines(rows[:6], "t"), traces.parse_lines(kept[:6], "t")
    assert (a.cycles, a.columns, a.world, a.starts) == (b.cycles, b.columns, b.world, b.starts)


def test_every_golden_is_stored_in_the_stored_form_and_expands_to_whole_cycles():
    """A golden re-recorded comes out exactly as committed only if the committed one is in
    the stored form (condensed from its own expansion), and every line it expands to is a
    whole cycle; stored, the goldens are at least 10x smaller than their full lines."""
    stored_bytes = full_bytes = 0
    for path in sorted(GOLDEN.rglob("*.jsonl")):
        kept = path.read_text(encoding="utf-8").splitlines()
        full = read_trace(path)
        assert list(stored.condensed(full)) == kept, path
        records = [json.loads(line) for line in full]
        assert [r["cycle"] for r in records] == list(range(1, len(records) + 1)), path
        assert all({"modules", "world"} <= r.keys() for r in records), path
        stored_bytes += sum(len(line) + 1 for line in kept)
        full_bytes += sum(len(line) + 1 for line in full)
    assert full_bytes >= 10 * stored_bytes, (full_bytes, stored_bytes)
