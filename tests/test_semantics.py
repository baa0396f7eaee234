"""The QQ1 semantics of generated controllers (docs/semantics.md), one test per rule.

Everything runs through the harness on the generated miner (built once per module) or on
the purpose-built three-level chain in tests/fixtures/semantics/chain. Each test gets a
fresh private block; `h.step(m)` runs one module alone, `h.cycle()` one whole cycle.
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import subprocess
import sys
import time
from multiprocessing import shared_memory
from pathlib import Path
from types import ModuleType

import pytest
from conftest import REPO

from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import trace_line

ROOT = Path(__file__).resolve().parent.parent
MINER = ROOT / "tests" / "fixtures" / "foundation" / "miner"  # the small foundation miner
FIXTURES = Path(__file__).resolve().parent / "fixtures" / "semantics"
CHAIN = FIXTURES / "chain"
PACKED = FIXTURES / "packed"
TICKER = FIXTURES / "ticker"
SUBS = ("cr", "vg", "cc")


# ---------------------------------------------------------------- fixtures and helpers


@pytest.fixture(scope="module")
def miner():
    with Harness.build(MINER) as built:
        yield built.package


@pytest.fixture
def h(miner):
    """A fresh block for the miner, nothing sent yet."""
    return Harness(miner)


@pytest.fixture(scope="module")
def chain_command_first():
    """The chain a -> b -> c run in the order [a, b, c]: supervisors first."""
    with Harness.build(CHAIN) as built:
        assert built.modules == ("a", "b", "c")
        yield built.package


@pytest.fixture(scope="module")
def chain_status_first(tmp_path_factory):
    """The same chain run in the order [c, b, a]: a copy of the fixture with the order reversed."""
    spec = tmp_path_factory.mktemp("semantics") / "chain"
    shutil.copytree(CHAIN, spec)
    system = spec / "system.yaml"
    text = system.read_text(encoding="utf-8")
    assert "modules: [a, b, c]" in text
    system.write_text(text.replace("modules: [a, b, c]", "modules: [c, b, a]"), encoding="utf-8")
    with Harness.build(spec) as built:
        assert built.modules == ("c", "b", "a")
        yield built.package


@pytest.fixture(scope="module")
def packed():
    """One controller and world fields bool, bool, float, int (tests/fixtures/semantics/packed)."""
    with Harness.build(PACKED) as built:
        yield built.package


@pytest.fixture(scope="module")
def ticker():
    """One controller `tk`: an every_cycle rule counting world.ticks, COPY copying it to
    world.seen, EITHER with one guarded rule per state (tests/fixtures/semantics/ticker)."""
    with Harness.build(TICKER) as built:
        yield built.package


@pytest.fixture
def tk(ticker):
    return Harness(ticker)


def codes(h: Harness) -> ModuleType:
    """The generated package's runtime constants (EXECUTING, DONE, ...)."""
    return importlib.import_module(f"{h.package.__name__}.rcs.contract")


def sent(h: Harness) -> dict[str, tuple[str, int]]:
    return {sub: (h.sent(sub).command, h.sent(sub).number) for sub in SUBS}


def snapshot(h: Harness, *modules: str) -> dict[str, tuple[str, int, str]]:
    """(status, status number, state) of each module, as its supervisor's buffer shows them."""
    return {m: (h.status(m).status, h.status(m).number, h.status(m).state) for m in modules}


def shearing(h: Harness) -> None:
    """Whole cycles of SUMP_SHEAR_CUSP until co is in S2 (the shear): exactly 6 cycles."""
    h.command("co", "SUMP_SHEAR_CUSP")
    h.cycle(5)
    assert h.status("co").state == "S1", "vg trams 4 cycles, cc sumps 5: co still waits"
    h.cycle()
    assert h.status("co").state == "S2"
    assert sent(h) == {"cr": ("SHEAR", 2), "vg": ("HALT", 2), "cc": ("SHEAR", 2)}


# ---------------------------------------------------------------- the command-number handshake


def test_new_command_is_echoed_and_its_table_runs_in_the_same_cycle(h):
    """A new command number is echoed, sets EXECUTING and runs S0 in the same cycle."""
    number = h.command("cc", "SUMP")
    assert number == 1
    assert snapshot(h, "cc") == {"cc": ("NOT_READY", 0, "NOP")}
    h.step("cc")
    # S0 ran in this cycle: it set ticks to 1 and moved to S1.
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S1")}
    assert h.controller("cc").var_ticks == 1


def test_the_same_number_again_is_not_a_new_command(h):
    """Re-writing the command buffer with the same number does not restart the command."""
    h.command("cc", "SUMP")
    h.step("cc")
    h.step("cc")
    assert h.controller("cc").var_ticks == 2
    sump = h.layout.COMMAND_NAMES["cc"].index("SUMP")
    h.layout.COMMAND_IN["cc"].write(h.buf, command_num=1, command=sump)
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S1")}
    assert h.controller("cc").var_ticks == 3, "the table went on from S1, not through S0"


def test_a_new_number_for_the_same_command_restarts_it_at_s0(h):
    """The same command with a new number is a new command: the table restarts at S0."""
    h.command("cc", "SUMP")
    for _ in range(3):
        h.step("cc")  # cc alone: a whole cycle would run co, which owns cc's command buffer
    assert h.controller("cc").var_ticks == 3
    assert h.command("cc", "SUMP") == 2
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 2, "S1")}
    assert h.controller("cc").var_ticks == 1, "S0 ran again"


def test_only_the_number_marks_a_new_command_not_the_code(h):
    """A new command code under the old number is not new: the new table runs from the old state."""
    h.command("cc", "SUMP")
    h.step("cc")
    h.layout.COMMAND_IN["cc"].write(h.buf, command=h.layout.COMMAND_NAMES["cc"].index("SHEAR"))
    h.step("cc")
    # SHEAR's S1 ran (ticks 1 -> 2); its S0 never did.
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S1")}
    assert h.controller("cc").var_ticks == 2


def test_a_done_command_stays_done_until_a_new_number(h):
    """After report: DONE the state is NOP and nothing runs until a new command number."""
    h.command("cc", "INIT")
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("DONE", 1, "NOP")}
    h.step("cc")
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("DONE", 1, "NOP")}


def test_a_subordinate_is_executing_until_it_echoes_the_last_number_sent(h):
    """A subordinate's status counts as EXECUTING until its status number echoes the last send."""
    rcs = codes(h)
    h.command("co", "INIT")
    h.cycle(2)
    assert snapshot(h, "co") == {"co": ("DONE", 1, "NOP")}
    h.command("co", "HALT")
    h.step("co")
    assert sent(h) == {"cr": ("HALT", 2), "vg": ("HALT", 2), "cc": ("HALT", 2)}
    h.reply("cr", "DONE")
    h.reply("vg", "DONE")
    # cc's buffer still holds DONE for INIT (number 1): a stale echo.
    assert snapshot(h, "cc") == {"cc": ("DONE", 1, "NOP")}
    h.step("co")
    assert h.controller("co").cc_status == rcs.EXECUTING
    assert h.controller("co").cr_status == rcs.DONE
    assert snapshot(h, "co") == {"co": ("EXECUTING", 2, "S1")}
    h.reply("cc", "DONE", number=1)  # a stale echo again, written explicitly
    h.step("co")
    assert snapshot(h, "co") == {"co": ("EXECUTING", 2, "S1")}
    h.reply("cc", "DONE", number=2)
    h.step("co")
    assert h.controller("co").cc_status == rcs.DONE
    assert snapshot(h, "co") == {"co": ("DONE", 2, "NOP")}


def test_an_echo_with_executing_is_still_executing(h):
    """The echoed number alone is not enough: the echoed status must be DONE for a DONE guard."""
    h.command("co", "INIT")
    h.step("co")
    for sub in SUBS:
        h.reply(sub, "EXECUTING")
    h.step("co")
    assert snapshot(h, "co") == {"co": ("EXECUTING", 1, "S1")}
    for sub in SUBS:
        h.reply(sub, "DONE")
    h.step("co")
    assert snapshot(h, "co") == {"co": ("DONE", 1, "NOP")}


def test_every_send_increments_the_subordinates_command_number(h):
    """Each send is a new number; Appendix C's loose-coal HALT is re-sent every cycle."""
    shearing(h)
    h.world["loose_coal"] = 6.0
    for number in (3, 4, 5, 6):
        h.cycle()
        assert (h.sent("cc").command, h.sent("cc").number) == ("HALT", number)
        # cc ran after co in the same cycle and took each HALT as a new command.
        assert snapshot(h, "cc") == {"cc": ("DONE", number, "NOP")}
        assert h.status("co").state == "S2"
    # cr and vg were not re-commanded.
    assert (h.sent("cr").number, h.sent("vg").number) == (2, 2)
    h.world["loose_coal"] = 1.0
    h.cycle()
    assert (h.sent("cc").command, h.sent("cc").number) == ("SHEAR", 7)
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 7, "S1")}
    h.cycle(3)
    assert (h.sent("cc").command, h.sent("cc").number) == ("SHEAR", 7), (
        "SHEAR is re-sent only while the last command to cc was HALT"
    )


def test_after_a_pop_out_s1_waits_for_vg_and_cc_and_vg_is_not_recommanded(h):
    """Appendix C quirk: a pop-out sends only SHEAR_CORRECT; S1 then re-shears with a new HALT."""
    shearing(h)
    h.world["popped_out_of_shear"] = True
    h.cycle()
    assert h.status("co").state == "S1"
    assert sent(h) == {"cr": ("SHEAR", 2), "vg": ("HALT", 2), "cc": ("SHEAR_CORRECT", 3)}
    h.world["popped_out_of_shear"] = False
    h.cycle(3)  # cc corrects for 3 cycles; vg's HALT was DONE long ago
    assert h.status("co").state == "S1"
    h.cycle()
    assert h.status("co").state == "S2"
    assert sent(h) == {"cr": ("SHEAR", 3), "vg": ("HALT", 3), "cc": ("SHEAR", 4)}


def test_command_numbers_are_64_bit(h):
    """Command numbers are 64-bit: a number past 2**32 is echoed unchanged (no wrap)."""
    init = h.layout.COMMAND_NAMES["cc"].index("INIT")
    h.layout.COMMAND_IN["cc"].write(h.buf, command_num=2**40 + 5, command=init)
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("DONE", 2**40 + 5, "NOP")}


# ---------------------------------------------------------------- INIT and HALT default tables


@pytest.mark.parametrize("command", ["INIT", "HALT"])
@pytest.mark.parametrize("late", SUBS)
def test_default_table_sends_to_all_and_waits_for_all_done(h, command, late):
    """Default INIT/HALT: send to every subordinate in one cycle, DONE only when all are DONE."""
    h.command("co", command)
    h.step("co")
    assert sent(h) == {sub: (command, 1) for sub in SUBS}
    assert snapshot(h, "co") == {"co": ("EXECUTING", 1, "S1")}
    for sub in SUBS:
        if sub != late:
            h.reply(sub, "DONE")
    h.step("co")
    h.step("co")
    assert snapshot(h, "co") == {"co": ("EXECUTING", 1, "S1")}, "two DONE are not enough"
    h.reply(late, "DONE")
    h.step("co")
    assert snapshot(h, "co") == {"co": ("DONE", 1, "NOP")}
    assert sent(h) == {sub: (command, 1) for sub in SUBS}, "nothing is re-sent"


@pytest.mark.parametrize("command", ["INIT", "HALT"])
def test_default_table_on_a_leaf_is_done_in_the_same_cycle(h, command):
    """Default INIT/HALT on a controller with no subordinates: DONE in the cycle it arrives."""
    h.command("cc", command)
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("DONE", 1, "NOP")}


def test_a_spec_may_override_the_default_halt(chain_command_first):
    """c declares its own HALT (S0 -> S1 -> DONE): one cycle more than the default on a leaf."""
    h = Harness(chain_command_first)
    h.command("c", "HALT")
    h.step("c")
    assert snapshot(h, "c") == {"c": ("EXECUTING", 1, "S1")}
    h.step("c")
    assert snapshot(h, "c") == {"c": ("DONE", 1, "NOP")}
    h.command("c", "INIT")  # INIT is still the default
    h.step("c")
    assert snapshot(h, "c") == {"c": ("DONE", 2, "NOP")}


# ---------------------------------------------------------------- modes


def test_dont_run_echoes_a_new_command_but_runs_no_table(h):
    """dont_run: the new-command check still echoes (EXECUTING, S0) but no table runs."""
    h.set_mode("co", dont_run=True)
    h.command("co", "INIT")
    h.step("co")
    h.step("co")
    assert snapshot(h, "co") == {"co": ("EXECUTING", 1, "S0")}
    assert sent(h) == {sub: ("NONE", 0) for sub in SUBS}, "no commands sent"
    assert h.performance("co")["cycles"] == 2, "the cycle is still measured"
    h.set_mode("co", dont_run=False)
    h.step("co")
    assert snapshot(h, "co") == {"co": ("EXECUTING", 1, "S1")}
    assert sent(h) == {sub: ("INIT", 1) for sub in SUBS}


def test_the_status_names_the_table_rule_that_fired_this_cycle(h):
    """Status `rule`: the rule that fired in the module's last cycle, None when none did
    (waiting, held by dont_run); every_cycle rules are not recorded."""
    h.command("co", "INIT")
    h.step("co")
    assert h.status("co").rule == "INIT/S0/1", "S0 sends INIT to every subordinate"
    h.step("co")
    assert h.status("co").rule is None, "S1 waits for every subordinate's DONE"
    for sub in SUBS:
        h.reply(sub, "DONE")
    h.step("co")
    assert (h.status("co").rule, h.status("co").status) == ("INIT/S1/1", "DONE")
    h.set_mode("co", dont_run=True)
    h.command("co", "HALT")
    h.step("co")
    assert h.status("co").rule is None, "no table runs under dont_run"
    h.set_mode("co", dont_run=False)
    h.step("co")
    assert h.status("co").rule == "HALT/S0/1"


def test_single_step_runs_the_table_once_per_change_of_single_step_num(h):
    """single_step: the table runs one cycle each time single_step_num changes, else it holds."""
    h.set_mode("cc", single_step=True)
    h.command("cc", "SUMP")
    h.step("cc")
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S0")}, "echoed, table held"
    ticks = []
    for step_num in (1, 2, 3):
        h.set_mode("cc", single_step_num=step_num)
        for _ in range(3):
            h.step("cc")
            ticks.append(h.controller("cc").var_ticks)
        assert h.performance("cc")["single_step_num"] == step_num
    assert ticks == [1, 1, 1, 2, 2, 2, 3, 3, 3]
    h.set_mode("cc", single_step_num=10)  # a jump of 7 is one change: one cycle
    h.step("cc")
    h.step("cc")
    assert h.controller("cc").var_ticks == 4
    h.set_mode("cc", single_step=False)
    h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("DONE", 1, "NOP")}, "running freely again"


def test_dont_run_takes_precedence_over_single_step(h):
    """Modes: with dont_run set a change of single_step_num is not consumed; it runs on clearing."""
    h.set_mode("cc", single_step=True, dont_run=True, single_step_num=1)
    h.command("cc", "SUMP")
    h.step("cc")
    assert h.performance("cc")["single_step_num"] == 0
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S0")}
    h.set_mode("cc", dont_run=False)
    h.step("cc")
    h.step("cc")
    assert h.controller("cc").var_ticks == 1, "one cycle for the pending change"


def test_a_step_number_changed_while_running_freely_is_one_step_when_single_step_starts(h):
    """Modes: single_step_num changed with single_step off gives one cycle when it is turned on."""
    h.command("cc", "SUMP")
    h.set_mode("cc", single_step_num=5)
    h.step("cc")
    h.step("cc")
    assert h.controller("cc").var_ticks == 2
    assert h.performance("cc")["single_step_num"] == 0, "free running does not track it"
    h.set_mode("cc", single_step=True)
    for _ in range(3):
        h.step("cc")
    assert h.controller("cc").var_ticks == 3


def test_every_cycle_rules_run_after_the_mode_checks_and_before_the_table(tk):
    """every_cycle: held by dont_run and single_step like the table; when the module runs, the
    rules run first, so the table sees their writes in the same cycle."""
    tk.command("tk", "COPY")
    tk.step("tk")
    assert tk.world.snapshot(["ticks", "seen"]) == {"ticks": 1, "seen": 1}, "before the table"
    tk.step("tk")
    assert tk.world.snapshot(["ticks", "seen"]) == {"ticks": 2, "seen": 2}
    tk.set_mode("tk", dont_run=True)
    tk.step("tk")
    tk.step("tk")
    assert tk.world.snapshot(["ticks", "seen"]) == {"ticks": 2, "seen": 2}, "dont_run holds it"
    tk.set_mode("tk", dont_run=False, single_step=True)
    tk.step("tk")
    assert tk.world.snapshot(["ticks", "seen"]) == {"ticks": 2, "seen": 2}, "single_step holds it"
    tk.set_mode("tk", single_step_num=1)
    tk.step("tk")
    tk.step("tk")
    assert tk.world.snapshot(["ticks", "seen"]) == {"ticks": 3, "seen": 3}, "one step"
    assert tk.status("tk").status == "EXECUTING"


def test_every_cycle_rules_run_whatever_the_command(tk):
    """every_cycle runs with no command at all, and after the command has finished."""
    tk.step("tk")
    assert tk.world["ticks"] == 1 and tk.status("tk").state == "NOP"
    tk.command("tk", "EITHER")
    tk.world["a"] = True
    tk.step("tk")
    tk.step("tk")
    assert tk.status("tk").status == "DONE"
    tk.step("tk")
    assert tk.world["ticks"] == 4


def test_a_single_rule_guard_holds_only_in_its_own_state(tk):
    """A state with one guarded rule: `when: world.a or world.b` in S1 fires only in S1,
    however its guard is joined with the state test (b alone neither fires it in S0 nor
    after the command is DONE)."""
    tk.command("tk", "EITHER")
    tk.world["b"] = True
    for _ in range(3):
        tk.step("tk")
    assert snapshot(tk, "tk") == {"tk": ("EXECUTING", 1, "S0")}, "S0 waits for a"
    assert tk.world["hits"] == 0
    tk.world["a"] = True
    tk.step("tk")
    assert snapshot(tk, "tk") == {"tk": ("EXECUTING", 1, "S1")}
    tk.world["a"] = False
    tk.step("tk")
    assert snapshot(tk, "tk") == {"tk": ("DONE", 1, "NOP")}, "b alone fires S1's rule"
    assert tk.world["hits"] == 1
    for _ in range(3):
        tk.step("tk")
    assert snapshot(tk, "tk") == {"tk": ("DONE", 1, "NOP")}
    assert tk.world["hits"] == 1, "no state: no rule fires"


def test_a_command_code_without_a_table_is_echoed_and_stays_executing(h):
    """A code with no state table (e.g. NONE) is echoed as EXECUTING and then nothing happens."""
    h.layout.COMMAND_IN["cc"].write(h.buf, command_num=1, command=0)
    for _ in range(3):
        h.step("cc")
    assert snapshot(h, "cc") == {"cc": ("EXECUTING", 1, "S0")}


# ---------------------------------------------------------------- performance buffer


def test_performance_buffer_counts_cycles(h):
    """Performance: every module counts its cycles; min <= last <= max whatever the clock."""
    h.command("co", "SUMP_SHEAR_CUSP")
    h.cycle(7)
    for module in h.modules:
        perf = h.performance(module)
        assert perf["cycles"] == 7
        assert perf["min_cycle_ns"] <= perf["last_cycle_ns"] <= perf["max_cycle_ns"]
    h.step("cc")
    assert h.performance("cc")["cycles"] == 8
    assert h.performance("co")["cycles"] == 7
    # Wall time never enters a trace: a trace line carries no performance field.
    line = json.loads(trace_line(h, []))
    assert set(line["modules"]["co"]) == {
        "command",
        "command_num",
        "status",
        "status_num",
        "state",
        "rule",
    }
    assert "cycle_ns" not in json.dumps(line)


def test_performance_buffer_times_each_cycle_on_its_clock(h, monkeypatch):
    """Performance: last = the cycle's clock difference (pre_process start to post_process);
    max the longest; min the shortest, starting from the first measured cycle."""
    controller = type(h.controller("cc"))
    module = sys.modules[controller.__module__]
    starts = iter(range(1000, 100_000, 1000))  # each cycle starts on a fresh thousand
    durations = iter([40, 25, 60, 30, 25])
    readings: list[int] = []

    def clock() -> int:
        if len(readings) % 2 == 0:
            readings.append(next(starts))
        else:
            readings.append(readings[-1] + next(durations))
        return readings[-1]

    monkeypatch.setattr(module, "perf_counter_ns", clock)
    h.command("cc", "SUMP")
    seen = []
    for _ in range(5):
        h.step("cc")
        perf = h.performance("cc")
        seen.append((perf["last_cycle_ns"], perf["min_cycle_ns"], perf["max_cycle_ns"]))
    assert seen == [(40, 40, 40), (25, 25, 40), (60, 25, 60), (30, 25, 60), (25, 25, 60)]
    assert h.performance("cc")["cycles"] == 5
    assert len(readings) == 10, "two clock readings per cycle"


# ---------------------------------------------------------------- world model and execution order


def test_world_write_is_seen_by_an_earlier_module_only_next_cycle(h):
    """World: vg writes pose_x in post_process; co (before vg) copies it in the next pre_process."""
    co = h.controller("co")
    h.command("co", "SUMP_SHEAR_CUSP")  # pose (0, 0), heading 0: vg trams to (0.5, 0)
    h.cycle(3)
    assert h.world["pose_x"] == 0.0
    h.cycle()  # cycle 4: vg reaches the goal and writes the pose
    assert h.world["pose_x"] == 0.5
    assert h.controller("vg").world_pose_x == 0.5
    assert co.world_pose_x == 0.0, "co ran before vg in this cycle"
    h.cycle()
    assert co.world_pose_x == 0.5
    assert not hasattr(h.controller("cc"), "world_pose_x"), "cc declares no world fields"


def test_world_write_is_seen_by_a_later_module_in_the_same_cycle(chain_command_first):
    """World: a writes mark in post_process; c (after a) copies it in the same cycle."""
    h = Harness(chain_command_first)
    h.command("a", "MARK")
    h.cycle()
    assert h.world["mark"] == 1
    assert h.controller("c").world_mark == 1
    assert snapshot(h, "a") == {"a": ("DONE", 1, "NOP")}


def test_world_write_reaches_an_earlier_module_next_cycle_in_status_first_order(
    chain_status_first,
):
    """World: in the order [c, b, a], c sees a's write of mark one cycle later."""
    h = Harness(chain_status_first)
    h.command("a", "MARK")
    h.cycle()
    assert h.world["mark"] == 1
    assert h.controller("c").world_mark == 0
    h.cycle()
    assert h.controller("c").world_mark == 1
    assert h.world["mark"] == 1, "MARK ran once"


def test_command_first_order_in_the_miner(h):
    """Command-first [co, cr, vg, cc]: a command reaches cc in its cycle; DONE reaches co next."""
    h.command("co", "INIT")
    h.cycle()
    assert snapshot(h, "co", *SUBS) == {
        "co": ("EXECUTING", 1, "S1"),
        "cr": ("DONE", 1, "NOP"),
        "vg": ("DONE", 1, "NOP"),
        "cc": ("DONE", 1, "NOP"),
    }
    h.cycle()
    assert snapshot(h, "co") == {"co": ("DONE", 1, "NOP")}


def test_command_first_chain_command_down_in_one_cycle_status_up_one_level_per_cycle(
    chain_command_first,
):
    """Command-first [a, b, c]: INIT reaches c in cycle 1; DONE climbs one level per cycle."""
    h = Harness(chain_command_first)
    h.command("a", "INIT")
    h.cycle()
    assert snapshot(h, "a", "b", "c") == {
        "a": ("EXECUTING", 1, "S1"),
        "b": ("EXECUTING", 1, "S1"),
        "c": ("DONE", 1, "NOP"),
    }
    h.cycle()
    assert snapshot(h, "a", "b") == {"a": ("EXECUTING", 1, "S1"), "b": ("DONE", 1, "NOP")}
    h.cycle()
    assert snapshot(h, "a") == {"a": ("DONE", 1, "NOP")}


def test_status_first_chain_command_down_one_level_per_cycle_status_up_in_one(
    chain_status_first,
):
    """Status-first [c, b, a]: INIT reaches c in cycle 3; DONE climbs to a in that same cycle."""
    h = Harness(chain_status_first)
    h.command("a", "INIT")
    h.cycle()
    assert snapshot(h, "a", "b", "c") == {
        "a": ("EXECUTING", 1, "S1"),
        "b": ("NOT_READY", 0, "NOP"),
        "c": ("NOT_READY", 0, "NOP"),
    }
    h.cycle()
    assert snapshot(h, "a", "b", "c") == {
        "a": ("EXECUTING", 1, "S1"),
        "b": ("EXECUTING", 1, "S1"),
        "c": ("NOT_READY", 0, "NOP"),
    }
    h.cycle()
    assert snapshot(h, "a", "b", "c") == {
        "a": ("DONE", 1, "NOP"),
        "b": ("DONE", 1, "NOP"),
        "c": ("DONE", 1, "NOP"),
    }


def test_overridden_halt_adds_its_cycle_to_the_chain(chain_command_first):
    """HALT through the chain: c's two-cycle HALT makes the round trip 4 cycles (INIT takes 3)."""
    h = Harness(chain_command_first)
    h.command("a", "HALT")
    done_at = None
    for cycle in range(1, 8):
        h.cycle()
        if done_at is None and h.status("a").status == "DONE":
            done_at = cycle
    assert done_at == 4


# ---------------------------------------------------------------- deliberate differences from C


def test_the_supervisor_writes_a_command_buffer_when_it_sends(h):
    """A supervisor writes its subordinate's command buffer when it sends; an outside write
    (an operator's) stays until then, and the supervisor's next command is numbered after it,
    so the subordinate sees it as new."""
    h.command("co", "INIT")
    h.step("co")
    assert (h.sent("cc").command, h.sent("cc").number) == ("INIT", 1)
    h.command("cc", "SUMP")  # an outside write: number 2
    h.step("co")  # co waits for INIT's DONE: it sends nothing
    assert (h.sent("cc").command, h.sent("cc").number) == ("SUMP", 2)
    h.command("co", "HALT")
    h.step("co")  # HALT S0 sends HALT to every subordinate
    assert (h.sent("cc").command, h.sent("cc").number) == ("HALT", 3)
    assert h.controller("co").cc_command_num == 3


def test_a_world_output_is_written_in_the_cycles_a_rule_set_it_only(h):
    """post_process writes a world field it owns when a rule set it to another value than
    the block holds (its sequence word moves on); an outside write between cycles stays."""
    goal = h.layout.WORLD["goal_x"]
    h.command("co", "INIT")
    h.cycle(3)
    before = goal.seq(h.buf)
    h.cycle(3)
    assert goal.seq(h.buf) == before, "nothing set goal_x: its buffer was not written"
    h.world["goal_x"] = 7.5  # an operator's write between cycles
    h.cycle()
    assert h.world["goal_x"] == 7.5
    h.command("co", "SUMP_SHEAR_CUSP")
    seq = goal.seq(h.buf)
    h.cycle()  # S0: co_position_for_sump sets the goal
    assert goal.seq(h.buf) == seq + 2 and h.world["goal_x"] == h.controller("co").world_goal_x
    assert h.world["goal_x"] != 7.5


def test_run_cycle_is_the_one_copy_of_the_four_steps(miner):
    """Appendix D's qq1_controller: one cycle, its four steps named in order, no second
    copy of them as methods (a second copy is a second place to get wrong)."""
    from rcsgen.compiler.back_end.emit import MARKER

    text = (REPO / "generated" / "miner" / "co.py").read_text()
    assert text.startswith(MARKER)
    cycle = text[text.index("    def run_cycle(self") : text.index("    def read_inputs(self")]
    steps = ["pre_process", "check_if_new_command", "decision_process", "post_process"]
    at = [cycle.index(f"        # {n}. {step}:") for n, step in enumerate(steps, start=1)]
    assert at == sorted(at)
    for step in steps:
        assert f"def {step}(" not in text
    controller = Harness(miner).controller("co")
    assert not any(hasattr(controller, step) for step in steps)


def test_a_restarted_controller_resumes_its_handshake_from_the_block(h):
    """A controller built on a used block reads its numbers back: no spurious new command."""
    h.command("co", "INIT")
    h.cycle(2)
    process = type(h.process)(h.process.plan, h.layout, h.block)  # a restart on the same block
    process.run_cycle()
    assert snapshot(h, "co") == {"co": ("DONE", 1, "NOP")}, "INIT #1 is not new again"
    h.command("co", "HALT")
    process.run_cycle()
    assert sent(h) == {sub: ("HALT", 2) for sub in SUBS}, "numbers go on from the block"


# ---------------------------------------------------------------- the main loop and the block


def test_run_starts_sends_init_to_the_roots_and_counts_cycles(miner):
    """Main loop: run(cycles=5, pace=False) starts, sends INIT to the roots, runs 5 cycles."""
    main = importlib.import_module(f"{miner.__name__}.main_pc1")
    layout = importlib.import_module(f"{miner.__name__}.layout")
    contract = importlib.import_module(f"{miner.__name__}.rcs.contract")
    assert main.PLAN.roots == ("co",)
    process = main.run(cycles=5, pace=False)
    assert process.cycle == 5
    buf = process.block.buf
    assert layout.COMMAND_IN["co"].read(buf) == {"command_num": 1, "command": 1}  # INIT
    for module in main.PLAN.modules:
        status = layout.STATUS_OUT[module].read(buf)
        assert (status["status_num"], contract.STATUS_NAMES[status["status"]]) == (1, "DONE")
        assert layout.PERFORMANCE[module].read(buf)["cycles"] == 5
    stopped = main.run(cycles=None, pace=False, on_cycle=lambda p: p.cycle >= 3)
    assert stopped.cycle == 3, "on_cycle returning True stops an unbounded run"


def test_pacer_sleeps_the_rest_of_each_period_and_counts_overruns(miner):
    """Pacer: sleeps to each period boundary; an overrun is counted and restarts the schedule;
    a sleep that ends more than a tenth of a period late is a late wake-up."""
    rcs = importlib.import_module(f"{miner.__name__}.rcs.loop")
    # start; then each wait reads the clock, and after a sleep reads it again
    times = iter([100.0, 100.03, 100.101, 100.25, 100.30, 100.37, 100.44, 100.45])
    slept: list[float] = []
    pacer = rcs.Pacer(0.1, clock=lambda: next(times), sleep=slept.append)
    assert pacer.deadline == pytest.approx(100.1)
    pacer.wait()  # 100.03: 0.07 left; woke at 100.101, on time
    pacer.wait()  # 100.25: past 100.2, an overrun; the next boundary is 100.35
    assert (pacer.overruns, pacer.behind(10)) == (1, pytest.approx(0.5))
    pacer.wait()  # 100.30: 0.05 left; woke at 100.37, 0.02 late: a late wake-up
    assert pacer.behind(10) == pytest.approx(0.7), "how late the recent cycles started"
    pacer.wait()  # 100.44: 0.01 left (the boundary is 100.45); woke on time
    assert slept == pytest.approx([0.07, 0.05, 0.01])
    assert (pacer.overruns, pacer.late) == (1, 1)
    flat = rcs.Pacer(0.0, clock=lambda: 0.0, sleep=slept.append)
    flat.wait()
    assert len(slept) == 3 and flat.overruns == 0, "period 0 never sleeps"


def records(layout: ModuleType) -> dict[str, object]:
    """Every buffer of the block by its layout name (CO_COMMAND, ..., WORLD_LOOSE_COAL)."""
    found = {}
    for kind, table in (
        ("COMMAND", layout.COMMAND_IN),
        ("STATUS", layout.STATUS_OUT),
        ("MODE", layout.MODE_IN),
        ("PERF", layout.PERFORMANCE),
    ):
        for module, record in table.items():
            found[f"{module.upper()}_{kind}"] = record
    for name, record in layout.WORLD.items():
        found[f"WORLD_{name.upper()}"] = record
    for name, record in layout.PROCESSES.items():
        found[f"PROCESS_{name.upper()}"] = record
    for name, record in layout.PACING.items():
        found[f"PACE_{name.upper()}"] = record
    for name, record in layout.OVERRIDE.items():
        found[f"OVERRIDE_{name.upper()}"] = record
    for name, record in layout.TIME_IN_STATE.items():
        found[f"TIME_{name.upper()}"] = record
    found["OVERRIDES"] = layout.OVERRIDES
    return found


@pytest.mark.parametrize("system", ["miner", "packed"])
def test_layout_docstring_table_is_the_layout(request, system):
    """Layout: the table in layout.py's docstring gives every buffer's true offset and size."""
    package = request.getfixturevalue(system).__name__
    layout = importlib.import_module(f"{package}.layout")
    contract = importlib.import_module(f"{package}.rcs.contract")
    rows = {}
    for line in layout.__doc__.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[0].isdigit():
            shape = getattr(contract, cells[3], None)  # STATUS_FIELDS: a buffer of that shape
            fields = contract.field_names(shape) if shape else tuple(cells[3].split(", "))
            rows[cells[2]] = (int(cells[0]), int(cells[1]), fields)
    actual = {
        name: (r.offset, r.struct.size, tuple(r.fields)) for name, r in records(layout).items()
    }
    assert rows == actual
    spans = sorted((offset, offset + size) for offset, size, _ in rows.values())
    assert all(end <= start for (_, end), (start, _) in zip(spans, spans[1:], strict=False))
    assert spans[-1][1] <= layout.SIZE and layout.SIZE % 8 == 0
    assert all(r.struct.format.startswith("<") for r in records(layout).values())


def test_layout_is_little_endian_at_fixed_offsets(h):
    """Layout: each field sits at its buffer's fixed offset, little-endian, packed in order."""
    at = h.layout.CO_COMMAND_AT
    h.layout.COMMAND_IN["co"].write(h.buf, command_num=0x0102030405060708, command=3)
    # The sequence word first: initialise leaves it at 2 (whole), one write odd then even: 4.
    assert bytes(h.buf[at : at + 20]) == bytes.fromhex("0400000000000000080706050403020103000000")
    at = h.layout.WORLD_LOOSE_COAL_AT
    h.world["loose_coal"] = 1.0
    assert bytes(h.buf[at + 8 : at + 16]) == bytes.fromhex("000000000000f03f")
    assert int.from_bytes(h.buf[at : at + 8], "little") % 2 == 0
    h.command("cc", "INIT")
    h.step("cc")
    # cc's status: status_num 1, DONE (2), error_num 0, state NOP (0), rule 1 (INIT/S0/1).
    at = h.layout.CC_STATUS_AT
    assert bytes(h.buf[at + 8 : at + 32]) == bytes.fromhex(
        "010000000000000002000000000000000000000001000000"
    )


def test_initialise_sets_the_world_and_flags_the_simulators(packed, miner):
    """Layout: initialise() zeroes the block, writes world initial values, flags simulators."""
    h = Harness(packed)
    assert h.world.snapshot() == {"flag_a": True, "flag_b": False, "level": 1.5, "count": -2}
    assert h.layout.MODE_IN["solo"].read(h.buf)["simulate"] is False
    m = Harness(miner)
    simulate = {name: m.layout.MODE_IN[name].read(m.buf)["simulate"] for name in m.modules}
    assert simulate == {"co": False, "cr": True, "vg": True, "cc": True}
    assert all(m.performance(name)["cycles"] == 0 for name in m.modules)


def test_every_buffer_starts_on_an_8_byte_boundary(packed):
    """Layout: as the generated docstring says, each buffer starts on an 8-byte boundary."""
    layout = importlib.import_module(f"{packed.__name__}.layout")
    offsets = {name: r.offset for name, r in records(layout).items()}
    assert {name: at for name, at in offsets.items() if at % 8} == {}


def attach_in_child(package_dir: Path, script: str, *args: str) -> subprocess.CompletedProcess:
    """Run `script` in a fresh Python process with the package's `layout` and `rcs` imported."""
    prelude = (
        "import importlib, json, os, sys\n"
        f"sys.path.insert(0, {str(package_dir.parent)!r})\n"
        f"layout = importlib.import_module('{package_dir.name}.layout')\n"
        f"rcs = importlib.import_module('{package_dir.name}.rcs.block')\n"
    )
    return subprocess.run(
        [sys.executable, "-c", prelude + script, *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=package_dir.parent,
    )


def test_block_on_named_shared_memory_is_seen_by_an_attached_block(miner):
    """Shared memory: another process attaches by name and reads the same co status."""
    main = importlib.import_module(f"{miner.__name__}.main_pc1")
    layout = importlib.import_module(f"{miner.__name__}.layout")
    rcs = importlib.import_module(f"{miner.__name__}.rcs.block")
    contract = importlib.import_module(f"{miner.__name__}.rcs.contract")
    name = f"rcsgen_sem_{os.getpid()}_{time.monotonic_ns() % 10**9}"
    process = main.start(name, create=True)
    try:
        process.run_cycle()
        process.run_cycle()
        child = attach_in_child(
            Path(miner.__file__).parent,
            "block = rcs.Block(layout, sys.argv[1], create=False)\n"
            "print(json.dumps(layout.STATUS_OUT['co'].read(block.buf)))\n"
            "block.close()\n",
            name,
        )
        assert child.returncode == 0, child.stderr
        assert child.stderr == ""
        theirs = json.loads(child.stdout)
        assert theirs == layout.STATUS_OUT["co"].read(process.block.buf)
        assert (theirs["status_num"], contract.STATUS_NAMES[theirs["status"]]) == (1, "DONE")
        # The attacher's close did not remove the segment: it still opens by name.
        shared_memory.SharedMemory(name=name).close()
    finally:
        process.block.close()
    with pytest.raises(rcs.BlockError, match="no shared-memory segment"):
        rcs.Block(layout, name, create=False)  # the creator unlinked it


def test_attaching_to_a_named_block_leaves_it_as_it_was(miner):
    """start(create=False) neither zeroes the block nor resets the world, and sends no INIT
    to a root that has had a command: everything but the attaching process's own control
    record (its heartbeat) and its modules' time-in-state clocks (which close the interval
    the creator left open) is as the creator left it, and its controllers resume from it."""
    main = importlib.import_module(f"{miner.__name__}.main_pc1")
    layout = importlib.import_module(f"{miner.__name__}.layout")
    name = f"rcsgen_sem_attach_{os.getpid()}_{time.monotonic_ns() % 10**9}"
    creator = main.start(name, create=True)
    try:
        for _ in range(3):
            creator.run_cycle()
        layout.WORLD["loose_coal"].write(creator.block.buf, loose_coal=4.5)  # initial: 0.0
        expected = bytes(creator.block.buf[: layout.SIZE])
        assert main.PLAN.roots == ("co",)
        assert layout.COMMAND_IN["co"].read(creator.block.buf)["command_num"] == 1
        attached = main.start(name, create=False)
        try:
            found = bytes(attached.block.buf[: layout.SIZE])  # no view left: close() can work
            co = attached.modules["co"]
            resumed = (co.status_num, co.world_loose_coal)
        finally:
            attached.block.close()
        changed = [n for n, r in records(layout).items() if r.read(found) != r.read(expected)]
        own = ["PROCESS_PC1"] + [  # and the time-in-state clocks of the modules it runs
            f"TIME_{m.upper()}" for m in layout.TIME_IN_STATE if m in main.PLAN.modules
        ]
        assert changed == [n for n in own if n in changed] and "PROCESS_PC1" in changed, (
            "the attacher rewrote these buffers"
        )
        assert resumed == (1, 4.5)
    finally:
        creator.block.close()


def test_a_segment_outlives_the_death_of_its_creator(miner):
    """Lifecycle: no process's death removes the segment under the others (Python's resource
    tracker is kept out of it): the creator dies without closing, the segment stays for
    the processes still attached, and whoever cleans up removes it."""
    name = f"rcsgen_sem_dies_{os.getpid()}_{time.monotonic_ns() % 10**9}"
    child = attach_in_child(
        Path(miner.__file__).parent,
        "owner = rcs.Block(layout, sys.argv[1], create=True)\n"
        "rcs.Block(layout, sys.argv[1], create=False).close()\n"
        "os._exit(0)  # dies without closing\n",
        name,
    )
    assert child.returncode == 0, child.stderr
    assert "leaked" not in child.stderr, child.stderr
    rcs = importlib.import_module(f"{miner.__name__}.rcs.block")
    layout = importlib.import_module(f"{miner.__name__}.layout")
    try:
        survivor = rcs.Block(layout, name, create=False)  # still there, still this layout
        survivor.close()
    finally:
        assert rcs.unlink(name), "the segment was still there to remove"
    assert not rcs.exists(name)
