"""Naming policy: how spec names become Python names, and which names are reserved.

Kept in one place so a collision is found before emission, never by a failing import.
"""

from __future__ import annotations

import keyword

from .expr import Ref

# Methods every generated controller class has (QQ1 shape).
FIXED_METHODS = frozenset(
    {"run_cycle", "pre_process", "check_if_new_command", "decision_process", "post_process"}
)
# Modules every generated package has besides one per controller.
FIXED_MODULES = frozenset({"layout", "rcs", "__init__", "__main__", "hooks"})
# Module-level names every generated controller module imports from the runtime and layout.
RUNTIME_NAMES = frozenset(
    {"NOT_READY", "EXECUTING", "DONE", "ERROR", "NOP", "STATUS", "STATUS_HEAD", "MODE", "PERF"}
)
# Prefixes of the attributes generated from spec names (world fields, params, locals).
ATTRIBUTE_PREFIXES = ("world_", "arg_", "var_", "perf_")


def command_method(command: str) -> str:
    """The state-table method of a command: SUMP_SHEAR_CUSP -> sump_shear_cusp."""
    return command.lower()


def sub_command_const(sub: str, command: str) -> str:
    """A subordinate's command code as its supervisor names it: cc, SUMP -> CC_SUMP."""
    return f"{sub.upper()}_{command}"


def process_module(process: str) -> str:
    return f"main_{process}"


def class_name(mnemonic: str) -> str:
    return "".join(part.capitalize() for part in mnemonic.split("_")) + "Controller"


def attribute(ref: Ref) -> str:
    """The Python text a resolved name is printed as inside a controller method."""
    kind, name, owner = ref.kind, ref.name, ref.owner
    if kind == "world":
        return f"self.world_{name}"
    if kind == "param":
        return f"self.arg_{name}"
    if kind == "local":
        return f"self.var_{name}"
    if kind in ("const", "status"):
        return name
    if kind == "sub_status":
        return f"self.{owner}_status"
    if kind == "sub_command":
        return f"self.{owner}_command"
    if kind == "sub_command_name":
        return sub_command_const(owner, name)
    if kind == "predicate":
        return f"self.{name}"
    raise ValueError(f"no Python name for {ref!r}")


def target_attribute(target: str) -> str:
    """`world.goal_x` -> self.world_goal_x; a local `ticks` -> self.var_ticks."""
    if target.startswith("world."):
        return f"self.world_{target.removeprefix('world.')}"
    return f"self.var_{target}"


def is_keyword(name: str) -> bool:
    return keyword.iskeyword(name) or keyword.issoftkeyword(name)
