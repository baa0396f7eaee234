"""Properties: the engineer's own `properties:` (system and controller files) -> IRProperty.

A property is read in one supervisor's view: the supervisor's state, command and status,
each direct subordinate's status (as the supervisor reads it) and last command, the
commands sent in a cycle, what a rule that fired writes, and whether an actuator the
supervisor writes is at its safe value (docs/spec.md section 19). That is what its model
in `rcsgen prove` holds, so each property is checked there, compositionally. A property
in a controller file is about that controller; one in the system file about the one
supervisor whose view covers every module it names (a property over modules no single
supervisor sees is global: not checked compositionally, refused with E711).

Written in the tables' expression syntax (`and`, `or`, `not`, `==`, `!=`, parentheses),
over these atoms only: world values, locals and parameters are free in the model, so a
comparison of them could not be decided and is refused (E713) rather than half-checked.
"""

from __future__ import annotations

import ast
import re

from ...runtime.contract import NO_COMMAND_NAME
from ..diagnostics import Diagnostics, Span, counted, did_you_mean
from ..expressions.nodes import STATUS_NAMES
from ..expressions.resolve import _parse, char_at
from ..front_end.model import ControllerSpec, Located, SystemSpec, UserProperty
from ..ir import IRPropAtom, IRProperty, IRPropExpr, PropKind

MAX_WITHIN = 100  # cycles: the longest response a property may give its supervisor
NO_STATE = "NOP"  # `<module>.state == NOP`: no table running (after a report)
_FIELDS = {"state": PropKind.STATE, "command": PropKind.COMMAND, "status": PropKind.STATUS}


_START = ast.Name("", lineno=1, col_offset=0)  # an error at the property itself


class _Fail(Exception):
    """Internal: stop at a property's first error."""


class _Names:
    """What the controllers of one system declare, as properties may name it."""

    def __init__(self, system: SystemSpec, controllers: list[ControllerSpec]) -> None:
        self.specs = {c.name: c for c in controllers}
        self.world = system.world

    def aliases(self, owner: str | None) -> dict[str, str]:
        """An instance's controllers by their names in its template, for a property
        written in one of its template's files."""
        mine = self.specs[owner].instance if owner else None
        if mine is None:
            return {}
        return {
            c.instance.member: c.name
            for c in self.specs.values()
            if c.instance is not None and c.instance.instance == mine.instance
        }

    def subs(self, name: str) -> list[str]:
        return [str(s.value) for s in self.specs[name].subordinates]

    def commands(self, name: str) -> list[str]:
        return list(self.specs[name].commands)

    def states(self, name: str) -> list[str]:
        return sorted({s for cmd in self.specs[name].commands.values() for s in cmd.states})


class _Reader:
    """One expression of a property -> IRPropExpr, the modules it names collected."""

    def __init__(
        self, names: _Names, span: Span, diags: Diagnostics, alias: dict[str, str] | None = None
    ) -> None:
        self.names, self.span, self.diags = names, span, diags
        self.source: object = None  # the expression read, as loaded (`char_at`)
        self.alias = alias or {}  # a template's names -> its instance's (section 18)
        self.modules: dict[str, Span] = {}  # module named -> where
        self.own: dict[str, Span] = {}  # modules whose `.state` is read (must be the scope)
        self.subs: dict[str, Span] = {}  # modules sent to (must be subordinates)
        self.local: list[tuple[IRPropAtom, Span]] = []  # writes()/safe(): the scope's

    def at(self, node: ast.AST) -> Span:
        return char_at(self.source, self.span, getattr(node, "col_offset", 0))

    def fail(self, node: ast.AST, code: str, message: str, hint: str = "") -> _Fail:
        self.diags.error(self.at(node), code, message, hint)
        return _Fail()

    def expr(self, node: ast.AST) -> IRPropExpr:
        if isinstance(node, ast.BoolOp):
            op = "and" if isinstance(node.op, ast.And) else "or"
            return IRPropExpr(op, None, tuple(self.expr(v) for v in node.values))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            return IRPropExpr("not", None, (self.expr(node.operand),))
        if isinstance(node, ast.Constant) and isinstance(node.value, bool):
            return IRPropExpr("true" if node.value else "false")
        if isinstance(node, ast.Compare):
            return self.compare(node)
        if isinstance(node, ast.Call):
            return IRPropExpr("atom", self.call(node))
        raise self.fail(
            node,
            "E713",
            "a property reads only `<module>.state|command|status == <NAME>`, "
            "`sent(<sub>.<COMMAND>)`, `writes(<name>)` and `safe(world.<actuator>)`",
            "combine them with and, or, not and parentheses; world values, locals and "
            "numbers are free in the model and cannot be compared in a property",
        )

    def compare(self, node: ast.Compare) -> IRPropExpr:
        for side in (node.left, *node.comparators):
            if isinstance(side, ast.Attribute) and isinstance(side.value, ast.Name):
                if side.value.id == "world":
                    raise self.fail(
                        side,
                        "E713",
                        f"`world.{side.attr}` is free in the model: a property cannot compare it",
                        f"state an actuator's safe value as `safe(world.{side.attr})`",
                    )
        if len(node.ops) != 1 or not isinstance(node.ops[0], ast.Eq | ast.NotEq):
            raise self.fail(node, "E713", "a property compares with `==` or `!=`, one at a time")
        left, right = node.left, node.comparators[0]
        if isinstance(left, ast.Name) and isinstance(right, ast.Attribute):
            left, right = right, left
        if not isinstance(left, ast.Attribute) or not isinstance(right, ast.Name):
            raise self.fail(
                node,
                "E713",
                "a property compares `<module>.state`, `.command` or `.status` with a name",
                "for example `cr.status == ERROR` or `helm.state == S2`",
            )
        atom = self.field(left, right)
        found = IRPropExpr("atom", atom)
        return IRPropExpr("not", None, (found,)) if isinstance(node.ops[0], ast.NotEq) else found

    def field(self, node: ast.Attribute, value: ast.Name) -> IRPropAtom:
        if not isinstance(node.value, ast.Name):
            raise self.fail(node, "E713", "a property reads `<module>.<field>`, not a deeper name")
        module, attr = self.alias.get(node.value.id, node.value.id), node.attr
        self.module(node.value, module)
        if attr not in _FIELDS:
            raise self.fail(
                node,
                "E710",
                f"`{module}.{attr}`: a property reads a module's state, command or status",
                did_you_mean(attr, _FIELDS),
            )
        if attr == "state":
            self.own.setdefault(module, self.at(node))
        allowed = {
            "state": [*self.names.states(module), NO_STATE],
            "command": [*self.names.commands(module), NO_COMMAND_NAME],  # nothing sent yet
            "status": list(STATUS_NAMES),
        }[attr]
        if value.id not in allowed:
            raise self.fail(
                value,
                "E710",
                f"`{value.id}` is no {attr} of {module}",
                did_you_mean(value.id, allowed) or f"one of: {', '.join(allowed)}",
            )
        return IRPropAtom(_FIELDS[attr], module, value.id)

    def module(self, node: ast.Name, name: str) -> None:
        if name not in self.names.specs:
            raise self.fail(
                node,
                "E710",
                f"`{name}` is no module of this system",
                did_you_mean(name, self.names.specs),
            )
        self.modules.setdefault(name, self.at(node))

    def call(self, node: ast.Call) -> IRPropAtom:
        name = node.func.id if isinstance(node.func, ast.Name) else ""
        if name not in ("sent", "writes", "safe") or len(node.args) != 1 or node.keywords:
            raise self.fail(
                node,
                "E713",
                "a property calls only `sent(<sub>.<COMMAND>)`, `writes(<name>)` and "
                "`safe(world.<actuator>)`, each with one argument",
            )
        arg = node.args[0]
        if name == "writes" and isinstance(arg, ast.Name):
            atom = IRPropAtom(PropKind.WRITES, "", arg.id)
            self.local.append((atom, self.at(arg)))
            return atom
        if not isinstance(arg, ast.Attribute) or not isinstance(arg.value, ast.Name):
            raise self.fail(arg, "E713", f"`{name}(...)` takes a dotted name")
        owner, attr = self.alias.get(arg.value.id, arg.value.id), arg.attr
        if name == "sent":
            self.module(arg.value, owner)
            self.subs.setdefault(owner, self.at(arg))
            commands = self.names.commands(owner)
            if attr not in commands:
                raise self.fail(
                    arg,
                    "E710",
                    f"`{attr}` is no command of {owner}",
                    did_you_mean(attr, commands) or f"one of: {', '.join(commands)}",
                )
            return IRPropAtom(PropKind.SENT, owner, attr)
        if owner != "world" or attr not in self.names.world:
            raise self.fail(
                arg,
                "E710",
                f"`{owner}.{attr}` is no world field",
                did_you_mean(attr, self.names.world) if owner == "world" else "",
            )
        if name == "safe" and not self.names.world[attr].actuator:
            raise self.fail(arg, "E713", f"`world.{attr}` is no actuator: it has no safe value")
        atom = IRPropAtom(PropKind.SAFE if name == "safe" else PropKind.WRITES, "", f"world.{attr}")
        self.local.append((atom, self.at(arg)))
        return atom


def _scope(reader: _Reader, owner: str | None, span: Span) -> str:
    """The supervisor a property is checked at: `owner` (its controller file), else the
    one controller whose view covers every module named (E711 when none does)."""
    names = reader.names
    named = set(reader.modules)
    fits = _fits(reader, owner)
    if not fits or (owner is None and len(fits) > 1):
        where = f"{owner} and its direct subordinates" if owner else "one supervisor"
        shown = ", ".join(sorted(named)) or "no module"
        raise reader.fail(
            _START,
            "E711",
            f"this property names {shown}: not in the view of {where}; a property over "
            "modules no single supervisor sees is global, and `rcsgen prove` checks "
            "properties compositionally",
            "state it over one supervisor (its state, command, status) and its direct "
            "subordinates (their status and command, what it sends them)",
        )
    scope = fits[0]
    for atom, at in reader.local:
        _local(reader, names.specs[scope], atom, at)
    return scope


def _fits(reader: _Reader, owner: str | None) -> list[str]:
    """The supervisors whose view covers what the property names (the named one first
    chosen among several: `rudder.status` alone is rudder's own, not helm's view of it)."""
    names, named = reader.names, set(reader.modules)
    candidates = [owner] if owner else [c for c in names.specs if not names.specs[c].is_operator]
    fits = [
        c
        for c in candidates
        if named <= {c, *names.subs(c)}
        and set(reader.own) <= {c}
        and set(reader.subs) <= set(names.subs(c))
        and (named or owner)
    ]
    if owner is None and len(fits) > 1:
        fits = [c for c in fits if c in named] or fits
    return fits


def _local(reader: _Reader, spec: ControllerSpec, atom: IRPropAtom, at: Span) -> None:
    """`writes(x)`: a local of the supervisor or a world field it writes; `safe(world.x)`:
    an actuator it writes (E710 otherwise)."""
    writes = {str(w.value) for w in spec.world_writes}
    if atom.value.startswith("world."):
        ok = atom.value.removeprefix("world.") in writes
        what = f"`{atom.value}` is not written by {spec.name}"
    else:
        ok = atom.value in spec.locals
        what = f"`{atom.value}` is no local of {spec.name}"
    if not ok:
        reader.diags.error(at, "E710", what, "a property reads what its supervisor writes")
        raise _Fail()


def _expression(reader: _Reader, raw: Located) -> IRPropExpr:
    reader.span, reader.source = char_at(raw.value, raw.span, 0), raw.value
    if not isinstance(raw.value, str | bool):
        raise reader.fail(_START, "E713", "a property is a condition")
    tree = _parse(raw.value, reader.span, reader.diags)
    if tree is None:
        raise _Fail()
    return reader.expr(tree.body)


def _within(prop: UserProperty, diags: Diagnostics) -> int:
    if prop.within is None:
        return 0
    value = prop.within.value
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_WITHIN:
        diags.error(
            prop.within.span,
            "E712",
            f"`within: {value}`: a response is due within 0 to {MAX_WITHIN} cycles",
            "0: in the same cycle as the trigger; longer waits are a time-out's job",
        )
        raise _Fail()
    return value


def _one(
    names: _Names, prop: UserProperty, owner: str | None, diags: Diagnostics
) -> IRProperty | None:
    reader = _Reader(names, prop.span, diags, names.aliases(owner))
    try:
        within = _within(prop, diags)
        if prop.always is not None:
            then, whenever = _expression(reader, prop.always), None
            text = f"always {prop.always.value}"
        else:
            assert prop.whenever is not None and prop.then is not None  # the schema's
            whenever = _expression(reader, prop.whenever)
            then = _expression(reader, prop.then)
            text = f"whenever {prop.whenever.value}, " + (
                f"within {counted(within, 'cycle')} {prop.then.value}"
                if within
                else f"in the same cycle {prop.then.value}"
            )
        reader.span, reader.source = prop.span, None
        scope = _scope(reader, owner, prop.span)
    except _Fail:
        return None
    return IRProperty(
        str(prop.name.value),
        scope,
        prop.name.span,
        _named(" ".join(text.split()), names.aliases(owner)),
        _at(then, scope),
        _at(whenever, scope) if whenever is not None else None,
        within,
        prop.doc,
    )


def _named(text: str, aliases: dict[str, str]) -> str:
    """A template's property text with each of its modules (`loco.status`) named as the
    instance's (`alpha_loco.status`): a report names the controller that broke it."""
    if not aliases:
        return text
    return re.sub(r"\b(\w+)(?=\.)", lambda m: aliases.get(m.group(1), m.group(1)), text)


_OF_SUB = {PropKind.STATUS: PropKind.SUB_STATUS, PropKind.COMMAND: PropKind.SUB_COMMAND}


def _at(e: IRPropExpr, scope: str) -> IRPropExpr:
    """`e` with each status and command of a module other than `scope` read as a
    subordinate's (what the supervisor reads of it, the last command it sent it)."""
    atom = e.atom
    if atom is not None and atom.module not in ("", scope) and atom.kind in _OF_SUB:
        atom = IRPropAtom(_OF_SUB[atom.kind], atom.module, atom.value)
    return IRPropExpr(e.op, atom, tuple(_at(x, scope) for x in e.args))


def check_properties(
    system: SystemSpec, controllers: list[ControllerSpec], diags: Diagnostics
) -> tuple[IRProperty, ...]:
    """Every property of a system's files, resolved; located errors for the bad ones."""
    names = _Names(system, controllers)
    found: list[IRProperty] = []
    seen: dict[str, Span] = {}
    owned: list[tuple[UserProperty, str | None]] = [(p, None) for p in system.properties]
    owned += [(p, c.name) for c in controllers for p in c.properties]
    for prop, owner in owned:
        name = str(prop.name.value)
        if name in seen and seen[name] != prop.name.span:  # not an instance's copy
            diags.error(
                prop.name.span,
                "E714",
                f"two properties are named `{name}`",
                f"the other is at {seen[name]}; a counter-example is named after its property",
            )
            continue
        seen[name] = prop.name.span
        made = _one(names, prop, owner, diags)
        if made is not None:
            found.append(made)
    return tuple(found)
