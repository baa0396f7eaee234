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


def test_utf16_without_a_bom_is_told_by_its_first_32_characters(system: Path) -> None:
    # the 33rd character is the first not ASCII (a euro sign: bytes 64 and 65, 0x20 0xac):
    # the first 64 bytes alone say UTF-16, not the byte after them, nor UTF-8's 0xac
    top = system / "top.yaml"
    top.write_bytes(("# " + "x" * 30 + "\u20ac\n" + top.read_text()).encode("utf-16-be"))
    one_error(
        ["validate", "sys"], "sys/top.yaml", "E008", "it is UTF-16 (big-endian) without a byte"
    )


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


# ---------------------------------------------------------------- the output directory


def built(system: Path) -> Path:
    """tmp_path/out holding a build of the tiny system; returns tmp_path/out."""
    result = rcsgen("build", "sys", "-o", "out")
    assert result.exit_code == 0, result.output
    return system.parent / "out"


def tree(root: Path) -> dict[str, tuple[int, bytes | None]]:
    """Every entry under `root`: its mode and, for a regular file, its bytes."""
    found = {}
    for path in sorted(root.rglob("*")):
        info = path.lstat()
        data = path.read_bytes() if path.is_file() and not path.is_symlink() else None
        found[path.relative_to(root).as_posix()] = (info.st_mode, data)
    return found


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda p: p.write_text("notes\n"), "`out` is a file, not a directory"),
        (lambda p: os.mkfifo(p), "`out` is a named pipe (FIFO), not a regular file"),
        (lambda p: p.symlink_to("nowhere"), "`out` is a dangling symbolic link"),
    ],
    ids=["file", "fifo", "dangling-link"],
)
def test_output_path_that_is_not_a_directory_is_e305(
    system: Path, make: Callable[[Path], None], words: str
) -> None:
    out = system.parent / "out"
    make(out)
    line = one_error(["build", "sys", "-o", "out"], "out", "E305", words)
    assert line.startswith("out:1:1: error[E305]: output directory `out`: ")


def test_output_path_through_a_file_is_e305(system: Path) -> None:
    (system.parent / "notes.txt").write_text("notes\n")
    line = one_error(["build", "sys", "-o", "notes.txt/out"], "notes.txt/out", "E305", "")
    assert "runs through `notes.txt`: `notes.txt` is a file, not a directory" in line
    assert (system.parent / "notes.txt").read_text() == "notes\n"


def test_special_file_where_a_module_goes_is_e303_without_opening_it(system: Path) -> None:
    out = built(system)
    (out / "tiny" / "top.py").unlink()
    os.mkfifo(out / "tiny" / "top.py")
    one_error(["build", "sys", "-o", "out"], "out/tiny/top.py", "E303", "is not a file")


def test_a_fifo_in_an_old_output_directory_is_never_opened(system: Path) -> None:
    """Without a manifest (an older rcsgen's output), stale files are found by their header:
    a FIFO among them must not be opened (it would hang) nor deleted."""
    out = built(system)
    (out / "tiny" / ".rcsgen-manifest").unlink()
    os.mkfifo(out / "tiny" / "old.py")
    result = rcsgen("build", "sys", "-o", "out")
    assert result.exit_code == 0, result.output
    assert (out / "tiny" / "old.py").exists()


def test_a_copy_of_a_generated_file_that_the_manifest_does_not_list_is_kept(
    system: Path,
) -> None:
    """With a manifest, rcsgen deletes only what it lists: a person's copy of a generated
    module (the header and all) is theirs, not stale output; the manifest's own header is
    what makes it rcsgen's."""
    out = built(system)
    copy = out / "tiny" / "top_before_the_fix.py"
    shutil.copy(out / "tiny" / "top.py", copy)
    result = rcsgen("build", "sys", "-o", "out")
    assert result.exit_code == 0, result.output
    assert copy.exists()


def test_a_failed_write_is_undone(system: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The disk refuses the third rename of a rebuild (as a full disk or a yanked drive
    would): every file already renamed into place is restored, nothing else is left."""
    out = built(system)
    (system / "top.yaml").write_text((system / "top.yaml").read_text().replace("2.5", "3.5"))
    (system / "sub.yaml").write_text(
        (system / "sub.yaml").read_text().replace("Sub controller", "Sub controller, renamed")
    )
    (system / "extra.yaml").write_text("controller: extra\ntitle: Extra\ncommands: {}\n")
    system.joinpath("system.yaml").write_text(
        (system / "system.yaml").read_text().replace("[top, sub]", "[top, sub, extra]")
    )
    before = tree(out)
    real = os.replace
    calls = []

    def failing(src: object, dst: object) -> None:
        calls.append(dst)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        real(src, dst)

    monkeypatch.setattr(os, "replace", failing)
    result = rcsgen("build", "sys", "-o", "out")
    monkeypatch.setattr(os, "replace", real)
    assert result.exit_code == 1
    assert len(calls) >= 3
    assert "error[E306]: cannot write `out/tiny/" in result.output
    assert "no space left on device; nothing was changed" in result.output
    assert "build failed: nothing was written" in result.output
    assert tree(out) == before


def changed_build(system: Path) -> dict[str, tuple[int, bytes | None]]:
    """A build of the tiny system in out/, then its spec changed: out/ as it is."""
    out = built(system)
    (system / "top.yaml").write_text((system / "top.yaml").read_text().replace("2.5", "3.5"))
    (system / "sub.yaml").write_text(
        (system / "sub.yaml").read_text().replace("Sub controller", "Sub controller, renamed")
    )
    return tree(out)


@pytest.mark.parametrize("stop", ["SIGTERM", "Ctrl-C"])
def test_a_build_stopped_while_writing_leaves_the_output_as_it_was(
    system: Path, monkeypatch: pytest.MonkeyPatch, stop: str
) -> None:
    """SIGTERM (a supervisor or `timeout` stopping the build) or Ctrl-C at the second rename
    of a rebuild: the files renamed into place are taken back, no temporary file stays,
    and SIGTERM exits 143 saying so (before, the default action killed it half-written)."""
    before = changed_build(system)
    real = os.replace
    calls = []

    def stopping(src: object, dst: object) -> None:
        calls.append(dst)
        real(src, dst)  # type: ignore[arg-type]
        if len(calls) == 2:
            if stop == "Ctrl-C":
                raise KeyboardInterrupt
            os.kill(os.getpid(), signal.SIGTERM)  # handled at the next line this runs

    monkeypatch.setattr(os, "replace", stopping)
    result = rcsgen("build", "sys", "-o", "out")
    monkeypatch.setattr(os, "replace", real)
    assert len(calls) == 2
    assert tree(system.parent / "out") == before
    if stop == "SIGTERM":
        assert result.exit_code == 143
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # the handler put back
    else:
        assert result.exit_code == 1 and "Aborted!" in result.output


def test_a_build_stopped_while_formatting_removes_its_scratch(
    system: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """SIGTERM while the formatter runs over the scratch copy (in /dev/shm, in RAM): the
    scratch directory is removed, the output left as it was, exit 143."""
    from rcsgen.compiler.back_end import emit

    before = changed_build(system)
    real = emit.subprocess.run
    scratches = []

    def formatting(command: list[str], **kwargs: object) -> object:
        scratches.append(Path(str(kwargs["cwd"])))
        done = real(command, **kwargs)  # type: ignore[call-overload]
        os.kill(os.getpid(), signal.SIGTERM)
        return done

    monkeypatch.setattr(emit.subprocess, "run", formatting)
    result = rcsgen("build", "sys", "-o", "out")
    monkeypatch.setattr(emit.subprocess, "run", real)
    assert result.exit_code == 143
    assert len(scratches) == 1 and scratches[0].name.startswith("rcsgen-fmt-")
    assert not scratches[0].exists()
    assert tree(system.parent / "out") == before


def test_read_only_output_directory_is_e306(system: Path) -> None:
    out = built(system)
    (system / "top.yaml").write_text((system / "top.yaml").read_text().replace("2.5", "3.5"))
    before = tree(out)
    (out / "tiny").chmod(0o555)
    try:
        done = unprivileged("build", "sys", "-o", "out", cwd=system.parent)
    finally:
        (out / "tiny").chmod(0o755)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert errors(done.stderr) == [
        "out/tiny:1:1: error[E306]: cannot write in `out/tiny`: permission denied (read-only?)"
    ]
    assert tree(out) == before


def test_unwritable_parent_of_a_new_output_directory_is_e306(system: Path) -> None:
    parent = system.parent / "locked"
    parent.mkdir()
    parent.chmod(0o555)
    try:
        done = unprivileged("build", "sys", "-o", "locked/out", cwd=system.parent)
    finally:
        parent.chmod(0o755)
    assert done.returncode == 1, done.stderr
    assert errors(done.stderr) == [
        "locked:1:1: error[E306]: cannot write in `locked`: permission denied (read-only?)"
    ]
    assert list(parent.iterdir()) == []


def test_a_system_at_the_depth_bound_is_found_and_one_level_deeper_is_not(
    system: Path,
) -> None:
    """The bound counts directories: a system MAX_DIR_DEPTH levels below the path given is
    still found (and valid); one level further, the search stops there with E014 and goes on
    with the directories beside it."""
    from rcsgen.compiler.frontend import MAX_DIR_DEPTH

    at_bound = system.parent.joinpath("deep", *["d"] * MAX_DIR_DEPTH)
    shutil.copytree(system, at_bound)
    result = rcsgen("validate", "deep")
    assert (result.exit_code, errors(result.output)) == (0, []), result.output
    (at_bound / "d").mkdir()
    for path in [p for p in at_bound.iterdir() if p.name != "d"]:
        path.rename(at_bound / "d" / path.name)
    (system.parent / "deep" / "z").mkdir()  # searched after the bound was met
    (system.parent / "deep" / "z" / "system.yaml").write_text("system: [\n")
    result = rcsgen("validate", "deep")
    shown = "deep/" + "/".join(["d"] * MAX_DIR_DEPTH)
    assert errors(result.output) == [
        f"{shown}:1:1: error[E014]: directories nest more than {MAX_DIR_DEPTH} levels below "
        "`deep`; not searched further",
        "deep/z/system.yaml:2:1: error[E001]: expected the node content, but found '<stream end>'",
    ]


@pytest.mark.parametrize(
    ("error", "reason"),
    [
        (PermissionError(13, "Permission denied"), "permission denied"),
        (OSError(5, "Input/output error"), "Input/output error"),
        (OSError("no errno"), "no errno"),
    ],
)
def test_a_directory_that_cannot_be_listed_is_e010_with_the_reason(
    system: Path, monkeypatch: pytest.MonkeyPatch, error: OSError, reason: str
) -> None:
    """In process (the unprivileged runs above are other processes): a directory met while
    searching that cannot be listed is E010 saying why."""
    from rcsgen.compiler import frontend

    (system.parent / "all" / "inner").mkdir(parents=True)
    listing = os.scandir

    def scandir(path: Path) -> object:
        if Path(path).name == "inner":
            raise error
        return listing(path)

    monkeypatch.setattr(frontend.os, "scandir", scandir)
    found = frontend.compile_paths([Path("all")], analyse=False).diagnostics.errors
    assert [(str(d.span), d.code, d.message, d.hint) for d in found] == [
        ("all/inner:1:1", "E010", f"cannot read directory: {reason}", "check its permissions")
    ]


def test_the_real_path_of_a_symlink_loop_is_its_absolute_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A link loop cannot be resolved (Python 3.11 raises): it is kept as given, made
    absolute, so that reading it says what is wrong (E012); a link that resolves gives its
    target."""
    from rcsgen.compiler.frontend import real_path

    (tmp_path / "real").mkdir()
    (tmp_path / "via").symlink_to("real", target_is_directory=True)
    (tmp_path / "real" / "loop").symlink_to("loop")
    monkeypatch.chdir(tmp_path)
    assert real_path(Path("real/loop")) == tmp_path / "real" / "loop"
    assert real_path(Path("via")) == (tmp_path / "real").resolve()


@pytest.mark.parametrize(("name", "what"), [("system.yaml", "system"), ("top.yaml", "controller")])
def test_an_empty_spec_file_is_told_what_belongs_there(system: Path, name: str, what: str) -> None:
    """E013's whole text, in process: the file, that it is empty, and what to write there."""
    from rcsgen.compiler.frontend import compile_paths

    (system / name).write_text("# nothing yet\n")
    found = compile_paths([Path("sys")], analyse=False).diagnostics.errors
    assert [(str(d.span), d.code, d.message, d.hint) for d in found] == [
        (
            f"sys/{name}:1:1",
            "E013",
            f"`{name}` is empty: it holds no YAML, only blank lines or comments",
            f"write the {what} spec here, or delete the file",
        )
    ]


def test_a_stray_mapping_in_a_system_is_e225_where_its_mapping_starts(system: Path) -> None:
    """A YAML file that is neither a controller nor an operator: E225 at its first key (after
    a comment line), with what belongs in a system directory."""
    from rcsgen.compiler.frontend import compile_paths

    (system / "notes.yaml").write_text("# to do\nnotes: a stray file\n")
    found = compile_paths([Path("sys")], analyse=False).diagnostics.errors
    assert [(str(d.span), d.code, d.message, d.hint) for d in found] == [
        (
            "sys/notes.yaml:2:1",
            "E225",
            "`notes.yaml` is not a controller spec (no `controller:` or `operator:` key)",
            "only system.yaml, fragments.yaml and controller or operator files belong in a "
            "system directory",
        )
    ]


def test_a_directory_without_a_system_is_e224_saying_what_one_holds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rcsgen.compiler.frontend import compile_paths

    (tmp_path / "empty" / "sub").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)
    found = compile_paths([Path("empty")], analyse=False).diagnostics.errors
    assert [(str(d.span), d.code, d.message, d.hint) for d in found] == [
        (
            "empty:1:1",
            "E224",
            "no system.yaml found under `empty`",
            "a system directory holds system.yaml and one <mnemonic>.yaml per controller",
        )
    ]


def test_a_manifest_with_a_byte_that_is_not_utf8_is_read_with_it_replaced(tmp_path: Path) -> None:
    """A manifest damaged by hand (a byte that is not UTF-8) still says which files rcsgen
    wrote: the others are read as written, the bad byte as U+FFFD - no traceback."""
    from rcsgen.compiler.back_end.write import MANIFEST, MARKER, read_manifest

    (tmp_path / MANIFEST).write_bytes(MARKER.encode() + b"\nplant.py\nbad\xff.py\n")
    assert read_manifest(tmp_path) == {"plant.py", "bad\ufffd.py"}


def test_check_shows_a_changed_a_new_and_a_deleted_file_as_one_unified_diff(
    tmp_path: Path,
) -> None:
    """`build --check`'s diff (write.unified_diff), relative to the output directory: a
    changed file against what it holds, a new one from /dev/null, a stale one (to be
    deleted) to /dev/null, each file once, in that order."""
    from rcsgen.compiler.back_end.write import Plan, unified_diff

    (tmp_path / "duo").mkdir()
    changed, new, stale = (tmp_path / "duo" / n for n in ("a.py", "b.py", "old.py"))
    stale.write_bytes(b"gone = 1\n")
    plan = Plan(
        write={changed: "x = 2\n", new: "y = 1\n"},
        delete=[stale],
        unchanged=0,
        old={changed: b"x = 1\n"},
    )
    assert unified_diff(plan, tmp_path) == (
        "--- a/duo/a.py\n+++ b/duo/a.py\n@@ -1 +1 @@\n-x = 1\n+x = 2\n"
        "--- /dev/null\n+++ b/duo/b.py\n@@ -0,0 +1 @@\n+y = 1\n"
        "--- a/duo/old.py\n+++ /dev/null\n@@ -1 +0,0 @@\n-gone = 1\n"
    )


def test_a_write_the_disk_refuses_is_e306_and_the_build_is_taken_back_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """write.apply puts each written file in place, then moves stale ones aside; when the
    disk refuses a step (here: putting the second file in place, EACCES) everything done is
    taken back - the first file's old text, the stale file, no temporary left - and E306
    says where and why, word for word."""
    import errno

    from rcsgen.compiler.back_end import write
    from rcsgen.compiler.diagnostics import SpecError

    out = tmp_path / "duo"
    out.mkdir()
    first, second, stale = (out / n for n in ("a.py", "b.py", "old.py"))
    first.write_text("a = 1\n")
    stale.write_text("gone = 1\n")
    plan = write.Plan(
        write={first: "a = 2\n", second: "b = 1\n"},
        delete=[stale],
        unchanged=0,
        old={first: b"a = 1\n"},
    )
    real = os.replace

    def refusing(src: object, dst: object) -> None:
        if Path(str(dst)) == second:
            raise PermissionError(errno.EACCES, "Permission denied")
        real(src, dst)

    monkeypatch.setattr(write.os, "replace", refusing)
    with pytest.raises(SpecError) as refused:
        write.apply(plan)
    (said,) = refused.value.diagnostics.items
    assert (said.code, said.span.file, said.message) == (
        "E306",
        str(second),
        f"cannot write `{second}`: permission denied (read-only?); nothing was changed",
    )
    assert sorted(p.name for p in out.iterdir()) == ["a.py", "old.py"]
    assert (first.read_text(), stale.read_text()) == ("a = 1\n", "gone = 1\n")


def test_a_stale_file_is_found_in_every_built_system_after_one_not_built_yet(
    tmp_path: Path,
) -> None:
    """write.plan_outputs looks for stale files system by system: one whose folder does not
    exist yet (built for the first time) is passed over, and a later system's file its
    manifest lists and the build no longer makes is deleted."""
    from rcsgen.compiler.back_end.write import MANIFEST, MARKER, plan_outputs
    from rcsgen.compiler.diagnostics import Diagnostics

    (tmp_path / "b").mkdir()
    stale = tmp_path / "b" / "old.py"
    stale.write_text(f"{MARKER}\n")
    (tmp_path / "b" / MANIFEST).write_text(f"{MARKER}\nold.py\n")
    files = {"a/x.py": f"{MARKER}\n", "b/y.py": f"{MARKER}\n"}
    diags = Diagnostics()
    plan = plan_outputs(files, tmp_path, ["a", "b"], diags)
    assert not diags.items
    assert plan.delete == [stale]
    assert sorted(plan.write) == [tmp_path / "a" / "x.py", tmp_path / "b" / "y.py"]


def test_a_generated_page_is_told_by_its_html_comment_header(tmp_path: Path) -> None:
    """write.is_generated: a Markdown page rcsgen writes (docs/reference) starts with the
    header as an HTML comment, a module with it as a Python comment; a page that only
    mentions it further down is not rcsgen's."""
    from rcsgen.compiler.back_end.write import is_generated

    page, module, other = (tmp_path / n for n in ("a.md", "a.py", "b.md"))
    page.write_text("<!-- Generated by rcsgen from specs/duo -->\n# duo\n")
    module.write_text("# Generated by rcsgen from specs/duo\n")
    other.write_text("# duo\n<!-- Generated by rcsgen -->\n")
    assert [is_generated(p) for p in (page, module, other)] == [True, True, False]
