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
import functools
import re
import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.checks import naming
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
    names: set[str] = set()
    for node in ast.parse(module.read_text()).body:
        if isinstance(node, ast.ImportFrom):
            names |= {a.asname or a.name for a in node.names}
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
    return {n for n in names if UPPER.fullmatch(n)}


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


# ------------------------------------------------------------ the reserved sets, both ways

GENERATED = sorted(p for p in (ROOT / "generated").iterdir() if (p / "layout.py").is_file())
# Blocks of a generated controller module whose constants its spec names (commands, reasons,
# states, constants, enumeration values), by their comment's first words.
OWN_BLOCKS = ("# Commands ", "# Why ", "# States ", "# Constants.", "# Enumeration values ")
# A runtime name no committed module has, and why it is reserved all the same.
NOT_SHIPPED = {"NOT_READY": "imported where a guard compares a status with it; no shipped spec"}


# What the tests below read of a generated module, by its lines (ruff formats it, so a
# module-level name starts its line, a class-level one is indented four spaces): a regular
# expression over the text is a tenth of the time a syntax tree of 90 modules takes.
_ASSIGNED = re.compile(r"^(\w+)(?:: [^=\n]+)? = ", re.MULTILINE)
_DEFINED = re.compile(r"^(?:def|class) (\w+)", re.MULTILINE)
_IMPORTS = re.compile(r"^(?:from \S+ )?import (\([^)]*\)|.+)$", re.MULTILINE)
_METHOD = re.compile(r"^    def (\w+)\(self[^)]*\)(?: -> ([^:]+))?:", re.MULTILINE)
_CLASS_ASSIGNED = re.compile(r"^    (\w+)(?:: [^=\n]+)? = (\w*)", re.MULTILINE)


@functools.cache
def _text(module: Path) -> str:
    return module.read_text()


@functools.cache
def _literal(module: Path, name: str) -> list[str]:
    """The names a generated module lists in `name` at module level (a tuple's strings, or
    a dict's keys; none where it has no `name`)."""
    found = re.search(rf"^{name}(?:: [^=\n]+)? = (.*?)(?=^\S)", _text(module), re.M | re.S)
    if found is None:
        return []
    value = found.group(1)
    if value.startswith("{"):
        return re.findall(r'^    "(\w+)": ', value, re.MULTILINE)
    return re.findall(r'"(\w+)"', value)


@functools.cache
def _spec_prefixes(package: Path) -> tuple[str, ...]:
    """The prefixes of the layout names a system's specs make: each module's and operator's
    mnemonic, each world field's, each process's records."""
    layout = package / "layout.py"
    modules = [*_literal(layout, "MODULES"), *_literal(layout, "OPERATORS")]
    return (*(f"{m.upper()}_" for m in modules), "WORLD_", "PROCESS_", "PACE_")


def _module_level(module: Path, blocks: bool = True) -> tuple[set[str], set[str]]:
    """(every module-level name of a generated module, those its spec names: its functions
    and classes and, with `blocks`, what its own blocks assign)."""
    text = _text(module)
    own = set(_DEFINED.findall(text))
    block = False
    for line in text.splitlines() if blocks else ():
        if line.startswith("#"):
            block = line.startswith(OWN_BLOCKS) or (block and line.startswith("# "))
        elif not line:
            block = False
        elif block and (m := re.match(r"(\w+) = ", line)):
            own.add(m.group(1))
    names = set(_ASSIGNED.findall(text)) | own
    for imported in _IMPORTS.findall(text):
        for item in imported.strip("()").split(","):
            words = item.split()
            names |= {words[-1].split(".")[0]} if words else set()
    return names, own


def _controllers(package: Path) -> list[Path]:
    """A package's controller modules (not its operator modules, layout, process plans)."""
    found = []
    for module in sorted(package.glob("*.py")):
        text = module.read_text()
        if module.stem != "layout" and not module.stem.startswith(("main_", "_")):
            found += [module] if "(OperatorModule):" not in text else []
    return found


def test_the_reserved_module_names_are_exactly_what_generated_modules_have() -> None:
    """naming.RUNTIME_NAMES is every module-level name a generated controller module has
    that its spec does not name (so a constant, state or function named like one is
    refused), and nothing else (a name nothing generates would refuse a valid spec: once
    `SEQ`, `SEQS`, `MODE` were). Read from every committed package (kept current by
    test_generated_current)."""
    fixed: set[str] = set()
    everywhere: set[str] = set()
    for package in GENERATED:
        prefixes = (*_spec_prefixes(package), "REASON_")
        for module in _controllers(package):
            names, own = _module_level(module)
            everywhere |= names
            fixed |= {n for n in names - own if not n.startswith(prefixes)}
    assert fixed - naming.RUNTIME_NAMES == set(), "generated but not reserved"
    assert naming.RUNTIME_NAMES - everywhere == set(NOT_SHIPPED), "reserved but never generated"


def _class_names(module: Path, package: Path) -> set[str]:
    """The attributes and methods of a generated controller class that its spec does not
    name: not a command's table, a predicate, a hook's method, a world field's, parameter's,
    local's, result's, plan's or subordinate's attribute, a `for:` counter."""
    text = _text(module)
    accepts = text.split(f"# Commands {module.stem} accepts", 1)[1]
    commands = re.findall(r"^(\w+) = ", accepts.split("\n\n")[0], re.MULTILINE)
    spec = {naming.command_method(c) for c in commands}
    fixed = {"__slots__"}
    for name, returns in _METHOD.findall(text):
        (spec if returns == "bool" else fixed).add(name)  # bool: a predicate
    for name, value in _CLASS_ASSIGNED.findall(text):
        (spec if value == "hook" else fixed).add(name)  # hook(...): a hook's method
    fixed |= set(re.findall(r"\bself\.(\w+)", text))
    world = tuple(f"world_{f}" for f in _literal(package / "layout.py", "WORLD"))
    subs = tuple(p.lower() for p in _spec_prefixes(package)[:-3])
    made = ("arg_", "var_", "result_", "plan_", *subs)
    held = re.compile(r"held_\w+_\d+")
    return {n for n in fixed - spec if not (n.startswith(made) or n in world or held.fullmatch(n))}


def test_the_reserved_class_names_are_exactly_what_generated_classes_have() -> None:
    """naming.CLASS_NAMES is every attribute and method of a generated controller class that
    no spec name makes, and nothing else (`pre_process` and the other QQ1 steps are comments
    in `run_cycle`, not methods, so a command or predicate may take their names)."""
    fixed: set[str] = set()
    for package in GENERATED:
        for module in _controllers(package):
            fixed |= _class_names(module, package)
    assert fixed - naming.CLASS_NAMES == set(), "generated but not reserved"
    assert naming.CLASS_NAMES - fixed == set(), "reserved but never generated"


def test_the_reserved_layout_names_are_exactly_what_generated_layouts_have() -> None:
    """naming.LAYOUT_NAMES is every module-level name of a generated layout module that no
    spec name makes (a controller's buffers, a process's records, a world field's, an
    operator's channels), and nothing else (`NamedTuple` and `STATUS_NAMES` no longer are)."""
    fixed: set[str] = set()
    for package in GENERATED:
        prefixes = _spec_prefixes(package)
        names, _ = _module_level(package / "layout.py", blocks=False)
        fixed |= {n for n in names if not n.startswith(prefixes)}
    spec_like = {n for n in naming.LAYOUT_NAMES if n.startswith(("WORLD_", "PROCESS_", "PACE_"))}
    assert fixed - naming.LAYOUT_NAMES == set(), "generated but not reserved"
    assert naming.LAYOUT_NAMES - fixed - spec_like == set(), "reserved but never generated"


@pytest.mark.parametrize("suffix", naming.SUB_SUFFIXES)
def test_a_local_named_like_an_attribute_kept_for_a_subordinate_is_refused(
    tmp_path: Path, suffix: str
) -> None:
    """`top` keeps `var<suffix>` for its subordinate `var`; a local that becomes that name
    (locals are `var_<name>` in the class) is one E228, naming both."""
    case = ROOT / "tests" / "cases" / "invalid" / "e228-name-collision--sub-attributes"
    spec = tmp_path / "spec"
    shutil.copytree(case, spec)
    top = spec / "top.yaml"
    local = suffix.removeprefix("_")
    top.write_text(top.read_text().replace("  status:  # expect: E228\n", f"  {local}:\n"))
    errors = compile_paths([spec]).diagnostics.errors
    assert [(d.code, d.message) for d in errors] == [
        (
            "E228",
            f"local `{local}` becomes `var{suffix}` in the generated class of `top`, which is "
            f"already subordinate `var` ({top}:3:21)",
        )
    ]
