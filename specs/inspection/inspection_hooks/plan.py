"""The job planner's hook: an inspection program -> the length of its feature schedule.

The program is read as measurement reads it (inspection_hooks.ms.read_program), so a bad
line is refused with its file:line in the same words."""

from __future__ import annotations

from .ms import PROGRAM_NAME, SYSTEM_DIR, ProgramError, read_program


def schedule(name: str) -> int:
    """How many features the inspection program `name` (programs/<name>.ipg) schedules."""
    if not PROGRAM_NAME.fullmatch(name):
        raise ProgramError(f"{name!r} is not an inspection program's name (a-z, 0-9, _)")
    return len(read_program(SYSTEM_DIR / "programs" / f"{name}.ipg"))
