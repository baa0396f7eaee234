"""rcsgen: NIST RCS controllers from declared state tables.

    import rcsgen

    result = rcsgen.check(["specs/miner"])  # the systems and every diagnostic
    built = rcsgen.build(["specs/"], "generated")  # writes all or nothing
    with rcsgen.Harness.build("specs/miner") as h:  # drive a system cycle by cycle
        ...

The names load on first use, so `import rcsgen` alone loads neither the compiler nor its
dependencies. The command line is `rcsgen.cli` (or `python -m rcsgen`), not exported here.
"""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["Diagnostic", "Diagnostics", "Harness", "SpecError", "__version__", "build", "check"]

# Not `from typing import TYPE_CHECKING`: typing alone costs more than the rest of this file.
# Type checkers treat any name TYPE_CHECKING as true, so they see the exports below.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from .api import build, check
    from .compiler.diagnostics import Diagnostic, Diagnostics, SpecError
    from .tools.harness import Harness

_HOMES = {
    "build": "rcsgen.api",
    "check": "rcsgen.api",
    "Diagnostic": "rcsgen.compiler.diagnostics",
    "Diagnostics": "rcsgen.compiler.diagnostics",
    "SpecError": "rcsgen.compiler.diagnostics",
    "Harness": "rcsgen.tools.harness",
}


if not TYPE_CHECKING:  # hidden from type checkers, which would then accept any name

    def __getattr__(name: str) -> object:
        """Import an exported name from its module on first use (PEP 562)."""
        home = _HOMES.get(name)
        if home is None:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        from importlib import import_module

        value = getattr(import_module(home), name)
        globals()[name] = value  # later lookups do not come back here
        return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
