"""Lost: the runtime's reaction to a lost process, as the model plays it - one pluggable piece.

A process is lost when its heartbeat stops (docs/semantics.md, "Liveness"). The runtime then
acts on the supervisors outside it whatever their tables say. Two reactions are written here:

- `DirectReaction`, the runtime as it is on main: the supervisors of a module of the lost
  process (in other processes) go to their safe state - HALT to every subordinate, state
  NOP, status ERROR with reason LOST - and the supervisors above them learn of it only
  through their tables (a subordinate's ERROR);
- `FailSafeReaction`, the runtime as issue "Fail safe" describes it: every controller that
  transitively supervises a module of the lost process goes to that safe state, unless it
  declares `on_lost: continue` for the subordinate above that module, in which case it sees
  that subordinate's ERROR (reason LOST) and its own rules handle it.

`reaction_for` picks the one the IR describes: the fail-safe one once the IR's subordinates
carry `on_lost`. The model asks only `candidates` (which processes can be lost, seen from a
supervisor) and `effect` (what that does to it).
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import ir


@dataclass(frozen=True)
class Effect:
    safe_state: bool  # the supervisor goes to the runtime's safe state
    errors: tuple[str, ...] = ()  # subordinates whose status it now reads as ERROR (LOST)


class DirectReaction:
    """main's runtime: only the direct supervisors of the lost process's modules react."""

    name = "direct"

    def __init__(self, system: ir.IRSystem, placement: dict[str, tuple[str, int]]):
        self.system, self.placement = system, placement
        self.children = {c.name: [s.name for s in c.subordinates] for c in system.controllers}

    def subtree(self, module: str) -> list[str]:
        found, todo = [], [module]
        while todo:
            at = todo.pop()
            found.append(at)
            todo.extend(self.children.get(at, []))
        return found

    def process_of(self, module: str) -> str | None:
        return self.placement.get(module, (None, 0))[0]

    def candidates(self, supervisor: str) -> tuple[str, ...]:
        """The processes, other than the supervisor's, that run a module below it."""
        own = self.process_of(supervisor)
        found = {
            self.process_of(m)
            for sub in self.children.get(supervisor, [])
            for m in self.subtree(sub)
        }
        return tuple(sorted(p for p in found if p is not None and p != own))

    def effect(self, supervisor: str, process: str) -> Effect:
        direct = any(self.process_of(s) == process for s in self.children.get(supervisor, []))
        return Effect(direct)


class FailSafeReaction(DirectReaction):
    """Issue "Fail safe": every transitive supervisor reacts; `on_lost: continue` per
    subordinate hands the loss to the supervisor's own rules instead."""

    name = "fail-safe"

    def effect(self, supervisor: str, process: str) -> Effect:
        c = self.system.controller(supervisor)
        hit = [
            s
            for s in c.subordinates
            if any(self.process_of(m) == process for m in self.subtree(s.name))
        ]
        continuing = [s.name for s in hit if getattr(s, "on_lost", "halt_all") == "continue"]
        if hit and len(continuing) == len(hit):
            return Effect(False, tuple(continuing))
        return Effect(bool(hit))


def reaction_for(system: ir.IRSystem, placement: dict[str, tuple[str, int]]) -> DirectReaction:
    """The reaction of the runtime the IR was made for."""
    if "on_lost" in getattr(ir.IRSub, "__dataclass_fields__", {}):
        return FailSafeReaction(system, placement)
    return DirectReaction(system, placement)
