"""A build into a directory it may not write in is refused before anything is written: E306
at the directory, whoever runs it. The suite may run as root, for whom every directory is
writable, so the operating system's answer is stood in for (os.access says no write
permission for that one directory); what is checked is that the build asks for write and
search permission where it must change files, and says so in one located line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rcsgen.compiler.back_end import write
from rcsgen.compiler.frontend import compile_paths

CELL = Path(__file__).resolve().parent.parent / "specs" / "cell"


def test_a_directory_without_write_permission_is_e306_before_anything_is_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    front = compile_paths([CELL])
    assert not front.diagnostics.errors
    out = tmp_path / "out"
    out.mkdir()
    real = os.access

    def access(path: str | os.PathLike[str], mode: int) -> bool:
        if Path(path) == out and mode & (os.W_OK | os.X_OK):  # read-only, no search
            return False
        return real(path, mode)

    monkeypatch.setattr(write.os, "access", access)
    _, problems = write.plan_build(front.systems, out)
    said = [d.render() for d in problems]
    assert said == [
        f"{out}:1:1: error[E306]: cannot write in `{out}`: permission denied (read-only?)\n"
        "  = hint: make it writable, or build into another directory with -o"
    ], said
    assert list(out.iterdir()) == []
    monkeypatch.setattr(write.os, "access", real)
    _, problems = write.plan_build(front.systems, out)
    assert list(problems) == []
