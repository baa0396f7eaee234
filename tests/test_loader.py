"""Tests for the Load stage: typing, spans and every loader diagnostic."""

from __future__ import annotations

import copy
import json
import os
import pathlib
from pathlib import Path

import jsonschema
import pytest
import yaml

from rcsgen.compiler.diagnostics import Diagnostic, Span, SpecError
from rcsgen.compiler.front_end import loader as loader_module
from rcsgen.compiler.front_end.loader import (
    MAX_BYTES,
    MAX_DEPTH,
    LocDict,
    LocList,
    LocStr,
    load_file,
    load_text,
    value_span,
)

PATH = "specs/demo.yaml"
NOWHERE = Span("nowhere")


def diagnostics(text: str, path: str = PATH) -> list[Diagnostic]:
    """The sorted diagnostics of a text that must fail to load."""
    with pytest.raises(SpecError) as info:
        load_text(text, path)
    return list(info.value.diagnostics)


def located(diags: list[Diagnostic]) -> list[tuple[str, int, int]]:
    return [(d.code, d.span.line, d.span.col) for d in diags]


def file_diagnostics(path: pathlib.Path, display: str = PATH) -> list[Diagnostic]:
    with pytest.raises(SpecError) as info:
        load_file(path, display)
    return list(info.value.diagnostics)


# --- scalar typing ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("scalar", "expected"),
    [
        ("on", "on"),
        ("off", "off"),
        ("yes", "yes"),
        ("no", "no"),
        ("y", "y"),
        ("n", "n"),
        ("True", True),
        ("true", True),
        ("TRUE", True),
        ("false", False),
        ("FALSE", False),
        ("tRUE", "tRUE"),
        ("010", 10),
        ("-12", -12),
        ("+7", 7),
        ("0x1F", 31),
        ("0o17", 15),
        ("1_000", "1_000"),
        ("1:20", "1:20"),
        ("2001-12-14", "2001-12-14"),
        ("'true'", "true"),
        ('"010"', "010"),
        ("1.5e3", 1500.0),
        ("1e3", 1000.0),
        (".5", 0.5),
        ("-2.", -2.0),
        ("~", None),
        ("null", None),
        ("NULL", None),
        ("", None),
        ("'~'", "~"),
        ("|\n  on\n", "on\n"),
        ("stop now", "stop now"),
    ],
)
def test_plain_scalars_follow_the_strict_yaml_1_2_core_schema(scalar: str, expected: object):
    value = load_text(f"v: {scalar}\n", PATH)["v"]
    assert value == expected
    assert type(value) is (LocStr if isinstance(expected, str) else type(expected))


def test_strings_are_locstr_and_numbers_bools_and_null_are_plain_values():
    data = load_text("s: go\nq: 'x'\ni: 3\nf: 2.5\nb: false\nz: null\n", PATH)
    assert isinstance(data["s"], LocStr) and data["s"].span == Span(PATH, 1, 4)
    assert isinstance(data["q"], LocStr) and data["q"].span == Span(PATH, 2, 4)
    assert [type(data[k]) for k in "ifbz"] == [int, float, bool, type(None)]
    assert value_span(data, "z", NOWHERE) == Span(PATH, 6, 4)


def test_located_containers_behave_like_plain_containers():
    data = load_text("name: pump\nstates: [on, off]\nlimits: {max: 3}\n", PATH)
    plain = {"name": "pump", "states": ["on", "off"], "limits": {"max": 3}}
    assert data == plain
    assert isinstance(data, LocDict) and isinstance(data["states"], LocList)
    assert hash(LocStr("a", Span(PATH))) == hash("a") and LocStr("a", Span(PATH)) == "a"
    assert all(isinstance(key, LocStr) for key in data)
    assert json.loads(json.dumps(data)) == plain
    schema = {
        "type": "object",
        "properties": {"states": {"type": "array", "items": {"type": "string"}}},
        "required": ["name"],
    }
    jsonschema.validate(data, schema)
    clone = copy.deepcopy(data)
    assert clone == plain and clone["states"][1].span == Span(PATH, 2, 14)


# --- spans --------------------------------------------------------------------------------------

NESTED = """\
controller:
  name: sump
  states:
    - idle
    - {name: run, next: idle}
  limits:
      depth: 12
"""


def test_spans_of_nested_keys_values_and_items():
    data = load_text(NESTED, PATH)
    assert data.span == Span(PATH, 1, 1)
    assert data.key_spans == {"controller": Span(PATH, 1, 1)}
    ctrl = data["controller"]
    assert value_span(data, "controller", NOWHERE) == ctrl.span == Span(PATH, 2, 3)
    assert ctrl.key_spans == {
        "name": Span(PATH, 2, 3),
        "states": Span(PATH, 3, 3),
        "limits": Span(PATH, 6, 3),
    }
    assert ctrl.value_spans["name"] == ctrl["name"].span == Span(PATH, 2, 9)
    states = ctrl["states"]
    assert states.span == value_span(ctrl, "states", NOWHERE) == Span(PATH, 4, 5)
    assert states.item_spans == [Span(PATH, 4, 7), Span(PATH, 5, 7)]
    assert value_span(states, 1, NOWHERE) == states[1].span == Span(PATH, 5, 7)
    assert states[1].key_spans["next"] == Span(PATH, 5, 19)
    assert value_span(states[1], "next", NOWHERE) == states[1]["next"].span == Span(PATH, 5, 25)
    assert value_span(ctrl["limits"], "depth", NOWHERE) == Span(PATH, 7, 14)
    assert [key.span for key in ctrl] == list(ctrl.key_spans.values())


def test_bom_and_crlf_do_not_shift_spans():
    data = load_text("\ufeffa: 1\r\nb:\r\n  - x\r\n", PATH)
    assert data == {"a": 1, "b": ["x"]}
    assert data.key_spans["a"] == Span(PATH, 1, 1)
    assert data["b"].item_spans == [Span(PATH, 3, 5)]


def test_top_level_scalar_and_empty_documents():
    top = load_text("hello\n", PATH)
    assert top == "hello" and top.span == Span(PATH, 1, 1)
    for empty in ("", "\n", "# only a comment\n", "---\n", "~\n", "--- \n...\n"):
        assert load_text(empty, PATH) is None


def test_value_span_falls_back_for_plain_containers():
    assert value_span({"a": 1}, "a", NOWHERE) == NOWHERE
    assert value_span([1], 0, NOWHERE) == NOWHERE


# --- duplicate and non-string keys --------------------------------------------------------------


def test_duplicate_key_is_reported_at_the_second_occurrence():
    [diag] = diagnostics("a: 1\nb: 2\nmode:\n  x: 1\n  'x': 2\n")
    assert (diag.code, diag.span) == ("E002", Span(PATH, 5, 3))
    assert diag.message == "duplicate key `x`"
    assert "first defined at line 4" in diag.hint and "PyYAML" in diag.hint


def test_every_duplicate_is_reported_in_one_pass():
    diags = diagnostics("a: 1\nb: 2\na: 3\nb: 4\na: 5\n")
    assert located(diags) == [("E002", 3, 1), ("E002", 4, 1), ("E002", 5, 1)]
    assert [d.hint.split(";")[0] for d in diags] == [
        "first defined at line 1",
        "first defined at line 2",
        "first defined at line 1",
    ]


def test_all_kinds_of_errors_are_collected_in_one_pass():
    text = "a: 1\na: 2\n1: x\nv: !!str y\nw: *q\nn: .nan\nl: [1, {m: 1, m: 2}]\n"
    assert located(diagnostics(text)) == [
        ("E002", 2, 1),
        ("E003", 3, 1),
        ("E005", 4, 4),
        ("E005", 5, 4),
        ("E004", 6, 4),
        ("E002", 7, 15),
    ]


def test_same_key_in_different_mappings_is_fine():
    assert load_text("a: {x: 1}\nb: {x: 2}\n", PATH) == {"a": {"x": 1}, "b": {"x": 2}}


@pytest.mark.parametrize(
    ("key", "col"),
    [("1", 1), ("true", 1), ("null", 1), ("~", 1), ("1.5", 1), ("0x10", 1), (".inf", 1)]
    + [("[a]", 1), ("{a: 1}", 1), ("? [a, b]\n", 3)],
)
def test_non_string_keys_are_rejected(key: str, col: int):
    [diag] = diagnostics(f"ok: 1\n{key}: x\n")
    assert (diag.code, diag.span) == ("E003", Span(PATH, 2, col))
    assert "key" in diag.hint


def test_quoted_and_word_keys_are_strings():
    data = load_text("'1': a\n\"true\": b\non: c\nno: d\n", PATH)
    assert data == {"1": "a", "true": "b", "on": "c", "no": "d"}


# --- tags, anchors, aliases, merge keys ---------------------------------------------------------


def test_python_object_tag_is_rejected_and_never_executed(tmp_path, monkeypatch):
    calls: list[str] = []
    monkeypatch.setattr(os, "system", calls.append)
    marker = tmp_path / "pwned"
    text = f'run: !!python/object/apply:os.system ["touch {marker}"]\n'
    [diag] = diagnostics(text)
    assert (diag.code, diag.span, diag.message) == (
        "E005",
        Span(PATH, 1, 6),
        "tags are not allowed",
    )
    assert "!!python/object/apply:os.system" in diag.hint
    assert calls == [] and not marker.exists()


@pytest.mark.parametrize("tagged", ["!foo x", "!!str x", "!!binary aGk=", "! x", "!!map {a: 1}"])
def test_every_explicit_tag_is_rejected(tagged: str):
    assert located(diagnostics(f"v: {tagged}\n")) == [("E005", 1, 4)]


def test_a_tagged_key_is_reported_once_as_a_tag() -> None:
    """`!!str 1: x`: the tag is the one mistake told; the key it makes (1, not a string) is
    not reported again as E003."""
    [diag] = diagnostics("!!str 1: x\n")
    assert (diag.code, diag.span, diag.message) == (
        "E005",
        Span(PATH, 1, 1),
        "tags are not allowed",
    )
    assert diag.hint == "remove `!!str`; a spec is plain data and no tag is ever constructed"


def test_anchors_aliases_and_merge_keys_are_rejected():
    text = "base: &b {x: 1}\ncopy: *b\nmerged:\n  <<: {y: 2}\nquoted:\n  '<<': fine\n*b : 3\n"
    diags = diagnostics(text)  # an alias used as a key is not also reported as E003
    assert located(diags) == [("E005", 1, 7), ("E005", 2, 7), ("E005", 4, 3), ("E005", 7, 1)]
    assert all(d.message == "anchors, aliases and merge keys are not allowed" for d in diags)


def test_each_merge_key_is_told_once_and_never_as_a_duplicate_key() -> None:
    """Two `<<` in one mapping: each is E005, neither is also E002 (the key is dropped)."""
    diags = diagnostics("m:\n  <<: {a: 1}\n  <<: {b: 2}\n")
    assert located(diags) == [("E005", 2, 3), ("E005", 3, 3)]


# --- numbers ------------------------------------------------------------------------------------


@pytest.mark.parametrize("number", [".nan", ".NaN", ".inf", "-.inf", "+.Inf", ".INF", "1e999"])
def test_nan_and_infinity_are_rejected(number: str):
    [diag] = diagnostics(f"limits:\n  - 1\n  - {number}\n")
    assert (diag.code, diag.span) == ("E004", Span(PATH, 3, 5))
    assert diag.message == "NaN and infinity are not allowed"
    assert f"`{number}`" in diag.hint


def test_quoted_nan_is_a_string():
    assert load_text("v: '.nan'\n", PATH) == {"v": ".nan"}


# --- limits -------------------------------------------------------------------------------------


def test_size_limit_counts_utf8_bytes():
    assert load_text("#" * MAX_BYTES, PATH) is None
    assert located(diagnostics("#" * (MAX_BYTES + 1))) == [("E006", 1, 1)]
    assert located(diagnostics("# " + "é" * (MAX_BYTES // 2))) == [("E006", 1, 1)]


def test_size_limit_in_load_file(tmp_path):
    big = tmp_path / "big.yaml"
    big.write_bytes(b"a: " + b"x" * MAX_BYTES)
    assert located(file_diagnostics(big)) == [("E006", 1, 1)]


def test_nesting_up_to_max_depth_is_fine_and_one_more_is_e007():
    assert load_text("[" * MAX_DEPTH + "]" * MAX_DEPTH, PATH) is not None
    too_deep = "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1)
    assert located(diagnostics(too_deep)) == [("E007", 1, MAX_DEPTH + 1)]


def test_deep_block_nesting_is_reported_at_the_first_too_deep_mapping():
    text = "".join(f"{'  ' * i}k{i}:\n" for i in range(MAX_DEPTH + 5))
    assert located(diagnostics(text)) == [("E007", MAX_DEPTH + 1, 2 * MAX_DEPTH + 1)]


@pytest.mark.parametrize("opener", ["[", "{", "- ", "a: [", "{a: "])
def test_pathological_nesting_never_escapes_as_another_exception(opener: str):
    diags = diagnostics(opener * 100_000)
    assert diags and {d.code for d in diags} <= {"E001", "E007"}


# --- documents, syntax, encoding, files ---------------------------------------------------------


@pytest.mark.parametrize(("text", "line"), [("a: 1\n---\nb: 2\n", 2), ("--- a\n--- b\n", 2)])
def test_more_than_one_document_is_rejected(text: str, line: int):
    assert located(diagnostics(text)) == [("E009", line, 1)]


def test_nothing_after_a_second_document_start_is_read() -> None:
    """After E009 the rest of the stream is not read: what is wrong there (a tag, a
    duplicate key, a syntax error) is not reported on top of it."""
    text = "a: 1\n---\nb: !!str x\nb: 2\nc: [\n"
    [diag] = diagnostics(text)
    assert (diag.code, diag.span, diag.message) == (
        "E009",
        Span(PATH, 2, 1),
        "more than one YAML document in a file",
    )
    assert diag.hint == "a spec is a single document; remove this `---` and what follows"


@pytest.mark.parametrize(
    ("text", "line", "col", "code"),
    [('a: "\ud800"\n', 1, 5, "d800"), ("a: b\n# \udcff\n", 2, 3, "dcff")],
)
def test_a_lone_surrogate_is_e001_where_it_is_not_a_traceback(
    text: str, line: int, col: int, code: str
) -> None:
    """A str that no file can give (decoding is strict) but a caller can: libyaml cannot
    encode it, so the pure parser reads it and says where."""
    [diag] = diagnostics(text)
    assert (diag.code, diag.span, diag.message, diag.hint) == (
        "E001",
        Span(PATH, line, col),
        f"unacceptable character #x{code}: special characters are not allowed",
        "remove it",
    )


def test_explicit_single_document_is_fine():
    assert load_text("---\na: 1\n...\n", PATH) == {"a": 1}


def test_syntax_error_has_the_problem_line_and_no_pyyaml_dump():
    [diag] = diagnostics("a: 1\nb: [1, 2\nc: 3\n")
    assert (diag.code, diag.span) == ("E001", Span(PATH, 3, 2))
    assert diag.message == "expected ',' or ']', but got ':'"
    assert "line 2" in diag.hint
    assert "unicode string" not in diag.render() and "Traceback" not in diag.render()


def test_syntax_error_keeps_the_errors_found_before_it():
    assert located(diagnostics("a: 1\na: 2\nb: 'open\n")) == [("E002", 2, 1), ("E001", 4, 1)]


def test_control_character_is_a_syntax_error_at_its_position():
    [diag] = diagnostics("a: 1\nb: x\x00y\n")
    assert (diag.code, diag.span) == ("E001", Span(PATH, 2, 5))
    assert "#x0000" in diag.message


def test_invalid_utf8_is_reported_at_the_first_bad_byte(tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_bytes(b"a: 1\nb: \xc3\xa9t\xff\n")
    [diag] = file_diagnostics(spec)
    assert (diag.code, diag.span) == ("E008", Span(PATH, 2, 7))
    assert "0xff" in diag.message


def test_load_file_reads_utf8_with_bom_and_crlf(tmp_path):
    spec = tmp_path / "ok.yaml"
    spec.write_bytes(b"\xef\xbb\xbfname: caf\xc3\xa9\r\nstate: on\r\n")
    data = load_file(spec, PATH)
    assert data == {"name": "café", "state": "on"}
    assert value_span(data, "state", NOWHERE) == Span(PATH, 2, 8)


def test_a_directory_or_a_missing_file_is_located_not_raised(tmp_path):
    [diag] = file_diagnostics(tmp_path)
    assert (diag.code, diag.span) == ("E011", Span(PATH, 1, 1))
    assert diag.message == f"`{tmp_path.name}` is a directory, not a file"
    [missing] = file_diagnostics(tmp_path / "missing.yaml")
    assert missing.code == "E010"
    assert missing.message == "cannot read file: no such file or directory"


@pytest.mark.parametrize(
    "content",
    [
        b"a: 1\na: 2\n1: x\nv: !!str y\nw: *q\nn: .nan\n",
        b"a: [\n",
        b"\xff",
        b"a: 1\n---\nb: 2\n",
        b"[" * 10_000,
        b"#" * (MAX_BYTES + 1),
    ],
)
def test_every_diagnostic_names_the_display_path(tmp_path, content: bytes):
    spec = tmp_path / "real-name.yaml"
    spec.write_bytes(content)
    display = "specs/miner/shown.yaml"
    diags = file_diagnostics(spec, display)
    assert diags and all(d.span.file == display for d in diags)
    assert all(d.severity == "error" for d in diags)


def test_a_key_longer_than_yaml_allows_says_so_where_it_starts() -> None:
    """PyYAML gives up on a plain key over 1,024 characters with `could not find expected
    ':'`; the report says what is wrong instead, at the key."""
    [d] = diagnostics("a: 1\n" + "k" * 1100 + ": 2\n")
    assert (str(d.span), d.code) == (f"{PATH}:2:1", "E001")
    assert d.message == "a key of 1,100 characters: YAML allows a key of at most 1,024"
    assert d.hint.startswith("keys are names: shorten it")
    [short] = diagnostics("a: 1\nb c\nd: 2\n")  # any other scanner error keeps its words
    assert "a key of" not in short.message


def _as_built(value: object) -> object:
    """A loaded value with its type and every span, to compare two loaders' results."""
    if isinstance(value, LocDict):
        items = [
            (str(k), k.span, value.key_spans[k], value.value_spans[k], _as_built(v))
            for k, v in value.items()
        ]
        return ("dict", value.span, items, len(value.key_spans), len(value.value_spans))
    if isinstance(value, LocList):
        return ("list", value.span, value.item_spans, [_as_built(v) for v in value])
    return (type(value), value, getattr(value, "span", None))


UNUSUAL_TEXTS = [
    "a: !!str 1\n",
    "a: &x 1\nb: *x\n",
    "<<: {a: 1}\n",
    "a: 1\na: 2\n",
    "1: one\n",
    "[a]: b\n",
    "a: .nan\n",
    "a: -.inf\n",
    "a: 1\n---\nb: 2\n",
    "a: " + "[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1) + "\n",
]


@pytest.mark.parametrize("text", UNUSUAL_TEXTS)
def test_the_quick_loader_leaves_every_unusual_document_to_the_reporting_one(text: str) -> None:
    """What the loader reports (a tag, an anchor, a merge key, a duplicate or non-string key,
    NaN, a second document, deep nesting) the quick path never loads: it hands the text on."""
    assert loader_module._plain(text, PATH, yaml.CSafeLoader) is loader_module._UNUSUAL
    assert diagnostics(text)


def test_the_quick_loader_gives_the_reporting_ones_values_and_spans() -> None:
    """On the miner's specs and the file with the mistake of each loader case (E0xx),
    the quick path loads what the event builder loads, each value, type and span alike, or
    hands the document on; it hands on none of the specs' files."""
    root = pathlib.Path(__file__).resolve().parents[1]
    cases = root.glob("tests/cases/invalid/e0*/*.yaml")
    paths = sorted({*root.glob("specs/miner/*.yaml"), *cases})
    quick = 0
    for path in paths:
        text = path.read_text(encoding="utf-8", errors="replace").removeprefix("\ufeff")
        if "# expect: E0" not in text and "/invalid/" in path.as_posix():
            continue  # a case's other files are like the specs'
        try:
            fast = loader_module._plain(text, path.name, yaml.CSafeLoader)
        except yaml.YAMLError:
            fast = loader_module._UNUSUAL
        diags, built = loader_module._build(text, path.name, yaml.CSafeLoader)
        if fast is loader_module._UNUSUAL:
            assert "/invalid/" in path.as_posix(), path
            continue
        quick += 1
        assert not diags.errors, path
        assert _as_built(fast) == _as_built(built), path
    assert quick > 20


def test_a_path_is_shown_relative_inside_the_working_directory_and_whole_outside(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`specs/x.yaml` for a file below the working directory; `/…/elsewhere/x.yaml`, not
    `../elsewhere/x.yaml`, for one outside it (the climb says less than the path)."""
    from rcsgen.compiler.frontend import display_path

    (tmp_path / "work" / "specs").mkdir(parents=True)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "work")
    assert display_path(tmp_path / "work" / "specs" / "x.yaml") == "specs/x.yaml"
    assert display_path(Path("specs/x.yaml")) == "specs/x.yaml"
    outside = (tmp_path / "elsewhere" / "x.yaml").resolve()
    assert display_path(tmp_path / "elsewhere" / "x.yaml") == outside.as_posix()
    assert display_path(Path("../elsewhere/x.yaml")) == outside.as_posix()


def test_a_character_of_a_quoted_or_block_scalar_is_found_where_it_is_written() -> None:
    """`char_span` steps over what quoting adds: a single-quoted scalar's opening quote and
    its doubled quotes, a double-quoted one's escapes, a block's indicator line (its `-` is
    not the text's); a whitespace character or one past the end is just after the
    character before it. (The text starts with a line break: line 2's columns count from
    it, the file's first character.)"""
    text = "\nb: '''q'' == r'\nc: \"\\\"q\\\" == r\"\nd: |-\n  -p ==\n  q\ne: >-\n  -s\n  t\n"
    data = load_text(text, PATH)

    def columns(key: str) -> list[tuple[int, int]]:
        value = data[key]
        spans = [loader_module.char_span(value, value, i) for i in range(len(value) + 1)]
        return [(span.line, span.col) for span in spans if span is not None]

    assert columns("b") == [(2, c) for c in (5, 7, 8, 9, 11, 12, 13, 14, 15)]
    assert columns("c") == [(3, c) for c in (6, 7, 9, 10, 11, 12, 13, 14, 15)]
    assert columns("d") == [(5, 3), (5, 4), (5, 5), (5, 6), (5, 7), (5, 8), (6, 3), (6, 4)]
    assert columns("e") == [(8, 3), (8, 4), (8, 5), (9, 3), (9, 4)]
    last = load_text("d: |", PATH)["d"]  # an empty block at the end: no line of text
    assert loader_module.char_span(last, last, 0) is None
