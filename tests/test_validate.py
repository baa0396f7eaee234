"""`rcsgen validate` and a failing `rcsgen build`: every spec error is reported, located, at once.

Each case mutates one scratch copy of specs/miner and runs the real command line from the
scratch root, so diagnostics name `specs/miner/<file>:<line>:<col>`. A failing run exits 1,
never shows a traceback and leaves generated/ byte-identical.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml
from conftest import edit, rcsgen, snapshot

HEADER = re.compile(r"^(\S+):(\d+):(\d+): (error|warning)\[(\w+)\]: (.*)$", re.MULTILINE)


@dataclass(frozen=True)
class Case:
    """One mutation of specs/miner and the diagnostic it must produce.

    `edits` are (file, old, new) replacements; new=None deletes the file. `at` is
    `file:text`, where `|` inside the text marks the exact position the diagnostic points at;
    the line and column are computed from the mutated file. `also` are the codes of the
    other diagnostics the same mutation is expected to produce.
    """

    id: str
    edits: list[tuple[str, str, str | None]]
    code: str
    at: str
    message: str
    hint: str = ""
    also: set[str] = field(default_factory=set)


def locate(root: Path, at: str) -> str:
    """`specs/miner/<file>:<line>:<col>` of the `|` in an `at` marker, in the mutated file."""
    name, _, marker = at.partition(":")
    before, _, after = marker.partition("|")
    text = (root / "specs" / "miner" / name).read_text(encoding="utf-8")
    assert text.count(before + after) == 1, f"marker {marker!r} is not unique in {name}"
    offset = text.index(before + after) + len(before)
    line = text.count("\n", 0, offset) + 1
    col = offset - (text.rfind("\n", 0, offset) + 1) + 1
    return f"specs/miner/{name}:{line}:{col}"


def diagnostics(output: str) -> list[tuple[str, str, str]]:
    """(location, severity[CODE], message) of every diagnostic printed, in printed order."""
    return [
        (f"{f}:{li}:{co}", f"{sev}[{code}]", msg)
        for f, li, co, sev, code, msg in HEADER.findall(output)
    ]


SEND_VG_2 = (  # the second send to vg (in S3)
    "send: vg.TRAM_TO_XY\n"
    "              with: {x: world.goal_x, y: world.goal_y}\n"
    "          next: S4"
)

CASES = [
    Case(
        "unknown-subordinate",
        [("co.yaml", "subordinates: [cr, vg, cc]", "subordinates: [cr, vg, cx]")],
        "E201",
        "co.yaml:subordinates: [cr, vg, |cx]",
        "unknown subordinate `cx` of `co`",
        hint="`cc`",
    ),
    Case(
        "unknown-subordinate-close-match",
        [("co.yaml", "subordinates: [cr, vg, cc]", "subordinates: [cr, vg, ccc]")],
        "E201",
        "co.yaml:subordinates: [cr, vg, |ccc]",
        "unknown subordinate `ccc` of `co`",
        hint="did you mean `cc`?",
    ),
    Case(
        "two-supervisors",
        [("cr.yaml", "title: Coal removal (simulated)\n", "title: C\nsubordinates: [cc]\n")],
        "E202",
        "cr.yaml:subordinates: [|cc]",
        "`cc` has two supervisors: `co` and `cr`",
        hint="exactly one supervisor",
    ),
    Case(
        "cycle",
        [("cc.yaml", "title: Coal cutting (simulated)\n", "title: C\nsubordinates: [co]\n")],
        "E203",
        "cc.yaml:subordinates: [|co]",
        "cycle in the hierarchy: co -> cc -> co",  # and again from co.yaml: cc -> co -> cc
    ),
    Case(
        "self-command",
        [("co.yaml", "subordinates: [cr, vg, cc]", "subordinates: [cr, vg, cc, co]")],
        "E203",
        "co.yaml:subordinates: [cr, vg, cc, |co]",
        "cycle in the hierarchy: co -> co",
    ),
    Case(
        "undeclared-command",
        [("co.yaml", "send: cc.SHEAR\n", "send: cc.SHEER\n")],
        "E204",
        "co.yaml:|send: cc.SHEER",
        "`cc` does not declare command `SHEER`",
        hint="did you mean `SHEAR`?",
    ),
    Case(
        "send-to-non-subordinate",
        [("co.yaml", "subordinates: [cr, vg, cc]", "subordinates: [vg, cc]")],
        "E205",
        "co.yaml:|send: cr.SUMP",
        "`co` sends to `cr`, which is not one of its subordinates",
        also={"E108"},  # and reads `cr.status` in guards
    ),
    Case(
        "undefined-state",
        [("co.yaml", "next: S3", "next: S9")],
        "E206",
        "co.yaml:next: |S9",
        "transition to undefined state `S9` in SUMP_SHEAR_CUSP",
        hint="`S3`",
        also={"E207"},  # S3 and S4 are no longer reached
    ),
    Case(
        "unreachable-state",
        [
            (
                "co.yaml",
                "      S4:\n",
                "      S5:\n        - do:\n            - report: DONE\n      S4:\n",
            )
        ],
        "E207",
        "co.yaml:      |S5:",
        "state `S5` of SUMP_SHEAR_CUSP is unreachable from S0",
    ),
    Case(
        "undeclared-world-field",
        [("co.yaml", "when: world.popped_out_of_shear\n", "when: world.popped_out_of_shears\n")],
        "E104",
        "co.yaml:when: |world.popped_out_of_shears",
        "undeclared world field `popped_out_of_shears`",
        hint="did you mean `popped_out_of_shear`?",
    ),
    Case(
        "undeclared-world-field-in-reads",
        [
            (
                "cr.yaml",
                "reads: [tail_in_position, loose_coal]",
                "reads: [tail_in_posiiton, loose_coal]",
            )
        ],
        "E104",
        "cr.yaml:reads: [|tail_in_posiiton",
        "undeclared world field `tail_in_posiiton`",
        hint="did you mean `tail_in_position`?",  # names resolve first: no E105 follow-ups
    ),
    Case(
        "world-field-not-in-reads",
        [("co.yaml", "when: world.popped_out_of_shear\n", "when: world.tail_in_position\n")],
        "E105",
        "co.yaml:when: |world.tail_in_position",
        "world field `tail_in_position` is not in this controller's world.reads",
        hint="add `tail_in_position` to `world: reads:`",
    ),
    Case(
        "undeclared-parameter",
        [("vg.yaml", "world.pose_y: y}", "world.pose_y: z}")],
        "E103",
        "vg.yaml:world.pose_y: |z}",
        "unknown name `z`",
    ),
    Case(
        "undeclared-constant",
        [("cc.yaml", "when: ticks >= SHEAR_CYCLES", "when: ticks >= SHEAR_CYCLE")],
        "E103",
        "cc.yaml:when: ticks >= |SHEAR_CYCLE\n",
        "unknown name `SHEAR_CYCLE`",
        hint="did you mean `SHEAR_CYCLES`?",
    ),
    Case(
        "undeclared-predicate",
        [("co.yaml", "when: too_much_loose_coal()\n", "when: too_much_coal()\n")],
        "E106",
        "co.yaml:when: |too_much_coal()",
        "`too_much_coal` is not a declared predicate",
        hint="did you mean `too_much_loose_coal`?",
    ),
    Case(
        "undeclared-hook",
        [("co.yaml", "- call: co_position_for_cusp", "- call: co_position_for_cups")],
        "E208",
        "co.yaml:call: |co_position_for_cups",
        "call of undeclared hook `co_position_for_cups`",
        hint="did you mean `co_position_for_cusp`?",
    ),
    Case(
        "hooks-module-missing",
        [("miner_hooks/co.py", "", None)],
        "E212",
        "co.yaml:hooks_module: |miner_hooks.co",
        "hooks module `miner_hooks.co` not found",
        hint="create miner_hooks/co.py next to system.yaml",
    ),
    Case(
        "hooks-module-misnamed",
        [("co.yaml", "hooks_module: miner_hooks.co\n", "hooks_module: miner_hooks.cx\n")],
        "E212",
        "co.yaml:hooks_module: |miner_hooks.cx",
        "hooks module `miner_hooks.cx` not found",
    ),
    Case(
        "hooks-module-syntax-error",
        [("miner_hooks/co.py", "import math\n", "import math(\n")],
        "E212",
        "co.yaml:hooks_module: |miner_hooks.co",
        "hooks module `miner_hooks.co` cannot be read",
    ),
    Case(
        "hook-not-defined",
        [("co.yaml", "hooks:\n", "hooks:\n  co_check_tail:\n    args: [world.loose_coal]\n")],
        "E213",
        "co.yaml:  |co_check_tail:",
        "hook `co_check_tail` is not defined in `miner_hooks.co`",
        hint="add `def co_check_tail(a0): ...` to co.py",
    ),
    Case(
        "hook-wrong-arity",
        [
            (
                "miner_hooks/co.py",
                "def co_position_for_cusp(pose_x: float, pose_y: float, heading: float)",
                "def co_position_for_cusp(pose_x: float, pose_y: float)",
            )
        ],
        "E214",
        "co.yaml:  |co_position_for_cusp:",
        "hook `co_position_for_cusp` is called with 3 arguments but "
        "`miner_hooks.co.co_position_for_cusp` takes 2",
    ),
    Case(
        "module-in-no-process",
        [("system.yaml", "modules: [co, cr, vg, cc]", "modules: [co, cr, vg]")],
        "E209",
        "cc.yaml:controller: |cc",
        "module `cc` is not mapped to any process",
        hint="add `cc` to a process's `modules:` in specs/miner/system.yaml",
    ),
    Case(
        "module-in-two-processes",
        [
            (
                "system.yaml",
                "modules: [co, cr, vg, cc]\n",
                "modules: [co, cr, vg, cc]\n  pc2:\n    modules: [cc]\n",
            )
        ],
        "E210",
        "system.yaml:modules: [|cc]",
        "module `cc` is mapped to more than one process (`pc1` and `pc2`)",
    ),
    Case(
        "process-module-without-spec",
        [("system.yaml", "modules: [co, cr, vg, cc]", "modules: [co, cr, vg, cc, ch]")],
        "E211",
        "system.yaml:cc, |ch]",
        "process `pc1` runs `ch`, which has no controller spec",
        hint="`cc`",
    ),
    Case(
        "missing-send-parameter",
        [("co.yaml", SEND_VG_2, SEND_VG_2.replace(", y: world.goal_y", ""))],
        "E217",
        "co.yaml:|send: vg.TRAM_TO_XY\n              with: {x: world.goal_x}\n",
        "`vg.TRAM_TO_XY` needs parameter y",
        hint="give it under `with:`",
    ),
    Case(
        "unknown-send-parameter",
        [("co.yaml", "y: world.goal_y}", "y: world.goal_y, z: 1.0}")],
        "E218",
        "co.yaml:y: world.goal_y, |z: 1.0}",  # at the unknown parameter name
        "`vg.TRAM_TO_XY` has no parameter `z`",
        hint="declared parameters: `x`, `y`",
    ),
    Case(
        "write-without-declaring",
        [("cr.yaml", "writes: [loose_coal]", "writes: []")],
        "E219",
        "cr.yaml:|world.loose_coal: max",
        "`cr` writes world field `loose_coal` without declaring it",
    ),
    Case(
        "unknown-key",
        [
            (
                "co.yaml",
                "          when: vg.status == DONE and cc.status == DONE\n",
                "          wehn: vg.status == DONE and cc.status == DONE\n",
            )
        ],
        "S002",
        "co.yaml:|wehn: vg.status",
        "unknown key `wehn`",
        hint="did you mean `when`?",
    ),
    Case(
        "wrong-type",
        [("system.yaml", "cycle_period: 0.1", "cycle_period: fast")],
        "S003",
        "system.yaml:cycle_period: |fast",
        "`cycle_period`: expected a number, got a string `fast`",
    ),
    Case(
        "duplicate-key",
        [("co.yaml", "title: Continuous miner operation coordinator\n", "title: A\ntitle: B\n")],
        "E002",
        "co.yaml:|title: B",
        "duplicate key `title`",
        hint="first defined at line 5",
    ),
]


@pytest.fixture
def before(work: Path) -> dict[str, bytes]:
    """generated/ as built from the pristine specs, before a case mutates them."""
    return snapshot(work / "generated")


def mutate(root: Path, edits: list[tuple[str, str, str | None]]) -> None:
    for name, old, new in edits:
        path = root / "specs" / "miner" / name
        if new is None:
            path.unlink()
        else:
            edit(path, old, new)


@pytest.mark.parametrize("command", ["validate", "build"])
@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_error_is_located_and_nothing_is_written(
    work: Path, before: dict[str, bytes], case: Case, command: str
) -> None:
    """Each spec error exits 1 with `file:line:col: error[CODE]: message` and writes nothing."""
    mutate(work, case.edits)
    result = rcsgen(command)
    assert result.exit_code == 1, result.output
    where = locate(work, case.at)
    assert f"{where}: error[{case.code}]: {case.message}" in result.output
    found = diagnostics(result.output)
    codes = {code for _, code, _ in found}
    assert codes == {f"error[{c}]" for c in {case.code, *case.also}}, result.output
    if case.hint:
        assert case.hint in result.output
    assert snapshot(work / "generated") == before
    if command == "build":
        assert "build failed: nothing was written" in result.output


def test_every_error_is_reported_in_one_run_sorted_by_position(
    work: Path, before: dict[str, bytes]
) -> None:
    """Three independent mistakes in two files give three diagnostics, in file/line order.

    co is checked before cc (process order), yet cc.yaml's error is printed first.
    """
    edit(work / "specs/miner/cc.yaml", "- set: {ticks: ticks + 1}", "- set: {tick: ticks + 1}")
    edit(work / "specs/miner/co.yaml", "when: too_much_loose_coal()\n", "when: too_much_coal()\n")
    edit(work / "specs/miner/co.yaml", "send: cc.SHEAR\n", "send: cc.SHEER\n")
    result = rcsgen("validate")
    assert result.exit_code == 1
    assert diagnostics(result.output) == [
        (
            locate(work, "cc.yaml:set: {|tick:"),
            "error[E220]",
            "cannot assign `tick`: not a local or `world.<field>`",
        ),
        (
            locate(work, "co.yaml:|send: cc.SHEER"),
            "error[E204]",
            "`cc` does not declare command `SHEER`",
        ),
        (
            locate(work, "co.yaml:when: |too_much_coal()"),
            "error[E106]",
            "`too_much_coal` is not a declared predicate",
        ),
    ]
    assert "3 errors, 0 warnings" in result.output
    assert snapshot(work / "generated") == before


def test_schema_errors_in_several_files_are_all_reported(work: Path) -> None:
    """Schema errors do not stop at the first file: each file is checked on its own."""
    edit(work / "specs/miner/cc.yaml", "title: Coal cutting (simulated)", "titel: Coal cutting")
    edit(work / "specs/miner/vg.yaml", "type: float\n", "type: flaot\n")
    result = rcsgen("validate")
    assert result.exit_code == 1
    codes = [(where.split(":")[0], code) for where, code, _ in diagnostics(result.output)]
    assert ("specs/miner/cc.yaml", "error[S002]") in codes
    assert ("specs/miner/cc.yaml", "error[S001]") in codes  # `title` is now missing
    assert ("specs/miner/vg.yaml", "error[S005]") in codes


def test_pristine_specs_validate(work: Path) -> None:
    """The example validates cleanly: exit 0, `ok: miner`, no diagnostics."""
    result = rcsgen("validate", "specs")
    assert result.exit_code == 0, result.output
    assert result.stdout == "ok: miner\n"


def test_validate_without_arguments_reads_specs(work: Path) -> None:
    """`rcsgen validate` with no path checks ./specs (an error there is found)."""
    assert rcsgen("validate").stdout == "ok: miner\n"
    edit(work / "specs/miner/co.yaml", "next: S3", "next: S9")
    result = rcsgen("validate")
    assert result.exit_code == 1
    assert f"{locate(work, 'co.yaml:next: |S9')}: error[E206]" in result.output


def test_validate_without_arguments_and_without_specs(tmp_path: Path, monkeypatch) -> None:
    """Where there is no ./specs, the default path is reported as missing, located."""
    monkeypatch.chdir(tmp_path)
    result = rcsgen("validate")
    assert result.exit_code == 1
    assert "specs:1:1: error[E010]: `specs` does not exist" in result.output


def test_missing_path_is_a_located_error(work: Path) -> None:
    """A spec path that does not exist: exit 1 and a located E010, other paths still checked."""
    result = rcsgen("validate", "specs/nope", "specs")
    assert result.exit_code == 1
    assert "specs/nope:1:1: error[E010]: `specs/nope` does not exist" in result.output
    assert diagnostics(result.output) == [
        ("specs/nope:1:1", "error[E010]", "`specs/nope` does not exist")
    ]


def test_directory_without_system_is_a_located_error(work: Path) -> None:
    """A directory with no system.yaml under it is reported, not silently accepted."""
    (work / "empty").mkdir()
    result = rcsgen("validate", "empty")
    assert result.exit_code == 1
    assert "empty:1:1: error[E224]: no system.yaml found under `empty`" in result.output


@pytest.mark.parametrize(
    "args",
    [["validate", "--bogus"], ["build", "--output"], ["frobnicate"]],
    ids=["unknown-option", "option-without-value", "unknown-command"],
)
def test_misuse_exits_2(work: Path, before: dict[str, bytes], args: list[str]) -> None:
    """Misusing the command line is exit 2 (Click's usage error), distinct from spec errors."""
    result = rcsgen(*args)
    assert result.exit_code == 2
    assert "Error:" in result.output
    assert snapshot(work / "generated") == before


def test_duplicate_system_names_are_located(work: Path) -> None:
    """Two system directories naming the same system: E231 at the second `system:` value."""
    shutil.copytree(work / "specs" / "miner", work / "specs" / "miner2")
    result = rcsgen("validate")
    assert result.exit_code == 1
    assert (
        "specs/miner2/system.yaml:4:9: error[E231]: two systems are named `miner`" in result.output
    )
    assert "the other is specs/miner/system.yaml:4:9" in result.output


def test_yaml_11_booleans_are_plain_names(work: Path) -> None:
    """`on`, `yes`, `no` are names (YAML 1.2), not booleans: usable as locals and world fields.

    PyYAML's default loader would turn these keys into True/False; rcsgen must not.
    """
    assert yaml.safe_load("on: 1\nyes: 2\nno: 3") == {True: 2, False: 3}  # the trap
    edit(
        work / "specs/miner/system.yaml",
        "world:\n",
        "world:\n  no:\n    type: bool\n    initial: false\n",
    )
    edit(
        work / "specs/miner/co.yaml",
        "constants:\n",
        "locals:\n  on:\n    type: bool\n    initial: false\n"
        "  yes:\n    type: int\n    initial: 0\n\nconstants:\n",
    )
    edit(work / "specs/miner/co.yaml", "reads: [", "reads: [no, ")
    edit(
        work / "specs/miner/co.yaml",
        "          do:\n            - report: DONE",
        "          do:\n"
        "            - set: {on: not world.no, yes: yes + 1}\n"
        "            - report: DONE",
    )
    edit(work / "specs/miner/vg.yaml", "next: S1\n      S1:", "next: ON\n      ON:")
    edit(work / "specs/miner/vg.yaml", "first_match: [S1]", "first_match: [ON]")
    result = rcsgen("validate")
    assert (result.exit_code, result.stdout) == (0, "ok: miner\n"), result.output
    result = rcsgen("build")
    assert result.exit_code == 0, result.output
    co = (work / "generated/miner/co.py").read_text(encoding="utf-8")
    assert "var_on" in co and "var_yes" in co and "world_no" in co
    vg = (work / "generated/miner/vg.py").read_text(encoding="utf-8")
    assert re.search(r"^ON = \d+$", vg, re.MULTILINE)


def test_yaml_11_boolean_value_is_not_a_bool(work: Path) -> None:
    """`initial: no` for a bool is a string under YAML 1.2: a located S003, not False."""
    edit(
        work / "specs/miner/system.yaml",
        "    initial: false\n    doc: The pose sensor",
        "    initial: no\n    doc: The pose sensor",
    )
    result = rcsgen("validate")
    assert result.exit_code == 1
    where = locate(work, "system.yaml:    initial: |no\n    doc: The pose sensor")
    assert f"{where}: error[S003]" in result.output


RULE_BEFORE_S4 = "      S4:\n        - do:\n            - report: ERROR\n        - when"


@pytest.fixture
def shadowed_rule(work: Path) -> Path:
    """co's S4 gets a first rule without `when`, so the rule after it never fires."""
    edit(work / "specs/miner/co.yaml", "      S4:\n        - when", RULE_BEFORE_S4)
    return work


def test_unreachable_rule_is_a_warning(shadowed_rule: Path) -> None:
    """W301 is located and printed, but a warning alone does not fail `validate`."""
    result = rcsgen("validate")
    assert result.exit_code == 0, result.output
    where = locate(
        shadowed_rule, "co.yaml:        - do:\n            - report: ERROR\n        - |when"
    )
    assert f"{where}: warning[W301]: this rule of SUMP_SHEAR_CUSP S4 never fires" in result.output
    assert "0 errors" in result.output  # the analysis adds its own warnings
    assert "ok: miner" in result.output


def test_strict_fails_on_warning(shadowed_rule: Path, before: dict[str, bytes]) -> None:
    """`--strict` turns warnings into failure: validate and build exit 1, nothing is written."""
    assert rcsgen("validate", "--strict").exit_code == 1
    result = rcsgen("build", "--strict")
    assert result.exit_code == 1
    assert "warning[W301]" in result.output
    assert snapshot(shadowed_rule / "generated") == before


def test_a_pathological_hooks_module_is_a_located_error(work: Path) -> None:
    """A hooks file the Python parser cannot even hold (deep unary nesting: MemoryError or
    RecursionError inside `ast.parse`) is E212 at `hooks_module`, never a traceback."""
    (work / "specs/miner/miner_hooks/co.py").write_text("x = " + "-" * 200_000 + "1\n")
    result = rcsgen("validate")
    assert result.exit_code == 1
    assert "error[E212]: hooks module `miner_hooks.co` cannot be read" in result.output
