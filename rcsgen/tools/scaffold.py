"""Scaffold: a name and a place -> new spec files that validate cleanly (`rcsgen new`).

The paper's "copy the template and rename" step, done by the tool: `new system` writes a
system file, its root controller (the QQ1 template as a state table) and a scenario that
commands the root; `new controller` writes a controller from the same template, adds it to
its supervisor's `subordinates:` and to a process, right after its supervisor's subtree
(command-first order). Existing files are edited as text, so their comments and layout stay;
every change is validated on a scratch copy first (with warnings counted as errors), and
the spec directory is touched only when the result is clean. Nothing is overwritten.
"""

from __future__ import annotations

import re
import shutil
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..compiler.back_end.emit import environment
from ..compiler.diagnostics import Diagnostic, Span, did_you_mean
from ..compiler.front_end import loader
from ..compiler.frontend import compile_paths
from .scenario.check import check_system_scenarios

NAME = re.compile(r"^[a-z][a-z0-9_]*$")


class ScaffoldError(Exception):
    """What `rcsgen new` refuses, in one line (and the diagnostics of a result that would
    not validate)."""

    def __init__(self, message: str, diagnostics: Iterable[Diagnostic] = (), code: int = 1) -> None:
        super().__init__(message)
        self.diagnostics = list(diagnostics)
        self.code = code  # 2: a malformed argument; 1: refused


@dataclass(frozen=True)
class Written:
    """What a scaffold did: files created and files edited, relative to the spec root."""

    created: tuple[Path, ...]
    edited: tuple[Path, ...]


def _check_name(name: str, what: str) -> None:
    if not NAME.fullmatch(name):
        raise ScaffoldError(
            f"{what} {name!r} is not a lower-case name (letters, digits, _; a letter first)",
            code=2,
        )


def _render(template: str, **values: object) -> str:
    return environment().get_template(f"new/{template}").render(**values)


def new_system(
    specs: Path, name: str, root: str = "top", period: float = 0.1, title: str = ""
) -> Written:
    """`specs/<name>/`: system.yaml, <root>.yaml and scenarios/first_command.yaml."""
    _check_name(name, "system name")
    _check_name(root, "controller mnemonic")
    if not period > 0:
        raise ScaffoldError(f"--period must be a positive number of seconds, not {period}", code=2)
    target = specs / name
    if target.exists():
        raise ScaffoldError(f"{target} exists; rcsgen new writes only new files")
    if specs.exists() and not specs.is_dir():
        raise ScaffoldError(f"{specs} is not a directory")
    files = {
        Path("system.yaml"): _render(
            "system.yaml.j2", name=name, root=root, period=period, title=title or name.title()
        ),
        Path(f"{root}.yaml"): _render("controller.yaml.j2", name=root, supervisor=None),
        Path("scenarios/first_command.yaml"): _render("scenario.yaml.j2", root=root),
    }
    with tempfile.TemporaryDirectory(prefix="rcsgen_new_") as scratch:
        trial = Path(scratch) / name
        for rel, text in files.items():
            (trial / rel).parent.mkdir(parents=True, exist_ok=True)
            (trial / rel).write_text(text, encoding="utf-8")
        _validate(trial, target)
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copytree(trial, target)
    return Written(tuple(Path(name) / rel for rel in files), ())


def new_controller(
    system_dir: Path, name: str, supervisor: str | None = None, process: str | None = None
) -> Written:
    """`<system_dir>/<name>.yaml`, added to its supervisor and to a process."""
    _check_name(name, "controller mnemonic")
    system_file = system_dir / "system.yaml"
    if not system_file.is_file():
        raise ScaffoldError(f"no system.yaml in {system_dir}")
    target = system_dir / f"{name}.yaml"
    if target.exists():
        raise ScaffoldError(f"{target} exists; rcsgen new writes only new files")
    system_text = system_file.read_text(encoding="utf-8")
    system = _load(system_text, system_file)
    processes: dict[str, Any] = system.get("processes") or {}
    edits: dict[Path, str] = {}
    if supervisor is not None:
        boss_file = system_dir / f"{supervisor}.yaml"
        if not boss_file.is_file():
            placed = sorted(p.stem for p in system_dir.glob("*.yaml") if p.name != "system.yaml")
            near = did_you_mean(supervisor, placed)
            raise ScaffoldError(
                f"no controller {supervisor!r} in {system_dir}"
                + (f" ({near})" if near else "")
                + f"; controllers: {', '.join(placed)}"
            )
        boss_text = boss_file.read_text(encoding="utf-8")
        edits[Path(boss_file.name)] = _add_subordinate(boss_text, _load(boss_text, boss_file), name)
    where = process or _process_of(processes, supervisor) or next(iter(processes), None)
    if where not in processes:
        raise ScaffoldError(
            f"no process {where!r} in {system_file}; processes: {', '.join(processes)}"
        )
    modules = list(processes[where].get("modules") or [])
    after = _last_of_subtree(system_dir, modules, supervisor) if where != process else None
    edits[Path("system.yaml")] = _insert_module(
        system_text, processes[where]["modules"], name, after
    )
    text = _render("controller.yaml.j2", name=name, supervisor=supervisor)
    with tempfile.TemporaryDirectory(prefix="rcsgen_new_") as scratch:
        trial = Path(scratch) / system_dir.name
        shutil.copytree(system_dir, trial, ignore=shutil.ignore_patterns("__pycache__"))
        for rel, edited in edits.items():
            (trial / rel).write_text(edited, encoding="utf-8")
        (trial / target.name).write_text(text, encoding="utf-8")
        _validate(trial, system_dir)
    for rel, edited in edits.items():
        (system_dir / rel).write_text(edited, encoding="utf-8")
    target.write_text(text, encoding="utf-8")
    return Written((Path(target.name),), tuple(sorted(edits)))


# ---------------------------------------------------------------- checks


def _validate(trial: Path, real: Path) -> None:
    """Refuse a result with any diagnostic, warnings included (they would fail --strict),
    each shown at the file it would have been in."""
    front = compile_paths([trial])
    found = list(front.diagnostics.items)
    for system in front.systems:
        found += check_system_scenarios(front.directories[system.name], system).items
    if found:
        raise ScaffoldError(
            "the result would not validate cleanly; nothing was written",
            [_moved(d, trial, real) for d in found],
        )


def _moved(diagnostic: Diagnostic, trial: Path, real: Path) -> Diagnostic:
    """The diagnostic with its file named in `real` rather than in the scratch `trial`."""
    try:
        rel = Path(diagnostic.span.file).resolve().relative_to(trial.resolve())
    except ValueError:
        return diagnostic
    return replace(diagnostic, span=diagnostic.span._replace(file=(real / rel).as_posix()))


def _load(text: str, path: Path) -> Any:
    try:
        data = loader.load_text(text, path.name)
    except Exception as error:  # a SpecError of the loader: the file does not read
        raise ScaffoldError(
            f"{path} does not read as a spec; run `rcsgen validate` first"
        ) from error
    if not isinstance(data, dict):
        raise ScaffoldError(f"{path} is not a mapping; run `rcsgen validate` first")
    return data


# ---------------------------------------------------------------- text edits


def _process_of(processes: dict[str, Any], module: str | None) -> str | None:
    for process, spec in processes.items():
        if module in (spec.get("modules") or []):
            return str(process)
    return None


def _last_of_subtree(system_dir: Path, modules: list[str], supervisor: str | None) -> str | None:
    """The last module of `modules` in the supervisor's subtree (itself included), so the
    new subordinate runs after its supervisor and its siblings: command-first order."""
    if supervisor is None or supervisor not in modules:
        return None
    subtree, todo = {supervisor}, [supervisor]
    while todo:
        path = system_dir / f"{todo.pop()}.yaml"
        if not path.is_file():
            continue
        data = _load(path.read_text(encoding="utf-8"), path)
        for sub in data.get("subordinates") or []:
            if sub not in subtree:
                subtree.add(sub)
                todo.append(sub)
    return [m for m in modules if m in subtree][-1]


def _add_subordinate(text: str, data: Any, name: str) -> str:
    if "subordinates" in data:
        return _insert_item(text, data["subordinates"], name, None)
    title = loader.key_span(data, "title", Span("?"))
    lines = text.splitlines(keepends=True)
    following = sorted(
        loader.key_span(data, key, Span("?")).line
        for key in data
        if loader.key_span(data, key, Span("?")).line > title.line
    )
    at = (following[0] - 1) if following else len(lines)
    # right after the title: above the blank lines and the comment that open the next key
    while at > title.line and (not lines[at - 1].strip() or lines[at - 1].lstrip()[0] == "#"):
        at -= 1
    lines.insert(at, f"subordinates: [{name}]\n")
    return "".join(lines)


def _insert_module(text: str, modules: Any, name: str, after: str | None) -> str:
    return _insert_item(text, modules, name, after)


def _insert_item(text: str, items: Any, name: str, after: str | None) -> str:
    """`name` inserted into the YAML list `items` (flow or block) after `after` (else at the
    end), as text: the rest of the file is unchanged."""
    lines = text.splitlines(keepends=True)
    offsets = [0]
    for line in lines:
        offsets.append(offsets[-1] + len(line))
    position = len(items) if after is None else list(items).index(after) + 1
    if position < len(items):  # before the item that follows
        at = loader.value_span(items, position, Span("?"))
        index = offsets[at.line - 1] + at.col - 1
        if _is_flow(text, items):
            return text[:index] + f"{name}, " + text[index:]
        indent = " " * (at.col - 1)
        start = offsets[at.line - 1]
        return text[:start] + f"{indent[:-2]}- {name}\n" + text[start:]
    if not items:
        raise ScaffoldError("an empty list cannot be extended here; add the module by hand")
    last = loader.value_span(items, len(items) - 1, Span("?"))
    index = offsets[last.line - 1] + last.col - 1 + len(str(items[-1]))
    if _is_flow(text, items):
        return text[:index] + f", {name}" + text[index:]
    end = offsets[last.line]
    return text[:end] + " " * (last.col - 3) + f"- {name}\n" + text[end:]


def _is_flow(text: str, items: Any) -> bool:
    """Whether the list is written `[a, b]` (the text before its first item is `[`)."""
    first = loader.value_span(items, 0, Span("?"))
    line = text.splitlines()[first.line - 1]
    return line[: first.col - 1].rstrip().endswith(("[", ","))
