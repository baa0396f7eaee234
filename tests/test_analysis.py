"""The static analysis of state tables (compiler/analysis/): codes, spans, counter-examples.

Each case writes a small system into a scratch directory: a supervisor `top` with two leaf
subordinates `a` and `b`, and the state table under test. Counter-examples are checked by
evaluating the guards on them with an evaluator written here, independent of the analysis,
and the decisions on random guards are checked against Python evaluating a grid of values.
"""

from __future__ import annotations

import itertools
import operator
import random
import re
import shutil
import textwrap
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from conftest import REPO, rcsgen

from rcsgen.compiler import expressions as X
from rcsgen.compiler.analysis import solver
from rcsgen.compiler.analysis import tables as analysis
from rcsgen.compiler.checks.check import check_system
from rcsgen.compiler.diagnostics import Diagnostic, Diagnostics, Span
from rcsgen.compiler.front_end import fragments
from rcsgen.compiler.front_end.loader import load_file
from rcsgen.compiler.front_end.model import (
    ControllerSpec,
    SystemSpec,
    build_controller,
    build_system,
)
from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.types import BOOL, FLOAT, INT, STATUS, CommandOf, Type

SYSTEM = """\
system: t
title: Analysis test
cycle_period: 0.1
world:
  hot: {type: bool, initial: false}
  cold: {type: bool, initial: false}
  level: {type: float, initial: 0.0}
  x: {type: float, initial: 0.0}
  y: {type: float, initial: 0.0}
processes:
  p:
    modules: [top, a, b]
"""

LEAF = """\
controller: {name}
title: Leaf {name}
commands:
  GO:
    states:
      S0:
        - do: [report: DONE]
"""

TOP = """\
controller: top
title: Top
subordinates: [a, b]
world:
  reads: [hot, cold, level, x, y]
locals:
  ticks: {{type: int, initial: 0}}
  i: {{type: int, initial: 0}}
  j: {{type: int, initial: 0}}{locals}
constants:
  LIMIT: 4.0
predicates:
  warm: world.level > LIMIT and not world.cold
{top_level}commands:
{commands}"""


def make(root: Path, commands: str, locals_: str = "", top_level: str = "") -> Path:
    """A system directory `sys/` under `root` whose `top` has these commands (YAML text)
    and, besides ticks, i and j, these locals (YAML lines); `top_level`: more top-level keys."""
    directory = root / "sys"
    directory.mkdir()
    (directory / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    for leaf in ("a", "b"):
        (directory / f"{leaf}.yaml").write_text(LEAF.format(name=leaf), encoding="utf-8")
    body = textwrap.indent(textwrap.dedent(commands).strip("\n") + "\n", "  ")
    top = TOP.format(commands=body, locals=locals_, top_level=textwrap.dedent(top_level))
    (directory / "top.yaml").write_text(top, encoding="utf-8")
    return directory


@pytest.fixture
def spec(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """`spec(commands, locals_, top_level)`: write the system, run the front end; its
    diagnostics, sorted."""
    monkeypatch.chdir(tmp_path)

    def run(commands: str, locals_: str = "", top_level: str = "") -> list[Diagnostic]:
        """Every diagnostic, the acknowledged ones included (their `acknowledged` is set)."""
        front = compile_paths([make(tmp_path, commands, locals_, top_level)])
        return [*front.diagnostics, *front.diagnostics.acknowledged]

    return run


def at(marker: str, file: str = "sys/top.yaml") -> str:
    """`file:line:col` of the `|` in `marker`, which must occur once in the file."""
    before, _, after = marker.partition("|")
    text = Path(file).read_text(encoding="utf-8")
    assert text.count(before + after) == 1, f"{marker!r} is not unique in {file}"
    offset = text.index(before + after) + len(before)
    line = text.count("\n", 0, offset) + 1
    return f"{file}:{line}:{offset - text.rfind(chr(10), 0, offset)}"


def found(diags: list[Diagnostic], *codes: str) -> list[tuple[str, str, str]]:
    """(location, code, message) of the diagnostics with these codes (all, if none given)."""
    return [(str(d.span), d.code, d.message) for d in diags if not codes or d.code in codes]


def codes(diags: list[Diagnostic]) -> set[str]:
    return {d.code for d in diags}


# ---------------------------------------------------------------- an independent evaluator


def models(directory: Path) -> tuple[SystemSpec, list[ControllerSpec]]:
    system = build_system(
        load_file(directory / "system.yaml", "system.yaml"), directory, "system.yaml"
    )
    shared: dict = {}
    if (directory / fragments.FILE).is_file():
        data = load_file(directory / fragments.FILE, fragments.FILE)
        shared = fragments.read(data["fragments"], Span(fragments.FILE), Diagnostics())
    controllers = []
    for path in sorted(directory.glob("*.yaml")):
        if path.name in ("system.yaml", fragments.FILE):
            continue
        data = load_file(path, path.name)
        fragments.expand(data, shared, Diagnostics(), Span(path.name))  # (the tc's tram)
        controllers.append(build_controller(data, path.name))
    return system, controllers


def parse_valuation(text: str) -> dict[str, Any]:
    """`a.status=DONE, world.hot=true, ticks=4` -> {"a.status": "DONE", ...}."""
    values: dict[str, Any] = {}
    for item in text.split(", "):
        name, _, raw = item.partition("=")
        if raw in ("true", "false"):
            values[name] = raw == "true"
        elif re.fullmatch(r"-?\d+", raw):
            values[name] = int(raw)
        elif re.fullmatch(r"-?\d+\.\d+(e-?\d+)?", raw):
            values[name] = float(raw)
        else:
            values[name] = raw
    return values


OPERATORS = {
    "+": operator.add,
    "-": operator.sub,
    "*": operator.mul,
    "/": operator.truediv,
    "//": operator.floordiv,
    "%": operator.mod,
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}


class Evaluator:
    """Guards of one controller, evaluated on named values with Python's semantics."""

    def __init__(self, directory: Path, controller: str):
        system, controllers = models(directory)
        checked = check_system(system, controllers, Diagnostics())
        assert checked is not None
        self.checked = checked.controllers[controller]
        self.spec = self.checked.spec
        self.commands = {
            s.value: tuple(next(c for c in controllers if c.name == s.value).commands)
            for s in self.spec.subordinates
        }
        self.predicates = {n: p.tree for n, p in self.checked.predicates.items()}

    def guard(self, command: str, state: str, number: int) -> X.Expr:
        rule = self.checked.commands[command].states[state].rules[number - 1]
        assert rule.guard is not None
        return rule.guard

    def names(self, tree: X.Expr) -> dict[str, str]:
        """Every name the guard reads (predicates followed) -> its type."""
        out: dict[str, Type] = {}
        todo = [tree]
        while todo:
            node = todo.pop()
            for ref in X.refs(node):
                if ref.kind in ("world", "local", "param"):
                    out[f"world.{ref.name}" if ref.kind == "world" else ref.name] = ref.type
                elif ref.kind in ("sub_status", "sub_command"):
                    out[f"{ref.owner}.{ref.name}"] = ref.type
            todo += [self.predicates[c.name] for c in _calls(node)]
        return out

    def value(self, e: X.Expr, values: dict[str, Any]) -> Any:
        if isinstance(e, X.Const):
            return e.value
        if isinstance(e, X.Ref):
            if e.kind == "const":
                return self.spec.constants[e.name].value
            if e.kind in ("status", "sub_command_name"):
                return e.name
            if e.kind == "world":
                return values[f"world.{e.name}"]
            if e.kind in ("sub_status", "sub_command"):
                return values[f"{e.owner}.{e.name}"]
            return values[e.name]
        if isinstance(e, X.Call):
            if e.kind == "predicate":
                return self.value(self.predicates[e.name], values)
            return {"abs": abs, "min": min, "max": max}[e.name](
                *(self.value(a, values) for a in e.args)
            )
        if isinstance(e, X.Unary):
            v = self.value(e.operand, values)
            return {"not": lambda: not v, "-": lambda: -v, "+": lambda: v}[e.op]()
        if isinstance(e, X.Binary):
            left, right = self.value(e.left, values), self.value(e.right, values)
            return OPERATORS[e.op](left, right)
        if isinstance(e, X.BoolOp):
            vs = (self.value(v, values) for v in e.values)
            return all(vs) if e.op == "and" else any(vs)
        if isinstance(e, X.Compare):
            operands = [self.value(o, values) for o in (e.left, *e.comparators)]
            return all(
                OPERATORS[op](a, b)
                for (a, b), op in zip(itertools.pairwise(operands), e.ops, strict=True)
            )
        raise TypeError(e)

    def domain(self, name: str, kind: Type) -> tuple[Any, ...]:
        if kind == BOOL:
            return (False, True)
        if kind == STATUS:
            return X.STATUS_NAMES
        if isinstance(kind, CommandOf):
            return self.commands[kind.sub]
        return (-1000, -1, 0, 1, 1000)

    def all_hold(self, trees: list[X.Expr], valuation: str) -> bool:
        """Whether every guard holds on the valuation, whatever the names it leaves out."""
        given = parse_valuation(valuation) if valuation else {}
        read: dict[str, Type] = {}
        for tree in trees:
            read.update(self.names(tree))
        assert set(given) <= set(read), f"{given} names something no guard reads"
        missing = [n for n in read if n not in given]
        for values in itertools.product(*(self.domain(n, read[n]) for n in missing)):
            at = {**given, **dict(zip(missing, values, strict=True))}
            if not all(self.value(t, at) for t in trees):
                return False
        return True

    def none_holds(self, trees: list[X.Expr], valuation: str) -> bool:
        given = parse_valuation(valuation)
        read: dict[str, Type] = {}
        for tree in trees:
            read.update(self.names(tree))
        missing = [n for n in read if n not in given]
        for values in itertools.product(*(self.domain(n, read[n]) for n in missing)):
            at = {**given, **dict(zip(missing, values, strict=True))}
            if any(self.value(t, at) for t in trees):
                return False
        return True


def _calls(tree: X.Expr) -> list[X.Call]:
    found_calls, todo = [], [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, X.Call):
            found_calls += [node] if node.kind == "predicate" else []
            todo += list(node.args)
        elif isinstance(node, X.Unary):
            todo.append(node.operand)
        elif isinstance(node, X.Binary):
            todo += [node.left, node.right]
        elif isinstance(node, X.BoolOp):
            todo += list(node.values)
        elif isinstance(node, X.Compare):
            todo += [node.left, *node.comparators]
    return found_calls


OVERLAP_RE = re.compile(
    r"rules (\d+) and (\d+) of (\w+) (\w+) (?:can both fire: )?both hold when (.*?)(?:;|$)"
)


def assert_fires_both(directory: Path, controller: str, message: str) -> None:
    """The E501/W501 message's valuation makes both of its rules' guards true."""
    match = OVERLAP_RE.search(message)
    assert match, message
    first, second, command, state, valuation = match.groups()
    evaluator = Evaluator(directory, controller)
    trees = [evaluator.guard(command, state, int(n)) for n in (first, second)]
    assert evaluator.all_hold(trees, valuation), message


# ---------------------------------------------------------------- determinism

OVERLAP = """
GO:
  states:
    S0:
      - do: [send: a.GO]
        next: S1
    S1:
      - when: world.hot and a.status == DONE
        do: [report: DONE]
      - when: a.status != ERROR and not world.cold
        next: S0
"""


def test_overlapping_guards_are_an_error_with_a_valuation_that_fires_both(spec) -> None:
    diags = spec(OVERLAP)
    assert found(diags, "E501", "W501", "W502") == [
        (
            at("        - |when: a.status != ERROR"),
            "E501",
            "rules 1 and 2 of GO S1 can both fire: "
            "both hold when world.hot=true, a.status=DONE, world.cold=false",
        )
    ]
    e501 = next(d for d in diags if d.code == "E501")
    assert e501.hint == (
        "make the guards exclusive, or declare `first_match: [S1]` on GO so that rule 1 "
        "wins on purpose"
    )
    assert_fires_both(Path("sys"), "top", e501.message)


def test_an_error_fails_validate_and_build(spec, tmp_path: Path) -> None:
    spec(OVERLAP)
    result = rcsgen("validate", "sys")
    assert result.exit_code == 1
    assert "error[E501]" in result.output
    result = rcsgen("build", "sys", "-o", "out")
    assert result.exit_code == 1
    assert not (tmp_path / "out").exists()


def test_first_match_acknowledges_the_overlap(spec) -> None:
    """The overlap is still found (and shown with --show-acknowledged), but first_match is its
    acknowledgement: nothing is reported and --strict passes."""
    diags = spec(OVERLAP.replace("GO:\n  states:", "GO:\n  first_match: [S1]\n  states:"))
    assert found(diags, "E501", "W501", "W502", "W511") == [
        (
            at("        - |when: a.status != ERROR"),
            "W501",
            "rules 1 and 2 of GO S1 both hold when world.hot=true, a.status=DONE, "
            "world.cold=false; rule 1 wins (first_match)",
        )
    ]
    [w501] = [d for d in diags if d.code == "W501"]
    assert w501.acknowledged == "`first_match: [S1]` on GO: the earlier rule wins"
    assert_fires_both(Path("sys"), "top", w501.message)
    assert not [d for d in diags if d.severity == "error"]
    plain = rcsgen("validate", "sys")
    assert plain.exit_code == 0 and "W501" not in plain.output  # (the table has a W503, W506)
    shown = rcsgen("validate", "--show-acknowledged", "sys")
    assert "sys/top.yaml:24:11: acknowledged[W501]: rules 1 and 2 of GO S1" in shown.output
    assert "= reason: `first_match: [S1]` on GO: the earlier rule wins" in shown.output


def test_a_rule_without_when_overlaps_the_rules_before_it(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: ticks >= 4
                do: [report: DONE]
              - do:
                  - set: {ticks: ticks + 1}
              - do: [report: ERROR]
        """
    )
    # The third rule never fires (W301): it is not compared again.
    assert found(diags, "E501", "W301") == [
        (at("      - |do:\n            - set"), "E501", _both(1, 2, "S0", "ticks=4")),
        (at("      - |do: [report: ERROR]"), "W301", "this rule of GO S0 never fires"),
    ]


def _both(first: int, second: int, state: str, valuation: str) -> str:
    return f"rules {first} and {second} of GO {state} can both fire: both hold when {valuation}"


EXCLUSIVE = """
GO:
  states:
    S0:
      - do: [send: a.GO]
        next: S1
    S1:
      - when: world.level > 4.0
        next: S2
      - when: not world.level > 4.0
        next: S2
    S2:
      - when: a.status == DONE
        next: S3
      - when: a.status == ERROR
        do: [report: ERROR]
    S3:
      - when: ticks >= 4
        next: S4
      - when: ticks < 4
        do:
          - set: {ticks: ticks + 1}
    S4:
      - when: ticks > 3
        next: S5
      - when: ticks < 4
        next: S5
    S5:
      - when: world.x > world.y + 0.5
        next: S6
      - when: world.x < world.y - 0.5
        next: S6
      - when: -0.5 <= world.x - world.y <= 0.5
        next: S6
    S6:
      - when: warm()
        next: S7
      - when: world.level <= LIMIT or world.cold
        next: S7
    S7:
      - when: i > j
        next: S8
      - when: j >= i
        next: S8
    S8:
      - when: "False"
        next: S0
      - do: [report: DONE]
"""


def test_exclusive_guards_are_not_reported(spec) -> None:
    """Complementary numeric atoms, distinct statuses, an int gap, linear forms, a predicate."""
    diags = spec(EXCLUSIVE)
    # Each state has a rule for every valuation, but for S2 waiting while `a` executes
    # (the handshake, not reported). S8's first guard is the constant false: the checker
    # says so (W302) and the rule is not analysed.
    assert found(diags) == [
        (
            at('when: |"False"'),
            "W302",
            "this rule of GO S8 never fires: its guard is always false",
        )
    ]


def test_comparisons_beyond_interval_reasoning_cannot_be_proven(spec) -> None:
    """A product of variables is opaque; a linear form of ints may hide a gap (i - j = 0.5)."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.x * world.y > 1.0
                do: [report: DONE]
              - when: world.x < 0.0
                do: [report: ERROR]
              - when: world.x >= 0.0
                next: S1
            S1:
              - when: i > j
                do: [report: DONE]
              - when: i < j + 1
                do: [report: ERROR]
        """
    )
    assert found(diags, "E501", "W502") == [
        (
            at("      - |when: world.x < 0.0"),
            "W502",
            "cannot prove rules 1 and 2 of GO S0 exclusive: both hold if world.x=-1.0, "
            "(world.x * world.y > 1.0)=true; interval reasoning cannot decide "
            "`world.x * world.y > 1.0`",
        ),
        (
            at("      - |when: world.x >= 0.0"),
            "W502",
            "cannot prove rules 1 and 3 of GO S0 exclusive: both hold if world.x=0.0, "
            "(world.x * world.y > 1.0)=true; interval reasoning cannot decide "
            "`world.x * world.y > 1.0`",
        ),
        (
            at("      - |when: i < j + 1"),
            "W502",
            "cannot prove rules 1 and 2 of GO S1 exclusive: both hold if (i - j)=0.5; "
            "interval reasoning cannot decide `i - j`",
        ),
    ]
    w502 = next(d for d in diags if d.code == "W502")
    assert w502.hint == (
        "compare a variable with a constant where you can, or declare `first_match: [S0]` "
        "on GO if rule 1 should win"
    )


def test_two_float_variables_are_decided_as_one_linear_form(spec) -> None:
    """`x > y` is `x - y > 0`: decided exactly, and a real overlap is an error. Forms that
    depend on each other (x - y, x - 2*y and y) cannot be set independently: W502."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.x > world.y
                do: [report: DONE]
              - when: world.y > world.x
                do: [report: ERROR]
              - when: world.x - world.y > 2.0
                next: S1
            S1:
              - when: world.x > world.y
                do: [report: DONE]
              - when: world.x > 2 * world.y and world.y > 1.0
                do: [report: ERROR]
        """
    )
    assert found(diags, "E501", "W502") == [
        (
            at("      - |when: world.x - world.y > 2.0"),
            "E501",
            _both(1, 3, "S0", "(world.x - world.y)=3.0"),
        ),
        (
            at("      - |when: world.x > 2 * world.y"),
            "W502",
            "cannot prove rules 1 and 2 of GO S1 exclusive: both hold if "
            "(world.x - world.y)=1.0, (world.x - 2*world.y)=1.0, world.y=2.0; interval "
            "reasoning cannot decide `world.x - world.y`, `world.x - 2*world.y`",
        ),
    ]


def test_too_many_valuations_cannot_be_proven_and_do_not_hang(spec, monkeypatch) -> None:
    """Two rules whose guards are the parity of 13 flags and its negation: exclusive, but
    only a look at all 2**13 valuations (no partial valuation decides a parity) could tell.
    The analysis gives up instead (W502) and evaluates the guards at most LIMIT times."""
    parity = "b0"
    for n in range(1, 13):
        parity = f"({parity} != b{n})"
    locals_ = "".join(f"\n  b{n}: {{type: bool, initial: false}}" for n in range(13))
    evaluations = 0
    compile_guard = analysis.GuardBuilder.guard

    def counted(self: analysis.GuardBuilder, tree: X.Expr) -> solver.Guard:
        guard = compile_guard(self, tree)
        fn = guard.fn

        def evaluate_counted(val: dict) -> Any:
            nonlocal evaluations
            evaluations += 1
            return fn(val)

        guard.fn = evaluate_counted
        return guard

    monkeypatch.setattr(analysis.GuardBuilder, "guard", counted)
    commands = f"""
        GO:
          states:
            S0:
              - when: "{parity}"
                do: [report: DONE]
              - when: "not {parity}"
                do: [report: ERROR]
        """
    diags = spec(commands, locals_)
    assert 0 < evaluations <= solver.LIMIT, "the analysis enumerated the valuations"
    assert found(diags, "W502") == [
        (
            at('      - |when: "not'),
            "W502",
            "cannot prove rules 1 and 2 of GO S0 exclusive: their guards have 8192 "
            f"valuations, more than {solver.LIMIT}",
        )
    ]


# ---------------------------------------------------------------- completeness


def test_waiting_for_executing_subordinates_is_the_handshake_not_a_warning(spec) -> None:
    """A state that waits only while the subordinates it tests are EXECUTING is the
    command-number handshake the designer chose by sending and testing: not reported."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO, send: b.GO]
                next: S1
            S1:
              - when: a.status == DONE and b.status == DONE
                do: [report: DONE]
              - when: a.status == ERROR or b.status == ERROR
                do: [report: ERROR]
        """
    )
    assert found(diags) == []


def test_a_state_that_waits_is_a_warning_naming_the_valuation(spec) -> None:
    """A wait that remains once every tested subordinate has finished is reported, with the
    valuation: here an ERROR from `a` leaves the table waiting forever."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO, send: b.GO]
                next: S1
            S1:
              - when: a.status == DONE and b.status == DONE
                do: [report: DONE]
              - when: b.status == ERROR
                do: [report: ERROR]
        """
    )
    w503 = [d for d in diags if d.code == "W503"]
    assert [(str(d.span), d.message) for d in w503] == [
        (at("    |S1:"), "GO S1 waits when a.status=ERROR, b.status=DONE: no rule fires then")
    ]
    assert w503[0].hint == (
        "waiting is normal in RCS; if this wait is intended, acknowledge it on GO: "
        "`allow: [{code: W503, states: [S1], reason: ...}]`"
    )
    evaluator = Evaluator(Path("sys"), "top")
    guards = [evaluator.guard("GO", "S1", n) for n in (1, 2)]
    assert evaluator.none_holds(guards, "a.status=ERROR, b.status=DONE")
    assert rcsgen("validate", "sys").exit_code == 0  # a warning does not fail a build


# ---------------------------------------------------------------- RCS rules


def test_a_command_that_can_never_report_is_an_error(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - next: S1
            S1:
              - when: world.hot
                next: S0
              - when: not world.hot
                next: S2
            S2:
              - when: world.level > 5.0 and world.level < 3.0
                do: [report: DONE]
              - next: S0
        """
    )
    assert found(diags, "E504") == [
        (
            at("  |GO:"),
            "E504",
            "GO can never finish: no rule reachable from S0 reports DONE or ERROR",
        )
    ]
    assert found(diags, "W512") == [  # S2's reporting rule can never fire
        (
            at("      - |when: world.level > 5.0 and world.level < 3.0"),
            "W512",
            "rule 1 of GO S2 never fires: its guard can never hold",
        )
    ]
    assert codes(diags) == {"E504", "W512"}


def test_a_rule_that_an_earlier_rule_always_beats_is_a_warning(spec) -> None:
    diags = spec(
        """
        GO:
          first_match: [S0]
          states:
            S0:
              - when: world.hot or world.cold
                do: [report: DONE]
              - when: world.hot
                do: [report: ERROR]
        """
    )
    assert found(diags, "W512") == [
        (
            at("      - |when: world.hot\n"),
            "W512",
            "rule 2 of GO S0 never fires: whenever its guard holds, an earlier rule (1) "
            "fires first",
        )
    ]


def test_a_command_sent_and_never_awaited_is_a_warning(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO, send: b.GO]
                next: S1
            S1:
              - when: a.status == DONE
                do: [send: b.GO, report: DONE]
              - when: a.status == ERROR
                do: [report: ERROR]
        """
    )
    assert found(diags, "W505") == [
        (
            at("      - do: [send: a.GO, |send: b.GO]"),
            "W505",
            "GO S0 sends b.GO but never waits for it: no state reached afterwards tests b.status",
        ),
        (
            at("        do: [|send: b.GO, report: DONE]"),
            "W505",
            "GO S1 sends b.GO but never waits for it: the command ends here",
        ),
    ]
    assert diags[-1].hint == (
        "wait with `when: b.status == DONE` in a later state, or do not send it"
    )
    assert codes(diags) == {"W505"}


def test_an_unhandled_subordinate_error_is_a_warning(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO, send: b.GO]
                next: S1
            S1:
              - when: a.status == DONE and b.status == DONE
                next: S2
              - when: world.hot
                do: [report: ERROR]
            S2:
              - when: a.status != DONE
                do: [report: ERROR]
              - do: [report: DONE]
        """
    )
    # S1: an ERROR from either leaves it waiting (world.hot is no answer to it). S2: a rule
    # that fires on `a.status != DONE` handles ERROR too.
    assert found(diags, "W506") == [
        (
            at("    |S1:"),
            "W506",
            "GO S1 waits on a but never handles a.status == ERROR: an ERROR from a leaves "
            "top waiting in S1 forever",
        ),
        (
            at("    |S1:"),
            "W506",
            "GO S1 waits on b but never handles b.status == ERROR: an ERROR from b leaves "
            "top waiting in S1 forever",
        ),
    ]
    assert next(d for d in diags if d.code == "W506").hint == (
        "add a rule such as `when: a.status == ERROR` with `do: [report: ERROR]`"
    )


def test_waiting_on_a_subordinate_never_commanded_is_an_error(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO]
                next: S1
            S1:
              - when: a.status == DONE and b.status == DONE
                do: [report: DONE]
              - when: a.status == ERROR or b.status == ERROR
                do: [report: ERROR]
        """
    )
    message = (
        "rule {} of GO S1 tests b.status, but GO never sends b a command: the status is "
        "left over from an earlier command"
    )
    assert found(diags, "E507") == [
        (at("      - |when: a.status == DONE"), "E507", message.format(1)),
        (at("      - |when: a.status == ERROR"), "E507", message.format(2)),
    ]
    assert next(d for d in diags if d.code == "E507").severity == "error"


def test_a_dead_state_is_a_warning(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.hot
                do: [report: DONE]
              - when: not world.hot
                next: S1
            S1:
              - when: world.level > 5.0 and world.level < 3.0
                next: S0
              - when: ticks > 3 and ticks < 4
                next: S0
        """
    )
    # each guard is a contradiction on its own: the warning is at the first, what to fix
    assert found(diags) == [
        (
            at("- when: |world.level > 5.0"),
            "W508",
            "GO S1 is dead: none of its rules can ever fire",
        )
    ]


def test_a_state_with_no_way_out_is_a_warning(spec) -> None:
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.hot
                do: [report: DONE]
              - when: not world.hot
                next: S1
            S1:
              - when: world.cold
                do:
                  - set: {ticks: ticks + 1}
              - next: S1
        """
    )
    assert found(diags, "E501", "W509") == [
        (
            at("    |S1:"),
            "W509",
            "GO S1 has no way out: no rule leaves it or reports, so `top` stays in S1 "
            "until a new command arrives",
        ),
        (at("        - |next: S1\n"), "E501", _both(1, 2, "S1", "world.cold=true")),
    ]


def test_every_cycle_sends_count_in_every_state(spec) -> None:
    """An every_cycle rule's sends count as commanding, in every state (it may not report:
    E232, it has no command to end)."""
    every = """
        every_cycle:
          - when: world.hot
            do: [send: b.GO]
        """
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [send: a.GO]
                next: S1
            S1:
              - when: a.status == DONE and b.status == DONE
                do: [report: DONE]
              - when: a.status == ERROR or b.status == ERROR
                do: [report: ERROR]
        """,
        top_level=every,
    )
    # No E507 (b is commanded, by every_cycle) and no W506 (both ERRORs are handled).
    assert [d for d in found(diags) if d[1] in ("E507", "W506", "E232")] == []


# ---------------------------------------------------------------- first_match


def test_first_match_names_must_be_states_and_are_needed(spec) -> None:
    diags = spec(
        """
        GO:
          first_match: [S0, S9]
          states:
            S0:
              - when: world.hot
                do: [report: DONE]
              - when: not world.hot
                do: [report: ERROR]
        """
    )
    assert found(diags) == [
        (
            at("  first_match: [|S0, S9]"),
            "W511",
            "`first_match` on GO S0 is not needed: its rules never overlap",
        ),
        (
            at("  first_match: [S0, |S9]"),
            "E510",
            "`first_match` names `S9`, which is not a state of GO",
        ),
    ]


# ---------------------------------------------------------------- the whole pipeline


def test_default_init_and_halt_tables_come_out_clean(spec) -> None:
    """INIT/HALT wait for every DONE (the QQ1 template): no W503/W506 for them."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - do: [report: DONE]
        """
    )
    assert diags == []
    for fixture in ("chain", "packed"):
        front = compile_paths([REPO / "tests" / "fixtures" / "semantics" / fixture])
        assert list(front.diagnostics) == []


def test_every_code_of_the_analysis_is_registered_with_its_meaning() -> None:
    from rcsgen.compiler.codes import CODES, Topic

    source = Path(analysis.__file__).read_text(encoding="utf-8")
    used = set(re.findall(r'"([EW]5\d\d)"', source))
    assert used == {c for c, code in CODES.items() if code.topic is Topic.ANALYSIS}
    assert all(CODES[c].title for c in used)


def test_samples_cover_every_region_once() -> None:
    from fractions import Fraction

    assert solver.samples(solver.INT, [Fraction(3), Fraction(4)], False) == (3, 4, 2, 5)
    assert solver.samples(solver.INT, [Fraction(5, 2)], False) == (2, 3)  # none between
    assert solver.samples(solver.INT, [Fraction(1), Fraction(2), Fraction(10)], False) == (
        (1, 2, 10, 0, 3, 11)
    )
    assert solver.samples(solver.FLOAT, [Fraction(0), Fraction(1)], False) == (
        0,
        1,
        -1,
        Fraction(1, 2),
        2,
    )
    assert solver.samples(solver.FLOAT, [Fraction(0), Fraction(1), Fraction(3)], False) == (
        (0, 1, 3, -1, Fraction(1, 2), 2, 4)
    )


def test_a_float_variable_samples_only_values_a_float_holds() -> None:
    """`3 * x <= 1` cuts at 1/3, which no float holds: a form's values keep it, a float
    variable's drop it, and each middle becomes the float nearest it inside its region."""
    from fractions import Fraction

    third = Fraction(1, 3)
    assert solver.samples(solver.FLOAT, [Fraction(0), third], False) == (
        0,
        third,
        -1,
        Fraction(1, 6),
        Fraction(4, 3),
    )
    assert solver.samples(solver.FLOAT, [Fraction(0), third], True) == (
        0,
        -1,
        Fraction(1 / 6),
        Fraction(4 / 3),
    )
    huge = Fraction(10**400)  # beyond every float: neither it nor the values past it held
    assert solver.samples(solver.FLOAT, [Fraction(0), huge], True) == (
        0,
        -1,
        huge / 2,
        huge + 1,
    )
    # between two neighbouring floats no float is strictly inside: the exact middle stays
    one, next_up, after = (Fraction(1 + n * 2.0**-52) for n in (0, 1, 2))
    assert solver.samples(solver.FLOAT, [one, next_up], True)[3] == (one + next_up) / 2
    assert solver.samples(solver.FLOAT, [next_up, after], True)[3] == (next_up + after) / 2


def test_vectors_are_independent_unless_one_is_a_combination_of_the_others() -> None:
    """Exact elimination: a row that another's multiple cancels leaves nothing (dependent)."""
    from fractions import Fraction as F

    x, y, z = ("world", "x"), ("world", "y"), ("world", "z")
    assert solver.independent([{x: F(1), y: F(-1)}, {x: F(1), y: F(-2)}, {y: F(1), z: F(3)}])
    assert not solver.independent([{x: F(1), y: F(-1)}, {x: F(1), y: F(-2)}, {y: F(3)}])
    assert solver.independent([{x: F(1), y: F(1)}, {x: F(1)}])  # leaves -y
    assert solver.independent([{x: F(2), y: F(4)}, {x: F(1), y: F(2)}]) is False  # a half
    assert solver.independent([{x: F(3)}, {}]) is False


def _parity(flags: int) -> solver.Guard:
    """A guard that only a look at every valuation of `flags` bools decides: their parity."""
    keys = [("local", f"b{n}") for n in range(flags)]

    def odd(val: solver.Valuation) -> bool | None:
        return None if any(k not in val for k in keys) else sum(val[k] for k in keys) % 2 == 1

    domains = dict.fromkeys(keys, solver.BOOL_DOMAIN)
    return solver.Guard(odd, domains=domains, order=dict.fromkeys(keys))


def test_the_solver_enumerates_up_to_its_limit_and_no_further() -> None:
    assert solver.LIMIT == 2**12
    at_limit = solver.solve([(_parity(12), True)])  # 4096 valuations: still searched
    assert (at_limit.kind, at_limit.size) == (solver.Verdict.YES, solver.LIMIT)
    assert sum(value for _, value in at_limit.shown) % 2 == 1
    beyond = solver.solve([(_parity(13), True)])
    assert (beyond.kind, beyond.size) == (solver.Verdict.UNKNOWN, 2 * solver.LIMIT)
    never = solver.solve([(_parity(2), True), (_parity(2), False)])
    assert (never.kind, never.size) == (solver.Verdict.NO, 4)


# ---------------------------------------------------------------- the miner

MINER = REPO / "specs" / "miner"

# Every finding on specs/miner: no errors. Update this list when the miner changes, after
# reading each new finding (the counter-examples of the W501s are checked below).
MINER_FINDINGS = [
    (
        "bm.yaml",
        "W503",
        "LOWER S1 waits when world.boom_angle=-8.5: no rule fires then",
    ),
    (
        "bm.yaml",
        "W503",
        "RAISE S1 waits when world.boom_angle=28.5: no rule fires then",
    ),
    (
        "co.yaml",
        "W501",
        (
            "rules 1 and 2 of SUMP_SHEAR_CUSP S2 both hold when "
            "world.popped_out_of_shear=true, world.loose_coal=5.0; rule 1 wins "
            "(first_match)"
        ),
    ),
    (
        "co.yaml",
        "W501",
        (
            "rules 1 and 3 of SUMP_SHEAR_CUSP S2 both hold when "
            "world.popped_out_of_shear=true, world.loose_coal=4.0, cc.command=HALT;"
            " rule 1 wins (first_match)"
        ),
    ),
    (
        "co.yaml",
        "W501",
        (
            "rules 2 and 4 of SUMP_SHEAR_CUSP S2 both hold when "
            "world.loose_coal=5.0, cr.status=DONE, vg.status=DONE, cc.status=DONE, "
            "world.popped_out_of_shear=false; rule 2 wins (first_match)"
        ),
    ),
    (
        "co.yaml",
        "W501",
        (
            "rules 3 and 4 of SUMP_SHEAR_CUSP S2 both hold when "
            "world.loose_coal=4.0, cc.command=HALT, cr.status=DONE, vg.status=DONE,"
            " cc.status=DONE, world.popped_out_of_shear=false; rule 3 wins "
            "(first_match)"
        ),
    ),
    (
        "co.yaml",
        "W503",
        "SUMP_SHEAR_CUSP S1 waits when cc.status=ERROR: no rule fires then",
    ),
    (
        "co.yaml",
        "W503",
        (
            "SUMP_SHEAR_CUSP S2 waits when world.popped_out_of_shear=false, "
            "world.loose_coal=4.0, cc.command=INIT, cc.status=ERROR: no rule fires "
            "then"
        ),
    ),
    (
        "co.yaml",
        "W503",
        "SUMP_SHEAR_CUSP S3 waits when cc.status=ERROR: no rule fires then",
    ),
    (
        "co.yaml",
        "W503",
        "SUMP_SHEAR_CUSP S4 waits when cc.status=ERROR: no rule fires then",
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S1 waits on cc but never handles cc.status == ERROR: "
            "an ERROR from cc leaves co waiting in S1 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S1 waits on vg but never handles vg.status == ERROR: "
            "an ERROR from vg leaves co waiting in S1 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S2 waits on cc but never handles cc.status == ERROR: "
            "an ERROR from cc leaves co waiting in S2 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S2 waits on cr but never handles cr.status == ERROR: "
            "an ERROR from cr leaves co waiting in S2 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S2 waits on vg but never handles vg.status == ERROR: "
            "an ERROR from vg leaves co waiting in S2 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S3 waits on cc but never handles cc.status == ERROR: "
            "an ERROR from cc leaves co waiting in S3 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S3 waits on cr but never handles cr.status == ERROR: "
            "an ERROR from cr leaves co waiting in S3 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S3 waits on vg but never handles vg.status == ERROR: "
            "an ERROR from vg leaves co waiting in S3 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S4 waits on cc but never handles cc.status == ERROR: "
            "an ERROR from cc leaves co waiting in S4 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S4 waits on cr but never handles cr.status == ERROR: "
            "an ERROR from cr leaves co waiting in S4 forever"
        ),
    ),
    (
        "co.yaml",
        "W506",
        (
            "SUMP_SHEAR_CUSP S4 waits on vg but never handles vg.status == ERROR: "
            "an ERROR from vg leaves co waiting in S4 forever"
        ),
    ),
    (
        "cr.yaml",
        "W503",
        (
            "CUSP S1 waits when gh.status=DONE, cv.status=DONE, "
            "world.loose_coal=1.05: no rule fires then"
        ),
    ),
    (
        "cr.yaml",
        "W503",
        "SHEAR S1 waits when world.loose_coal=0.05, gh.command=INIT: no rule fires then",
    ),
    (
        "cr.yaml",
        "W503",
        (
            "SHEAR S2 waits when gh.status=DONE, cv.status=DONE, "
            "world.loose_coal=1.05: no rule fires then"
        ),
    ),
    (
        "cr.yaml",
        "W505",
        (
            "SUMP S0 sends ct.POSITION_TAIL but never waits for it: no state "
            "reached afterwards tests ct.status"
        ),
    ),
    (
        "ct.yaml",
        "W503",
        ("POSITION_TAIL S1 waits when world.tail_in_position=false: no rule fires then"),
    ),
    (
        "sj.yaml",
        "W503",
        "LOWER S1 waits when world.jack_down=false: no rule fires then",
    ),
    (
        "sj.yaml",
        "W503",
        "RAISE S1 waits when world.jack_down=true: no rule fires then",
    ),
]


def test_the_miner_has_no_findings_but_these_acknowledged_ones() -> None:
    """Every finding on the miner is intended and acknowledged in its spec with a reason
    (`allow:`, or `first_match` for the overlaps of co's Appendix C table)."""
    front = compile_paths([MINER])
    assert list(front.diagnostics) == []
    diags = front.diagnostics.acknowledged
    assert all(d.acknowledged for d in diags)
    assert sorted((Path(d.span.file).name, d.code, d.message) for d in diags) == sorted(
        MINER_FINDINGS
    )
    overlaps = [d for d in diags if d.code == "W501"]
    assert overlaps, "co's SUMP_SHEAR_CUSP S2 relies on first_match"
    for d in overlaps:
        assert_fires_both(MINER, Path(d.span.file).stem, d.message)


# ---------------------------------------------------------------- against brute force


def _random_guard(rnd: random.Random, depth: int = 0) -> str:
    """A random guard over booleans, a status, a command, an int, a float and a linear form."""
    if depth < 2 and rnd.random() < 0.45:
        op = rnd.choice(["and", "or"])
        parts = [_random_guard(rnd, depth + 1) for _ in range(rnd.randint(2, 3))]
        return f"({f' {op} '.join(parts)})"
    if depth < 3 and rnd.random() < 0.15:
        return f"not {_random_guard(rnd, depth + 1)}"
    kind = rnd.randrange(6)
    if kind == 0:
        return rnd.choice(["world.hot", "world.cold"])
    if kind == 1:
        op = rnd.choice(["==", "!="])
        return f"a.status {op} {rnd.choice(['EXECUTING', 'DONE', 'ERROR'])}"
    if kind == 2:
        return f"a.command {rnd.choice(['==', '!='])} {rnd.choice(['INIT', 'HALT', 'GO'])}"
    op = rnd.choice(["<", "<=", ">", ">=", "==", "!="])
    if kind == 3:
        return f"ticks {op} {rnd.randint(0, 4)}"
    if kind == 4:
        return f"world.level {op} {rnd.choice(['1.0', '2.5', 'LIMIT', 'LIMIT - 1.5'])}"
    return f"world.x {op} world.y + {rnd.choice(['0.0', '1.5'])}"


GRID = {  # name in the guard text -> values meeting every region of the constants used
    "world.hot": {"hot": (False, True)},
    "world.cold": {"cold": (False, True)},
    "a.status": {"status": ("EXECUTING", "DONE", "ERROR")},
    "a.command": {"command": ("INIT", "HALT", "GO")},
    "ticks": {"ticks": tuple(range(-1, 7))},
    "world.level": {"level": (0.0, 1.0, 1.5, 2.5, 3.0, 4.0, 5.0)},
    "world.x": {"x": (0.0, 0.75, 1.5, 3.0), "y": (0.0, 1.5)},
}


def _brute_force(guards: list[tuple[str, bool]]) -> bool:
    """Whether some grid point gives each guard its wanted truth value, evaluated by Python."""
    from types import SimpleNamespace

    axes = {"hot": (False,), "cold": (False,), "status": ("DONE",), "command": ("GO",)}
    axes.update(ticks=(0,), level=(0.0,), x=(0.0,), y=(0.0,))
    for name, values in GRID.items():
        if any(name in text for text, _ in guards):
            axes.update(values)
    code = [(compile(text, "<guard>", "eval"), wanted) for text, wanted in guards]
    env: dict[str, Any] = {n: n for n in ("EXECUTING", "DONE", "ERROR", "INIT", "HALT", "GO")}
    env["LIMIT"] = 4.0
    for hot, cold, status, command, ticks, level, x, y in itertools.product(*axes.values()):
        env["world"] = SimpleNamespace(hot=hot, cold=cold, level=level, x=x, y=y)
        env["a"] = SimpleNamespace(status=status, command=command)
        env["ticks"] = ticks
        if all(bool(eval(c, {}, env)) == wanted for c, wanted in code):  # noqa: S307
            return True
    return False


def test_decisions_agree_with_brute_force() -> None:
    """On random guards, "yes" and "no" agree with Python evaluating every grid point; with
    independent forms of floats nothing is left undecided."""
    scope = X.Scope(
        world={"hot": BOOL, "cold": BOOL, "level": FLOAT, "x": FLOAT, "y": FLOAT},
        world_access=frozenset({"hot", "cold", "level", "x", "y"}),
        locals={"ticks": INT},
        constants={"LIMIT": 4.0},
        subordinates={"a": frozenset({"INIT", "HALT", "GO"})},
    )
    compiler = analysis.GuardBuilder({"LIMIT": 4.0}, {}, {"a": ("INIT", "HALT", "GO")})
    rnd = random.Random(20260501)
    kinds: Counter[str] = Counter()
    for _ in range(500):
        texts = [_random_guard(rnd) for _ in range(rnd.randint(1, 4))]
        wanted = [rnd.random() < 0.6 for _ in texts]
        trees = [X.compile_expr(t, Span("t"), scope, Diagnostics(), BOOL) for t in texts]
        answer = solver.solve(
            [(compiler.guard(tree), w) for tree, w in zip(trees, wanted, strict=True)]
        )
        kinds[answer.kind] += 1
        truth = _brute_force(list(zip(texts, wanted, strict=True)))
        assert answer.kind in ("yes", "no"), (texts, wanted, answer)
        assert (answer.kind == "yes") == truth, (texts, wanted, answer)
    assert kinds["yes"] > 50 and kinds["no"] > 50, kinds


_RENAMED = {  # each name of _random_guard's guards -> another, in the same sorted order
    r"world\.hot\b": "world.heat",
    r"world\.cold\b": "world.chill",
    r"world\.level\b": "world.depth",
    r"world\.x\b": "world.p",
    r"world\.y\b": "world.q",
    r"\ba\.": "b.",
    r"\bticks\b": "count",
}


def test_questions_alike_but_for_names_get_the_answer_solve_gives_each() -> None:
    """`Questions` solves a question once for every question alike but for its atoms' names:
    on random questions, each also asked with every name changed, its answer (verdict,
    counter-example, size, atoms undecided) is exactly what `solve` gives that question, and
    the renamed questions were not solved again."""
    scopes, builders = [], []
    for hot, cold, level, x, y, sub, ticks in [
        ("hot", "cold", "level", "x", "y", "a", "ticks"),
        ("heat", "chill", "depth", "p", "q", "b", "count"),
    ]:
        floats = {level: FLOAT, x: FLOAT, y: FLOAT}
        world: dict[str, Type] = {hot: BOOL, cold: BOOL, **floats}
        scopes.append(
            X.Scope(
                world=world,
                world_access=frozenset(world),
                locals={ticks: INT},
                constants={"LIMIT": 4.0},
                subordinates={sub: frozenset({"INIT", "HALT", "GO"})},
            )
        )
        builders.append(analysis.GuardBuilder({"LIMIT": 4.0}, {}, {sub: ("INIT", "HALT", "GO")}))
    questions = solver.Questions()
    rnd = random.Random(20261127)
    for _ in range(80):
        texts = [_random_guard(rnd) for _ in range(rnd.randint(1, 3))]
        renamed = list(texts)
        for pattern, name in _RENAMED.items():
            renamed = [re.sub(pattern, name, t) for t in renamed]
        wanted = [rnd.random() < 0.6 for _ in texts]
        before = len(questions.answers)
        for scope, builder, guards in zip(scopes, builders, (texts, renamed), strict=True):
            trees = [X.compile_expr(t, Span("t"), scope, Diagnostics(), BOOL) for t in guards]
            parts: list[solver.Part] = [
                (builder.guard(tree), w) for tree, w in zip(trees, wanted, strict=True)
            ]
            assert questions.solve(parts) == solver.solve(parts), (guards, wanted)
        assert len(questions.answers) <= before + 1, (texts, "asked again under other names")
    assert questions.asked == 160
    assert len(questions.answers) < 80


def test_questions_alike_but_for_a_value_type_or_wanted_truth_are_not_shared() -> None:
    """`True` and `1` are equal in Python, but a counter-example shows them differently
    (`true`, `1`): a question over a boolean is not answered with an int's counter-example;
    nor is a guard wanted false answered as the same guard wanted true."""
    key: solver.Key = ("local", "v")
    term = (solver.Op.GET, key)
    questions = solver.Questions()
    for domain in [(False, True), (0, 1)]:
        guard = solver.Guard(solver.compiled(term), {key: domain}, order={key: None}, term=term)
        for wanted, value in [(True, domain[1]), (False, domain[0])]:
            answer = questions.solve([(guard, wanted)])
            assert answer.shown == [(key, value)]
            assert type(answer.shown[0][1]) is type(value)
    assert len(questions.answers) == 4


def test_a_reason_is_read_only_with_an_error_and_shown_by_its_name(spec) -> None:
    """A subordinate's reason comes only with its ERROR (NONE otherwise): the valuation
    that fires both rules says the status that goes with the reason, by their names."""
    spec("GO:\n  states:\n    S0:\n      - do: [report: DONE]\n")
    assert overlap(spec, "a.reason == JAMMED", "not world.cold") == (
        "rules 1 and 2 of GO S1 can both fire: "
        "both hold when a.status=ERROR, a.reason=JAMMED, world.cold=false"
    )
    # no valuation has a reason with a status other than ERROR
    assert overlap(spec, "a.reason == JAMMED", "a.status != ERROR") is None
    assert overlap(spec, "a.reason == NONE", "a.status == DONE") is not None


def overlap(spec, first: str, second: str) -> str | None:
    """The E501/W501 message of two rules with these guards, None if they cannot both fire
    (a.GO may end in ERROR for the reason JAMMED)."""
    shutil.rmtree("sys")
    directory = make(
        Path("."),
        f"""
        GO:
          states:
            S0:
              - do: [send: a.GO]
                next: S1
            S1:
              - when: {first}
                do: [report: DONE]
              - when: {second}
                next: S0
        """,
    )
    leaf = directory / "a.yaml"
    leaf.write_text(leaf.read_text().replace("  GO:\n", "  GO:\n    reasons: [JAMMED]\n"))
    front = compile_paths([directory])
    diags = [*front.diagnostics, *front.diagnostics.acknowledged]
    assert not [d for d in diags if d.severity == "error" and d.code != "E501"], diags
    return next((d.message for d in diags if d.code in ("E501", "W501")), None)


@pytest.mark.parametrize(
    ("first", "overlaps"),
    [
        ("+world.level > 3.0", False),  # a unary plus scales by one
        ("+world.level > 1.5", True),
        ("-world.level < -3.0", False),  # a unary minus by minus one
        ("-world.level < -1.5", True),
        ("world.level / 2.0 > 1.0", False),  # level > 2
        ("world.level / 2.0 > 0.5", True),
        ("world.level > 7 // 2", False),  # 3
        ("world.level > 7 % 6", True),  # 1
        ("2.0 * world.level > 3.0", True),  # level > 1.5
        ("world.level * 2.0 > 5.0", False),  # level > 2.5
        ("world.level * 2.0 > 3.0", True),
        ("-world.level != -1.0", True),  # a negative lead keeps != as it is
        ("-world.level == -3.0", False),
    ],
)
def test_linear_forms_keep_their_exact_coefficients(spec, first: str, overlaps: bool) -> None:
    """Each of these against `world.level <= 2.0`: the bound the analysis derives is the
    exact one, so the rules overlap just when Python's arithmetic says they can."""
    spec("GO:\n  states:\n    S0:\n      - do: [report: DONE]\n")
    assert (overlap(spec, first, "world.level <= 2.0") is not None) is overlaps


def test_a_rule_that_never_fires_is_not_told_to_wait_for_what_it_sends(spec) -> None:
    """W505 (sent but never waited for) is about rules that can fire: one whose guard no
    valuation makes true is reported as such, and its send is not."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: world.level > 3.0 and world.level < 2.0
                do: [send: b.GO]
                next: S1
              - when: not (world.level > 3.0 and world.level < 2.0)
                do: [send: a.GO]
                next: S1
            S1:
              - when: a.status == DONE
                do: [report: DONE]
        """
    )
    assert "W505" not in codes(diags), found(diags)
    assert any("rule 1 of GO S0" in d.message for d in diags), found(diags)


def test_a_guard_repeated_in_a_controller_is_built_once_its_constants_as_written(
    tmp_path: Path,
) -> None:
    """The analysis builds a controller's guard once for every rule that repeats it, in
    any table; guards written otherwise stay two, each with its own text, even when
    their trees compare equal (a constant -0.0 and 0.0)."""
    directory = make(
        tmp_path,
        """
        GO:
          states:
            S0:
              - when: a.status == DONE and world.x * world.y > 0.0
                next: S1
              - when: a.status == DONE and world.x * world.y > -0.0
                next: S1
            S1:
              - when: a.status == DONE and world.x * world.y > 0.0
                do: [report: DONE]
        STOP:
          states:
            S0:
              - when: a.status == DONE and world.x * world.y > 0.0
                do: [report: DONE]
        """,
    )
    system, controllers = models(directory)
    checked = check_system(system, controllers, Diagnostics())
    assert checked is not None
    top = checked.controllers["top"]
    controller = analysis._Controller(top, Diagnostics(), solver.Questions())
    go, stop = (controller.table(top.commands[name]) for name in ("GO", "STOP"))
    first, negative = (rule.guard for rule in go["S0"])
    assert go["S1"][0].guard is first and stop["S0"][0].guard is first
    assert first is not None and negative is not None and negative is not first
    assert list(first.opaque) == [(analysis.Atom.OPAQUE, "world.x * world.y > 0.0")]
    assert list(negative.opaque) == [(analysis.Atom.OPAQUE, "world.x * world.y > -0.0")]
    x = X.Ref(FLOAT, X.RefKind.WORLD, "x")
    zero, minus_zero = (X.Compare(BOOL, x, (">",), (X.Const(FLOAT, v),)) for v in (0.0, -0.0))
    assert zero == minus_zero  # (the trees compare by value: the key must not)
    assert analysis._exact(zero) != analysis._exact(minus_zero)


def test_a_constant_on_the_left_is_compared_as_written_and_a_for_rule_waits_its_time(
    spec,
) -> None:
    """`2.0 < world.x` is `world.x > 2.0`: each comparison with its sides swapped (the
    analysis puts the variable first) decides as written; and a `for:` rule's counter, like
    `after:`'s time, is read once its time has come, so S2 does not wait."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: 2.0 < world.x
                do: [report: DONE]
              - when: 1.0 >= world.x
                do: [report: ERROR]
              - when: 2.0 == world.x
                next: S1
            S1:
              - when: 1.0 > world.x
                do: [report: DONE]
              - when: 1.0 <= world.x
                do: [report: ERROR]
              - when: 3.0 != world.x
                next: S2
            S2:
              - when: world.hot
                for: 3 cycles
                do: [report: DONE]
              - when: not world.hot
                do: [report: ERROR]
        """
    )
    third = at("        - |when: 3.0 != world.x")
    assert found(diags) == [
        (at("      |S0:"), "W503", "GO S0 waits when world.x=1.5: no rule fires then"),
        (third, "E501", "rules 1 and 3 of GO S1 can both fire: both hold when world.x=0.0"),
        (third, "E501", "rules 2 and 3 of GO S1 can both fire: both hold when world.x=1.0"),
        (
            third,
            "W512",
            "rule 3 of GO S1 never fires: whenever its guard holds, an earlier rule (1, 2) "
            "fires first",
        ),
    ]


def test_abs_min_max_and_a_minus_sign_are_decided_as_python_computes_them(spec) -> None:
    """`abs(x)` is `x if x >= 0 else -x`, `min`/`max` of three the first two then the third,
    `-x > 1.0` is `x < -1.0`: each written out, they decide exactly (E501's witness, S1
    complete, S2's first two rules impossible since a min with 1.0 is at most 1.0)."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: abs(world.x) > 1.0
                do: [report: DONE]
              - when: world.x < -2.0
                do: [report: ERROR]
              - when: abs(world.x) <= 1.0
                next: S1
            S1:
              - when: -world.x > 1.0
                do: [report: DONE]
              - when: world.x >= -1.0
                next: S2
            S2:
              - when: min(world.x, world.y, 1.0) > 2.0
                do: [report: DONE]
              - when: max(world.x, world.y, 1.0) < 0.0
                do: [report: ERROR]
              - when: world.x > 0.0
                next: S0
        """
    )
    second = at("        - |when: world.x < -2.0")
    assert found(diags) == [
        (second, "E501", "rules 1 and 2 of GO S0 can both fire: both hold when world.x=-3.0"),
        (
            second,
            "W512",
            "rule 2 of GO S0 never fires: whenever its guard holds, an earlier rule (1) fires "
            "first",
        ),
        (
            at("      |S2:"),
            "W503",
            "GO S2 waits when (world.x - world.y)=0.0, world.x=0.0: no rule fires then",
        ),
        (
            at("        - |when: min(world.x"),
            "W512",
            "rule 1 of GO S2 never fires: its guard can never hold",
        ),
        (
            at("        - |when: max(world.x"),
            "W512",
            "rule 2 of GO S2 never fires: its guard can never hold",
        ),
    ]


def test_a_scaled_variable_and_a_min_of_constants_keep_their_exact_bounds(spec) -> None:
    """`2.0 * world.x > 3.0` is `world.x > 1.5` (the bound divided by the coefficient), and
    `min(2.0, 3.0)` is 2.0: the two rules overlap between them, and only there."""
    diags = spec(
        """
        GO:
          states:
            S0:
              - when: 2.0 * world.x > 3.0
                do: [report: DONE]
              - when: world.x < min(2.0, 3.0)
                do: [report: ERROR]
        """
    )
    assert found(diags) == [
        (
            at("        - |when: world.x < min"),
            "E501",
            "rules 1 and 2 of GO S0 can both fire: both hold when world.x=1.75",
        )
    ]


def test_a_form_names_its_variables_in_key_order_as_the_spec_spells_them() -> None:
    """A comparison of several variables becomes one form, its variables in key order (a
    local before a subordinate's result before a world field) with the first's coefficient
    1, each shown as the spec spells it: the text a counter-example shows."""
    scope = X.Scope(
        world={"level": FLOAT},
        world_access=frozenset({"level"}),
        locals={"ticks": INT},
        subordinates={"a": frozenset({"INIT", "HALT", "GO"})},
        sub_results={"a": {"n": FLOAT}},
    )
    builder = analysis.GuardBuilder({}, {}, {"a": ("INIT", "HALT", "GO")})
    shown = []
    for text in ("a.result.n > ticks + 1", "world.level < 2 * a.result.n", "a.status == DONE"):
        tree = X.compile_expr(text, Span("t"), scope, Diagnostics(), BOOL)
        shown += [analysis.show_key(key) for key in builder.guard(tree).order]
    assert shown == ["(ticks - a.result.n)", "(a.result.n - 0.5*world.level)", "a.status"]
