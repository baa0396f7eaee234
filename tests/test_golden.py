"""Golden traces: the committed generated system runs each scenario exactly as recorded.

The trace is written as `rcsgen run` writes it and compared with the golden file byte for
byte, so the trace format (key order, separators, final newline) is pinned as well as the
values. A mismatch names the first differing cycle and field (or, when the values agree, the
first differing line and column) and the command that re-records the golden file;
re-record only after reading the diff, and say why in the commit message.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import (
    first_difference,
    load_scenario,
    open_harness,
    read_trace,
    run,
    write_trace,
)

ROOT = Path(__file__).resolve().parent.parent
MINER = ROOT / "specs" / "miner"
GOLDEN = ROOT / "tests" / "golden"
# Every system's scenarios, each with its golden trace: the miner's in tests/golden/, another
# system's in tests/golden/<system>/ (so that tests/golden/*.jsonl stays the miner's). A
# scenario against soft PLCs (`devices:`) runs paced on a real protocol stack: its trace is
# not deterministic, so it has none (tests/test_io_scenario.py runs it).
SCENARIOS = sorted(
    p
    for p in (ROOT / "specs").glob("*/scenarios/*.yaml")
    if "\ndevices:" not in p.read_text(encoding="utf-8")
)


def golden_of(path: Path) -> Path:
    """The golden trace of the scenario at `path`."""
    system = path.parent.parent.name
    return GOLDEN / ("" if system == "miner" else system) / f"{path.stem}.jsonl"


def run_scenario(path: Path, package: Path | None = None, processes: bool = False):
    """Run a scenario on `package`, by default the committed package of its system."""
    package = package or ROOT / "generated" / path.parent.parent.name
    scenario = load_scenario(path)
    harness = open_harness(scenario, package, processes)
    try:
        return run(scenario, harness)
    finally:
        harness.close()


def first_byte_difference(expected: bytes, actual: bytes) -> str | None:
    """Where two trace files first differ as bytes: line, column and both lines."""
    if expected == actual:
        return None
    want, got = expected.splitlines(keepends=True), actual.splitlines(keepends=True)
    for number, (a, b) in enumerate(zip(want, got, strict=False), start=1):
        if a != b:
            col = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y), None)
            col = min(len(a), len(b)) if col is None else col
            start = max(col - 30, 0)
            return (
                f"line {number}, column {col + 1}: expected {a[start : col + 30]!r}, "
                f"got {b[start : col + 30]!r}"
            )
    return f"expected {len(want)} lines, got {len(got)}"


@pytest.mark.parametrize("processes", [False, True], ids=["one-process", "processes"])
@pytest.mark.parametrize(
    "path", SCENARIOS, ids=lambda p: golden_of(p).relative_to(GOLDEN).with_suffix("").as_posix()
)
def test_scenario_matches_its_golden_trace(path, processes, tmp_path):
    """In one process, and as the spec's processes (the miner's are two OS processes in
    lockstep: the path planner on its own, Figure 7), every scenario leaves its golden
    trace, byte for byte."""
    golden = golden_of(path)
    result = run_scenario(path, processes=processes)
    written = tmp_path / golden.name
    write_trace(written, result.trace)  # as `rcsgen run` writes it
    expected, actual = golden.read_bytes(), written.read_bytes()
    if actual == expected:
        return
    mismatch = first_difference(read_trace(golden), result.trace)
    where = mismatch or f"same values, other bytes: {first_byte_difference(expected, actual)}"
    rel = path.relative_to(ROOT)
    pytest.fail(
        f"{path.stem}: {where}\nif the change is intended, re-record with\n"
        f"  rcsgen run {rel} --record {golden.relative_to(ROOT)}\nand review the diff"
    )


def test_every_scenario_has_a_golden_trace():
    assert SCENARIOS, "no scenarios found"
    systems = {p.parent.name for p in (ROOT / "specs").glob("*/system.yaml")}
    assert {"miner", "submarine", "inspection"} <= systems
    # A system on fieldbus I/O runs against its equipment, not in a scenario's flat-out
    # cycles: its scenarios serve soft PLCs (tests/test_io.py, test_io_scenario.py).
    on_io = {s for s in systems if "\nio:" in (ROOT / "specs" / s / "system.yaml").read_text()}
    assert on_io == {"miner_hil"}
    systems -= on_io
    assert {p.parent.parent.name for p in SCENARIOS} == systems, "every system has scenarios"
    assert sorted(GOLDEN.glob("**/*.jsonl")) == sorted(golden_of(p) for p in SCENARIOS)


def test_first_difference_names_cycle_and_field():
    a = [
        '{"cycle":1,"modules":{"co":{"state":"S1"}}}',
        '{"cycle":2,"modules":{"co":{"state":"S2"}}}',
    ]
    b = [a[0], '{"cycle":2,"modules":{"co":{"state":"S3"}}}']
    mismatch = first_difference(a, b)
    assert (mismatch.cycle, mismatch.field, mismatch.expected, mismatch.actual) == (
        2,
        "modules.co.state",
        "S2",
        "S3",
    )
    assert str(mismatch) == "cycle 2: `modules.co.state` expected 'S2', got 'S3'"
    assert first_difference(a, a) is None
    assert first_difference(a, a[:1]).field == "length"


def test_first_byte_difference_names_line_and_column():
    a = b'{"a":1,"b":2}\n{"a":3,"b":4}\n'
    assert first_byte_difference(a, a) is None
    assert first_byte_difference(a, a.replace(b'"a":3,"b"', b'"a": 3, "b"')) == (
        'line 2, column 6: expected b\'{"a":3,"b":4}\\n\', got b\'{"a": 3, "b":4}\\n\''
    )
    assert (
        first_byte_difference(a, a[:-1])
        == 'line 2, column 14: expected b\'{"a":3,"b":4}\\n\', got b\'{"a":3,"b":4}\''
    )
    assert first_byte_difference(a, a + a) == "expected 2 lines, got 4"


def test_editing_a_guard_is_caught_with_the_first_differing_cycle(tmp_path):
    """A one-guard change in co.yaml shows up as a golden mismatch at a named cycle and field."""
    import shutil

    specs = tmp_path / "miner"
    shutil.copytree(MINER, specs)
    co = specs / "co.yaml"
    text = co.read_text(encoding="utf-8")
    old = "when: too_much_loose_coal()\n"
    assert old in text
    co.write_text(
        text.replace(old, "when: too_much_loose_coal() and world.loose_coal > 9.0\n"),
        encoding="utf-8",
    )
    with Harness.build(specs) as built:
        result = run_scenario(
            specs / "scenarios" / "late_tail.yaml", Path(built.package.__path__[0])
        )
    mismatch = first_difference(read_trace(GOLDEN / "late_tail.jsonl"), result.trace)
    assert mismatch is not None
    # 4.01 t of loose coal on the gauge no longer pauses the shear at cycle 111: the HALT
    # that reached the boom (first field in sorted order) is not sent, the boom keeps lowering.
    assert (mismatch.cycle, mismatch.field) == (111, "modules.bm.command")
    assert (mismatch.expected, mismatch.actual) == ("HALT", "LOWER")
