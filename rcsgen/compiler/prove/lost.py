"""Lost: the runtime's reaction to a lost process, as the model plays it.

A process is lost when its heartbeat stops, it is stopped or dead, or its watchdog trips
(docs/semantics.md, "Fail safe"). What every other process then does is decided by one
function of the runtime, `rcs/loop.py` `reaction`, from the layout's hierarchy and
policies. The model does not restate it: `RuntimeReaction` builds the same tables the
generated layout holds (PLACEMENT, SUBORDINATES, ON_LOST_CONTINUE, SAFE_VALUES,
ACTUATED_BY) from the IR and asks that function, so the proofs follow the runtime as it is.

Seen from one supervisor being explored, the loss of a process that runs a module below it
has one of three effects (`Effect`): the supervisor goes to its safe state (`halt_all`:
HALT to every subordinate, NOP, ERROR with reason LOST); or it reads some subordinates'
status as ERROR for as long as the process is lost (`on_lost: continue`, the loss
contained); and the actuators the reaction latches keep their safe values whatever the
supervisor sets. A lost process stays lost in the model (a recovery changes nothing a
property reads: the latches stay until an explicit reset, the safe state until a new
command).
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType

from ...runtime.loop import reaction
from .. import ir


@dataclass(frozen=True)
class Effect:
    safe_state: bool  # the supervisor goes to the runtime's safe state
    errors: tuple[str, ...] = ()  # subordinates it reads as ERROR (LOST) while lost
    latched: frozenset[str] = frozenset()  # actuator fields held at their safe values


def layout_view(system: ir.IRSystem) -> ModuleType:
    """The part of the generated layout module `reaction` reads, from the IR (as
    templates/layout.py.j2 writes it)."""
    placement: dict[str, str] = {}
    for process in system.processes:
        for module in process.modules:
            placement[module] = process.name
            for channel in system.controller(module).channels:
                placement[channel] = process.name
    owners = [c for c in system.controllers if c.buffers == c.name]
    view = ModuleType(f"{system.name}.layout (as prove reads it)")
    vars(view).update(
        PLACEMENT=placement,
        SUBORDINATES={c.name: tuple(s.key for s in c.subordinates) for c in system.controllers},
        ON_LOST_CONTINUE=_continued(system),
        MODULES=tuple(n for c in owners for n in (c.channels if c.is_operator else (c.name,))),
        SAFE_VALUES={f.name: f.safe for f in system.world if f.actuator},
        ACTUATED_BY=dict(system.actuated_by),
        SIMULATORS=tuple(c.name for c in owners if c.simulator),
    )
    return view


def _continued(system: ir.IRSystem) -> dict[str, tuple[str, ...]]:
    """Each supervisor that declares `on_lost: continue` for some subordinates: those."""
    return {
        c.name: tuple(s.name for s in c.subordinates if s.continue_on_lost)
        for c in system.controllers
        if any(s.continue_on_lost for s in c.subordinates)
    }


class RuntimeReaction:
    """The runtime's reaction to the loss of each process, seen from each supervisor."""

    name = "rcs/loop.py reaction: halt_all, or on_lost: continue where declared"

    def __init__(self, system: ir.IRSystem):
        view = layout_view(system)
        self.placement: dict[str, str] = vars(view)["PLACEMENT"]
        self.reactions = {p.name: reaction(view, p.name) for p in system.processes}
        self.children = {c.name: [s.name for s in c.subordinates] for c in system.controllers}

    def subtree(self, module: str) -> list[str]:
        found, todo = [], [module]
        while todo:
            at = todo.pop()
            found.append(at)
            todo.extend(self.children.get(at, []))
        return found

    def process_of(self, module: str) -> str | None:
        return self.placement.get(module)

    def candidates(self, supervisor: str) -> tuple[str, ...]:
        """The processes, other than the supervisor's, that run a module below it: the
        losses its model plays."""
        own = self.process_of(supervisor)
        found = {
            self.process_of(m)
            for sub in self.children.get(supervisor, [])
            for m in self.subtree(sub)
        }
        return tuple(sorted(p for p in found if p is not None and p != own))

    def effect(self, supervisor: str, process: str) -> Effect:
        done = self.reactions[process]
        return Effect(
            supervisor in done.safe,
            tuple(sub for sup, sub in done.told if sup == supervisor),
            frozenset(done.latch),
        )
