"""`ctl wait` names the command whose outcome it saw, from the same read.

It used to read the outcome, then the module's row again for the command to print: a
supervisor writing the next command in between made it print "DONE" for a command that
had only just been given. Now the outcome and its command come from one read.
"""

from __future__ import annotations

import argparse
from typing import Any

from rcsgen.runtime.operate import ctl


class Reads:
    """A console whose module ends command #2, then is given #3 at once."""

    def __init__(self) -> None:
        self.polls = 0

    def outcome(self, module: str, number: int | None = None) -> tuple[str, str] | None:
        self.polls += 1
        return None if self.polls < 3 else ("DONE", "MOVE #2")

    def modules(self, *_: Any) -> dict[str, Any]:  # what a second read would say by now
        return {"top": {"command": "STOP", "command_num": 3}}


def test_wait_prints_the_command_its_outcome_was_read_with(capsys: Any) -> None:
    reads = Reads()
    args = argparse.Namespace(module="top", number=None, timeout=5.0, outcome="DONE")
    assert ctl._VERBS["wait"](reads, args, None) == 0  # type: ignore[arg-type]
    assert capsys.readouterr().out == "top DONE MOVE #2\n"
    assert reads.polls == 3  # polled until it ended, not read again after


def test_wait_for_the_other_outcome_fails_and_says_what_it_saw(capsys: Any) -> None:
    args = argparse.Namespace(module="top", number=None, timeout=5.0, outcome="ERROR")
    assert ctl._VERBS["wait"](Reads(), args, None) == ctl.FAILED  # type: ignore[arg-type]
    assert capsys.readouterr().out == "top DONE MOVE #2\n"
