"""Fragments: loaded controller data and shared fragments -> the data with each `use:` expanded.

A fragment is a named, parameterised piece of state table (docs/spec.md section 14),
declared under `fragments:` in a controller or in the spec directory's `fragments.yaml`.
A command's state written `{use: NAME, with: {param: value}}` becomes the fragment's states:
the first takes the using state's name, each other one `<USING>_<NAME>`; `$param` in any
string of the fragment is replaced by its value. A fragment's state may itself use another
fragment (not itself, directly or through others: E298). The expansion runs before the schema, so
every later stage sees an ordinary table; the expanded nodes keep the spans of the
fragment's text, and `annotate` adds the use's place to a diagnostic found there.
Diagnostics: E265 unknown fragment, E266 wrong arguments, E267 undeclared `$param`,
E268 expanded state name already used, E269 malformed fragment or use, E270 fragment
declared twice, E298 fragments that use each other in a cycle, W305 fragment never used,
E912 a list of actions given or used where it does not go.

A parameter may also take a list of actions (`with: {on_done: [{send: ...}, {report: DONE}]}`):
the fragment splices it where it writes `$on_done` as an item of a rule's `do:` list, or as
the whole `do:` (`do: $on_done`), and may pass it on whole to a fragment it uses.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Any

from ..diagnostics import Diagnostic, Diagnostics, Span, known_names_hint
from .loader import LocDict, LocList, LocStr, key_span, span_of, value_span

FILE = "fragments.yaml"
# `$name`, or `${name}` where a name goes on: `world.${node}_asking`.
PLACEHOLDER = re.compile(r"\$(?:\{([A-Za-z_][A-Za-z0-9_]*)\}|([A-Za-z_][A-Za-z0-9_]*))")
_PARAM = re.compile(r"[a-z][a-z0-9_]*")
_FRAGMENT = re.compile(r"[a-z][a-z0-9_]*")
_STATE = re.compile(r"[A-Z][A-Z0-9_]*")
_FRAGMENT_KEYS = ("doc", "params", "first_match", "states")
_USE_KEYS = ("use", "with")


@dataclass(frozen=True)
class Fragment:
    """A fragment as declared: its parameters and its states (loaded data, not yet checked)."""

    name: str
    span: Span  # its name where it is declared
    params: tuple[str, ...]
    states: LocDict
    first_match: tuple[str, ...]
    last_line: int  # the last line of its text, to place diagnostics found in it


@dataclass(frozen=True)
class Use:
    """Where a command's state uses a fragment."""

    fragment: Fragment
    span: Span  # the fragment's name after `use:`
    controller: str
    command: str
    state: str
    states: tuple[str, ...]  # the state names it became


def _walk_strings(node: object) -> Iterator[str]:
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for key, value in node.items():
            yield key
            yield from _walk_strings(value)
    elif isinstance(node, list):
        for item in node:
            yield from _walk_strings(item)


def _last_line(node: object, line: int) -> int:
    last = max(line, getattr(getattr(node, "span", None), "line", line))
    if isinstance(node, dict):
        for key, value in node.items():
            last = max(last, _last_line(key, last), _last_line(value, last))
    elif isinstance(node, list):
        for item in node:
            last = max(last, _last_line(item, last))
    return last


def read(data: object, where: Span, diags: Diagnostics) -> dict[str, Fragment | None]:
    """The fragments a `fragments:` mapping declares (checked for shape: E269, E267); a
    fragment found wrong maps to None, so that its uses say nothing more."""
    out: dict[str, Fragment | None] = {}
    if not isinstance(data, dict):
        diags.error(span_of(data, where), "E269", "`fragments` must be a mapping: name -> fragment")
        return out
    for name, body in data.items():
        at = key_span(data, name, where)
        if not _FRAGMENT.fullmatch(name):
            diags.error(at, "E269", f"fragment name `{name}` is not a lower_case identifier")
            continue
        out[name] = None  # until it is found whole
        if not isinstance(body, dict) or not isinstance(body.get("states"), dict):
            diags.error(
                at, "E269", f"fragment `{name}` needs `states:`, a mapping of state -> rules"
            )
            continue
        unknown = [k for k in body if k not in _FRAGMENT_KEYS]
        if unknown:
            diags.error(
                key_span(body, unknown[0], at),
                "E269",
                f"fragment `{name}` has an unknown key `{unknown[0]}`",
                known_names_hint("keys", _FRAGMENT_KEYS, unknown[0]),
            )
            continue
        params = body.get("params", [])
        if not isinstance(params, list) or not all(
            isinstance(p, str) and _PARAM.fullmatch(p) for p in params
        ):
            diags.error(
                value_span(body, "params", at),
                "E269",
                f"fragment `{name}`'s `params` must be a list of lower_case names",
            )
            continue
        states = body["states"]
        bad = [
            s
            for s, rules in states.items()
            if not _STATE.fullmatch(s) or not (isinstance(rules, list) or _is_use(rules))
        ]
        if not states or bad:
            diags.error(
                key_span(states, bad[0], at) if bad else at,
                "E269",
                f"fragment `{name}`'s states must be UPPER_CASE names, each with a list of "
                "rules or a use of another fragment",
            )
            continue
        first_match = body.get("first_match", [])
        if not isinstance(first_match, list) or any(s not in states for s in first_match):
            odd = (
                next((s for s in first_match if s not in states), "")
                if isinstance(first_match, list)
                else ""
            )
            diags.error(
                value_span(body, "first_match", at),
                "E269",
                f"fragment `{name}`'s `first_match` must list its own states",
                known_names_hint("states", states, str(odd)),
            )
            continue
        ok = True
        for text in _walk_strings(states):
            for found in PLACEHOLDER.finditer(text):
                param = _param(found)
                if param not in params:
                    ok = False
                    diags.error(
                        span_of(text, at),
                        "E267",
                        f"`{found.group(0)}` is not a parameter of fragment `{name}`",
                        known_names_hint("parameters", params, param),
                    )
        if ok:
            out[name] = Fragment(
                name, at, tuple(params), states, tuple(first_match), _last_line(body, at.line)
            )
    return out


def _param(found: re.Match[str]) -> str:
    return found.group(1) or found.group(2)


def _value_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def _copy(node: Any, values: dict[str, Any], names: dict[str, str]) -> Any:
    """`node` with `$param` replaced (keeping its spans) and `next:` renamed by `names`."""
    if isinstance(node, str):
        whole = PLACEHOLDER.fullmatch(node)
        if whole and not isinstance(values[_param(whole)], str):
            return _clone(values[_param(whole)])  # a number, bool or list keeps its type
        text = PLACEHOLDER.sub(lambda m: _value_text(values[_param(m)]), node)
        return LocStr(text, node.span) if isinstance(node, LocStr) else text
    if isinstance(node, LocDict):
        out = LocDict(node.span)
        for key, value in node.items():
            new_key = _copy(key, values, names)
            new = _copy(value, values, names)
            if key == "next" and isinstance(new, str) and new in names:
                new = LocStr(names[new], span_of(new, node.span))
            out[new_key] = new
            out.key_spans[new_key] = node.key_spans.get(key, node.span)
            out.value_spans[new_key] = node.value_spans.get(key, node.span)
        return out
    if isinstance(node, LocList):
        items = LocList(node.span)
        for i, item in enumerate(node):
            new = _copy(item, values, names)
            if isinstance(item, str) and isinstance(new, LocList):  # `- $actions`: spliced in
                for j, action in enumerate(new):
                    items.append(action)
                    items.item_spans.append(span_of(action, new.item_spans[j]))
                continue
            items.append(new)
            items.item_spans.append(node.item_spans[i] if i < len(node.item_spans) else node.span)
        return items
    return node


def _clone(node: Any) -> Any:
    """A copy of loaded data, spans kept (a list of actions given to a use, copied into each
    place the fragment splices it, so that no two places share one node)."""
    if isinstance(node, LocDict):
        out = LocDict(node.span)
        for key, value in node.items():
            out[key] = _clone(value)
            out.key_spans[key] = node.key_spans.get(key, node.span)
            out.value_spans[key] = node.value_spans.get(key, node.span)
        return out
    if isinstance(node, LocList):
        items = LocList(node.span)
        items.extend(_clone(item) for item in node)
        items.item_spans = list(node.item_spans)
        return items
    return node


# Where a fragment writes a parameter: as actions (an item of a `do:` list, or the whole
# `do:`), passed on whole to a fragment it uses, or in text (anything else).
ACTIONS, PASSED, TEXT = "actions", "passed", "text"


def positions(node: object, inside: str = "") -> Iterator[tuple[str, str, object]]:
    """(parameter, where it is written, the string) for each `$param` in a fragment's
    states. `inside`: `do` for the value of a rule's `do:` and the items of its list."""
    if isinstance(node, str):
        whole = PLACEHOLDER.fullmatch(node)
        if whole and inside == "do":
            yield _param(whole), ACTIONS, node
            return
        for found in PLACEHOLDER.finditer(node):
            yield _param(found), TEXT, node
    elif isinstance(node, dict):
        for key, value in node.items():
            yield from positions(key)
            if _is_use(node) and key == "with" and isinstance(value, dict):
                for given in value.values():  # a use within the fragment: passed on whole
                    whole = PLACEHOLDER.fullmatch(given) if isinstance(given, str) else None
                    if whole:
                        yield _param(whole), PASSED, given
                    else:
                        yield from positions(given)
                continue
            yield from positions(value, "do" if key == "do" else "")
    elif isinstance(node, list):
        for item in node:
            yield from positions(item, inside)


def _arguments(
    use: dict[str, Any], fragment: Fragment, at: Span, diags: Diagnostics
) -> dict[str, Any] | None:
    given = use.get("with", {})
    if not isinstance(given, dict):
        diags.error(value_span(use, "with", at), "E269", "`with` must be a mapping: param -> value")
        return None
    where = f"fragment `{fragment.name}` (declared at {fragment.span})"
    for name in given:
        if name not in fragment.params:
            diags.error(
                key_span(given, name, at),
                "E266",
                f"`{name}` is not a parameter of {where}",
                known_names_hint("parameters", fragment.params, name),
            )
            return None
    missing = [p for p in fragment.params if p not in given]
    if missing:
        diags.error(
            at,
            "E266",
            f"the use of {where} gives no value for `{missing[0]}`",
            f"add `{missing[0]}: ...` to `with:`",
        )
        return None
    bad = [n for n, v in given.items() if not isinstance(v, str | int | float | bool | list)]
    if bad:
        diags.error(
            value_span(given, bad[0], at),
            "E269",
            f"the value of `{bad[0]}` must be a name, an expression, a number or a list of actions",
        )
        return None
    if not _action_lists_fit(given, fragment, at, diags):
        return None
    return dict(given)


def _action_lists_fit(
    given: dict[str, Any], fragment: Fragment, at: Span, diags: Diagnostics
) -> bool:
    """A list of actions goes only where the fragment writes actions (or passes the value
    on), and where it writes actions it needs a list of mappings (E912)."""
    found: dict[tuple[str, str], object] = {}
    for param, where, text in positions(fragment.states):
        found.setdefault((param, where), text)
    for name, value in given.items():
        span = value_span(given, name, at)
        if isinstance(value, list):
            text = found.get((name, TEXT))
            if text is not None:
                diags.error(
                    span,
                    "E912",
                    f"`{name}` is a list of actions, but fragment `{fragment.name}` writes "
                    f"`${name}` in text at {span_of(text, fragment.span)}",
                    "give a name, an expression or a number, or splice it as `- $"
                    + name
                    + "` in a `do:` list",
                )
                return False
            odd = next((a for a in value if not isinstance(a, dict)), None)
            if odd is not None or not value:
                diags.error(
                    span_of(odd, span) if odd is not None else span,
                    "E912",
                    f"`{name}` must be a list of actions (`{{send: ...}}`, `{{set: ...}}`, ...)"
                    + (f"; `{odd}` is not one" if odd is not None else ", not empty"),
                    "write each action as a mapping, as in a rule's `do:`",
                )
                return False
        elif (name, ACTIONS) in found:
            text = found[(name, ACTIONS)]
            diags.error(
                span,
                "E912",
                f"fragment `{fragment.name}` puts `${name}` where actions go (at "
                f"{span_of(text, fragment.span)}): `{name}` needs a list of actions",
                f"write `{name}: [{{send: ...}}, ...]`",
            )
            return False
    return True


def named(data: object) -> set[str]:
    """The fragment names `data`'s commands use (whether or not the use is right)."""
    commands = data.get("commands") if isinstance(data, dict) else None
    out: set[str] = set()
    for body in commands.values() if isinstance(commands, dict) else ():
        states = body.get("states") if isinstance(body, dict) else None
        for rules in states.values() if isinstance(states, dict) else ():
            if _is_use(rules) and isinstance(rules["use"], str):
                out.add(rules["use"])
    return out


def report_unused(declared: dict[str, Fragment | None], used: set[str], diags: Diagnostics) -> None:
    """W305 for each fragment (found whole) that no use names."""
    for fragment in declared.values():
        if fragment is not None and fragment.name not in used:
            diags.warning(
                fragment.span,
                "W305",
                f"fragment `{fragment.name}` is declared but no command uses it",
                "use it in a state (`{use: NAME, with: {...}}`) or remove it",
            )


def expand(
    data: object, shared: dict[str, Fragment | None], diags: Diagnostics, where: Span
) -> tuple[list[Use], bool]:
    """Replace each `{use: ...}` state of `data`'s commands in place: the uses made, and
    whether every use could be expanded (when not, a diagnostic says why)."""
    if not isinstance(data, LocDict):
        return [], True
    own: dict[str, Fragment | None] = {}
    used = named(data)
    before = len(diags.errors)
    uses, whole = _expand(data, own, shared, diags, where)
    used |= {u.fragment.name for u in uses}  # (a use inside a used fragment counts)
    if whole and len(diags.errors) == before:  # (a misspelt use would make it noise)
        report_unused(own, used, diags)
    return uses, whole


def _expand(
    data: LocDict,
    own: dict[str, Fragment | None],
    shared: dict[str, Fragment | None],
    diags: Diagnostics,
    where: Span,
) -> tuple[list[Use], bool]:
    whole = True
    if "fragments" in data:
        own.update(read(data["fragments"], key_span(data, "fragments", where), diags))
        for name, fragment in own.items():
            if name in shared and fragment is not None:
                theirs = shared[name]
                diags.error(
                    fragment.span,
                    "E270",
                    f"fragment `{name}` is declared here and in {FILE}"
                    + (f" ({theirs.span})" if theirs else ""),
                    "rename one: a controller's fragment may not hide a shared one",
                )
        del data["fragments"]
    known = {**shared, **own}
    controller = str(data.get("controller", ""))
    uses: list[Use] = []
    commands = data.get("commands")
    if not isinstance(commands, dict):
        return uses, whole
    for command, body in commands.items():
        states = body.get("states") if isinstance(body, dict) else None
        if not isinstance(states, LocDict):
            continue
        if not any(_is_use(v) for v in states.values()):
            continue  # (a state that is a mapping without `use` is the schema's to report)
        out = LocDict(states.span)
        added_first: list[str] = []
        for state, rules in states.items():
            if not _is_use(rules):
                out[state] = rules
                out.key_spans[state] = states.key_spans.get(state, states.span)
                out.value_spans[state] = states.value_spans.get(state, states.span)
                continue
            made = _use(rules, state, states, known, diags, where, ())
            if made is None:
                whole = False
                continue
            fragment, at, expanded, first, inner = made
            for name, table in expanded.items():
                if name in out or (name != state and name in states):
                    diags.error(
                        at,
                        "E268",
                        f"fragment `{fragment.name}` used in `{state}` makes state `{name}`, "
                        f"which `{command}` already has",
                        "rename the using state or the other one",
                    )
                    whole = False
                    continue
                span = states.key_spans.get(state, at) if name == state else at
                key = LocStr(name, span)
                out[key] = table
                out.key_spans[key] = span
                out.value_spans[key] = at
            added_first += first
            uses.append(Use(fragment, at, controller, str(command), str(state), tuple(expanded)))
            uses += [replace(u, controller=controller, command=str(command)) for u in inner]
        body["states"] = out
        if added_first:
            listed = body.get("first_match")
            merged = LocList(span_of(listed, states.span))
            for s in (list(listed) if isinstance(listed, list) else []) + added_first:
                if s not in merged:
                    merged.append(s)
                    merged.item_spans.append(merged.span)
            body["first_match"] = merged
    return uses, whole


def _is_use(rules: object) -> bool:
    return isinstance(rules, dict) and "use" in rules


_NESTING = 8  # fragments within fragments: deeper is surely a mistake


def _use(
    use: dict[str, Any],
    state: str,
    states: LocDict,
    known: dict[str, Fragment | None],
    diags: Diagnostics,
    where: Span,
    within: tuple[Fragment, ...],
) -> tuple[Fragment, Span, dict[str, Any], list[str], list[Use]] | None:
    """One state's use expanded: (fragment, the use's span, new state name -> rules, the
    new states that are first_match, the uses nested in it). `within`: the fragments
    being expanded around this use, outermost first."""
    at = value_span(states, state, where)
    unknown = [k for k in use if k not in _USE_KEYS]
    if unknown:
        diags.error(
            key_span(use, unknown[0], at),
            "E269",
            f"a use of a fragment is `{{use: FRAGMENT, with: {{...}}}}`, without `{unknown[0]}`",
            known_names_hint("keys", _USE_KEYS, unknown[0]),
        )
        return None
    name = use["use"]
    at = value_span(use, "use", at)
    if not isinstance(name, str) or name not in known:
        diags.error(
            at,
            "E265",
            f"no fragment `{name}` is declared",
            known_names_hint("fragments", known, str(name))
            if known
            else f"declare it under `fragments:` in this file or in {FILE}",
        )
        return None
    fragment = known[name]
    if fragment is None:
        return None  # what is wrong with it is reported where it is declared
    if fragment in within or len(within) >= _NESTING:
        chain = " -> ".join(f.name for f in (*within, fragment))
        diags.error(
            at,
            "E298",
            f"fragment `{fragment.name}` is used within itself ({chain})"
            if fragment in within
            else f"fragments nested more than {_NESTING} deep ({chain})",
            "a fragment may use other fragments, but not itself, directly or through others",
        )
        return None
    values = _arguments(use, fragment, at, diags)
    if values is None:
        return None
    names = {s: (state if i == 0 else f"{state}_{s}") for i, s in enumerate(fragment.states)}
    expanded: dict[str, Any] = {}
    first = [names[s] for s in fragment.first_match]
    inner: list[Use] = []
    for s, rules in fragment.states.items():
        if not _is_use(rules):
            expanded[names[s]] = _copy(rules, values, names)
            continue
        # A use within the fragment: its values are this use's, and a value naming one of
        # this fragment's states means that state as expanded here.
        nested = _copy(rules, values, names)
        given = nested.get("with")
        if isinstance(given, dict):
            for key, value in given.items():
                if isinstance(value, str) and value in names:
                    given[key] = LocStr(names[value], span_of(value, at))
        holder = LocDict(fragment.states.span)
        holder[names[s]] = nested
        holder.value_spans[names[s]] = fragment.states.value_spans.get(s, fragment.span)
        made = _use(nested, names[s], holder, known, diags, where, (*within, fragment))
        if made is None:
            return None
        inner_fragment, inner_at, inner_states, inner_first, deeper = made
        clash = [n for n in inner_states if n in expanded or n in names.values() and n != names[s]]
        if clash:
            diags.error(
                inner_at,
                "E268",
                f"fragment `{inner_fragment.name}` used in `{fragment.name}`'s `{s}` makes "
                f"state `{clash[0]}`, which the expansion of `{fragment.name}` already has",
                "rename a state of one of the fragments",
            )
            return None
        expanded.update(inner_states)
        first += inner_first
        inner.append(Use(inner_fragment, inner_at, "", "", names[s], tuple(inner_states)))
        inner += deeper
    return fragment, at, expanded, first, inner


def annotate(diags: Diagnostics, uses: list[Use], first: int) -> None:
    """Diagnostics (from index `first`) found in a fragment's text also name its uses."""
    if not uses:
        return
    for i in range(first, len(diags.items)):
        found = diags.items[i]
        diags.items[i] = _with_uses(found, uses)
    for i, found in enumerate(diags.acknowledged):
        diags.acknowledged[i] = _with_uses(found, uses)


def _with_uses(found: Diagnostic, uses: list[Use]) -> Diagnostic:
    fragment_uses = [
        u
        for u in uses
        if u.fragment.span.file == found.span.file
        and u.fragment.span.line <= found.span.line <= u.fragment.last_line
    ]
    subject = found.subject
    if subject is not None and subject.command is not None:
        mine = [
            u
            for u in fragment_uses
            if u.controller == subject.controller
            and u.command == subject.command
            and (subject.state is None or subject.state in u.states)
        ]
        fragment_uses = mine or fragment_uses
    if not fragment_uses:
        return found
    shown = ", ".join(f"{u.span} ({u.command}.{u.state})" for u in fragment_uses[:3])
    more = f" and {len(fragment_uses) - 3} more" if len(fragment_uses) > 3 else ""
    note = f"in fragment `{fragment_uses[0].fragment.name}`, used at {shown}{more}"
    hint = f"{found.hint} ({note})" if found.hint else note
    return replace(found, hint=hint)
