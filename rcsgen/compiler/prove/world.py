"""World: which modules write each world field, and when - so a supervisor's wait on a world
field its idle subordinates alone could change is seen as the deadlock it is.

A world field is *controlled* below a supervisor when every module that writes it is in the
supervisor's subtree, none writes it whatever it runs (an every_cycle rule, a hook outside
the tables) and none is a simulator (the physics; a stand-in too). Such a field is *quiet*
in a state of the supervisor's model when no subordinate is running a command that may
write it, directly or through the commands it sends, and none ran one during the current
command (the wait may be on what that command set): a subordinate that reported DONE has
waited for the echoes of the motion commands it sent (W708), so its subtree is idle; one
that reported ERROR may still have work running below it, and counts as running. A wait on
quiet fields alone is then a wait on values set before the command began, which nothing
below is asked to change.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from .. import ir
from .adapter import ERROR, EXECUTING, Skeleton
from .model import State


@dataclass
class Writers:
    """Who writes each world field, and what each command may write."""

    skeletons: dict[str, Skeleton]
    writers: dict[str, frozenset[str]]  # field -> the modules that write it
    anytime: frozenset[str]  # fields some module writes whatever it runs
    stand_in: dict[str, str]  # controller -> its stand-in
    _memo: dict[tuple[str, str], frozenset[str]]

    def writes(
        self, module: str, command: str, seen: frozenset[tuple[str, str]] = frozenset()
    ) -> frozenset[str]:
        """The world fields `module` may write while it runs `command`, the commands it
        sends included (and its stand-in's, which may run in its place)."""
        key = (module, command)
        if key in self._memo:
            return self._memo[key]
        if key in seen:
            return frozenset()
        found: set[str] = set()
        for name in (module, self.stand_in.get(module)):
            sk = self.skeletons.get(name or "")
            if sk is None:
                continue
            for rules in sk.tables.get(command, {}).values():
                for rule in rules:
                    found |= rule.world_sets
                    for sub, sent in rule.sends:
                        found |= self.writes(sub, sent, seen | {key})
        self._memo[key] = frozenset(found)
        return self._memo[key]


def writers(system: ir.IRSystem, skeletons: dict[str, Skeleton]) -> Writers:
    by_field: dict[str, set[str]] = {}
    anytime: set[str] = set()
    for c in system.controllers:
        sk = skeletons[c.name]
        in_tables = {
            f
            for table in sk.tables.values()
            for rules in table.values()
            for r in rules
            for f in r.world_sets
        }
        every = {f for r in sk.every for f in r.world_sets}
        for f in c.world_writes:
            by_field.setdefault(f.name, set()).add(c.buffers)
            # a simulator is the world itself (the physics a real machine has): what it
            # writes changes whatever the controllers do
            if c.simulator or f.name in every or f.name not in in_tables:
                anytime.add(f.name)
    return Writers(
        skeletons,
        {f: frozenset(m) for f, m in by_field.items()},
        frozenset(anytime),
        {c.buffers: c.name for c in system.controllers if c.buffers != c.name},
        {},
    )


def quiet_fields(
    system: ir.IRSystem, found: Writers, supervisor: str
) -> Callable[[State], frozenset[str]]:
    """For a state of `supervisor`'s model: the world fields that cannot change while it
    stays (controlled below it, and no subordinate running a command that writes them)."""
    children = {c.name: [s.name for s in c.subordinates] for c in system.controllers}
    below: set[str] = set()
    todo = list(children.get(supervisor, []))
    while todo:
        at = todo.pop()
        if at not in below:
            below.add(at)
            todo.extend(children.get(at, []))
    controlled = frozenset(
        f for f, who in found.writers.items() if who <= below and f not in found.anytime
    )
    subs = tuple(children.get(supervisor, []))
    memo: dict[tuple[tuple[str | None, str, bool], ...], frozenset[str]] = {}

    def quiet(s: State) -> frozenset[str]:
        if not controlled:
            return controlled
        got = memo.get(s.subs)
        if got is None:
            busy: set[str] = set()
            for sub, (sent, view, fresh) in zip(subs, s.subs, strict=True):
                # running a command that may write it, or ran one during this command (the
                # wait may be on what that command set)
                if sent is not None and (fresh or view in (EXECUTING, ERROR)):
                    busy |= found.writes(sub, sent)
            got = memo[s.subs] = controlled - busy
        return got

    return quiet
