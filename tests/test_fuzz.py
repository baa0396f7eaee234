"""Property-based fuzzing of the front end: a mutated spec is a clean success or located
diagnostics, never a traceback.

Hypothesis mutates valid systems (specs/miner, tests/fixtures/semantics/chain and the
corpus base tests/cases/valid/tiny) at the YAML text level (delete, duplicate or re-indent
a line, swap characters, insert random characters, keywords, YAML syntax and injection
payloads, replace a word) and at the data level (drop a key, rename a key such as a state,
change a value's type, replace an expression with token soup, duplicate or drop a file).
For every mutated system:

- `compile_paths` returns; every diagnostic names a file inside the spec directory, with
  line >= 1 and col >= 1;
- when it reports no error, every generated module renders, formats and compiles;
- for every BUILD_EVERY-th example, `rcsgen build` runs through the CLI in-process on a
  copy whose output directory holds a previous build: a failed build leaves it byte-identical.

The test runs FUZZ_EXAMPLES examples (80 by default, derandomized for CI);
`make fuzz` runs 5,000 with fresh randomness and prints a summary.
"""

from __future__ import annotations

import os
import random
import shutil
import tempfile
import time
from collections import Counter
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rcsgen.cli import main
from rcsgen.compiler.back_end import emit
from rcsgen.compiler.frontend import compile_paths

REPO = Path(__file__).resolve().parent.parent
TINY = REPO / "tests" / "cases" / "valid" / "tiny"
CHAIN = REPO / "tests" / "fixtures" / "semantics" / "chain"
MINER = REPO / "specs" / "miner"  # 20 times slower to check than the others: drawn less
SEEDS = [TINY, TINY, TINY, CHAIN, CHAIN, CHAIN, MINER]
EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "80"))
DERANDOMIZE = os.environ.get("FUZZ_RANDOM", "") == ""
BUILD_EVERY = 10

# What random insertions and replacements are made of.
VOCABULARY = [
    *": - { } [ ] , ? | > # & * ! % @ ` ' \" \\".split(),
    "\t",
    "\n",
    "\r",
    "\r\n",
    "  ",
    "\x00",
    "\x85",
    "\u2028",
    "\u2029",
    "\ufeff",
    "\x1b",
    "\x07",
    "é",
    "\U0001f642",
    "\ud800",
    "ｎ",
    "&a",
    "*a",
    "!!str",
    "!!python/object:os.system",
    "<<:",
    "---",
    "...",
    "%YAML 1.2",
    "~",
    "null",
    "yes",
    "no",
    "on",
    "off",
    "True",
    ".nan",
    "-.inf",
    "1e999",
    "0x10",
    "0o7",
    "-0",
    "99999999999999999999999999",
    "3.0",
    "1_000",
    "",
    "S0",
    "S1",
    "S99",
    "NOP",
    "DONE",
    "ERROR",
    "EXECUTING",
    "INIT",
    "HALT",
    "world.",
    "status",
    "command",
    ".status",
    ".command",
    "self",
    "hooks",
    "buf",
    "state",
    "abs(",
    "max(1, 2)",
    "not",
    "and",
    "or",
    "==",
    "!=",
    "<=",
    "(",
    ")",
    "((((((((((",
    "lambda: 0",
    "__import__",
    "__class__",
    "import",
    "class",
    "def",
    "if",
    "None",
    "print",
    "report: DONE",
    "next: S0",
    "send: x.Y",
    "set: {}",
    "call: h",
    "when: true",
    "do: []",
    "controller: x",
    "system: os",
    '"""; import os; os.system("touch CANARY") #',
    "{{ 7*7 }}",
    "{% raw %}",
    "f'{x}'",
    "first_match: [S0]",
    "every_cycle: []",
    "stand_ins: {}",
    "hooks_module: os.path",
]
SOUP = [
    "x",
    "1",
    "2.5",
    "(",
    ")",
    "+",
    "-",
    "*",
    "/",
    "//",
    "%",
    "==",
    "<",
    "and",
    "or",
    "not",
    "True",
    "world.",
    "DONE",
    ".",
    ",",
    "abs",
    "min",
    "max",
    "'s'",
    "[0]",
    "if",
    "else",
    "lambda",
    ":",
    "__",
    "S0",
    "cc.status",
    "**",
    "~",
    "@",
    "=",
    ";",
]


def pristine(seed: Path) -> dict[str, str]:
    """What building the unmutated seed writes (empty if it does not build today)."""
    if seed not in _PRISTINE:
        front = compile_paths([seed])
        _PRISTINE[seed] = {} if front.diagnostics.errors else emit.render_all(front.systems)
    return _PRISTINE[seed]


_PRISTINE: dict[Path, dict[str, str]] = {}


# ---------------------------------------------------------------- mutations


def _lines(text: str) -> list[str]:
    return text.split("\n")


def mutate_text(text: str, rnd: random.Random) -> str:
    lines = _lines(text)
    at = rnd.randrange(len(lines))
    kind = rnd.choice(
        ["delete", "duplicate", "swap", "insert", "indent", "dedent", "tab", "word", "join"]
        + ["comment", "number", "text"] * 2  # mostly harmless: reach the later stages too
    )
    texts = [i for i, line in enumerate(lines) if line.lstrip().startswith(("doc:", "title:"))]
    if kind == "text" and texts:
        at = rnd.choice(texts)
        lines[at] += " " + rnd.choice(VOCABULARY)
    elif kind == "comment":
        lines[at] += "  # " + rnd.choice(VOCABULARY)
    elif kind == "number":
        digits = [i for i, char in enumerate(lines[at]) if char.isdigit()]
        if digits:
            col = rnd.choice(digits)
            lines[at] = lines[at][:col] + str(rnd.randint(0, 99)) + lines[at][col + 1 :]
    elif kind == "delete":
        del lines[at]
    elif kind == "duplicate":
        lines.insert(at, lines[at])
    elif kind == "indent":
        lines[at] = " " * rnd.randint(1, 4) + lines[at]
    elif kind == "dedent":
        lines[at] = lines[at][rnd.randint(1, 4) :]
    elif kind == "tab":
        lines[at] = "\t" + lines[at].lstrip(" ")
    elif kind == "join" and at + 1 < len(lines):
        lines[at : at + 2] = [lines[at] + " " + lines[at + 1].lstrip()]
    else:
        line = lines[at]
        col = rnd.randint(0, len(line))
        if kind == "swap" and len(line) >= 2:
            col = min(col, len(line) - 2)
            line = line[:col] + line[col + 1] + line[col] + line[col + 2 :]
        elif kind == "word":
            words = [w for w in line.replace(":", " ").split() if w.strip("-")]
            if words:
                line = line.replace(rnd.choice(words), rnd.choice(VOCABULARY), 1)
        else:
            line = line[:col] + rnd.choice(VOCABULARY) + line[col:]
        lines[at] = line
    return "\n".join(lines)


def _paths(data: object, path: tuple = ()) -> list[tuple]:
    """Every path to a value inside loaded YAML data."""
    found = [path] if path else []
    if isinstance(data, dict):
        for key, value in data.items():
            found += _paths(value, (*path, key))
    elif isinstance(data, list):
        for index, value in enumerate(data):
            found += _paths(value, (*path, index))
    return found


def _soup(rnd: random.Random) -> str:
    return " ".join(rnd.choice(SOUP) for _ in range(rnd.randint(1, 8)))


def _random_value(rnd: random.Random) -> object:
    return rnd.choice(
        [
            lambda: rnd.randint(-(2**70), 2**70),
            lambda: rnd.random() * 1e6,
            lambda: rnd.choice([True, False, None]),
            lambda: rnd.choice(VOCABULARY),
            lambda: _soup(rnd),
            lambda: [],
            lambda: {},
            lambda: [_soup(rnd)],
            lambda: {rnd.choice(VOCABULARY) or "k": _soup(rnd)},
            lambda: {"when": _soup(rnd), "do": [{"report": "DONE"}]},
        ]
    )()


def mutate_data(text: str, rnd: random.Random) -> str | None:
    """A data-level mutation re-dumped as YAML, or None when the text is not plain YAML."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError:
        return None
    paths = _paths(data)
    if not paths:
        return None
    path = rnd.choice(paths)
    parent = data
    for step in path[:-1]:
        parent = parent[step]
    last = path[-1]
    kind = rnd.choice(["drop", "rename", "retype", "soup", "duplicate", "swap"])
    if kind == "drop":
        del parent[last]
    elif kind == "rename" and isinstance(parent, dict):
        new = rnd.choice([str(last) + "X", str(last).lower(), str(last).upper(), "S1", "NOP"])
        parent[new if new != last else f"{last}_"] = parent.pop(last)
    elif kind == "soup" and isinstance(parent[last], str):
        parent[last] = _soup(rnd)
    elif kind == "duplicate" and isinstance(parent, list):
        parent.insert(last, parent[last])
    elif kind == "swap" and isinstance(parent, list) and len(parent) > 1:
        other = rnd.randrange(len(parent))
        parent[last], parent[other] = parent[other], parent[last]
    else:
        parent[last] = _random_value(rnd)
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=100)


def mutate_system(directory: Path, rnd: random.Random, count: int) -> list[str]:
    """Apply `count` random mutations to the spec files of `directory`; what was done."""
    done = []
    for _ in range(count):
        files = sorted(directory.glob("*.yaml"))
        hooks = sorted(p for p in directory.rglob("*.py") if "__pycache__" not in p.parts)
        choice = rnd.random()
        if choice < 0.03 and len(files) > 1:
            victim = rnd.choice(files)
            victim.unlink()
            done.append(f"delete {victim.name}")
            continue
        if choice < 0.05 and files:
            source = rnd.choice(files)
            copy = directory / f"{rnd.choice(['zz', 'cc', 'co', 'a', 'system2'])}.yaml"
            if copy == source:
                continue
            shutil.copyfile(source, copy)
            done.append(f"copy {source.name} to {copy.name}")
            continue
        target = rnd.choice(hooks) if choice < 0.08 and hooks else rnd.choice(files)
        text = target.read_text(encoding="utf-8")
        mutated = mutate_data(text, rnd) if rnd.random() < 0.4 else None
        mutated = mutated if mutated is not None else mutate_text(text, rnd)
        target.write_bytes(mutated.encode("utf-8", "surrogatepass"))
        done.append(f"mutate {target.relative_to(directory)}")
    return done


# ---------------------------------------------------------------- oracle


def check_front_end(directory: Path, stats: Counter) -> None:
    front = compile_paths([directory])
    root = directory.resolve()
    for diag in front.diagnostics:
        where = Path(diag.span.file)
        where = where if where.is_absolute() else Path.cwd() / where
        assert where.resolve().is_relative_to(root), diag.render()
        if diag.code != "E224":  # no system.yaml left: located at the directory itself
            assert where.resolve() != root, diag.render()
        assert diag.span.line >= 1 and diag.span.col >= 1, diag.render()
        assert diag.code and diag.message, diag.render()
    if front.diagnostics.errors:
        stats["rejected"] += 1
        stats.update(d.code for d in front.diagnostics.errors)
        return
    stats["accepted"] += 1
    for rel, source in emit.render_all(front.systems).items():
        compile(source, rel, "exec", dont_inherit=True)


def snapshot(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


def check_cli_build(directory: Path, seed: Path, stats: Counter) -> None:
    """`rcsgen build` in-process: exit 0 or 1, and a failed build writes nothing."""
    out = directory.parent / "generated"
    for rel, text in pristine(seed).items():
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        (out / rel).write_text(text, encoding="utf-8")
    (out / "README.user").parent.mkdir(parents=True, exist_ok=True)
    (out / "README.user").write_text("not rcsgen's\n", encoding="utf-8")
    before = snapshot(out)
    result = CliRunner().invoke(main, ["build", str(directory), "-o", str(out)])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    assert result.exit_code in (0, 1), result.output
    assert "Traceback" not in result.output
    stats["cli builds"] += 1
    if result.exit_code == 1:
        assert snapshot(out) == before, "a failed build changed the output directory"


def run_fuzz(examples: int, derandomize: bool) -> Counter:
    stats: Counter = Counter()

    @settings(
        max_examples=examples,
        deadline=None,
        derandomize=derandomize,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(
        seed=st.sampled_from(SEEDS),
        mutations=st.integers(min_value=1, max_value=2),
        salt=st.integers(min_value=0, max_value=2**32),
    )
    def one(seed: Path, mutations: int, salt: int) -> None:
        rnd = random.Random(salt)
        with tempfile.TemporaryDirectory(prefix="rcsgen-fuzz-") as scratch:
            directory = Path(scratch) / seed.name
            shutil.copytree(seed, directory, ignore=shutil.ignore_patterns("__pycache__"))
            mutate_system(directory, rnd, mutations)
            stats["examples"] += 1
            check_front_end(directory, stats)
            if stats["examples"] % BUILD_EVERY == 0:
                check_cli_build(directory, seed, stats)

    one()
    return stats


def test_fuzz_front_end(capsys: pytest.CaptureFixture[str]) -> None:
    """Mutated specs: located diagnostics or a build that compiles, never a traceback."""
    start = time.perf_counter()
    stats = run_fuzz(EXAMPLES, DERANDOMIZE)
    elapsed = time.perf_counter() - start
    assert stats["examples"] >= EXAMPLES
    assert (
        stats["rejected"] and stats["accepted"]
    )  # the mutations are neither all fatal nor all harmless
    codes = sorted(k for k in stats if k[:1] in "ESW" and k[1:].isdigit())
    with capsys.disabled():
        print(
            f"\nfuzz: {stats['examples']} mutated specs, tracebacks=0, "
            f"{stats['accepted']} built, {stats['rejected']} rejected with located diagnostics "
            f"({len(codes)} distinct codes), {stats['cli builds']} CLI builds, "
            f"{elapsed:.1f} s"
        )
