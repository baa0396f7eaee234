"""`rcsgen prove --export smv` (rcsgen/tools/prove_smv.py) on test_prove_small's tank, word
for word: each controller's explored model as an SMV module (its cycles numbered, the next
cycles of each, one DEFINE per atom a property can read: state, command, status, each
subordinate's status and last command, what was sent and written, a new command, the
runtime's cycles) and the spec's properties as LTLSPECs with prove's meaning (an invariant,
a response within 0 or 1 cycles, one reading `safe(...)` left out with why)."""

from __future__ import annotations

from pathlib import Path

import pytest
import test_prove_small as small
from click.testing import CliRunner

from rcsgen.cli import main

EXPECTED = Path(__file__).parent / "cases" / "prove_small"


@pytest.mark.parametrize("variant", ["one_process", "on_lost_continue", "retries"])
def test_each_controllers_model_and_properties_as_smv(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, variant: str
) -> None:
    system, sup, tank, _ = small.variants()[variant]
    for name, text in (("system", system), ("sup", sup), ("tank", tank)):
        (tmp_path / f"{name}.yaml").write_text(text)
    monkeypatch.chdir(tmp_path)
    args = ["prove", ".", "--no-replay", "--export", "smv", "--export-dir", "out"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    written = sorted(p.name for p in (tmp_path / "out" / "tank").iterdir())
    assert written == ["sup.smv", "tank.smv"]
    for name in written:
        said = (tmp_path / "out" / "tank" / name).read_text()
        assert said == (EXPECTED / f"{variant}.{name}").read_text(), name
