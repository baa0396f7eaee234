"""The miner's scenarios, asserted directly: each one's defining behaviour, so a wrong
golden file cannot hide a wrong machine (the golden comparison is in test_golden.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import yaml
from support.golden_runs import golden_run

from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import load_scenario
from rcsgen.tools.traces import mine as mine_view
from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces.mine import import_hooks

ROOT = Path(__file__).resolve().parent.parent
SCENARIOS = ROOT / "specs" / "miner" / "scenarios"
GOLDEN = ROOT / "tests" / "golden"
mine_hooks = import_hooks(ROOT / "specs" / "miner", "miner_hooks.mine")  # the map, the cutting


def played(name: str) -> tuple[dict, list[dict]]:
    """A scenario's run on the committed generated package: (final status, trace lines),
    as its golden trace records them (support/golden_runs.py says why that is the run)."""
    return golden_run("miner", name)


def commands_sent(lines: list[dict], module: str) -> list[str]:
    """Each new command `module` received, in order (one entry per command number)."""
    seen, out = 0, []
    for line in lines:
        entry = line["modules"][module]
        if entry["command_num"] != seen:
            seen = entry["command_num"]
            out.append(entry["command"])
    return out


def test_nominal_box_cut_three_slices_to_depth():
    final, lines = played("box_cut")
    assert final["status"] == "DONE"
    co = commands_sent(lines, "co")
    assert co == [
        "INIT",
        "INITIAL_APPROACH_FACE",
        "SUMP_SHEAR_CUSP",
        "APPROACH_FACE",
        "SUMP_SHEAR_CUSP",
        "APPROACH_FACE",
        "SUMP_SHEAR_CUSP",
        "HALT",
    ]
    world = lines[-1]["world"]
    assert abs(world["depth_cut"] - 1.5) <= DEPTH_TOLERANCE, "stopped at the ordered depth"
    assert world["coal_mined"] > 10.0 and world["loose_coal"] <= 0.05
    assert not world["drum_on_cmd"] and not world["conveyor_on_cmd"], "stopped at the end"


# The box cut ends within half a map cell (0.25 m cells) of the ordered depth, measured on
# the simulation's truth: the controllers only know world modelling's estimate.
DEPTH_TOLERANCE = 0.125


def test_the_last_sump_is_shortened_to_stop_at_the_ordered_depth():
    for name, depth in (("box_cut", 1.5), ("sump_shear_cusp", 0.5)):
        _, lines = played(name)
        steps = [line["world"]["sump_step"] for line in lines]
        assert steps[-1] < 0.5, f"{name}: the last sump was shortened"
        assert abs(lines[-1]["world"]["depth_cut"] - depth) <= DEPTH_TOLERANCE, name


def test_world_modelling_estimates_the_depth_from_the_sensed_pose():
    _, lines = played("box_cut")
    estimates = [(line["world"]["depth_est"], line["world"]["depth_cut"]) for line in lines]
    assert estimates[-1][0] > 1.45, "the shift boss decided on the estimate"
    slices = {round(est, 2) for est, _ in estimates if est > 0.0}
    assert len(slices) >= 3, "the estimate grows slice by slice"
    ends = [
        line["world"]
        for line in lines
        if line["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
        and line["modules"]["co"]["status"] == "DONE"
    ]
    assert ends, "slices ended"
    for world in ends:  # where the shift boss decides: after each slice
        assert abs(world["depth_est"] - world["depth_cut"]) <= 0.125, "within half a map cell"


def test_no_controller_uses_a_ground_truth_field():
    miner = ROOT / "specs" / "miner"
    system = yaml.safe_load((miner / "system.yaml").read_text("utf-8"))
    truth = {name for name, field in system["world"].items() if field.get("ground_truth")}
    assert {"depth_cut", "loose_coal_true", "true_x", "boom_angle_true", "in_coal"} <= truth
    simulated = set(system["simulators"]) | set(system["stand_ins"].values())
    controllers = [yaml.safe_load(p.read_text("utf-8")) for p in sorted(miner.glob("*.yaml"))]
    controllers = [c for c in controllers if "controller" in c]
    checked = [c for c in controllers if c["controller"] not in simulated]
    assert {"sb", "co", "cr", "wm", "vg", "pp"} <= {c["controller"] for c in checked}
    for spec in checked:
        world = spec.get("world", {})
        used = set(world.get("reads", [])) | set(world.get("writes", []))
        assert not used & truth, f"{spec['controller']} uses {sorted(used & truth)}"


def test_the_cusp_tram_takes_the_floor_wedge_and_coal_removal_gathers_it():
    _, lines = played("box_cut")
    cusp = [
        line
        for line in lines
        if line["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
        and line["modules"]["co"]["state"] == "S4"
    ]
    assert cusp, "co trammed back to take the cusp"
    assert all(line["world"]["gather_on_cmd"] and line["world"]["conveyor_on_cmd"] for line in cusp)
    mined = [line["world"]["coal_mined"] for line in cusp]
    assert mined[-1] > mined[0], "coal cut on the way back was gathered"


def _plain_cut(mine, x, y, boom_angle, drum_on):
    """cut_coal as the plain walk over `seam` it replaced (no grid, no kept levels, face or
    last call): what the kept values must never change."""
    m = mine_hooks
    height = (boom_angle - m.FLOOR_ANGLE) / (m.ROOF_ANGLE - m.FLOOR_ANGLE)
    bottom = max(0.0, min(1.0, height) * (1.0 - m.DRUM_HEIGHT))
    levels = []
    for c in m._span(x - m.DRUM_RADIUS, x + m.DRUM_RADIUS, mine.x0):
        level = min(1.0, bottom + m._wedge(mine, x, c))
        levels.append((c, 0.0 if level < m.CUT_THROUGH else level))
    contact, tonnes = False, 0.0
    for r in m._span(y - m.DRUM_HALF_WIDTH, y + m.DRUM_HALF_WIDTH, mine.y0):
        for c, level in levels:
            standing = mine.seam.get((r, c))
            if standing is not None and standing > level:
                contact = True
                if drum_on:
                    tonnes += (standing - level) * m.TONNES_PER_CELL
                    mine.seam[r, c] = level
                    if level <= m.FACE_MIN and mine.first.get(r) == c:
                        after = [
                            k
                            for k in range(c + 1, mine.columns)
                            if mine.seam.get((r, k), 0.0) > m.FACE_MIN
                        ]
                        if after:
                            mine.first[r] = after[0]
                        else:
                            del mine.first[r]
    now = m.face(mine, y)
    return contact, round(now, 6), round(now - mine.first_face, 6), round(tonnes, 6)


def test_cut_coal_keeps_nothing_that_changes_its_answer():
    """cut_coal keeps a grid, the levels, the face and its last call between calls: over a
    seeded walk of the drum (repeated calls, the drum off and on, the boom up and down, the
    map's edge, `seam` replaced half-way as the trace replay does) every answer, the map and
    each row's first coal are those of the plain walk."""
    import random

    kept, plain = load_mine(), load_mine()
    rng = random.Random(5)
    x, y, angle, drum = kept.first_face - 0.6, 0.0, 30.0, True
    answers = 0
    for step in range(1200):
        if step == 600:
            kept.seam = type("Wrapped", (dict,), {})(kept.seam)  # a replay's recorder
        move = rng.random()
        if move < 0.3:
            x += rng.choice((0.05, 0.05, 0.05, -0.05, 0.25))
        elif move < 0.5:
            angle = rng.choice((30.0, 10.0, -10.0, -10.0, -5.5))
        elif move < 0.6:
            y = rng.choice((0.0, 0.0, 0.0, 30.0))  # 30 m across: off the map
        elif move < 0.7:
            drum = not drum
        got = mine_hooks.cut_coal(kept, x, y, angle, drum)
        assert got == _plain_cut(plain, x, y, angle, drum), f"step {step}"
        answers += got[3] > 0.0
    assert answers > 50, "the walk cut coal"
    assert plain.first != load_mine().first, "and moved rows' first coal"
    assert dict(kept.seam) == plain.seam
    assert kept.first == plain.first


def test_the_hooks_rounding_gives_round_s_bits():
    """round6/round9 (miner_hooks/rounding.py: the simulators' fast rounding) give the bits
    `round(x, 6)` and `round(x, 9)` give: on seeded values of every size, values a hair from
    a tie (both sides), ties, tiny values of both signs (round keeps -0.0), huge and
    non-finite ones; and its fast path is the one taken for the usual values."""
    import math
    import random
    import struct

    rounding = import_hooks(ROOT / "specs" / "miner", "miner_hooks.rounding")
    rng = random.Random(24)
    values = [0.0, -0.0, math.inf, -math.inf, math.nan, 1e12, -1e12, 5e-7, -5e-7, 2.5e-6]
    for _ in range(15_000):
        values.append(rng.uniform(-300.0, 300.0))
        tie = rng.randrange(-(10**9), 10**9) + 0.5
        values += [tie / 1e6, math.nextafter(tie / 1e6, 0.0), math.nextafter(tie / 1e6, 9e9)]
        values += [tie / 1e9, math.nextafter(tie / 1e9, -9e9), rng.uniform(-1e-8, 1e-8)]
    bits = struct.Struct("<d").pack
    for x in values:
        assert bits(rounding.round6(x)) == bits(round(x, 6)), x
        assert bits(rounding.round9(x)) == bits(round(x, 9)), x
    calls: list[float] = []
    real = round  # the slow path (round with digits) counted, the fast one's round(p) not
    rounding.round = lambda x, n=None: real(x) if n is None else calls.append(x) or 0.0
    try:
        assert rounding.round6(12.3456789) == 12.345679 and rounding.round9(-1.25) == -1.25
    finally:
        del rounding.round
    assert not calls


def test_a_shear_leaves_a_floor_wedge_that_a_tram_back_at_the_floor_takes():
    mine = load_mine()
    face = mine.first_face
    x = face + 0.25  # drum centre, a slice into the face
    for angle in (30.0, 10.0, -10.0):  # sump at the roof, shear down to the floor
        mine_hooks.cut_coal(mine, x, 0.0, angle, True)
    behind = [c for c in range(mine.columns) if face - 0.25 < mine.x0 + (c + 0.5) * 0.25 < x]
    wedges = {c: mine.seam[(45, c)] for c in behind if (45, c) in mine.seam}
    assert wedges and all(0.0 < h <= mine_hooks.FACE_MIN for h in wedges.values()), wedges
    tonnes = 0.0
    for step in range(1, 11):  # tram back 0.5 m with the drum at the floor
        tonnes += mine_hooks.cut_coal(mine, x - 0.05 * step, 0.0, -10.0, True)[3]
    assert tonnes > 0.0, "the cusp is loose coal"
    assert all(mine.seam[(45, c)] == 0.0 for c in wedges), "nothing left on the floor behind"


def load_mine():
    return mine_hooks.load_map(ROOT / "specs" / "miner" / "maps" / "box_cut.map")


def test_one_slice_is_one_sump_shear_cusp():
    final, lines = played("sump_shear_cusp")
    assert final["status"] == "DONE"
    assert commands_sent(lines, "co").count("SUMP_SHEAR_CUSP") == 1
    assert commands_sent(lines, "cc") == [
        "INIT", "RAISE_DRUM", "SUMP", "SHEAR", "CUSP", "HALT"
    ]  # fmt: skip


def test_pop_out_is_corrected_and_the_cut_completes():
    final, lines = played("pop_out")
    assert final["status"] == "DONE"
    scenario = load_scenario(SCENARIOS / "pop_out.yaml")
    assert all(not event.world for event in scenario.events), "nothing is set by hand"
    cc = commands_sent(lines, "cc")
    first = cc.index("SHEAR_CORRECT")
    assert cc[first - 1 : first + 2] == ["SHEAR", "SHEAR_CORRECT", "SHEAR"], "corrected, again"
    popped = next(line["cycle"] for line in lines if line["world"]["popped_out_of_shear"])
    by_cycle = {line["cycle"]: line for line in lines}
    start = max(c for c in by_cycle if c < popped and by_cycle[c]["world"]["boom_angle"] >= 29.5)
    slid = by_cycle[start]["world"]["true_x"] - by_cycle[popped]["world"]["true_x"]
    assert slid > 0.1, "the roll in the seam floor slid the machine out of the cut"
    assert by_cycle[popped + 1]["modules"]["co"]["state"] == "S1", "co went back to S1 at once"
    cleared = next(
        c
        for c in sorted(by_cycle)
        if c > popped and not by_cycle[c]["world"]["popped_out_of_shear"]
    )
    assert by_cycle[cleared]["world"]["boom_angle"] >= 29.0, (
        "cleared with the boom back at the roof"
    )
    assert abs(lines[-1]["world"]["depth_cut"] - 1.5) <= DEPTH_TOLERANCE


def test_late_tail_halts_the_shear_until_the_tail_is_in_position():
    final, lines = played("late_tail")
    assert final["status"] == "DONE"
    halts = [  # co's loose-coal pauses (not the shift boss's HALT at the end)
        line
        for line in lines
        if line["modules"]["cc"]["command"] == "HALT"
        and line["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
    ]
    assert halts, "too much loose coal halted the shear"
    by_cycle = {line["cycle"]: line for line in lines}
    for line in halts:  # each HALT co sent was decided on the gauge's reading of the cycle before
        before = by_cycle[line["cycle"] - 1]
        if before["modules"]["cc"]["command_num"] != line["modules"]["cc"]["command_num"]:
            assert before["world"]["loose_coal"] > 4.0, "halted for coal"
    assert not halts[0]["world"]["tail_in_position"], "the tail was not there when it halted"
    placed = next(line["cycle"] for line in lines if line["world"]["tail_in_position"])
    assert halts[0]["cycle"] < placed <= halts[-1]["cycle"], "halted until after the tail came"
    numbers = {line["modules"]["cc"]["command_num"] for line in halts}
    assert len(numbers) > 1, "Appendix C re-sends HALT while there is too much coal"
    resumed = next(
        line
        for line in lines
        if line["cycle"] > halts[-1]["cycle"] and line["modules"]["cc"]["command"] == "SHEAR"
    )
    assert resumed["world"]["tail_in_position"], "the shear resumed once the tail was placed"
    assert lines[-1]["world"]["depth_cut"] >= 1.45


def test_stalled_tread_times_out_and_error_reaches_the_shift_boss():
    final, lines = played("stalled_tread")
    assert final["status"] == "ERROR"
    first_error = {}
    for line in lines:
        for module in ("tc", "vg", "co", "sb", "sec"):
            if line["modules"][module]["status"] == "ERROR":
                first_error.setdefault(module, line["cycle"])
    assert list(first_error) == ["tc", "vg", "co", "sb", "sec"], "ERROR climbs in order"
    assert first_error["vg"] - first_error["tc"] == 1, "one level per cycle, command-first"
    stalled = next(line["cycle"] for line in lines if line["world"]["tread_stalled"])
    assert first_error["tc"] - stalled >= 60, "the safety time-out, not an early failure"
    end = lines[-1]
    assert (end["world"]["left_tread_cmd"], end["world"]["right_tread_cmd"]) == (0, 0)
    assert end["modules"]["co"]["command"] == "HALT", "the shift boss stopped the machine"


def test_operator_halt_reaches_every_controller_in_one_cycle_then_restarts():
    final, lines = played("operator_halt")
    by_cycle = {line["cycle"]: line for line in lines}
    halt_cycle = next(
        c for c, line in by_cycle.items() if line["modules"]["sb"]["command"] == "HALT"
    )
    controllers = ["sb", "co", "cc", "bm", "cd", "sj", "cr", "gh", "cv", "ct", "vg", "pp", "tc"]
    halted = by_cycle[halt_cycle]["modules"]
    assert all(halted[m]["command"] == "HALT" for m in controllers), "HALT reached the bottom"
    assert all(halted[m]["status_num"] == halted[m]["command_num"] for m in controllers)
    assert by_cycle[halt_cycle - 1]["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
    assert by_cycle[halt_cycle]["world"]["boom_rate_cmd"] == 0.0, "the boom stopped"
    restart = next(
        c for c in sorted(by_cycle) if c > halt_cycle and halted_then(by_cycle[c], "BOX_CUT")
    )
    assert by_cycle[restart]["modules"]["co"]["command"] == "INITIAL_APPROACH_FACE"
    assert final["status"] == "DONE" and lines[-1]["world"]["depth_cut"] >= 1.45


def actuator_fields() -> list[str]:
    """The world fields the system declares `actuator: true`: what HALT must stop."""
    system = yaml.safe_load((ROOT / "specs" / "miner" / "system.yaml").read_text("utf-8"))
    return sorted(name for name, field in system["world"].items() if field.get("actuator"))


def test_operator_halt_in_mid_shear_leaves_every_actuator_stopped():
    _, lines = played("operator_halt")
    by_cycle = {line["cycle"]: line for line in lines}
    halt = next(c for c, line in by_cycle.items() if line["modules"]["sb"]["command"] == "HALT")
    before = by_cycle[halt - 1]
    assert before["modules"]["cc"]["command"] == "SHEAR", "halted during the shear"
    assert before["world"]["drum_on_cmd"] and before["world"]["boom_rate_cmd"] < 0.0
    restart = next(c for c in sorted(by_cycle) if c > halt and halted_then(by_cycle[c], "BOX_CUT"))
    fields = actuator_fields()
    assert {"drum_on_cmd", "jack_down_cmd", "tail_request", "left_tread_cmd"} <= set(fields)
    for cycle in range(halt, restart):
        world = by_cycle[cycle]["world"]
        stopped = {
            "boom_rate_cmd": world["boom_rate_cmd"] == 0.0,
            "drum_on_cmd": world["drum_on_cmd"] is False,
            "jack_down_cmd": world["jack_down_cmd"] == world["jack_down"],  # not travelling
            "left_tread_cmd": world["left_tread_cmd"] == 0,
            "right_tread_cmd": world["right_tread_cmd"] == 0,
            "gather_on_cmd": world["gather_on_cmd"] is False,
            "conveyor_on_cmd": world["conveyor_on_cmd"] is False,
            "tail_request": world["tail_request"] is False,
            "pan_float_cmd": True,  # a position the pan holds, not a motion
        }
        assert set(stopped) == set(fields), "every actuator field is judged"
        assert all(stopped.values()), f"cycle {cycle}: {[f for f, ok in stopped.items() if not ok]}"
    still = [by_cycle[c]["world"] for c in range(halt + 2, restart)]
    assert len({(w["true_x"], w["boom_angle_true"], w["jack_down"]) for w in still}) == 1, (
        "nothing moves while halted"
    )


def halted_then(line: dict, command: str) -> bool:
    return line["modules"]["sb"]["command"] == command


def test_simulated_coal_removal_section_still_completes_the_box_cut():
    final, lines = played("cr_simulated")
    assert final["status"] == "DONE"
    modules = set(lines[0]["modules"])
    assert {"gh", "cv", "ct"}.isdisjoint(modules), "cr's subtree is skipped"
    assert "cr" in modules and "oi" in modules
    assert not any(line["world"]["tail_request"] for line in lines), "nobody asked the operator"
    assert lines[-1]["world"]["depth_cut"] >= 1.45
    assert lines[-1]["world"]["coal_mined"] > 10.0, "the stand-in hauled the coal away"


def test_operator_goal_entry_trams_the_machine_there():
    final, lines = played("operator_goal")
    assert final["status"] == "DONE"
    entered = next(line for line in lines if line["modules"]["oi"]["command"] == "ENTER_GOAL")
    assert entered["world"]["operator_goal_x"] == -1.5, "the console entry reached the world"
    assert commands_sent(lines, "co")[-1] == "TRAM_TO_GOAL"
    assert abs(lines[-1]["world"]["pose_x"] - -1.5) < 0.05, "the machine is at the goal"


def rising(lines: list[dict], field: str) -> list[int]:
    """The cycles in which a bool world field became true."""
    cycles, was = [], False
    for line in lines:
        now = line["world"][field]
        if now and not was:
            cycles.append(line["cycle"])
        was = now
    return cycles


def test_the_operator_is_asked_for_the_tail_on_every_sump():
    for name in ("box_cut", "late_tail"):
        _, lines = played(name)
        sumps = commands_sent(lines, "co").count("SUMP_SHEAR_CUSP")
        asked = rising(lines, "tail_request")
        assert len(asked) == sumps == 3, name
        for cycle in asked:  # asking moves the tail: not in position until the operator is done
            assert not next(li for li in lines if li["cycle"] == cycle)["world"]["tail_in_position"]


def test_the_tail_is_out_of_position_once_the_machine_advances_beyond_it():
    with Harness.build(ROOT / "specs" / "miner") as h:
        h.world.update({"tail_request": True, "true_x": 1.0})
        for _ in range(5):  # the operator's delay is 3 cycles
            h.step("oi")
        assert h.world["tail_in_position"], "placed for the sump ahead"
        h.world["tail_request"] = False
        h.world["true_x"] = 1.6  # within the tail's reach of where it was placed (1.25)
        h.step("oi")
        h.step("oi")
        assert h.world["tail_in_position"]
        h.world["true_x"] = 1.7  # beyond it
        h.step("oi")
        assert not h.world["tail_in_position"], "the machine advanced beyond the tail"


pp_hooks = import_hooks(ROOT / "specs" / "miner", "miner_hooks.pp")  # the path planner


def test_the_planner_goes_straight_in_line_and_around_pillars_otherwise():
    planner = pp_hooks.new_planner({"map": "maps/box_cut.map"})
    assert pp_hooks.plan(planner, 0.0, 0.0, 0.0, 5.0, 0.0) == (True, 2.5, 0.0, False)
    assert pp_hooks.plan(planner, 0.0, 0.0, 0.0, -1.5, 0.0) == (True, -1.5, 0.0, True)
    found, wx, wy, last = pp_hooks.plan(planner, 0.0, 0.0, 0.0, -3.0, -9.75)
    assert found and not last, "the goal behind the pillar is not in plain sight"
    assert abs(wy) < 0.5 and -2.6 < wx < 0.0, "first back along the entry, towards the crosscut"
    assert pp_hooks.plan(planner, 0.0, 0.0, 0.0, 20.0, 5.0)[0] is False, "inside solid coal"


def test_the_planners_free_cells_are_those_clear_of_coal_by_its_clearance():
    """new_planner finds free cells with bit masks (a row of coal per integer): on every
    shipped map the result must be the definition, cell by cell: no coal cell within
    CLEARANCE of the cell's own (distance between cell indices times the cell size)."""
    import math

    for name in ("maps/box_cut.map", "maps/roll.map", "maps/two_pass.map"):
        planner = pp_hooks.new_planner({"map": name})
        seam = mine_hooks.load_map(Path(mine_hooks.SYSTEM_DIR, name)).seam
        rows = 1 + max(r for r, _ in seam)
        columns = 1 + max(c for _, c in seam)
        reach = math.ceil(pp_hooks.CLEARANCE / mine_hooks.CELL)
        expected = {
            (r, c)
            for r in range(rows)
            for c in range(columns)
            if not any(
                (r + dr, c + dc) in seam
                for dr in range(-reach, reach + 1)
                for dc in range(-reach, reach + 1)
                if math.hypot(dr, dc) * mine_hooks.CELL < pp_hooks.CLEARANCE
            )
        }
        assert planner.free == expected, name
        assert 0 < len(expected) < rows * columns, "some cells free, some not"


def test_guidance_trams_around_the_pillar_to_a_goal_in_the_next_entry():
    final, lines = played("around_pillar")
    assert final["status"] == "DONE"
    end = lines[-1]["world"]
    assert abs(end["true_x"] - -3.0) < 0.15 and abs(end["true_y"] - -9.75) < 0.15
    assert abs(end["true_heading"]) <= 0.06, "facing inby at the goal"
    moves = set(commands_sent(lines, "tc"))
    assert "SLOW_REVERSE" in moves and moves & {"PIVOT_LEFT", "PIVOT_RIGHT"}, "reverse and turn"
    mine = load_mine()
    for line in lines:  # the drum centre never stands in the surveyed coal: around the pillar
        w = line["world"]
        cell = (
            int((w["true_y"] - mine.y0) // mine_hooks.CELL),
            int((w["true_x"] - mine.x0) // mine_hooks.CELL),
        )
        assert cell not in mine.seam, f"cycle {line['cycle']}: in the coal at {cell}"
    assert min(line["world"]["true_x"] for line in lines) < -6.0, "through the crosscut"


def test_two_passes_cut_the_whole_wide_face_to_depth():
    final, lines = played("two_passes")
    assert final["status"] == "DONE"
    # the section's MINE_COAL is the shift boss's two passes, with the operator's figures
    assert commands_sent(lines, "sec")[-1] == "MINE_COAL"
    assert commands_sent(lines, "sb") == ["INIT", "CUT_TWO_PASSES"]
    sb_done = next(
        i
        for i, line in enumerate(lines)
        if line["modules"]["sb"]["status"] == "DONE"
        and line["modules"]["sb"]["command"] == "CUT_TWO_PASSES"
    )
    assert lines[sb_done]["modules"]["sec"]["status"] == "EXECUTING"
    assert lines[sb_done + 1]["modules"]["sec"]["status"] == "DONE", "a cycle a level up"
    co = commands_sent(lines, "co")
    first_slab = co.index("REPOSITION") + 2
    assert co[: first_slab + 1].count("SUMP_SHEAR_CUSP") >= 2, "the box cut, slice by slice"
    assert co[co.index("REPOSITION") : first_slab + 1] == [
        "REPOSITION", "REPOSITION", "INITIAL_APPROACH_FACE"
    ], "backed out, across, then the slab cut from the face"  # fmt: skip
    assert "SUMP_SHEAR_CUSP" in co[first_slab:] and co[-1] == "HALT"
    ys = [line["world"]["true_y"] for line in lines]
    assert abs(ys[0]) < 0.01 and abs(ys[-1] - 2.75) < 0.1, "the slab pass is 2.75 m across"
    # the mine as the run left it: the whole 6 m face (rows 39-62) cut back 1.5 m
    trace = traces.load(GOLDEN / "two_passes.jsonl")
    settings = {"map": "maps/two_pass.map", "seed": "7"}
    result = mine_view.replay(trace, mine_hooks, "new_mine", settings)
    assert result.mismatch is None
    final_heights = {cell: h for _, cell, h in result.cuts}
    for row in range(39, 63):
        for column in range(72, 78):  # 2.0 m to 3.5 m inby
            assert final_heights.get(row * result.columns + column, 1.0) <= mine_hooks.FACE_MIN, (
                row,
                column,
            )


def test_the_checker_refuses_a_controller_that_reads_the_truth_and_a_halt_that_stops_nothing(
    tmp_path,
):
    copy = tmp_path / "miner"
    shutil.copytree(ROOT / "specs" / "miner", copy, ignore=shutil.ignore_patterns("__pycache__"))
    sb = copy / "sb.yaml"
    sb.write_text(
        sb.read_text("utf-8").replace("reads: [depth_est,", "reads: [depth_est, depth_cut,", 1),
        "utf-8",
    )
    cd = copy / "cd.yaml"
    cd.write_text(cd.read_text("utf-8").replace("  HALT:\n", "  STOP:\n", 1), "utf-8")
    found = {(Path(d.span.file).name, d.code, d.message) for d in compile_paths([copy]).diagnostics}
    assert ("sb.yaml", "E280", "controller `sb` uses ground-truth world field `depth_cut`") in found
    assert (
        "cd.yaml",
        "W520",
        "`cd` commands actuator `drum_on_cmd` but keeps the default HALT, which stops nothing",
    ) in found


sim_hooks = import_hooks(ROOT / "specs" / "miner", "miner_hooks.sim")
haulage_hooks = import_hooks(ROOT / "specs" / "miner", "miner_hooks.haulage")


def test_a_shuttle_car_away_piles_up_loose_coal_until_the_shear_pauses():
    """Nothing is set by hand: the car fills, leaves, the conveyor has nowhere to put coal,
    the pile grows past the gauge's limit and co pauses the shear (Appendix C's loose-coal
    branch) until the car is back and the pile is gathered; the cut then completes."""
    final, lines = played("shuttle_car")
    assert final["status"] == "DONE"
    scenario = load_scenario(SCENARIOS / "shuttle_car.yaml")
    assert all(not event.world for event in scenario.events), "nothing is set by hand"
    halts = [
        line
        for line in lines
        if line["modules"]["cc"]["command"] == "HALT"
        and line["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
    ]
    assert halts, "too much loose coal paused the shear"
    assert halts[0]["world"]["shuttle_car_away"], "because the car was away"
    assert halts[0]["world"]["tail_in_position"], "not because of the tail"
    by_cycle = {line["cycle"]: line for line in lines}
    assert by_cycle[halts[0]["cycle"] - 1]["world"]["loose_coal"] > 4.0, "the gauge said so"
    resumed = next(
        line
        for line in lines
        if line["cycle"] > halts[-1]["cycle"] and line["modules"]["cc"]["command"] == "SHEAR"
    )
    assert not resumed["world"]["shuttle_car_away"], "resumed once the car was back"
    assert lines[-1]["world"]["depth_cut"] >= 1.5 and lines[-1]["world"]["coal_mined"] > 12.0
    # without the car (a belt), the same cut never pauses
    _, belt = played("box_cut")
    assert not any(
        line["modules"]["cc"]["command"] == "HALT"
        and line["modules"]["co"]["command"] == "SUMP_SHEAR_CUSP"
        for line in belt
    )


def test_the_shuttle_car_fills_leaves_and_comes_back_empty():
    car = haulage_hooks.new_haulage({"shuttle_car": "1.0 3"})
    steps = [haulage_hooks.haul(car, 5.0, 0.0, True, 0.6)]
    assert steps[0] == (4.4, 0.6, False)
    steps.append(haulage_hooks.haul(car, 4.4, 0.6, True, 0.6))
    assert steps[1] == (4.0, 1.0, True), "only what fits; full, it leaves"
    for _ in range(2):
        assert haulage_hooks.haul(car, 4.0, 1.0, True, 0.6) == (4.0, 1.0, True)
    assert haulage_hooks.haul(car, 4.0, 1.0, True, 0.6) == (3.4, 1.6, False), "back, empty"
    belt = haulage_hooks.new_haulage({})
    assert haulage_hooks.haul(belt, 50.0, 0.0, True, 0.6) == (49.4, 0.6, False)
    assert haulage_hooks.haul(belt, 1.0, 0.0, False, 0.6) == (1.0, 0.0, False), "not running"
    for bad in ("3.0", "x 4", "3.0 0", "-1 10", "1 2 3"):
        try:
            haulage_hooks.new_haulage({"shuttle_car": bad})
        except haulage_hooks.HaulageSettingError as error:
            assert repr(bad) in str(error)
        else:
            raise AssertionError(f"{bad!r} was taken")


def test_actuators_have_seeded_random_error_within_their_bounds():
    """Boom rate within 10% of the command, a jack stroke of 15 +- 3 cycles, each tread
    within 5% of its speed: they vary, stay in bounds, and the same seed repeats them."""
    rng = sim_hooks.new_actuator_error({"seed": "7"})
    moves = [sim_hooks.turn_boom(rng, 0.0, 1.5, 0.1, -10.0, 30.0) for _ in range(200)]
    assert all(1.35 <= m <= 1.65 for m in moves) and len(set(moves)) > 100
    assert sim_hooks.turn_boom(rng, 29.5, 1.5, 0.1, -10.0, 30.0) == 30.0, "the stop holds"
    strokes = {sim_hooks.travel_time(rng, 15, 3) for _ in range(200)}
    assert strokes == set(range(12, 19))
    poses = [sim_hooks.advance(rng, 0.0, 0.0, 0.0, 1, 1, 0.05) for _ in range(200)]
    assert all(0.0475 <= x <= 0.0525 for x, _, _ in poses)
    assert len({h for _, _, h in poses}) > 100, "unequal treads turn the machine a little"
    again = sim_hooks.new_actuator_error({"seed": "7"})
    assert [sim_hooks.turn_boom(again, 0.0, 1.5, 0.1, -10.0, 30.0) for _ in range(200)] == moves
    other = sim_hooks.new_actuator_error({"seed": "8"})
    assert sim_hooks.turn_boom(other, 0.0, 1.5, 0.1, -10.0, 30.0) != moves[0]
