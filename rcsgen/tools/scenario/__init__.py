"""Scenarios: a scenario file -> a checked scenario -> a deterministic run and its trace.

In: a scenario file (`<system>/scenarios/*.yaml`) and the system it runs on. Out: the
canonical JSON Lines trace, the run's figures, and located diagnostics for whatever stands
in the way. `model` holds what a checked scenario says; `check` reads a file into one
(E401-E415, E285-E289), never running it; `run` runs it on a harness and writes the trace;
`runs` turns what goes wrong during and after a run into diagnostics (E416-E423); `session`
strings them together as `rcsgen run` does. The checker and the runner share only `model`.

The names below are the package's entry points; each is defined in one of those modules.
"""

from .check import check_scenario, check_system_scenarios
from .model import Event, Expected, OperatorScript, Scenario, ScriptedAnswer, find_system_dir
from .run import (
    RunResult,
    first_difference,
    load_scenario,
    open_harness,
    read_trace,
    run,
    trace_line,
    write_trace,
)

__all__ = [
    "Event",
    "Expected",
    "OperatorScript",
    "RunResult",
    "Scenario",
    "ScriptedAnswer",
    "check_scenario",
    "check_system_scenarios",
    "find_system_dir",
    "first_difference",
    "load_scenario",
    "open_harness",
    "read_trace",
    "run",
    "trace_line",
    "write_trace",
]
