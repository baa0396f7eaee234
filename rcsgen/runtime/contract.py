"""Contract: the codes and buffer shapes generated code, tools and the compiler all read.

The one place the status and mode codes, the built-in commands and the fields of the
buffers every module has (QQ1.h) are spelled. Standard library only: this file is copied
verbatim into every generated package (as `<system>/rcs/contract.py`).
"""

from __future__ import annotations

from struct import Struct
from typing import NamedTuple

# Status a module reports to its supervisor (QQ1.h `qq1_responses`), by code.
NOT_READY = 0
EXECUTING = 1
DONE = 2
ERROR = 3
STATUS_NAMES = ("NOT_READY", "EXECUTING", "DONE", "ERROR")
FINISHED = ("DONE", "ERROR")  # the statuses that end a command

# The state of a module with no command to work on.
NOP = 0
# The command code of a buffer that never received a command.
NO_COMMAND = 0
NO_COMMAND_NAME = "NONE"
# Every module accepts these first, with codes 1 and 2; declared commands follow.
BUILTIN_COMMANDS = ("INIT", "HALT")

# Buffers every module has, in the same shape: (field, struct code). A command buffer is
# its head followed by one `arg_<name>` field per parameter of the module's commands.
COMMAND_HEAD_FIELDS = (("command_num", "Q"), ("command", "I"))
# `rule` is the code of the table rule that fired in the module's last cycle (0: none); the
# layout's RULES names each code (`SUMP_SHEAR_CUSP/S2/3`), for monitors, traces and coverage.
STATUS_FIELDS = (
    ("status_num", "Q"),
    ("status", "I"),
    ("error_num", "I"),
    ("state", "i"),
    ("rule", "i"),
)
NO_RULE = 0
MODE_FIELDS = (
    ("dont_run", "?"),
    ("single_step", "?"),
    ("simulate", "?"),
    ("pad", "x"),
    ("single_step_num", "I"),
)
PERF_FIELDS = (
    ("last_cycle_ns", "Q"),
    ("min_cycle_ns", "Q"),
    ("max_cycle_ns", "Q"),
    ("cycles", "Q"),
    ("single_step_num", "I"),
)
# The struct code of each spec type (world fields, parameters).
FORMAT_OF_TYPE = {"bool": "?", "int": "q", "float": "d"}


def field_names(fields: tuple[tuple[str, str], ...]) -> tuple[str, ...]:
    """The names of a buffer's fields, without padding."""
    return tuple(name for name, code in fields if code != "x")


def struct_format(fields: tuple[tuple[str, str], ...]) -> str:
    """The little-endian `struct` format of a buffer's fields, with no implicit padding."""
    return "<" + "".join(code for _, code in fields)


STATUS = Struct(struct_format(STATUS_FIELDS))
STATUS_HEAD = Struct(
    struct_format(STATUS_FIELDS[:2])
)  # status_num, status: what a supervisor reads
MODE = Struct(struct_format(MODE_FIELDS))
PERF = Struct(struct_format(PERF_FIELDS))


class Record(NamedTuple):
    """A buffer for tools (harness, traces, operator interfaces): its struct, offset, fields."""

    struct: Struct
    offset: int
    fields: tuple[str, ...]

    def read(self, buf: memoryview) -> dict[str, object]:
        return dict(zip(self.fields, self.struct.unpack_from(buf, self.offset), strict=True))

    def write(self, buf: memoryview, **values: object) -> None:
        unknown = set(values) - set(self.fields)
        if unknown:
            raise KeyError(f"no field(s) {sorted(unknown)} in a buffer of {self.fields}")
        current = self.read(buf)
        current.update(values)
        self.struct.pack_into(buf, self.offset, *current.values())
