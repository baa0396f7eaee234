"""`make mutate` in the Python processes the tests start (see tests/mutation_runtime.py).

The mutate venv imports this module at every start (a `.pth` file the Makefile installs;
not with `python -S`). Outside a mutation session it does nothing. In one, the session's
environment tells it what to do, and the processes the tests start inherit that:

- RCSGEN_MUTATION_RUNTIME (every session): the runtime the session tests. When the package
  `rcsgen.runtime` is imported, its resources (what a build copies into `<system>/rcs/`)
  point there, as they do in the test process: `python -m rcsgen build/run` started by a
  test builds the same copies as the test process.
- RCSGEN_MUTATION_PROBE (mutmut's stats session only): a directory. mutmut finds the tests
  that reach a function by recording the trampolines that run in the test process; the
  runtime's copies in generated packages have none. Each copied runtime module
  (`<package>.rcs.<module>`, a file whose first line says it was copied from
  rcsgen/runtime) is compiled with one call at the top of every top-level function and
  method, the functions mutmut mutates; the first call of each function in a process
  appends its mutmut name (`rcsgen.runtime.<module>.x_<function>` or
  `...xǁ<Class>ǁ<method>`) to `<directory>/hits-<pid>`, which the test process reads after
  each test. The test process loads this file itself for the same probe.

Standard library only, and nothing that `import rcsgen` would not load anyway (no `typing`:
tests/test_api.py counts what a bare `import rcsgen` loads): the finders are duck-typed.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import sys
from collections.abc import Sequence
from importlib.machinery import ModuleSpec, PathFinder, SourceFileLoader
from types import CodeType, ModuleType

TYPE_CHECKING = False  # as rcsgen/__init__.py: typing itself stays unloaded
if TYPE_CHECKING:
    from typing import Any

PROBE_ENV = "RCSGEN_MUTATION_PROBE"  # the directory the hits go to
RUNTIME_ENV = "RCSGEN_MUTATION_RUNTIME"  # the runtime builds copy
COPY = re.compile(r"(?:[A-Za-z_]\w*\.)+rcs\.([A-Za-z_]\w*)")
MARKER = "its runtime, copied from rcsgen/runtime/"  # emit's header on every copied file
PROBE = "__rcsgen_probe__"
SEPARATOR = "ǁ"  # mutmut's, between class and method in a mangled name

_seen: set[str] = set()
_pid = 0


def hit(key: str) -> None:
    """Record the first call of the function named `key` in this process (a line appended
    and the file closed again: a process may end at any moment, and leaves nothing open)."""
    global _pid
    if os.getpid() != _pid:  # a forked child records its own calls
        _pid = os.getpid()
        _seen.clear()
    if key in _seen:
        return
    _seen.add(key)
    directory = os.environ.get(PROBE_ENV)
    if not directory:
        return
    try:
        with open(os.path.join(directory, f"hits-{_pid}"), "a", encoding="utf-8") as out:
            out.write(key + "\n")
    except OSError:
        pass  # the session is over: nobody reads the hits any more


def instrument(source: bytes, module: str, filename: str) -> CodeType:
    """`source` compiled with a probe call at the top of each top-level function and method."""
    tree = ast.parse(source, filename)
    prefix = f"rcsgen.runtime.{module}."
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            _probe(node, prefix + f"x_{node.name}")
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    _probe(item, prefix + f"x{SEPARATOR}{node.name}{SEPARATOR}{item.name}")
    return compile(tree, filename, "exec", dont_inherit=True)


def _probe(function: ast.FunctionDef | ast.AsyncFunctionDef, key: str) -> None:
    body = function.body
    first = body[0]
    docstring = (
        isinstance(first, ast.Expr)
        and isinstance(first.value, ast.Constant)
        and isinstance(first.value.value, str)
    )
    call = ast.Expr(ast.Call(ast.Name(PROBE, ast.Load()), [ast.Constant(key)], []))
    for node in ast.walk(call):
        ast.copy_location(node, first)
    body.insert(1 if docstring else 0, call)


class _ProbeLoader(SourceFileLoader):
    """Compiles a runtime copy with its probes; never from or to a bytecode cache."""

    def get_code(self, fullname: str) -> CodeType:
        match = COPY.fullmatch(fullname)
        assert match is not None
        return instrument(self.get_data(self.path), match.group(1), self.path)

    def exec_module(self, module: ModuleType) -> None:
        module.__dict__[PROBE] = hit
        super().exec_module(module)


class ProbeFinder:
    """Finds the runtime copies of generated packages and loads them with probes."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None = None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if not COPY.fullmatch(fullname):
            return None
        spec = PathFinder.find_spec(fullname, path)
        if spec is None or not spec.origin or not spec.origin.endswith(".py"):
            return None
        try:
            with open(spec.origin, encoding="utf-8") as file:
                header = file.readline()
        except (OSError, UnicodeDecodeError):
            return None
        if MARKER not in header:
            return None
        spec.loader = _ProbeLoader(fullname, spec.origin)
        return spec


def runtime_spec(directory: str) -> ModuleSpec:
    """A spec of `rcsgen.runtime` whose resources are the files in `directory`."""
    spec = importlib.util.spec_from_file_location(
        "rcsgen.runtime",
        os.path.join(directory, "__init__.py"),
        submodule_search_locations=[directory],
    )
    assert spec is not None
    return spec


class _RuntimeLoader:
    """Loads `rcsgen.runtime` as usual, then points its resources at the session's runtime."""

    def __init__(self, loader: Any, directory: str) -> None:
        self.loader, self.directory = loader, directory

    def create_module(self, spec: ModuleSpec) -> ModuleType | None:
        return self.loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self.loader.exec_module(module)
        module.__spec__ = runtime_spec(self.directory)


class RuntimeFinder:
    """Finds `rcsgen.runtime` and gives it `_RuntimeLoader`."""

    def __init__(self, directory: str) -> None:
        self.directory = directory

    def find_spec(
        self, fullname: str, path: Sequence[str] | None = None, target: ModuleType | None = None
    ) -> ModuleSpec | None:
        if fullname != "rcsgen.runtime":
            return None
        spec = PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return None
        spec.loader = _RuntimeLoader(spec.loader, self.directory)
        return spec


def install_probe() -> None:
    """Probe the runtime copies imported from now on."""
    if not any(isinstance(f, ProbeFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, ProbeFinder())


def uninstall_probe() -> None:
    sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, ProbeFinder)]


def install() -> None:
    """What the environment asks for, in a process a test started."""
    if os.environ.get(PROBE_ENV):
        install_probe()
    runtime = os.environ.get(RUNTIME_ENV)
    if runtime and "rcsgen.runtime" not in sys.modules:
        sys.meta_path.insert(0, RuntimeFinder(runtime))


if __name__ == "mutation_hooks":  # imported by the venv's .pth file at start-up
    install()
