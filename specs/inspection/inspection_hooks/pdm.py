"""The simulated PDM system's hook: an inspection program's name -> its record, the number
of features it measures (the shop's job planner retrieves it, section 5.3.1: "The Shop may
retrieve the instructions from a product database management (PDM) system").

The PDM's vault is the system's programs/ folder, read as measurement reads it
(inspection_hooks.ms.read_program), so a bad line is refused with its file:line in the
same words; a program that is not in the vault is the answer 0 (the planner's ERROR
NO_PROGRAM), not a stopped run."""

from __future__ import annotations

from .ms import PROGRAM_NAME, SYSTEM_DIR, read_program


def retrieve(name: str) -> int:
    """How many features the inspection program `name` (programs/<name>.dmi) measures; 0
    when the vault has no such program (a name mistyped at the Guardian). A program that
    exists but cannot be read stops the run in one line naming file:line, as MS's hook
    does."""
    path = SYSTEM_DIR / "programs" / f"{name}.dmi"
    if not PROGRAM_NAME.fullmatch(name) or not path.is_file():
        return 0
    return len(read_program(path))
