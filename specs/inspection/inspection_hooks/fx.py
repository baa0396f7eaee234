"""Fixturing's planner (the PL of the paper's task-level fixturing node, section 5.3.2, which
interprets the DMIS program too): a setup of the inspection program -> the fixturing the
operator is asked for, the setup and the clamps its FIXTID statement names
(inspection_hooks/dmis.py). The executor, FX's table, asks the operator for each step."""

from __future__ import annotations

from .ms import ProgramError, named


def fixturing(name: str, setup: int) -> list[tuple[int, int]]:
    """FX's plan of putting the part in `setup` of program `name`: one step (setup, clamps),
    from the setup's FIXTID. A setup the program does not have stops the run, naming it."""
    for found in named(name).setups:
        if found.number == setup:
            return [(found.number, found.clamps)]
    raise ProgramError(f"programs/{name}.dmi has no FIXTID/'SETUP {setup}'")
