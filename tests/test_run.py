"""`rcsgen run`: a scenario through the command line, end to end.

Each test runs the committed generated miner from a scratch working directory and checks
what a user sees: the exit code (0 only when the stop module finished DONE), the trace
file (byte for byte the golden one), the `--record` file, and the summary on stdout.
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from pathlib import Path

import pytest
import yaml
from conftest import REPO, rcsgen

from rcsgen.tools import traces
from rcsgen.tools.scenario import read_trace

MINER = REPO / "specs" / "miner"
SCENARIOS = MINER / "scenarios"
GENERATED = REPO / "generated"
GOLDEN = REPO / "tests" / "golden"


@pytest.fixture
def cwd(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    return tmp_path


def files_under(root: Path) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())


def phases(trace: list[str], module: str) -> Counter[str]:
    """Cycles per command of `module`, counted from a trace ("idle" when not EXECUTING)."""
    counts: Counter[str] = Counter()
    for line in trace:
        state = json.loads(line)["modules"][module]
        counts[state["command"] if state["status"] == "EXECUTING" else "idle"] += 1
    return counts


def test_a_run_ending_in_the_expected_error_writes_trace_and_record_and_exits_0(
    cwd: Path,
) -> None:
    """stalled_tread: sec reports ERROR, as its `expect:` says. Exit 0; the trace (default
    path) and the --record file are the golden trace byte for byte; the summary names the
    result, cycles and phases. (An outcome that is not the expected one exits 1: E416 in
    the corpus.)"""
    scenario = SCENARIOS / "stalled_tread.yaml"
    result = rcsgen("run", scenario, "--generated", GENERATED, "--record", "rec/golden.jsonl")
    assert result.exit_code == 0, result.output
    golden = (GOLDEN / "stalled_tread.jsonl").read_bytes()
    assert files_under(cwd) == ["rec/golden.jsonl", "traces/stalled_tread.jsonl"]
    assert (cwd / "traces" / "stalled_tread.jsonl").read_bytes() == golden
    assert (cwd / "rec" / "golden.jsonl").read_bytes() == golden
    cycles = golden.count(b"\n")
    title = yaml.safe_load(scenario.read_text(encoding="utf-8"))["title"]
    lines = result.stdout.splitlines()
    assert lines[:4] == [
        f"scenario  stalled_tread: {title}",
        "result    sec ERROR (state NOP)",
        f"cycles    {cycles}",
        "phases    cycles per co command:",
    ]
    shown = {}
    for line in lines[4:]:
        if not line.startswith("            "):
            break
        phase, count = line.split()
        shown[phase] = int(count)
    assert shown == phases(read_trace(GOLDEN / "stalled_tread.jsonl"), "co")
    assert sum(shown.values()) == cycles
    last = json.loads(read_trace(GOLDEN / "stalled_tread.jsonl")[-1])["world"]
    assert f"depth cut {last['depth_cut']:.3f}" in lines
    assert f"left tread cmd {last['left_tread_cmd']}" in lines
    assert "max cycle time per module (us):" in lines
    assert lines[-2:] == [
        f"trace     traces/stalled_tread.jsonl ({cycles} lines)",
        "recorded  rec/golden.jsonl: review `git diff rec/golden.jsonl` before committing",
    ]


def test_a_run_ending_done_exits_0_and_writes_only_its_trace(cwd: Path) -> None:
    """sump_shear_cusp: sec reports DONE. Exit 0; `--trace` names the file; no record."""
    result = rcsgen(
        "run", SCENARIOS / "sump_shear_cusp.yaml", "--generated", GENERATED, "--trace", "t.jsonl"
    )
    assert result.exit_code == 0, result.output
    golden = (GOLDEN / "sump_shear_cusp.jsonl").read_bytes()
    assert files_under(cwd) == ["t.jsonl"]
    assert (cwd / "t.jsonl").read_bytes() == golden
    cycles = len(golden.splitlines())
    lines = result.stdout.splitlines()
    assert "result    sec DONE (state NOP)" in lines
    assert lines[-1] == f"trace     t.jsonl ({cycles} lines)"
    assert not any(line.startswith("recorded") for line in lines)


def test_a_run_cut_short_before_the_stop_module_finishes_exits_1(cwd: Path) -> None:
    """max_cycles reached while sec is still EXECUTING: not a success either."""
    specs = cwd / "specs" / "miner"
    shutil.copytree(MINER, specs, ignore=shutil.ignore_patterns("__pycache__"))
    scenario = specs / "scenarios" / "sump_shear_cusp.yaml"
    text = scenario.read_text(encoding="utf-8")
    assert "max_cycles: 400\n" in text
    scenario.write_text(text.replace("max_cycles: 400\n", "max_cycles: 20\n"), encoding="utf-8")
    result = rcsgen("run", scenario, "--generated", GENERATED, "--trace", "t.jsonl")
    assert result.exit_code == 1, result.output
    assert "result    sec EXECUTING (state S1)" in result.stdout.splitlines()
    golden = (GOLDEN / "sump_shear_cusp.jsonl").read_bytes().splitlines(keepends=True)
    assert (cwd / "t.jsonl").read_bytes() == b"".join(golden[:20])


def test_run_without_a_generated_package_exits_1_and_writes_nothing(cwd: Path) -> None:
    result = rcsgen("run", SCENARIOS / "box_cut.yaml", "--generated", cwd / "nowhere")
    assert result.exit_code == 1
    assert "error[E418]: `nowhere/miner` is stale" in result.stderr
    assert files_under(cwd) == []


def test_run_of_a_bad_scenario_reports_it_and_writes_nothing(cwd: Path) -> None:
    specs = cwd / "specs" / "miner"
    shutil.copytree(MINER, specs, ignore=shutil.ignore_patterns("__pycache__"))
    scenario = specs / "scenarios" / "box_cut.yaml"
    scenario.write_text(scenario.read_text(encoding="utf-8") + "stop_when: sb\n", encoding="utf-8")
    before = files_under(cwd)
    result = rcsgen("run", scenario, "--generated", GENERATED)
    assert result.exit_code == 1
    assert "error[S002]: unknown key `stop_when`" in result.stderr
    assert files_under(cwd) == before


def test_a_trace_named_gz_is_written_gzipped_and_read_everywhere(cwd: Path) -> None:
    """`--trace X.jsonl.gz` writes the trace gzip-compressed (reproducibly: no time in its
    header); the trace tools and the golden comparison read it as they read plain JSON
    Lines, known by its first bytes."""
    import gzip

    from rcsgen.tools import traces

    scenario = SCENARIOS / "sump_shear_cusp.yaml"
    result = rcsgen("run", scenario, "--generated", GENERATED, "--trace", "t.jsonl.gz")
    assert result.exit_code == 0, result.output
    golden = (GOLDEN / "sump_shear_cusp.jsonl").read_bytes()
    packed = (cwd / "t.jsonl.gz").read_bytes()
    assert gzip.decompress(packed) == golden and len(packed) * 4 < len(golden)  # (stored form)
    again = rcsgen("run", scenario, "--generated", GENERATED, "--trace", "u.jsonl.gz")
    assert again.exit_code == 0 and (cwd / "u.jsonl.gz").read_bytes() == packed
    plain, packed_trace = (
        traces.load(GOLDEN / "sump_shear_cusp.jsonl"),
        traces.load(cwd / "t.jsonl.gz"),
    )
    assert (packed_trace.cycles, packed_trace.columns, packed_trace.world) == (
        plain.cycles,
        plain.columns,
        plain.world,
    )
    compared = rcsgen("run", scenario, "--generated", GENERATED, "--golden", "t.jsonl.gz")
    assert compared.exit_code == 0, compared.output
    assert "golden    t.jsonl.gz: identical, cycle for cycle" in compared.stdout
    shown = rcsgen("trace", "show", "t.jsonl.gz", "--specs", MINER.parent)  # writes t.html
    assert shown.exit_code == 0, shown.output
    page = (cwd / "t.html").read_text(encoding="utf-8")
    assert "t.jsonl.gz" in page and f'"n":{len(plain)}' in page


def test_a_damaged_gzip_trace_is_one_line_not_a_traceback(cwd: Path) -> None:
    """A `.jsonl.gz` corrupted: one line from the trace tools (exit 1) and from the
    golden comparison (E419), never a traceback. Cut short (a run killed while writing
    it), the trace tools read its whole cycles and say the last line was cut; as a golden
    it is refused (a golden must be whole)."""
    import gzip

    data = gzip.compress((GOLDEN / "pop_out.jsonl").read_bytes(), mtime=0)
    (cwd / "cut.jsonl.gz").write_bytes(data[: len(data) // 2])
    (cwd / "bad.jsonl.gz").write_bytes(data[:20] + b"\0" * 64 + data[84:])
    for name in ("cut.jsonl.gz", "bad.jsonl.gz"):
        shown = rcsgen("trace", "changes", name)
        if name == "cut.jsonl.gz":
            assert shown.exit_code == 0, shown.output
            assert f"note: {name}'s last line was written only in part" in shown.stderr
            whole = len(read_trace(GOLDEN / "pop_out.jsonl"))
            assert 0 < len(traces.load(cwd / name)) < whole
        else:
            assert shown.exit_code == 1, shown.output
            assert f"{name} is not a trace: a damaged gzip file" in shown.stderr
            assert len(shown.stderr.strip().splitlines()) == 1
        scenario = SCENARIOS / "pop_out.yaml"
        compared = rcsgen("run", scenario, "--generated", GENERATED, "--golden", name)
        assert compared.exit_code == 1, compared.output
        assert "error[E419]: cannot read golden trace: not a trace: a damaged gzip" in (
            compared.stderr
        )
