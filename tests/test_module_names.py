"""A controller's own names (constants, states, commands, enum values) become module-level
names of its generated module, beside the names the module always has: the runtime's and
the layout's it imports, its world runs' structs, its subordinates' codes and links, its
reasons' codes (rcsgen/compiler/checks/naming.py, `check_module_names`). A spec name equal
to one of those would silently replace it (a constant `OVERRIDDEN_AT: 0` made a world
writer read byte 0 for its override flag, so a field forced safe was driven anyway): E228.

Checked against the product: every upper-case module-level name of the committed
generated modules, given as a constant of the spec it was made from, is refused, at the
constant, with what it collides with."""

from __future__ import annotations

import ast
import re
import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths

ROOT = Path(__file__).resolve().parent.parent
# (system, controllers): a world writer with its overrides (exe, ship), supervisors with
# subordinates' codes and links and an operator's channel (sm, cc), a controller with its
# own status struct (cc), a stand-in running in the buffers of the controller it replaces
# (cr_sim for cr).
CASES = [
    ("cell", ("exe", "sup")),
    ("submarine", ("cc", "sm", "ship")),
    ("miner", ("cr_sim",)),
]
UPPER = re.compile(r"[A-Z][A-Z0-9_]*")


def module_level_names(module: Path) -> set[str]:
    """The upper-case names a generated module defines or imports at module level."""
    return {n for n in top_level_names(module) if UPPER.fullmatch(n)}


def top_level_names(module: Path) -> set[str]:
    """Every name a generated module defines or imports at module level."""
    names: set[str] = set()
    for node in ast.parse(module.read_text()).body:
        if isinstance(node, ast.ImportFrom):
            names |= {a.asname or a.name for a in node.names}
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
    return names


def own_names(module: Path) -> set[str]:
    """The constants a generated module has for its spec's own commands and states (some
    from the default INIT/HALT tables or fragments, written nowhere in the spec itself)."""
    own: set[str] = set()
    block = False
    for line in module.read_text().splitlines():
        if line.startswith(("# States of the state tables", f"# Commands {module.stem} accepts")):
            block = True
        elif not line:
            block = False
        elif block and (m := re.match(r"(\w+) = ", line)):
            own.add(m.group(1))
    return own


def with_constants(spec: Path, names: list[str]) -> None:
    """`spec` with `names` declared as constants (before its own, if it has any)."""
    text = spec.read_text()
    block = "constants:\n" + "".join(f"  {name}: 1\n" for name in names)
    if "\nconstants:\n" in text:
        text = text.replace("\nconstants:\n", "\n" + block, 1)
    else:
        text = text.replace("\ncommands:\n", "\n" + block + "\ncommands:\n", 1)
    spec.write_text(text)


# Names each module has although (for some) its committed module does not import them, and
# what each collides with, word for word.
NAMED = {
    "exe": {
        "OVERRIDDEN_AT": "a status or runtime name",
        "OVERRIDE": "a status or runtime name",
        "FACTORY_DEADLINE": "a status or runtime name",
        "WORLD_HELD_1": "a generated name",
        "WORLD_OUT_1_AT": "a generated name",
        "WORLD_ARM_X": "a layout name",
        "WORLD_ARM_X_AT": "a layout name",
        "WORLD_ARM_X_WORD": "a generated name",
        "EXE_MODE_AT": "a layout name",
        "REASON_NONE": "the code of the reason NONE",
        "REASON_LOST": "the code of the reason LOST",
    },
    "sup": {
        "SUP_STATUS": "a layout name",
        "PLN_LINK": "pln's number in the causes' chain",
        "PLN_PLAN": "the code of pln's PLAN",
        "EXE_ECHO_CYCLES": "exe's echo timeout",
        "EXE_REASON_LOST": "the code of exe's reason LOST",
        "PLN_STATUS_WORD": "a layout name",
    },
    "cc": {
        "EOOW_CC_COMMAND_WORD": "a layout name",
        "EOOW_CC_COMMAND_AT": "a layout name",
        "EOOW_REASON_REFUSED": "the code of eoow's reason REFUSED",
    },
    "cr_sim": {"CR_STATUS_AT": "a layout name", "CR_PERF_WORD": "a layout name"},
}


@pytest.mark.parametrize(("system", "controllers"), CASES, ids=[c[0] for c in CASES])
def test_every_name_of_a_generated_module_is_refused_as_a_constant(
    tmp_path: Path, system: str, controllers: tuple[str, ...]
) -> None:
    specs = tmp_path / system
    shutil.copytree(ROOT / "specs" / system, specs)
    given: dict[str, list[str]] = {}
    lines: dict[tuple[str, str], int] = {}  # where each constant is written
    for name in controllers:
        spec = specs / f"{name}.yaml"
        own = set(re.findall(r"\b[A-Z][A-Z0-9_]*\b", spec.read_text()))  # its own names
        module = ROOT / "generated" / system / f"{name}.py"
        own |= own_names(module)
        given[name] = sorted((module_level_names(module) | set(NAMED.get(name, ()))) - own)
        with_constants(spec, given[name])
        for number, line in enumerate(spec.read_text().splitlines(), start=1):
            if m := re.fullmatch(r"  (\w+): 1", line):
                lines[(name, m.group(1))] = number
    found = compile_paths([specs], analyse=False).diagnostics.items
    refused: dict[tuple[str, str], str] = {}
    for d in found:
        m = re.fullmatch(r"constant `(\w+)` collides with (.+) in the generated module", d.message)
        assert m is not None and d.code == "E228", (d.code, d.message)
        assert d.hint == "rename it"
        where = (Path(d.span.file).stem, m.group(1))
        assert (d.span.line, d.span.col) == (lines[where], 3), (d.span, where)
        refused[where] = m.group(2)
    for name, names in given.items():
        assert len(names) > 10
        missing = [n for n in names if (name, n) not in refused]
        assert missing == [], f"{system}/{name}: no E228 for the constants {missing}"
        for constant, what in NAMED.get(name, {}).items():
            assert refused[(name, constant)] == what, constant
    assert len(found) == sum(map(len, given.values()))


def class_names(module: Path) -> set[str]:
    """The lower-case attributes and methods of a generated module's controller class."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(module.read_text())):
        if isinstance(node, ast.ClassDef):
            names |= {b.name for b in node.body if isinstance(b, ast.FunctionDef)}
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            names |= {node.attr} if node.value.id == "self" else set()
    return {n for n in names if re.fullmatch(r"[a-z][a-z0-9_]*", n)}


@pytest.mark.parametrize(
    ("system", "controllers"),
    [("cell", ("exe", "sup", "pln")), ("submarine", ("cc", "sm", "rudder_sim", "atmosphere"))],
    ids=["cell", "submarine"],
)
def test_every_attribute_of_a_generated_class_is_refused_as_a_predicate(
    tmp_path: Path, system: str, controllers: tuple[str, ...]
) -> None:
    """A predicate becomes a method of the class: named like an attribute (`words`, `cause`,
    `result_made` once made a class whose import failed: '... in __slots__ conflicts with
    class variable'), it is refused at the predicate."""
    specs = tmp_path / system
    shutil.copytree(ROOT / "specs" / system, specs)
    given: dict[str, list[str]] = {}
    lines: dict[tuple[str, str], int] = {}
    for name in controllers:
        spec = specs / f"{name}.yaml"
        text = spec.read_text()
        bare = re.sub(r"#.*", "", text)  # its predicates, hooks, ..., not its comments' words
        own = set(re.findall(r"\b[a-z][a-z0-9_]*\b", bare))
        made = class_names(ROOT / "generated" / system / f"{name}.py") - own
        # a plan's names: E291 at the plan, once for all of them (the corpus has its case)
        given[name] = sorted(n for n in made if not n.startswith("plan_"))
        assert "\npredicates:" not in text
        block = "predicates:\n" + "".join(f"  {n}: 1 > 0\n" for n in given[name])
        spec.write_text(text.replace("\ncommands:", "\n" + block + "\ncommands:", 1))
        for number, line in enumerate(spec.read_text().splitlines(), start=1):
            if m := re.fullmatch(r"  (\w+): 1 > 0", line):
                lines[(name, m.group(1))] = number
    found = compile_paths([specs], analyse=False).diagnostics.items
    refused = set()
    for d in found:
        assert d.code in ("E228", "E291"), (d.code, d.message)
        where = Path(d.span.file).stem
        named = {n for n in re.findall(r"`(\w+)`", d.message) if (where, n) in lines}
        assert len(named) == 1, d.message
        at = lines[(where, *named)]  # at the predicate, or (a later claim's) naming its place
        assert d.span.line == at or f".yaml:{at}:3)" in d.message, (d.span, d.message)
        refused.add((where, *named))
    for name, names in given.items():
        assert {"words", "result_made"} <= set(names) or name != "sup"
        assert "cause" in names or name != "sm"
        assert "held_every_cycle_1" in names or name != "atmosphere"  # its `for:` rule's
        missing = [n for n in names if (name, n) not in refused]
        assert missing == [], f"{system}/{name}: no error for the predicates {missing}"


def test_the_layout_names_reserved_are_the_ones_every_layout_module_has() -> None:
    """naming.LAYOUT_NAMES, against the committed layout modules of every system: each is a
    name some layout has (no stale entry), and each name all of them have (no spec name is
    common to every system) is reserved."""
    from rcsgen.compiler.checks.naming import LAYOUT_NAMES

    layouts = [top_level_names(p) for p in sorted((ROOT / "generated").glob("*/layout.py"))]
    assert len(layouts) >= 5
    assert sorted(LAYOUT_NAMES - set.union(*layouts)) == []
    assert sorted(set.intersection(*layouts) - LAYOUT_NAMES) == []
