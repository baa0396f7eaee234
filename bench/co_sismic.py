"""co's tables as a sismic statechart (https://github.com/AlexandreDecan/sismic).

The chart is bench/co_statechart.yaml; the wrapper (co_library.LibraryCo) is in the
interpreter's context as `co`. Each state's entry action writes co's state code to
`co.state`, which the wrapper's post_process writes to the block. A cycle queues the
current command's event and runs one step of the interpreter; a new command number first
queues `new_command` and runs a step, so the table restarts at S0 in the same cycle even if
a mode holds it. Sismic runs an event with no enabled transition as an empty step.
"""

from __future__ import annotations

from pathlib import Path

from co_layout import DONE, HALT, LOOSE_COAL_LIMIT
from co_library import LibraryCo
from sismic.interpreter import Interpreter
from sismic.io import import_from_yaml

CHART = import_from_yaml(filepath=str(Path(__file__).with_name("co_statechart.yaml")))


class SismicCo(LibraryCo):
    """co with its tables in a sismic `Interpreter`."""

    def __init__(self, buf: memoryview) -> None:
        super().__init__(buf)
        context = {"co": self, "DONE": DONE, "HALT": HALT, "LOOSE_COAL_LIMIT": LOOSE_COAL_LIMIT}
        self.interpreter = Interpreter(CHART, initial_context=context)
        self.interpreter.execute_once()  # enter the initial state, NOP

    def restart(self) -> None:
        self.interpreter.queue("new_command")
        self.interpreter.execute_once()

    def fire(self, event: str) -> None:
        self.interpreter.queue(event)
        self.interpreter.execute_once()
