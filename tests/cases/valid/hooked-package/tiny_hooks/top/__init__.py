"""Hooks of the hooked test system: annotated, quoted and unannotated."""

from __future__ import annotations


def new_state(settings: dict[str, str]) -> list[float]:
    return [float(settings.get("scale", "1"))]


def nudge(state: list[float], n: int, flag: bool) -> float:
    if not flag:
        return 0.0
    return n * state[0]


def split(state, level: "float") -> "tuple[int, float]":
    whole = int(level)
    return whole, level - whole
