"""The committed packages in generated/ are exactly what their specs make (what `make check`'s
`rcsgen build specs/ --check --strict` asks), one system a test, in memory: nothing is
written; and the specs have no warning left unacknowledged (`--strict`). A
change to lowering or emitting that alters one byte of generated code shows here as E418
naming the file, in the unit tier (`make mutate-sample` tries the compiler's mutants
against it: a changed slot, import, offset or name in generated code is a kill, not a
survivor waiting for the golden tests)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen import api

ROOT = Path(__file__).resolve().parent.parent
SYSTEMS = sorted(p.name for p in (ROOT / "specs").iterdir() if (p / "system.yaml").is_file())


def test_every_spec_system_has_a_committed_package() -> None:
    assert SYSTEMS and all((ROOT / "generated" / name).is_dir() for name in SYSTEMS), SYSTEMS


@pytest.mark.parametrize("system", SYSTEMS)
def test_the_specs_have_no_warning_left_unacknowledged(system: str) -> None:
    """--strict: every warning of a shipped system is acknowledged with its reason, and
    every acknowledgement matches a finding (W303 otherwise), `prove`'s findings apart:
    only `prove` can tell whether one of those is still found."""
    front = api.check(ROOT / "specs" / system)
    assert [d.render() for d in front.diagnostics] == []


@pytest.mark.parametrize("system", SYSTEMS)
def test_the_committed_package_is_what_the_specs_make(system: str) -> None:
    errors, stale = api.stale(ROOT / "specs" / system, ROOT / "generated")
    assert not errors.items, [d.render() for d in errors]
    assert stale == [], "\n".join(d.render() for d in stale)
