"""The command contract (rcsgen/runtime/command.py), as a property: `ctl send` with random
parameter text never writes anything invalid into the block.

The fixture system (tests/fixtures/runtime/every_type) has one command, TAKE, with a
parameter of every type: bool, int, float, enum (LEFT, RIGHT) and str of 8 bytes. Each
example sends TAKE through the package's own console (`ctl send`, in this process, on a
segment of its own) with parameters drawn from text that is valid, nearly valid or anything
at all, sometimes one missing, repeated or unknown. The oracle below says, independently of
the contract's code, which sends are valid: those must be written exactly (exit 0); every
other one must leave the command buffer's bytes as they were and say why in one line
(exit 2).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rcsgen.tools.harness import generate, import_package

EVERY_TYPE = Path(__file__).resolve().parent / "fixtures" / "runtime" / "every_type"
EXAMPLES = int(os.environ.get("CONTRACT_EXAMPLES", "400"))
INT64 = (-(2**63), 2**63 - 1)

# ---------------------------------------------------------------- the oracle


def valid(kind: str, raw: str) -> bool:
    """Whether an operator's text is a value of this parameter (docs/semantics.md)."""
    if kind == "flag":
        return raw in ("true", "false")
    if kind == "count":
        return bool(re.fullmatch(r"[+-]?[0-9]+", raw, re.ASCII)) and (
            INT64[0] <= int(raw) <= INT64[1]
        )
    if kind == "level":
        number = r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?"
        return bool(re.fullmatch(number, raw, re.ASCII)) and math.isfinite(float(raw))
    if kind == "side":
        return raw in ("LEFT", "RIGHT")
    try:
        data = raw.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return "\0" not in raw and len(data) <= 8


def expected(kind: str, raw: str) -> object:
    """What the block holds for a valid value."""
    return {
        "flag": lambda: raw == "true",
        "count": lambda: int(raw),
        "level": lambda: float(raw),
        "side": lambda: ["LEFT", "RIGHT"].index(raw),
        "label": lambda: raw,
    }[kind]()


# ---------------------------------------------------------------- the strategies

TRICKY = [
    "",
    " ",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "1e999",
    "-1e999",
    "1e308",
    "1_000",
    "0x10",
    " 1",
    "1 ",
    "+1",
    "-0",
    "1.",
    ".5",
    "1e",
    "١٢",  # Arabic-Indic digits: int() takes them
    str(2**63),
    str(-(2**63) - 1),
    str(2**63 - 1),
    "True",
    "TRUE",
    "1",
    "0",
    "yes",
    "left",
    "LEFT ",
    "LEFTT",
    "\0",
    "a\0b",
    "\udc80",  # a byte of argv that is not UTF-8
    "12345678",
    "123456789",
    "ééééé",  # 10 bytes
    "éééé",  # 8 bytes
    "=",
]
VALID = {
    "flag": st.sampled_from(["true", "false"]),
    "count": st.integers(*INT64).map(str),
    "level": st.floats(allow_nan=False, allow_infinity=False).map(repr),
    "side": st.sampled_from(["LEFT", "RIGHT"]),
    "label": st.text(max_size=8).filter(lambda s: valid("label", s)),
}
KINDS = tuple(VALID)


def raw_value(kind: str) -> st.SearchStrategy[str]:
    return st.one_of(st.sampled_from(TRICKY), st.text(max_size=12), VALID[kind])


@st.composite
def sends(draw: st.DrawFn) -> list[tuple[str, str]]:
    """NAME=VALUE pairs: usually each parameter once, sometimes one left out, one given
    twice or a name that is no parameter; in any order."""
    pairs = [(kind, draw(VALID[kind])) for kind in KINDS]
    for _ in range(draw(st.integers(0, 2))):  # one or two values from anywhere
        index = draw(st.integers(0, len(pairs) - 1))
        pairs[index] = (pairs[index][0], draw(raw_value(pairs[index][0])))
    change = draw(st.sampled_from(["none"] * 4 + ["drop", "twice", "unknown"]))
    if change == "drop":
        pairs.pop(draw(st.integers(0, len(pairs) - 1)))
    elif change == "twice":
        kind = draw(st.sampled_from(KINDS))
        pairs.append((kind, draw(raw_value(kind))))
    elif change == "unknown":
        pairs.append((draw(st.sampled_from(["lvl", "Flag", "count2", ""])), "1"))
    return draw(st.permutations(pairs))


# ---------------------------------------------------------------- the system


@pytest.fixture(scope="module")
def system() -> Iterator[tuple[ModuleType, ModuleType, object, str]]:
    scratch, name = generate(EVERY_TYPE)
    package = import_package(scratch / name, EVERY_TYPE)
    layout = __import__(f"{package.__name__}.layout", fromlist=["layout"])
    block_module = __import__(f"{package.__name__}.rcs.block", fromlist=["block"])
    segment = f"rcsgen_contract_{os.getpid()}"
    block = block_module.Block(layout, segment, create=True)
    try:
        yield package, layout, block, segment
    finally:
        block.close()
        shutil.rmtree(scratch, ignore_errors=True)


def ctl(package: ModuleType, *argv: str) -> tuple[int, str, str]:
    """The package's console in this process: its exit code, stdout and stderr."""
    main = __import__(f"{package.__name__}.rcs.ctl", fromlist=["ctl"]).main
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(package.__name__, list(argv))
    return code, out.getvalue(), err.getvalue()


@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(pairs=sends())
def test_nothing_invalid_from_ctl_send_ever_reaches_the_block(
    system: tuple[ModuleType, ModuleType, object, str], pairs: list[tuple[str, str]]
) -> None:
    package, layout, block, segment = system
    record = layout.COMMAND_IN["top"]
    buf = block.buf  # type: ignore[attr-defined]
    size = record.struct.size
    before = bytes(buf[record.offset : record.offset + size])
    code, out, err = ctl(
        package, "--shm", segment, "send", "top", "TAKE", *(f"{k}={v}" for k, v in pairs)
    )
    names = [k for k, _ in pairs]
    ok = sorted(names) == sorted(KINDS) and all(valid(k, v) for k, v in pairs)
    after = bytes(buf[record.offset : record.offset + size])
    if ok:
        assert (code, err) == (0, ""), (pairs, err)
        values = record.read(buf)
        for kind, raw in pairs:
            assert values[f"arg_{kind}"] == expected(kind, raw), (kind, raw)
        assert values["command"] == layout.COMMAND_NAMES["top"].index("TAKE")
        assert out.startswith("sent top.TAKE ")
    else:
        assert code == 2, (pairs, code, out, err)
        assert after == before, f"a refused send changed the block: {pairs}"
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("ctl: error: "), err
        assert "Traceback" not in err


def test_every_tricky_text_in_every_parameter(
    system: tuple[ModuleType, ModuleType, object, str],
) -> None:
    """Each of the tricky texts above in each parameter, the others valid: the property's
    rare cases, every one of them, every run."""
    package, layout, block, segment = system
    record, buf = layout.COMMAND_IN["top"], block.buf  # type: ignore[attr-defined]
    good = {"flag": "true", "count": "7", "level": "2.5", "side": "LEFT", "label": "ok"}
    for kind in KINDS:
        for raw in TRICKY:
            given = {**good, kind: raw}
            before = bytes(buf[record.offset : record.offset + record.struct.size])
            code, _, err = ctl(
                package,
                "--shm",
                segment,
                "send",
                "top",
                "TAKE",
                *(f"{k}={v}" for k, v in given.items()),
            )
            if valid(kind, raw):
                assert code == 0, (kind, raw, err)
                assert record.read(buf)[f"arg_{kind}"] == expected(kind, raw), (kind, raw)
            else:
                assert code == 2 and len(err.splitlines()) == 1, (kind, raw, err)
                assert bytes(buf[record.offset : record.offset + record.struct.size]) == before


def test_a_command_without_parameters_takes_none(
    system: tuple[ModuleType, ModuleType, object, str],
) -> None:
    package, layout, block, segment = system
    assert ctl(package, "--shm", segment, "send", "top", "NOTHING")[0] == 0
    code, _, err = ctl(package, "--shm", segment, "send", "top", "NOTHING", "flag=true")
    assert code == 2 and "top.NOTHING has no parameter 'flag'; parameters: none" in err
