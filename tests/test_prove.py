"""`rcsgen prove`: the shipped systems' findings, seeded handshake bugs caught, counter-examples
replayed in the generated code (rcsgen/compiler/prove/, rcsgen/tools/replay.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import INFINITE, diagnostics, prove_front
from rcsgen.tools.replay import replay_all

SPECS = Path(__file__).resolve().parents[1] / "specs"


def _proved(directory: Path):
    front = compile_paths([directory])
    assert not front.diagnostics.errors, [d.render() for d in front.diagnostics.errors]
    return front, prove_front(front)


def _shown(result) -> list[tuple[str, str]]:
    """(code, controller) of every finding no acknowledgement covers."""
    return sorted({(d.code, d.span.file.split("/")[-1]) for d in diagnostics(result).items})


@pytest.fixture(scope="module")
def miner():
    return _proved(SPECS / "miner")


def test_the_miners_appendix_c_behaviour_is_found_and_acknowledged(miner):
    front, result = miner
    proof = result.proofs[0]
    co = {(f.code, f.state) for f in proof.findings if f.controller == "co"}
    # after vg's ERROR, SUMP_SHEAR_CUSP still pauses and resumes the shear (two modules,
    # several cycles: what validate cannot state), and waits for ever in S1
    assert ("W701", "S2") in co and ("W703", "S1") in co and ("W705", "S1") in co
    acknowledged = {(d.code, d.subject.controller) for d in diagnostics(result).acknowledged}
    assert {("W701", "co"), ("W703", "co"), ("W705", "co")} <= acknowledged
    w701 = next(f for f in proof.findings if f.code == "W701" and f.controller == "co")
    assert [sub for e, _ in w701.trace for sub, a in e.answers if a == "ERROR"] == ["vg"]
    assert w701.trace[0][0].new == "SUMP_SHEAR_CUSP"


def test_halt_bounds_per_leaf_follow_the_execution_order(miner):
    _, result = miner
    halt = {b.leaf: b for b in result.proofs[0].halt if b.start == "sec"}
    assert halt["bm"].cycles == 1 and halt["bm"].safe == 1  # command-first on pc1
    assert halt["pp"].cycles == 2  # pp runs on pc2: one more cycle
    states = result.proofs[0].controllers["co"].states
    assert 0 < states < 400_000 and result.proofs[0].controllers["co"].complete


def _copy(tmp_path: Path, system: str) -> Path:
    target = tmp_path / system
    shutil.copytree(SPECS / system, target, ignore=shutil.ignore_patterns("scenarios"))
    return target


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, old
    path.write_text(text.replace(old, new, 1))


# Seeded handshake bugs: (name, file, old text, new text, a finding it must cause)
DROP_ERROR_BRANCH = (  # tc's safety time-out is an ERROR vg must pass up
    "vg.yaml",
    """          next: STOPPING
        - when: tc.status == ERROR
          do:
            - report: ERROR
      REVERSE:""",
    """          next: STOPPING
      REVERSE:""",
)
FORGET_ECHO = (  # APPROACH_FACE takes "not ERROR" for done: it does not wait for the echo
    "co.yaml",
    """      S2:
        - when: vg.status == DONE""",
    """      S2:
        - when: vg.status != ERROR""",
)
REMOVE_HALT = (
    "bm.yaml",
    """  HALT:
    doc: Stop the boom where it is.
    states:
      S0:
        - do:
            - set: {world.boom_rate_cmd: 0.0}
            - report: DONE
""",
    "",
)
DROP_SEND = (
    "cc.yaml",
    """commands:
""",
    """commands:
  HALT:
    doc: Halt all actions (written out; a send dropped).
    states:
      S0:
        - do: [send: bm.HALT, send: cd.HALT]
          next: S1
      S1:
        - when: bm.status == DONE and cd.status == DONE
          do: [report: DONE]
""",
)


@pytest.mark.parametrize(
    ("mutant", "expected", "replays"),
    [
        # vg decides on its `steer` hook's result, which a replay cannot script: undecided
        (DROP_ERROR_BRANCH, {("W705", "vg.yaml")}, False),
        (FORGET_ECHO, {("W708", "co.yaml")}, True),
        (REMOVE_HALT, {("W704", "bm.yaml")}, True),
        (DROP_SEND, {("W704", "cc.yaml")}, True),
    ],
    ids=["drop-error-branch", "forget-echo", "remove-halt-table", "drop-send"],
)
def test_seeded_handshake_bugs_are_caught_and_replay(tmp_path, mutant, expected, replays):
    directory = _copy(tmp_path, "miner")
    file, old, new = mutant
    _edit(directory / file, old, new)
    front, result = _proved(directory)
    shown = set(_shown(result))
    assert expected <= shown, shown
    proof = result.proofs[0]
    caught = [
        i for i, f in enumerate(proof.findings) if (f.code, f.span.file.split("/")[-1]) in expected
    ]
    replay_all(proof, front.systems[0], front.directories["miner"], tmp_path / "cex", set(caught))
    verdicts = {proof.findings[i].verdict for i in caught}
    if replays:
        assert "violated" in verdicts, [proof.findings[i].replay for i in caught]
    else:  # never "violated" when the code does not follow the counter-example
        assert verdicts == {"undecided"}
        assert all("departs" in proof.findings[i].replay for i in caught)
    written = sorted((tmp_path / "cex").glob("*.yaml"))
    assert len(written) == len(caught)


def test_swapping_two_modules_in_the_order_changes_the_bounds(tmp_path, miner):
    _, before = miner
    directory = _copy(tmp_path, "miner")
    _edit(directory / "system.yaml", "[sec, sb, co, cc, bm,", "[sec, sb, cc, co, bm,")
    _, after = _proved(directory)
    old = {(b.start, b.leaf): b.cycles for b in before.proofs[0].halt}
    new = {(b.start, b.leaf): b.cycles for b in after.proofs[0].halt}
    assert new[("sec", "bm")] == old[("sec", "bm")] + 1  # cc now reads co's HALT a cycle late


def test_a_counter_example_the_code_does_not_follow_is_undecided(miner, tmp_path):
    front, result = miner
    proof = result.proofs[0]
    lost = [i for i, f in enumerate(proof.findings) if any(e.lost for e, _ in f.trace)]
    assert lost  # vg: pp's process pc2 lost, then a new command waits for it
    replay_all(proof, front.systems[0], front.directories["miner"], None, set(lost))
    for i in lost:
        assert proof.findings[i].verdict == "undecided"
        assert "lost" in proof.findings[i].replay


def test_the_written_scenario_runs(tmp_path):
    from click.testing import CliRunner

    from rcsgen.cli import main

    directory = _copy(tmp_path, "miner")
    _edit(directory / FORGET_ECHO[0], FORGET_ECHO[1], FORGET_ECHO[2])
    runner = CliRunner()
    proved = runner.invoke(main, ["prove", str(directory), "--format", "json"])
    assert proved.exit_code == 1, proved.output
    assert '"W708"' in proved.stdout
    scenario = next((directory / "counterexamples").glob("co_w708_*.yaml"))
    ran = runner.invoke(main, ["run", str(scenario), "--trace", str(tmp_path / "t.jsonl")])
    assert ran.exit_code == 0, ran.output
    last = (tmp_path / "t.jsonl").read_text().splitlines()[-1]
    assert '"co":{' in last and '"status":"DONE"' in last.split('"co":{')[1].split("}")[0]


def test_every_shipped_system_proves_with_no_violation():
    from click.testing import CliRunner

    from rcsgen.cli import main

    result = CliRunner().invoke(main, ["prove", str(SPECS), "--no-replay", "-q"])
    assert result.exit_code == 0, result.output
    assert INFINITE > 0


def test_the_handshake_invariant_is_proven_by_induction():
    from rcsgen.compiler.prove import handshake

    if not handshake.available():
        proven, said = handshake.prove_handshake()
        assert proven is None and "rcsgen[prove]" in said
        pytest.skip("z3-solver is not installed")
    proven, said = handshake.prove_handshake()
    assert proven is True, said
    # without numbering a send after an operator's command, an old echo can be believed
    broken, why = handshake.prove_handshake(renumber=False)
    assert broken is False and why
