"""The corpus of bad specs: every mistake is reported with its code, where it was made.

`tests/cases/invalid/<kind>--<variant>/` is one whole system (system.yaml, controllers,
sometimes a hooks package) with one mistake. Each offending line carries its expectation as
a YAML comment: `# expect: E204` means a diagnostic E204 on that line, `# expect: E204@31`
also pins the column, `# expect: E221 E222` expects two codes there. The test runs the front
end on the case directory and asserts the reported (file, line, code) set equals the expected
set: an extra diagnostic fails the case as surely as a missing one, so each case is kept
minimal. Nothing may raise. The messages and hints themselves, word for word, are what a
person reads: each case's are recorded in `cases/invalid_messages.json` and compared too
(`python tests/test_corpus.py` records them again after a change meant, to be reviewed as
a diff).

Warnings of the static analysis (W5xx) are compared only in cases that expect one: they
judge tables, not mistakes, and a case is about its one mistake.
`tests/cases/valid/` holds systems that must validate without a single diagnostic.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from rcsgen.cli import main
from rcsgen.compiler.back_end import write
from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span
from rcsgen.compiler.front_end.loader import utf16_without_bom
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.scenario import check_system_scenarios

CASES = Path(__file__).resolve().parent / "cases"
INVALID = sorted(p for p in (CASES / "invalid").iterdir() if p.is_dir())
VALID = sorted(p for p in (CASES / "valid").iterdir() if p.is_dir())
EXPECT = re.compile(r"#\s*expect:\s*(.*)$")
TOKEN = re.compile(r"([ESW]\d{3})(?:@(\d+))?")
ANALYSIS_WARNING = re.compile(r"W5\d\d")


@dataclass(frozen=True)
class Expected:
    file: str  # relative to the case directory, as the front end shows it from there
    line: int
    code: str
    col: int | None = None


def expectations(case: Path) -> list[Expected]:
    """Every `# expect:` comment of the case's files (YAML, hooks, files in `out`)."""
    found = []
    for path in sorted(p for p in case.rglob("*") if p.is_file()):
        if "__pycache__" in path.parts:
            continue
        rel = path.relative_to(case).as_posix()
        data = path.read_bytes()
        encoding = "utf-16-be" if utf16_without_bom(data) == "big-endian" else "utf-16-le"
        # E008 cases are not UTF-8 (one is UTF-16 without a byte-order mark)
        text = data.decode(encoding if utf16_without_bom(data) else "utf-8", errors="replace")
        for number, line in enumerate(text.split("\n"), start=1):
            match = EXPECT.search(line)
            if match is None:
                continue
            tokens = match.group(1).split()
            assert tokens, f"{rel}:{number}: `# expect:` without a code"
            for token in tokens:
                parsed = TOKEN.fullmatch(token)
                assert parsed, f"{rel}:{number}: bad expectation {token!r}"
                col = int(parsed.group(2)) if parsed.group(2) else None
                found.append(Expected(rel, number, parsed.group(1), col))
    return found


# Codes only a run finds: a case expecting one also runs each of its scenarios.
RUN_CODES = {"E416", "E417", "E420", "E421", "E422"}


def run_front_end(
    case: Path, monkeypatch: pytest.MonkeyPatch, run: bool = False
) -> list[Diagnostic]:
    """What `rcsgen validate .` reports in the case directory (the specs and the scenarios
    of each system); with an `out` entry (a case about the output directory), also what
    `rcsgen build . -o out` would report; with `run`, what `rcsgen run` reports for each
    scenario."""
    monkeypatch.chdir(case)  # diagnostics then name files relative to the case
    front = compile_paths([Path(".")])
    found = list(front.diagnostics)
    for system in front.systems:
        found += list(check_system_scenarios(front.directories[system.name], system))
    if os.path.lexists(case / "out") and not front.diagnostics.errors:
        _, problems = write.plan_build(front.systems, Path("out"))  # plans; writes nothing
        found += list(problems)
    if run:
        for scenario in sorted(case.rglob("scenarios/*.yaml")):
            args = ["run", str(scenario.relative_to(case)), "--format", "json", "-q"]
            args += ["--trace", os.devnull]
            result = CliRunner().invoke(main, args, catch_exceptions=False)
            assert result.exit_code in (0, 1) and "Traceback" not in result.output
            found += [
                Diagnostic(Span(d["file"], d["line"], d["col"]), d["code"], d["message"])
                for d in json.loads(result.stdout)
                if d["code"] in RUN_CODES
            ]
    return found


# The rendered diagnostics of every invalid case (message and hint, where), as a person
# reads them: `python tests/test_corpus.py` records them again after a reviewed change.
MESSAGES = CASES / "invalid_messages.json"


def said(diags: list[Diagnostic]) -> list[str]:
    return sorted(d.render() for d in diags)


_recorded: dict[str, list[str]] = {}


def _messages() -> dict[str, list[str]]:
    if not _recorded:
        _recorded.update(json.loads(MESSAGES.read_text(encoding="utf-8")))
    return _recorded


def record_messages() -> None:
    """Every invalid case's messages, as test_invalid_case compares them, into MESSAGES."""
    found = {}
    for case in INVALID:
        want = expectations(case)
        with pytest.MonkeyPatch.context() as monkeypatch:
            diags = run_front_end(case, monkeypatch, run=any(e.code in RUN_CODES for e in want))
        analysis = any(ANALYSIS_WARNING.fullmatch(e.code) for e in want)
        found[case.name] = said(
            [d for d in diags if analysis or not ANALYSIS_WARNING.fullmatch(d.code)]
        )
    text = json.dumps(found, indent=1, sort_keys=True, ensure_ascii=False) + "\n"
    MESSAGES.write_text(text, encoding="utf-8")


def test_corpus_size() -> None:
    """At least 100 bad specs, covering at least 40 kinds of mistake."""
    kinds = {case.name.split("--")[0] for case in INVALID}
    assert len(INVALID) >= 100, len(INVALID)
    assert len(kinds) >= 40, sorted(kinds)


@pytest.mark.parametrize("case", INVALID, ids=[c.name for c in INVALID])
def test_invalid_case(case: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    want = expectations(case)
    assert want, f"{case.name} expects nothing: add `# expect: CODE` to the offending line"
    diags = run_front_end(case, monkeypatch, run=any(e.code in RUN_CODES for e in want))
    expects_analysis = any(ANALYSIS_WARNING.fullmatch(e.code) for e in want)
    compared = [d for d in diags if expects_analysis or not ANALYSIS_WARNING.fullmatch(d.code)]
    got = {(d.span.file, d.span.line, d.code) for d in compared}
    assert got == {(e.file, e.line, e.code) for e in want}, "\n".join(d.render() for d in diags)
    for e in want:
        if e.col is not None:
            at = (e.file, e.line, e.code)
            cols = [d.span.col for d in diags if (d.span.file, d.span.line, d.code) == at]
            assert e.col in cols, f"{e}: reported at columns {cols}"
    for d in diags:  # every diagnostic is located in a file of the case
        assert (case / d.span.file).is_file(), d.render()
        assert d.span.line >= 1 and d.span.col >= 1, d.render()
        assert d.message and "Traceback" not in d.message
    # what a person reads, word for word: each message and hint as recorded
    recorded = _messages().get(case.name)
    assert said(compared) == recorded, (
        f"{case.name}: the messages differ from {MESSAGES.name} (if the change is meant, "
        "record them again: python tests/test_corpus.py, and review the diff)"
    )


@pytest.mark.parametrize("case", VALID, ids=[c.name for c in VALID])
def test_valid_case(case: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The systems the invalid cases are made from are themselves clean."""
    diags = run_front_end(case, monkeypatch)
    assert not [d for d in diags if not ANALYSIS_WARNING.fullmatch(d.code)], diags


def test_corpus_shows_did_you_mean(monkeypatch: pytest.MonkeyPatch) -> None:
    """Misspelled names get a `did you mean` hint naming the declared one."""
    hints = {}
    for name in (
        "e103-unknown-name--local-typo",
        "e103-unknown-name--constant-typo",
        "e104-undeclared-world-field--guard",
        "e106-unknown-predicate--typo",
        "e201-unknown-subordinate--typo",
        "e204-undeclared-command--typo",
        "e206-undefined-state--typo",
        "e211-unknown-module--typo",
        "e271-reason-passed-from-a-non-subordinate--typo",
        "e292-undeclared-plan--typo",
        "s002-unknown-key--typo-title",
        "s005-invalid-value--type-typo",
    ):
        diags = run_front_end(CASES / "invalid" / name, monkeypatch)
        hints[name] = [d.hint for d in diags if "did you mean" in d.hint]
    assert all(hints.values()), hints
    assert hints["e103-unknown-name--local-typo"] == ["did you mean `n`?"]
    assert hints["e204-undeclared-command--typo"] == ["did you mean `MOVE`?"]
    assert hints["s005-invalid-value--type-typo"] == ["did you mean `float`?"]
    assert hints["e271-reason-passed-from-a-non-subordinate--typo"] == ["did you mean `sub`?"]
    assert hints["e292-undeclared-plan--typo"] == ["did you mean `legs`?"]


def test_corpus_hints_say_what_to_do(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where no name is near, the hint says the fix."""
    [e215] = run_front_end(CASES / "invalid" / "e215-hooks-without-module", monkeypatch)
    assert (
        e215.hint
        == "add `hooks_module: <package>.<module>`, a Python module in the system directory"
    )


CODE = re.compile(r"""["']([ESW]\d{3})["']""")
DOC_ENTRY = re.compile(r"^### ([ESW]\d{3}) (.*)$", re.MULTILINE)
MENTION = re.compile(r"\b([ESW]\d{3})\b")  # `"E204"`, `error[E430]`, `E216_...`
TESTS = Path(__file__).resolve().parent


def test_the_registry_is_the_one_list_of_codes() -> None:
    """rcsgen/compiler/codes.py registers every code once, and each registered code is
    reported somewhere (a string literal like "E204" in rcsgen/, outside the registry),
    documented in docs/diagnostics.md under its registered title, and tested by a case (a
    corpus case named after it, a running-side case or a test that names it). Nothing is
    reported, documented or selectable that is not registered; the docs' index is the
    registry's."""
    from rcsgen.compiler.codes import CODES, WARNING_CODES, index_markdown

    package = TESTS.parent / "rcsgen"
    registry = package / "compiler" / "codes.py"
    reported = {
        c for p in package.rglob("*.py") if p != registry for c in CODE.findall(p.read_text())
    }
    doc = (package.parent / "docs" / "diagnostics.md").read_text(encoding="utf-8")
    documented = dict(DOC_ENTRY.findall(doc))
    tested = {case.name[:4].upper() for case in INVALID}
    tested |= {c for p in TESTS.glob("test_*.py") for c in MENTION.findall(p.read_text())}
    running = (CASES / "running").glob("*.yaml")  # the running side's cases (test_operate)
    tested |= {c for p in running for c in MENTION.findall(p.read_text(encoding="utf-8"))}
    assert len(DOC_ENTRY.findall(doc)) == len(documented), "a code is documented twice"
    assert sorted(reported - set(CODES)) == [], "reported but not registered"
    assert sorted(set(CODES) - reported) == [], "registered but never reported"
    assert sorted(set(documented) ^ set(CODES)) == [], "documented or registered, not both"
    titles = {code: c.title for code, c in CODES.items() if documented[code] != c.title}
    assert titles == {}, "the registry's titles are the docs' headings"
    assert sorted(set(CODES) - tested) == [], "registered but tested by no case"
    assert WARNING_CODES == {c for c in documented if c.startswith("W")}
    assert index_markdown() in doc, "docs/diagnostics.md's index is not the registry's"
    # E237's list: what a spec can acknowledge, by what each finding is about (W303's hint)
    about = {c.about for c in CODES.values() if c.acknowledgeable}
    assert about == {"a rule", "a state", "a command"}, "a subject W303 cannot place"
    words = " ".join(doc.split())
    for kind in sorted(about):
        codes = ", ".join(sorted(code for code, c in CODES.items() if c.about == kind))
        assert re.search(rf"- about {kind} \([^)]*\): {codes}[;.]", words), kind


def test_the_registry_prints_the_docs_index() -> None:
    """`python -m rcsgen.compiler.codes`, as docs/diagnostics.md says, prints its index."""
    from rcsgen.compiler.codes import index_markdown

    printed = subprocess.run(
        [sys.executable, "-m", "rcsgen.compiler.codes"],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout
    assert printed == index_markdown() and printed.startswith("| range | stage | module |\n")


def test_a_code_reported_with_another_severity_is_an_internal_error() -> None:
    """A reporting site takes its severity from the registry: a warning's code reported as
    an error (or an unregistered code) fails where it is made, never reaches a user."""
    diags = Diagnostics()
    with pytest.raises(ValueError, match="W301 is a registered warning, reported as a error"):
        diags.error(Span("x.yaml"), "W301", "message")
    with pytest.raises(ValueError, match="E204 is a registered error, reported as a warning"):
        diags.warning(Span("x.yaml"), "E204", "message")
    with pytest.raises(ValueError, match="'E999' is not registered"):
        Diagnostic(Span("x.yaml"), "E999", "message")
    assert diags.items == []
    diags.warning(Span("x.yaml"), "W301", "message")
    assert [d.severity for d in diags] == ["warning"]


def test_completion_of_select_names_each_warning_with_its_title() -> None:
    from rcsgen.terminal import complete_codes

    items = complete_codes(None, None, "W50")  # type: ignore[arg-type]
    assert [(i.value, i.help) for i in items][:2] == [
        ("W501", "overlap in a first_match state"),
        ("W502", "exclusivity not provable"),
    ]
    assert [i.value for i in complete_codes(None, None, "W301,W30")][-1] == "W301,W309"  # type: ignore[arg-type]


def test_corpus_cases_are_named_after_documented_codes() -> None:
    doc = (CASES.parent.parent / "docs" / "diagnostics.md").read_text(encoding="utf-8")
    documented = {c.lower() for c, _ in DOC_ENTRY.findall(doc)}
    assert {case.name[:4] for case in INVALID} <= documented


# ---------------------------------------------------------------- --format json


def _cli(*args: str) -> Result:
    result = CliRunner().invoke(main, list(args), catch_exceptions=False)
    assert "Traceback" not in result.output
    return result


def test_validate_json_lists_every_diagnostic_sorted(monkeypatch: pytest.MonkeyPatch) -> None:
    """`--format json`: one array on stdout, sorted by position, all fields; exit 1."""
    monkeypatch.chdir(CASES / "invalid" / "e206-undefined-state--typo")
    result = _cli("validate", ".", "--format", "json")
    assert result.exit_code == 1
    found = json.loads(result.stdout)
    assert [(d["file"], d["line"], d["code"]) for d in found] == [
        ("top.yaml", 30, "E206"),
        ("top.yaml", 31, "E207"),
    ]
    assert set(found[0]) == {"file", "line", "col", "severity", "code", "message", "hint"}
    assert found[0]["severity"] == "error" and found[0]["col"] == 17
    assert found[0]["hint"].startswith("did you mean")
    text = _cli("validate", ".")
    assert text.exit_code == 1 and text.stdout == ""  # text goes to stderr
    assert "top.yaml:30:17: error[E206]" in text.stderr


def test_json_of_many_files_is_sorted_by_position(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(CASES / "invalid" / "e203-cycle--mutual")
    found = json.loads(_cli("validate", ".", "--format", "json").stdout)
    keys = [(d["file"], d["line"], d["col"]) for d in found]
    assert keys == sorted(keys) and len(keys) == 2


def test_build_json_keeps_stdout_for_the_array(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A clean build prints `[...]` (warnings included) on stdout and its summary on stderr;
    a failed one prints the errors, exits 1 and writes nothing."""
    monkeypatch.chdir(tmp_path)
    shutil.copytree(CASES / "valid" / "tiny", tmp_path / "specs" / "tiny")
    result = _cli("build", "specs", "-o", "out", "--format", "json")
    assert result.exit_code == 0, result.output
    assert all(d["severity"] == "warning" for d in json.loads(result.stdout))
    assert "built tiny into out" in result.stderr
    assert (tmp_path / "out" / "tiny" / "top.py").is_file()
    checked = _cli("build", "specs", "-o", "out", "--check", "--format", "json")
    assert checked.exit_code == 0 and isinstance(json.loads(checked.stdout), list)
    shutil.copytree(CASES / "invalid" / "e204-undeclared-command--typo", tmp_path / "bad")
    failed = _cli("build", "bad", "-o", "out2", "--format", "json")
    assert failed.exit_code == 1
    assert [d["code"] for d in json.loads(failed.stdout)] == ["E204"]
    assert "nothing was written" in failed.stderr and not (tmp_path / "out2").exists()


if __name__ == "__main__":
    record_messages()
