"""Write: rendered files -> the output directory, all-or-nothing, or a diff (`--check`).

Each system's directory keeps a manifest (`.rcsgen-manifest`) of the files rcsgen wrote
there. A build overwrites or deletes only files that are in the manifest (or, in a directory
an older rcsgen wrote without one, that start with rcsgen's header) and still start with the
header: a file rcsgen did not write is never overwritten (E304) nor deleted, whatever its
name or first line. A build writes every new or changed file to a temporary file beside it
first, then renames them into place and moves stale files aside; if any step fails (a
read-only directory, a full disk) everything done so far is undone, so a failed build leaves
the output directory byte-identical (E306).
"""

from __future__ import annotations

import difflib
import errno
import os
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..diagnostics import Diagnostics, Span, SpecError
from ..front_end.loader import path_problem, read_bytes
from ..ir import IRSystem
from .emit import MARKER, render_all

MANIFEST = ".rcsgen-manifest"
_MANIFEST_HEAD = f"{MARKER}: the files it wrote in this directory; it overwrites and deletes\n"
_MANIFEST_HEAD += "# no others. Do not edit.\n"


def plan_build(
    systems: list[IRSystem], output: Path, progress: Callable[[str], None] | None = None
) -> tuple[Plan, Diagnostics]:
    """Render every file of `systems` and compare them with `output`: what a build writes and
    deletes, and the errors that stop it (symlinks, paths leaving `output`, files in the way
    that rcsgen did not write, an output path that is a file). Nothing is written."""
    if progress is not None:
        modules = sum(len(s.controllers) for s in systems)
        progress(f"rendering and formatting {modules} controller modules")
    files = with_manifests(render_all(systems))
    if progress is not None:
        progress(f"comparing {len(files)} files with {output}")
    problems = Diagnostics()
    plan = plan_outputs(files, output, [s.name for s in systems], problems)
    return plan, problems


def with_manifests(files: dict[str, str]) -> dict[str, str]:
    """The rendered files and, for each system directory, the manifest listing them."""
    by_system: dict[str, list[str]] = {}
    for rel in [*files, *(f"{rel.partition('/')[0]}/{MANIFEST}" for rel in files)]:
        system, _, inner = rel.partition("/")
        by_system.setdefault(system, []).append(inner)
    manifests = {
        f"{system}/{MANIFEST}": _MANIFEST_HEAD + "".join(f"{n}\n" for n in sorted(set(names)))
        for system, names in by_system.items()
    }
    return {**files, **manifests}


@dataclass
class Plan:
    """What a build changes under the output directory."""

    write: dict[Path, str]  # new or changed files
    delete: list[Path]  # files rcsgen generated earlier that are no longer produced
    unchanged: int
    old: dict[Path, bytes] = field(default_factory=dict)  # what `write` replaces, to undo

    @property
    def stale(self) -> bool:
        return bool(self.write or self.delete)


# The first line of every file rcsgen writes starts with one of these: Python's comment,
# and the HTML comment that opens a generated Markdown page (`rcsgen doc`).
MARKERS = (MARKER, "<!-- " + MARKER.removeprefix("# "))


def is_generated(path: Path) -> bool:
    """A regular file whose first line is rcsgen's header (read safely)."""
    try:
        head = read_bytes(path, str(path), 1_000_000)
    except SpecError:
        return False
    return head.startswith(tuple(marker.encode("ascii") for marker in MARKERS))


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def read_manifest(folder: Path) -> set[str] | None:
    """The files a manifest says rcsgen wrote in `folder`; None when there is no manifest
    (a directory written by an older rcsgen) or it is not rcsgen's."""
    path = folder / MANIFEST
    if not _regular(path) or not is_generated(path):
        return None
    text = read_bytes(path, str(path)).decode("utf-8", errors="replace")
    return {line for line in text.splitlines() if line and not line.startswith("#")}


def _output_root_problem(out_dir: Path) -> str:
    """Why `out_dir` cannot be the output directory ('' when it can): it, or a directory on
    the way to it, is a file or something else that is not a directory."""
    for path in [*reversed(out_dir.parents), out_dir]:
        if not os.path.lexists(path):
            return ""
        problem = path_problem(path, "dir")
        if problem is not None:
            if path == out_dir:
                return f"output directory `{out_dir}`: {problem.message}"
            return f"output directory `{out_dir}` runs through `{path}`: {problem.message}"
    return ""


def plan_outputs(
    files: dict[str, str],
    out_dir: Path,
    systems: list[str],
    diags: Diagnostics,
    pattern: str = "*.py",
) -> Plan:
    """Compare rendered files with the output directory; refuses symlinks and escapes.
    Stale files are generated files matching `pattern` under a system's directory."""
    problem = _output_root_problem(out_dir)
    if problem:
        hint = "give -o a directory (it is created if it does not exist)"
        diags.error(Span(str(out_dir)), "E305", problem, hint)
        return Plan({}, [], 0)
    root = out_dir.resolve() if out_dir.exists() else out_dir.absolute()
    manifests = {system: read_manifest(out_dir / system) for system in systems}
    write: dict[Path, str] = {}
    old: dict[Path, bytes] = {}
    unchanged = 0
    # What is asked of each system's folder and each file's directory, asked once (a
    # thousand files share a few directories; resolving every file's path took ~10 stats).
    folders = {s: _Folder.of(out_dir / s) for s in {rel.partition("/")[0] for rel in files}}
    resolved: dict[Path, Path] = {}
    for rel, text in sorted(files.items()):
        target = out_dir / rel
        system, _, inner = rel.partition("/")
        if _refused(target, rel, out_dir / system, folders[system], (root, resolved), diags):
            continue
        if not os.path.lexists(target):
            write[target] = text
            continue
        if not _regular(target):
            diags.error(Span(str(target)), "E303", f"`{target}` exists and is not a file")
            continue
        data = read_bytes(target, str(target), 50_000_000)
        if data == text.encode("utf-8"):
            unchanged += 1
            continue
        if not _owned(target, inner, manifests[system]):
            diags.error(
                Span(str(target)),
                "E304",
                f"`{target}` was not generated by rcsgen; refusing to overwrite it",
                "move it away, or build into another directory with -o",
            )
            continue
        write[target] = text
        old[target] = data
    produced = {out_dir / rel for rel in files}
    delete = []
    for system in systems:
        folder = out_dir / system
        if not folder.is_dir() or folder.is_symlink():
            continue
        manifest = manifests[system]
        if manifest is None:  # an older rcsgen's output: its files carry the header
            candidates = [p for p in sorted(folder.rglob(pattern)) if _regular(p)]
        else:
            candidates = [folder / name for name in sorted(manifest)]
        for path in candidates:
            inner = path.relative_to(folder).as_posix()
            if path in produced or not _regular(path) or not _safe_inside(path, root):
                continue
            if _owned(path, inner, manifest):
                delete.append(path)
    _check_writable(write, delete, out_dir, diags)
    return Plan(write, delete, unchanged, old)


def _refused(
    target: Path,
    rel: str,
    folder: Path,
    state: _Folder,
    inside: tuple[Path, dict[Path, Path]],
    diags: Diagnostics,
) -> bool:
    """Whether `target` may not be written, after saying why: a symbolic link on the way
    (E301), its system's folder not a directory (E303), a path leaving the output root
    `inside[0]` (E302; `inside[1]` keeps the directories resolved so far)."""
    linked = [folder] * state.linked + [target] * target.is_symlink()
    for part in linked:
        diags.error(Span(str(part)), "E301", f"refusing to write through symlink `{part}`")
    if linked:  # one cause: no follow-up E302/E304 for where the link happens to point
        return True
    if state.not_a_directory:
        diags.error(
            Span(str(folder)),
            "E303",
            f"`{folder}` exists and is not a directory",
            "move it away: rcsgen puts the system's package there",
        )
        return True
    root, resolved = inside
    if not _real(target, resolved).is_relative_to(root):
        diags.error(Span(str(target)), "E302", f"output path `{rel}` leaves the output directory")
        return True
    return False


@dataclass(frozen=True)
class _Folder:
    """What plan_outputs asks of a system's folder under the output directory."""

    linked: bool  # a symbolic link
    not_a_directory: bool  # something else than a directory is there

    @classmethod
    def of(cls, folder: Path) -> _Folder:
        return cls(folder.is_symlink(), os.path.lexists(folder) and not folder.is_dir())


def _real(target: Path, resolved: dict[Path, Path]) -> Path:
    """`target` absolute with its links resolved, as `resolve` makes it, for a target that is
    not itself a link: its directory resolved (once per directory, kept in `resolved`)."""
    if target.name in ("", ".", ".."):
        return target.absolute().resolve()
    parent = target.parent
    if parent not in resolved:
        resolved[parent] = parent.absolute().resolve()
    return resolved[parent] / target.name


def _owned(path: Path, inner: str, manifest: set[str] | None) -> bool:
    """Whether rcsgen may replace or delete this file: it wrote it (the manifest lists it, or
    there is no manifest yet) and it still starts with rcsgen's header."""
    listed = manifest is None or inner in manifest
    return listed and is_generated(path)


def _safe_inside(path: Path, root: Path) -> bool:
    try:
        return path.resolve().is_relative_to(root)
    except (OSError, RuntimeError):
        return False


def _check_writable(
    write: dict[Path, str], delete: list[Path], out_dir: Path, diags: Diagnostics
) -> None:
    """E306 for each directory a build must change but cannot (read-only, no permission):
    the nearest directory that exists on the way to each file."""
    seen: set[Path] = set()
    for path in [*write, *delete]:
        directory = path.parent
        while not os.path.lexists(directory) and directory != directory.parent:
            directory = directory.parent
        if directory in seen:
            continue
        seen.add(directory)
        if not os.access(directory, os.W_OK | os.X_OK):
            diags.error(
                Span(str(directory)),
                "E306",
                f"cannot write in `{directory}`: permission denied (read-only?)",
                "make it writable, or build into another directory with -o",
            )


def _file_mode() -> int:
    """The mode a plain new file gets under the current umask (os.open gives 0600 here)."""
    umask = os.umask(0o022)
    os.umask(umask)
    return 0o666 & ~umask


@dataclass
class _Undo:
    """What `apply` did so far, to take back in reverse."""

    dirs: list[Path] = field(default_factory=list)  # created, outermost first
    temps: list[Path] = field(default_factory=list)  # written, not yet renamed
    placed: list[Path] = field(default_factory=list)  # renamed into place
    aside: list[tuple[Path, Path]] = field(default_factory=list)  # (stale file, moved to)

    def rollback(self, old: dict[Path, bytes]) -> None:
        # Each step is listed before it is taken, so that an interruption between the two
        # (Ctrl-C, SIGTERM) is undone too: undoing a step not taken does nothing.
        for original, moved in reversed(self.aside):
            if os.path.lexists(moved):
                os.replace(moved, original)
        for path in reversed(self.placed):
            if path in old:
                path.write_bytes(old[path])
            else:
                path.unlink(missing_ok=True)
        for path in self.temps:
            path.unlink(missing_ok=True)
        for directory in reversed(self.dirs):
            try:
                directory.rmdir()
            except OSError:
                pass


def apply(plan: Plan) -> None:
    """Write changed files atomically, then delete stale ones: all or nothing.

    Raises SpecError (E306) after undoing everything when the disk refuses a step."""
    mode = _file_mode()
    undo = _Undo()
    current: Path | None = None
    there: set[Path] = set()  # directories known to exist (each file's, asked once)
    try:
        for path in plan.write:
            current = path
            if path.parent not in there:
                missing = [p for p in [path.parent, *path.parent.parents] if not p.exists()]
                for directory in reversed(missing):
                    undo.dirs.append(directory)
                    directory.mkdir()
                there.add(path.parent)
            tmp = path.with_name(f".rcsgen-{path.name}.{os.getpid()}.tmp")
            undo.temps.append(tmp)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as handle:
                handle.write(plan.write[path])
            os.chmod(tmp, mode)
        for target, written in zip(plan.write, list(undo.temps), strict=True):
            current = target
            undo.placed.append(target)
            os.replace(written, target)
            undo.temps.remove(written)
        for path in plan.delete:
            current = path
            moved = path.with_name(f".rcsgen-{path.name}.deleted")
            undo.aside.append((path, moved))
            os.replace(path, moved)
    except OSError as exc:
        undo.rollback(plan.old)
        where = current or Path(".")
        reason = os.strerror(exc.errno) if exc.errno else str(exc)
        if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
            reason += " (read-only?)"
        diags = Diagnostics()
        diags.error(
            Span(str(where)),
            "E306",
            f"cannot write `{where}`: {reason.lower()}; nothing was changed",
            "make the output directory writable (or free space), or build elsewhere with -o",
        )
        raise SpecError(diags) from None
    except BaseException:  # interrupted (Ctrl-C, SIGTERM): nothing half-written stays
        undo.rollback(plan.old)
        raise
    for _, moved in undo.aside:
        moved.unlink(missing_ok=True)


def unified_diff(plan: Plan, out_dir: Path) -> str:
    """The diff `--check` prints: what a build would change, relative to the output dir."""
    chunks: list[str] = []
    for path, text in sorted(plan.write.items()):
        old = plan.old.get(path, b"").decode("utf-8", errors="replace")
        name = path.relative_to(out_dir).as_posix()
        chunks += difflib.unified_diff(
            old.splitlines(keepends=True),
            text.splitlines(keepends=True),
            f"a/{name}" if old else "/dev/null",
            f"b/{name}",
        )
    for path in plan.delete:
        name = path.relative_to(out_dir).as_posix()
        old = read_bytes(path, str(path), 50_000_000).decode("utf-8", errors="replace")
        chunks += difflib.unified_diff(old.splitlines(keepends=True), [], f"a/{name}", "/dev/null")
    return "".join(chunks)
