"""Which part of rcsgen may import which, read from the source with `ast` (nothing is imported).

    runtime   the standard library, and other runtime modules by relative import only: it is
              copied verbatim into every generated package as `<system>/rcs/`
    compiler  the standard library, its dependencies (yaml, jinja2, jsonschema, ruff),
              compiler and runtime (the contract generated code shares)
    tools     as the compiler, plus tools
    api       `rcsgen/__init__.py` and `rcsgen/api.py`: compiler, runtime, tools
    cli       `rcsgen/cli.py` (the commands), `cli_trace.py` (the trace group), `cli_prove.py` and
              `terminal.py` (what they share):
              anything but `__main__`; click is its own dependency
    __main__  cli

Nothing but `rcsgen/__main__.py` imports `rcsgen.cli`. Every import counts, wherever it is
written (inside a function or under `if TYPE_CHECKING:` too). No cycle among the imports
that run when a module is imported, nor among those that run at all (inside functions too:
two modules that need each other are one); `TYPE_CHECKING` imports never run. Imports by
computed name (`importlib`) are not seen: the harness loads generated packages that way.

Under `make mutate` the package is mutmut's working copy, in which every mutated function is a
trampoline that imports `mutmut.mutation.trampoline`; there, and only there (`under_mutmut()`:
mutmut's variable set and the suite running from its copy `mutants/`), that one import is
accepted. The normal suite accepts nothing of the kind.
"""

from __future__ import annotations

import ast
import functools
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from mutation_runtime import under_mutmut

PACKAGE = Path(__file__).resolve().parents[1] / "rcsgen"

COMPILER_DEPENDENCIES = frozenset({"yaml", "jinja2", "jsonschema", "ruff"})
# layer -> (the layers it may import, the third-party top-level packages it may import)
ALLOWED: dict[str, tuple[frozenset[str], frozenset[str]]] = {
    "runtime": (frozenset({"runtime"}), frozenset()),
    "compiler": (frozenset({"compiler", "runtime"}), COMPILER_DEPENDENCIES),
    # textual (and rich, which it is built on): the optional monitor extra, tools/monitor.py
    "tools": (
        frozenset({"compiler", "runtime", "tools"}),
        COMPILER_DEPENDENCIES | {"textual", "rich"},
    ),
    "api": (frozenset({"api", "compiler", "runtime", "tools"}), frozenset()),
    "cli": (
        frozenset({"api", "compiler", "runtime", "tools", "cli"}),
        COMPILER_DEPENDENCIES | {"click"},
    ),
    "main": (frozenset({"cli"}), frozenset()),
}
# The optional extras a single module may import, where it is the only one that does.
OPTIONAL = {
    # the Zenoh transport, imported (inside a function, never eagerly) only when a process
    # is started with `--transport zenoh`
    ("rcsgen.runtime.zenoh_transport", "zenoh"),
    # fieldbus I/O (issue 27), imported only when a process runs such a device; the soft PLC
    # is a test bench's tool built on the same stacks (their servers)
    ("rcsgen.runtime.io_modbus", "pymodbus"),
    ("rcsgen.runtime.io_opcua", "asyncua"),
    ("rcsgen.tools.softplc", "pymodbus"),
    ("rcsgen.tools.softplc", "asyncua"),
    # z3 (the optional extra rcsgen[prove]), imported inside a function of the prover's
    # handshake proof only
    ("rcsgen.compiler.prove.handshake", "z3"),
}
# What mutmut's trampolines import (see the module docstring).
TRAMPOLINE = "mutmut.mutation.trampoline"
WHY = {
    "runtime": "it is copied into every generated package, which needs nothing but Python",
    "compiler": "it is the library under the tools and the command line",
    "tools": "they are a library under the command line",
    "api": "`import rcsgen` must not pull in the command line",
    "cli": "nothing depends on __main__",
    "main": "__main__ only starts the command line",
}


def layer_of(module: str) -> str | None:
    """The layer of a module of the package `rcsgen`, or None for a module outside it."""
    parts = module.split(".")
    if parts[0] != "rcsgen":
        return None
    if len(parts) == 1 or parts[1] == "api":
        return "api"
    if parts[1] in ("runtime", "compiler", "tools", "cli"):
        return parts[1]
    if parts[1] in (
        "terminal",
        "cli_trace",
        "cli_prove",
    ):  # what the commands share, a group of them
        return "cli"
    return "main" if parts[1] == "__main__" else "unknown"


@dataclass(frozen=True)
class Import:
    """One imported module: who imports it, where, and how."""

    source: str  # the importing module
    target: str  # the imported module (or the package a name is imported from)
    path: str  # the importing file, as messages show it
    line: int
    relative: bool
    eager: bool  # runs when the source is imported: not in a function, not TYPE_CHECKING
    runs: bool = True  # runs at all (not under TYPE_CHECKING): now or when a function is called

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.source} -> {self.target}"


def module_names(package_dir: Path) -> dict[str, Path]:
    """Every module of the package in `package_dir`, dotted, with its file."""
    names = {}
    for path in sorted(package_dir.rglob("*.py")):
        parts = path.relative_to(package_dir.parent).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return names


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


class _Finder(ast.NodeVisitor):
    """The imports of one module, with relative ones resolved against its package."""

    def __init__(self, module: str, is_package: bool, shown: str, modules: set[str]) -> None:
        self.module, self.shown, self.modules = module, shown, modules
        self.package = module if is_package else module.rpartition(".")[0]
        self.deferred = 0  # > 0 inside a function body or an `if TYPE_CHECKING:` block
        self.typing = 0  # > 0 inside an `if TYPE_CHECKING:` block (never runs)
        self.found: list[Import] = []
        self.errors: list[str] = []

    def deferring(self, nodes: list[ast.stmt] | list[ast.AST]) -> None:
        self.deferred += 1
        for node in nodes:
            self.visit(node)
        self.deferred -= 1

    def visit_FunctionDef(self, node: ast.FunctionDef | ast.AsyncFunctionDef) -> None:
        for outer in [*node.decorator_list, *node.args.defaults, *node.args.kw_defaults]:
            if outer is not None:
                self.visit(outer)
        self.deferring(node.body)

    visit_AsyncFunctionDef = visit_FunctionDef

    def visit_Lambda(self, node: ast.Lambda) -> None:
        self.deferring([node.body])

    def visit_If(self, node: ast.If) -> None:
        if not _is_type_checking(node.test):
            self.generic_visit(node)
            return
        self.typing += 1
        self.deferring(node.body)
        self.typing -= 1
        for statement in node.orelse:
            self.visit(statement)

    def add(self, target: str, node: ast.stmt, relative: bool) -> None:
        self.found.append(
            Import(
                self.module,
                target,
                self.shown,
                node.lineno,
                relative,
                not self.deferred,
                runs=not self.typing,
            )
        )

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self.add(alias.name, node, relative=False)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        base = node.module or ""
        if node.level:
            package = self.package.split(".")
            if node.level - 1 >= len(package):
                self.errors.append(
                    f"{self.shown}:{node.lineno}: {self.module}: relative import beyond the "
                    "top-level package"
                )
                return
            anchor = ".".join(package[: len(package) - (node.level - 1)])
            base = f"{anchor}.{base}" if base else anchor
        for alias in node.names:  # `from pkg import module` imports the module
            submodule = f"{base}.{alias.name}"
            self.add(submodule if submodule in self.modules else base, node, bool(node.level))


def find_imports(package_dir: Path) -> tuple[list[Import], list[str]]:
    """Every import in the package in `package_dir`, and the ones that cannot be resolved.
    rcsgen's own are read once (mutmut's trampolined copy is ~100 MB of source)."""
    imports, errors = _rcsgen_imports() if package_dir == PACKAGE else _read_imports(package_dir)
    return list(imports), list(errors)


@functools.cache
def _rcsgen_imports() -> tuple[list[Import], list[str]]:
    return _read_imports(PACKAGE)


def _read_imports(package_dir: Path) -> tuple[list[Import], list[str]]:
    modules = module_names(package_dir)
    found: list[Import] = []
    errors: list[str] = []
    for module, path in modules.items():
        shown = path.relative_to(package_dir.parent).as_posix()
        finder = _Finder(module, path.name == "__init__.py", shown, set(modules))
        finder.visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)))
        found += finder.found
        errors += finder.errors
    return found, errors


def rule_violations(package_dir: Path, trampolines: bool = False) -> list[str]:
    """Every import that breaks the layer rules, as `file:line: source -> target: why`;
    `trampolines`: accept mutmut's trampoline import (in its working copy only)."""
    imports, problems = find_imports(package_dir)
    for module, path in module_names(package_dir).items():
        if layer_of(module) not in ALLOWED:
            shown = path.relative_to(package_dir.parent).as_posix()
            problems.append(f"{shown}: {module} is in no layer; give it one in layer_of")
    for imp in imports:
        source = layer_of(imp.source)
        target = layer_of(imp.target)
        top = imp.target.split(".")[0]
        if source not in ALLOWED:
            continue  # reported above
        if trampolines and imp.target == TRAMPOLINE:
            continue
        if target is None and top in sys.stdlib_module_names:
            continue
        if target is None and (imp.source, top) in OPTIONAL and not imp.eager:
            continue
        if target is None:
            third_party = ALLOWED[source][1]
            if top not in third_party:
                allowed = ", ".join(sorted(third_party))
                what = f"only {allowed} besides" if allowed else "nothing but"
                problems.append(
                    f"{imp}: {source} imports {what} the standard library ({WHY[source]})"
                )
        elif target == "cli" and source not in ("main", "cli"):
            problems.append(f"{imp}: only rcsgen/__main__.py imports rcsgen.cli")
        elif target not in ALLOWED[source][0]:
            problems.append(f"{imp}: {source} must not import {target} ({WHY[source]})")
        elif source == "runtime" and not imp.relative:
            problems.append(
                f"{imp}: the runtime imports itself by relative import only (it runs as "
                "`<system>.rcs` in generated packages)"
            )
    return problems


def import_cycles(package_dir: Path, deferred: bool = False) -> list[str]:
    """Each cycle among the package's modules through imports that run at import time (with
    `deferred`, through imports inside functions too: two modules that need each other
    whenever one is used, which is one module split in two)."""
    imports, _ = find_imports(package_dir)
    modules = set(module_names(package_dir))
    edges: dict[str, dict[str, Import]] = {}
    for imp in imports:
        if (imp.eager or (deferred and imp.runs)) and imp.target in modules:
            edges.setdefault(imp.source, {}).setdefault(imp.target, imp)
    cycles = []
    for component in _strongly_connected(modules, edges):
        start = min(component)
        if len(component) > 1 or start in edges.get(start, {}):
            path = _cycle_through(start, component, edges)
            steps = "\n    ".join(str(edges[a][b]) for a, b in zip(path, path[1:], strict=False))
            cycles.append(f"import cycle {' -> '.join(path)}:\n    {steps}")
    return cycles


def _strongly_connected(nodes: set[str], edges: dict[str, dict[str, Import]]) -> list[set[str]]:
    """Tarjan's strongly connected components."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[set[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for succ in sorted(edges.get(node, {})):
            if succ not in index:
                visit(succ)
                low[node] = min(low[node], low[succ])
            elif succ in stack:
                low[node] = min(low[node], index[succ])
        if low[node] == index[node]:
            component = set()
            while True:
                member = stack.pop()
                component.add(member)
                if member == node:
                    break
            found.append(component)

    for node in sorted(nodes):
        if node not in index:
            visit(node)
    return found


def _cycle_through(
    start: str, component: set[str], edges: dict[str, dict[str, Import]]
) -> list[str]:
    """A shortest path start -> ... -> start inside one strongly connected component."""
    previous: dict[str, str] = {}
    frontier = [start]
    while frontier:
        following = []
        for node in frontier:
            for succ in sorted(edges.get(node, {})):
                if succ == start:
                    path = [start]
                    while node != start:
                        path.append(node)
                        node = previous[node]
                    return [start, *reversed(path[1:]), start]
                if succ in component and succ not in previous:
                    previous[succ] = node
                    following.append(succ)
        frontier = following
    raise AssertionError(f"no cycle through {start}")


# ---------------------------------------------------------------- rcsgen itself


def test_rcsgen_keeps_the_import_rules() -> None:
    problems = rule_violations(PACKAGE, trampolines=under_mutmut())
    assert not problems, "imports that break the layer rules:\n" + "\n".join(problems)


def test_rcsgen_has_no_import_cycles() -> None:
    cycles = import_cycles(PACKAGE)
    assert not cycles, "\n".join(cycles)


def test_rcsgen_has_no_import_cycles_through_functions() -> None:
    """An import inside a function still makes its module need the other: a cycle through
    one is two modules that are one (issue 25: scenario and scenario_check were)."""
    cycles = import_cycles(PACKAGE, deferred=True)
    assert not cycles, "\n".join(cycles)


def test_what_runs_every_cycle_never_imports_the_operators_tools() -> None:
    """rcsgen/runtime/ at its top is what runs every cycle; runtime/operate/ (launcher,
    console, command contract, deployment, start-up) is built on it, never the reverse, not
    even inside a function: a cycle's code cannot come to depend on the console."""
    imports, _ = find_imports(PACKAGE)
    wrong = [
        str(imp)
        for imp in imports
        if imp.source.startswith("rcsgen.runtime")
        and not imp.source.startswith("rcsgen.runtime.operate")
        and imp.target.startswith("rcsgen.runtime.operate")
    ]
    assert not wrong, "\n".join(wrong)
    operate = {m for m in module_names(PACKAGE) if m.startswith("rcsgen.runtime.operate.")}
    assert {m.rpartition(".")[2] for m in operate} >= {"launcher", "ctl", "command"}


def test_the_package_keeps_its_complexity_budget() -> None:
    """At most 1.5 % of rcsgen's functions at cyclomatic complexity 20 or more, none above
    30 (radon, as `make complexity` reports it): a function past it is split where its
    parts have names (a verb each, a section each, a check each)."""
    from complexity_report import BUDGET_MAX, BUDGET_SHARE, HIGH, measure

    every = measure()
    high = [f"{m.complexity} {m.path} {m.name}" for m in every if m.complexity >= HIGH]
    assert len(high) <= BUDGET_SHARE * len(every), "\n".join(high)
    assert every[0].complexity <= BUDGET_MAX, high[0]


def test_the_compiler_keeps_its_complexity_budget() -> None:
    """At most 1.5 % of the compiler's functions at cyclomatic complexity 20 or more, none
    above 30 (radon, as `make complexity` reports it): split along the stages' seams."""
    from complexity_report import BUDGET_MAX, BUDGET_SHARE, HIGH, measure, part

    compiler = part(measure(), "rcsgen/compiler/")
    high = [f"{m.complexity} {m.path} {m.name}" for m in compiler if m.complexity >= HIGH]
    assert len(high) <= BUDGET_SHARE * len(compiler), "\n".join(high)
    assert compiler[0].complexity <= BUDGET_MAX, high[0]


def test_every_module_is_seen() -> None:
    """The walk covers every layer, so an empty result above means something."""
    imports, _ = find_imports(PACKAGE)
    layers = {layer_of(m) for m in module_names(PACKAGE)}
    assert layers >= {"runtime", "compiler", "tools", "api", "cli", "main"}
    assert any(
        i.source == "rcsgen.compiler.back_end.emit" and i.target == "rcsgen.runtime"
        for i in imports
    )


# ---------------------------------------------------------------- the checker, on fake trees


def write_tree(root: Path, files: dict[str, str]) -> Path:
    """A fake `rcsgen` package under `root`; every directory gets an __init__.py."""
    for rel, text in files.items():
        path = root / "rcsgen" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    for directory in [root / "rcsgen", *(root / "rcsgen").rglob("*")]:
        if directory.is_dir() and not (directory / "__init__.py").exists():
            (directory / "__init__.py").write_text("", encoding="utf-8")
    return root / "rcsgen"


def test_checker_reports_compiler_importing_tools(tmp_path: Path) -> None:
    package = write_tree(
        tmp_path,
        {"compiler/x.py": "import os\n\nfrom ..tools import harness\n", "tools/harness.py": ""},
    )
    [problem] = rule_violations(package)
    assert problem.startswith("rcsgen/compiler/x.py:3: rcsgen.compiler.x -> rcsgen.tools.harness:")
    assert "compiler must not import tools" in problem


FORBIDDEN = {
    "runtime imports the compiler": (
        {"runtime/loop.py": "from ..compiler import emit\n", "compiler/emit.py": ""},
        "rcsgen/runtime/loop.py:1: rcsgen.runtime.loop -> rcsgen.compiler.emit: runtime must not",
    ),
    "runtime imports itself absolutely": (
        {"runtime/loop.py": "from rcsgen.runtime import block\n", "runtime/block.py": ""},
        "rcsgen.runtime.loop -> rcsgen.runtime.block: the runtime imports itself by relative",
    ),
    "runtime imports a third-party package": (
        {"runtime/loop.py": "import yaml\n"},
        "rcsgen.runtime.loop -> yaml: runtime imports nothing but the standard library",
    ),
    "compiler imports click": (
        {"compiler/emit.py": "def f():\n    import click\n"},
        "rcsgen/compiler/emit.py:2: rcsgen.compiler.emit -> click: compiler imports only jinja2, "
        "jsonschema, ruff, yaml besides",
    ),
    "compiler imports the cli under TYPE_CHECKING": (
        {"compiler/emit.py": "if TYPE_CHECKING:\n    from .. import cli\n", "cli.py": ""},
        "rcsgen.compiler.emit -> rcsgen.cli: only rcsgen/__main__.py imports rcsgen.cli",
    ),
    "compiler imports the public API": (
        {"compiler/emit.py": "from rcsgen import __version__\n"},
        "rcsgen.compiler.emit -> rcsgen: compiler must not import api",
    ),
    "tools import the cli": (
        {"tools/harness.py": "from ..cli import main\n", "cli.py": ""},
        "rcsgen.tools.harness -> rcsgen.cli: only rcsgen/__main__.py imports rcsgen.cli",
    ),
    "the package imports the cli": (
        {"__init__.py": "def main():\n    from rcsgen.cli import main\n", "cli.py": ""},
        "rcsgen/__init__.py:2: rcsgen -> rcsgen.cli: only rcsgen/__main__.py",
    ),
    "a relative import leaves the package": (
        {"compiler/emit.py": "from ... import x\n"},
        "rcsgen/compiler/emit.py:1: rcsgen.compiler.emit: relative import beyond the top-level",
    ),
    "a module outside every layer": (
        {"extra.py": ""},
        "rcsgen/extra.py: rcsgen.extra is in no layer",
    ),
}


@pytest.mark.parametrize("case", sorted(FORBIDDEN))
def test_checker_reports(tmp_path: Path, case: str) -> None:
    files, expected = FORBIDDEN[case]
    problems = rule_violations(write_tree(tmp_path, files))
    assert len(problems) == 1 and expected in problems[0], problems


def test_checker_accepts_trampolines_only_when_told(tmp_path: Path) -> None:
    """mutmut's trampoline import, as it writes it into every mutated module: an error in
    the normal suite, accepted only when the suite runs under mutmut."""
    trampoline = (
        "from __future__ import annotations\n\nimport os\n\n"
        "from mutmut.mutation.trampoline import wrap_in_trampoline as _mutmut_mutated, "
        "MutantDict\n"
    )
    package = write_tree(tmp_path, {"runtime/loop.py": trampoline, "compiler/emit.py": trampoline})
    problems = rule_violations(package)
    assert len(problems) == 4  # two names imported in each file
    assert sorted(set(problems)) == [
        "rcsgen/compiler/emit.py:5: rcsgen.compiler.emit -> mutmut.mutation.trampoline: compiler "
        "imports only jinja2, jsonschema, ruff, yaml besides the standard library (it is the "
        "library under the tools and the command line)",
        "rcsgen/runtime/loop.py:5: rcsgen.runtime.loop -> mutmut.mutation.trampoline: runtime "
        "imports nothing but the standard library (it is copied into every generated package, "
        "which needs nothing but Python)",
    ]
    assert rule_violations(package, trampolines=True) == []
    # anything else of mutmut's stays an error even then
    (package / "runtime" / "loop.py").write_text("import mutmut\n", encoding="utf-8")
    assert len(rule_violations(package, trampolines=True)) == 1


def test_checker_allows_what_the_rules_allow(tmp_path: Path) -> None:
    package = write_tree(
        tmp_path,
        {
            "__init__.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from .tools.harness import Harness\n",
            "__main__.py": "from rcsgen.cli import main\n",
            "api.py": "from .compiler import emit\n",
            "cli.py": "import click\n\nfrom . import api\nfrom .tools import harness\n",
            "compiler/emit.py": "import jinja2\n\nfrom ..runtime import contract\n"
            "from . import ir\n",
            "compiler/ir.py": "from ..runtime.contract import STATUS\n",
            "tools/harness.py": "from ..compiler import emit\n",
            "runtime/loop.py": "import time\n\nfrom . import contract\nfrom .block import Block\n",
            "runtime/block.py": "from __future__ import annotations\n",
            "runtime/contract.py": "import struct\n",
        },
    )
    assert rule_violations(package) == []
    assert import_cycles(package) == []


def test_checker_reports_a_cycle(tmp_path: Path) -> None:
    package = write_tree(
        tmp_path,
        {
            "compiler/a.py": "from . import b\n",
            "compiler/b.py": "import os\nfrom .c import thing\n",
            "compiler/c.py": "from rcsgen.compiler import a\n",
        },
    )
    [cycle] = import_cycles(package)
    assert cycle.startswith(
        "import cycle rcsgen.compiler.a -> rcsgen.compiler.b -> rcsgen.compiler.c -> "
        "rcsgen.compiler.a"
    )
    assert "rcsgen/compiler/b.py:2: rcsgen.compiler.b -> rcsgen.compiler.c" in cycle


def test_deferred_imports_make_no_cycle(tmp_path: Path) -> None:
    package = write_tree(
        tmp_path,
        {
            "compiler/a.py": "from . import b\n",
            "compiler/b.py": "def f():\n    from . import a\n",
            "compiler/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from . import d\n",
            "compiler/d.py": "from . import c\n",
        },
    )
    assert import_cycles(package) == []


def test_imports_inside_functions_make_a_cycle_of_their_own(tmp_path: Path) -> None:
    """`from . import b` in a function of a, `from . import a` at b's top: not a cycle when
    a is imported, a cycle of need all the same; a TYPE_CHECKING import never runs."""
    package = write_tree(
        tmp_path,
        {
            "tools/a.py": "def f():\n    from . import b\n",
            "tools/b.py": "from . import a\n",
            "tools/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from . import d\n",
            "tools/d.py": "from . import c\n",
        },
    )
    assert import_cycles(package) == []
    [cycle] = import_cycles(package, deferred=True)
    assert cycle.startswith("import cycle rcsgen.tools.a -> rcsgen.tools.b -> rcsgen.tools.a")


def test_walk_finds_imports_everywhere(tmp_path: Path) -> None:
    package = write_tree(
        tmp_path,
        {
            "compiler/a.py": "class A:\n    import json\n\n"
            "def f(x=None):\n    import csv\n"
            "try:\n    import tomllib\nexcept ImportError:\n    pass\n"
        },
    )
    found = {(i.target, i.eager) for i in _imports_of(package, "rcsgen.compiler.a")}
    assert found == {("json", True), ("csv", False), ("tomllib", True)}


def _imports_of(package: Path, module: str) -> Iterator[Import]:
    imports, _ = find_imports(package)
    return (i for i in imports if i.source == module)


def test_the_command_line_starts_without_the_heavy_libraries() -> None:
    """`rcsgen validate` must answer in about a second (issue 24): importing the command line
    (what every command pays before it runs) loads no template engine, no JSON Schema
    library, no solver and no terminal UI; the commands that need one import it themselves.
    Checked in a fresh interpreter, as a user starts the command."""
    import subprocess

    heavy = ("jinja2", "jsonschema", "z3", "textual", "ruff")
    probe = f"import sys, rcsgen.cli; print(*(m for m in {heavy!r} if m in sys.modules))"
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=120
    )
    assert done.stdout.split() == [], f"imported at start-up: {done.stdout.strip()}"
