"""The harness's view of the world's overrides (rcsgen/tools/harness.py `World.overrides`), in
the unit tier on a layout made by hand: what a trace line shows under `overrides` and what
the device bench's fail-safe check reads (`held.get(...)`): every field forced or latched
safe by name, and an empty mapping, never None, while nothing is held (one byte read, so a
system without overrides pays nothing)."""

from __future__ import annotations

from types import SimpleNamespace

from rcsgen.tools.harness import World


class Record:
    def __init__(self, state: int) -> None:
        self.state = state

    def read(self, buf: object) -> dict[str, int]:
        return {"state": self.state}


def test_the_overrides_by_name_and_none_held_is_empty() -> None:
    layout = SimpleNamespace(
        OVERRIDDEN_AT=3, OVERRIDE={"a": Record(0), "b": Record(1), "c": Record(2)}, WORLD={}
    )
    buf = bytearray(8)
    assert World(layout, memoryview(buf)).overrides() == {}  # the flag byte clear: not read
    buf[3] = 1
    assert World(layout, memoryview(buf)).overrides() == {"b": "FORCED", "c": "SAFE"}
    layout.OVERRIDE["b"].state = 0
    assert World(layout, memoryview(buf)).overrides() == {"c": "SAFE"}
    older = SimpleNamespace(OVERRIDE={}, WORLD={})  # a package built before overrides
    assert World(older, memoryview(buf)).overrides() == {}
