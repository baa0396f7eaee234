"""Files and paths that cannot live in git: each is built in tmp_path by the test itself.

FIFOs, devices, sockets, symbolic-link loops and dangling links, unreadable files and
directories, over-long names, oversized files and very deep trees. Every one must end in
one located error and exit 1 (2 only for command-line misuse): no hang, no traceback.

Unreadable files need a process that file permissions apply to: as root, the command runs
in a child without CAP_DAC_OVERRIDE (`setpriv`), so the test is real, not simulated.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from conftest import REPO, rcsgen

TINY = REPO / "tests" / "cases" / "valid" / "tiny"
SETPRIV = shutil.which("setpriv")


@pytest.fixture(autouse=True)
def no_hang() -> Iterator[None]:
    """A FIFO that is opened blocks forever: turn a hang into a failure."""

    def hung(signum: int, frame: object) -> None:
        raise AssertionError("rcsgen hung (a FIFO or a device was opened)")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def system(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of the tiny system in tmp_path/sys; the working directory is tmp_path."""
    shutil.copytree(TINY, tmp_path / "sys")
    monkeypatch.chdir(tmp_path)
    return tmp_path / "sys"


def errors(output: str) -> list[str]:
    return [line for line in output.splitlines() if ": error[" in line]


def one_error(args: list[str], where: str, code: str, words: str) -> str:
    """Run rcsgen in-process: exit 1, exactly one located error, no traceback."""
    result = rcsgen(*args)
    assert result.exit_code == 1, result.output
    found = errors(result.output)
    assert len(found) == 1, result.output
    at = where if where.count(":") == 2 else f"{where}:1:1"
    assert found[0].startswith(f"{at}: error[{code}]: "), found
    assert words in found[0], found
    return found[0]


# ---------------------------------------------------------------- special files


def _bound(path: Path) -> None:
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind(str(path))  # the socket file stays after the socket is closed


SPECIAL: dict[str, tuple[Callable[[Path], None], str, str]] = {
    "fifo": (lambda p: os.mkfifo(p), "E011", "is a named pipe (FIFO), not a regular file"),
    "device": (lambda p: p.symlink_to("/dev/zero"), "E011", "is a character device"),
    "socket": (
        lambda p: _bound(p),
        "E011",
        "is a socket, not a regular file",
    ),
    "directory": (lambda p: p.mkdir(), "E011", "is a directory, not a file"),
    "dangling-link": (
        lambda p: p.symlink_to("gone.yaml"),
        "E012",
        "is a dangling symbolic link to `gone.yaml`",
    ),
    "link-loop": (lambda p: p.symlink_to(p.name), "E012", "symbolic link loop"),
}


@pytest.mark.parametrize("kind", sorted(SPECIAL))
@pytest.mark.parametrize("name", ["system.yaml", "extra.yaml"])
def test_special_file_in_a_system_is_one_located_error(system: Path, kind: str, name: str) -> None:
    make, code, words = SPECIAL[kind]
    target = system / name
    target.unlink(missing_ok=True)
    make(target)
    one_error(["validate", "sys"], f"sys/{name}", code, words)


@pytest.mark.parametrize("kind", sorted(set(SPECIAL) - {"directory"}))  # a directory is fine
def test_special_path_on_the_command_line(system: Path, kind: str) -> None:
    make, code, words = SPECIAL[kind]
    make(system.parent / "odd")
    one_error(["validate", "odd"], "odd", code, words)


@pytest.mark.parametrize("kind", ["fifo", "device", "dangling-link"])
def test_special_hooks_module_is_a_located_error(system: Path, kind: str) -> None:
    make, _, words = SPECIAL[kind]
    top = system / "top.yaml"
    top.write_text(
        top.read_text().replace(
            "commands:", "hooks_module: tiny_hooks.top\nhooks:\n  nudge: {}\ncommands:", 1
        )
    )
    (system / "tiny_hooks").mkdir()
    make(system / "tiny_hooks" / "top.py")
    line = one_error(["validate", "sys"], "sys/top.yaml:20:15", "E212", words)
    assert "hooks module `tiny_hooks.top` cannot be read (top.py)" in line


def test_special_scenario_is_a_located_error(system: Path) -> None:
    (system / "scenarios").mkdir()
    os.mkfifo(system / "scenarios" / "go.yaml")
    result = rcsgen("run", "sys/scenarios/go.yaml")
    assert result.exit_code == 1, result.output
    assert "sys/scenarios/go.yaml:1:1: error[E011]: `go.yaml` is a named pipe" in result.output


# ---------------------------------------------------------------- empty, encodings, sizes


@pytest.mark.parametrize("text", ["", "\n\n", "# a comment only\n", "~\n"])
@pytest.mark.parametrize("name", ["system.yaml", "top.yaml"])
def test_empty_spec_file_is_e013_not_skipped(system: Path, name: str, text: str) -> None:
    (system / name).write_text(text)
    line = one_error(["validate", "sys"], f"sys/{name}", "E013", "is empty")
    assert f"`{name}` is empty" in line


def test_utf16_file_is_e008_with_a_hint(system: Path) -> None:
    top = system / "top.yaml"
    top.write_bytes(top.read_text().encode("utf-16"))
    result = rcsgen("validate", "sys")
    assert result.exit_code == 1
    assert "sys/top.yaml:1:1: error[E008]: file is not valid UTF-8: byte 0xff" in result.output
    assert "the file is UTF-16" in result.output


def test_oversized_file_is_e006_and_is_not_read_whole(system: Path) -> None:
    with (system / "huge.yaml").open("wb") as handle:
        handle.truncate(50_000_000)  # sparse: 50 MB of zeros on disk costs nothing
    one_error(["validate", "sys"], "sys/huge.yaml", "E006", "larger than 1,000,000 bytes")


def test_over_long_name_is_e010(system: Path) -> None:
    name = "x" * 300
    one_error(["validate", name], name, "E010", "file name too long")


def test_path_through_a_file_is_e010(system: Path) -> None:
    one_error(["validate", "sys/top.yaml/more"], "sys/top.yaml/more", "E010", "not a directory")


def test_very_deep_tree_is_searched_to_a_bound(system: Path) -> None:
    deep = system.parent / "deep"
    path = deep.joinpath(*["d"] * 40)
    path.mkdir(parents=True)
    result = rcsgen("validate", "deep")
    assert result.exit_code == 1
    assert [line.split(": ")[1] for line in errors(result.output)] == ["error[E014]"]
    assert "directories nest more than 32 levels below `deep`" in result.output


def test_symlinked_directory_loop_is_not_followed(system: Path) -> None:
    (system / "again").symlink_to(".", target_is_directory=True)
    result = rcsgen("validate", "sys")
    assert result.exit_code == 0, result.output


# ---------------------------------------------------------------- permissions


def unprivileged(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """`rcsgen ARGS` in a child that file permissions apply to (root drops its DAC override)."""
    command = [sys.executable, "-m", "rcsgen", *args]
    if os.geteuid() == 0:
        if SETPRIV is None:
            pytest.skip("running as root without setpriv: permissions would not apply")
        command = [SETPRIV, "--bounding-set", "-dac_override,-dac_read_search", *command]
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=60)


def assert_unreadable(root: Path, target: str, locked: Path, where: str, what: str) -> None:
    locked.chmod(0)
    try:
        done = unprivileged("validate", target, cwd=root)
    finally:
        locked.chmod(0o755)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    found = errors(done.stderr)
    assert found == [f"{where}:1:1: error[E010]: cannot read {what}: permission denied"], (
        done.stderr
    )


def test_unreadable_spec_file_is_e010(system: Path) -> None:
    assert_unreadable(system.parent, "sys", system / "top.yaml", "sys/top.yaml", "file")


def test_unreadable_system_directory_is_e010(system: Path) -> None:
    assert_unreadable(system.parent, "sys", system, "sys", "directory")


def test_unreadable_directory_met_while_searching_is_e010(system: Path) -> None:
    inner = system.parent / "all" / "inner"
    inner.mkdir(parents=True)
    shutil.move(system, inner / "sys")
    assert_unreadable(system.parent, "all", inner, "all/inner", "directory")
