"""The job planner's hook: an inspection program -> the length of its feature schedule.

The program is read as measurement reads it (inspection_hooks.ms.read_program), so a bad
line is refused with its file:line in the same words; a program that does not exist is
the planner's ERROR, not a stopped run."""

from __future__ import annotations

from .ms import PROGRAM_NAME, SYSTEM_DIR, read_program


def schedule(name: str) -> int:
    """How many features the inspection program `name` (programs/<name>.ipg) schedules; 0
    when there is no such program (a name mistyped at the Guardian: the planner reports
    it, the lot fails with NO_PROGRAM). A program that exists but cannot be read stops the
    run in one line naming file:line, as MS's hook does."""
    path = SYSTEM_DIR / "programs" / f"{name}.ipg"
    if not PROGRAM_NAME.fullmatch(name) or not path.is_file():
        return 0
    return len(read_program(path))
