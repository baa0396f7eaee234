"""`make mutate-templates`: mutation testing of the templates' safety code, which mutmut
cannot reach (it mutates Python; the controllers are rendered from Jinja).

The safety code of templates/controller.py.j2 is its regions named in REGIONS: the seqlocked
read of the inputs another process writes (and the stale first read), a subordinate told
lost (`on_lost: continue`), the seqlocked writes of status, commands and world outputs, the
world outputs held by an override, `resume` and `safe_state`. Each mutant changes one thing
on one line of a region, in the Python text only (never inside `{{ }}`, `{% %}` or a
comment): an operator or constant swapped (OPERATORS), or a statement replaced by `pass`.
For each, the suite's tests of the runtime's safety (TESTS) run in a fresh pytest process
whose builds render from a scratch copy of templates/ holding the mutant (the variable
RCSGEN_MUTATE_TEMPLATES, read by tests/conftest.py); a mutant is killed when a test fails.
A control run with the templates unchanged must pass first.

The summary gives the score and lists the survivors; survivors judged equivalent are listed,
with the reason, in tests/mutation_equivalent.txt under their key (`controller.py.j2:LINE:
OLD->NEW`, as printed). Arguments: `--list` prints the mutants without running them;
`--only TEXT` (several allowed) runs the mutants whose key contains one of them.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
TEMPLATES = REPO / "templates"
ENV = "RCSGEN_MUTATE_TEMPLATES"
EQUIVALENT = HERE / "mutation_equivalent.txt"

# (template, first line's text, last line's text): inclusive, the first match of each.
REGIONS = (
    (
        "controller.py.j2",
        "        for _ in range(READ_TRIES):",
        "            self.stale_reads += 1",
    ),
    (
        "controller.py.j2",
        "{% if sub.continue_on_lost %}",
        "            self.{{ sub.name }}_status = ERROR",
    ),
    ("controller.py.j2", "{% macro seqs_torn() %}", "{% endmacro %}"),
    ("controller.py.j2", "{% macro world_writes(pad) %}", "{%- endmacro %}"),
    ("controller.py.j2", "        values = INPUTS.unpack_from(buf, INPUTS_AT)", "        else:"),
    (
        "controller.py.j2",
        "        if self.rule or self.status_dirty:",
        "            self.min_cycle_ns = last  # the shortest yet: with the next publish",
    ),
    (
        "controller.py.j2",
        "        if not whole:",
        "            self.command_num, self.dont_run = self.status_num, True",
    ),
    ("controller.py.j2", "    def resume(self) -> None:", "{% for target in resume_texts %}"),
    (
        "controller.py.j2",
        "    def safe_state(self, reason: int) -> None:",
        "        self.status_dirty = True",
    ),
)
OPERATORS = (
    (" and ", " or "),
    (" or ", " and "),
    (" == ", " != "),
    (" != ", " == "),
    ("not ", ""),
    ("+ 1", "+ 2"),
    ("+= 1", "+= 2"),
    ("| 1", "| 2"),
    ("& 1", "& 2"),
    (" > ", " >= "),
    (" < ", " <= "),
    ("True", "False"),
    ("False", "True"),
    ("range(READ_TRIES)", "range(1)"),
    ("if self.", "if not self."),
    ("if buf[", "if not buf["),
)
# The tests of the runtime's safety that run in one process, quickly (the fault tests in real
# processes are left out: each takes seconds, and these reach the same generated code).
TESTS = (
    "tests/test_runtime_safety.py",
    "tests/test_runtime_mutants.py",
    "tests/test_failsafe.py",
    "-k",
    "not (dead or frozen or starved or survivor or restart or restarted or second_copy "
    "or start_up or launcher or killed or miner or paced_process or policy)",
)
JINJA = re.compile(r"\{\{.*?\}\}|\{%.*?%\}|\{#.*?#\}")


def code_spans(line: str) -> list[tuple[int, int]]:
    """The parts of a template line that are Python text: outside Jinja tags and before a
    comment."""
    if line.lstrip().startswith(("{%", "{#", "#")):
        return []
    spans, start = [], 0
    for tag in JINJA.finditer(line):
        spans.append((start, tag.start()))
        start = tag.end()
    spans.append((start, len(line)))
    out = []
    for a, b in spans:
        hash_at = line.find("#", a, b)
        if hash_at >= 0:
            out.append((a, hash_at))
            break
        out.append((a, b))
    return [(a, b) for a, b in out if a < b]


def docstring_lines(lines: list[str]) -> set[int]:
    """The 0-based numbers of the lines inside (or opening, or closing) a docstring."""
    inside, found = False, set()
    for i, line in enumerate(lines):
        quotes = line.count('"""')
        if inside or quotes:
            found.add(i)
        if quotes % 2:
            inside = not inside
    return found


def region_lines(name: str, text: str) -> list[int]:
    """The 0-based numbers of the lines of `name` that REGIONS name (docstrings left out)."""
    lines = text.splitlines()
    docs = docstring_lines(lines)
    found: list[int] = []
    for template, first, last in REGIONS:
        if template != name:
            continue
        start = next(i for i, line in enumerate(lines) if line == first)
        end = next(i for i in range(start, len(lines)) if lines[i] == last)
        found += [i for i in range(start, end + 1) if i not in found and i not in docs]
    return sorted(found)


def mutants(name: str, text: str) -> list[tuple[str, str]]:
    """(key, mutated text) of every mutant of template `name`."""
    lines = text.splitlines(keepends=True)
    out = []
    for i in region_lines(name, text):
        line = lines[i]
        body = line.rstrip("\n")
        for a, b in code_spans(body):
            for old, new in OPERATORS:
                at = body.find(old, a, b)
                while at >= 0:
                    changed = body[:at] + new + body[at + len(old) :] + "\n"
                    key = f"{name}:{i + 1}:{old.strip() or old}->{new.strip() or 'nothing'}@{at}"
                    out.append((key, "".join(lines[:i] + [changed] + lines[i + 1 :])))
                    at = body.find(old, at + 1, b)
        stripped = body.strip()
        simple = (
            code_spans(body)
            and not stripped.startswith(("{", "def ", "else", "elif", "if ", "for ", '"""'))
            and not stripped.endswith((":", "(", ","))
            and stripped != "pass"
        )
        if simple:
            indent = body[: len(body) - len(body.lstrip())]
            key = f"{name}:{i + 1}:statement->pass"
            out.append((key, "".join(lines[:i] + [f"{indent}pass\n"] + lines[i + 1 :])))
    return out


def run_tests(templates: Path) -> tuple[bool, str]:
    """Whether TESTS pass with builds rendering from `templates`; the last output line."""
    env = {**os.environ, ENV: str(templates), "PYTHONDONTWRITEBYTECODE": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *TESTS],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    tail = (result.stdout.strip().splitlines() or [""])[-1]
    return result.returncode == 0, tail


def parse(args: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="tests/mutation_templates.py",
        description="Mutation testing of the templates' safety code (make mutate-templates).",
    )
    parser.add_argument("--list", action="store_true", help="print the mutants, run nothing")
    parser.add_argument(
        "--only",
        action="append",
        metavar="TEXT",
        help="run the mutants whose key contains TEXT (may be given several times)",
    )
    return parser.parse_args(args)


def main(args: list[str]) -> int:
    options = parse(args)
    only = options.only or [""]
    found = [
        (key, name, text)
        for name in sorted({r[0] for r in REGIONS})
        for key, text in mutants(name, (TEMPLATES / name).read_text(encoding="utf-8"))
        if any(o in key for o in only)
    ]
    if options.list:
        for key, _, _ in found:
            print(key)
        return 0
    listed = {}
    if EQUIVALENT.exists():
        for line in EQUIVALENT.read_text(encoding="utf-8").splitlines():
            key, _, reason = line.partition("#")
            if key.strip():
                listed[key.strip()] = reason.strip()
    scratch = Path(tempfile.mkdtemp(prefix="rcsgen-template-mutants-"))
    try:
        copy = scratch / "templates"
        shutil.copytree(TEMPLATES, copy)
        ok, tail = run_tests(copy)
        if not ok:
            print(f"the control run fails with the templates unchanged: {tail}")
            return 1
        killed, survived, equivalent = 0, [], []
        for key, name, text in found:
            original = (TEMPLATES / name).read_text(encoding="utf-8")
            (copy / name).write_text(text, encoding="utf-8")
            began = time.monotonic()
            ok, tail = run_tests(copy)
            (copy / name).write_text(original, encoding="utf-8")
            verdict = "survived" if ok else "killed"
            print(f"{verdict:8} {key}  ({time.monotonic() - began:.0f} s; {tail})", flush=True)
            if not ok:
                killed += 1
            elif key in listed:
                equivalent.append(key)
            else:
                survived.append(key)
        scored = killed + len(survived)
        print(
            f"\ntemplates: {killed} killed, {len(survived)} survived, {len(equivalent)} "
            f"equivalent; score {killed / scored:.1%} of {scored}"
        )
        for key in survived:
            print(f"    {key}: survived")
        return 0
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
