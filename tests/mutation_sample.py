"""`make mutate-sample`: a stratified, seeded sample of one-line mutants of the compiler and the
tools, each tried against the tests that run its line, in bounded time on a shared machine.

A full mutmut run (`make mutate`) over the compiler and the tools is hours on two shared cores.
This script measures the same thing on a deterministic sample, and says how sure the figure is:

1. **Which tests run which line.** The fast tiers (test_files(): the unit tier, the quick
   fuzz files, the system files in SYSTEM and the single system tests in SYSTEM_TESTS) run
   once in process with a line tracer on every file of rcsgen/compiler and rcsgen/tools
   (this file is also the pytest plugin that records it: `-p mutation_sample`). A line run
   at import (a table, a default) belongs to every test that runs its module.
   For each line it keeps the tests that ran it, and each test's own time.
2. **The mutants.** Every module's one-line mutants, from its syntax tree (OPERATORS: an
   arithmetic or comparison operator swapped, `and`/`or` swapped, a `not` or a unary minus
   dropped, a number plus one, True/False flipped, a string changed, a returned value replaced
   by None, `break`/`continue` swapped); docstrings, annotations and f-strings are left alone.
3. **The sample.** Per module, a fixed-seed random sample (proportional to the module's
   mutants, at least MIN_PER_MODULE), so the same sources give the same mutants every run.
4. **Each mutant** is written into a scratch copy of the tracked tree (never this worktree),
   and the tests that ran its lines (fastest first, up to BUDGET seconds of their own time;
   then the fastest test of each other file that runs them, up to REACH in all)
   run in a fresh pytest with `-x`: a failure, an error, a crash or a timeout kills it. A
   mutant no test reaches counts as surviving. Mutants listed in
   tests/mutation_sample_equivalent.txt (under the key printed) are counted apart and left
   out of the score.

The summary prints, per module, package (compiler, tools) and overall: mutants in the module,
tried, killed, survived, equivalent and the score with a 95 % interval (Wilson's for a module;
for a package and overall, the stratified estimate weighting each module by its mutants, with
the finite-population correction). The score is a lower bound: only the lines' own tests in
the fast tiers (and the system files in SYSTEM) are tried, the processes tier never; a survivor may
still be killed there. Survivors are listed with their key, so a test can be written or an
equivalence argued.

Arguments: `--per-module N` / `--total N` (sample size), `--seed S`, `--budget SECONDS`,
`--only TEXT` (modules whose path contains TEXT), `--list` (print the sample, run nothing),
`--reach SECONDS` (after the budget's tests, the fastest test of each other file that runs
the mutant's lines, up to this in all; 0: the budget alone), `--carry COMMIT` (with
`--cover`: the kept map was made on the modules as at COMMIT; its lines are carried across
the edits since, a changed line dropped),
`--cover FILE` (keep the map of which tests run which line there, and reuse it while the
modules and the tests are unchanged), `--add TESTFILE` (repeatable, with `--cover`: the map
kept, only these test files traced again and merged in, after tests were added or changed;
a changed module still wants the whole run), `--json FILE` (write every result), `--minutes M`
(stop trying mutants after M minutes: they are tried in one seeded order across the modules,
so what was tried is still a sample of each), `--keys FILE` (try only these keys, e.g. the
survivors of a run after new tests).
"""

from __future__ import annotations

import argparse
import ast
import functools
import hashlib
import json
import math
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
EQUIVALENT = HERE / "mutation_sample_equivalent.txt"
PACKAGES = ("rcsgen/compiler", "rcsgen/tools")
# The tests tried: the unit and fuzz tiers (but the long fuzzers), and the system tier's files
# that are the only ones reaching a module in process (prove, its seeds, the trace and mine
# views, the scenarios; the monitor's screen against a system run in the test process; the
# soft PLC, validate --connect and a scenario's device bench in process). The processes tier
# never: there the monitor, softplc and io_connect run in other processes, where no tracer
# sees them (test_monitor_screen and test_softplc run their logic in process instead).
SLOW = ("test_fuzz", "test_differential", "test_prove_differential")
SYSTEM = (
    "test_prove",
    "test_prove_seeds",
    "test_prove_numbers",  # prove/numbers.py: only these two reach it
    "test_prove_properties",  # checks/properties.py, tools/prove_smv.py
    "test_trace_view",
    "test_mine_view",
    "test_sea_view",  # traces/sea.py, station.py and player.py: only these reach them
    "test_station_view",
    "test_scenarios",
    "test_monitor_screen",
    "test_softplc",
)
# Single system tests that alone reach a tool's lines in process (the scenario runner's scripted
# person, a stand-in simulated, plans, results and console answers in a trace line; the
# harness under them): golden runs in one process, each compared byte for byte with its trace.
GOLDEN = "test_golden.py::test_scenario_matches_its_golden_trace"
SYSTEM_TESTS = tuple(
    f"{GOLDEN}[{name}-one-process]"
    for name in (
        "cr_simulated",
        "inspection/console_refusal",
        "inspection/lot_replanned",
        "inspection/operator_refuses",
        "inspection/slow_operator",
        "platoon/spot_report",
        "submarine/ood_refuses",
    )
)
TEST_ENV = {"EXPR_EXAMPLES": "200", "DIFF_EXAMPLES": "5"}
SEED = 25
TOTAL = 200
MIN_PER_MODULE = 3
BUDGET = 30.0  # seconds of the selected tests' own time per mutant, fastest first
REACH = 120.0  # then each other file's fastest test of the line, up to this in all
COVER_ENV = "RCSGEN_MUTATION_COVER"

SWAPS: dict[type, type] = {
    ast.Add: ast.Sub,
    ast.Sub: ast.Add,
    ast.Mult: ast.Div,
    ast.Div: ast.Mult,
    ast.FloorDiv: ast.Div,
    ast.Mod: ast.FloorDiv,
    ast.Pow: ast.Mult,
    ast.BitOr: ast.BitAnd,
    ast.BitAnd: ast.BitOr,
    ast.BitXor: ast.BitOr,
    ast.LShift: ast.RShift,
    ast.RShift: ast.LShift,
    ast.Lt: ast.LtE,
    ast.LtE: ast.Lt,
    ast.Gt: ast.GtE,
    ast.GtE: ast.Gt,
    ast.Eq: ast.NotEq,
    ast.NotEq: ast.Eq,
    ast.Is: ast.IsNot,
    ast.IsNot: ast.Is,
    ast.In: ast.NotIn,
    ast.NotIn: ast.In,
    ast.And: ast.Or,
    ast.Or: ast.And,
}
OPERATORS = (
    "binop",
    "augassign",
    "compare",
    "boolop",
    "not",
    "neg",
    "number",
    "bool",
    "string",
    "return",
    "break",
)


# --- 1. which tests run which line -------------------------------------------------------------


class _Recorder:
    """The pytest plugin of the coverage run (active when COVER_ENV names the output file)."""

    def __init__(self, out: Path) -> None:
        self.out = out
        roots = tuple(str(REPO / p) + os.sep for p in PACKAGES)
        self.files = {str(p): str(p.relative_to(REPO)) for p in _modules(roots)}
        self.lines: dict[str, dict[int, set[int]]] = defaultdict(lambda: defaultdict(set))
        self.tests: list[list[Any]] = []  # [nodeid, seconds, passed]
        self.hit: set[tuple[str, int]] = set()

    def _global(self, frame: Any, event: str, arg: Any) -> Any:
        rel = self.files.get(frame.f_code.co_filename)
        if rel is None:
            return None
        hit = self.hit

        def local(frame: Any, event: str, arg: Any) -> Any:
            if event == "line":
                hit.add((rel, frame.f_lineno))
            return local

        hit.add((rel, frame.f_lineno))
        return local

    def pytest_runtest_protocol(self, item: Any, nextitem: Any) -> None:
        self.hit = set()
        self.started = time.perf_counter()
        self.passed = True
        sys.settrace(self._global)

    def pytest_runtest_logreport(self, report: Any) -> None:
        if report.failed:
            self.passed = False
        if report.when == "teardown":
            sys.settrace(None)
            index = len(self.tests)
            self.tests.append([report.nodeid, time.perf_counter() - self.started, self.passed])
            if self.passed:
                for rel, line in self.hit:
                    self.lines[rel][line].add(index)

    def pytest_sessionfinish(self, session: Any) -> None:
        sys.settrace(None)
        lines = {rel: {str(n): sorted(t) for n, t in by.items()} for rel, by in self.lines.items()}
        self.out.write_text(json.dumps({"tests": self.tests, "lines": lines}))


def pytest_configure(config: Any) -> None:
    if os.environ.get(COVER_ENV):
        config.pluginmanager.register(_Recorder(Path(os.environ[COVER_ENV])), "mutation_cover")


def _modules(roots: tuple[str, ...]) -> list[Path]:
    return sorted(p.resolve() for root in roots for p in Path(root).rglob("*.py"))


def cover(tree: Path, out: Path, files: list[str] | None = None) -> None:
    """The coverage run, in the scratch copy `tree`; the map is written to `out`. `files`:
    these test files only (test_files(), the whole fast selection, else)."""
    env = _env(tree) | {COVER_ENV: str(out)}
    cmd = [
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-p",
        "no:cacheprovider",
        "-p",
        "no:xdist",
        "-p",
        "mutation_sample",
        *(files if files is not None else test_files()),
    ]
    started = time.monotonic()
    done = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    # the whole output beside the map: why a test failed under the tracer, not one line of it
    out.with_suffix(".log").write_text(done.stdout + done.stderr)
    lines = done.stdout.strip().splitlines()
    print(f"coverage run: {time.monotonic() - started:.0f} s, {lines[-1] if lines else ''}")
    for line in lines:  # a test failing under the tracer maps no line: said, not hidden
        if line.startswith(("FAILED", "ERROR")):
            print(f"  {line}")
    sys.stdout.flush()
    if not out.exists():
        sys.exit(f"the coverage run wrote no map:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")


def merged(base: dict[str, Any], added: dict[str, Any], files: list[str]) -> dict[str, Any]:
    """`base` with the tests of `files` (traced again, or new) taken from `added`: a map
    kept current after a few test files changed, without the whole coverage run again."""
    # a file's tests all go; a test named alone (file::name) goes with its parameters
    names = tuple(f"{f}[" if "::" in f else f"{f}::" for f in files)
    alone = {f for f in files if "::" in f}
    keep = [
        i for i, t in enumerate(base["tests"]) if not t[0].startswith(names) and t[0] not in alone
    ]
    renumber = {old: new for new, old in enumerate(keep)}
    tests = [base["tests"][i] for i in keep]
    shift = len(tests)
    tests += added["tests"]
    lines: dict[str, dict[str, list[int]]] = {}
    for rel in sorted(set(base["lines"]) | set(added["lines"])):
        by: dict[str, set[int]] = defaultdict(set)
        for n, ids in base["lines"].get(rel, {}).items():
            by[n].update(renumber[i] for i in ids if i in renumber)
        for n, ids in added["lines"].get(rel, {}).items():
            by[n].update(i + shift for i in ids)
        lines[rel] = {n: sorted(ids) for n, ids in by.items() if ids}
    return {"tests": tests, "lines": lines}


def carried(cover_map: dict[str, Any], edits: dict[str, tuple[str, str]]) -> dict[str, Any]:
    """`cover_map` carried across small edits of modules (`edits`: path -> (the text the map
    was made on, the text now)): each mapped line moves to its place in the new text where
    difflib finds it unchanged; a changed line is dropped (what runs it now is mapped by
    tracing its tests again with --add). Minutes of tracing saved for a one-line fix."""
    import difflib

    lines = dict(cover_map["lines"])
    for rel, (before, after) in edits.items():
        moves: dict[str, str] = {}
        old, new = before.splitlines(), after.splitlines()
        matcher = difflib.SequenceMatcher(None, old, new, autojunk=False)
        for tag, i1, i2, j1, _ in matcher.get_opcodes():
            if tag == "equal":
                moves.update((str(i1 + k + 1), str(j1 + k + 1)) for k in range(i2 - i1))
        by = lines.get(rel, {})
        lines[rel] = {moves[n]: ids for n, ids in by.items() if n in moves}
        print(f"carried {rel}: {len(lines[rel])} of {len(by)} mapped lines")
    return cover_map | {"lines": lines}


def needs_carrying(cover_map: dict[str, Any], commit: str, digest: str) -> bool:
    """Whether a kept map is to be carried from `commit` to the sources now. A map carried
    before (and written back) is not carried twice: on the same sources it is current, on
    others its lines are no longer where `commit` had them, and it is refused (MapError)."""
    if "carried" not in cover_map:
        return True
    if cover_map.get("digest") == digest:
        return False
    raise MapError(
        f"the kept map was carried from {cover_map['carried']} already and the sources "
        f"changed since: carry a fresh copy of the map made on {commit}"
    )


class MapError(Exception):
    """A kept coverage map that cannot be used as asked."""


def edits_since(commit: str) -> dict[str, tuple[str, str]]:
    """Every mutated module whose text differs from its text at `commit`: (then, now)."""
    found = {}
    for path in _modules(tuple(str(REPO / p) for p in PACKAGES)):
        rel = str(path.relative_to(REPO))
        then = subprocess.run(
            ["git", "show", f"{commit}:{rel}"], cwd=REPO, capture_output=True, text=True
        )
        now = path.read_text()
        if then.returncode == 0 and then.stdout != now:
            found[rel] = (then.stdout, now)
    return found


def test_files() -> list[str]:
    from conftest import TIERS

    names = [n for tier in ("unit", "fuzz") for n in TIERS[tier][1] if n not in SLOW]
    files = [f"tests/{n}.py" for n in sorted(names + list(SYSTEM))]
    return files + [f"tests/{t}" for t in SYSTEM_TESTS]


def sources_digest() -> str:
    """What a coverage map depends on: the modules mutated and the tests."""
    paths = _modules(tuple(str(REPO / p) for p in PACKAGES)) + sorted(HERE.rglob("*.py"))
    h = hashlib.sha256()
    for path in paths:
        h.update(str(path.relative_to(REPO)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def _env(tree: Path) -> dict[str, str]:
    env = dict(os.environ) | TEST_ENV
    env["PYTHONPATH"] = os.pathsep.join([str(tree), str(tree / "tests")])
    env.pop("PYTEST_ADDOPTS", None)
    return env


# --- 2. the mutants ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Mutant:
    path: str  # relative to the repository
    line: int
    last: int  # last line of the mutated node
    kind: str
    old: str
    new: str
    start: tuple[int, int]  # (line, byte column) of the replaced text
    end: tuple[int, int]
    toplevel: bool = False  # run when the module is imported, before any test

    @property
    def module(self) -> str:
        return self.path.removesuffix(".py").replace("/", ".")

    def key(self, n: int) -> str:
        """Its name in tests/mutation_sample_equivalent.txt: path:line:old->new, #n if repeated."""
        base = f"{self.path}:{self.line}:{_short(self.old)}->{_short(self.new)}"
        return base if n == 0 else f"{base}#{n}"


def _short(text: str) -> str:
    one = " ".join(text.split())
    return one if len(one) <= 60 else one[:57] + "..."


def _skipped(tree: ast.Module) -> set[int]:
    """ids of nodes no mutant may touch: docstrings, annotations, f-strings, TYPE_CHECKING."""
    skip: set[int] = set()

    def all_of(node: ast.AST | None) -> None:
        if node is not None:
            skip.update(id(n) for n in ast.walk(node))

    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(body, list)
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)
        ):
            all_of(body[0])
        if isinstance(node, (ast.arg, ast.AnnAssign)):
            all_of(node.annotation)
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            all_of(node.returns)
        if isinstance(node, ast.JoinedStr):
            all_of(node)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            all_of(node)
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
        ):
            all_of(node)
    return skip


def _in_functions(tree: ast.Module) -> set[int]:
    """ids of nodes that run when a function is called (not when its module is imported:
    a default value or a decorator runs at import)."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for statement in node.body:
                inside.update(id(n) for n in ast.walk(statement))
        elif isinstance(node, ast.Lambda):
            inside.update(id(n) for n in ast.walk(node.body))
    return inside


def _swapped(node: ast.AST) -> ast.AST | None:
    import copy

    new = copy.copy(node)
    if isinstance(node, (ast.BinOp, ast.AugAssign, ast.BoolOp)):
        to = SWAPS.get(type(node.op))
        if to is None:
            return None
        new.op = to()  # type: ignore[attr-defined]
        return new
    return None


def mutants_of(path: Path, root: Path = REPO) -> list[Mutant]:
    """Every mutant of one module, in the order of their place in it."""
    source = path.read_bytes()
    tree = ast.parse(source)
    lines = source.split(b"\n")
    skip = _skipped(tree)
    inside = _in_functions(tree)
    rel = str(path.relative_to(root))
    found: list[Mutant] = []

    def segment(node: ast.AST) -> str:
        return ast.get_source_segment(source.decode(), node) or ""

    def add(
        kind: str,
        node: ast.AST,
        new: str,
        start: tuple[int, int] | None = None,
        end: tuple[int, int] | None = None,
        old: str | None = None,
    ) -> None:
        s = start or (node.lineno, node.col_offset)  # type: ignore[attr-defined]
        e = end or (node.end_lineno, node.end_col_offset)  # type: ignore[attr-defined]
        text = old if old is not None else _slice(lines, s, e)
        if text != new:
            found.append(Mutant(rel, s[0], e[0], kind, text, new, s, e, id(node) not in inside))

    for node in ast.walk(tree):
        if id(node) in skip or not hasattr(node, "lineno"):
            continue
        if isinstance(node, ast.BinOp) and (new := _swapped(node)) is not None:
            add("binop", node, f"({ast.unparse(new)})")
        elif isinstance(node, ast.AugAssign):
            if (new := _swapped(node)) is not None:
                add("augassign", node, ast.unparse(new))
            add("augassign", node, ast.unparse(ast.Assign([node.target], node.value, lineno=0)))
        elif isinstance(node, ast.BoolOp) and (new := _swapped(node)) is not None:
            add("boolop", node, f"({ast.unparse(new)})")
        elif isinstance(node, ast.Compare):
            for i, op in enumerate(node.ops):
                to = SWAPS.get(type(op))
                if to is not None:
                    ops = list(node.ops)
                    ops[i] = to()
                    add(
                        "compare",
                        node,
                        f"({ast.unparse(ast.Compare(node.left, ops, node.comparators))})",
                    )
        elif isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.Not, ast.USub)):
            kind = "not" if isinstance(node.op, ast.Not) else "neg"
            add(kind, node, f"({ast.unparse(node.operand)})")
        elif isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, bool):
                add("bool", node, repr(not value))
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                add("number", node, repr(value + 1))
            elif isinstance(value, str):
                add("string", node, repr(f"XX{value}XX"))
        elif (
            isinstance(node, ast.Return)
            and node.value is not None
            and not (isinstance(node.value, ast.Constant) and node.value.value is None)
        ):
            add("return", node.value, "None")
        elif isinstance(node, ast.Break):
            add("break", node, "continue")
        elif isinstance(node, ast.Continue):
            add("break", node, "break")
    found.sort(key=lambda m: (m.start, m.kind, m.new))
    return found


def compiles(m: Mutant, root: Path = REPO) -> bool:
    try:
        compile(apply((root / m.path).read_bytes(), m), m.path, "exec")
    except SyntaxError:
        return False
    return True


def _slice(lines: list[bytes], start: tuple[int, int], end: tuple[int, int]) -> str:
    (l1, c1), (l2, c2) = start, end
    if l1 == l2:
        return lines[l1 - 1][c1:c2].decode()
    parts = [lines[l1 - 1][c1:], *lines[l1 : l2 - 1], lines[l2 - 1][:c2]]
    return b"\n".join(parts).decode()


def apply(source: bytes, m: Mutant) -> bytes:
    lines = source.split(b"\n")
    (l1, c1), (l2, c2) = m.start, m.end
    head = b"\n".join(lines[: l1 - 1] + [lines[l1 - 1][:c1]])
    tail = b"\n".join([lines[l2 - 1][c2:]] + lines[l2:])
    return head + m.new.encode() + tail


# --- 3. the sample -----------------------------------------------------------------------------


def sample(
    every: dict[str, list[Mutant]],
    total: int,
    least: int,
    seed: int,
    per_module: int | None,
    root: Path = REPO,
) -> dict[str, list[Mutant]]:
    """A fixed-seed sample per module: `per_module` each, or proportional to `total`."""
    population = sum(len(ms) for ms in every.values()) or 1
    chosen = {}
    for path, ms in every.items():
        want = (
            per_module
            if per_module is not None
            else max(least, round(total * len(ms) / population))
        )
        digest = hashlib.sha256(f"{seed}:{path}".encode()).digest()
        rng = random.Random(int.from_bytes(digest[:8], "big"))
        order = rng.sample(ms, len(ms))
        picked: list[Mutant] = []
        for m in order:  # the first `want` of a fixed shuffle that are valid Python
            if len(picked) == want:
                break
            if compiles(m, root):
                picked.append(m)
        chosen[path] = sorted(picked, key=lambda m: m.start)
    return chosen


# --- 4. each mutant ----------------------------------------------------------------------------


@dataclass
class Result:
    path: str
    key: str
    kind: str
    outcome: str  # killed, survived, no tests, equivalent
    tests: int
    seconds: float
    detail: str = ""
    budgeted: tuple[str, ...] = ()  # the budget's tests, tried first (then --reach's)
    failed: str = ""  # the test that killed it (none: a timeout, or collection broke)


def scratch(tree: Path) -> None:
    """A copy of the tracked tree into `tree` (the mutants are written there, never here)."""
    files = (
        subprocess.run(
            ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
            cwd=REPO,
            capture_output=True,
            check=True,
        )
        .stdout.decode()
        .split("\0")
    )
    for name in filter(None, files):
        src, dst = REPO / name, tree / name
        if src.is_symlink():  # as a link (specs/miner_hil's specs, hooks and maps are)
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.symlink(os.readlink(src), dst)
        elif src.is_file():
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst)


def importers(module: str, root: Path = REPO) -> set[str]:
    """The test files that import `module` (a path, `rcsgen/tools/monitor.py`) by name:
    `import rcsgen.tools.monitor`, `from rcsgen.tools.monitor import ...`, `from
    rcsgen.tools import monitor` (in any function too). Its own tests: they read its tables
    and defaults, which run at import, so the line tracer cannot tell them apart."""
    dotted = module.removesuffix(".py").replace("/", ".").removesuffix(".__init__")
    parent, _, name = dotted.rpartition(".")
    return {
        file
        for file, imported in _imports(root).items()
        if dotted in imported or (parent, name) in imported
    }


@functools.cache
def _imports(root: Path) -> dict[str, set[Any]]:
    """Each test file's imports: the dotted names it imports or imports from, and for each
    `from A import b`, (A, b). Read once a run."""
    found: dict[str, set[Any]] = {}
    for path in sorted((root / "tests").glob("test_*.py")):
        names: set[Any] = set()
        for node in ast.walk(ast.parse(path.read_bytes())):
            if isinstance(node, ast.Import):
                names.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                names.add(node.module)
                names.update((node.module, alias.name) for alias in node.names)
        found[str(path.relative_to(root))] = names
    return found


def selection(
    m: Mutant,
    cover_map: dict[str, Any],
    budget: float,
    reach: float = 0.0,
    own: set[str] | frozenset[str] = frozenset(),
) -> list[str]:
    """The tests a mutant is tried against: those that run its lines, fastest first, until
    their own times add up to `budget`. A line run at import (a table, a default) is run
    by every test that uses the module: those that run most of the module come first (the
    tests of the module itself), then the fastest.

    Then, up to `reach` seconds in all, the fastest test of each file that runs the lines and
    has none chosen yet (fastest first): one slow traced test (a prove, 5-10 s traced) no
    longer fills the budget alone and leaves the other files' tests of the line untried.
    What the budget chose comes first and stays: a superset, so no kill is lost.

    A line run at import is the module's: its tables and defaults are read by the tests of
    the files that import it (`own`, from `importers`), which the tracer sees running no
    line of it, or only some. After all the above, each test of those files not chosen yet
    (the quickest file first, its tests in the order they run), up to `reach` in all."""
    tests = cover_map["tests"]
    by_line = cover_map["lines"].get(m.path, {})
    if m.toplevel:
        breadth: dict[int, int] = defaultdict(int)
        for ids_of_line in by_line.values():
            for t in ids_of_line:
                breadth[t] += 1
        ids = sorted(breadth, key=lambda t: (-breadth[t], tests[t][1], t))
    else:
        lines = [str(n) for n in range(m.line, m.last + 1)]
        found = {t for n in lines for t in by_line.get(n, ())}
        # tests named after a word of the mutated text first (`echo_timeouts` ->
        # test_invalid_case[e244-echo-timeout-...], "E216" -> ...[e216-...]), then the
        # fastest of each test file before the second fastest of any (a file is one
        # aspect: the corpus's hundred quick cases do not crowd out the one file that
        # compares the generated code)
        # and within a rank, the files that run most of the module first (its own tests)
        words = _words(m.old)
        rank: dict[int, int] = {}
        seen: dict[str, int] = defaultdict(int)
        for t in sorted(found, key=lambda t: (tests[t][1], t)):
            module = tests[t][0].partition("::")[0]
            rank[t], seen[module] = seen[module], seen[module] + 1
        runs: dict[str, set[str]] = defaultdict(set)
        for n, ids_of_line in by_line.items():
            for t in ids_of_line:
                runs[tests[t][0].partition("::")[0]].add(n)

        def order(t: int) -> tuple[int, int, int, float, int]:
            file = tests[t][0].partition("::")[0]
            named = len(words & _words(tests[t][0]))
            return (-named, rank[t], -len(runs[file]), tests[t][1], t)

        ids = sorted(found, key=order)
    chosen, spent = [], 0.0
    for t in ids:  # in that order, each that still fits in the budget
        if spent + tests[t][1] > budget:
            continue
        chosen.append(tests[t][0])
        spent += tests[t][1]
    if ids and tests[ids[0]][0] not in chosen:
        # the first in that order is alone over the budget (a prove of the shipped systems
        # that runs most of the module): it still runs, as it ran alone before, but after
        # the quick tests that fit, which it no longer leaves untried - a superset
        chosen.append(tests[ids[0]][0])
        spent += tests[ids[0]][1]
    files = {name.partition("::")[0] for name in chosen}
    first: dict[str, int] = {}
    for t in sorted(ids, key=lambda t: (tests[t][1], t)):
        first.setdefault(tests[t][0].partition("::")[0], t)
    for file, t in sorted(first.items(), key=lambda ft: (tests[ft[1]][1], ft[1])):
        if file not in files and spent + tests[t][1] <= reach:
            chosen.append(tests[t][0])
            spent += tests[t][1]
    if m.toplevel and own:
        of_file: dict[str, list[int]] = defaultdict(list)
        for t, (name, *_) in enumerate(tests):
            if name.partition("::")[0] in own:
                of_file[name.partition("::")[0]].append(t)
        taken = set(chosen)
        for file in sorted(of_file, key=lambda f: (sum(tests[t][1] for t in of_file[f]), f)):
            for t in of_file[file]:
                if tests[t][0] not in taken and spent + tests[t][1] <= reach:
                    chosen.append(tests[t][0])
                    spent += tests[t][1]
    return chosen


def _words(text: str) -> set[str]:
    """The lower-case words of a text or a test id, split at anything not a letter or digit,
    and their singulars: `echo_timeouts` -> {echo, timeouts, timeout}."""
    import re

    found = {w for w in re.split(r"[^a-z0-9]+", text.lower()) if len(w) >= 3}
    return found | {w[:-1] for w in found if w.endswith("s") and len(w) > 3}


def _run_bounded(cmd: list[str], tree: Path) -> subprocess.CompletedProcess[str] | None:
    """pytest in a session of its own, at most TIMEOUT seconds (None: it took longer). Past
    it, the whole session is killed (a system a test launched too, not pytest alone) and
    the segments the suite names after that pytest's pid are removed (their fixtures never
    ran): a timeout leaves no process and nothing in /dev/shm."""
    with subprocess.Popen(
        cmd,
        cwd=tree,
        env=_env(tree),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    ) as proc:
        try:
            out, err = proc.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            shm = Path("/dev/shm")
            for left in shm.glob(f"rcsgen_*_{proc.pid}_*") if shm.is_dir() else ():
                left.unlink(missing_ok=True)
            return None
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def attempt(
    tree: Path, m: Mutant, key: str, nodeids: list[str], n: int, budgeted: int = 0
) -> Result:
    """`m` tried against `nodeids` (the first `budgeted` of them the budget's)."""
    if not nodeids:
        return Result(m.path, key, m.kind, "no tests", 0, 0.0)
    target = tree / m.path
    original = target.read_bytes()
    stat = target.stat()
    started = time.monotonic()
    lines: list[str] = []
    try:
        target.write_bytes(apply(original, m))
        # a distinct mtime, so no cached bytecode of the original (or another mutant) is used
        os.utime(target, ns=(stat.st_atime_ns, stat.st_mtime_ns + (n + 1) * 1_000_000_000))
        cmd = [
            sys.executable,
            "-m",
            "pytest",
            "-x",
            "-q",
            "-p",
            "no:cacheprovider",
            "-p",
            "no:xdist",
            "--no-header",
            "-o",
            "addopts=",
            *nodeids,
        ]
        done = _run_bounded(cmd, tree)
        if done is None:
            code, detail = -1, f"timeout after {TIMEOUT:.0f} s"
        else:
            code = done.returncode
            lines = done.stdout.strip().splitlines()
            detail = lines[-1] if lines else ""
            if code == 4 and "while loading conftest" in done.stdout + done.stderr:
                code, detail = 2, "the mutant breaks the import of the package"
    finally:
        target.write_bytes(original)
        os.utime(target, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    seconds = time.monotonic() - started
    if code == 0:
        outcome = "survived"
    elif code in (-1, 1, 2, 3):  # a test failed, or collection broke, or pytest crashed
        outcome = "killed"
    else:  # 4: usage error, 5: no tests ran -- a fault of this script, not a kill
        outcome = "error"
    words = [line.split() for line in lines]
    failed = next((w[1] for w in words if len(w) > 1 and w[0] in ("FAILED", "ERROR")), "")
    return Result(
        m.path,
        key,
        m.kind,
        outcome,
        len(nodeids),
        seconds,
        detail,
        tuple(nodeids[:budgeted]),
        failed,
    )


TIMEOUT = 120.0


# --- the summary -------------------------------------------------------------------------------


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    if n == 0:
        return (0.0, 1.0)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


def stratified(rows: list[tuple[int, int, int]]) -> tuple[float, float, float] | None:
    """rows: (mutants in the module, tried, killed) -> (estimate, low, high) at 95 %."""
    rows = [r for r in rows if r[1] > 0]
    population = sum(r[0] for r in rows)
    if not population:
        return None
    estimate = sum(big * k / n for big, n, k in rows) / population
    variance = 0.0
    for big, n, k in rows:
        # p from (k + 1) / (n + 2) in the variance: a module whose few mutants all died
        # still carries its sampling error (k / n = 1 would claim none)
        w, p = big / population, (k + 1) / (n + 2)
        fpc = (big - n) / (big - 1) if big > 1 else 0.0
        variance += w * w * fpc * p * (1 - p) / max(n - 1, 1)
    half = 1.96 * math.sqrt(variance)
    return (estimate, max(0.0, estimate - half), min(1.0, estimate + half))


def read_equivalent() -> dict[str, str]:
    found = {}
    for line in EQUIVALENT.read_text().splitlines():
        name, _, reason = line.partition("  #")
        if name.strip() and not name.startswith("#"):
            found[name.strip()] = reason.strip()
    return found


def summary(every: dict[str, list[Mutant]], results: list[Result]) -> str:
    """The table: per module, then per package and overall. `unreached` mutants (no test
    tried runs their lines) count as survivors in the score, as mutmut counts them; the
    last column is the score of the reached ones alone."""
    by_path: dict[str, list[Result]] = defaultdict(list)
    for r in results:
        by_path[r.path].append(r)
    out = [
        "| module | mutants | tried | killed | survived | unreached | equivalent "
        "| score (95 % interval) | of reached |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    strata: dict[str, list[tuple[int, int, int]]] = defaultdict(list)
    totals: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0, 0, 0, 0])
    for path in sorted(every):
        rs = by_path.get(path, [])
        killed = sum(r.outcome == "killed" for r in rs)
        survived = sum(r.outcome == "survived" for r in rs)
        unreached = sum(r.outcome == "no tests" for r in rs)
        equivalent = sum(r.outcome == "equivalent" for r in rs)
        tried = killed + survived + unreached
        package = "compiler" if path.startswith("rcsgen/compiler/") else "tools"
        row = (len(every[path]), tried, killed, survived, unreached, equivalent)
        for name in (package, "all"):
            strata[name].append((len(every[path]), tried, killed))
            totals[name] = [a + b for a, b in zip(totals[name], row, strict=True)]
        score = f"{100 * killed / tried:.0f} % ({_pct(wilson(killed, tried))})" if tried else "—"
        reached = f"{100 * killed / (tried - unreached):.0f} %" if tried > unreached else "—"
        module = path.removeprefix("rcsgen/").removesuffix(".py")
        cells = " | ".join(str(v) for v in row)
        out.append(f"| `{module}` | {cells} | {score} | {reached} |")
    for name in ("compiler", "tools", "all"):
        big, tried, killed, survived, unreached, equivalent = totals[name]
        est = stratified(strata[name])
        score = "—" if est is None else f"**{100 * est[0]:.1f} %** ({_pct(est[1:])})"
        reached = f"{100 * killed / (tried - unreached):.1f} %" if tried > unreached else "—"
        cells = " | ".join(str(v) for v in totals[name])
        out.append(f"| **{name}** | {cells} | {score}; raw {killed}/{tried} | {reached} |")
    return "\n".join(out)


def attribution(results: list[Result]) -> str:
    """Which part of each mutant's selection killed it: the budget's tests (run first, so
    `--reach 0`, the selection before, kills it alike) or only the tests --reach added."""
    killed = [r for r in results if r.outcome == "killed"]
    by_budget = [r for r in killed if r.failed and r.failed in r.budgeted]
    by_reach = [r for r in killed if r.failed and r not in by_budget]
    untold = len(killed) - len(by_budget) - len(by_reach)
    return (
        f"of {len(killed)} killed: {len(by_budget)} by the budget's tests (as --reach 0 would), "
        f"{len(by_reach)} only by the tests --reach added, {untold} by a timeout or a broken "
        "collection (either way)"
        + "".join(f"\n  by --reach: {r.key}  ({r.failed})" for r in by_reach)
    )


def _pct(interval: tuple[float, ...]) -> str:
    return f"{100 * interval[0]:.0f}–{100 * interval[1]:.0f} %"


def main(argv: list[str] | None = None) -> int:
    global TIMEOUT
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--total", type=int, default=TOTAL)
    parser.add_argument("--per-module", type=int)
    parser.add_argument("--least", type=int, default=MIN_PER_MODULE)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--budget", type=float, default=BUDGET)
    parser.add_argument(
        "--reach",
        type=float,
        default=REACH,
        help="then the fastest test of each other file that runs the line, up to this in all"
        " (0: the budget alone, as before)",
    )
    parser.add_argument("--timeout", type=float, default=TIMEOUT)
    parser.add_argument("--only", action="append", default=[])
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--minutes", type=float, help="stop trying mutants after this long")
    parser.add_argument("--keys", type=Path, help="try only the sampled mutants listed here")
    parser.add_argument("--cover", type=Path)
    parser.add_argument(
        "--add",
        action="append",
        default=[],
        metavar="TESTFILE",
        help="with --cover: trace only this test file (new or changed) into the kept map",
    )
    parser.add_argument(
        "--carry",
        metavar="COMMIT",
        help="with --cover: the kept map was made on the modules as at COMMIT; carry its lines"
        " across their edits since (with --add for the tests of the changed lines)",
    )
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    TIMEOUT = args.timeout

    roots = tuple(str(REPO / p) for p in PACKAGES)
    every = {}
    for path in _modules(roots):
        rel = str(path.relative_to(REPO))
        if args.only and not any(o in rel for o in args.only):
            continue
        ms = mutants_of(path)
        if ms:
            every[rel] = ms
    chosen = sample(every, args.total, args.least, args.seed, args.per_module)
    keys: dict[Mutant, str] = {}
    for ms in every.values():
        seen: dict[str, int] = defaultdict(int)
        for m in ms:
            base = m.key(0)
            keys[m] = m.key(seen[base])
            seen[base] += 1
    count = sum(len(ms) for ms in chosen.values())
    print(
        f"{sum(len(ms) for ms in every.values())} mutants in {len(every)} modules; "
        f"{count} sampled (seed {args.seed})",
        flush=True,
    )
    if args.list:
        for ms in chosen.values():
            for m in ms:
                print(f"{keys[m]}  [{m.kind}]")
        return 0

    started = time.monotonic()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit("stopped by SIGTERM"))  # cleans up
    tree = Path(tempfile.mkdtemp(prefix="rcsgen-mutate-"))
    try:
        scratch(tree)
        cover_file = args.cover or tree / "cover.json"
        digest = sources_digest()
        cover_map = json.loads(cover_file.read_text()) if cover_file.exists() else {}
        try:
            carry = bool(args.carry and cover_map) and needs_carrying(cover_map, args.carry, digest)
        except MapError as error:
            print(f"mutation_sample: {cover_file}: {error}", file=sys.stderr)
            return 2
        if carry:
            # the map was made on the modules as at this commit
            cover_map = carried(cover_map, edits_since(args.carry)) | {"carried": args.carry}
            if not args.add:
                cover_map["digest"] = digest
                cover_file.write_text(json.dumps(cover_map))
        if args.add and cover_map and cover_map.get("digest") != digest:
            # a few test files changed or were added: only they are traced again
            added_file = cover_file.with_suffix(".added.json")  # its .log kept beside it
            cover(tree, added_file, args.add)
            added = json.loads(added_file.read_text())
            cover_map = merged(cover_map, added, args.add) | {"digest": digest}
            cover_file.write_text(json.dumps(cover_map))
        if cover_map.get("digest") != digest:  # none yet, or the sources or tests changed
            cover(tree, cover_file)
            cover_map = json.loads(cover_file.read_text()) | {"digest": digest}
            cover_file.write_text(json.dumps(cover_map))
        equivalent = read_equivalent()
        # one seeded order across the modules: a run stopped early (--minutes, SIGTERM)
        # has tried a sample of every module, not the first modules whole
        order = [m for ms in chosen.values() for m in ms]
        random.Random(args.seed).shuffle(order)
        if args.keys:  # e.g. the survivors of a run, tried again after new tests
            wanted = {line.strip() for line in args.keys.read_text().splitlines()}
            order = [m for m in order if keys[m] in wanted]
        deadline = started + 60 * args.minutes if args.minutes else None
        results: list[Result] = []
        try:
            for done, m in enumerate(order, 1):
                if deadline is not None and time.monotonic() > deadline:
                    print(f"\nstopped at the {args.minutes:.0f}-minute limit", flush=True)
                    break
                key = keys[m]
                if key in equivalent:
                    why = equivalent[key]
                    results.append(Result(m.path, key, m.kind, "equivalent", 0, 0.0, why))
                    continue
                own = importers(m.path) if m.toplevel else set()
                chosen = selection(m, cover_map, args.budget, args.reach, own)
                budgeted = len(selection(m, cover_map, args.budget))  # chosen's first ones
                r = attempt(tree, m, key, chosen, done, budgeted)
                results.append(r)
                if r.outcome == "killed":
                    print(".", end="", flush=True)
                else:
                    print(f"\n{r.outcome}: {key}  [{m.kind}] {r.detail}", flush=True)
        except (KeyboardInterrupt, SystemExit):
            print("\nstopped: the summary covers the mutants tried so far", flush=True)
        print(flush=True)
    finally:
        shutil.rmtree(tree, ignore_errors=True)
    elapsed = time.monotonic() - started
    if args.json:
        args.json.write_text(json.dumps([asdict(r) for r in results], indent=1))
    print(summary(every, results))
    print("\n" + attribution(results))
    print(
        f"\n{len(results)} of {len(order)} sampled mutants in {elapsed / 60:.1f} min; a lower "
        "bound: only the fast "
        "tiers' tests that run each mutant's lines were tried."
    )
    for outcome in ("survived", "no tests", "error"):
        rs = [r for r in results if r.outcome == outcome]
        if rs:
            print(f"\n{outcome} ({len(rs)}):")
            for r in rs:
                print(f"  {r.key}  [{r.kind}] {r.detail}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
