"""The generated CO reproduces the paper's Appendix C (co_sump_shear_cusp) cycle for cycle.

CO runs alone through the harness: its subordinates never run, the test plays them by
writing their status buffers and the world flags, and reads what CO sends each cycle.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.tools.harness import Harness

MINER = Path(__file__).resolve().parent.parent / "specs" / "miner"
SUBS = ("cr", "vg", "cc")


@pytest.fixture(scope="module")
def package():
    with Harness.build(MINER) as built:
        yield built.package


@pytest.fixture
def co(package):
    """A fresh block with CO given SUMP_SHEAR_CUSP; no subordinate has answered yet."""
    h = Harness(package)
    h.command("co", "SUMP_SHEAR_CUSP")
    return h


def sent(h: Harness) -> dict[str, tuple[str, int]]:
    return {sub: (h.sent(sub).command, h.sent(sub).number) for sub in SUBS}


def done(h: Harness, *subs: str) -> None:
    for sub in subs:
        h.reply(sub, "DONE")


def test_s0_sumps_all_three_and_positions_for_the_sump(co):
    co.world.update({"pose_x": 10.0, "pose_y": 2.0, "heading": 0.0})
    co.step("co")
    assert sent(co) == {"cr": ("SUMP", 1), "vg": ("TRAM_TO_XY", 1), "cc": ("SUMP", 1)}
    # co_position_for_sump: half a drum diameter ahead; the goal goes to vg as parameters.
    assert co.sent("vg").args == {"x": 10.5, "y": 2.0}
    assert co.world["goal_x"] == 10.5
    assert co.status("co").state == "S1"
    assert co.status("co").status == "EXECUTING"


def test_s1_waits_for_vg_and_cc_but_not_cr(co):
    co.step("co")
    done(co, "vg")
    co.step("co")
    assert co.status("co").state == "S1", "cc is still executing"
    done(co, "cc")  # cr has not answered: Appendix C does not wait for it here
    co.step("co")
    assert co.status("co").state == "S2"
    assert sent(co) == {"cr": ("SHEAR", 2), "vg": ("HALT", 2), "cc": ("SHEAR", 2)}


def shearing(h: Harness) -> Harness:
    h.step("co")
    done(h, "vg", "cc")
    h.step("co")
    assert h.status("co").state == "S2"
    return h


def test_popped_out_of_the_shear_corrects_and_resumps(co):
    shearing(co)
    co.world.update({"popped_out_of_shear": True, "pose_x": 3.0})
    co.step("co")
    assert co.status("co").state == "S1"
    assert sent(co)["cc"] == ("SHEAR_CORRECT", 3)
    assert sent(co)["vg"] == ("HALT", 2), "Appendix C does not re-command vg after a pop-out"
    assert co.world["goal_x"] == 3.5, "co_position_for_sump ran again"
    co.world["popped_out_of_shear"] = False
    done(co, "vg", "cc")
    co.step("co")
    assert co.status("co").state == "S2"
    assert sent(co) == {"cr": ("SHEAR", 3), "vg": ("HALT", 3), "cc": ("SHEAR", 4)}


def test_too_much_loose_coal_halts_the_shear_every_cycle_and_resumes_once(co):
    shearing(co)
    co.world["loose_coal"] = 6.0
    numbers = []
    for _ in range(3):
        co.step("co")
        assert co.sent("cc").command == "HALT"
        numbers.append(co.sent("cc").number)
        assert co.status("co").state == "S2", "the loose-coal halt stays in S2"
    assert numbers == [3, 4, 5], "Appendix C re-sends HALT (a new command) every cycle"
    co.world["loose_coal"] = 1.0
    co.step("co")
    assert sent(co)["cc"] == ("SHEAR", 6)
    co.step("co")
    assert sent(co)["cc"] == ("SHEAR", 6), "SHEAR is re-sent only while the last command was HALT"


def test_popped_out_takes_precedence_over_loose_coal(co):
    shearing(co)
    co.world.update({"loose_coal": 9.0, "popped_out_of_shear": True})
    co.step("co")
    assert sent(co)["cc"] == ("SHEAR_CORRECT", 3)
    assert co.status("co").state == "S1"


def test_cusp_waits_for_all_three_done_and_not_popped_out(co):
    shearing(co)
    done(co, "vg", "cc")
    co.step("co")
    assert co.status("co").state == "S2", "cr has not finished the shear"
    done(co, "cr")
    co.step("co")
    assert co.status("co").state == "S3"
    assert sent(co) == {"cr": ("CUSP", 3), "vg": ("HALT", 2), "cc": ("CUSP", 3)}


def test_s3_trams_back_for_the_cusp_and_s4_reports_done(co):
    shearing(co)
    done(co, "cr", "vg", "cc")
    co.step("co")
    assert co.status("co").state == "S3"
    co.world.update({"pose_x": 20.0, "pose_y": 1.0, "heading": 0.0})
    done(co, "cr", "cc")
    co.step("co")
    assert co.status("co").state == "S4"
    assert sent(co)["vg"] == ("TRAM_TO_XY", 3)
    assert co.sent("vg").args == {"x": 19.5, "y": 1.0}, "co_position_for_cusp backs off"
    co.step("co")
    assert co.status("co").status == "EXECUTING", "vg is still tramming"
    done(co, "vg")
    co.step("co")
    assert co.status("co").status == "DONE"
    assert co.status("co").state == "NOP"
    before = sent(co)
    co.step("co")
    assert sent(co) == before, "nothing more is sent once the command is done"


def test_the_whole_command_sequence_of_appendix_c(co):
    """Every command CO sends, in order, through sump, a pop-out, a loose-coal pause,
    shear, cusp and the final tram, with subordinates answering at once."""
    log: list[tuple[str, str]] = []
    last = {sub: 0 for sub in SUBS}
    script = {3: {"popped_out_of_shear": True}, 4: {"popped_out_of_shear": False}}
    script |= {5: {"loose_coal": 5.0}, 7: {"loose_coal": 0.0}}
    for cycle in range(1, 16):
        co.world.update(script.get(cycle, {}))
        co.step("co")
        for sub in SUBS:
            if co.sent(sub).number != last[sub]:
                last[sub] = co.sent(sub).number
                log.append((sub, co.sent(sub).command))
        done(co, *SUBS)
    assert log == [
        ("cr", "SUMP"), ("vg", "TRAM_TO_XY"), ("cc", "SUMP"),  # S0
        ("cr", "SHEAR"), ("vg", "HALT"), ("cc", "SHEAR"),  # S1 -> S2
        ("cc", "SHEAR_CORRECT"),  # popped out: S2 -> S1
        ("cr", "SHEAR"), ("vg", "HALT"), ("cc", "SHEAR"),  # S1 -> S2 again
        ("cc", "HALT"), ("cc", "HALT"),  # too much loose coal, two cycles
        ("cc", "SHEAR"),  # coal cleared: continue the shear
        ("cr", "CUSP"), ("cc", "CUSP"),  # S2 -> S3
        ("vg", "TRAM_TO_XY"),  # S3 -> S4
    ]  # fmt: skip
    assert co.status("co").status == "DONE"
