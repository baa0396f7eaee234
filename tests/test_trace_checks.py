"""What the trace tools promise beyond the realistic runs of tests/test_traces.py: every way a
trace line can disagree with the first line is one located error (the viewers trust what
`traces.load` accepts), and rule coverage counts each rule's cycles over all the traces given.
"""

from __future__ import annotations

import json
import zlib
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.traces import coverage
from rcsgen.tools.traces import read as traces

REPO = Path(__file__).resolve().parent.parent
GOLDEN = REPO / "tests" / "golden"


def line(cycle: int, world: object = None, **modules: dict[str, object]) -> str:
    record: dict[str, object] = {"cycle": cycle, "modules": modules}
    if world is not None:
        record["world"] = world
    return json.dumps(record)


def co(**extra: object) -> dict[str, object]:
    values: dict[str, object] = {
        "command": "INIT",
        "command_num": 1,
        "status": "DONE",
        "status_num": 1,
        "state": "NOP",
        "rule": None,
    }
    return values | extra


GOOD = line(1, {"a": 1, "b": True}, co=co())


@pytest.mark.parametrize(
    ("second", "message"),
    [
        (line(2, {"a": 2}, co=co()), "t:2: world fields differ from the first line's"),
        (line(2, {"a": 2, "b": 1, "c": 0}, co=co()), "t:2: world fields differ"),
        (line(2, None, co=co()), "t:2: world fields differ"),
        (line(2, ["a", "b"], co=co()), "t:2: world fields differ"),  # not an object
        (
            line(2, {"a": 2, "b": False}, co=co(reason="NONE")),
            "t:2: module co has a `reason` the first line does not have",
        ),
        (line(2, {"a": 2, "b": False}, co={**co(), "rule": "X"} | {"state": None}), ""),
        (line(2, {"a": 2, "b": False}), "t:2: modules differ from the first line's (co)"),
        (line(1, {"a": 2, "b": False}, co=co()), "t:2: cycle 1 after cycle 1"),
        (line(0, {"a": 2, "b": False}, co=co()), "t:2: cycle 0 after cycle 1"),
        ('{"cycle": 2, "modules": {"co": 1}}', "t:2: not a trace line (no `modules` object)"),
        ('{"cycle": "2", "modules": {}}', "t:2: not a trace line (no `cycle` number)"),
        ("[1, 2]", "t:2: not a trace line (no `cycle` number)"),
        # Change lines (traces.stored): checked as the full line they stand for.
        ('{"cycle": 2, "changed": {"world": {"c": 1}}}', "t:2: world fields differ"),
        ('{"cycle": 2, "removed": [["world", "a"]]}', "t:2: world fields differ"),
        (
            '{"cycle": 2, "removed": [["modules", "co", "zz"]]}',
            "t:2: not a trace line (`removed` names modules.co.zz, which is not there)",
        ),
        ('{"cycle": 2, "removed": [["modules", "co", "rule"]]}', "t:2: module co has no `rule`"),
        (
            '{"cycle": 2, "removed": [["modules", "co"]]}',
            "t:2: modules differ from the first line's (co)",
        ),
        (
            '{"cycle": 2, "changed": {"modules": {"zz": {}}}}',
            "t:2: modules differ from the first line's (zz)",
        ),
        ('{"cycle": 2, "removed": ["a"]}', 't:2: not a trace line (`removed` holds "a", not a'),
        ('{"cycle": 2, "changed": 5}', "t:2: not a trace line (`changed` is not an object"),
        ('{"cycle": 1, "changed": {}}', "t:2: cycle 1 after cycle 1"),
        (
            '{"cycle": 2, "changed": {"modules": {"co": {"reason": "NONE"}}}}',
            "t:2: module co has a `reason` the first line does not have",
        ),
        (
            '{"cycle": 2, "changed": {"modules": {"co": {"rule": "X", "state": null}},'
            ' "world": {"a": 2, "b": false}}}',
            "",
        ),
    ],
)
def test_a_line_that_disagrees_with_the_first_is_one_located_error(
    second: str, message: str
) -> None:
    text = GOOD + "\n" + second + "\n"
    if not message:  # a well-formed line: accepted, values kept as written
        trace = traces.parse(text, "t")
        assert trace.columns["co"]["rule"] == [None, "X"]
        assert trace.columns["co"]["state"] == ["NOP", None]
        assert trace.world == {"a": [1, 2], "b": [True, False]}
        return
    with pytest.raises(traces.TraceError) as caught:
        traces.parse(text, "t")
    assert str(caught.value).startswith(message)
    assert "\n" not in str(caught.value)


def test_the_first_line_fixes_the_optional_fields_of_each_module() -> None:
    first = line(1, None, co=co(reason="NONE", result={"n": 1}), cc=co())
    second = line(2, None, co=co(reason="REFUSED", status="ERROR", result={"n": 2}), cc=co())
    trace = traces.parse(first + "\n\n" + second, "t")  # blank lines are skipped
    assert trace.cycles == [1, 2] and trace.modules == ["cc", "co"]
    assert set(trace.columns["cc"]) == set(traces.FIELDS)
    assert trace.columns["co"]["result"] == [{"n": 1}, {"n": 2}]
    assert traces.status_text(trace.columns["co"], 1) == "ERROR(REFUSED)"
    assert traces.status_text(trace.columns["cc"], 1) == "DONE"
    assert trace.world == {}
    missing = line(2, None, co=co(result={"n": 2}), cc=co())
    with pytest.raises(traces.TraceError, match=r"^t:2: module co has no `reason`$"):
        traces.parse(first + "\n" + missing, "t")
    wrong = line(2, None, co=co(reason="NONE", result=[2]), cc=co())
    with pytest.raises(traces.TraceError, match=r"^t:2: module co's `result` is not an object$"):
        traces.parse(first + "\n" + wrong, "t")
    with pytest.raises(traces.TraceError, match=r"^t:3: not a trace line: Expecting value$"):
        traces.parse(first + "\n" + second + "\nx", "t")


def test_a_file_that_is_not_text_or_not_a_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "binary.jsonl").write_bytes(b"\xff\xfe\x00")
    with pytest.raises(traces.TraceError, match=r"binary.jsonl is not a trace: cannot read it as"):
        traces.load(tmp_path / "binary.jsonl")
    with pytest.raises(traces.TraceError, match=r"is not a file$"):
        traces.load(tmp_path)
    (tmp_path / "blank.jsonl").write_text("\n  \n", encoding="utf-8")
    with pytest.raises(traces.TraceError, match="blank.jsonl is empty: a trace has one JSON line"):
        traces.load(tmp_path / "blank.jsonl")


def test_a_trace_given_as_text_is_named_trace_in_its_errors() -> None:
    with pytest.raises(traces.TraceError, match=r"^<trace> is empty: a trace has one JSON line"):
        traces.parse("\n")
    with pytest.raises(traces.TraceError, match=r"^<trace>:1: not a trace line"):
        traces.parse("[]")
    with pytest.raises(traces.TraceError, match=r"^<trace>:2: not a trace line"):
        traces.parse_lines([GOOD, "[]"])  # lines given without a name, as parse gives them


@pytest.mark.parametrize(
    ("name", "page"),
    [
        ("run.jsonl", "run.html"),
        ("run.jsonl.gz", "run.html"),
        ("run.txt", "run.html"),
        ("run.txt.gz", "run.html"),
        ("a.b.jsonl", "a.b.html"),
    ],
)
def test_a_page_beside_a_trace_is_named_after_it(name: str, page: str) -> None:
    assert traces.beside(Path("d") / name, ".html") == Path("d") / page


def test_an_interrupted_run_names_its_signal_on_the_last_line_only() -> None:
    stop = json.dumps({"cycle": 2, "interrupted": "SIGINT"})
    assert traces.parse(GOOD + "\n" + stop, "t").interrupted == "SIGINT"
    with pytest.raises(traces.TraceError, match=r"^t holds no cycle: its run was interrupted"):
        traces.parse(stop, "t")
    with pytest.raises(traces.TraceError, match=r"^t:3: a line after the one that says"):
        traces.parse("\n".join([GOOD, stop, GOOD]), "t")
    for bad in (
        {"cycle": 2, "interrupted": 2},
        {"cycle": 2, "interrupted": "SIGINT", "modules": {}},
    ):
        with pytest.raises(
            traces.TraceError,
            match=r"^t:2: not a trace line \(an `interrupted` line has only it and `cycle`\)$",
        ):
            traces.parse(GOOD + "\n" + json.dumps(bad), "t")


def test_a_gzipped_trace_reads_as_its_text_within_a_limit() -> None:
    text = GOOD + "\n"
    packed = traces.compressed(text)
    assert packed[:2] == b"\x1f\x8b" and packed[4:8] == bytes(4)  # no time in the header
    assert traces.decompressed(packed, len(text)) == text.encode("utf-8")
    assert traces.decompressed(text.encode(), 1) == text.encode()  # plain text: as it is
    with pytest.raises(ValueError, match=rf"^it holds more than {len(text) - 1:,} bytes"):
        traces.decompressed(packed, len(text) - 1)
    with pytest.raises(ValueError, match=r"^a damaged gzip file \(it ends before its data"):
        traces.decompressed(packed[:-12], len(text))
    with pytest.raises(ValueError, match=r"^a damaged gzip file \(Error"):
        traces.decompressed(packed[:10] + b"\xff" * 20, len(text))
    accented = "é\n"
    assert traces.decompressed(traces.compressed(accented), 10) == accented.encode("utf-8")


def test_select_takes_lists_and_suggests_a_close_name() -> None:
    trace = traces.parse(line(1, None, co=co(), cc=co()), "t")
    assert traces.select(trace, []) == ["cc", "co"]
    assert traces.select(trace, ["co, cc", " ", "co"]) == ["co", "cc", "co"]
    with pytest.raises(
        traces.TraceError,
        match=r"^unknown module `coo`: t has no such module; did you mean `co`\?$",
    ):
        traces.select(trace, ["coo"])
    with pytest.raises(traces.TraceError) as caught:
        traces.select(trace, ["zzzz"])
    assert str(caught.value) == "unknown module `zzzz`: t has no such module"


# ---------------------------------------------------------------- rule coverage


@pytest.fixture(scope="module")
def miner():
    return compile_paths([REPO / "specs" / "miner"]).systems[0]


def test_coverage_adds_up_the_cycles_of_every_trace(miner, tmp_path: Path) -> None:
    """The whole sump_shear_cusp run and its first 70 cycles, as two traces: a rule's cycles
    are the cycles it fired in, summed over both; its traces are each trace it fired in,
    once."""
    whole = GOLDEN / "sump_shear_cusp.jsonl"
    lines = whole.read_text(encoding="utf-8").splitlines()
    part = tmp_path / "first70.jsonl"
    part.write_text("\n".join(lines[:70]) + "\n", encoding="utf-8")
    result = coverage.measure(miner, [traces.load(whole), traces.load(part)])
    rules = {(r.module, r.rule): r for r in result.rules}
    both = [str(whole), str(part)]
    # cd ON fires in cycles 5, 67 and 83; sj RAISE/S1 in 6 and 140; pp HALT in 64, 83, 160
    assert (rules[("cd", "ON/S0/1")].cycles, rules[("cd", "ON/S0/1")].traces) == (5, both)
    assert (rules[("sj", "RAISE/S1/1")].cycles, rules[("sj", "RAISE/S1/1")].traces) == (3, both)
    assert (rules[("pp", "HALT/S0/1")].cycles, rules[("pp", "HALT/S0/1")].traces) == (4, both)
    late = [r for r in result.rules if r.traces == [str(whole)]]
    assert late and all(r.cycles >= 1 for r in late)  # fired after cycle 70 only
    never = rules[("tc", "FAST_FORWARD/S0/1")]
    assert (never.cycles, never.traces) == (0, [])
    assert result.ran["co"] == both
    assert result.fired == sum(1 for r in result.rules if r.cycles)
    assert result.traces == both


def test_coverage_text_and_json_give_each_modules_counts(miner) -> None:
    whole = traces.load(GOLDEN / "sump_shear_cusp.jsonl")
    result = coverage.measure(miner, [whole])
    text = coverage.to_text(result)
    lines = text.splitlines()
    total = len(result.rules)
    assert lines[0] == (
        f"rule coverage of miner over 1 trace: {result.fired} of {total} table rules fired "
        f"({100 * result.fired / total:.1f}%)"
    )
    assert lines[1] == "" and lines[2] == "module   rules fired         ran in"
    cd = [r for r in result.rules if r.module == "cd"]
    fired = sum(1 for r in cd if r.cycles)
    shown = f"{100 * fired / len(cd):.1f}%"
    assert f"cd       {len(cd):>5} {fired:>5} {shown:>6}  1 trace" in lines
    assert text.endswith("\n") and lines[lines.index("never fired:") - 1] == ""
    sec = lines.index("  sec", lines.index("never fired:"))
    where = {(r.module, r.rule): r.where for r in result.rules}
    assert where[("sec", "INIT/S1/1")].endswith("sec.yaml:6")
    assert lines[sec + 1 : sec + 3] == [  # each with its spec line and guard, aligned
        f"    INIT/S1/1          {where[('sec', 'INIT/S1/1')]}  sb.status == DONE",
        f"    HALT/S0/1          {where[('sec', 'HALT/S0/1')]}  always",
    ]
    cr_sim = next(line for line in lines if line.startswith("cr_sim "))
    assert cr_sim.endswith("  no trace")  # the stand-in did not run
    assert "  cr_sim  (not run by any trace)" in lines
    text = coverage.to_json(result)
    data = json.loads(text)
    # stable for diffs: keys sorted, two-space indents, one trailing newline
    assert text == json.dumps(data, indent=2, sort_keys=True) + "\n"
    assert text.startswith('{\n  "fired": ')
    assert data["traces"] == [whole.name] and data["system"] == "miner"
    module = next(m for m in data["modules"] if m["module"] == "cd")
    assert module["ran_in"] == [whole.name]
    on = next(r for r in module["rules"] if r["rule"] == "ON/S0/1")
    assert (on["cycles"], on["traces"]) == (3, [whole.name])
    sec = next(m for m in data["modules"] if m["module"] == "sec")["rules"][0]
    assert (sec["rule"], sec["doc"], sec["guard"]) == (
        "INIT/S0/1",
        "send INIT to every subordinate",
        "always",
    )
    assert coverage._percent(0, 0) == "-"


# ---------------------------------------------------------------- lanes


def test_an_operator_modules_channels_are_lanes_of_the_operator_module() -> None:
    """The inspection workstation's operator `op` serves fx and tl: its trace rows `op/fx`
    and `op/tl` are lanes in op's place in the execution order, with op's title and level
    (below its deepest client), running op's tables."""
    inspection = compile_paths([REPO / "specs" / "inspection"]).systems[0]
    trace = traces.load(GOLDEN / "inspection" / "nominal_inspection.jsonl")
    assert traces.module_of("op/fx") == "op" and traces.module_of("ws") == "ws"
    lanes = traces.lanes(trace, inspection)
    assert [lane.module for lane in lanes] == [
        "shop", "jp", "wc", "ws", "ms", "fx", "tl", "cmm", "prim", "servo", "op/fx", "op/tl",
        "cmm_sim", "drives", "pdm",
    ]  # fmt: skip
    by_row = {lane.module: lane for lane in lanes}
    op = inspection.controller("op")
    # shop 1, workcell 2, workstation 3, measurement 4, tooling 5: op below its deepest client
    assert by_row["op/fx"] == traces.Lane("op/fx", op.title, 6, False, "op")
    assert by_row["ws"] == traces.Lane("ws", "Inspection workstation", 3, False, "ws")
    sim = by_row["cmm_sim"]
    assert (sim.level, sim.simulator, sim.title) == (0, True, "CMM (simulated)")
    assert traces.process_of(inspection, trace) is inspection.processes[0]


# ---------------------------------------------------------------- the changes timeline


def synthetic() -> traces.Trace:
    """Three cycles of a module with a reason and results, and a sensor and a flag."""
    rows = [
        line(1, {"flag": False, "level": 0.5, "n": 1}, co=co(reason="NONE", result={"k": 0})),
        line(
            2,
            {"flag": True, "level": 0.25, "n": 1},
            co=co(
                command="GO",
                command_num=2,
                status="ERROR",
                status_num=2,
                state="S1",
                rule="GO/S0/1",
                reason="REFUSED",
                result={"k": 0, "m": None},
            ),
        ),
        line(
            4,
            {"flag": True, "level": 0.25, "n": 2},
            co=co(
                command="GO",
                command_num=2,
                status="ERROR",
                status_num=2,
                state="S1",
                reason="REFUSED",
                result={"k": 3, "m": True},
            ),
        ),
    ]
    return traces.parse("\n".join(rows), "t")


def test_changes_show_reasons_results_and_world_values_as_written() -> None:
    from rcsgen.tools.traces import changes

    trace = synthetic()
    lanes = traces.lanes(trace, None)
    assert list(changes.timeline(trace, lanes, ["co"], world="all", merge=False)) == [
        "cycle 1",
        "  co     command INIT #1  status DONE #1  state NOP  result.k 0",
        "  world  flag false  level 0.5  n 1",
        "cycle 2",
        "  co     command INIT #1 -> GO #2  status DONE #1 -> ERROR(REFUSED) #2  state NOP -> S1"
        "  fired GO/S0/1",
        "  world  flag false -> true  level 0.5 -> 0.25",
        "cycle 4",
        "  co     result.k 0 -> 3  result.m null -> true",
        "  world  n 1 -> 2",
    ]
    discrete = list(changes.timeline(trace, lanes, ["co"], first=2, last=2))
    assert discrete == [
        "cycle 2",
        "  co     command INIT #1 -> GO #2  status DONE #1 -> ERROR(REFUSED) #2  state NOP -> S1"
        "  fired GO/S0/1",
        "  world  flag false -> true",
    ]
    assert changes.world_fields(trace, "discrete") == ["flag", "n"]
    assert list(changes.timeline(trace, lanes, [], world="none")) == []


def test_a_trace_the_specs_cannot_have_run_is_refused_with_the_reason(miner) -> None:
    stand_in = traces.parse(line(1, None, cr_sim=co()), "t")  # a stand-in runs as cr, never alone
    with pytest.raises(traces.TraceError) as caught:
        traces.check_against(miner, stand_in)
    assert str(caught.value) == "t: no process of system miner runs its modules"
    other = traces.parse(line(1, None, zz=co()), "t")
    with pytest.raises(traces.TraceError) as caught:
        traces.check_against(miner, other)
    assert str(caught.value) == (
        "t: module `zz` is not in system miner: was the trace recorded from other specs?"
    )
    pc2 = miner.processes[1]
    alone = traces.parse(line(1, None, **{m: co() for m in pc2.modules}), "t")
    assert traces.check_against(miner, alone) is pc2  # exactly one process's modules
    assert traces.recorded_by([miner], [alone, alone]) == (miner, "")
    assert traces.recorded_by([miner], [alone, other]) == (
        None,
        "t: module `zz` is not in system miner: was the trace recorded from other specs?",
    )
    assert traces.recorded_by([miner, miner], [other]) == (None, "")  # each refused: no one reason


def test_a_gzip_bomb_is_refused_without_inflating_it() -> None:
    import gzip
    import tracemalloc

    bomb = gzip.compress(bytes(20_000_000), mtime=0)  # 20 MB of zeros in about 20 kB
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"^it holds more than 1,000 bytes of text$"):
            traces.decompressed(bomb, 1000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000, f"{peak:,} bytes taken to refuse it"


def test_a_gzip_trace_is_read_member_by_member_and_what_is_not_gzip_after_it_is_damaged(
    tmp_path: Path,
) -> None:
    """A run appends a gzip member at a time; after the last one, anything that is not
    gzip (here a zlib stream, which a reader guessing the format would take) is damage."""
    second = line(2, {"a": 2, "b": False}, co=co()) + "\n"
    trace = tmp_path / "t.jsonl.gz"
    trace.write_bytes(traces.compressed(GOOD + "\n") + traces.compressed(second))
    assert traces.load(trace).cycles == [1, 2]
    trace.write_bytes(traces.compressed(GOOD + "\n") + zlib.compress(second.encode()))
    with pytest.raises(
        traces.TraceError,
        match=r"t\.jsonl\.gz is not a trace: a damaged gzip file \(.*incorrect header check\)$",
    ):
        traces.load(trace)


def test_a_line_holding_two_records_is_one_located_error() -> None:
    """Lines are decoded a batch at a time; a line of two JSON values (two records pasted
    onto one line) would make the batch one record longer: named at its line, not a crash."""
    two = line(2, {"a": 1, "b": True}, co=co())
    with pytest.raises(traces.TraceError, match=r"^t:2: not a trace line: Extra data"):
        traces.parse(GOOD + "\n" + two + ", " + two + "\n", "t")


TIMING_FIGURES = {
    "period_ms": 50.0,
    "wakeups": 3,
    "period_error_mean_us": 12.5,
    "period_error_max_us": 40.0,
    "lateness_p99_us": 30.0,
    "lateness_max_us": 31.5,
    "lateness_warnings": 0,
}


@pytest.mark.parametrize(
    "figures",
    [
        {},
        {"period_ms": 50.0},  # a figure the views show is missing
        TIMING_FIGURES | {"extra": 1},
        TIMING_FIGURES | {"wakeups": "3"},
        TIMING_FIGURES | {"lateness_warnings": True},
        TIMING_FIGURES | {"lateness_p99_us": float("nan")},  # json writes NaN, and reads it
        TIMING_FIGURES | {"period_ms": float("inf")},
    ],
)
def test_a_timing_record_holds_every_figure_as_a_finite_number(figures: dict[str, object]) -> None:
    """A paced run's timing record is read whole (its figures reach the trace view's title
    and its page's JSON, which a NaN would make unreadable): anything else is one located
    error naming the figures, never a KeyError or a page that does not load."""
    timing = json.dumps({"cycle": 1, "periodicity": TIMING_FIGURES})
    assert traces.parse(GOOD + "\n" + timing, "t").periodicity == TIMING_FIGURES
    with pytest.raises(traces.TraceError) as caught:
        traces.parse(GOOD + "\n" + json.dumps({"cycle": 1, "periodicity": figures}), "t")
    assert str(caught.value) == (
        "t:2: not a trace line (a `periodicity` record's figures are lateness_max_us, "
        "lateness_p99_us, lateness_warnings, period_error_max_us, period_error_mean_us, "
        "period_ms, wakeups, each a finite number)"
    )


def test_a_cause_is_kept_on_the_lines_that_have_one_and_empty_on_the_others() -> None:
    """`cause` is written only where a module with reasons is in ERROR passed up from a
    subordinate: its column is that text there and '' on every other line."""
    failed = co(status="ERROR", reason="LOST", cause="sub: TIMED_OUT")
    lines = [
        line(1, {}, co=co(reason="NONE")),
        line(2, {}, co=failed),
        line(3, {}, co=co(reason="NONE")),
    ]
    trace = traces.parse("\n".join(lines), "t")
    assert trace.columns["co"]["cause"] == ["", "sub: TIMED_OUT", ""]
    assert trace.columns["co"]["reason"] == ["NONE", "LOST", "NONE"]


def test_a_change_line_may_remove_what_the_reader_does_not_read() -> None:
    """`removed` paths outside `modules` and `world` (the `overrides` a run latched and
    released) are the writer's business: the line is read, its modules as before."""
    for path in (["overrides"], ["overrides", "a"]):
        text = GOOD + "\n" + json.dumps({"cycle": 2, "removed": [path]})
        trace = traces.parse(text, "t")
        assert trace.cycles == [1, 2] and trace.columns["co"]["state"] == ["NOP", "NOP"]


def test_a_change_line_that_removes_one_modules_field_is_checked_whole() -> None:
    """A change line that changes one module and removes another's field: the modules are
    checked whole, not only the one changed (the removal is what broke the other)."""
    first = line(1, None, co=co(), cc=co())
    second = '{"cycle": 2, "changed": {"modules": {"cc": {"status": "EXECUTING"}}}, '
    second += '"removed": [["modules", "co", "rule"]]}'
    with pytest.raises(traces.TraceError) as caught:
        traces.parse(first + "\n" + second + "\n", "t")
    assert str(caught.value) == "t:2: module co has no `rule`"
