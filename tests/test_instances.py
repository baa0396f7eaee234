"""Instances of a template (docs/spec.md section 18) beyond the corpus' cases: what is found in
a template's text names the instance it was found in; each instance's parameters reach its
own copy only."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from conftest import edit

from rcsgen.compiler.frontend import compile_paths

CASE = Path(__file__).resolve().parent / "cases" / "valid" / "instances"


@pytest.fixture
def fleet(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(CASE, tmp_path / "fleet")
    monkeypatch.chdir(tmp_path)
    return Path("fleet")


def test_a_finding_in_a_template_names_each_instance_it_was_found_in(fleet: Path) -> None:
    """A state of the template that can wait (W503) is found in each instance's copy: one
    finding per instance, each at the template's line, each hint naming its instance and
    where system.yaml declares it."""
    edit(
        fleet / "cart" / "wheel.yaml",
        "        - when: n >= LIMIT\n          do: [report: ERROR]\n",
        "",
    )
    found = [d for d in compile_paths([fleet]).diagnostics if d.code == "W503"]
    assert [(d.span.file, d.span.line) for d in found] == [("fleet/cart/wheel.yaml", 14)] * 2
    assert [d.hint.rsplit("(in ", 1)[1] for d in found] == [
        "instance `c1` (fleet/system.yaml:14:3) of template `cart`)",
        "instance `c2` (fleet/system.yaml:18:3) of template `cart`)",
    ]


def test_each_instance_s_constants_and_fields_reach_its_own_copy_only(fleet: Path) -> None:
    """c1 and c2 give SPEED 1.0 and 2.0, take LIMIT's default, and own `c1_pos`, `c2_pos`:
    each copy reads its own; the system binds both instances' `goal` to `target`."""
    front = compile_paths([fleet])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics]
    (system,) = front.systems
    controllers = {c.name: c for c in system.controllers}
    assert sorted(controllers) == ["boss", "c1", "c1_wheel", "c2", "c2_wheel"]
    constants = {n: dict(c.constants) for n, c in controllers.items()}
    assert constants["c1"] == {"SPEED": "1.0"} and constants["c2"] == {"SPEED": "2.0"}
    assert constants["c1_wheel"] == constants["c2_wheel"] == {"LIMIT": "3"}
    assert {f.name for f in system.world} == {"target", "on", "c1_pos", "c2_pos"}
    assert [f.name for f in controllers["c1_wheel"].world_writes] == ["c1_pos"]
    assert [f.name for f in controllers["c2"].world_reads] == ["target"]


def test_an_instance_binds_a_field_another_instance_owns(fleet: Path) -> None:
    """c2's `goal` bound to c1's own `pos` (a follower of the first cart): c2 reads `c1_pos`,
    which c1's wheel writes; a misspelt one is E904 naming the instances' fields too."""
    system_yaml = fleet / "system.yaml"
    edit(
        system_yaml,
        "    constants: {SPEED: 2.0}\n    bind: {goal: target}",
        "    constants: {SPEED: 2.0}\n    bind: {goal: c1_pos}",
    )
    front = compile_paths([fleet])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics]
    (system,) = front.systems
    c2 = next(c for c in system.controllers if c.name == "c2")
    assert [f.name for f in c2.world_reads] == ["c1_pos"]
    edit(system_yaml, "bind: {goal: c1_pos}", "bind: {goal: c1_pso}")
    found = compile_paths([fleet]).diagnostics
    assert [(d.code, d.span.line, d.hint) for d in found] == [
        ("E904", 21, "did you mean `c1_pos`?")
    ]


def test_a_bool_constant_takes_true_or_false_and_its_default(fleet: Path) -> None:
    """A template's bool constant: each instance gives it `true` or `false`, or takes its
    default; its copy holds that value (an int or a float is refused: E905)."""
    edit(
        fleet / "cart" / "template.yaml",
        "  LIMIT: {type: int, default: 3}\n",
        "  LIMIT: {type: int, default: 3}\n  ARMED: {type: bool}\n"
        "  LOUD: {type: bool, default: true}\n",
    )
    edit(fleet / "system.yaml", "{SPEED: 1.0}", "{SPEED: 1.0, ARMED: true}")
    edit(fleet / "system.yaml", "{SPEED: 2.0}", "{SPEED: 2.0, ARMED: false, LOUD: false}")
    edit(
        fleet / "cart" / "cart.yaml",
        "- when: wheel.status == DONE",
        "- when: wheel.status == DONE and (ARMED or not LOUD)",
    )
    edit(
        fleet / "cart" / "cart.yaml",
        "- when: wheel.status == ERROR",
        "- when: wheel.status == ERROR or (not ARMED and LOUD)",
    )
    front = compile_paths([fleet], analyse=False)
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics]
    constants = {c.name: dict(c.constants) for c in front.systems[0].controllers}
    assert constants["c1"] == {"SPEED": "1.0", "ARMED": "True", "LOUD": "True"}
    assert constants["c2"] == {"SPEED": "2.0", "ARMED": "False", "LOUD": "False"}
    edit(fleet / "system.yaml", "ARMED: true", "ARMED: 1")
    (found,) = compile_paths([fleet], analyse=False).diagnostics.errors
    assert (found.code, found.message) == (
        "E905",
        "`ARMED` of template `cart` is true or false, not 1",
    )


def test_a_constant_of_the_wrong_kind_is_told_in_words(fleet: Path) -> None:
    """A constant of the wrong kind is told what it takes, as a user reads it: an int
    constant `an integer`, a float one `a number`, in an instance (E905) as in a default
    (E907)."""
    edit(fleet / "cart" / "template.yaml", "default: 3}", "default: 3.5}")
    edit(fleet / "system.yaml", "{SPEED: 1.0}", "{SPEED: 1.0, LIMIT: 2.5}")
    edit(fleet / "system.yaml", "{SPEED: 2.0}", "{SPEED: true}")
    found = compile_paths([fleet], analyse=False).diagnostics.errors
    assert [(str(d.span), d.code, d.message) for d in found] == [
        ("fleet/cart/template.yaml:7:31", "E907", "the default of `LIMIT` is not an integer: 3.5"),
    ]
    edit(fleet / "cart" / "template.yaml", "default: 3.5}", "default: 3}")
    found = compile_paths([fleet], analyse=False).diagnostics.errors
    assert [(d.code, d.message) for d in found] == [
        ("E905", "`LIMIT` of template `cart` is an integer, not 2.5"),
        ("E905", "`SPEED` of template `cart` is a number, not True"),
    ]


def test_each_misnamed_controller_file_of_a_template_is_reported(fleet: Path) -> None:
    """Two controller files of a template named unlike their controllers: E222 for each, not
    the first alone."""
    for name in ("cart", "wheel"):
        (fleet / "cart" / f"{name}.yaml").rename(fleet / "cart" / f"{name}_x.yaml")
    found = compile_paths([fleet], analyse=False).diagnostics.errors
    assert [(d.code, d.message) for d in found] == [
        ("E222", "controller `cart` is declared in `cart_x.yaml`"),
        ("E222", "controller `wheel` is declared in `wheel_x.yaml`"),
    ]


def test_a_template_s_finding_names_its_instances_by_subject_or_quoted_module() -> None:
    """`annotate` in process (no build): a finding in a template's file names the instances
    it was found in, by its subject's controller, else by a module quoted in its message (at
    most three named); one outside the template's directory, or from index `first` back, or
    naming no instance's module is left as it is. Acknowledged findings are named too."""
    from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span, Subject
    from rcsgen.compiler.front_end.instances import Instance, Template, annotate
    from rcsgen.compiler.front_end.loader import LocDict

    at = Span("fleet/cart/template.yaml", 1, 1)
    cart = Template(
        "cart", Path("fleet/cart"), at, "Cart", "cart", {}, LocDict(at), {}, {}, [], {}, {}
    )
    made = [
        Instance(
            f"c{n}",
            cart,
            Span("fleet/system.yaml", 10 + n, 3),
            "",
            {},
            {},
            {"cart": f"c{n}", "wheel": f"c{n}_wheel"},
        )
        for n in range(1, 6)
    ]
    wheel = Span("fleet/cart/wheel.yaml", 14, 9)
    diags = Diagnostics()
    diags.error(wheel, "E204", "unknown command `c9_wheel.GO`", "seen before index first")
    diags.warning(
        wheel,
        "W503",
        "this state can wait forever",
        "add a timeout",
        Subject("c2_wheel", "GO", "S0"),
    )
    diags.error(wheel, "E204", "`c1_wheel.MOVEE` and `c3.GO` are not commands")
    diags.error(wheel, "E204", "`c1_wheel.MOVEE`, `c2.X`, `c3.Y`, `c4.Z`: not commands")
    diags.error(wheel, "E204", "unknown command `c9_wheel.GO`", "no instance's module")
    diags.error(Span("fleet/boss.yaml", 3, 1), "E204", "`c1.GO` is not a command", "elsewhere")
    diags.error(Span("wheel.yaml", 3, 1), "E204", "`c1.GO` is not a command", "no directory")
    diags.error(Span("cart/wheel.yaml", 3, 1), "E204", "`c4.GO` is not a command")
    diags.acknowledge(Diagnostic(wheel, "W503", "acknowledged", "", Subject("c5")), "why")
    annotate(diags, made, 1)
    assert [d.hint for d in [*diags.items, *diags.acknowledged]] == [
        "seen before index first",
        "add a timeout (in instance `c2` (fleet/system.yaml:12:3) of template `cart`)",
        "in instance `c1` (fleet/system.yaml:11:3), instance `c3` (fleet/system.yaml:13:3) "
        "of template `cart`",
        "in instance `c1` (fleet/system.yaml:11:3), instance `c2` (fleet/system.yaml:12:3), "
        "instance `c3` (fleet/system.yaml:13:3) of template `cart`",
        "no instance's module",
        "elsewhere",
        "no directory",
        "in instance `c4` (fleet/system.yaml:14:3) of template `cart`",
        "in instance `c5` (fleet/system.yaml:15:3) of template `cart`",
    ]


def test_an_instance_renames_references_but_copies_text_as_written(fleet: Path) -> None:
    """In c1's copy of the cart, `wheel` in an expression or a send is c1's wheel
    (`c1_wheel`); in a doc it is a word, kept as written."""
    cart = fleet / "cart" / "cart.yaml"
    edit(cart, "title: Cart controller\n", "title: Cart controller\ndoc: Drives wheel.MOVE.\n")
    edit(
        cart,
        "      S1:\n        - when: wheel.status == ERROR\n",
        "      S1:\n        - doc: when wheel.status is ERROR\n"
        "          when: wheel.status == ERROR\n",
    )
    front = compile_paths([fleet], analyse=False)
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics]
    ((_, specs),) = front.models.values()
    c1 = next(c for c in specs if c.name == "c1")
    assert (c1.title, c1.doc) == ("Cart controller (c1)", "Drives wheel.MOVE.")
    assert [str(s.value) for s in c1.subordinates] == ["c1_wheel"]
    rule = c1.commands["GO"].states["S1"].rules[0]
    assert (rule.doc, rule.when.value if rule.when else None) == (
        "when wheel.status is ERROR",
        "c1_wheel.status == ERROR",
    )
