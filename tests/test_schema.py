"""Schema stage: the JSON schemas accept the examples and each error maps to one located S0xx."""

from __future__ import annotations

import pathlib
import textwrap

import pytest
from jsonschema import Draft202012Validator

from rcsgen.compiler.diagnostics import Span
from rcsgen.compiler.front_end.loader import load_text
from rcsgen.compiler.front_end.schema import check_document, schema_for

SPECS = pathlib.Path(__file__).resolve().parent.parent / "specs"
MINER = SPECS / "miner"
# Every shipped spec as an editor sees it: fragments not expanded (`{use: ...}` states).
# Every spec file: a system's, and a template's (specs/platoon/vehicle/) beside it.
EXAMPLES = sorted(
    p
    for p in [*SPECS.glob("*/*.yaml"), *SPECS.glob("*/*/*.yaml")]
    # scenarios are checked apart; counter-examples are what `rcsgen prove` writes (gitignored)
    if p.name != "fragments.yaml" and p.parent.name not in ("scenarios", "counterexamples")
)
SCENARIOS = sorted(SPECS.glob("*/scenarios/*.yaml"))


def kind_of(path: pathlib.Path) -> str:
    if path.name == "system.yaml":
        return "system"
    if path.name == "template.yaml":
        return "template"
    first = path.read_text(encoding="utf-8").splitlines()[0]
    return "operator" if "operator.schema.json" in first else "controller"


def check(text: str, kind: str = "controller") -> list:
    return check_document(load_text(textwrap.dedent(text), "x.yaml"), kind, "x.yaml")


def only(diags: list, code: str):
    """The single diagnostic of `code`, failing with the whole list otherwise."""
    found = [d for d in diags if d.code == code]
    assert len(found) == 1, diags
    return found[0]


CONTROLLER = """\
controller: co
title: T
subordinates: [cr]
commands:
  GO:
    states:
      S0:
        - do:
            - {action}
"""


def action(text: str) -> list:
    return check(CONTROLLER.format(action=text))


# ---------------------------------------------------------------- the schemas themselves


@pytest.mark.parametrize("kind", ["system", "controller", "operator", "scenario", "template"])
def test_schema_is_valid_draft_2020_12(kind):
    schema = schema_for(kind)
    Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["$id"] == f"https://rcsgen.dev/schema/v1/{kind}.schema.json"


@pytest.mark.parametrize("kind", ["system", "controller", "operator", "scenario", "template"])
def test_every_property_and_definition_has_a_description(kind):
    missing = []

    def walk(node, where):
        if isinstance(node, dict):
            for name, sub in node.get("properties", {}).items():
                if "description" not in sub and not where.endswith("/if"):
                    missing.append(f"{where}/{name}")
            for key, sub in node.items():
                if key == "properties" and isinstance(sub, dict):  # names -> schemas (one
                    for name, inner in sub.items():  # may be named `properties` itself)
                        walk(inner, f"{where}/properties/{name}")
                else:
                    walk(sub, f"{where}/{key}")
        elif isinstance(node, list):
            for index, sub in enumerate(node):
                walk(sub, f"{where}/{index}")

    schema = schema_for(kind)
    walk(schema, "#")
    missing += [f"#/$defs/{n}" for n, d in schema["$defs"].items() if "description" not in d]
    assert missing == []


def test_the_template_schema_declares_world_fields_as_the_system_schema_does():
    """template.schema.json carries copies of system.schema.json's definitions (an editor
    reads one file): they must stay the same."""
    system, template = schema_for("system")["$defs"], schema_for("template")["$defs"]
    for name in ("mnemonic", "field_name", "value_type_name", "field"):
        assert template[name] == system[name], name


def test_schema_for_is_cached_and_rejects_unknown_kinds():
    assert schema_for("controller") is schema_for("controller")
    with pytest.raises(ValueError):
        schema_for("trace")


# ---------------------------------------------------------------- the examples


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_example_specs_pass_their_schema(path):
    text = path.read_text(encoding="utf-8")
    # Only rcsgen's loader: PyYAML's YAML 1.1 would turn the cutter drum's ON/OFF into booleans.
    assert check_document(load_text(text, path.name), kind_of(path), path.name) == []


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: f"{p.parent.parent.name}/{p.name}")
def test_example_scenarios_pass_their_schema(path):
    text = path.read_text(encoding="utf-8")
    assert check_document(load_text(text, path.name), "scenario", path.name) == []


def test_a_comma_in_a_flow_mapping_gets_a_hint():
    diags = check("""\
        controller: vg
        title: T
        commands:
          GO:
            params:
              x: {type: float, doc: Goal, metres.}
            states: {S0: [{next: S0}]}
        """)
    d = only(diags, "S002")
    assert d.message == "unknown key `metres.`"
    assert d.span == Span("x.yaml", 6, 35)
    assert "comma inside `{...}`" in d.hint


def test_a_fragment_use_may_pass_a_list_of_actions():
    """docs/spec.md section 14: a fragment parameter may take a list of actions (the
    inspection workstation's `ask_operator`, `with: {ask: [send: op.PLACE_PART]}`); each
    action is checked as any other."""
    use = """\
        controller: fx
        title: T
        commands:
          GO:
            states:
              S0: {use: ask_operator, with: {ask: [%s]}}
        """
    assert check(use % "{send: op.PLACE_PART, with: {setup: 1}}") == []
    d = only(check(use % "{sned: op.PLACE_PART}"), "S006")
    assert "malformed action" in d.message and d.hint == "did you mean `send`?"
    assert d.span == Span("x.yaml", 6, 45), "at the action in the list"
    assert only(check(use.replace("[%s]", "{a: 1}")), "S003"), "a mapping is neither"


# ---------------------------------------------------------------- S001 missing key


def test_s001_missing_top_level_key_points_at_the_mapping():
    d = only(check("controller: co\ncommands: {}\n"), "S001")
    assert d.message == "missing required key `title`"
    assert d.span == Span("x.yaml", 1, 1)
    assert "One-line" in d.hint


def test_s001_missing_nested_key_and_entry_state():
    diags = check("""\
        controller: co
        title: T
        commands:
          GO:
            doc: no states
          STOP:
            states:
              S1: [{next: S1}]
        """)
    messages = {(d.message, d.span.line, d.span.col) for d in diags if d.code == "S001"}
    assert messages == {
        ("missing required key `states`", 5, 5),
        ("missing required key `S0`", 8, 7),
    }


def test_s001_system_file():
    diags = check("system: miner\ntitle: T\nprocesses: {p: {modules: [co]}}\n", "system")
    assert [d.message for d in diags] == ["missing required key `cycle_period`"]


# ---------------------------------------------------------------- S002 unknown key


def test_s002_unknown_key_points_at_the_key_with_a_suggestion():
    d = only(check("controller: co\ntitle: T\ncommands: {}\nsubordinate: [cr]\n"), "S002")
    assert d.message == "unknown key `subordinate`"
    assert d.span == Span("x.yaml", 4, 1)
    assert d.hint == "did you mean `subordinates`?"


def test_s002_unknown_key_without_a_near_name_lists_the_allowed_keys():
    d = only(
        check(
            "system: m\ntitle: T\ncycle_period: 1\nprocesses: {p: {modules: [a], x: 1}}\n", "system"
        ),
        "S002",
    )
    assert d.message == "unknown key `x`"
    assert d.span == Span("x.yaml", 4, 31)
    assert d.hint == (
        "allowed keys here: `modules`, `doc`, `cycle_period`, `watchdog` and `realtime`"
    )


def test_s002_inside_an_action():
    d = only(action("{send: cr.GO, wiht: {x: 1}}"), "S002")
    assert d.message == "unknown key `wiht`"
    assert d.span == Span("x.yaml", 9, 29)
    assert d.hint == "did you mean `with`?"


# ---------------------------------------------------------------- S003 wrong type


def test_s003_wrong_type_names_key_and_both_types():
    d = only(
        check(
            "system: m\ntitle: T\ncycle_period: fast\nprocesses: {p: {modules: [a]}}\n", "system"
        ),
        "S003",
    )
    assert d.message == "`cycle_period`: expected a number, got a string `fast`"
    assert d.span == Span("x.yaml", 3, 15)


def test_s003_initial_value_must_match_the_declared_type():
    diags = check("""\
        controller: co
        title: T
        locals:
          n: {type: int, initial: 1.5}
          b: {type: bool, initial: 0}
          f: {type: float, initial: 2}
        commands: {}
        """)
    got = sorted((d.span.line, d.message) for d in diags)
    assert got == [
        (4, "`initial`: expected an integer, got a float `1.5`"),
        (5, "`initial`: expected a boolean, got an integer `0`"),
    ]


def test_s003_a_yaml_11_boolean_word_is_a_string_and_says_so():
    """`initial: yes` is the string "yes" in YAML 1.2, never true: refused with the fix."""
    diags = check("""\
        controller: co
        title: T
        locals:
          b: {type: bool, initial: yes}
          c: {type: bool, initial: maybe}
        commands: {}
        """)
    yes, maybe = sorted(diags, key=lambda d: d.span.line)
    assert yes.message == "`initial`: expected a boolean, got a string `yes`"
    assert yes.hint == "`yes` is a string in YAML 1.2 (not a boolean): write true or false"
    assert maybe.message == "`initial`: expected a boolean, got a string `maybe`"
    assert "YAML 1.2" not in maybe.hint


def test_s003_list_item_and_empty_document():
    d = only(check("controller: co\ntitle: T\nsubordinates: [cr, 7]\ncommands: {}\n"), "S003")
    assert d.message == "item 2 of `subordinates`: expected a string, got an integer `7`"
    assert d.span == Span("x.yaml", 3, 20)
    assert 'Quote the value to make it a string: "7"' in d.hint
    [empty] = check_document(None, "system", "empty.yaml")
    assert (empty.code, empty.message, empty.span) == (
        "S003",
        "expected a mapping, got nothing",
        Span("empty.yaml", 1, 1),
    )


# ---------------------------------------------------------------- S004 invalid name


def test_s004_bad_state_name_points_at_the_key():
    diags = check("""\
        controller: co
        title: T
        commands:
          GO:
            states:
              S0: [{next: Sx-1}]
              Sx-1: [{next: S0}]
        """)
    got = sorted((d.span.line, d.span.col, d.message) for d in diags)
    message = "`Sx-1` is not a valid state name: state names are UPPER_CASE identifiers"
    assert got == [(6, 19, message), (7, 7, message)]
    assert all(d.code == "S004" for d in diags)


def test_s004_other_patterns():
    assert only(action("{send: cr.go}"), "S004").message == (
        "`cr.go` is not a valid command to send: expected `<subordinate>.<COMMAND>`"
    )
    d = only(action("{set: {World.x: 1}}"), "S004")
    assert d.message == (
        "`World.x` is not a valid assignment target: expected `world.<field>`, `result.<name>` "
        "or a lower_case local name"
    )
    assert d.span == Span("x.yaml", 9, 22)
    d = only(check("controller: Co\ntitle: T\ncommands: {}\n"), "S004")
    assert d.message == (
        "`Co` is not a valid controller mnemonic: controller mnemonics are lower_case identifiers"
    )


# ---------------------------------------------------------------- S005 invalid value


def test_s005_enum_with_suggestion():
    d = only(
        check("controller: co\ntitle: T\nlocals: {n: {type: flaot, initial: 0}}\ncommands: {}\n"),
        "S005",
    )
    assert d.message == (
        "`flaot` is not a valid type: expected `bool`, `int`, `float`, `enum` or `str`"
    )
    assert d.span == Span("x.yaml", 3, 20)
    assert d.hint == "did you mean `float`?"
    d = only(action("{report: FINISHED}"), "S005")
    assert d.message == "`FINISHED` is not a valid report status: expected `DONE` or `ERROR`"


def test_s005_minimum_empty_and_duplicates():
    diags = check(
        "system: m\ntitle: T\ncycle_period: 0\nprocesses: {}\nsimulators: [a, b, a]\n", "system"
    )
    got = sorted((d.code, d.span.line, d.span.col, d.message) for d in diags)
    assert got == [
        ("S005", 3, 15, "`cycle_period`: must be greater than 0, got 0"),
        ("S005", 4, 12, "`processes`: needs at least one entry, got none"),
        ("S005", 5, 20, "`simulators`: duplicate item `a`"),
    ]


# ---------------------------------------------------------------- S006 malformed rule or action


def test_s006_rule_needs_when_do_or_next():
    diags = check("""\
        controller: co
        title: T
        commands:
          GO:
            states:
              S0:
                - doc: nothing here
        """)
    d = only(diags, "S006")
    assert d.message == "a rule needs at least one of `when`, `after`, `do` or `next`"
    assert d.span == Span("x.yaml", 7, 11)
    assert len(diags) == 1


def test_s006_action_with_two_forms_points_at_the_second():
    d = only(action("{send: cr.GO, report: DONE}"), "S006")
    assert d.message == "malformed action: it has both `send` and `report`"
    assert d.span == Span("x.yaml", 9, 29)
    assert len(action("{send: cr.GO, report: DONE}")) == 1


def test_s006_unknown_action_and_missing_colon():
    d = only(action("{sned: cr.GO}"), "S006")
    assert d.message == (
        "malformed action: no `send`, `set`, `report`, `call`, `plan`, `replan` or `advance` "
        "(found `sned`)"
    )
    assert (d.span, d.hint) == (Span("x.yaml", 9, 16), "did you mean `send`?")
    d = only(action("report DONE"), "S006")
    assert d.message == "malformed action: expected a mapping, got a string `report DONE`"
    assert (d.span, d.hint) == (Span("x.yaml", 9, 15), "write `report: DONE`")


def test_a_valid_action_branch_reports_only_its_own_problem():
    diags = action("{call: 3}")
    assert [(d.code, d.message) for d in diags] == [
        ("S003", "`call`: expected a string, got an integer `3`")
    ]


# ---------------------------------------------------------------- plain data (no spans)


def test_plain_data_falls_back_to_the_file_start():
    data = {"controller": "co", "title": "T", "commands": {"go": {"states": {"S0": [{}]}}}}
    diags = check_document(data, "controller", "plain.yaml")
    assert sorted((d.code, d.span) for d in diags) == [
        ("S004", Span("plain.yaml", 1, 1)),
        ("S006", Span("plain.yaml", 1, 1)),
    ]


# ---------------------------------------------------------------- editors and pre-commit


def test_every_shipped_spec_and_scenario_names_its_schema_for_editors():
    """yaml-language-server reads the modeline on the first line; its path must resolve."""
    for path in sorted(MINER.rglob("*.yaml")):
        first = path.read_text(encoding="utf-8").splitlines()[0]
        kind = "scenario" if path.parent.name == "scenarios" else kind_of(path)
        assert first.startswith("# yaml-language-server: $schema="), path
        target = (path.parent / first.split("$schema=", 1)[1]).resolve()
        assert target.name == f"{kind}.schema.json" and target.is_file(), path


def test_pre_commit_hooks_run_existing_commands():
    hooks = load_text(
        (MINER.parent.parent / ".pre-commit-hooks.yaml").read_text(encoding="utf-8"), "hooks"
    )
    assert [h["id"] for h in hooks] == ["rcsgen-validate", "rcsgen-check"]
    from click.testing import CliRunner

    from rcsgen.cli import main

    for hook in hooks:
        assert {"id", "name", "entry", "language"} <= set(hook)
        assert hook["language"] == "python" and hook["pass_filenames"] is False
        program, *args = hook["entry"].split()
        assert program == "rcsgen"
        result = CliRunner().invoke(main, [*args, "--help"])
        assert result.exit_code == 0, result.output


def test_a_use_of_a_fragment_is_a_state_for_editors_and_a_mistyped_one_is_flagged():
    use = (
        "controller: fx\ntitle: T\ncommands:\n  GO:\n    states:\n"
        "      S0: {use: ask, with: {task: place}}\n"
    )
    assert check(use) == []
    wrong = only(check(use.replace("with:", "whit:")), "S002")
    assert (wrong.span.line, "whit" in wrong.message) == (6, True)
    # A single rule written without its list is still the familiar "not a list" error.
    single = check(use.replace("{use: ask, with: {task: place}}", "{do: [report: DONE]}"))
    single = only(single, "S003")
    assert single.span.line == 6


# ---------------------------------------------------------------- the compiled checks


@pytest.mark.parametrize("kind", ["system", "controller", "operator", "scenario", "template"])
def test_every_schema_compiles_to_the_fast_check(kind):
    """A schema the compiled checks cannot take falls back to jsonschema alone (correct but
    slow): every shipped schema must compile, or a build loses its speed unnoticed."""
    from rcsgen.compiler.front_end.schema import fast_check

    assert fast_check(kind) is not None


def test_the_fast_check_refuses_a_keyword_it_does_not_implement():
    from rcsgen.compiler.front_end.schema_fast import Unsupported, compile_schema

    with pytest.raises(Unsupported, match="patternProperties"):
        compile_schema({"type": "object", "patternProperties": {"^x": {"type": "string"}}})
    with pytest.raises(Unsupported, match=r"\$ref"):
        compile_schema({"$ref": "other.json#/x"})


@pytest.mark.parametrize(
    ("schema", "value", "valid"),
    [
        ({"type": "integer"}, True, False),  # YAML's `true` is not an int
        ({"type": "integer"}, 3.0, False),  # nor is 3.0 (YAML tells them apart)
        ({"type": "number"}, False, False),
        ({"const": 1}, True, False),
        ({"const": 1}, 1.0, True),
        ({"enum": [0, "a"]}, False, False),
        ({"uniqueItems": True}, [1, True], True),
        ({"uniqueItems": True}, [1, 1.0], False),
        ({"uniqueItems": True}, [{"a": [1, 2]}, {"a": [1, 2.0]}], False),  # by hashed keys
        ({"uniqueItems": True}, [{"a": 1}, {"a": True}, {"b": 1}], True),
        ({"uniqueItems": True}, [[1, "a"], ["a", 1], None, False, 0], True),
        ({"uniqueItems": True}, ["x", "y", "x"], False),
        ({"minimum": 0}, "text", True),  # a bound applies to numbers only
        ({"pattern": "b"}, "abc", True),  # search, not match
        ({"oneOf": [{"type": "number"}, {"type": "integer"}]}, 3, False),
        ({"if": {"required": ["a"]}, "then": {"required": ["b"]}}, {"a": 1}, False),
        ({"properties": {"a": True}, "additionalProperties": False}, {"a": 1, "b": 2}, False),
        ({"dependentRequired": {"a": ["b"]}}, {"a": 1}, False),
        ({"propertyNames": {"pattern": "^[a-z]+$"}}, {"ab": 1, "c": 2}, True),
        ({"propertyNames": {"pattern": "^[a-z]+$"}}, {"ab": 1, "C": 2}, False),
        ({"propertyNames": {"pattern": "^[a-z]+$"}}, "not an object", True),
        ({"$defs": {"n": {"items": {"$ref": "#/$defs/n"}}}, "$ref": "#/$defs/n"}, [[[]]], True),
        ({"description": "a note only"}, 3, True),  # no keyword: anything is valid
        ({"then": {"type": "string"}}, 3, True),  # `then` without `if` says nothing
    ],
)
def test_the_fast_check_agrees_with_jsonschema_on_edge_cases(schema, value, valid):
    from rcsgen.compiler.front_end.schema import validator_class
    from rcsgen.compiler.front_end.schema_fast import compile_schema

    assert validator_class()(schema).is_valid(value) is valid
    assert compile_schema(schema)(value) is valid


def _plain(node):
    if isinstance(node, dict):
        return {key: _plain(value) for key, value in node.items()}
    return [_plain(value) for value in node] if isinstance(node, list) else node


def _paths(node, path=()):
    yield path
    items = node.items() if isinstance(node, dict) else ()
    items = enumerate(node) if isinstance(node, list) else items
    for step, value in items:
        yield from _paths(value, (*path, step))


_ODD_VALUES = [1, True, None, "X", "ON", [], {}, 1.5, -1, 0, "a b", ["X"], {"zz_unknown": 1}]


def test_the_fast_check_agrees_with_jsonschema_on_mutated_examples():
    """Differential: every shipped spec and scenario, mutated at random (a value replaced, a
    key or item removed, an unknown key added, an item repeated); the compiled check and
    jsonschema must give the same verdict on each, valid and invalid alike."""
    import copy
    import random

    from rcsgen.compiler.front_end.schema import _validator, fast_check

    documents = [(_plain(load_text(p.read_text("utf-8"), p.name)), kind_of(p)) for p in EXAMPLES]
    documents += [(_plain(load_text(p.read_text("utf-8"), p.name)), "scenario") for p in SCENARIOS]
    rng = random.Random(24)
    verdicts = {True: 0, False: 0}
    for _ in range(160):
        document, kind = rng.choice(documents)
        mutant = copy.deepcopy(document)
        *where, last = rng.choice(list(_paths(mutant))[1:])
        parent = mutant
        for step in where:
            parent = parent[step]
        operation = rng.randrange(4)
        if operation == 0:
            parent[last] = copy.deepcopy(rng.choice(_ODD_VALUES))
        elif operation == 1:
            del parent[last]
        elif isinstance(parent, dict):
            parent[f"zz_{rng.randrange(3)}"] = copy.deepcopy(rng.choice(_ODD_VALUES))
        else:
            parent.append(copy.deepcopy(parent[last]))
        expected = _validator(kind).is_valid(mutant)
        assert fast_check(kind)(mutant) is expected, (kind, where, last, operation)
        verdicts[expected] += 1
    assert min(verdicts.values()) >= 30, verdicts  # both verdicts exercised


def test_each_keyword_s_failure_is_told_in_its_own_words():
    """One document with a mistake of each kind the schema finds (a required key, an unknown
    key, a type of each kind, a pattern, an enum, a minimum, a minimum of items, a `const` of
    an if/then): each is told by its own code and sentence, never jsonschema's words."""
    diags = check("""\
        controller: Co
        title: 3
        subordinate: [cr]
        locals:
          n: {type: flaot, initial: 0}
          e: {type: enum, values: [], initial: A}
          s: {type: str, size: 0, initial: ""}
          i: {type: int, values: [A], initial: 0}
          b: {type: bool, initial: 3}
          f: {type: float, initial: "x"}
          k: {type: int, initial: 1.5}
        commands:
          GO:
            doc: no states
            params: [x]
          STOP:
            first_match: S0
            states:
              S0: [{do: [{report: FINISHED}]}]
        """)
    assert [(d.code, d.span.line, d.span.col, d.message) for d in diags] == [
        (
            "S004",
            1,
            13,
            "`Co` is not a valid controller mnemonic: controller mnemonics are lower_case "
            "identifiers",
        ),
        ("S003", 2, 8, "`title`: expected a string, got an integer `3`"),
        ("S002", 3, 1, "unknown key `subordinate`"),
        (
            "S005",
            5,
            13,
            "`flaot` is not a valid type: expected `bool`, `int`, `float`, `enum` or `str`",
        ),
        ("S005", 6, 27, "`values`: needs at least one item, got none"),
        ("S005", 7, 24, "`size`: must be at least 1, got 0"),
        ("S005", 8, 13, "`int` is not a valid value: expected `enum`"),
        ("S003", 9, 28, "`initial`: expected a boolean, got an integer `3`"),
        ("S003", 10, 29, "`initial`: expected a number, got a string `x`"),
        ("S003", 11, 27, "`initial`: expected an integer, got a float `1.5`"),
        ("S001", 14, 5, "missing required key `states`"),
        ("S003", 15, 13, "`params`: expected a mapping, got a list"),
        ("S003", 17, 18, "`first_match`: expected a list, got a string `S0`"),
        ("S005", 19, 27, "`FINISHED` is not a valid report status: expected `DONE` or `ERROR`"),
    ]


def test_every_type_and_name_pattern_of_the_schemas_has_its_words():
    """Each JSON type a shipped schema asks for is told in words (`a mapping`, not
    `object`: a type added to a schema without its words is caught here), and each name
    rule is written for a pattern a schema uses (a rule's pattern mistyped would leave its
    names told "does not match `^[a-z]...$`")."""
    from rcsgen.compiler.front_end.schema import _EXPECTED, _NAME_RULES, KINDS

    types, patterns = set(), set()

    def walk(node):
        if isinstance(node, dict):
            kind = node.get("type")  # (a dict there is a property named `type`)
            types.update([kind] if isinstance(kind, str) else [])
            types.update(kind if isinstance(kind, list) else [])
            if isinstance(node.get("pattern"), str):
                patterns.add(node["pattern"])
            for key, value in node.items():
                if key not in ("enum", "const", "examples", "default"):
                    walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    for kind in KINDS:
        walk(schema_for(kind))
    assert types <= set(_EXPECTED), types - set(_EXPECTED)
    assert set(_NAME_RULES) <= patterns, set(_NAME_RULES) - patterns


@pytest.mark.parametrize("word", ["yes", "no", "on", "off", "y", "n"])
def test_s003_each_yaml_11_boolean_word_is_told_it_is_a_string(word):
    diags = check(f"controller: co\ntitle: T\nlocals:\n  b: {{type: bool, initial: {word}}}\n")
    [d] = [d for d in diags if d.code == "S003"]
    assert d.hint == f"`{word}` is a string in YAML 1.2 (not a boolean): write true or false"
