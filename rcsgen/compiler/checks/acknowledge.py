"""Acknowledge: `allow:` entries -> warnings moved out of the report, with their reasons.

A spec says that a finding is intended where it happens: on a command (`allow:` with the
code, optionally the states it covers, and the reason) or on a rule (`allow:` with the code
and reason). Each warning of the checker and the analysis carries a `Subject` (controller,
command, state, rule); an acknowledgement that matches it moves it to
`Diagnostics.acknowledged`. An acknowledgement must name a warning that can be
acknowledged (E237), states of its command (E238) and a reason (E239); one that matches
nothing is itself a warning (W303), so acknowledgements do not outlive their findings.
`first_match` is the acknowledgement of the overlaps it resolves (the analysis files its
W501 findings as acknowledged directly).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from ..codes import ACKNOWLEDGEABLE, PROVE_CODES, Severity
from ..diagnostics import Diagnostic, Diagnostics, known_names_hint
from ..front_end.model import Allow, ControllerSpec


@dataclass
class _Entry:
    allow: Allow
    controller: str
    command: str | None  # None: an every_cycle rule
    states: frozenset[str] | None  # None: every state (or the rule's own)
    rule: tuple[str | None, int] | None  # (state, index) of a rule-level acknowledgement
    used: bool = False

    def matches(self, diagnostic: Diagnostic) -> bool:
        subject = diagnostic.subject
        if subject is None or diagnostic.code != self.allow.code.value:
            return False
        if subject.controller != self.controller or subject.command != self.command:
            return False
        if self.rule is not None:
            return (subject.state, subject.rule) == self.rule
        return self.states is None or subject.state in self.states


def _entries(spec: ControllerSpec) -> list[_Entry]:
    found = []
    for command in spec.commands.values():
        for allow in command.allow:
            states = frozenset(s.value for s in allow.states) if allow.states else None
            found.append(_Entry(allow, spec.name, command.name, states, None))
        for state in command.states.values():
            for index, rule in enumerate(state.rules, start=1):
                found += [
                    _Entry(a, spec.name, command.name, None, (state.name, index))
                    for a in rule.allow
                ]
    for index, rule in enumerate(spec.every_cycle, start=1):
        found += [_Entry(a, spec.name, None, None, (None, index)) for a in rule.allow]
    return found


def check_allows(controllers: Iterable[ControllerSpec], diags: Diagnostics) -> None:
    """Each acknowledgement names a warning that can be acknowledged, states of its command
    and a reason (E237, E238, E239)."""
    for spec in controllers:
        for entry in _entries(spec):
            allow = entry.allow
            code = str(allow.code.value)
            if code not in ACKNOWLEDGEABLE:
                what = "an error: fix it" if code.startswith(("E", "S")) else "not a warning"
                if code.startswith("W"):
                    what = "not a warning that can be acknowledged"
                diags.error(
                    allow.code.span,
                    "E237",
                    f"`{code}` cannot be acknowledged: it is {what}",
                    f"warnings that can be acknowledged: {', '.join(sorted(ACKNOWLEDGEABLE))}",
                )
            if not str(allow.reason.value).strip():
                diags.error(
                    allow.reason.span,
                    "E239",
                    f"the acknowledgement of `{code}` has no reason",
                    "say why the finding is intended, so a reviewer can check it",
                )
            command = spec.commands.get(entry.command) if entry.command else None
            for state in allow.states:
                if command is not None and state.value not in command.states:
                    diags.error(
                        state.span,
                        "E238",
                        f"the acknowledgement names `{state.value}`, which is not a state "
                        f"of {command.name}",
                        known_names_hint(f"states of {command.name}", command.states, state.value),
                    )


def apply(
    controllers: Iterable[ControllerSpec],
    diags: Diagnostics,
    since: int,
    complete: bool,
    checked: frozenset[str] | None = None,
) -> None:
    """Move the warnings from `diags.items[since:]` that an acknowledgement matches to
    `diags.acknowledged`. With `complete` (every check ran), an acknowledgement that matched
    nothing is W303 - of the codes in `checked` only (default: every code but `prove`'s)."""
    if checked is None:
        checked = frozenset(ACKNOWLEDGEABLE) - frozenset(PROVE_CODES)
    entries = [entry for spec in controllers for entry in _entries(spec)]
    if not entries:
        return
    kept = []
    for diagnostic in diags.items[since:]:
        entry = next((e for e in entries if e.matches(diagnostic)), None)
        if entry is None or diagnostic.severity is not Severity.WARNING:
            kept.append(diagnostic)
            continue
        entry.used = True
        diags.acknowledge(diagnostic, " ".join(str(entry.allow.reason.value).split()))
    del diags.items[since:]
    diags.items.extend(kept)
    if not complete:
        return
    for entry in entries:
        if entry.used or entry.allow.code.value not in checked:
            continue
        code = entry.allow.code.value
        where = _where(entry)
        kind = ACKNOWLEDGEABLE[code]
        diags.warning(
            entry.allow.span,
            "W303",
            f"the acknowledgement of {code} {where} matches no finding",
            f"remove it if the finding is gone; {code} is about {kind}: acknowledge it "
            + _HOW.get(kind, "on the rule, or on the command with `states:`"),
        )


# Where a finding about a state, or about a command (W704: no state nor rule of its own), is
# acknowledged; one about a rule: on the rule, or on the command with `states:`.
_HOW = {
    "a state": "on the command, with `states:`",
    "a command": "on the command, without `states:`",
}


def _where(entry: _Entry) -> str:
    if entry.command is None:
        return f"on every_cycle rule {entry.rule[1] if entry.rule else '?'}"
    if entry.rule is not None:
        return f"on rule {entry.rule[1]} of {entry.command} {entry.rule[0]}"
    if entry.states:
        return f"in {entry.command} {', '.join(sorted(entry.states))}"
    return f"in {entry.command}"
