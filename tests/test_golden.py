"""Golden traces: the committed generated system runs each scenario exactly as recorded.

A mismatch names the first differing cycle and field and the command that re-records the
golden file; re-record only after reading the diff, and say why in the commit message.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from rcsgen.harness import Harness
from rcsgen.scenario import first_difference, load_scenario, read_trace, run

ROOT = Path(__file__).resolve().parent.parent
MINER = ROOT / "specs" / "miner"
GOLDEN = ROOT / "tests" / "golden"
SCENARIOS = sorted((MINER / "scenarios").glob("*.yaml"))


def run_scenario(path: Path, package: Path = ROOT / "generated" / "miner"):
    scenario = load_scenario(path)
    harness = Harness.load(package, scenario.system_dir, scenario.process, send_init=True)
    return run(scenario, harness)


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.stem)
def test_scenario_matches_its_golden_trace(path):
    golden = GOLDEN / f"{path.stem}.jsonl"
    result = run_scenario(path)
    mismatch = first_difference(read_trace(golden), result.trace)
    rel = path.relative_to(ROOT)
    assert mismatch is None, (
        f"{path.stem}: {mismatch}\nif the change is intended, re-record with\n"
        f"  rcsgen run {rel} --record tests/golden/{golden.name}\nand review the diff"
    )


def test_every_scenario_has_a_golden_trace():
    assert SCENARIOS, "no scenarios found"
    assert sorted(p.stem for p in GOLDEN.glob("*.jsonl")) == [p.stem for p in SCENARIOS]


def test_sump_shear_cusp_does_what_appendix_c_says():
    """Asserted directly, so a wrong golden file cannot hide a wrong machine."""
    result = run_scenario(MINER / "scenarios" / "sump_shear_cusp.yaml")
    lines = [json.loads(line) for line in result.trace]
    assert result.final["status"] == "DONE"
    co_states = [line["modules"]["co"]["state"] for line in lines]
    cc_commands = [line["modules"]["cc"]["command"] for line in lines]
    # S0 runs within the cycle the command arrives, so the trace shows S1 onwards, in order.
    seen = [s for i, s in enumerate(co_states) if i == 0 or s != co_states[i - 1]]
    assert seen == ["S1", "NOP", "S1", "S2", "S1", "S2", "S3", "S4", "NOP"]
    assert "SHEAR_CORRECT" in cc_commands, "the pop-out was corrected"
    halts = {
        line["modules"]["cc"]["command_num"]
        for line in lines
        if line["modules"]["cc"]["command"] == "HALT"
    }
    assert len(halts) > 1, "the loose-coal HALT is re-sent while too much coal lies in front"
    assert lines[-1]["world"]["loose_coal"] == 0.0, "gathering cleared the loose coal"


def test_first_difference_names_cycle_and_field():
    a = [
        '{"cycle":1,"modules":{"co":{"state":"S1"}}}',
        '{"cycle":2,"modules":{"co":{"state":"S2"}}}',
    ]
    b = [a[0], '{"cycle":2,"modules":{"co":{"state":"S3"}}}']
    mismatch = first_difference(a, b)
    assert (mismatch.cycle, mismatch.field, mismatch.expected, mismatch.actual) == (
        2,
        "modules.co.state",
        "S2",
        "S3",
    )
    assert str(mismatch) == "cycle 2: `modules.co.state` expected 'S2', got 'S3'"
    assert first_difference(a, a) is None
    assert first_difference(a, a[:1]).field == "length"


def test_editing_a_guard_is_caught_with_the_first_differing_cycle(tmp_path):
    """A one-guard change in co.yaml shows up as a golden mismatch at a named cycle and field."""
    import shutil

    specs = tmp_path / "miner"
    shutil.copytree(MINER, specs)
    co = specs / "co.yaml"
    text = co.read_text(encoding="utf-8")
    old = "when: too_much_loose_coal()\n"
    assert old in text
    co.write_text(
        text.replace(old, "when: too_much_loose_coal() and world.loose_coal > 9.0\n"),
        encoding="utf-8",
    )
    with Harness.build(specs) as built:
        result = run_scenario(
            specs / "scenarios" / "sump_shear_cusp.yaml", Path(built.package.__path__[0])
        )
    mismatch = first_difference(read_trace(GOLDEN / "sump_shear_cusp.jsonl"), result.trace)
    assert mismatch is not None
    # The loose coal (6 t) no longer pauses the shear: cc keeps its SHEAR from cycle 14 on.
    assert (mismatch.cycle, mismatch.field) == (14, "modules.cc.command")
    assert (mismatch.expected, mismatch.actual) == ("HALT", "SHEAR")
