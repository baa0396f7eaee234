"""Schema: loaded spec data -> structural diagnostics (JSON Schema Draft 2020-12).

The schemas in `rcsgen/compiler/schemas/` are the single source of truth for the shape of a
spec file; editors use the same files. This stage maps each jsonschema error to one located
diagnostic: S001 missing required key, S002 unknown key, S003 wrong type, S004 invalid name
or pattern, S005 invalid value (enum, minimum, ...), S006 malformed action or rule.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from importlib.resources import files
from typing import TYPE_CHECKING, Any, cast

from ..diagnostics import Diagnostic, Span, did_you_mean, number_shown
from .schema_fast import Check, Unsupported, compile_schema

if TYPE_CHECKING:
    from jsonschema.exceptions import ValidationError
    from jsonschema.protocols import Validator

KINDS = ("system", "controller", "operator", "scenario", "template")

_EXPECTED = {"object": "a mapping", "array": "a list", "string": "a string", "null": "nothing"}
_EXPECTED |= {"number": "a number", "integer": "an integer", "boolean": "a boolean"}
_YAML_11_BOOLS = ("yes", "no", "on", "off", "y", "n")
_KEYLIKE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)?")
_NAME_RULES = {
    "^[a-z][a-z0-9_]*$": "{}s are lower_case identifiers",
    "^[A-Z][A-Z0-9_]*$": "{}s are UPPER_CASE identifiers",
    r"^[a-z_][a-z0-9_]*(\.[a-z_][a-z0-9_]*)*$": "{}s are dotted lower_case Python names",
    r"^((world|result)\.)?[a-z][a-z0-9_]*$": (
        "expected `world.<field>`, `result.<name>` or a lower_case local name"
    ),
    r"^[a-z][a-z0-9_]*\.[A-Z][A-Z0-9_]*$": "expected `<subordinate>.<COMMAND>`",
    r"^([A-Z][A-Z0-9_]*|[a-z][a-z0-9_]*\.reason)$": (
        "expected an UPPER_CASE reason, or `<subordinate>.reason` to pass its reason up"
    ),
    r"^[0-9]{1,9}(\.[0-9]+)?\s*(s|ms|cycles?)$": (
        "expected seconds (2.5), `<number> s`, `<number> ms` or `<whole number> cycles`, "
        "the number at most 9 digits before its point"
    ),
}


@cache
def schema_for(kind: str) -> dict[str, Any]:
    """The JSON schema of a `system` or `controller` file (cached: do not mutate)."""
    if kind not in KINDS:
        raise ValueError(f"unknown spec kind {kind!r}; expected one of {KINDS}")
    path = files("rcsgen.compiler") / "schemas" / f"{kind}.schema.json"
    schema: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return schema


@cache
def validator_class() -> type[Validator]:
    """Draft 2020-12 as YAML needs it: 3 and 3.0 differ, so an `int` must be written as an
    integer, unlike JSON Schema's default. jsonschema is imported here, on the first
    invalid document (a valid one never needs it: the compiled test answers; ~0.1 s of
    every command's start-up otherwise)."""
    from jsonschema import Draft202012Validator, validators

    types = Draft202012Validator.TYPE_CHECKER.redefine(
        "integer", lambda _checker, value: isinstance(value, int) and not isinstance(value, bool)
    )
    # (`extend` is untyped in the jsonschema stubs.)
    extended: type[Validator] = validators.extend(  # type: ignore[no-untyped-call]
        Draft202012Validator, type_checker=types
    )
    return extended


@cache
def _validator(kind: str) -> Validator:
    return validator_class()(schema_for(kind))


@cache
def fast_check(kind: str) -> Check | None:
    """The schema of `kind` compiled to one validity test (None: a keyword it lacks)."""
    try:
        return compile_schema(schema_for(kind))
    except Unsupported:
        return None


def check_document(data: object, kind: str, display_path: str) -> list[Diagnostic]:
    """Every structural problem of one loaded spec document, in source order. The compiled
    test answers for a valid document; jsonschema locates the problems of an invalid one."""
    valid = fast_check(kind)
    if valid is not None and valid(data):
        return []
    found: dict[Diagnostic, None] = {}
    for error in _validator(kind).iter_errors(cast(Any, data)):  # loaded YAML: JSON-shaped
        found.update(dict.fromkeys(_diagnose(error, data, display_path)))
    return sorted(found, key=Diagnostic.sort_key)


def _locate(data: object, path: Iterable[str | int], file: str) -> Span:
    """The span of the value at `path`, else of its nearest located ancestor."""
    node, span = data, getattr(data, "span", None) or Span(file)
    for step in path:
        spans = getattr(node, "value_spans" if isinstance(node, dict) else "item_spans", None)
        node = node[step]  # type: ignore[index]
        if isinstance(spans, dict) and step in spans:
            span = spans[step]
        elif isinstance(spans, list) and isinstance(step, int) and step < len(spans):
            span = spans[step]
        else:
            span = getattr(node, "span", span)
    return span


def _walk(data: object, path: Iterable[str | int]) -> object:
    for step in path:
        data = data[step]  # type: ignore[index]
    return data


def _key_span(mapping: object, key: object, fallback: Span) -> Span:
    spans: Mapping[object, Span] = getattr(mapping, "key_spans", {})
    return spans.get(key, fallback)


def _where(path: Sequence[str | int]) -> str:
    """`key`: or item N of `key`: naming the value at `path`, for message prefixes."""
    if not path:
        return ""
    owner = next((s for s in reversed(path) if isinstance(s, str)), None)
    if isinstance(path[-1], int):
        return f"item {path[-1] + 1} of `{owner}`: " if owner else f"item {path[-1] + 1}: "
    return f"`{path[-1]}`: "


def _got(value: object) -> str:
    """Plain words for the YAML type of `value`, showing short scalars."""
    if value is None:
        return "nothing"
    if isinstance(value, dict | list):
        return "a mapping" if isinstance(value, dict) else "a list"
    if isinstance(value, bool):
        kind, shown = "a boolean", str(value).lower()
    else:
        kind = "a string" if isinstance(value, str) else "an integer"
        kind, shown = ("a float" if isinstance(value, float) else kind), str(value)
    return f"{kind} `{shown if len(shown) <= 30 else shown[:27] + '...'}`"


def _words(names: Sequence[object], last: str = "or") -> str:
    quoted = [f"`{n}`" for n in names]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} {last} {quoted[-1]}"


def _comma_hint(mapping: object, key: object) -> str:
    """A hint for a key with no value that looks like text cut off at a comma."""
    odd = isinstance(key, str) and not _KEYLIKE.fullmatch(key)
    if odd and isinstance(mapping, dict) and mapping.get(key) is None:
        return "a comma inside `{...}` separates entries: quote the value or use block style"
    return ""


def _schema_of(error: ValidationError) -> Mapping[str, Any]:
    """The schema an error failed, or {} for a boolean one."""
    return error.schema if isinstance(error.schema, Mapping) else {}


@dataclass
class _Failed:
    """One jsonschema error, located: the keyword's value, the instance, the schema of the
    place, its span and words (`where`), and the hint and title its schema gives."""

    error: ValidationError
    data: object
    schema: Mapping[str, Any]
    inst: Any  # JSON-shaped values: set on every error iter_errors yields
    value: Any
    span: Span
    where: str
    hint: str
    title: str

    def one(self, code: str, message: str, hint: str | None = None) -> list[Diagnostic]:
        return [Diagnostic(self.span, code, message, self.hint if hint is None else hint)]


def _diagnose(error: ValidationError, data: object, file: str) -> list[Diagnostic]:
    """The diagnostics of one jsonschema error (several for a missing/unknown-keys error)."""
    kw, schema, path = error.validator, _schema_of(error), error.absolute_path
    span = _locate(data, path, file)
    if kw in ("oneOf", "anyOf"):
        return _composite(error, data, file, span)
    failed = _Failed(
        error,
        data,
        schema,
        error.instance,
        error.validator_value,
        span,
        _where(list(path)),
        schema.get("description", ""),
        schema.get("title") or "value",
    )
    if "propertyNames" in error.absolute_schema_path:  # a bad key: point at the key itself
        mapping = _walk(data, path)
        failed.span, failed.where = _key_span(mapping, failed.inst, span), ""
        failed.hint = _comma_hint(mapping, failed.inst) or failed.hint
    return _BY_KEYWORD.get(str(kw), _other)(failed)


def _required(f: _Failed) -> list[Diagnostic]:
    props = f.schema.get("properties", {})
    return [
        Diagnostic(
            f.span,
            "S001",
            f"missing required key `{key}`",
            props.get(key, f.schema).get("description", ""),
        )
        for key in f.value
        if isinstance(f.inst, dict) and key not in f.inst
    ]


def _dependent_required(f: _Failed) -> list[Diagnostic]:
    inst = f.inst
    return [
        Diagnostic(
            _key_span(inst, key, f.span),
            "S001",
            f"`{key}` needs {_words(needed, 'and')}",
            f.schema.get("properties", {}).get(key, {}).get("description", ""),
        )
        for key, needed in f.value.items()
        if isinstance(inst, dict) and key in inst and any(n not in inst for n in needed)
    ]


def _additional_properties(f: _Failed) -> list[Diagnostic]:
    allowed, patterns = list(f.schema.get("properties", {})), f.schema.get("patternProperties", {})
    extras = [k for k in f.inst if k not in allowed and not any(re.search(p, k) for p in patterns)]
    return [
        Diagnostic(
            _key_span(f.inst, key, f.span),
            "S002",
            f"unknown key `{key}`",
            did_you_mean(key, allowed)
            or _comma_hint(f.inst, key)
            or f"allowed keys here: {_words(allowed, 'and')}",
        )
        for key in extras
    ]


def _type(f: _Failed) -> list[Diagnostic]:
    inst, path, hint = f.inst, f.error.absolute_path, f.hint
    wanted = [f.value] if isinstance(f.value, str) else f.value
    expected = _words([_EXPECTED[t] for t in wanted]).replace("`", "")
    if inst is None and path:
        hint = _comma_hint(_walk(f.data, list(path)[:-1]), path[-1]) or hint
    if "string" in wanted and isinstance(inst, bool | int | float):
        text = str(inst).lower() if isinstance(inst, bool) else inst
        hint = f'{hint} Quote the value to make it a string: "{text}"'.strip()
    if "boolean" in wanted and isinstance(inst, str) and inst.lower() in _YAML_11_BOOLS:
        hint = f"`{inst}` is a string in YAML 1.2 (not a boolean): write true or false"
    return f.one("S003", f"{f.where}expected {expected}, got {_got(inst)}", hint)


def _pattern(f: _Failed) -> list[Diagnostic]:
    rule = _NAME_RULES.get(f.value, "does not match `{}`")
    rule = rule.format(f.title if "{}s" in rule else f.value)
    return f.one("S004", f"`{f.inst}` is not a valid {f.title}: {rule}")


def _choice(f: _Failed) -> list[Diagnostic]:
    choices = f.value if f.error.validator == "enum" else [f.value]
    near = did_you_mean(str(f.inst), [str(c) for c in choices])
    return f.one(
        "S005", f"`{f.inst}` is not a valid {f.title}: expected {_words(choices)}", near or f.hint
    )


_BOUNDS = {
    "minimum": "at least",
    "exclusiveMinimum": "greater than",
    "maximum": "at most",
    "exclusiveMaximum": "less than",
}


def _bound(f: _Failed) -> list[Diagnostic]:
    bound = _BOUNDS[str(f.error.validator)]
    return f.one("S005", f"{f.where}must be {bound} {f.value}, got {number_shown(f.inst)}")


def _min_size(f: _Failed) -> list[Diagnostic]:
    what = "item" if f.error.validator == "minItems" else "entry"
    message = f"{f.where}needs at least {f.value} {what}, got {len(f.inst) or 'none'}"
    return f.one("S005", message.replace("at least 1 ", "at least one "))


def _unique_items(f: _Failed) -> list[Diagnostic]:
    seen: list[object] = []
    for index, item in enumerate(f.inst):
        if item in seen:
            spans = getattr(f.inst, "item_spans", [])
            at = spans[index] if index < len(spans) else f.span
            return [Diagnostic(at, "S005", f"{f.where}duplicate item `{item}`", "remove it")]
        seen.append(item)
    return _other(f)


def _other(f: _Failed) -> list[Diagnostic]:
    return f.one("S005", f"{f.where}{f.error.message}")


# How each JSON Schema keyword's failure is told (any other: S005 with jsonschema's words).
_BY_KEYWORD: dict[str, Callable[[_Failed], list[Diagnostic]]] = {
    "required": _required,
    "dependentRequired": _dependent_required,
    "additionalProperties": _additional_properties,
    "type": _type,
    "pattern": _pattern,
    "enum": _choice,
    "const": _choice,
    "exclusiveMinimum": _bound,
    "minimum": _bound,
    "exclusiveMaximum": _bound,
    "maximum": _bound,
    "minItems": _min_size,
    "minProperties": _min_size,
    "uniqueItems": _unique_items,
}


def _composite(error: ValidationError, data: object, file: str, span: Span) -> list[Diagnostic]:
    """One clear message for a oneOf/anyOf failure instead of one per alternative."""
    inst: Any = error.instance
    schema = _schema_of(error)
    title = schema.get("title", "value")
    article = "an" if title[:1] in "aeiou" else "a"
    branches = schema.get(str(error.validator), [])
    forms = [b["required"][0] for b in branches if len(b.get("required", [])) == 1]
    if len(forms) != len(branches) or not forms:
        from jsonschema.exceptions import best_match

        # the alternative of the value's own kind says what is wrong (a string against the
        # string form's pattern, not "expected a number")
        own = [e for e in error.context if e.validator != "type"]
        best = best_match(own or error.context)
        return _diagnose(best, data, file) if best else [Diagnostic(span, "S006", error.message)]
    if error.validator == "anyOf":
        return [
            Diagnostic(
                span,
                "S006",
                f"{article} {title} needs at least one of {_words(forms)}",
                schema.get("description", ""),
            )
        ]
    usage = f"{article} {title} is a mapping with exactly one of {_words(forms)}"
    if not isinstance(inst, dict):
        first, _, rest = str(inst).partition(" ")
        hint = f"write `{first}: {rest}`" if first in forms and rest else usage
        return [
            Diagnostic(
                span, "S006", f"malformed {title}: expected a mapping, got {_got(inst)}", hint
            )
        ]
    return _one_form(error, data, file, span, forms, usage)


def _one_form(
    error: ValidationError, data: object, file: str, span: Span, forms: list[str], usage: str
) -> list[Diagnostic]:
    """A mapping that must have exactly one of `forms` (an action, a rule's form): which
    it has both of, or none of; else what is wrong inside the one it has."""
    inst: Any = error.instance
    title = _schema_of(error).get("title", "value")
    present = [k for k in inst if k in forms]
    if len(present) > 1:
        at = _key_span(inst, present[1], span)
        message = f"malformed {title}: it has both `{present[0]}` and `{present[1]}`"
        return [Diagnostic(at, "S006", message, f"{usage}; use one list item per {title}")]
    if not present:
        unknown = [k for k in inst if k not in forms]
        key = unknown[0] if unknown else ""
        at = _key_span(inst, key, span)
        message = f"malformed {title}: no {_words(forms)}" + (f" (found `{key}`)" if key else "")
        return [Diagnostic(at, "S006", message, did_you_mean(key, forms) or usage)]
    index = forms.index(present[0])
    chosen = [e for e in error.context if e.relative_schema_path[0] == index]
    return [d for e in chosen for d in _diagnose(e, data, file)]
