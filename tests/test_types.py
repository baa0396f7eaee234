"""Enumerations and strings (`type: enum`, `type: str`): checked, generated, run and refused.

The system is tests/cases/valid/typed: `top` sends `sub.MEASURE` a string and an enum it
was given, `sub` answers with an enum and a string result and a hook's string, `top` keeps
an enum local. Mistakes are checked on mutated copies of it; the invalid corpus holds one
case per code as well (tests/cases/invalid/e274-* ... w307-*).
"""

from __future__ import annotations

import ast
import importlib
import json
import re
import shutil
from pathlib import Path

import pytest
from conftest import edit, rcsgen
from support.browser import load, needs_chromium

from rcsgen.compiler import expressions as expr
from rcsgen.compiler.back_end.emit import render_system
from rcsgen.compiler.diagnostics import Diagnostics, Span
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.types import BOOL, Str
from rcsgen.runtime import contract
from rcsgen.runtime.operate import command, launcher
from rcsgen.tools.harness import Harness, generate, import_package
from rcsgen.tools.scenario import check_scenario, read_trace
from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces import view as trace_view

TYPED = Path(__file__).resolve().parent / "cases" / "valid" / "typed"


@pytest.fixture
def typed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(TYPED, tmp_path / "typed", ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.chdir(tmp_path)
    return tmp_path / "typed"


def findings(directory: Path) -> list[tuple[str, str, int, str]]:
    """(code, file, line, message) of every diagnostic the front end reports."""
    found = compile_paths([directory]).diagnostics
    return [(d.code, Path(d.span.file).name, d.span.line, d.message) for d in found]


def codes(directory: Path) -> set[str]:
    return {code for code, *_ in findings(directory)}


# ---------------------------------------------------------------- running


def inspect(h: Harness, program: str, side: str) -> None:
    h.command("top", "INSPECT", program=program, side=side)
    h.cycle(4)


def test_enums_travel_as_names_and_strings_as_text(typed: Path) -> None:
    with Harness.build(typed) as h:
        inspect(h, "bracket", "LEFT")
        assert h.status("top").status == "DONE"
        assert h.sent("sub").args == {"program": "bracket", "side": "LEFT"}
        assert h.results("sub") == {"verdict": "PASS", "seen": "bracket"}
        assert h.results("top") == {"verdict": "PASS"}
        assert h.world.snapshot() == {"side": "LEFT", "label": "bracket@0"}  # a hook's text
        assert h.controller("top").var_last == 0  # PASS, stored as its index
        inspect(h, "flange", "RIGHT")
        assert h.results("sub") == {"verdict": "FAIL", "seen": "other"}
        assert h.results("top") == {"verdict": "FAIL"}
        assert h.world.snapshot() == {"side": "RIGHT", "label": "flange@1"}
        assert h.controller("top").var_last == 1  # `set: {last: sub.result.verdict}`


def test_utf8_text_fills_its_field_exactly(typed: Path) -> None:
    """16 bytes of UTF-8 fit a str of size 16, however many characters they are."""
    with Harness.build(typed) as h:
        text = "é" * 8  # 16 bytes
        h.world["label"] = text
        assert h.world["label"] == text
        with pytest.raises(ValueError, match="17 bytes: more than the 16"):
            h.world["label"] = text + "x"
        assert h.world["label"] == text  # refused whole, not truncated


def test_a_hook_string_too_long_for_its_target_is_a_hook_error(typed: Path) -> None:
    with Harness.build(typed) as h, pytest.raises(Exception) as caught:
        inspect(h, "p" * 16, "RIGHT")  # the hook returns "ppp...@1": 18 bytes for 16
    assert type(caught.value).__name__ == "HookError"
    message = str(caught.value)
    assert "hook `describe` of `sub` returned 'pppppppppppppppp@1'" in message
    assert "needs a str of at most 16 bytes" in message


def test_a_hook_result_for_an_enum_is_an_index_of_its_values(typed: Path) -> None:
    edit(typed / "typed_hooks" / "sub.py", 'return f"{program}@{side}"', "return side * 3")
    edit(typed / "sub.yaml", "returns: [world.label]", "returns: [kind]")
    edit(
        typed / "sub.yaml",
        "hooks_module:",
        "locals:\n  kind: {type: enum, values: [A, B, C, D], initial: A}\n\nhooks_module:",
    )
    assert "E241" in codes(typed)  # annotated `-> str`: an enum's target takes an int
    edit(typed / "typed_hooks" / "sub.py", "-> str:", "-> int:")
    with Harness.build(typed) as h:
        inspect(h, "bracket", "RIGHT")  # side 1: the hook returns 3, D
        assert h.controller("sub").var_kind == 3
        inspect(h, "bracket", "LEFT")  # side 0: 0, A
        assert h.controller("sub").var_kind == 0
    again = shutil.copytree(typed, typed.parent / "again")  # hook modules are not reloaded
    edit(again / "typed_hooks" / "sub.py", "return side * 3", "return side * 4")
    with Harness.build(again) as h, pytest.raises(Exception) as caught:
        inspect(h, "bracket", "RIGHT")  # 4: no value of four
    assert type(caught.value).__name__ == "HookError"
    assert "returned 4; its `returns:` needs an int 0..3 (an enum's index)" in str(caught.value)


def test_the_console_takes_names_and_refuses_what_does_not_fit(typed: Path) -> None:
    with Harness.build(typed) as h:
        layout = h.layout
        sent = command.parse_command(layout, "top", "INSPECT", ["program=bracket", "side=RIGHT"])
        assert sent.args == {"program": "bracket", "side": "RIGHT"}
        with pytest.raises(ValueError) as long:
            command.parse_command(layout, "top", "INSPECT", ["program=" + "x" * 17, "side=LEFT"])
        assert str(long.value) == (
            "top.INSPECT: parameter program is 'xxxxxxxxxxxxxxxxx': 17 bytes of UTF-8, more "
            "than the 16 it holds"
        )
        with pytest.raises(ValueError) as typo:
            command.parse_command(layout, "top", "INSPECT", ["side=LEFTT"])
        assert str(typo.value) == (
            "top.INSPECT: parameter side is 'LEFTT', not one of LEFT, RIGHT (did you mean LEFT?)"
        )
        assert launcher.parse_world(layout, ["side=RIGHT", "label=bore"]) == {
            "side": "RIGHT",
            "label": "bore",
        }
        with pytest.raises(ValueError, match=r"^--world: label is .*: 17 bytes of UTF-8, more"):
            launcher.parse_world(layout, ["label=" + "x" * 17])
        with pytest.raises(ValueError, match=r"^--world: side is 'UP', not one of LEFT, RIGHT$"):
            launcher.parse_world(layout, ["side=UP"])


def test_records_name_their_string_fields_and_refuse_long_text() -> None:
    record = contract.Record(__import__("struct").Struct("<Qq4s?"), 0, ("n", "text", "flag"))
    buf = memoryview(bytearray(32))
    contract.SEQ.pack_into(buf, 0, contract.FIRST_SEQ)
    assert record.codes() == {"n": "q", "text": "4s", "flag": "?"}
    record.write(buf, text="ab")
    assert record.read(buf) == {"n": 0, "text": "ab", "flag": False}
    record.write(buf, flag=True)  # the other fields are kept, the text too
    assert record.read(buf)["text"] == "ab"
    with pytest.raises(ValueError, match="5 bytes: more than the 4"):
        record.write(buf, text="abcde")
    with pytest.raises(ValueError, match="NUL"):
        record.write(buf, text="a\0b")
    assert record.read(buf)["text"] == "ab"
    assert contract.field_codes("<QI32s44x???1xI") == ["Q", "I", "32s", "?", "?", "?", "I"]


def test_a_scenario_refuses_an_unknown_value_and_a_long_string(typed: Path) -> None:
    (typed / "scenarios").mkdir()
    path = typed / "scenarios" / "bad.yaml"
    path.write_text(
        "scenario: bad\ntitle: Bad values\nmax_cycles: 10\nevents:\n"
        "  - cycle: 1\n    command: top.INSPECT\n"
        "    with: {program: xxxxxxxxxxxxxxxxx, side: LEFFT}\n"
        "    set: {side: RIGHT, label: ok}\n",
        encoding="utf-8",
    )
    scenario, diags = check_scenario(path)
    assert scenario is None
    found = sorted((d.code, d.span.line, d.span.col, d.message, d.hint) for d in diags)
    assert [(code, line) for code, line, *_ in found] == [("E408", 7), ("E408", 7)]
    messages = " | ".join(m for *_, m, _ in found)
    assert "parameter `program` is a string of at most 16 bytes" in messages
    assert "parameter `side` is an enum: give one of LEFT, RIGHT, not `LEFFT`" in messages
    assert "did you mean `LEFT`?" in [hint for *_, hint in found]


# ---------------------------------------------------------------- checking


def test_a_bare_value_name_resolves_against_the_other_operand(typed: Path) -> None:
    edit(typed / "top.yaml", "sub.result.verdict == PASS", "sub.result.verdict == PASSS")
    assert [(c, f, m) for c, f, _, m in findings(typed)] == [
        ("E274", "top.yaml", "`PASSS` is not a value of enum PASS, FAIL")
    ]
    edit(typed / "top.yaml", "sub.result.verdict == PASSS", "PASS == sub.result.verdict")
    assert findings(typed) == []  # either side


@pytest.mark.parametrize(
    ("old", "new", "code", "message"),
    [
        ("side == LEFT", "side < RIGHT", "E275", "cannot compare enum LEFT, RIGHT with enum"),
        ("side == LEFT", "side == 1", "E277", "cannot compare enum LEFT, RIGHT with an integer"),
        (
            "program == 'bracket'",
            "program + 'x' == 'y'",
            "E275",
            "expected a number, got a string of at most 16 bytes",
        ),
        ("program == 'bracket'", "program", "E275", "expected a boolean, got a string"),
        (
            "program == 'bracket'",
            "program == 'a string of more than 255 bytes " + "x" * 230 + "'",
            "E276",
            "invalid string literal",
        ),
    ],
    ids=["order", "enum-with-int", "arithmetic", "as-a-guard", "literal-too-long"],
)
def test_what_an_enum_or_a_string_cannot_do(
    typed: Path, old: str, new: str, code: str, message: str
) -> None:
    edit(typed / "sub.yaml", old, new)
    found = [(c, m) for c, _, _, m in findings(typed) if not c.startswith("W5")]
    assert len(found) == 1 and found[0][0] == code, found
    assert message in found[0][1]


def test_assignment_needs_the_same_enum_and_room_for_the_string(typed: Path) -> None:
    edit(
        typed / "top.yaml",
        "values: [PASS, FAIL]\n    initial: FAIL",
        "values: [GOOD, BAD]\n    initial: BAD",
    )
    edit(typed / "top.yaml", "set: {last: PASS,", "set: {last: GOOD,")
    assert [(c, m) for c, _, _, m in findings(typed)] == [
        ("E277", "expected enum GOOD, BAD, got enum PASS, FAIL")
    ]
    shutil.rmtree(typed)
    shutil.copytree(TYPED, typed, ignore=shutil.ignore_patterns("__pycache__"))
    edit(typed / "top.yaml", "program: {type: str, size: 16}", "program: {type: str, size: 17}")
    assert [(c, m) for c, _, _, m in findings(typed)] == [
        ("E277", "expected a string of at most 16 bytes, got a string of at most 17 bytes")
    ]


def test_an_enum_value_is_one_module_constant(typed: Path) -> None:
    """Values name module constants (`self.arg_side == LEFT`): one index per name."""
    generated = emit_sub_module(typed)
    assert "LEFT = 0\n" in generated and "self.arg_side == LEFT" in generated
    edit(
        typed / "top.yaml",
        "values: [PASS, FAIL]\n    initial: FAIL",
        "values: [FAIL, PASS]\n    initial: FAIL",
    )
    found = [(c, f, m) for c, f, _, m in findings(typed) if c == "E228"]
    assert len(found) == 1, found
    assert found[0][2].startswith("enum value `PASS` is 0 in `verdict` but 1 in `last`")


def emit_sub_module(directory: Path) -> str:
    system = compile_paths([directory]).systems[0]
    return render_system(system)["typed/sub.py"]


def test_declarations_are_checked(typed: Path) -> None:
    edit(typed / "system.yaml", "initial: LEFT", "initial: LEFFT")
    edit(typed / "system.yaml", "initial: none", "initial: a long label, longer than 16")
    edit(
        typed / "top.yaml",
        "values: [PASS, FAIL]\n    initial: FAIL",
        "values: [DONE]\n    initial: DONE",
    )
    found = sorted((c, f, m) for c, f, _, m in findings(typed) if c != "E277")
    assert found == [
        (
            "E274",
            "system.yaml",
            "initial value `LEFFT` of `side` is not a value of enum LEFT, RIGHT",
        ),
        (
            "E276",
            "system.yaml",
            "initial value of `label`: 'a long label, longer'... is 28 bytes: more than the "
            "16 it holds",
        ),
        ("E278", "top.yaml", "enum value `DONE` of `last` is a status name"),
        ("W307", "top.yaml", "enum `last` has one value, `DONE`: it can never change"),
    ]


def test_string_literals_are_printed_as_constants() -> None:
    """A string literal reaches Python only through repr(): quotes, backslashes and code in
    it stay text."""
    diags = Diagnostics()
    scope = expr.Scope(params={"p": Str(64)})
    for text in ("'a\"); import os; (\"'", "'\\\\x'", '"it\'s"', "'__import__(\"os\")'"):
        tree = expr.compile_expr(f"p == {text}", Span("t"), scope, diags, BOOL)
        assert tree is not None, diags
        python = expr.to_python(tree, lambda ref: "self.arg_p")
        literal = python.removeprefix("self.arg_p == ")
        assert ast.literal_eval(literal) == ast.literal_eval(text)
    assert not diags.errors


def test_the_analysis_decides_enums_and_never_proves_string_equalities(typed: Path) -> None:
    edit(typed / "top.yaml", "sub.result.verdict != PASS", "sub.result.verdict != FAIL")
    overlaps = [(c, m) for c, _, _, m in findings(typed) if c == "E501"]
    assert len(overlaps) == 1 and "sub.result.verdict=PASS" in overlaps[0][1]
    edit(typed / "sub.yaml", "    first_match: [S0]\n", "")
    found = [(c, m) for c, _, _, m in findings(typed) if c.startswith(("E5", "W5"))]
    assert ("W502" in {c for c, _ in found}) and not any(
        c == "E501" and "program" in m for c, m in found
    )


GOOD = """\
scenario: good
title: A program and a side, by name
max_cycles: 20
stop_when_done: top
trace: {world: [side, label]}
report: {figures: [side, label]}
expect:
  status: DONE
  figures: {side: RIGHT, label: "flange@1"}
events:
  - cycle: 1
    set: {label: "é"}
  - cycle: 2
    command: top.INSPECT
    with: {program: flange, side: RIGHT}
"""


def test_a_scenario_sets_sends_traces_and_expects_by_name(typed: Path) -> None:
    (typed / "scenarios").mkdir()
    (typed / "scenarios" / "good.yaml").write_text(GOOD, encoding="utf-8")
    trace = typed.parent / "good.jsonl"
    ran = rcsgen("run", typed / "scenarios" / "good.yaml", "--trace", trace)
    assert ran.exit_code == 0, ran.output
    lines = [json.loads(line) for line in read_trace(trace)]
    assert lines[0]["world"] == {"side": "LEFT", "label": "é"}
    assert lines[-1]["world"] == {"side": "RIGHT", "label": "flange@1"}
    edit(typed / "scenarios" / "good.yaml", "side: RIGHT, label", "side: LEFT, label")
    ran = rcsgen("run", typed / "scenarios" / "good.yaml", "--trace", trace)
    assert ran.exit_code == 1 and "E416" in ran.output and "RIGHT" in ran.output
    edit(typed / "scenarios" / "good.yaml", "side: LEFT, label", "side: {min: 1}, label")
    ran = rcsgen("validate", typed)
    assert ran.exit_code == 1
    assert "E415" in ran.output and "`side` is an enum: expect one value, not a range" in ran.output


def test_reference_pages_name_the_values_and_sizes(typed: Path) -> None:
    out = typed.parent / "reference"
    assert rcsgen("doc", typed, "-o", out).exit_code == 0
    page = (out / "typed" / "sub.md").read_text(encoding="utf-8")
    assert "### MEASURE(program: str[16], side: enum(LEFT, RIGHT))" in page
    assert "| `result.verdict` | enum(PASS, FAIL) |" in page
    world = (out / "typed" / "README.md").read_text(encoding="utf-8")
    assert "| `side` | enum(LEFT, RIGHT) | `LEFT` |" in world
    assert "| `label` | str[16] | `'none'` |" in world


def test_the_console_of_a_running_system_sends_and_shows_names(tmp_path: Path) -> None:
    from test_ctl import Running  # a system launched as OS processes, on a pid-named segment

    scratch, name = generate(TYPED)
    try:
        package = import_package(scratch / name, TYPED)
        layout = importlib.import_module(f"{package.__name__}.layout")
        running = Running(scratch / name, TYPED, layout)
        try:
            sent = running.ctl("send", "top", "INSPECT", "program=bracket", "side=LEFT")
            assert sent.returncode == 0, sent.stderr
            assert sent.stdout.splitlines()[0] == "sent top.INSPECT program=bracket side=LEFT #2"
            assert running.ctl("wait", "top", "DONE", "--timeout", "20").returncode == 0
            modules = running.json()["modules"]
            assert modules["top"]["args"] == {"program": "bracket", "side": "LEFT"}
            assert modules["top"]["results"] == {"verdict": "PASS"}
            assert modules["sub"]["results"] == {"verdict": "PASS", "seen": "bracket"}
            long = running.ctl("send", "top", "INSPECT", "program=" + "x" * 17, "side=LEFT")
            typo = running.ctl("send", "top", "INSPECT", "program=x", "side=LEFTT")
            assert (long.returncode, typo.returncode) == (2, 2)
            assert long.stderr.splitlines() == [
                "ctl: error: top.INSPECT: parameter program is 'xxxxxxxxxxxxxxxxx': 17 bytes of "
                "UTF-8, more than the 16 it holds"
            ]
            assert "(did you mean LEFT?)" in typo.stderr and len(typo.stderr.splitlines()) == 1
        finally:
            running.stop()
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


@needs_chromium
def test_the_trace_view_shows_enum_and_string_fields_by_value(typed: Path) -> None:
    (typed / "scenarios").mkdir()
    (typed / "scenarios" / "good.yaml").write_text(GOOD, encoding="utf-8")
    trace_file = typed.parent / "good.jsonl"
    assert rcsgen("run", typed / "scenarios" / "good.yaml", "--trace", trace_file).exit_code == 0
    system = compile_paths([typed]).systems[0]
    trace = traces.load(trace_file)
    page = typed.parent / "good.html"
    page.write_text(trace_view.render(trace, traces.lanes(trace, system), "typed", 0.1))
    shown = load(f"{page.as_uri()}#cycle=3", typed.parent, "typed")
    assert shown.console == [], shown.console
    assert shown.body().get("data-ready") == "1" and "data-error" not in shown.body()
    assert 'class="plot" data-field="side"' in shown.dom
    assert re.search(r"<td>side</td><td[^>]*>RIGHT</td>", shown.dom), shown.dom[-2000:]
    assert re.search(r"<td>label</td><td[^>]*>flange@1</td>", shown.dom)
