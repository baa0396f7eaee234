"""`rcsgen new` (rcsgen/tools/scaffold.py): scaffolds that validate cleanly, edits that keep
every other byte of the files they touch, and refusals that leave everything as it was."""

from __future__ import annotations

import difflib
import shutil
from pathlib import Path

import pytest
from conftest import rcsgen, snapshot

REPO = Path(__file__).resolve().parent.parent


def added_lines(before: str, after: str) -> list[str]:
    """What an edit added, and nothing may have been removed."""
    diff = list(difflib.ndiff(before.splitlines(), after.splitlines()))
    assert not [d for d in diff if d.startswith("- ")], "\n".join(diff)
    return [d[2:] for d in diff if d.startswith("+ ")]


def test_a_new_system_validates_builds_and_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    made = rcsgen("new", "system", "lamp", "--root", "lp", "--period", "0.05")
    assert made.exit_code == 0, made.output
    assert made.output.splitlines()[:3] == [
        "created lamp/system.yaml",
        "created lamp/lp.yaml",
        "created lamp/scenarios/first_command.yaml",
    ]
    assert rcsgen("validate", "specs", "--strict").exit_code == 0
    system = (tmp_path / "specs/lamp/system.yaml").read_text()
    assert "cycle_period: 0.05" in system
    assert "\ntitle: Lamp\n" in system  # no --title: the name's
    assert rcsgen("build", "specs").exit_code == 0
    ran = rcsgen("run", "specs/lamp/scenarios/first_command.yaml")
    assert ran.exit_code == 0, ran.output
    assert "lp DONE" in ran.output


def test_the_scaffolds_defaults_are_the_commands(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`scaffold.new_system` called with a name alone writes what `rcsgen new system NAME`
    writes (root `top`, 0.1 s, the name as title), byte for byte."""
    from rcsgen.tools.scaffold import new_system

    monkeypatch.chdir(tmp_path)
    assert rcsgen("new", "system", "lamp").exit_code == 0
    new_system(tmp_path / "api", "lamp")
    made = sorted(p.relative_to(tmp_path / "specs") for p in (tmp_path / "specs").rglob("*.*"))
    assert made == sorted(p.relative_to(tmp_path / "api") for p in (tmp_path / "api").rglob("*.*"))
    assert made == [
        Path("lamp/scenarios/first_command.yaml"),
        Path("lamp/system.yaml"),
        Path("lamp/top.yaml"),
    ]
    for rel in made:
        assert (tmp_path / "api" / rel).read_bytes() == (tmp_path / "specs" / rel).read_bytes()
    assert "\ncycle_period: 0.1  #" in (tmp_path / "api/lamp/system.yaml").read_text()


def test_a_controller_joins_its_supervisor_and_runs_after_its_subtree(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """In the miner (a flow list over several lines), a new subordinate of cc is put after
    sj, the last of cc's subtree in pc1; system.yaml and cc.yaml gain one item each and
    lose nothing (comments included); the result passes --strict."""
    shutil.copytree(REPO / "specs" / "miner", tmp_path / "specs" / "miner")
    monkeypatch.chdir(tmp_path)
    system, cc = Path("specs/miner/system.yaml"), Path("specs/miner/cc.yaml")
    before = {p: p.read_text() for p in (system, cc)}
    made = rcsgen("new", "controller", "specs/miner", "wl", "--supervisor", "cc")
    assert made.exit_code == 0, made.output
    assert made.output.splitlines() == [
        "created wl.yaml",
        "edited  cc.yaml",
        "edited  system.yaml",
    ]
    after = system.read_text()
    assert "[sec, sb, co, cc, bm, cd, sj, wl, cr, gh," in after
    assert after.replace(" wl,", "", 1) == before[system]  # one item more, nothing else
    subordinates = next(line for line in cc.read_text().splitlines() if "subordinates" in line)
    assert subordinates.endswith(", wl]")
    assert cc.read_text().replace(", wl]", "]", 1) == before[cc]
    assert rcsgen("validate", "specs/miner", "--strict").exit_code == 0


def test_block_lists_and_a_new_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert rcsgen("new", "system", "duo").exit_code == 0
    path = Path("specs/duo/system.yaml")
    text = path.read_text().replace("modules: [top]", "modules:\n      - top  # the root")
    path.write_text(text)
    assert rcsgen("new", "controller", "specs/duo", "arm", "--supervisor", "top").exit_code == 0
    assert rcsgen("new", "controller", "specs/duo", "log").exit_code == 0  # a second root
    assert added_lines(text, path.read_text()) == ["      - arm", "      - log"]
    top = Path("specs/duo/top.yaml").read_text().splitlines()
    assert top[top.index("title: TOP controller") + 1] == "subordinates: [arm]"
    assert rcsgen("validate", "specs", "--strict").exit_code == 0


@pytest.mark.parametrize(
    ("args", "code", "message"),
    [
        (
            ["system", "Lamp"],
            2,
            "system name 'Lamp' is not a lower-case name (letters, digits, _; a letter first)",
        ),
        (
            ["system", "lamp", "--root", "1st"],
            2,
            "controller mnemonic '1st' is not a lower-case name (letters, digits, _; a letter "
            "first)",
        ),
        (
            ["controller", "specs/demo", "Arm"],
            2,
            "controller mnemonic 'Arm' is not a lower-case name (letters, digits, _; a letter "
            "first)",
        ),
        (
            ["system", "lamp", "--period", "0"],
            2,
            "'0' is not a number more than 0 and at most 3600",
        ),
        (["system", "demo"], 1, "specs/demo exists; rcsgen new writes only new files"),
        (["controller", "specs/demo", "top"], 1, "specs/demo/top.yaml exists"),
        (["controller", "specs/demo", "arm", "--supervisor", "tpo"], 1, "(did you mean `top`?)"),
        (["controller", "specs/demo", "arm", "--process", "mian"], 1, "no process 'mian'"),
        (["controller", "specs/nowhere", "arm"], 1, "no system.yaml in specs/nowhere"),
        (["controller", "specs/demo", "layout"], 1, "the result would not validate cleanly"),
    ],
)
def test_refusals_are_one_line_and_change_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], code: int, message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    assert rcsgen("new", "system", "demo").exit_code == 0
    before = snapshot(tmp_path)
    result = rcsgen("new", *args)
    assert result.exit_code == code, result.output
    assert message in result.output
    assert snapshot(tmp_path) == before
    if "layout" in args:  # the diagnostic names the file as it would have been
        assert "specs/demo/layout.yaml:4:13: error[E228]" in result.output
