"""The values the compiler hands from stage to stage cannot be changed after they are made:
lowering decides every name, slot and import once and emit only renders (docs/architecture.md,
"Lower decides, emit renders"); a checked table, a type or an expression node is shared by
every check that reads it. Each dataclass of these modules is frozen: setting a field raises,
and two equal values hash alike (they are kept in sets and used as keys)."""

from __future__ import annotations

import dataclasses
import inspect
from types import ModuleType

import pytest

from rcsgen.compiler import codes, diagnostics, ir, types
from rcsgen.compiler.back_end import module_io
from rcsgen.compiler.checks import tables
from rcsgen.compiler.expressions import nodes
from rcsgen.compiler.front_end import fragments
from rcsgen.compiler.prove import model as prove_model

# (module_io: the fields lowering gathers into a struct and where each module runs;
# fragments: a fragment and each use of it, shared by every command that uses it; codes:
# the registry's codes, read by every stage)
MODULES = (ir, types, tables, nodes, prove_model, diagnostics, module_io, fragments, codes)


def dataclasses_of(module: ModuleType) -> list[type]:
    return [
        c
        for _, c in inspect.getmembers(module, inspect.isclass)
        if c.__module__ == module.__name__ and dataclasses.is_dataclass(c)
    ]


@pytest.mark.parametrize("module", MODULES, ids=[m.__name__ for m in MODULES])
def test_every_value_the_stages_share_is_frozen(module: ModuleType) -> None:
    found = dataclasses_of(module)
    mutable = [c.__name__ for c in found if not c.__dataclass_params__.frozen]
    assert found and mutable == list(MUTABLE.get(module.__name__, ()))
    assert [c.__name__ for c in found if c.__name__ not in mutable and c.__hash__ is None] == []


# the few built up in place on purpose (the spec's model, front_end/model.py, is made in place
# as the loader reads the YAML and is not listed: it is the loader's, not a stage's output)
MUTABLE: dict[str, tuple[str, ...]] = {
    "rcsgen.compiler.prove.model": ("Graph", "_Acts"),  # grow as the model is explored
    "rcsgen.compiler.diagnostics": ("Diagnostics",),  # collects findings as checks run
}
