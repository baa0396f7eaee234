"""Reporting: which warnings are shown (--select, --ignore, [tool.rcsgen]), how (text with
colour, --statistics, JSON, SARIF 2.1.0, GitHub annotations) and whether they fail."""

from __future__ import annotations

import io
import json
import re
import shutil
from pathlib import Path

import jsonschema
import pytest
from click.testing import CliRunner
from conftest import REPO, rcsgen

from rcsgen.cli import main
from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span
from rcsgen.terminal import Progress, report
from rcsgen.tools.report import Options, to_github

TINY = REPO / "tests" / "cases" / "valid" / "tiny"
# tiny's top waits on sub: one W503 and one W506 at top.yaml line 31.
WARNINGS = {"W503", "W506"}


@pytest.fixture
def tiny(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(TINY, tmp_path / "sys")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("NO_COLOR", raising=False)
    monkeypatch.delenv("FORCE_COLOR", raising=False)
    return tmp_path


def codes(output: str) -> set[str]:
    return set(re.findall(r"(?:error|warning|acknowledged)\[([EWS]\d{3})\]", output))


def test_warnings_are_shown_and_do_not_fail(tiny: Path) -> None:
    result = rcsgen("validate", "sys")
    assert result.exit_code == 0
    assert codes(result.output) == WARNINGS
    assert "0 errors, 2 warnings" in result.stderr
    assert result.stdout == "ok: tiny\n"


@pytest.mark.parametrize(
    "args, shown",
    [
        (["--select", "W503"], {"W503"}),
        (["--select", "w5"], WARNINGS),
        (["--ignore", "W506"], {"W503"}),
        (["--ignore", "W503,W506"], set()),
        (["--select", "W5", "--ignore", "W503"], {"W506"}),
    ],
)
def test_select_and_ignore_choose_the_warnings(tiny: Path, args: list[str], shown: set[str]):
    result = rcsgen("validate", "sys", "--strict", *args)
    assert codes(result.output) == shown
    assert result.exit_code == (1 if shown else 0)  # --strict fails only on shown warnings


@pytest.mark.parametrize(
    "code, words",
    [
        ("E204", "errors are always reported and cannot be ignored"),
        ("S0", "errors are always reported"),
        ("W999", "no warning code starts with `W999`"),
        ("X1", "is not a warning code or prefix"),
    ],
)
def test_errors_cannot_be_ignored_and_codes_must_exist(tiny: Path, code: str, words: str):
    result = rcsgen("validate", "sys", "--ignore", code)
    assert result.exit_code == 2
    assert words in result.output


def test_an_ignored_error_is_still_an_error(tiny: Path) -> None:
    (tiny / "sys" / "top.yaml").write_text(
        (tiny / "sys" / "top.yaml").read_text().replace("sub.MOVE", "sub.MOVEE")
    )
    result = rcsgen("validate", "sys", "--select", "W503")
    assert result.exit_code == 1 and codes(result.output) == {"E204"}


def write_config(root: Path, body: str) -> None:
    (root / "pyproject.toml").write_text(f'[project]\nname = "x"\n\n[tool.rcsgen]\n{body}\n')


def test_pyproject_configures_the_defaults_and_the_command_line_wins(tiny: Path) -> None:
    write_config(tiny, 'ignore = ["W506"]\nstrict = true')
    nested = tiny / "sys" / "deeper"
    nested.mkdir()
    result = rcsgen("validate", "sys")
    assert codes(result.output) == {"W503"} and result.exit_code == 1  # strict from the file
    assert rcsgen("validate", "sys", "--no-strict").exit_code == 0
    assert codes(rcsgen("validate", "sys", "--ignore", "W503").output) == set()  # adds
    assert codes(rcsgen("validate", "sys", "--isolated").output) == WARNINGS
    assert rcsgen("validate", "sys", "--isolated").exit_code == 0


def test_pyproject_found_from_a_subdirectory(tiny: Path, monkeypatch) -> None:
    write_config(tiny, 'select = ["W506"]')
    monkeypatch.chdir(tiny / "sys")
    assert codes(rcsgen("validate", ".").output) == {"W506"}


@pytest.mark.parametrize(
    "body, words",
    [
        ('selct = ["W5"]', "unknown key `selct`; did you mean `select`?"),
        ('ignore = "W503"', "`ignore` must be a list of warning codes"),
        ('ignore = ["E501"]', "`E501` names errors"),
        ('strict = "yes"', "`strict` must be true or false"),
        ("strict = ", "invalid TOML"),
    ],
)
def test_a_bad_configuration_is_misuse(tiny: Path, body: str, words: str) -> None:
    write_config(tiny, body)
    result = rcsgen("validate", "sys")
    assert result.exit_code == 2
    assert "pyproject.toml: " in result.output and words in result.output


def test_quiet_prints_the_diagnostics_only(tiny: Path) -> None:
    result = rcsgen("validate", "sys", "-q")
    assert codes(result.output) == WARNINGS
    assert "ok:" not in result.output and "0 errors, " not in result.output
    assert rcsgen("validate", "sys", "-q", "--ignore", "W5").output == ""


def test_statistics_count_per_code(tiny: Path) -> None:
    (tiny / "sys" / "top.yaml").write_text(
        (tiny / "sys" / "top.yaml").read_text().replace("ready()", "ready() and n < 1 // 0")
    )
    result = rcsgen("validate", "sys", "--statistics")
    lines = [line for line in result.stderr.splitlines() if "  e.g. " in line]
    assert lines == ["1  E111  error         e.g. sys/top.yaml:32:61"]
    assert rcsgen("validate", "sys", "--statistics", "--format", "json").exit_code == 2


def test_colour_on_request_and_never_with_no_color(tiny: Path, monkeypatch) -> None:
    coloured = rcsgen("validate", "sys", "--color", "always").stderr
    assert "\x1b[" in coloured and "warning[W503]" in re.sub(r"\x1b\[[0-9;]*m", "", coloured)
    assert "\x1b[" not in rcsgen("validate", "sys").stderr  # auto: not a terminal
    assert "\x1b[" not in rcsgen("validate", "sys", "--color", "never").stderr
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert "\x1b[" in rcsgen("validate", "sys").stderr
    monkeypatch.setenv("NO_COLOR", "1")
    assert "\x1b[" not in rcsgen("validate", "sys").stderr


# ---------------------------------------------------------------- SARIF

# The parts of the SARIF 2.1.0 schema (OASIS, sarif-schema-2.1.0.json) that rcsgen's log uses,
# with the constraints the standard puts on them: required properties, the version, the
# level and suppression-kind enumerations, 1-based regions. Written out here because the
# official schema file is too large to vendor.
SARIF_SUBSET = {
    "type": "object",
    "required": ["version", "runs"],
    "properties": {
        "$schema": {"type": "string", "format": "uri"},
        "version": {"enum": ["2.1.0"]},
        "runs": {
            "type": "array",
            "items": {
                "type": "object",
                "required": ["tool"],
                "properties": {
                    "tool": {
                        "type": "object",
                        "required": ["driver"],
                        "properties": {
                            "driver": {
                                "type": "object",
                                "required": ["name"],
                                "properties": {
                                    "name": {"type": "string"},
                                    "version": {"type": "string"},
                                    "rules": {
                                        "type": "array",
                                        "items": {
                                            "type": "object",
                                            "required": ["id"],
                                            "properties": {
                                                "id": {"type": "string"},
                                                "shortDescription": {
                                                    "type": "object",
                                                    "required": ["text"],
                                                    "properties": {"text": {"type": "string"}},
                                                },
                                                "defaultConfiguration": {
                                                    "type": "object",
                                                    "properties": {
                                                        "level": {
                                                            "enum": [
                                                                "none",
                                                                "note",
                                                                "warning",
                                                                "error",
                                                            ]
                                                        }
                                                    },
                                                },
                                            },
                                        },
                                    },
                                },
                            }
                        },
                    },
                    "columnKind": {"enum": ["utf16CodeUnits", "unicodeCodePoints"]},
                    "results": {
                        "type": "array",
                        "items": {
                            "type": "object",
                            "required": ["message"],
                            "properties": {
                                "ruleId": {"type": "string"},
                                "ruleIndex": {"type": "integer", "minimum": -1},
                                "level": {"enum": ["none", "note", "warning", "error"]},
                                "message": {
                                    "type": "object",
                                    "required": ["text"],
                                    "properties": {"text": {"type": "string"}},
                                },
                                "locations": {
                                    "type": "array",
                                    "items": {
                                        "type": "object",
                                        "properties": {
                                            "physicalLocation": {
                                                "type": "object",
                                                "required": ["artifactLocation"],
                                                "properties": {
                                                    "artifactLocation": {
                                                        "type": "object",
                                                        "properties": {
                                                            "uri": {
                                                                "type": "string",
                                                                "format": "uri-reference",
                                                            }
                                                        },
                                                    },
                                                    "region": {
                                                        "type": "object",
                                                        "properties": {
                                                            "startLine": {
                                                                "type": "integer",
                                                                "minimum": 1,
                                                            },
                                                            "startColumn": {
                                                                "type": "integer",
                                                                "minimum": 1,
                                                            },
                                                        },
                                                    },
                                                },
                                            }
                                        },
                                    },
                                },
                                "suppressions": {
                                    "type": "array",
                                    "items": {
                                        "type": "object",
                                        "required": ["kind"],
                                        "properties": {
                                            "kind": {"enum": ["inSource", "external"]},
                                            "justification": {"type": "string"},
                                        },
                                    },
                                },
                            },
                        },
                    },
                },
            },
        },
    },
}


def test_sarif_is_a_valid_2_1_0_log(tiny: Path) -> None:
    (tiny / "sys" / "top.yaml").write_text(
        (tiny / "sys" / "top.yaml").read_text().replace("sub.MOVE", "sub.MOVEE")
    )
    result = rcsgen("validate", "sys", "--format", "sarif")
    assert result.exit_code == 1
    log = json.loads(result.stdout)
    jsonschema.validate(log, SARIF_SUBSET, format_checker=jsonschema.FormatChecker())
    [run] = log["runs"]
    assert run["tool"]["driver"]["name"] == "rcsgen"
    [error] = run["results"]
    assert (error["ruleId"], error["level"]) == ("E204", "error")
    rule = run["tool"]["driver"]["rules"][error["ruleIndex"]]
    assert rule["id"] == "E204"
    # the rule's title and level are the registry's (docs/diagnostics.md's heading)
    assert rule["shortDescription"]["text"] == "undeclared command"
    assert rule["defaultConfiguration"]["level"] == "error"
    where = error["locations"][0]["physicalLocation"]
    assert where["artifactLocation"]["uri"] == "sys/top.yaml"
    assert where["region"] == {"startLine": 27, "startColumn": 15}


def test_sarif_marks_acknowledged_warnings_as_suppressed(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(REPO)
    result = rcsgen("validate", "specs", "--format", "sarif", "--show-acknowledged")
    assert result.exit_code == 0
    log = json.loads(result.stdout)
    jsonschema.validate(log, SARIF_SUBSET, format_checker=jsonschema.FormatChecker())
    results = log["runs"][0]["results"]
    assert results and all(r["level"] == "warning" for r in results)
    assert all(r["suppressions"][0]["kind"] == "inSource" for r in results)
    assert all(r["suppressions"][0]["justification"] for r in results)
    plain = json.loads(rcsgen("validate", "specs", "--format", "sarif").stdout)
    assert plain["runs"][0]["results"] == []


# ---------------------------------------------------------------- GitHub


def test_github_annotations(tiny: Path) -> None:
    result = rcsgen("validate", "sys", "--format", "github")
    lines = result.stdout.splitlines()
    assert len(lines) == 2 and all(
        line.startswith("::warning file=sys/top.yaml,line=31,col=7,") for line in lines
    )
    assert "title=rcsgen W503::" in result.stdout


def test_github_escapes_what_would_end_a_command() -> None:
    diagnostic = Diagnostic(Span("a,b:c.yaml", 3, 4), "E204", "50% of\nit", "hint, here")
    [line] = to_github([diagnostic]).splitlines()
    assert (
        line
        == "::error file=a%2Cb%3Ac.yaml,line=3,col=4,title=rcsgen E204::50%25 of%0Ait%0Ahint, here"
    )


# ---------------------------------------------------------------- progress and completion


class FakeTerminal(io.StringIO):
    def __init__(self, tty: bool) -> None:
        super().__init__()
        self.tty = tty

    def isatty(self) -> bool:
        return self.tty


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_progress_on_a_terminal_is_one_line_rewritten_then_erased() -> None:
    out, clock = FakeTerminal(tty=True), Clock()
    progress = Progress(Options(), out, clock)
    progress("checking miner: 23 controllers")
    clock.now = 0.05
    progress("too soon: not shown")
    clock.now = 0.5
    progress("analysing   the state tables")
    progress.done()
    assert out.getvalue() == (
        "\r\x1b[Kchecking miner: 23 controllers\r\x1b[Kanalysing the state tables\r\x1b[K"
    )


def test_progress_in_a_log_says_something_only_for_long_work() -> None:
    out, clock = FakeTerminal(tty=False), Clock()
    progress = Progress(Options(), out, clock, after=2.0)
    progress("cycle 10/2000")
    clock.now = 1.0
    progress("cycle 100/2000")
    clock.now = 2.5
    progress("cycle 500/2000  sb BOX_CUT/S2")
    progress("")  # never an empty line
    clock.now = 3.0
    progress("cycle 600/2000")  # within the interval
    progress.done()
    assert out.getvalue() == "  cycle 500/2000 sb BOX_CUT/S2\n"


@pytest.mark.parametrize("options", [Options(quiet=True), Options(fmt="json")])
def test_no_progress_when_quiet_or_for_machines(options: Options) -> None:
    out = FakeTerminal(tty=True)
    progress = Progress(options, out)
    progress("checking")
    progress.done()
    assert out.getvalue() == ""


def test_shell_completion_of_warning_codes(tiny: Path, monkeypatch) -> None:
    monkeypatch.setenv("_RCSGEN_COMPLETE", "bash_complete")
    monkeypatch.setenv("COMP_WORDS", "rcsgen validate --ignore W503,W50")
    monkeypatch.setenv("COMP_CWORD", "3")
    result = CliRunner().invoke(main, [], prog_name="rcsgen")
    assert "plain,W503,W505" in result.output.splitlines()
    assert all(line.startswith("plain,W503,W50") for line in result.output.splitlines())


def test_a_bug_is_one_line_and_exit_3(tiny: Path, monkeypatch) -> None:
    """An exception rcsgen did not foresee is not a traceback: one line, exit 3."""

    def broken(*args: object, **kwargs: object) -> None:
        raise KeyError("surprise")

    monkeypatch.setattr("rcsgen.api.compile_paths", broken)
    result = CliRunner().invoke(main, ["validate", "sys"])
    assert result.exit_code == 3
    assert result.output == (
        "internal error (a bug in rcsgen; please report it): KeyError: 'surprise'\n"
        "set RCSGEN_TRACEBACK=1 to see where it happened\n"
    )

    def disk_full(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device", "/tmp/x")

    monkeypatch.setattr("rcsgen.api.compile_paths", disk_full)
    full = CliRunner().invoke(main, ["validate", "sys"])
    assert (full.exit_code, full.output) == (1, "error: No space left on device: `/tmp/x`\n")


def test_a_report_is_plain_text_unless_colour_is_asked_for(capsys) -> None:
    """The reports made inside commands (`rcsgen up` on a stale package, `rcsgen doc` on bad
    specs) use the default options: no escape codes in a log or a pipe."""
    diags = Diagnostics()
    diags.error(Span("a.yaml", 2, 3), "E204", "undeclared command `GO`", "declare it")
    assert report(diags, Options()).fails
    plain = capsys.readouterr().err
    assert "a.yaml:2:3: error[E204]: undeclared command `GO`" in plain
    assert "\x1b[" not in plain
    report(diags, Options(color=True))
    assert "\x1b[" in capsys.readouterr().err
