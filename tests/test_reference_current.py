"""Every shipped system's committed reference (docs/reference/, what `make check`'s `rcsgen doc
specs/ --check` asks) is exactly what its specs make, one system a test, in memory: nothing
is written. test_reference reads the miner's pages closely; the other systems carry what the
miner has not (operator modules and their tasks, results, lets, first-match states, fieldbus
devices), so a changed word, table row or figure of any page shows here, in the unit tier."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.compiler.back_end.write import unified_diff
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools import reference

ROOT = Path(__file__).resolve().parent.parent
COMMITTED = ROOT / "docs" / "reference"
SYSTEMS = sorted(p.name for p in (ROOT / "specs").iterdir() if (p / "system.yaml").is_file())


def test_every_shipped_system_has_a_committed_reference() -> None:
    assert SYSTEMS and sorted(p.name for p in COMMITTED.iterdir() if p.is_dir()) == SYSTEMS


@pytest.mark.parametrize("name", SYSTEMS)
def test_the_committed_reference_is_what_the_specs_make(name: str) -> None:
    front = compile_paths([ROOT / "specs" / name])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    [system] = front.systems
    plan, problems = reference.plan([system], COMMITTED)
    assert not problems.errors
    assert not plan.stale, (
        f"docs/reference/{name} is stale; update it with\n  rcsgen doc specs/ -o docs/reference\n"
        + unified_diff(plan, COMMITTED)[:3000]
    )
