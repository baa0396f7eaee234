"""The engineer's own properties (`properties:`, rcsgen/compiler/checks/properties.py, docs/spec.md
section 19) refused when `rcsgen prove` could not check them: each way of writing one wrong
(E710 a name that is not there, E712 a response too late, E713 what the model cannot decide)
gets its one error, word for word, at the property. The miner's specs with these properties
added to its system file, compiled once, in the unit tier."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.diagnostics import Diagnostic
from rcsgen.compiler.frontend import compile_paths

MINER = Path(__file__).resolve().parent.parent / "specs" / "miner"
ANY_ATOM = (
    "combine them with and, or, not and parentheses; world values, locals and numbers are "
    "free in the model and cannot be compared in a property"
)
# (the property's condition, as YAML; the error it gets)
CASES = {
    "no_such_command": (
        "always: cr.command == ZZZZ",
        ("E710", "`ZZZZ` is no command of cr", "one of: INIT, HALT, SUMP, SHEAR, CUSP, NONE"),
    ),
    "world_compared": (
        "always: world.drum_on_cmd == true",
        (
            "E713",
            "`world.drum_on_cmd` is free in the model: a property cannot compare it",
            "state an actuator's safe value as `safe(world.drum_on_cmd)`",
        ),
    ),
    "two_comparisons": (
        "always: co.status == DONE == DONE",
        ("E713", "a property compares with `==` or `!=`, one at a time", ""),
    ),
    "less_than": (
        "always: co.status < DONE",
        ("E713", "a property compares with `==` or `!=`, one at a time", ""),
    ),
    "two_names": (
        "always: DONE == ERROR",
        (
            "E713",
            "a property compares `<module>.state`, `.command` or `.status` with a name",
            "for example `cr.status == ERROR` or `helm.state == S2`",
        ),
    ),
    "deeper_name": (
        "always: co.status.x == DONE",
        ("E713", "a property reads `<module>.<field>`, not a deeper name", ""),
    ),
    "other_field": (
        "always: co.statu == DONE",
        (
            "E710",
            "`co.statu`: a property reads a module's state, command or status",
            "did you mean `status`?",
        ),
    ),
    "no_such_status": (
        "always: co.status == DONNE",
        ("E710", "`DONNE` is no status of co", "did you mean `DONE`?"),
    ),
    "no_such_state": (
        "always: cr.state == RUNNING",
        ("E710", "`RUNNING` is no state of cr", "one of: S0, S1, S2, NOP"),
    ),
    "no_such_module": (
        "always: crr.status == DONE",
        ("E710", "`crr` is no module of this system", "did you mean `cr`?"),
    ),
    "arithmetic": (
        "always: co.status + 1",
        (
            "E713",
            "a property reads only `<module>.state|command|status == <NAME>`, "
            "`sent(<sub>.<COMMAND>)`, `writes(<name>)` and `safe(world.<actuator>)`",
            ANY_ATOM,
        ),
    ),
    "other_call": (
        "always: halted(co.SUMP)",
        (
            "E713",
            "a property calls only `sent(<sub>.<COMMAND>)`, `writes(<name>)` and "
            "`safe(world.<actuator>)`, each with one argument",
            "",
        ),
    ),
    "sent_a_module": (
        "always: not sent(cr)",
        ("E713", "`sent(...)` takes a dotted name", ""),
    ),
    "sent_no_command": (
        "always: not sent(cr.SUMPP)",
        ("E710", "`SUMPP` is no command of cr", "did you mean `SUMP`?"),
    ),
    "no_world_field": (
        "always: safe(world.drum_on_cmdd)",
        ("E710", "`world.drum_on_cmdd` is no world field", "did you mean `drum_on_cmd`?"),
    ),
    "safe_of_no_actuator": (
        "always: safe(world.true_x)",
        ("E713", "`world.true_x` is no actuator: it has no safe value", ""),
    ),
    "too_late": (
        "whenever: co.status == ERROR\n    then: cr.command == SUMP\n    within: 101",
        (
            "E712",
            "`within: 101`: a response is due within 0 to 100 cycles",
            "0: in the same cycle as the trigger; longer waits are a time-out's job",
        ),
    ),
}


@pytest.fixture(scope="module")
def located(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Diagnostic]:
    """Each added property's error, by the property's name (found from the line it is on)."""
    copy = tmp_path_factory.mktemp("props") / "miner"
    shutil.copytree(MINER, copy, ignore=shutil.ignore_patterns("scenarios", "__pycache__"))
    system = copy / "system.yaml"
    text = system.read_text(encoding="utf-8")
    assert "\nproperties:" not in text
    added, line_of = ["", "properties:"], {}
    first = text.count("\n") + 1 + len(added)
    for name, (condition, _) in CASES.items():
        line_of[first + len(added) - 2] = name
        added += [f"  - name: {name}", f"    {condition}"]
    system.write_text(text + "\n".join(added) + "\n", encoding="utf-8")
    errors = compile_paths([copy]).diagnostics.errors
    out = {}
    for d in errors:
        assert d.span.file.endswith("system.yaml"), d.render()
        # the error is on the property's condition line(s), just after its name
        name = next(line_of[n] for n in sorted(line_of, reverse=True) if n < d.span.line)
        assert name not in out, d.render()
        out[name] = d
    return out


@pytest.fixture(scope="module")
def found(located: dict[str, Diagnostic]) -> dict[str, tuple[str, str, str]]:
    return {name: (d.code, d.message, d.hint) for name, d in located.items()}


@pytest.mark.parametrize("name", CASES)
def test_each_wrong_property_gets_its_one_error(found, name: str) -> None:
    assert found.get(name) == CASES[name][1]


@pytest.mark.parametrize(
    ("name", "at"),
    [("no_such_status", "DONNE"), ("deeper_name", "co.status.x"), ("sent_no_command", "cr.SUMPP")],
)
def test_an_error_inside_a_condition_is_located_at_what_it_is_about(
    located: dict[str, Diagnostic], name: str, at: str
) -> None:
    """The column of the name the error is about, in the condition's line (not its start)."""
    line = f"    {CASES[name][0]}"
    assert located[name].span.col == line.index(at) + 1, located[name].render()
