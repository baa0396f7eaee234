"""How `make mutate` reaches rcsgen/runtime: a pytest plugin that tests/conftest.py loads only
when mutmut runs the suite (`under_mutmut()`); the normal suite never sees it.

mutmut 3 rewrites every function in its working copy of the package (`mutants/`) into a
trampoline that calls the original or one mutant according to the environment variable
MUTANT_UNDER_TEST, and learns which tests reach a function from the trampolines that run
during a first "stats" session of the suite. That is enough for the compiler and the tools.
The runtime also runs as the verbatim copy every generated package carries (`<system>/rcs/`),
imported in the test process under the package's name and in the processes the tests start.
A trampoline copied there never calls a mutant (it compares the mutant's module,
`rcsgen.runtime.block`, with its own, `<system>.rcs.block`), records nothing outside the test
process, and its 15 MB would cost every started process seconds of compiling. So under mutmut
the copies stay plain Python, and each session gives them the runtime it tests:

- a session for a runtime mutant (MUTANT_UNDER_TEST=`rcsgen.runtime.<module>.<name>__mutmut_<n>`)
  gets the checkout's rcsgen/runtime with that one function replaced by the mutant (read back
  from mutmut's working copy, formatted as a build formats it); every other session gets the
  checkout's rcsgen/runtime unchanged;
- every build in the session copies that runtime (the resources of the package
  `rcsgen.runtime`, which the emitter reads, point at it), and the working copy's committed
  generated/*/rcs/ are rewritten to hold it, so the tests that run generated/ directly and
  `rcsgen build --check` agree with the builds; generated packages imported by an earlier
  session of the same process are forgotten;
- in the stats session a probe reports the first call of each runtime function in a copy,
  and each test is added to the tests of the functions it reached once its teardown is over
  (a system a fixture stops still counts for the test that started it).

tests/mutation_site/mutation_hooks.py does the same in every Python process the tests
start: the mutate venv imports it at start-up, and the session's environment says which
runtime the builds copy (`python -m rcsgen` started by a test builds what the test process
builds) and, in the stats session, where the probes write.

A test that fails is run once more before its failure counts: the suite's multi-process tests
wait on conditions with generous bounds, but a mutation campaign shares the machine for hours,
and one starved run must neither stop mutmut's first sessions (which must pass whole) nor kill
a mutant. A mutant that only sometimes makes a test fail may survive: the score errs low.

The in-process `rcsgen.runtime` (what tests and the compiler import directly) is mutmut's
trampolined copy, as for the compiler. A `python -m rcsgen` a test starts in the working copy
runs the trampolined package too (elsewhere the mutate venv's editable install, unmutated).
Sessions of runtime mutants rewrite the shared generated/ copies: they hold an exclusive lock
(`mutants/.rcsgen-mutation.lock`) and every other session a shared one, so a run with several
children stays correct; `make mutate` runs one child.
"""

from __future__ import annotations

import fcntl
import fnmatch
import os
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import IO, Any

import pytest

HERE = Path(__file__).resolve().parent
REPO = HERE.parent  # mutmut's working copy `mutants/` when under mutmut
CHECKOUT = REPO.parent  # ... inside the checkout it was copied from
RUNTIME_PREFIX = "rcsgen.runtime."
# RCSGEN_MUTATE_CONTROL=1: leave the runtime copies as mutmut alone leaves them (the control of
# an experiment: a runtime mutant killed only through the copies then survives).
CONTROL_ENV = "RCSGEN_MUTATE_CONTROL"
MARKER = "its runtime, copied from rcsgen/runtime/"  # the first line of every copied file


def under_mutmut() -> bool:
    """True when mutmut runs this suite: its variable is set and the suite is its copy in
    `mutants/` of a checkout (the trampolined package is importable only there)."""
    return (
        "MUTANT_UNDER_TEST" in os.environ
        and REPO.name == "mutants"
        and (CHECKOUT / "rcsgen" / "runtime").is_dir()
    )


def runtime_mutant(name: str) -> bool:
    """Whether `name` (MUTANT_UNDER_TEST) is a mutant of the runtime."""
    return name.startswith(RUNTIME_PREFIX) and "__mutmut_" in name


@contextmanager
def _cwd(path: Path) -> Iterator[None]:
    old = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


def apply_mutant(name: str, source: str) -> str:
    """`source` (the checkout's module of mutant `name`) with the mutated function in place of
    the original, read back from mutmut's working copy."""
    import libcst as cst
    from mutmut.mutation.diff_apply import (
        read_functions_from_index,
        read_mutant_function,
        read_mutants_module,
    )
    from mutmut.utils.format_utils import orig_function_and_class_names_from_key

    rel = Path(*name.rpartition(".")[0].split(".")).with_suffix(".py")
    with _cwd(CHECKOUT):  # mutmut reads `mutants/<path>` relative to the checkout
        found = read_functions_from_index(name, rel)
        mutant = found[1] if found else read_mutant_function(read_mutants_module(rel), name)
    function, owner = orig_function_and_class_names_from_key(name)
    module = cst.parse_module(source)
    body: Any = module.body
    if owner is not None:
        [cls] = [n for n in body if isinstance(n, cst.ClassDef) and n.name.value == owner]
        body = cls.body.body
    [original] = [n for n in body if isinstance(n, cst.FunctionDef) and n.name.value == function]
    return module.deep_replace(original, mutant.with_changes(name=cst.Name(function))).code  # type: ignore[union-attr]


def materialise(name: str, scratch: Path) -> Path:
    """A copy of the checkout's runtime in `scratch` with mutant `name` applied; its path."""
    from rcsgen.compiler import emit  # the unmutated compiler: a runtime mutant is active

    runtime = scratch / "runtime"
    shutil.copytree(
        CHECKOUT / "rcsgen" / "runtime", runtime, ignore=shutil.ignore_patterns("__pycache__")
    )
    file = name.rpartition(".")[0].rpartition(".")[2] + ".py"
    mutated = apply_mutant(name, (runtime / file).read_text(encoding="utf-8"))
    (runtime / file).write_text(emit.format_files({file: mutated})[file], encoding="utf-8")
    return runtime


def sync_generated(runtime: Path, generated: Path) -> list[Path]:
    """Make the runtime copies of the packages in `generated` hold `runtime`'s files (each
    under its own first line, the build's header); the files rewritten."""
    written = []
    for rcs in sorted(generated.glob("*/rcs")):
        before = len(written)
        for source in sorted(runtime.glob("*.py")):
            copy = rcs / source.name
            if not copy.is_file():
                continue
            text = copy.read_text(encoding="utf-8")
            header = text.partition("\n")[0] + "\n"
            if MARKER not in header:
                raise AssertionError(f"{copy}: no runtime header on its first line")
            wanted = header + source.read_text(encoding="utf-8")
            if text != wanted:
                copy.write_text(wanted, encoding="utf-8")
                written.append(copy)
        if len(written) > before:  # a rewrite in the same second and size: no old bytecode
            shutil.rmtree(rcs / "__pycache__", ignore_errors=True)
    return written


def forget_generated_packages() -> None:
    """Drop from sys.modules every generated package (one with an `rcs` subpackage) an
    earlier session of this process imported: the next import reads this session's copy."""
    tops = {name.rpartition(".")[0] for name in sys.modules if name.endswith(".rcs")}
    for name in list(sys.modules):
        if name in tops or any(name.startswith(top + ".") for top in tops):
            del sys.modules[name]


def site() -> ModuleType:
    """tests/mutation_site/mutation_hooks.py, which the mutate venv imports at start-up."""
    module = sys.modules.get("mutation_hooks")
    if module is None:
        raise pytest.UsageError(
            "this venv does not import tests/mutation_site/mutation_hooks.py at start-up: "
            "run mutmut from the one `make mutate` installs (.venv-mutate)"
        )
    return module


class MutationSession:
    """What one pytest session under mutmut changes, and undoes at its end."""

    def __init__(self) -> None:
        self.mutant = os.environ.get("MUTANT_UNDER_TEST", "")
        self.lock: IO[str] | None = None
        self.scratch: Path | None = None
        self.saved_spec: Any = None
        self.saved_env: dict[str, str | None] = {}
        self.probe: ModuleType | None = None
        self.read: dict[Path, int] = {}  # hits file -> bytes already read

    def describe(self) -> str:
        if os.environ.get(CONTROL_ENV):
            return "mutation testing, control run: the runtime copies are left as they are"
        if runtime_mutant(self.mutant):
            what = f"the runtime with {self.mutant}"
        else:
            what = "the unmutated runtime"
        probe = "; probing the runtime copies for mutmut's stats" if self.probe else ""
        return (
            f"mutation testing (MUTANT_UNDER_TEST={self.mutant!r}): generated packages copy "
            f"{what}{probe}; the architecture test accepts mutmut's trampoline imports; "
            f"a failing test runs {RETRIES} more time(s) before it counts"
            + (f"; only the tests in {os.environ[TESTS_ENV]}" if os.environ.get(TESTS_ENV) else "")
        )

    def start(self) -> None:
        import rcsgen.runtime

        if os.environ.get(CONTROL_ENV):  # as mutmut alone: the copies are not touched
            return
        self.lock = open(REPO / ".rcsgen-mutation.lock", "a", encoding="utf-8")
        exclusive = runtime_mutant(self.mutant)
        fcntl.flock(self.lock, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        if exclusive:
            self.scratch = Path(tempfile.mkdtemp(prefix="rcsgen-mutant-"))
            runtime = materialise(self.mutant, self.scratch)
        else:
            runtime = CHECKOUT / "rcsgen" / "runtime"
        helper = site()
        self.saved_spec = rcsgen.runtime.__spec__
        rcsgen.runtime.__spec__ = helper.runtime_spec(str(runtime))
        self._set_env(helper.RUNTIME_ENV, str(runtime))  # for `python -m rcsgen` in tests
        sync_generated(runtime, REPO / "generated")
        forget_generated_packages()
        self._set_env(helper.PROBE_ENV, None)
        if self.mutant == "stats":
            if self.scratch is None:
                self.scratch = Path(tempfile.mkdtemp(prefix="rcsgen-probe-"))
            self._set_env(helper.PROBE_ENV, str(self.scratch))
            self.probe = helper
            helper.install_probe()

    def _set_env(self, name: str, value: str | None) -> None:
        self.saved_env.setdefault(name, os.environ.get(name))
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value

    def hits(self) -> set[str]:
        """The runtime functions the probed processes reached since the last call."""
        found: set[str] = set()
        if self.scratch is None or self.probe is None:
            return found
        for path in sorted(self.scratch.glob("hits-*")):
            with open(path, "rb") as file:
                file.seek(self.read.get(path, 0))
                data = file.read()
            complete = data[: data.rfind(b"\n") + 1]  # a line still being written waits
            self.read[path] = self.read.get(path, 0) + len(complete)
            found.update(complete.decode("utf-8").split())
        return found

    def finish(self) -> None:
        import rcsgen.runtime

        if self.probe is not None:
            self.probe.uninstall_probe()
        for name, value in self.saved_env.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        if self.saved_spec is not None:
            rcsgen.runtime.__spec__ = self.saved_spec
        if self.scratch is not None:
            shutil.rmtree(self.scratch, ignore_errors=True)
        if self.lock is not None:
            self.lock.close()


_session: MutationSession | None = None


# ---------------------------------------------------------------- pytest hooks (conftest.py)


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    global _session
    _session = MutationSession()
    _session.start()


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session: pytest.Session) -> None:
    global _session
    if _session is not None:
        _session.finish()
        _session = None


def pytest_report_header(config: pytest.Config) -> str:
    return _session.describe() if _session else "mutation testing"


RETRIES = 1  # a failing test runs once more before its failure counts
TESTS_ENV = "RCSGEN_MUTATE_TESTS"  # `make mutate MUTATE_TESTS=...`: test files to run (globs)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """With MUTATE_TESTS, mutants are tried against those test files only (a quick campaign
    on one module: its score is then a lower bound). mutmut's stats session and its listing
    of the tests are left whole, so its map of which tests reach which function stays whole."""
    wanted = os.environ.get(TESTS_ENV, "").split()
    if not wanted or os.environ.get("MUTANT_UNDER_TEST") in ("stats", "list_all_tests"):
        return
    keep = [i for i in items if any(fnmatch.fnmatch(i.nodeid.split("::")[0], w) for w in wanted)]
    if len(keep) < len(items):
        config.hook.pytest_deselected(items=[i for i in items if i not in keep])
        items[:] = keep


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> bool:
    """Run a test, and once more when it fails; only the last run is reported."""
    from _pytest.runner import runtestprotocol

    item.ihook.pytest_runtest_logstart(nodeid=item.nodeid, location=item.location)
    for attempt in range(RETRIES + 1):
        reports = runtestprotocol(item, nextitem=nextitem, log=False)
        if attempt == RETRIES or not any(report.failed for report in reports):
            break
    for report in reports:
        item.ihook.pytest_runtest_logreport(report=report)
    item.ihook.pytest_runtest_logfinish(nodeid=item.nodeid, location=item.location)
    return True


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item: pytest.Item) -> Iterator[None]:
    yield
    if _session is None or _session.probe is None:
        return
    from mutmut.state import state
    from mutmut.utils.format_utils import strip_prefix

    test = strip_prefix(item.nodeid, prefix="mutants/")
    for function in _session.hits():
        state().tests_by_mangled_function_name[function].add(test)
