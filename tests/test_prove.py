"""`rcsgen prove`: the shipped systems' findings, seeded handshake bugs caught, counter-examples
replayed in the generated code (rcsgen/compiler/prove/, rcsgen/tools/replay.py)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
import test_prove_catalogue as catalogue

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.prove import INFINITE, diagnostics, prove_front
from rcsgen.tools.replay import replay_all
from rcsgen.tools.scenario import read_trace

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


FLEET = Path(__file__).resolve().parent / "fixtures" / "runtime" / "fleet"


def test_the_model_plays_the_runtimes_reaction_to_a_lost_process(tmp_path):
    """prove/lost.py asks rcs/loop.py's `reaction` itself, over the tables the generated
    layout holds: built from the IR, they are the layout's, for every shipped system and
    the fleet (on_lost: continue); and the model plays what the runtime does."""
    import importlib

    from rcsgen.compiler.prove.lost import RuntimeReaction, layout_view
    from rcsgen.runtime.loop import reaction
    from rcsgen.tools.harness import import_package, write_package

    front = compile_paths([SPECS, FLEET])
    assert not front.diagnostics.errors
    for system in front.systems:
        package = import_package(write_package(system, tmp_path / "out"))
        layout = importlib.import_module(f"{package.__name__}.layout")
        view = layout_view(system)
        names = ("PLACEMENT", "SUBORDINATES", "ON_LOST_CONTINUE", "MODULES", "SAFE_VALUES")
        for name in (*names, "SIMULATORS"):
            assert vars(view)[name] == getattr(layout, name), (system.name, name)
        assert vars(view)["ACTUATED_BY"] == layout.ACTUATED_BY
        model = RuntimeReaction(system)
        for p in system.processes:
            assert model.reactions[p.name] == reaction(layout, p.name)
    fleet = next(s for s in front.systems if s.name == "fleet")
    model = RuntimeReaction(fleet)
    # v1's process: halt_all - the leader goes to its safe state, every actuator latched
    hard = model.effect("lead", "pa")
    assert hard.safe_state and not hard.errors
    assert hard.latched == {"v1_drive", "v2_drive", "v2_brake"}
    # v2's process: contained - the leader reads v2 as ERROR, only pb's actuators latched
    soft = model.effect("lead", "pb")
    assert not soft.safe_state and soft.errors == ("v2",)
    assert soft.latched == {"v2_drive", "v2_brake"}
    proof = prove_front(compile_paths([FLEET])).proofs[0]
    graph = proof.graphs["lead"]
    after_pa = [(e, t) for es in graph.edges.values() for e, t in es if e.lost == "pa"]
    assert after_pa and all(e.safe_state for e, _ in after_pa)
    assert all(t.status == "ERROR" and t.state == "NOP" for e, t in after_pa if e.new is None)
    assert all(("v1", "HALT") in e.sends and ("v2", "HALT") in e.sends for e, _ in after_pa)
    after_pb = [e for es in graph.edges.values() for e, t in es if "pb" in t.lost]
    assert after_pb and not any(e.safe_state for e in after_pb if e.lost == "pb")
    # while pb is lost the leader reads v2's status as ERROR, whatever it sends v2
    assert all(e.views[1] == "ERROR" for e in after_pb)


def test_a_counter_example_the_code_does_not_follow_is_undecided(tmp_path):
    """The leader retries the vehicle whose process is lost (on_lost: continue): motion
    after ERROR, found through the loss - which a lockstep replay cannot reproduce, so the
    finding is undecided, never violated."""
    directory = tmp_path / "fleet"
    shutil.copytree(FLEET, directory)
    _edit(
        directory / "lead.yaml",
        """      S2:
        - when: v1.status == ERROR""",
        """      S2:
        - when: v2.status == ERROR and v1.status != ERROR
          do:
            - send: v2.DRIVE
        - when: v1.status == ERROR""",
    )
    front, result = _proved(directory)
    proof = result.proofs[0]
    lost = [i for i, f in enumerate(proof.findings) if any(e.lost for e, _ in f.trace)]
    assert {proof.findings[i].code for i in lost} >= {"W701"}
    replay_all(proof, front.systems[0], front.directories["fleet"], None, set(lost))
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
    last = read_trace(tmp_path / "t.jsonl")[-1]
    assert '"co":{' in last and '"status":"DONE"' in last.split('"co":{')[1].split("}")[0]


def test_every_shipped_system_proves_with_no_violation():
    from click.testing import CliRunner

    from rcsgen.cli import main

    result = CliRunner().invoke(main, ["prove", str(SPECS), "--no-replay", "-q"])
    assert result.exit_code == 0, result.output
    assert INFINITE > 0


def test_the_handshake_invariant_is_proven_by_induction():
    from rcsgen.compiler.prove import handshake

    if handshake.z3_or_none() is None:
        proven, said = handshake.prove_handshake()
        assert proven is None and "rcsgen[prove]" in said
        pytest.skip("z3-solver is not installed")
    proven, said = handshake.prove_handshake()
    assert proven is True, said
    # without numbering a send after an operator's command, an old echo can be believed
    broken, why = handshake.prove_handshake(renumber=False)
    assert broken is False
    intro = "a transition breaks the invariant: "
    assert why.startswith(intro)
    # the counter-example names each number before and after: a send numbered from the
    # supervisor's own count, below the buffer an operator's override raised, so the old
    # echo is ahead of the new number
    v = {k: int(n) for k, n in re.findall(r"(\w+) = (-?\d+)", why.removeprefix(intro))}
    names = ("buffer", "written", "sent", "echo", "status")
    assert set(v) == {*names, *(name + "2" for name in names)}
    assert v["echo"] <= v["buffer"] and v["written"] == v["sent"] <= v["buffer"]
    assert v["sent2"] == v["buffer2"] == v["written2"] == v["sent"] + 1 < v["buffer"]
    assert v["echo2"] == v["echo"] > v["buffer2"]


def test_without_z3_the_handshake_is_undecided_and_says_how_to_get_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from rcsgen.compiler.prove import handshake

    monkeypatch.setattr(handshake, "z3_or_none", lambda: None)
    assert handshake.prove_handshake() == (
        None,
        "the handshake invariant needs z3: install rcsgen[prove] (z3-solver)",
    )


# ---------------------------------------------------------------- small systems

TINY_SYSTEM = catalogue.TINY_SYSTEM
TINY_SUB = catalogue.TINY_SUB


def _tiny(tmp_path: Path, top: str, sub: str = TINY_SUB) -> Path:
    directory = tmp_path / "tiny"
    directory.mkdir()
    (directory / "system.yaml").write_text(TINY_SYSTEM)
    (directory / "sub.yaml").write_text(sub)
    (directory / "top.yaml").write_text(
        "controller: top\ntitle: Top\nsubordinates: [sub]\ncommands:\n" + top
    )
    return directory


def test_a_command_that_goes_round_for_ever_is_w702(tmp_path):
    directory = _tiny(
        tmp_path,
        catalogue.GOES_ROUND,
    )
    _, result = _proved(directory)
    assert ("W702", "top.yaml") in _shown(result)
    finding = next(f for f in result.proofs[0].findings if f.code == "W702")
    assert finding.command == "GO" and "never report DONE or ERROR" in finding.message


def test_motion_after_halt_is_w706(tmp_path):
    directory = _tiny(
        tmp_path,
        catalogue.MOTION_AFTER_HALT,
    )
    _, result = _proved(directory)
    assert ("W706", "top.yaml") in _shown(result)
    finding = next(f for f in result.proofs[0].findings if f.code == "W706")
    assert finding.rule == 1 and finding.state == "S1" and "sub.MOVE" in finding.message


LATCH_SYSTEM = catalogue.LATCH_SYSTEM
LATCH_TOP = catalogue.LATCH_TOP


def test_a_latch_holds_until_an_explicit_reset(tmp_path):
    """docs/semantics.md "Fail safe": under halt_all the loss of sub's process latches every
    actuator of the system - the lamp top writes too - and only `ctl reset` releases it:
    not the safe state's end, not a new command. The model keeps the latch, so a GO after the
    loss lights no lamp until the reset; under `on_lost: continue` only b's actuators are
    latched, none of which top writes."""
    directory = tmp_path / "latch"
    directory.mkdir()
    (directory / "system.yaml").write_text(LATCH_SYSTEM)
    (directory / "sub.yaml").write_text(TINY_SUB)
    (directory / "top.yaml").write_text(LATCH_TOP)
    _, result = _proved(directory)
    graph = result.proofs[0].graphs["top"]
    edges = [(s, e, t) for s, es in graph.edges.items() for e, t in es]
    safe = [(s, e, t) for s, e, t in edges if e.safe_state]
    assert safe and all(t.latched == {"lamp"} for _, _, t in safe)
    latched_go = [e for s, e, _ in edges if s.latched and e.new == "GO" and not e.reset]
    assert latched_go and not any("lamp" in e.unsafe for e in latched_go)
    resets = [(s, t) for s, e, t in edges if e.reset]
    assert resets and all(s.latched and not t.latched for s, t in resets)
    # nothing but a reset releases: every edge from a latched state keeps it, or resets
    assert all(t.latched >= s.latched for s, e, t in edges if not e.reset)
    free_go = [e for s, e, _ in edges if not s.latched and e.new == "GO"]
    assert any("lamp" in e.unsafe for e in free_go)  # unlatched, the lamp is the table's
    # the loss is the supervisor's own business: nothing it writes is latched
    (directory / "top.yaml").write_text(
        LATCH_TOP.replace(
            "subordinates: [sub]\n", "subordinates: [sub]\non_lost:\n  sub: continue\n"
        )
    )
    _, result = _proved(directory)
    graph = result.proofs[0].graphs["top"]
    lost = [t for es in graph.edges.values() for e, t in es if e.lost == "b"]
    assert lost and not any(e.safe_state for es in graph.edges.values() for e, _ in es)
    assert all(not t.latched for es in graph.edges.values() for _, t in es)


def test_a_wait_that_goes_on_on_a_done_it_already_took_is_w707(tmp_path):
    """S2 waits for sub's DONE again without sending it anything: the DONE S1 went on on
    is stale (a `send:` left out); the same wait after a new send is fine."""
    top = catalogue.STALE_DONE
    _, result = _proved(_tiny(tmp_path, top))
    found = [f for f in result.proofs[0].findings if f.code == "W707"]
    assert [(f.state, f.rule) for f in found] == [("S2", 1)], found
    assert "sub.MOVE" in found[0].message
    fixed = top.replace(
        "          next: S2\n", "          do: [send: sub.MOVE]\n          next: S2\n", 1
    )
    (tmp_path / "fixed").mkdir()
    _, result = _proved(_tiny(tmp_path / "fixed", fixed))
    assert not [f for f in result.proofs[0].findings if f.code == "W707"]


def test_going_on_before_the_echo_is_w708(tmp_path):
    """`sub.status != ERROR` is true while sub is EXECUTING: S1 goes on before MOVE's echo."""
    top = catalogue.NO_ECHO
    _, result = _proved(_tiny(tmp_path, top))
    found = [f for f in result.proofs[0].findings if f.code == "W708"]
    assert [(f.state, f.rule) for f in found] == [("S1", 1)], found
    assert "goes on while sub.MOVE is still executing" in found[0].message


def test_a_subordinate_before_its_supervisor_in_the_order_is_w704(tmp_path):
    """HALT reach as fast as the process split allows: sub placed before top reads top's
    HALT a cycle late - a finding at top, not only a larger bound."""
    top = catalogue.WAITS
    directory = _tiny(tmp_path, top)
    _, result = _proved(directory)
    assert not [f for f in result.proofs[0].findings if f.code == "W704"]
    before = {b.leaf: b.cycles for b in result.proofs[0].halt}
    _edit(directory / "system.yaml", "modules: [top, sub]", "modules: [sub, top]")
    _, result = _proved(directory)
    found = [f for f in result.proofs[0].findings if f.code == "W704"]
    assert [(f.controller, f.command) for f in found] == [("top", "HALT")]
    assert "sub runs before its supervisor top" in found[0].message
    assert {b.leaf: b.cycles for b in result.proofs[0].halt} == {"sub": before["sub"] + 1}


def test_a_deployment_adds_a_cycle_per_host_crossed(tmp_path):
    """`rcsgen prove --deploy`: pp (pc2) on another host than pc1 reads vg's HALT one cycle
    later again; a bad deployment file is its located error, exit 2."""
    from click.testing import CliRunner

    from rcsgen.cli import main

    deploy = tmp_path / "deploy.json"
    deploy.write_text(
        '{"system": "miner", "hosts": {'
        '"vehicle": {"processes": ["pc1"], "listen": ["tcp/192.0.2.10:7447"]},'
        '"planner": {"processes": ["pc2"], "connect": ["tcp/192.0.2.10:7447"]}}}'
    )
    args = ["prove", str(SPECS / "miner"), "--no-replay"]
    one = CliRunner().invoke(main, args)
    two = CliRunner().invoke(main, [*args, "--deploy", str(deploy)])
    assert one.exit_code == 0 and two.exit_code == 0, two.output
    assert "pp       k=2 " in one.output and "pp       k=3 " in two.output
    assert "tc       k=1 " in two.output  # on pc1 with its supervisors: no host crossed
    deploy.write_text('{"system": "miner", "hosts": {"vehicle": {"processes": ["pc9"]}}}')
    bad = CliRunner().invoke(main, [*args, "--deploy", str(deploy)])
    assert bad.exit_code == 2 and "error[E43" in bad.output and "Traceback" not in bad.output
