"""`rcsgen build`: the guarantees of the generated package and of writing it.

The package needs only the standard library and the hooks module, runs without rcsgen,
is byte-identical wherever it is built, passes ruff, names its sources portably, and a
build is all-or-nothing: it never writes through symlinks, never touches user files and
deletes only files it generated itself.
"""

from __future__ import annotations

import ast
import getpass
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import MINER, REPO, edit, rcsgen, snapshot

from rcsgen.emit import RUFF_FORMAT_ARGS, ruff_binary

OLD = 1_000_000_000 * 10**9  # 2001-09-09, in ns
HOOKS_PACKAGE = "miner_hooks"  # co.yaml's `hooks_module: miner_hooks.co`
EXPECTED_FILES = {
    "miner/__init__.py",
    "miner/__main__.py",
    "miner/rcs.py",
    "miner/layout.py",
    "miner/main_pc1.py",
    "miner/co.py",
    "miner/cr.py",
    "miner/vg.py",
    "miner/cc.py",
}


def mtimes(root: Path, files_only: bool = False) -> dict[str, int]:
    """Modification times under `root`, of directories too unless `files_only`."""
    return {
        p.relative_to(root).as_posix(): p.stat().st_mtime_ns
        for p in root.rglob("*")
        if p.is_file() or not files_only
    }


def write_tree(root: Path, files: dict[str, bytes]) -> None:
    for rel, data in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_bytes(data)


# ---------------------------------------------------------------- the generated package


def test_build_produces_the_package(pristine: dict[str, bytes]) -> None:
    """One package per system: the runtime, the layout, one module per controller and process."""
    assert set(pristine) == EXPECTED_FILES


def test_generated_code_imports_only_stdlib_itself_and_hooks(pristine: dict[str, bytes]) -> None:
    """Every import in the output is relative, standard library, or the declared hooks module."""
    absolute: set[str] = set()
    for rel, data in pristine.items():
        for node in ast.walk(ast.parse(data, filename=rel)):
            if isinstance(node, ast.Import):
                absolute.update(alias.name.split(".")[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                absolute.add(node.module.split(".")[0])
    outside = {name for name in absolute if name not in sys.stdlib_module_names}
    assert outside == {HOOKS_PACKAGE}  # and the hooks are imported at all
    assert b"import miner_hooks.co as hooks" in pristine["miner/co.py"]


RUN_WITHOUT_RCSGEN = """
import importlib.util, json, sys
assert all(importlib.util.find_spec(m) is None for m in ("rcsgen", "yaml", "jinja2", "click"))
import miner.main_pc1 as m
from miner import layout
p = m.run(cycles=20, pace=False)  # the start-up INIT ripples down and back
after_init = layout.STATUS_OUT["co"].read(p.block.buf)
names = layout.COMMAND_NAMES["co"]
layout.COMMAND_IN["co"].write(p.block.buf, command_num=2, command=names.index("SUMP_SHEAR_CUSP"))
layout.WORLD["tail_in_position"].write(p.block.buf, tail_in_position=True)
poses = []
for _ in range(100):
    p.run_cycle()
    poses.append(layout.WORLD["pose_x"].read(p.block.buf)["pose_x"])
    done = layout.STATUS_OUT["co"].read(p.block.buf)
    if done["status_num"] == 2 and done["status"] != 1:
        break
third_party = sorted(
    n for n, mod in sys.modules.items()
    if mod is not None and n.split(".")[0] not in sys.stdlib_module_names
    and n.split(".")[0] not in ("miner", "miner_hooks", "__main__", "__mp_main__")
)
print(json.dumps({"init": after_init, "done": done, "poses": poses, "third_party": third_party}))
"""


def test_generated_package_runs_without_rcsgen(tmp_path: Path, pristine: dict[str, bytes]) -> None:
    """The package runs on a bare interpreter: no site-packages, only itself and the hooks.

    `-S` drops site-packages (where rcsgen, PyYAML, Jinja2 live, editable or not); the path
    holds just the output directory and the spec directory (for `miner_hooks`). It runs the
    start-up INIT and then the paper's SUMP_SHEAR_CUSP to DONE.
    """
    out = tmp_path / "out"
    write_tree(out, pristine)
    run_dir = tmp_path / "cwd"
    run_dir.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(out), str(MINER)])}
    done = subprocess.run(
        [sys.executable, "-S", "-c", RUN_WITHOUT_RCSGEN],
        cwd=run_dir,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    DONE = 2
    assert report["init"] == {"status_num": 1, "status": DONE, "error_num": 0, "state": 0}
    assert report["done"]["status_num"] == 2 and report["done"]["status"] == DONE
    assert max(report["poses"]) == pytest.approx(0.5)  # trammed to the sump goal (hook output)
    assert report["poses"][-1] == pytest.approx(0.0)  # and back out of the cusp
    assert report["third_party"] == []


def test_generated_package_has_a_main(tmp_path: Path, pristine: dict[str, bytes]) -> None:
    """`python -m miner pc1 --cycles N --fast` runs the process, again without site-packages."""
    write_tree(tmp_path, pristine)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(MINER)])}
    done = subprocess.run(
        [sys.executable, "-S", "-m", "miner", "pc1", "--cycles", "5", "--fast"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert (done.returncode, done.stdout) == (0, "pc1: 5 cycles\n"), done.stderr


def test_output_is_byte_identical_wherever_it_is_built(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, pristine: dict[str, bytes]
) -> None:
    """Relative or absolute paths, another cwd, another directory: the same bytes every time."""
    first = tmp_path / "one"
    shutil.copytree(MINER, first / "specs" / "miner")
    monkeypatch.chdir(first)
    assert rcsgen("build").exit_code == 0  # relative defaults: ./specs -> ./generated
    second = tmp_path / "deeper" / "two"
    shutil.copytree(MINER, second / "input" / "miner")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert rcsgen("build", second / "input", "-o", second / "out").exit_code == 0
    monkeypatch.chdir(second)
    assert rcsgen("build", "input/miner/system.yaml", "-o", "again").exit_code == 0
    assert snapshot(first / "generated") == pristine
    assert snapshot(second / "out") == pristine
    assert snapshot(second / "again") == pristine


def test_output_passes_ruff(tmp_path: Path, pristine: dict[str, bytes]) -> None:
    """The output is lint-clean (ruff defaults and the project's rule set) and ruff-formatted."""
    write_tree(tmp_path, pristine)
    ruff = ruff_binary()
    checks = [
        [ruff, "check", "--isolated", "."],
        [ruff, "check", "--isolated", "--select", "E,F,W,I,B,UP", "--line-length", "100", "."],
        [ruff, *RUFF_FORMAT_ARGS, "--check", "."],
    ]
    for command in checks:
        done = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, check=False)
        assert done.returncode == 0, f"{command}:\n{done.stdout}{done.stderr}"


HEADER = re.compile(
    r"# Generated by rcsgen from (miner/[a-z0-9_]+\.yaml)\. Do not edit: change the spec and "
    r"run `rcsgen build`\.\n"
)


def test_every_file_names_its_source_and_nothing_machine_specific(
    work: Path, pristine: dict[str, bytes]
) -> None:
    """Line 1 names an existing spec relative to the specs root; no paths, user or date leak."""
    user = getpass.getuser()
    leaks = [str(work), str(Path.home()), str(REPO), os.sep + user + os.sep]
    stamp = re.compile(rb"20\d\d-\d\d-\d\d|\d\d:\d\d:\d\d")
    for rel, data in pristine.items():
        text = data.decode("utf-8")
        match = HEADER.match(text)
        assert match, f"{rel} starts with {text.splitlines()[0]!r}"
        assert (work / "specs" / match[1]).is_file()
        assert not [leak for leak in leaks if leak in text], rel
        assert not stamp.search(data), rel
    controller = HEADER.match(pristine["miner/vg.py"].decode())
    assert controller and controller[1] == "miner/vg.yaml"


# ---------------------------------------------------------------- writing generated/


def test_spec_error_writes_nothing(work: Path) -> None:
    """A build with a spec error exits 1 and leaves generated/ byte- and mtime-identical."""
    before, stamps = snapshot(work / "generated"), mtimes(work / "generated")
    edit(work / "specs/miner/co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 5.0")
    edit(work / "specs/miner/vg.yaml", "next: S1", "next: S7")  # co.py would change too
    result = rcsgen("build")
    assert result.exit_code == 1
    assert "error[E206]" in result.output
    assert "build failed: nothing was written" in result.output
    assert snapshot(work / "generated") == before
    assert mtimes(work / "generated") == stamps


def test_rebuild_changes_only_what_changed(work: Path) -> None:
    """A spec edit rewrites exactly the affected file; the others keep their mtimes."""
    for path in (work / "generated").rglob("*.py"):
        os.utime(path, ns=(OLD, OLD))  # no reliance on the file system's mtime resolution
    stamps = mtimes(work / "generated", files_only=True)
    edit(work / "specs/miner/co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 5.0")
    result = rcsgen("build")
    assert result.exit_code == 0, result.output
    assert "1 written, 0 deleted, 8 unchanged" in result.output
    after = mtimes(work / "generated", files_only=True)
    assert {rel for rel in after if after[rel] != stamps[rel]} == {"miner/co.py"}
    assert "LOOSE_COAL_LIMIT = 5.0" in (work / "generated/miner/co.py").read_text()
    mode = (work / "generated/miner/co.py").stat().st_mode & 0o777
    umask = os.umask(0o022)
    os.umask(umask)
    assert mode == 0o666 & ~umask  # an ordinary file, not mkstemp's private 0600


DROP_CR = [
    ("co.yaml", "subordinates: [cr, vg, cc]", "subordinates: [vg, cc]"),
    ("co.yaml", "            - send: cr.SUMP\n", ""),
    ("co.yaml", "            - send: cr.SHEAR\n", ""),
    ("co.yaml", "            - send: cr.CUSP\n", ""),
    ("co.yaml", "            cr.status == DONE and vg.status", "            vg.status"),
    ("co.yaml", "- when: cr.status == DONE and vg.status", "- when: vg.status"),
    ("co.yaml", "- when: cr.status == DONE and vg.status", "- when: vg.status"),
    ("system.yaml", "modules: [co, cr, vg, cc]", "modules: [co, vg, cc]"),
    ("system.yaml", "simulators: [cr, vg, cc]", "simulators: [vg, cc]"),
]


def test_removed_controller_is_deleted_but_user_files_are_kept(work: Path) -> None:
    """Dropping `cr` deletes the stale generated cr.py; a user's own file there is untouched."""
    notes = work / "generated/miner/notes.py"
    notes.write_text("# my notes\nTODO = 1\n")
    helper = work / "generated/miner/sub/helper.py"
    helper.parent.mkdir()
    helper.write_text("x = 1\n")
    user_stamps = {p: p.stat().st_mtime_ns for p in (notes, helper)}
    for name, old, new in DROP_CR:
        edit(work / "specs/miner" / name, old, new)
    (work / "specs/miner/cr.yaml").unlink()
    check = rcsgen("build", "--check")
    assert check.exit_code == 1
    assert "--- a/miner/cr.py\n+++ /dev/null\n" in check.output
    assert (work / "generated/miner/cr.py").is_file()  # --check deleted nothing
    result = rcsgen("build")
    assert result.exit_code == 0, result.output
    assert "1 deleted" in result.output
    assert not (work / "generated/miner/cr.py").exists()
    assert notes.read_text() == "# my notes\nTODO = 1\n"
    assert helper.read_text() == "x = 1\n"
    assert {p: p.stat().st_mtime_ns for p in (notes, helper)} == user_stamps
    assert "CrController" not in (work / "generated/miner/main_pc1.py").read_text()
    assert rcsgen("build", "--check").exit_code == 0


@pytest.mark.parametrize("changed", [False, True], ids=["current-spec", "changed-spec"])
def test_user_file_in_the_way_is_refused(work: Path, changed: bool) -> None:
    """A file without the rcsgen header where rcsgen would write: E304, exit 1, nothing written."""
    user_file = work / "generated/miner/vg.py"
    user_file.write_text("# hand-written vehicle guidance\n")
    if changed:  # other files would be written too: none of them may be
        edit(work / "specs/miner/co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 5.0")
    before, stamps = snapshot(work / "generated"), mtimes(work / "generated")
    result = rcsgen("build")
    assert result.exit_code == 1
    assert (
        "generated/miner/vg.py:1:1: error[E304]: `generated/miner/vg.py` was not generated by "
        "rcsgen; refusing to overwrite it" in result.output
    )
    assert "build failed: nothing was written" in result.output
    assert snapshot(work / "generated") == before
    assert mtimes(work / "generated") == stamps


def test_undecodable_user_file_is_refused_not_a_crash(work: Path) -> None:
    """A binary file at a generated path is a user file too: E304, not a UnicodeDecodeError."""
    (work / "generated/miner/vg.py").write_bytes(b"\xff\xfe\x00binary")
    result = rcsgen("build")
    assert result.exit_code == 1
    assert "error[E304]" in result.output
    assert (work / "generated/miner/vg.py").read_bytes() == b"\xff\xfe\x00binary"


def test_check_on_a_current_tree(work: Path) -> None:
    """`build --check` on a current tree: exit 0, says so, writes nothing."""
    stamps = mtimes(work / "generated")
    result = rcsgen("build", "--check")
    assert result.exit_code == 0, result.output
    assert result.stdout == "generated is current (9 files)\n"
    assert mtimes(work / "generated") == stamps


def test_check_on_a_stale_tree_prints_a_diff(work: Path) -> None:
    """After a spec edit `build --check` exits 1 with a unified diff and changes nothing."""
    before, stamps = snapshot(work / "generated"), mtimes(work / "generated")
    edit(work / "specs/miner/co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 5.0")
    result = rcsgen("build", "--check")
    assert result.exit_code == 1
    assert result.stdout.startswith("--- a/miner/co.py\n+++ b/miner/co.py\n@@ ")
    assert "\n-LOOSE_COAL_LIMIT = 4.0\n+LOOSE_COAL_LIMIT = 5.0\n" in result.stdout
    assert "generated is stale: 1 file(s) to write, 0 to delete" in result.stderr
    assert snapshot(work / "generated") == before
    assert mtimes(work / "generated") == stamps


def test_check_without_output_directory(work: Path) -> None:
    """`--check` against a missing output directory: stale (every file new), nothing created."""
    result = rcsgen("build", "--check", "-o", "nowhere")
    assert result.exit_code == 1
    assert "--- /dev/null\n+++ b/miner/co.py\n" in result.stdout
    assert not (work / "nowhere").exists()


def test_symlinked_system_directory_is_refused(work: Path) -> None:
    """generated/miner as a symlink: E301, exit 1, nothing written through it."""
    real = work / "elsewhere"
    (work / "generated/miner").rename(real)
    (work / "generated/miner").symlink_to(real, target_is_directory=True)
    edit(work / "specs/miner/co.yaml", "LOOSE_COAL_LIMIT: 4.0", "LOOSE_COAL_LIMIT: 5.0")
    before, stamps = snapshot(real), mtimes(real)
    result = rcsgen("build")
    assert result.exit_code == 1
    assert "generated/miner:1:1: error[E301]: refusing to write through symlink" in result.output
    assert "1 error(s), 0 warning(s)" in result.output  # one problem, counted once
    assert snapshot(real) == before
    assert mtimes(real) == stamps


def test_symlinked_file_is_refused(work: Path, tmp_path: Path) -> None:
    """A generated file replaced by a symlink: E301, the link target is not overwritten."""
    target = tmp_path / "outside.py"
    target.write_text("keep me\n")
    (work / "generated/miner/co.py").unlink()
    (work / "generated/miner/co.py").symlink_to(target)
    result = rcsgen("build")
    assert result.exit_code == 1
    assert "generated/miner/co.py:1:1: error[E301]" in result.output
    assert target.read_text() == "keep me\n"


# ---------------------------------------------------------------- the repository itself


def test_committed_generated_tree_is_current(monkeypatch: pytest.MonkeyPatch) -> None:
    """`rcsgen build specs --check` in the repository: generated/ matches specs/ (read-only)."""
    monkeypatch.chdir(REPO)
    stamps = mtimes(REPO / "generated")
    result = rcsgen("build", "specs", "--check")
    assert result.exit_code == 0, result.output
    assert mtimes(REPO / "generated") == stamps


def test_pip_install_gives_a_working_rcsgen(tmp_path: Path, pristine: dict[str, bytes]) -> None:
    """A non-editable `pip install .` into a clean venv builds the same bytes (templates shipped).

    Installs from a copy of the repository without generated/, caches or VCS data, so the
    wheel cannot lean on files that only exist in a checkout.
    """
    source = tmp_path / "src"
    ignore = shutil.ignore_patterns(
        ".git", ".venv", "generated", "traces", "__pycache__", ".pytest_cache", ".ruff_cache"
    )
    shutil.copytree(REPO, source, ignore=ignore)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", venv], check=True, timeout=120)
    bindir = venv / ("Scripts" if os.name == "nt" else "bin")
    install = subprocess.run(
        [bindir / "python", "-m", "pip", "install", "--quiet", str(source)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert install.returncode == 0, install.stdout + install.stderr
    shutil.copytree(MINER, tmp_path / "specs" / "miner")
    done = subprocess.run(
        [bindir / "rcsgen", "build", tmp_path / "specs", "-o", tmp_path / "out"],
        cwd=tmp_path / "specs",  # not the checkout: the installed package must carry everything
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert snapshot(tmp_path / "out") == pristine
