"""Hooks at run time: every call's result is checked, and a hook that raises or returns the
wrong values is one error naming the module, the hook, the spec line and the cycle.

Uses tests/cases/valid/hooked: top's GO calls `nudge` (returns world.level, a float) and
`split` (returns n, an int, and world.level) in S0, with a hook-state factory.
"""

from __future__ import annotations

import faulthandler
import shutil
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import pytest
from click.testing import CliRunner
from conftest import REPO, rcsgen

from rcsgen.cli import main
from rcsgen.tools.harness import Harness

HOOKED = REPO / "tests" / "cases" / "valid" / "hooked"
SCENARIO = """\
scenario: go
title: GO once
max_cycles: 20
stop_when_done: top
events:
  - cycle: 2
    command: top.GO
"""


@pytest.fixture
def hooked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copytree(HOOKED, tmp_path / "sys", ignore=shutil.ignore_patterns("__pycache__"))
    (tmp_path / "sys" / "scenarios").mkdir()
    (tmp_path / "sys" / "scenarios" / "go.yaml").write_text(SCENARIO)
    monkeypatch.chdir(tmp_path)
    return tmp_path / "sys"


def hooks_with(directory: Path, old: str, new: str) -> None:
    path = directory / "tiny_hooks" / "top.py"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def run_go(directory: Path) -> None:
    with Harness.build(directory, send_init=True) as h:
        h.cycle()
        h.command("top", "GO")
        h.cycle(3)


def test_the_hooked_system_runs(hooked: Path) -> None:
    run_go(hooked)


@pytest.mark.parametrize(
    "old, new, problem",
    [
        (
            "return whole, level - whole",
            "return level - whole, whole",
            "hook `split` of `top` returned (0.0, 1); its `returns:` needs a tuple of 2 values "
            "(int, finite float)",
        ),
        (
            "return whole, level - whole",
            "values = whole, level - whole, 0  # (a literal tuple of 3 fails validation)\n"
            "    return values",
            "hook `split` of `top` returned (1, 0.0, 0); its `returns:` needs a tuple of 2 "
            "values (int, finite float)",
        ),
        (
            "return whole, level - whole",
            "return [whole, level - whole]",
            "hook `split` of `top` returned [1, 0.0]; its `returns:` needs a tuple of 2 values",
        ),
        (
            "return whole, level - whole",
            "return 2**70, 0.0",
            "returned (1180591620717411303424, 0.0)",
        ),
        (
            "    return n * state[0]",
            "    return True",
            "returned True; its `returns:` needs a finite float",
        ),
        (
            "return whole, level - whole",
            'return whole, float("nan")',
            "returned (1, nan); its `returns:` needs a tuple of 2 values (int, finite float)",
        ),
        (
            "return whole, level - whole",
            'return whole, -float("inf")',
            "returned (1, -inf); its `returns:` needs a tuple of 2 values (int, finite float)",
        ),
        (
            "return whole, level - whole",
            "return whole, 10**400",
            "returned (1, 1000000000",
        ),
    ],
    ids=["order", "arity", "list", "int-overflow", "bool-for-float", "nan", "inf", "huge"],
)
def test_a_result_that_does_not_fit_is_a_hook_error(
    hooked: Path, old: str, new: str, problem: str
) -> None:
    hooks_with(hooked, old, new)
    hooks_with(hooked, "    if not flag:\n        return 0.0\n", "")
    with pytest.raises(Exception) as caught:
        run_go(hooked)
    assert type(caught.value).__name__ == "HookError"
    assert problem in str(caught.value)
    assert "(rule GO/S0/1, cycle 2)" in str(caught.value)


def test_an_int_for_a_float_target_is_accepted(hooked: Path) -> None:
    hooks_with(
        hooked, "    if not flag:\n        return 0.0\n", "    if not flag:\n        return 0\n"
    )
    run_go(hooked)


def test_a_hook_that_raises_is_one_error_at_the_call(hooked: Path) -> None:
    hooks_with(hooked, "    whole = int(level)\n", "    whole = int(level) // 0\n")
    result = rcsgen("build", "sys", "-o", "gen")
    assert result.exit_code == 0, result.output
    ran = rcsgen("run", "sys/scenarios/go.yaml", "--generated", "gen")
    assert ran.exit_code == 1
    errors = [line for line in ran.output.splitlines() if "error[" in line]
    assert errors == [
        "sys/top.yaml:42:21: error[E420]: hook `split` of `top` raised ZeroDivisionError: "
        "integer division or modulo by zero (rule GO/S0/1, cycle 2)"
    ]
    assert "Traceback" not in ran.output
    verbose = CliRunner().invoke(main, ["run", "sys/scenarios/go.yaml", "--generated", "gen", "-v"])
    assert verbose.exit_code == 1
    assert "Traceback (most recent call last)" in verbose.output
    assert 'tiny_hooks/top.py", line 17, in split' in verbose.output


def test_a_factory_that_raises_is_reported_at_start_up(hooked: Path) -> None:
    hooks_with(hooked, 'float(settings.get("scale", "1"))', 'float(settings["scale"])')
    assert rcsgen("build", "sys", "-o", "gen").exit_code == 0
    ran = rcsgen("run", "sys/scenarios/go.yaml", "--generated", "gen")
    assert ran.exit_code == 1
    assert (
        "error[E420]: hook `new_state` of `top` raised KeyError: 'scale' "
        "(made by `hooks_state`, start-up)" in ran.output
    )


def test_a_wrong_result_names_the_call_and_what_returns_needs(hooked: Path) -> None:
    hooks_with(hooked, "return whole, level - whole", "return level")
    assert rcsgen("build", "sys", "-o", "gen").exit_code == 0
    ran = rcsgen("run", "sys/scenarios/go.yaml", "--generated", "gen")
    assert ran.exit_code == 1
    assert (
        "sys/top.yaml:42:21: error[E421]: hook `split` of `top` returned 0.0; its `returns:` "
        "needs a tuple of 2 values (int, finite float) (rule GO/S0/1, cycle 2)" in ran.output
    )


@pytest.mark.parametrize(
    ("kinds", "value", "fits"),
    [
        ("f", 1.5, True),
        ("f", 2, True),  # an int, as in spec expressions
        ("f", Fraction(1, 3), True),  # any real number
        ("f", True, False),  # never a bool
        ("f", float("nan"), False),
        ("f", float("inf"), False),
        ("f", "1.0", False),
        ("i", 2**63 - 1, True),
        ("i", 2**63, False),
        ("i", 1.0, False),
        ("i", False, False),
        ("b", False, True),
        ("b", 0, False),
        ("e3", 2, True),
        ("e3", 3, False),
        ("e3", -1, False),
        ("s4", "abcd", True),
        ("s4", "abcde", False),
        ("s4", "a\0", False),
        ("ff", (1.0, 2), True),
        ("ff", [1.0, 2.0], False),  # a tuple, exactly
        ("ff", (1.0,), False),
        ("ff", (1.0, 2.0, 3.0), False),
        ("fi", (1.0, 2.5), False),
    ],
)
def test_one_runtime_check_decides_what_fits_a_hooks_targets(
    kinds: str, value: object, fits: bool
) -> None:
    """Every generated hook call checks its result with the runtime's `result_fits` (one
    place for what a target of each type accepts), and the generated code names no check."""
    from rcsgen.runtime.contract import result_fits

    assert result_fits(kinds)(value) is fits
    text = (REPO / "generated" / "miner" / "co.py").read_text()
    assert (
        'hook_co_position_for_sump = hook("co", hooks, "co_position_for_sump", 1.0, "ff")' in text
    )
    assert "returned" not in text and "is_real" not in text


def test_the_fast_check_of_a_usual_result_agrees_with_the_check_value_by_value() -> None:
    """A tuple of exactly float/int/bool is accepted without a call per value: for every
    mix of awkward values (NaN, infinities, sums that overflow, ints at and past int64,
    bools for ints, ints for floats, a Fraction) the answer is the one of each target's own
    test, value by value."""
    from itertools import product

    from rcsgen.runtime.contract import kind_fits, result_fits

    big = 1.7e308
    values = [0.5, -big, big, float("nan"), float("inf"), -float("inf"), 3, 2**63 - 1]
    values += [-(2**63), 2**63, -(2**63) - 1, True, False, Fraction(1, 3)]
    for kinds in ("ff", "if", "fib", "bfff"):
        tests = [kind_fits(token) for token in kinds]
        for value in product(values, repeat=len(kinds) if len(kinds) < 4 else 2):
            value = value + (1.0,) * (len(kinds) - len(value))
            expected = all(test(v) for test, v in zip(tests, value, strict=True))
            assert result_fits(kinds)(value) is expected, (kinds, value)


def test_other_numeric_types_that_are_numbers_are_accepted(hooked: Path) -> None:
    """A Fraction (like a numpy float) is a real number: fine for a float target; a bool is
    not a number there, and not an int either."""
    hooks_with(hooked, "    if not flag:\n        return 0.0\n", "")
    hooks_with(hooked, "    return n * state[0]\n", "    return Fraction(n) * 2\n")
    hooks_with(
        hooked,
        "from __future__ import annotations\n",
        "from __future__ import annotations\n\nfrom fractions import Fraction\n",
    )
    run_go(hooked)


# ---------------------------------------------------------------- hooks that lie or hang


@pytest.fixture
def bounded() -> Iterator[None]:
    """A backstop for the tests of hooks that never return: should the deadline fail, the
    test process dumps its threads and exits after two minutes instead of hanging."""
    faulthandler.dump_traceback_later(120, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


@pytest.mark.parametrize(
    "body",
    [
        "    import time\n    time.sleep(3600)\n",  # blocked in a system call
        "    while True:\n        try:\n            while True:\n                pass\n"
        "        except BaseException:\n            pass\n",  # swallows the first interruption
    ],
    ids=["sleeps", "swallows"],
)
def test_a_hook_is_interrupted_wherever_it_waits(hooked: Path, body: str, bounded: None) -> None:
    """In the harness (the main thread): interrupted in a sleep, and again and again while it
    swallows the interruption, until it gives up; its result is never used."""
    hooks_with(hooked, "    whole = int(level)\n", body + "    whole = int(level)\n")
    top = hooked / "top.yaml"
    top.write_text(
        top.read_text().replace(
            "    returns: [n, world.level]\n", "    returns: [n, world.level]\n    deadline: 0.1\n"
        )
    )
    if "swallows" in body or "except BaseException" in body:
        hooks_with(
            hooked,
            "        except BaseException:\n            pass\n",
            "        except BaseException:\n            break\n",
        )
        hooks_with(hooked, "    while True:\n        try:", "    for _ in range(3):\n        try:")
    with pytest.raises(Exception) as caught:
        run_go(hooked)
    assert type(caught.value).__name__ == "HookError"
    assert "deadline of 0.1 s" in str(caught.value)


def test_the_default_deadline_is_five_periods_and_at_least_a_second(hooked: Path) -> None:
    """tiny runs at 0.1 s: 5 periods are 0.5 s, so a hook gets the 1 s floor; a declared
    deadline in cycles is that many periods."""
    text = rcsgen("build", "sys", "-o", "gen")
    assert text.exit_code == 0, text.output
    module = (hooked.parent / "gen" / "tiny" / "top.py").read_text()
    assert 'hook_nudge = hook("top", hooks, "nudge", 1.0, "f")' in module
    assert 'hook_split = hook("top", hooks, "split", 1.0, "if")' in module
    top = hooked / "top.yaml"
    top.write_text(
        top.read_text().replace(
            "    returns: [n, world.level]\n",
            "    returns: [n, world.level]\n    deadline: 30 cycles\n",
        )
    )
    assert rcsgen("build", "sys", "-o", "gen").exit_code == 0
    module = (hooked.parent / "gen" / "tiny" / "top.py").read_text()
    assert 'hook_split = hook("top", hooks, "split", 3.0, "if")' in module
