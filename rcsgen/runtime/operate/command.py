"""Command: the one contract a command meets before it reaches a running machine.

An operator gives a module a command from four places: `ctl send`, the monitor's send
form, the launcher's `--send` and a scenario's events. Each of them checks it here, against
the layout (the spec as the running package knows it), before anything is written: the
module exists and is commanded by the operator (not an operator module's channel), the
command is one of its own, every parameter the command declares is given once and only
those, and each value is of its parameter's type and within its range: `true`/`false` for a
bool, a whole number within 64 bits for an int, a finite number for a float (no NaN, no
infinity), one of the value names for an enumeration, a text that fits its size (no NUL)
for a string. A problem is a `ValueError` whose text names what is wrong in one line; the
command line tools turn it into exit 2. `write_command` is the one writer of an operator's
command: numbered after the last one, through the buffer's seqlock; `outcome` is the one
reading of how a module ended a command (DONE or ERROR, the named statuses).

World fields given as text (`--world`, `ctl force`) are parsed and checked by the same
`parse_value`. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import Any, NamedTuple

from ..contract import (
    DONE,
    ERROR,
    INT_MAX,
    INT_MIN,
    STATUS_NAMES,
    StaleRead,
    enum_code,
    listed,
    range_problem,
    shared,
)

# What a number given as text may look like: ASCII digits only (Python's int() and float()
# also take `1_000`, Unicode digits, `nan`, `infinity` and surrounding blanks).
_INT = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


@shared
class Command(NamedTuple):
    """A checked command for a module: every parameter of the command, each of its type (an
    enumeration's value by name)."""

    module: str
    command: str
    args: dict[str, object]

    def __str__(self) -> str:
        args = " ".join(f"{k}={shown(v)}" for k, v in self.args.items())
        return f"{self.module}.{self.command}" + (f" {args}" if args else "")


def shown(value: object) -> str:
    """A value as an operator writes it: `true`, `1.5`, `LEFT`, `bracket`."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def suggest(name: str, choices: Sequence[str], what: str) -> str:
    """`no module 'cx' (did you mean 'co'?); modules: sb, co, ...`."""
    import difflib  # here: only a mistake pays its import, not every process's start

    close = difflib.get_close_matches(name, list(choices), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    plural = f"{what}es" if what.endswith("s") else f"{what}s"
    return f"no {what} {name!r}{hint}; {plural}: {', '.join(choices) or 'none'}"


# ---------------------------------------------------------------- values


def kind_words(code: str, names: Sequence[str] = ()) -> str:
    """What a field of this struct code holds, as the spec says it."""
    if names:
        return f"one of {', '.join(names)}"
    if code.endswith("s"):
        return f"a text of at most {code[:-1]} bytes"
    return {"?": "true or false", "q": "a whole number (64-bit)"}.get(code, "a finite number")


def value_problem(value: object, code: str, names: Sequence[str] = ()) -> str:
    """'' when `value` may go into a field of struct `code` (`?` bool, `q` int, `d` float,
    `Ns` a string of N bytes; with `names` an enumeration, given by value name), else what
    is wrong, as the end of a sentence that starts with the field's name."""
    if names:
        if isinstance(value, str) and value in names:
            return ""
        import difflib

        close = difflib.get_close_matches(str(value), list(names), n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        return f"is {_repr(value)}, not {kind_words(code, names)}{hint}"
    if code.endswith("s"):
        return _text_problem(value, code)
    if code == "?":
        return "" if type(value) is bool else f"is {_repr(value)}, not true or false"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return f"is {_repr(value)}, not {kind_words(code)}"
    if code == "q":
        if not isinstance(value, int):
            return f"is {_repr(value)}, not a whole number"
        if not INT_MIN <= value <= INT_MAX:
            return f"is {_short(value)}: out of range (an int is 64-bit, {INT_MIN} to {INT_MAX})"
        return ""
    if isinstance(value, float) and math.isnan(value):
        return "is NaN: not a number"
    if not -1.7976931348623157e308 <= value <= 1.7976931348623157e308:
        return f"is {_short(value)}: out of range (a float is finite)"
    return ""


def _text_problem(value: object, code: str) -> str:
    """As `value_problem`, for a string field of struct `code` (`Ns`, N bytes)."""
    if not isinstance(value, str):
        return f"is {_repr(value)}, not {kind_words(code)}"
    try:
        used = len(value.encode("utf-8"))
    except UnicodeEncodeError:
        return f"is {_repr(value)}: not text (it holds bytes that are not UTF-8)"
    if "\0" in value:
        return "holds the NUL character, which no string may"
    if used > int(code[:-1]):
        return f"is {_repr(value)}: {used} bytes of UTF-8, more than the {code[:-1]} it holds"
    return ""


def parse_value(raw: str, code: str, names: Sequence[str] = ()) -> object:
    """`raw` (text an operator typed) as the value of a field of struct `code`: `true` or
    `false`, a whole number, a number, a value name, a text. ValueError: what is wrong (the
    end of a sentence that starts with the field's name), nothing written anywhere."""
    value: object = raw
    if names or code.endswith("s"):
        pass
    elif code == "?":
        if raw not in ("true", "false"):
            raise ValueError(f"is {_repr(raw)}, not true or false")
        value = raw == "true"
    elif code == "q":
        if not _INT.fullmatch(raw):
            raise ValueError(f"is {_repr(raw)}, not {kind_words(code)}")
        value = int(raw)
    else:
        if not _FLOAT.fullmatch(raw):
            raise ValueError(f"is {_repr(raw)}, not {kind_words(code)}")
        value = float(raw)
        if math.isinf(value):
            raise ValueError(f"is {_short(raw)}: out of range (a float is finite)")
    problem = value_problem(value, code, names)
    if problem:
        raise ValueError(problem)
    return value


def _repr(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _short(value: object) -> str:
    text = str(value)
    return text if len(text) <= 30 else text[:27] + "..."


# ---------------------------------------------------------------- an answer's results


def task_results(layout: ModuleType, operator: str, task: str) -> dict[str, tuple[Any, ...]]:
    """What a DONE answer to `task` of operator module `operator` records: each result's
    name -> (its struct code, an enumeration's value names, its least and greatest value)."""
    declared = getattr(layout, "TASK_RESULTS", {}).get(operator, {}).get(task, ())
    if not declared:
        return {}
    channel = layout.OPERATORS[operator][0]  # every channel of one operator: the same slots
    codes = layout.ANSWERS[channel].codes()
    enums = getattr(layout, "ENUMS", {})
    return {
        name: (str(codes[f"result_{name}"]), tuple(enums.get((channel, f"result_{name}"), ())))
        + (low, high)
        for name, low, high in declared
    }


def answer_results(
    layout: ModuleType,
    operator: str,
    task: str,
    given: Mapping[str, object],
    typed: bool = False,
) -> dict[str, object]:
    """The answer record's result slots (`result_<name>` -> the value as the slot holds it)
    for a DONE answer to `task` giving `given`: text a person typed (`NAME=VALUE`), or, with
    `typed`, values as a scenario's YAML gives them. ValueError naming the first thing wrong:
    a result the task does not record, one left out, a value of another type or out of its
    range. Nothing is written anywhere: an answer that does not fit never reaches the rules."""
    declared = task_results(layout, operator, task)
    where = f"{operator}.{task}"
    for name in given:
        if name not in declared:
            if not declared:
                raise ValueError(f"{where} records no results: answer DONE alone")
            raise ValueError(f"{where} records " + suggest(name, list(declared), "result"))
    missing = [name for name in declared if name not in given]
    if missing:
        form = " ".join(f"{name}=..." for name in declared)
        raise ValueError(f"{where} needs {listed('result', missing)} with DONE ({form})")
    slots: dict[str, object] = {}
    channel = layout.OPERATORS[operator][0]
    for name, (code, names, low, high) in declared.items():
        raw = given[name]
        try:
            if typed:
                value = float(raw) if code == "d" and type(raw) is int else raw
                problem = value_problem(value, code, names)
                if problem:
                    raise ValueError(problem)
            else:
                value = parse_value(str(raw), code, names)
        except ValueError as error:
            raise ValueError(f"{where}: result {name} {error}") from None
        problem = range_problem(value, low, high)
        if problem:
            raise ValueError(f"{where}: result {name} {problem}")
        slots[f"result_{name}"] = enum_code(layout, channel, f"result_{name}", value)
    return slots


# ---------------------------------------------------------------- commands


def operated(layout: ModuleType) -> list[str]:
    """The modules an operator may command: every module with a command buffer of its own
    (an operator module's channels are written by its clients)."""
    channels = {c for found in getattr(layout, "OPERATORS", {}).values() for c in found}
    return [m for m in layout.MODULES if m in layout.COMMAND_IN and m not in channels]


def parameters(
    layout: ModuleType, module: str, command: str
) -> dict[str, tuple[str, tuple[str, ...]]]:
    """`command`'s parameters in order, each with the struct code of its slot and an
    enumeration's value names."""
    record = layout.COMMAND_IN[module]
    codes = record.codes()
    enums = getattr(layout, "ENUMS", {})
    return {
        name: (str(codes[f"arg_{name}"]), tuple(enums.get((module, f"arg_{name}"), ())))
        for name in layout.PARAMS.get(module, {}).get(command, ())
    }


def _command(layout: ModuleType, module: str, command: str, client: bool = False) -> None:
    """ValueError unless `module` is operated (or, for a `client`, a channel) and has
    `command`."""
    if module not in operated(layout) and not (client and module in layout.COMMAND_IN):
        if module in layout.COMMAND_IN:  # an operator module's channel
            operator, by = module.split("/", 1)
            raise ValueError(
                f"{module} is {operator}'s channel to its client {by}: {by} writes it; "
                f"answer what {by} asks with `ctl answer {module}`"
            )
        raise ValueError(suggest(module, operated(layout), "module"))
    commands = list(layout.COMMAND_NAMES[module][1:])
    if command not in commands:
        raise ValueError(f"{module} has " + suggest(command, commands, "command"))


def check_command(
    layout: ModuleType,
    module: str,
    command: str,
    args: Mapping[str, object],
    client: bool = False,
) -> Command:
    """`module.command` with typed `args` (a scenario's `with:`, a harness), checked: every
    parameter given, none other, each of its type. ValueError names what is wrong. With
    `client`, an operator module's channel (`op/fx`) may be written as its client does (a
    test harness standing in for the client)."""
    _command(layout, module, command, client)
    params = parameters(layout, module, command)
    where = f"{module}.{command}"
    for name, value in args.items():
        if name not in params:
            raise ValueError(f"{where} has " + suggest(name, list(params), "parameter"))
        problem = value_problem(value, *params[name])
        if problem:
            raise ValueError(f"{where}: parameter {name} {problem}")
    _all_given(where, params, args)
    return Command(module, command, {name: args[name] for name in params})


def parse_command(layout: ModuleType, module: str, command: str, items: Sequence[str]) -> Command:
    """`MODULE COMMAND NAME=VALUE ...` as an operator typed it, checked as `check_command`
    does; a parameter given twice is refused too."""
    _command(layout, module, command)
    params = parameters(layout, module, command)
    where = f"{module}.{command}"
    values: dict[str, object] = {}
    for item in items:
        name, equals, raw = item.partition("=")
        if not equals:
            raise ValueError(f"{where}: {_repr(item)} is not NAME=VALUE")
        if name not in params:
            raise ValueError(f"{where} has " + suggest(name, list(params), "parameter"))
        if name in values:
            raise ValueError(f"{where}: parameter {name} is given twice")
        try:
            values[name] = parse_value(raw, *params[name])
        except ValueError as error:
            raise ValueError(f"{where}: parameter {name} {error}") from None
    _all_given(where, params, values)
    return Command(module, command, {name: values[name] for name in params})


def _all_given(where: str, params: Mapping[str, Any], given: Mapping[str, object]) -> None:
    missing = [name for name in params if name not in given]
    if missing:
        form = " ".join(f"{name}=..." for name in params)
        raise ValueError(f"{where} needs {listed('parameter', missing)} ({where} {form})")


def write_command(layout: ModuleType, buf: memoryview, command: Command, tries: int = 20) -> int:
    """Write a checked command to its module's buffer, numbered after the last one, through
    the seqlock, retried briefly while the buffer is being written; its number. StaleRead
    (contract) when the buffer cannot be read whole after `tries`."""
    record = layout.COMMAND_IN[command.module]
    code = layout.COMMAND_NAMES[command.module].index(command.command)
    args = {
        f"arg_{k}": enum_code(layout, command.module, f"arg_{k}", v)
        for k, v in command.args.items()
    }
    for attempt in range(tries):
        try:
            number = int(record.read(buf)["command_num"]) + 1
            break
        except StaleRead:
            if attempt == tries - 1:
                raise
            time.sleep(0.0005)
    record.write(buf, command_num=number, command=code, **args)
    return number


def outcome(
    command: Mapping[str, Any], status: Mapping[str, Any], number: int | None = None
) -> str | None:
    """How a module ended a command: DONE or ERROR once it reported on command `number`
    (default: the one in its command buffer), from its `command` and `status` records as
    read ({} when unreadable); None while it has not, or while `number` is not given yet.
    ValueError when `number` was replaced by a later command before it finished (its
    outcome is no longer in the status buffer). A module that has ended its last command
    is ready for the next one (the launcher's `--send` waits for that)."""
    if not command or not status:
        return None
    given = int(command["command_num"])
    if number is not None and given > number:
        raise ValueError(
            f"command #{number} was replaced by #{given}: "
            "its outcome is no longer in the status buffer"
        )
    if number is not None and given < number:
        return None  # not given yet
    if status["status_num"] != given or int(status["status"]) not in (DONE, ERROR):
        return None
    return STATUS_NAMES[int(status["status"])]
