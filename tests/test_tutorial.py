"""docs/tutorial.md, followed as a new user would: every file it shows is written where it
says (`<!-- file: PATH -->` before a block), every command of its `sh` blocks is run in
order in an empty directory, with the exit code it states (`# exit 1`, else 0), and what
the prose claims of the outputs is checked. A tutorial that drifts from rcsgen fails here.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import rcsgen

TUTORIAL = Path(__file__).resolve().parent.parent / "docs" / "tutorial.md"
BLOCK = re.compile(r"(?:<!-- (file|delete): (\S+) -->\n)?```(\w+)\n(.*?)```", re.S)
DELETE = re.compile(r"<!-- delete: (\S+) -->")


def steps(text: str) -> list[tuple[str, str, str]]:
    """(kind, argument, body) in document order: ("file", path, text), ("delete", path, ""),
    ("sh", "", commands)."""
    found: list[tuple[int, tuple[str, str, str]]] = []
    for match in DELETE.finditer(text):
        found.append((match.start(), ("delete", match.group(1), "")))
    for match in BLOCK.finditer(text):
        marker, path, language, body = match.groups()
        if marker == "file":
            found.append((match.start(), ("file", path, body)))
        elif language == "sh":
            found.append((match.start(), ("sh", "", body)))
    return [step for _, step in sorted(found)]


def run(line: str, cwd: Path) -> tuple[int, str]:
    command, _, comment = line.partition("#")
    expected = re.search(r"exit (\d+)", comment)
    words = shlex.split(command)
    if words[0] == "rcsgen":
        result = rcsgen(*words[1:])
        code, output = result.exit_code, result.output
    else:
        assert words[:3] == ["python", "-m", "pytest"], f"the tutorial runs {line!r}"
        done = subprocess.run(
            [sys.executable, *words[1:]],
            cwd=cwd,
            capture_output=True,
            text=True,
            timeout=300,
        )
        code, output = done.returncode, done.stdout + done.stderr
    want = int(expected.group(1)) if expected else 0
    assert code == want, f"`{line}` exited {code}, the tutorial says {want}:\n{output}"
    return code, output


def test_the_tutorial_runs_as_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    outputs: list[tuple[str, str]] = []
    for kind, argument, body in steps(TUTORIAL.read_text(encoding="utf-8")):
        if kind == "file":
            path = tmp_path / argument
            assert path.parent.is_dir(), f"the tutorial writes {argument} before its directory"
            path.write_text(body, encoding="utf-8")
        elif kind == "delete":
            (tmp_path / argument).unlink()
        else:
            for line in body.splitlines():
                if line.strip():
                    outputs.append((line, run(line, tmp_path)[1]))
    said = "\n".join(output for _, output in outputs)
    # what the prose says of the outputs
    assert "water.yaml:1:1: error[S001]: missing required key `commands`" in said
    draft = next(out for line, out in outputs if "exit 1" in line and "[E501]" in out)
    assert "rules 1 and 2 of BOIL S1 can both fire" in draft
    assert "world.water_temp=100.0" in draft and "ht.status=ERROR" in draft
    assert "warning[W503]: BOIL S1 waits when world.water_temp=99.0, ht.status=DONE" in draft
    stale = next(out for line, out in outputs if "exit 1" in line and "[E406]" in out)
    assert "`kt` has no command `RUN`" in stale and "[E501]" not in stale
    boiled = next(out for line, out in outputs if line.endswith("boil.yaml"))
    assert "kt DONE" in boiled and re.search(r"cycles\s+34\n", boiled), boiled
    assert re.search(r"water temp\s+100\.000", boiled) and re.search(r"heater on\s+False", boiled)
    assert "2 passed" in outputs[-1][1]
    assert (tmp_path / "generated" / "kettle" / "kt.py").is_file()
    assert (tmp_path / "tests" / "golden" / "boil.jsonl").is_file()
