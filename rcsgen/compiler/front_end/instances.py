"""Instances: a template (a controller and its subtree, written once) -> one copy per instance.

A template is a directory beside system.yaml: `template.yaml` (its name, its root, its
constants, its own world fields, its world-field parameters, its simulators) and one
controller file per controller, written as any other (docs/spec.md section 18). system.yaml's
`instances:` names each instance, its template and a value for each parameter. Each instance
is the template's controllers again, renamed: the root takes the instance's name, every other
controller X becomes `<instance>_X`, each own world field F becomes `<instance>_F` (declared
in the system by the expansion) and each `bind:` parameter becomes the system field the
instance binds it to; the template's constants become constants of the controllers that read
them, with the instance's values.

The expansion runs in two places of the front end: `expand_system` on system.yaml's data,
after its schema check (the template is loaded and checked once, the instances' parameters
are checked, their own fields, simulators and stand-ins are added to the system's data), and
`rename` on each copy of a template controller's data, after its fragments are expanded and
before its schema check: every later stage sees ordinary controllers. The copies keep the
spans of the template's text; `annotate` adds the instance to a diagnostic found there.

Diagnostics: E901 unknown template, E902 unknown parameter, E903 missing binding, E904 binding
to an unknown world field, E905 a value or binding of the wrong type, E906 a name two
instances (or an instance and the system) both make, E907 a malformed template, E908 a
template controller using a world field its template does not declare; a template's file that
is no controller is E225, one named unlike its controller E222, as in a system directory.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..codes import Severity
from ..diagnostics import Diagnostic, Diagnostics, Span, SpecError, known_names_hint
from ..types import Type
from .loader import LocDict, LocList, LocStr, key_span, load_file, span_of, value_span
from .model import declared_type
from .schema import check_document

FILE = "template.yaml"

# In an expression: a string literal (left alone), `world.<field>`, or a name before a dot.
_REFERENCE = re.compile(
    r"""'[^']*'|"[^"]*"|(?<![\w.])world\s*\.\s*([A-Za-z_]\w*)|(?<![\w.])([A-Za-z_]\w*)(?=\s*\.)"""
)
_TEXT_KEYS = frozenset({"doc", "title", "text", "hooks_module", "hooks_state", "planner"})
_SCALARS = {"bool": (bool,), "int": (int,), "float": (int, float)}


@dataclass
class Template:
    """A template as loaded and checked: its parameters and its controllers' data."""

    name: str
    directory: Path
    span: Span  # `template:` in template.yaml
    title: str
    root: str
    constants: dict[str, LocDict]  # NAME -> {type, default, doc}
    world: LocDict  # own fields: name -> declaration, as in system.yaml
    bind: dict[str, Type]  # world-field parameter -> its type
    bind_spans: dict[str, Span]
    simulators: list[str]
    stand_ins: dict[str, str]
    members: dict[str, tuple[Path, LocDict]]  # controller -> its file and loaded data


@dataclass
class Instance:
    """One instance: its template, its names and its parameters' values."""

    name: str
    template: Template
    span: Span  # its name in system.yaml
    title: str
    constants: dict[str, tuple[object, Span]]  # NAME -> (value, where it is given)
    bind: dict[str, str]  # parameter -> system field
    modules: dict[str, str] = field(default_factory=dict)  # template controller -> module
    fields: dict[str, str] = field(default_factory=dict)  # world name in the template -> system

    def module(self, member: str) -> str:
        return self.name if member == self.template.root else f"{self.name}_{member}"


# ---------------------------------------------------------------- the template


def _load(path: Path, shown: str, diags: Diagnostics) -> object:
    try:
        return load_file(path, shown)
    except SpecError as error:
        diags.extend(error.diagnostics.items)
        return None


def _schema(data: object, kind: str, shown: str, diags: Diagnostics) -> bool:
    problems = check_document(data, kind, shown)
    diags.extend(problems)
    return not any(p.severity is Severity.ERROR for p in problems)


def _templates_in(directory: Path) -> list[str]:
    try:
        return sorted(p.parent.name for p in directory.glob(f"*/{FILE}"))
    except OSError:
        return []


def load_template(
    directory: Path, name: str, at: Span, show: Callable[[Path], str], diags: Diagnostics
) -> Template | None:
    """The template `<directory>/<name>/`, checked, or None after its problems (E901 when
    there is none)."""
    path = directory / name / FILE
    if not path.is_file():
        diags.error(
            at,
            "E901",
            f"no template `{name}`: there is no `{name}/{FILE}` beside system.yaml",
            known_names_hint("templates", _templates_in(directory), name),
        )
        return None
    shown = show(path)
    before = len(diags.errors)
    data = _load(path, shown, diags)
    if len(diags.errors) > before:
        return None
    if data is None:
        diags.error(Span(shown), "E013", f"`{FILE}` is empty", "declare the template here")
        return None
    if not _schema(data, "template", shown, diags) or not isinstance(data, LocDict):
        return None  # the schema requires a mapping: a problem was reported
    top = span_of(data, Span(shown))
    if data["template"] != name:
        diags.error(
            value_span(data, "template", top),
            "E907",
            f"template `{data['template']}` is declared in directory `{name}/`",
            f"name it `{name}`: an instance finds its template by its directory",
        )
        return None
    members = _members(path.parent, show, diags)
    if members is None:
        return None
    constants, world, bind = (data.get(k) or LocDict(top) for k in ("constants", "world", "bind"))
    template = Template(
        name=name,
        directory=path.parent,
        span=value_span(data, "template", top),
        title=str(data["title"]),
        root=str(data["root"]),
        constants=dict(constants),
        world=world,
        bind={k: declared_type(v) for k, v in bind.items()},
        bind_spans={k: key_span(bind, k, top) for k in bind},
        simulators=[str(s) for s in data.get("simulators") or []],
        stand_ins={str(k): str(v) for k, v in (data.get("stand_ins") or {}).items()},
        members=members,
    )
    return template if _template_ok(template, data, top, diags) else None


def _members(
    directory: Path, show: Callable[[Path], str], diags: Diagnostics
) -> dict[str, tuple[Path, LocDict]] | None:
    """Every controller file of a template directory by its controller's name (None after a
    problem: E225, E222, E013)."""
    out: dict[str, tuple[Path, LocDict]] = {}
    before = len(diags.errors)
    for path in sorted(directory.glob("*.yaml")):
        if path.name == FILE:
            continue
        shown = show(path)
        loaded = len(diags.errors)
        data = _load(path, shown, diags)
        if len(diags.errors) > loaded:
            continue
        kind = _kind(data)
        if not isinstance(data, LocDict) or kind is None:
            diags.error(
                span_of(data, Span(shown)),
                "E225",
                f"`{path.name}` is not a controller spec (no `controller:` or `operator:` key)",
                f"a template's directory holds {FILE} and its controllers' files only",
            )
            continue
        if not _schema(data, kind, shown, diags):
            continue
        name = str(data[kind])
        if name != path.stem:
            diags.error(
                value_span(data, kind, span_of(data, Span(shown))),
                "E222",
                f"controller `{name}` is declared in `{path.name}`",
                f"name the file `{name}.yaml` so each controller is found by its mnemonic",
            )
            continue
        out[name] = (path, data)
    return out if len(diags.errors) == before else None


def _kind(data: object) -> str | None:
    if isinstance(data, dict) and "controller" in data:
        return "controller"
    if isinstance(data, dict) and "operator" in data:
        return "operator"
    return None


def _template_ok(template: Template, data: LocDict, top: Span, diags: Diagnostics) -> bool:
    """E907 and E908: the template's declarations against its controllers."""
    before = len(diags.errors)
    members = template.members

    def unknown(at: Span, what: str, name: str) -> None:
        diags.error(
            at,
            "E907",
            f"{what} `{name}` is not a controller of template `{template.name}`",
            known_names_hint("controllers", members, name),
        )

    if template.root not in members:
        unknown(value_span(data, "root", top), "root", template.root)
    for i, name in enumerate(template.simulators):
        if name not in members:
            unknown(value_span(data["simulators"], i, top), "simulator", name)
    for name, stand_in in template.stand_ins.items():
        for what, mnemonic in (("controller", name), ("stand-in", stand_in)):
            if mnemonic not in members:
                unknown(value_span(data["stand_ins"], name, top), what, mnemonic)
    for name in template.bind:
        if name in template.world:
            diags.error(
                template.bind_spans[name],
                "E907",
                f"`{name}` is both a world field of the template and a `bind:` parameter",
                "a field is the instance's own (`world:`) or the system's (`bind:`), not both",
            )
    for name, spec in template.constants.items():
        default = spec.get("default")
        if default is not None and not _fits(str(spec["type"]), default):
            diags.error(
                value_span(spec, "default", top),
                "E907",
                f"the default of `{name}` is not {_words(str(spec['type']))}: {default!r}",
            )
    _members_ok(template, diags)
    return len(diags.errors) == before


def _members_ok(template: Template, diags: Diagnostics) -> None:
    """E907 and E908: each controller of the template against its declarations."""
    names = {*template.world, *template.bind}
    for member, (path, body) in template.members.items():
        at = span_of(body, Span(str(path)))
        for key in [k for k in body.get("constants") or {} if k in template.constants]:
            diags.error(
                key_span(body["constants"], key, at),
                "E907",
                f"`{member}` declares constant `{key}`, a constant of its template",
                f"remove it here: each instance gives `{key}` (template.yaml declares it)",
            )
        world = body.get("world") or {}
        for side in ("reads", "writes"):
            for i, name in enumerate(world.get(side) or []):
                if name not in names:
                    diags.error(
                        value_span(world[side], i, at),
                        "E908",
                        f"world field `{name}` is not declared by template `{template.name}`",
                        known_names_hint("fields", names, str(name))
                        + "; a template declares its own fields (`world:`) and the ones each "
                        "instance binds (`bind:`) in template.yaml",
                    )


def _fits(kind: str, value: object) -> bool:
    return isinstance(value, _SCALARS[kind]) and (kind == "bool") == isinstance(value, bool)


def _words(kind: str) -> str:
    return {"bool": "true or false", "int": "an integer", "float": "a number"}[kind]


# ---------------------------------------------------------------- the instances


def expand_system(
    data: LocDict, directory: Path, show: Callable[[Path], str], diags: Diagnostics
) -> list[Instance]:
    """The instances system.yaml's schema-valid `data` declares, checked; each one's own world
    fields, simulators and stand-ins are added to `data` (as if system.yaml declared them)."""
    declared = data.get("instances")
    if not isinstance(declared, LocDict) or not declared:
        return []
    top = span_of(data, Span("system.yaml"))
    templates: dict[str, Template | None] = {}
    for name, spec in declared.items():
        wanted = str(spec["template"])
        if wanted not in templates:
            where = value_span(spec, "template", key_span(declared, name, top))
            templates[wanted] = load_template(directory, wanted, where, show, diags)
    # What an instance may bind: the system's fields and every instance's own (a follower's
    # `leader_x` bound to `alpha_x`); a name made twice is E906, below.
    world: dict[str, Any] = {}
    for name, spec in declared.items():
        template = templates[str(spec["template"])]
        if template is not None:
            world |= {f"{name}_{f}": declaration for f, declaration in template.world.items()}
    world |= dict(data.get("world") or {})
    made: list[Instance] = []
    for name, spec in declared.items():
        at = key_span(declared, name, top)
        template = templates[str(spec["template"])]
        if template is None:
            continue
        instance = _instance(str(name), spec, template, at, world, diags)
        if instance is not None:
            made.append(instance)
    if _collisions(made, data, directory, diags):
        return []
    for instance in made:
        _declare(instance, data, top)
    return made


def _instance(
    name: str,
    spec: LocDict,
    template: Template,
    at: Span,
    world: dict[str, Any],
    diags: Diagnostics,
) -> Instance | None:
    """One instance's parameters checked against its template (E902-E905)."""
    before = len(diags.errors)
    constants = _given_constants(name, spec, template, at, diags)
    bound = _given_bindings(name, spec, template, at, world, diags)
    if len(diags.errors) > before:
        return None
    root = template.members[template.root][1]
    title = str(spec.get("title") or f"{root['title']} ({name})")
    instance = Instance(
        name, template, at, title, constants, {str(k): str(v) for k, v in bound.items()}
    )
    instance.modules = {member: instance.module(member) for member in template.members}
    instance.fields = {f: f"{name}_{f}" for f in template.world} | instance.bind
    return instance


def _given_constants(
    name: str, spec: LocDict, template: Template, at: Span, diags: Diagnostics
) -> dict[str, tuple[object, Span]]:
    """The instance's value of each template constant, given or default (E902, E903, E905)."""
    where = f"template `{template.name}`"
    constants: dict[str, tuple[object, Span]] = {}
    given = spec.get("constants") or LocDict(at)
    for key, value in given.items():
        declared = template.constants.get(key)
        if declared is None:
            diags.error(
                key_span(given, key, at),
                "E902",
                f"`{key}` is not a constant of {where}",
                known_names_hint("constants", template.constants, key),
            )
        elif not _fits(str(declared["type"]), value):
            diags.error(
                value_span(given, key, at),
                "E905",
                f"`{key}` of {where} is {_words(str(declared['type']))}, not {value!r}",
            )
        else:
            kind = str(declared["type"])
            constants[key] = (float(value) if kind == "float" else value, key_span(given, key, at))
    for key, declared in template.constants.items():
        if key not in given and "default" in declared:
            constants[key] = (declared["default"], key_span(template.constants, key, at))
        elif key not in given:
            diags.error(
                at,
                "E903",
                f"instance `{name}` gives no value for constant `{key}` of {where}",
                f"add `constants: {{{key}: ...}}` to it (template.yaml declares `{key}` "
                "without a default)",
            )
    return constants


def _given_bindings(
    name: str,
    spec: LocDict,
    template: Template,
    at: Span,
    world: dict[str, Any],
    diags: Diagnostics,
) -> LocDict:
    """The instance's `bind:`, each parameter checked against the system's world fields
    (E902-E905)."""
    where = f"template `{template.name}`"
    bound = spec.get("bind") or LocDict(at)
    for key, target in bound.items():
        if key not in template.bind:
            diags.error(
                key_span(bound, key, at),
                "E902",
                f"`{key}` is not a `bind:` parameter of {where}",
                known_names_hint("parameters", template.bind, key),
            )
        elif target not in world:
            diags.error(
                value_span(bound, key, at),
                "E904",
                f"`{key}` is bound to `{target}`, which is not a world field of the system",
                known_names_hint("world fields", world, str(target)),
            )
        else:
            have, want = declared_type(world[target]), template.bind[key]
            if have != want:
                diags.error(
                    value_span(bound, key, at),
                    "E905",
                    f"`{key}` of {where} is {want.words}, but world field `{target}` is "
                    f"{have.words}",
                    f"bind it to a field of type {want} (declared at {template.bind_spans[key]})",
                )
    for key in template.bind:
        if key not in bound:
            diags.error(
                at,
                "E903",
                f"instance `{name}` does not bind `{key}`, a world field of {where}",
                f"add `bind: {{{key}: <a world field>}}` to it",
            )
    return bound


def _collisions(made: list[Instance], data: LocDict, directory: Path, diags: Diagnostics) -> bool:
    """E906 for each module or world field name an instance makes that is taken."""
    before = len(diags.errors)
    modules = {p.stem: f"`{p.name}`" for p in sorted(directory.glob("*.yaml"))}
    fields = {str(f): "system.yaml's `world:`" for f in data.get("world") or {}}
    for instance in made:
        mine = [(m, modules) for m in instance.modules.values()]
        mine += [(instance.fields[f], fields) for f in instance.template.world]
        for name, taken in mine:
            kind = "controller" if taken is modules else "world field"
            if name in taken:
                diags.error(
                    instance.span,
                    "E906",
                    f"instance `{instance.name}` makes {kind} `{name}`, which {taken[name]} "
                    "already makes",
                    "rename the instance (or the other): each module and each field has one name",
                )
            else:
                taken[name] = f"instance `{instance.name}` ({instance.span})"
    return len(diags.errors) > before


def _declare(instance: Instance, data: LocDict, top: Span) -> None:
    """Add the instance's own world fields, simulators and stand-ins to system.yaml's data."""
    template = instance.template
    world = data.get("world")
    if not isinstance(world, LocDict):
        world = data["world"] = LocDict(top)
    for name, spec in template.world.items():
        key = LocStr(instance.fields[name], key_span(template.world, name, top))
        world[key] = spec
        world.key_spans[key] = key.span
        world.value_spans[key] = value_span(template.world, name, top)
    if template.simulators:
        simulators = data.get("simulators")
        if not isinstance(simulators, LocList):
            simulators = data["simulators"] = LocList(top)
        for member in template.simulators:
            simulators.append(LocStr(instance.modules[member], instance.span))
            simulators.item_spans.append(instance.span)
    if template.stand_ins:
        stand_ins = data.get("stand_ins")
        if not isinstance(stand_ins, LocDict):
            stand_ins = data["stand_ins"] = LocDict(top)
        for name, stand_in in template.stand_ins.items():
            key = LocStr(instance.modules[name], instance.span)
            stand_ins[key] = LocStr(instance.modules[stand_in], instance.span)
            stand_ins.key_spans[key] = stand_ins.value_spans[key] = instance.span


# ---------------------------------------------------------------- the copies


def copies(made: list[Instance]) -> Iterator[tuple[Instance, str, Path, LocDict]]:
    """Each instance's copy of each template controller's data (to expand and `rename`)."""
    for instance in made:
        for member, (path, data) in instance.template.members.items():
            yield instance, member, path, _copy(data, lambda s: s)


def rename(data: LocDict, instance: Instance, member: str) -> LocDict:
    """A template controller's data (fragments expanded) as the instance's controller."""
    template = instance.template
    subs = {
        str(s): instance.modules[str(s)]
        for s in data.get("subordinates") or []
        if str(s) in instance.modules
    }

    def reference(found: re.Match[str]) -> str:
        whole, field_name, module = found.group(0), found.group(1), found.group(2)
        if field_name is not None and field_name in instance.fields:
            return f"world.{instance.fields[field_name]}"
        if module is not None and module in subs:
            return subs[module]
        return whole

    def expression(text: str) -> str:
        return _REFERENCE.sub(reference, text)

    out = _walk(data, (), expression, subs, instance)
    assert isinstance(out, LocDict)
    kind = "controller" if "controller" in out else "operator"
    out[kind] = LocStr(instance.modules[member], span_of(data[kind], out.span))
    if member == template.root:
        out["title"] = LocStr(instance.title, span_of(data["title"], out.span))
    else:
        out["title"] = LocStr(
            f"{data['title']} ({instance.name})", span_of(data["title"], out.span)
        )
    _constants(out, instance)
    return out


def _walk(
    node: Any,
    path: tuple[str, ...],
    expression: Callable[[str], str],
    subs: dict[str, str],
    instance: Instance,
) -> Any:
    """`node` at `path` in a controller's data, its references renamed by context."""
    if isinstance(node, str):
        if path and (path[-1] in _TEXT_KEYS or "allow" in path):
            return node
        if path[:1] == ("subordinates",):
            return LocStr(subs.get(node, node), span_of(node, Span("?")))
        if path[:2] in (("world", "reads"), ("world", "writes")):
            return LocStr(instance.fields.get(node, node), span_of(node, Span("?")))
        new = expression(node)
        return node if new == node else LocStr(new, span_of(node, Span("?")))
    if isinstance(node, LocDict):
        out = LocDict(node.span)
        for key, value in node.items():
            if path[-1:] in (("echo_timeouts",), ("on_lost",)):
                new_key: Any = LocStr(subs.get(key, key), node.key_spans.get(key, node.span))
            elif path[-1:] in (("constants",), ("locals",), ("functions",), ("hooks",)):
                new_key = key
            else:
                new_key = _walk(key, (*path, "<key>"), expression, subs, instance)
            out[new_key] = _walk(value, (*path, str(key)), expression, subs, instance)
            out.key_spans[new_key] = node.key_spans.get(key, node.span)
            out.value_spans[new_key] = node.value_spans.get(key, node.span)
        return out
    if isinstance(node, LocList):
        items = LocList(node.span)
        for i, item in enumerate(node):
            items.append(_walk(item, path, expression, subs, instance))
            items.item_spans.append(node.item_spans[i] if i < len(node.item_spans) else node.span)
        return items
    return node


def _copy(node: Any, text: Callable[[str], str]) -> Any:
    """A deep copy of loaded data, keeping every span (fragments expand a copy in place)."""
    if isinstance(node, LocStr):
        return LocStr(text(str(node)), node.span)
    if isinstance(node, LocDict):
        out = LocDict(node.span)
        for key, value in node.items():
            out[key] = _copy(value, text)
        out.key_spans, out.value_spans = dict(node.key_spans), dict(node.value_spans)
        return out
    if isinstance(node, LocList):
        items = LocList(node.span)
        items.extend(_copy(item, text) for item in node)
        items.item_spans = list(node.item_spans)
        return items
    return node


def _constants(data: LocDict, instance: Instance) -> None:
    """The template's constants a controller reads become its own, with the instance's
    values (only those it names, so that no controller carries one it never reads)."""
    if not instance.constants:
        return
    words = set(re.findall(r"[A-Z][A-Z0-9_]*", " ".join(_strings(data))))
    wanted = [k for k in instance.constants if k in words]
    if not wanted:
        return
    constants = data.get("constants")
    if not isinstance(constants, LocDict):
        constants = LocDict(data.span)
        data["constants"] = constants
    for key in wanted:
        value, at = instance.constants[key]
        name = LocStr(key, at)
        constants[name] = value
        constants.key_spans[name] = constants.value_spans[name] = at


def _strings(node: Any) -> Iterator[str]:
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for key, value in node.items():
            yield key
            yield from _strings(value)
    elif isinstance(node, list):
        for item in node:
            yield from _strings(item)


# ---------------------------------------------------------------- diagnostics


def annotate(diags: Diagnostics, made: list[Instance], first: int) -> None:
    """Diagnostics (from index `first`) found in a template's text also name the instance
    they were found in (by the controller they are about, else a module name they quote)."""
    if not made:
        return
    shown = {i.template.name for i in made}
    for i in range(first, len(diags.items)):
        diags.items[i] = _with_instance(diags.items[i], made, shown)
    for i, found in enumerate(diags.acknowledged):
        diags.acknowledged[i] = _with_instance(found, made, shown)


def _with_instance(found: Diagnostic, made: list[Instance], templates: set[str]) -> Diagnostic:
    parts = Path(found.span.file).parts
    if len(parts) < 2 or parts[-2] not in templates:
        return found
    subject = found.subject.controller if found.subject is not None else None
    mine = [i for i in made if subject in i.modules.values()]
    if not mine:
        mine = [
            i
            for i in made
            if any(re.search(rf"`{m}[.`]", found.message) for m in i.modules.values())
        ]
    if not mine:
        return found
    note = ", ".join(f"instance `{i.name}` ({i.span})" for i in mine[:3])
    note = f"in {note} of template `{mine[0].template.name}`"
    return replace(found, hint=f"{found.hint} ({note})" if found.hint else note)
