"""A trace whose run was killed while it wrote the last line (`rcsgen run` writes its trace
as it goes; a line longer than the file's buffer goes out in more than one write, and a
SIGKILL can fall between them): the trace tools read every whole cycle before it and say
the last line was cut; a damaged line anywhere else is still an error naming it."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from rcsgen.cli import main
from rcsgen.tools import traces
from rcsgen.tools.scenario.run import LiveTrace, write_trace

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden" / "cell" / "plan_ahead.jsonl"


@pytest.fixture
def whole(tmp_path: Path) -> Path:
    path = tmp_path / "run.jsonl"
    shutil.copyfile(GOLDEN, path)
    return path


def cut_in_last_line(path: Path, keep: float) -> None:
    """Cut the file inside its last line, `keep` of the way through it."""
    data = path.read_bytes()
    start = data.rstrip(b"\n").rfind(b"\n") + 1
    path.write_bytes(data[: start + max(1, int((len(data) - 1 - start) * keep))])


@pytest.mark.parametrize("keep", [0.02, 0.5, 0.98])
def test_a_last_line_written_in_part_is_left_out_and_said(whole: Path, keep: float) -> None:
    full = traces.load(whole)
    cut_in_last_line(whole, keep)
    loaded = traces.load(whole)
    assert loaded.interrupted == traces.CUT
    assert loaded.cycles == full.cycles[:-1]
    for module, columns in loaded.columns.items():
        for name, values in columns.items():
            assert values == full.columns[module][name][:-1], (module, name)
    expanded = traces.full_lines(whole)
    assert [json.loads(line)["cycle"] for line in expanded] == full.cycles[:-1]


def test_the_trace_commands_read_it_and_tell_the_user(whole: Path, tmp_path: Path) -> None:
    cut_in_last_line(whole, 0.5)
    out = tmp_path / "page.html"
    result = CliRunner().invoke(main, ["trace", "show", str(whole), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "last line was written only in part" in result.output
    cycles = len(traces.load(whole))
    assert f"its {cycles:,} whole cycles are read" in result.output
    assert out.is_file() and f"{cycles:,} cycles" in out.read_text(encoding="utf-8")


def test_a_whole_last_line_without_a_newline_is_a_cycle(whole: Path) -> None:
    full = traces.load(whole)
    whole.write_bytes(whole.read_bytes().rstrip(b"\n"))
    loaded = traces.load(whole)
    assert loaded.interrupted is None and loaded.cycles == full.cycles


def test_a_damaged_line_before_the_last_is_still_an_error(whole: Path) -> None:
    lines = whole.read_text(encoding="utf-8").splitlines(keepends=True)
    lines[3] = lines[3][: len(lines[3]) // 2] + "\n"
    whole.write_text("".join(lines), encoding="utf-8")
    with pytest.raises(traces.TraceError, match=r"run\.jsonl:4: not a trace line"):
        traces.load(whole)


def test_a_gzip_trace_written_as_the_run_goes_reads_wherever_it_stops(tmp_path: Path) -> None:
    """A `.jsonl.gz` trace is written as the run goes (a gzip stream flushed at each cycle):
    cut anywhere, as a kill would leave it, it reads as the cycles whose lines are whole;
    ended (the write at the end), it is the ordinary gzip file, every cycle."""
    lines = traces.full_lines(GOLDEN)
    path = tmp_path / "run.jsonl.gz"
    live = LiveTrace(path)
    sizes = []
    for line in lines:
        live.append(line)
        assert live.out is not None
        sizes.append(live.out.tell())  # (the file as it is after each cycle's flush)
    live.close()
    data = path.read_bytes()
    cycles = [json.loads(line)["cycle"] for line in lines]
    for n, size in enumerate(sizes, start=1):  # stopped right after a cycle's flush
        path.write_bytes(data[:size])
        assert traces.load(path).cycles == cycles[:n]
        assert traces.load(path).interrupted is None
    for size in ((sizes[4] + sizes[5]) // 2, (sizes[-2] + sizes[-1]) // 2):  # inside a line
        path.write_bytes(data[:size])
        loaded = traces.load(path)
        assert loaded.cycles == cycles[: len(loaded)] and len(loaded) < len(cycles)
    path.write_bytes(data[: sizes[0] // 2])  # inside the first line
    with pytest.raises(traces.TraceError, match="holds no cycle: its run was interrupted"):
        traces.load(path)
    path.write_bytes(data[:10])  # (the header alone: nothing written yet)
    with pytest.raises(traces.TraceError, match="is empty"):
        traces.load(path)
    write_trace(path, live)
    assert traces.read.decompressed(path.read_bytes(), 1 << 30).decode().count("\n") == len(lines)
    assert traces.load(path).cycles == cycles
