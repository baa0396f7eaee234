"""The workstation's planner (the PL of the paper's section 5.3.2, which "interprets the
workstation inspection plan and sends the decomposed fixturing instructions and part
feature inspection schedules ... for the two task level subordinates"): an inspection
program -> one step per setup, in the program's order: the setup fixturing is to put the
part in, and the schedule of features measurement is to inspect in it (the first
feature's index and how many).
"""

from __future__ import annotations

from .ms import named_program


def setups(name: str) -> list[tuple[int, int, int]]:
    """The steps (setup, first feature, features) of the inspection program `name`: each
    run of consecutive features measured in one setup (a program that returns to a setup
    fixtures the part in it again)."""
    steps: list[tuple[int, int, int]] = []
    for index, feature in enumerate(named_program(name)):
        if steps and steps[-1][0] == feature.setup:
            setup, first, count = steps[-1]
            steps[-1] = (setup, first, count + 1)
        else:
            steps.append((feature.setup, index, 1))
    return steps
