"""Config: `[tool.rcsgen]` in the nearest pyproject.toml -> reporting defaults.

Searched from the working directory upwards; the first pyproject.toml with a `[tool.rcsgen]`
table is used. Keys: `select` and `ignore` (lists of warning codes or prefixes, as on the
command line) and `strict` (a boolean). The command line wins: `--select` replaces the
configured list, `--ignore` adds to it, `--strict/--no-strict` overrides it.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..compiler.diagnostics import did_you_mean
from ..compiler.front_end.loader import path_problem, read_bytes
from .report import code_prefix_problem

KEYS = {"select": "a list of warning codes", "ignore": "a list of warning codes"}
KEYS["strict"] = "true or false"


class ConfigError(Exception):
    """A configuration problem: the command is misused (exit 2)."""


@dataclass(frozen=True)
class Config:
    path: Path | None = None  # where it was read from; None: no configuration
    select: tuple[str, ...] = ()
    ignore: tuple[str, ...] = ()
    strict: bool | None = None
    keys: frozenset[str] = field(default_factory=frozenset)  # the keys it sets


def find(start: Path) -> Path | None:
    """The nearest pyproject.toml at or above `start` that has a `[tool.rcsgen]` table."""
    for directory in [start, *start.parents]:
        candidate = directory / "pyproject.toml"
        if path_problem(candidate) is None and "[tool.rcsgen]" in _text(candidate):
            return candidate
    return None


def _text(path: Path) -> str:
    try:
        return read_bytes(path, str(path)).decode("utf-8", errors="replace")
    except Exception:  # unreadable: not our configuration
        return ""


def load(start: Path) -> Config:
    """The configuration that applies in `start` (empty when there is none)."""
    path = find(start)
    if path is None:
        return Config()
    try:
        table = tomllib.loads(_text(path)).get("tool", {}).get("rcsgen", {})
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from None
    if not isinstance(table, dict):
        raise ConfigError(f"{path}: [tool.rcsgen] must be a table")
    for key in table:
        if key not in KEYS:
            near = did_you_mean(key, KEYS) or f"the keys are {', '.join(sorted(KEYS))}"
            raise ConfigError(f"{path}: [tool.rcsgen]: unknown key `{key}`; {near}")
    codes: dict[str, tuple[str, ...]] = {}
    for key in ("select", "ignore"):
        value = table.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{path}: [tool.rcsgen]: `{key}` must be {KEYS[key]}")
        for prefix in value:
            problem = code_prefix_problem(prefix)
            if problem:
                raise ConfigError(f"{path}: [tool.rcsgen]: `{key}`: {problem}")
        codes[key] = tuple(value)
    strict = table.get("strict")
    if strict is not None and not isinstance(strict, bool):
        raise ConfigError(f"{path}: [tool.rcsgen]: `strict` must be {KEYS['strict']}")
    return Config(path, codes["select"], codes["ignore"], strict, frozenset(table))


__all__ = ["Config", "ConfigError", "find", "load"]
