"""The submarine's scenarios, asserted directly: clearance from every keel, the casualty
response's phases and their lengths, so a wrong golden file cannot hide a wrong submarine
(the golden comparison is in test_golden.py). Also the hooks' geometry, and a helm whose
ice avoidance is switched off, which must run into the ice."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest
from support.golden_runs import golden_run

from rcsgen.tools.harness import Harness
from rcsgen.tools.scenario import load_scenario, open_harness, run
from rcsgen.tools.traces.read import load as stored_trace

ROOT = Path(__file__).resolve().parent.parent
SUBMARINE = ROOT / "specs" / "submarine"
SCENARIOS = SUBMARINE / "scenarios"
GOLDEN_DIR = ROOT / "tests" / "golden" / "submarine"
CO_HIGH = 50.0  # cc.yaml: the fire alarm
CO_SAFE = 5.0  # ec.yaml: the atmosphere is acceptable
HAVEN = 150.0  # sm.yaml ARRIVAL: half the box around a waypoint that counts as reached
MOVING_HAVEN = 300.0  # sm.yaml HAVEN: half the side of the moving haven
BAFFLE_TURN = 60.0  # helm.yaml: degrees to starboard to clear baffles


def play(name: str, package: Path) -> tuple[dict, list[dict]]:
    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    harness = open_harness(scenario, package)
    try:
        result = run(scenario, harness)
    finally:
        harness.close()
    return result.final, [json.loads(line) for line in result.trace]


def played(name: str) -> tuple[dict, list[dict]]:
    """A scenario's run on the committed generated package: (final status, trace lines),
    as its golden trace records them (support/golden_runs.py says why that is the run)."""
    return golden_run("submarine", name)


def commands_sent(lines: list[dict], module: str) -> list[str]:
    """Each new command `module` received, in order (one entry per command number)."""
    seen, out = 0, []
    for line in lines:
        entry = line["modules"][module]
        if entry["command_num"] != seen:
            seen = entry["command_num"]
            out.append(entry["command"])
    return out


def spans(lines: list[dict], module: str, state: str) -> list[tuple[int, int]]:
    """The (first, last) cycles of each run of consecutive cycles `module` is in `state`."""
    out: list[tuple[int, int]] = []
    for line in lines:
        if line["modules"][module]["state"] != state:
            continue
        if out and out[-1][1] == line["cycle"] - 1:
            out[-1] = (out[-1][0], line["cycle"])
        else:
            out.append((line["cycle"], line["cycle"]))
    return out


def route(name: str) -> list[tuple[float, float]]:
    from_file = (SUBMARINE / "maps" / name).read_text(encoding="utf-8").splitlines()
    rows = [line.split("#")[0].split() for line in from_file]
    return [(float(r[0]), float(r[1])) for r in rows if r]


# Helm's rules that set ICE_MANEUVER's result at_goal (helm.yaml): Evt3 to true; Evt0 (a new
# command clears it), Evt1 and Evt5 to false. The trace records rules, not results.
AT_GOAL_SETS = {
    "ICE_MANEUVER/S1/4": True,
    "ICE_MANEUVER/S0/1": False,
    "ICE_MANEUVER/S1/1": False,
    "ICE_MANEUVER/S1/2": False,
}


def helm_at_goal(lines: list[dict]) -> list[bool]:
    """Helm's result at_goal after each cycle, replayed from the rules the trace shows."""
    out, value = [], False
    for line in lines:
        value = AT_GOAL_SETS.get(line["modules"]["helm"]["rule"], value)
        out.append(value)
    return out


def at(lines: list[dict], cycle: int) -> dict:
    assert lines[cycle - 1]["cycle"] == cycle
    return lines[cycle - 1]


# ---- the ice transit


def test_ice_transit_keeps_clear_of_every_keel_and_reaches_every_waypoint():
    final, lines = played("ice_transit")
    assert final["status"] == "DONE"
    clearance = min(line["world"]["clearance"] for line in lines)
    assert clearance >= 100.0, f"came within {clearance} m of a keel's edge"
    assert lines[-1]["world"]["min_clearance"] == clearance, "the sonar's running minimum"
    waypoints = route("bering.route")
    assert commands_sent(lines, "sm") == ["INIT"] + ["SUBMERGED_TRANSIT"] * len(waypoints)
    # each SUBMERGED_TRANSIT ended (DONE) inside the box around its waypoint
    done = [
        line
        for prev, line in zip(lines, lines[1:], strict=False)
        if line["modules"]["sm"]["status"] == "DONE"
        and prev["modules"]["sm"]["status"] == "EXECUTING"
        and line["modules"]["sm"]["command"] == "SUBMERGED_TRANSIT"
    ]
    assert len(done) == len(waypoints)
    for line, (x, y) in zip(done, waypoints, strict=True):
        assert abs(line["world"]["pos_x"] - x) < HAVEN + 8.0  # one cycle's run at 7.7 m/s
        assert abs(line["world"]["pos_y"] - y) < HAVEN + 8.0


def test_ice_transit_avoids_ice_then_recomputes_the_course():
    _, lines = played("ice_transit")
    avoided = spans(lines, "helm", "S2")
    assert len(avoided) >= 3, "Helm avoided ice more than once on the way"
    for first, last in avoided:
        before, after = at(lines, first - 1), at(lines, last + 1)
        assert after["modules"]["helm"]["state"] == "S1", "Evt2: back to servoing the heading"
        # the course was recomputed from where the ship is now towards the same goal
        assert after["world"]["course"] != before["world"]["course"]
        assert not any(helm_at_goal(lines)[c - 1] for c in range(first, last + 1))
    # while avoiding, the rudder turned the ship off the course it had been holding
    first, last = avoided[0]
    held = at(lines, first)["world"]["course"]
    off = [
        abs((at(lines, c)["world"]["heading"] - held + 180) % 360 - 180)
        for c in range(first, last + 1)
    ]
    assert max(off) > 10.0


def off_track(lines: list[dict]) -> list[float]:
    """Metres from the ship to its leg's track in every transit cycle: the line from where
    the transit started (the haven's first centre) through the haven's centre, which moves
    along it towards the waypoint."""
    out, start, number = [], (0.0, 0.0), None
    for line in lines:
        sm, w = line["modules"]["sm"], line["world"]
        if sm["command"] != "SUBMERGED_TRANSIT" or sm["status"] != "EXECUTING":
            continue
        if sm["command_num"] != number:
            number, start = sm["command_num"], (w["pos_x"], w["pos_y"])
        along_x, along_y = w["haven_x"] - start[0], w["haven_y"] - start[1]
        length = math.hypot(along_x, along_y)
        if length > 50.0:  # the track's direction is known once the haven has moved
            cross = (w["pos_x"] - start[0]) * along_y - (w["pos_y"] - start[1]) * along_x
            out.append(abs(cross) / length)
    return out


def test_helm_steers_back_onto_the_track_after_avoiding_ice():
    """Figure 19: the submarine follows the planned path's line segments, jagged only where
    it avoids ice. Helm's course is recomputed every cycle towards the track (not only
    towards the waypoint once, which left the ship wherever avoidance had set it, a median
    56 m off the line and within 50 m of it 43 % of the time)."""
    _, lines = played("ice_transit")
    off = sorted(off_track(lines))
    assert len(off) > 1000
    assert off[len(off) // 2] < 25.0, "the median cycle is on the track"
    # 75 % with the CMAC's stored map, which steers wider of the keels (79 % before it)
    assert sum(d < 50.0 for d in off) >= 0.7 * len(off)


def test_the_course_along_the_track(hooks):
    helm = hooks[0]
    # on the track: along it; off it: back towards a point LOOKAHEAD (600 m) on along it
    assert helm.track_course(None, 0.0, 10000.0, 0.0, 0.0, 0.0, 5000.0) == 0.0
    assert helm.track_course(None, 0.0, 10000.0, 0.0, 0.0, 150.0, 5000.0) == pytest.approx(
        360.0 - math.degrees(math.atan2(150.0, 600.0))
    )
    assert helm.track_course(None, 0.0, 10000.0, 0.0, 0.0, -150.0, 5000.0) == pytest.approx(
        math.degrees(math.atan2(150.0, 600.0))
    )
    # within LOOKAHEAD of the goal: straight for it; a track of no length: the goal's bearing
    assert helm.track_course(None, 0.0, 10000.0, 0.0, 0.0, -150.0, 9800.0) == pytest.approx(
        math.degrees(math.atan2(150.0, 200.0))
    )
    assert helm.track_course(None, 100.0, 0.0, 100.0, 0.0, 0.0, 0.0) == 90.0


def test_helm_reports_at_goal_only_on_course_with_the_rudder_centred():
    _, lines = played("ice_transit")
    on = [line for line, at_goal in zip(lines, helm_at_goal(lines), strict=True) if at_goal]
    assert len(on) > 100
    for line in on:
        w = line["world"]
        assert abs(w["rudder_angle"]) <= 1.5 + 3.0  # centred (within the rudder's tolerance)
        assert line["modules"]["helm"]["status"] == "EXECUTING", "reported while executing"


def test_the_rudder_is_driven_only_by_voltage_commands_and_stays_within_its_limits():
    _, lines = played("ice_transit")
    sent = set(commands_sent(lines, "rudder_sim"))
    assert sent == {"INIT", "PLUS_VOLT", "MINUS_VOLT", "ZERO_VOLT"}
    angles = [line["world"]["rudder_angle"] for line in lines]
    assert max(angles) <= 37.0 and min(angles) >= -37.0
    assert max(angles) > 10.0 and min(angles) < -10.0, "turned both ways"
    steps = [abs(b - a) for a, b in zip(angles, angles[1:], strict=False)]
    assert max(steps) <= 3.0 + 1e-9, "rate-limited to 3 degrees a cycle"


def test_without_ice_avoidance_the_ship_runs_into_a_keel(tmp_path):
    """The same transit with a persistence time longer than the run: Helm never avoids, and
    the ship passes through ice. The clearance is the avoidance's doing, not the route's."""
    specs = tmp_path / "submarine"
    shutil.copytree(SUBMARINE, specs)
    helm = specs / "helm.yaml"
    text = helm.read_text(encoding="utf-8")
    old = "          for: 5 s\n"
    assert text.count(old) == 1
    helm.write_text(text.replace(old, "          for: 100000 s\n"), encoding="utf-8")
    with Harness.build(specs) as built:
        final, lines = play("ice_transit", Path(built.package.__path__[0]))
    assert final["status"] == "DONE"
    assert not spans(lines, "helm", "S2")
    assert min(line["world"]["clearance"] for line in lines) < 0.0


# ---- the engine-room fire


def fire_phases(lines: list[dict]) -> dict[str, tuple[int, int]]:
    """cc's casualty phases: (first, last) cycle of PREP_VENT and VENT (each exactly once)."""
    prep, vent = spans(lines, "cc", "PREP_VENT"), spans(lines, "cc", "VENT")
    assert len(prep) == 1 and len(vent) == 1
    return {"prep": prep[0], "vent": vent[0]}


def test_engine_room_fire_phases_and_their_cycles():
    """Section 4.1.3 step by step: the alarm and "all hands on EABs"; the OOD's actions for
    coming to periscope depth as Maneuver decomposes them (4.7.1: Clear_baffles, then
    Slow_and_Change_Depth with Shift_To_EPM, asked of the EOOW, Figure 30), the periscope
    raised; emergency ventilation; the EABs off and the transit resumed on the EPM."""
    final, lines = played("engine_room_fire")
    assert final["status"] == "DONE"
    scenario = load_scenario(SCENARIOS / "engine_room_fire.yaml")
    fire_at = next(e.cycle for e in scenario.events if e.world.get("fire"))
    phases = fire_phases(lines)
    (prep_from, prep_to), (vent_from, vent_to) = phases["prep"], phases["vent"]
    # the alarm (section 4.2): the ventilation sensor's CO (the atmosphere, last in the
    # cycle) is above 50 after the fire's second cycle; the engineering node (after cc)
    # infers the contamination the next cycle; cc reads its report the cycle after
    high = next(line["cycle"] for line in lines if line["world"]["co_ppm"] > CO_HIGH)
    assert high == fire_at + 1  # 40 ppm a cycle
    contaminated = [ln["cycle"] for ln in lines if ln["world"]["engine_room_contaminated"]]
    assert contaminated[0] == high + 1
    # and the propulsion system's sensor (4.7.1): the pumps hot from the fire's second
    # cycle, propulsion's inference in the same cycle as the engineering node's; it clears
    # once the fire is out and the pumps have cooled, before the transit resumes
    hot = next(ln["cycle"] for ln in lines if ln["world"]["lube_oil_temp"] > 65.0)
    assert hot == high
    pumps = [ln["cycle"] for ln in lines if ln["world"]["pumps_fire"]]
    assert pumps[0] == contaminated[0]
    out = max(ln["cycle"] for ln in lines if ln["world"]["fire"])
    resumed = spans(lines, "cc", "TRANSIT")[1][0]  # no second alarm on the resumed transit
    assert pumps == list(range(pumps[0], pumps[-1] + 1)) and out < pumps[-1] < resumed
    alarm = contaminated[0] + 1
    assert prep_from == alarm
    assert at(lines, alarm)["world"]["announcement"] == "ENGINE ROOM FIRE, ALL HANDS ON EABS"
    assert at(lines, alarm - 1)["world"]["announcement"] == ""
    # the general alarm musters the crew (7 s to battle stations, the section watchstanders
    # relieved); the damage control party on scene puts the fire out after 20 s; secured
    # from general emergency with the all-clear, the underway watch section takes over
    assert [ln["world"]["general_alarm"] for ln in lines[alarm - 2 : alarm]] == [False, True]
    stations = [ln["cycle"] for ln in lines if ln["world"]["watch"] == "BATTLE_STATIONS"]
    assert stations[0] == alarm + 7
    fire_out = max(ln["cycle"] for ln in lines if ln["world"]["fire"]) + 1
    assert fire_out == stations[0] + 20
    secure = next(
        ln["cycle"]
        for ln in lines
        if ln["world"]["announcement"] == "SECURE FROM FIRE, EABS MAY BE REMOVED"
    )
    assert stations == list(range(stations[0], secure))
    assert not at(lines, secure)["world"]["general_alarm"]
    # clear baffles first: the helm turns BAFFLE_TURN to starboard at transit depth and speed
    baffles = spans(lines, "sm", "BAFFLES")
    assert len(baffles) == 1 and baffles[0][0] == prep_from
    turned_from = at(lines, prep_from)["world"]["heading"]
    turned_to = at(lines, baffles[0][1])["world"]["heading"]
    assert BAFFLE_TURN - 5.0 <= (turned_to - turned_from) % 360.0 <= BAFFLE_TURN + 5.0
    assert all(at(lines, c)["world"]["depth"] == 120.0 for c in range(*baffles[0]))
    # then slow and come up, and shift propulsion: all stop (declutched) while the EOOW is
    # asked CHANGE_TO_EPM; his report engages the EPM
    slowing = spans(lines, "sm", "SLOWING")[0]
    assert slowing[0] == baffles[0][1] + 1
    # on indication of decreasing main lube oil pressure (the fire is at the pumps; the
    # engineering node infers it low) the EOOW recommends the EPM: the shift is asked in
    # SLOWING's first cycle, the pressure having fallen since the fire (4.1.3)
    low = next(ln["cycle"] for ln in lines if ln["world"]["lube_oil_low"])
    assert fire_at < low < slowing[0]
    assert at(lines, fire_at - 1)["world"]["lube_oil_psi"] == 60.0
    assert at(lines, low)["world"]["lube_oil_psi"] < 40.0
    asked, back = spans(lines, "eoow/prop", "ASKING")
    assert asked[0] == slowing[0] + 1
    assert at(lines, asked[0])["modules"]["eoow/prop"]["command"] == "CHANGE_TO_EPM"
    asked = [asked]
    assert 20 <= asked[0][1] - asked[0][0] + 1 <= 22, "the scripted EOOW takes 20 s"
    assert {at(lines, c)["world"]["shaft"] for c in range(asked[0][0], asked[0][1] + 1)} == {
        "DISENGAGED"
    }
    assert at(lines, asked[0][1] + 2)["world"]["shaft"] == "EPM"
    # ahead one-third while slowing; on the EPM ("prepared to answer bells on the EPM") the
    # OOD orders ahead two-thirds, the cycle ship maneuver reads propulsion's DONE (4.1.3)
    assert at(lines, slowing[0])["world"]["speed_cmd"] == 2.6
    two_thirds = next(c for c in range(*slowing) if at(lines, c)["world"]["speed_cmd"] == 5.1)
    assert two_thirds == asked[0][1] + 3
    # the main lube oil restored (the scenario's event): the engineering node's indication
    # clears the cycle after, cc has SM shift back to the turbines (the EOOW asked
    # CHANGE_TO_TURBINE, the shaft declutched meanwhile), then the transit at standard speed
    restored = next(e.cycle for e in scenario.events if "lube_oil_psi" in e.world)
    assert at(lines, restored)["world"]["lube_oil_low"] is False
    assert at(lines, restored - 1)["world"]["shaft"] == "EPM"
    (shifting,) = spans(lines, "cc", "SHIFTING")
    assert shifting[0] == restored + 1
    assert at(lines, back[0])["modules"]["eoow/prop"]["command"] == "CHANGE_TO_TURBINE"
    assert {at(lines, c)["world"]["shaft"] for c in range(back[0], back[1] + 1)} == {"DISENGAGED"}
    assert at(lines, shifting[1])["world"]["shaft"] == "TURBINE"
    assert at(lines, shifting[1])["world"]["speed_cmd"] == 7.7
    assert lines[-1]["world"]["shaft"] == "TURBINE" and lines[-1]["world"]["speed"] == 7.7
    assert all(at(lines, c)["world"]["speed_cmd"] == 5.1 for c in range(two_thirds, prep_to + 1))
    # prepared: periscope depth at two-thirds on the EPM, steady on course, periscope raised
    top = at(lines, prep_to)
    assert abs(top["world"]["depth"] - 18.0) < 1.0 and abs(top["world"]["speed"] - 5.1) < 0.1
    assert top["world"]["periscope_raised"] and top["world"]["shaft"] == "EPM"
    assert not any(
        line["world"]["periscope_raised"] for line in lines if line["cycle"] < prep_to - 1
    )
    assert helm_at_goal(lines)[prep_to - 1]
    # the word from the damage control party, relayed by the EOOW (4.1.3: "The fire is out,
    # the reflash watch is stationed"): asked once the ship is prepared, answered in 2 s
    (report,) = spans(lines, "cc", "FIRE_REPORT")
    assert report[0] == prep_to + 1
    (asked_out,) = spans(lines, "eoow/cc", "ASKING")
    assert (
        asked_out[0] == report[0]
        and at(lines, asked_out[0])["modules"]["eoow/cc"]["command"] == "FIRE_OUT"
    )
    assert not any(at(lines, c)["world"]["fire"] for c in range(*asked_out)), "the fire is out"
    assert at(lines, asked_out[1] + 1)["modules"]["eoow/cc"]["status"] == "DONE"
    # line up (the BCP, one cycle: "prepared to emergency ventilate with the diesel") only
    # after the word, then commence snorkeling: engineering runs the diesel until the fire
    # is out and the analyzers read safe
    (line_up,) = spans(lines, "cc", "LINE_UP")
    assert line_up == (report[1] + 1, report[1] + 1) and vent_from == report[1] + 2
    assert at(lines, report[1])["world"]["vent_lineup"] != "DIESEL_VENTILATION"
    assert at(lines, line_up[0])["world"]["vent_lineup"] == "DIESEL_VENTILATION"
    assert not at(lines, line_up[0])["world"]["diesel_running"]
    assert all(at(lines, c)["world"]["diesel_running"] for c in range(vent_from, vent_to))
    assert max(ln["world"]["smoke"] for ln in lines) > 100.0
    assert (
        min(ln["world"]["o2_pct"] for ln in lines)
        < 20.5
        < 20.8
        < at(lines, vent_to)["world"]["o2_pct"]
    )
    # (in VENT's last cycle cc sees the DONE engineering reported after securing: recirculate)
    assert {at(lines, c)["world"]["vent_flow"] for c in range(vent_from, vent_to)} == {0.05}
    assert all(at(lines, c)["world"]["depth"] == 18.0 for c in range(vent_from, vent_to + 1))
    end = at(lines, vent_to)
    assert end["world"]["co_ppm"] <= CO_SAFE and not end["world"]["fire"]
    # ventilated no longer than needed: the atmosphere (last in the cycle) reads safe in
    # cycle k, engineering secures in k + 1 (VENT's last cycle), cc resumes in k + 2
    safe = next(
        c for c in range(vent_from, vent_to + 1) if at(lines, c)["world"]["co_ppm"] <= CO_SAFE
    )
    assert safe == vent_to - 1
    # EABs off area by area (4.1.3): forward of the engine room, where the analyzer reads
    # normal first, while the engine room is still being ventilated; the engine room last
    forward = next(c for c in range(vent_from, vent_to) if at(lines, c)["world"]["forward_normal"])
    assert (
        at(lines, forward)["world"]["co_ppm_fwd"] <= CO_SAFE < at(lines, forward)["world"]["co_ppm"]
    )
    # (the atmosphere, last in the cycle, reads safe in cycle k; ec infers it in k + 1)
    assert at(lines, forward - 1)["world"]["co_ppm_fwd"] <= CO_SAFE
    assert at(lines, forward - 2)["world"]["co_ppm_fwd"] > CO_SAFE
    assert at(lines, forward + 1)["world"]["announcement"] == "EABS MAY BE REMOVED FORWARD"
    assert at(lines, forward)["world"]["announcement"] == "ENGINE ROOM FIRE, ALL HANDS ON EABS"
    assert forward + 1 < vent_to - 10
    # the fire burned for the damage control party's 30 cycles
    burning = [line["cycle"] for line in lines if line["world"]["fire"]]
    assert burning == list(range(fire_at, fire_at + 30))
    # (S4) EABs off; SM prepares to resume (periscope down, back to transit depth) while EC
    # lines up for submerged ventilation; then (S1) the transit to the same waypoint
    resuming = at(lines, vent_to + 1)
    assert resuming["modules"]["cc"]["state"] == "RESUMING"
    assert resuming["world"]["vent_flow"] == 0.002
    assert resuming["world"]["announcement"] == "SECURE FROM FIRE, EABS MAY BE REMOVED"
    assert not resuming["world"]["periscope_raised"]
    (res_from, res_to), *_ = spans(lines, "cc", "RESUMING")
    assert abs(at(lines, res_to)["world"]["depth"] - 120.0) < 1.0, "at transit depth"
    assert at(lines, res_to + 1)["modules"]["cc"]["state"] == "S1"
    assert at(lines, res_to + 2)["modules"]["cc"]["state"] == "TRANSIT"
    # the bubble angle: bow up coming to periscope depth, bow down going back
    assert max(at(lines, c)["world"]["bubble"] for c in range(slowing[0], prep_to)) > 5.0
    assert at(lines, res_from + 10)["world"]["bubble"] < -5.0
    assert lines[-1]["world"]["bubble"] == 0.0
    assert commands_sent(lines, "sm") == [
        "INIT", "SUBMERGED_TRANSIT", "PREP_EMERGENCY_VENT", "PREP_SUBMERGED_TRANSIT",
        "SUBMERGED_TRANSIT", "SUBMERGED_TRANSIT", "SHIFT_TO_TURBINES", "SUBMERGED_TRANSIT",
    ]  # fmt: skip
    assert commands_sent(lines, "ec") == [
        "INIT", "SUBMERGED_VENT", "LINE_UP_EMERGENCY_VENT", "EMERGENCY_VENT", "SUBMERGED_VENT",
        "SUBMERGED_VENT", "SUBMERGED_VENT", "SUBMERGED_VENT",  # the last after the shift back
    ]  # fmt: skip
    assert commands_sent(lines, "helm")[:4] == [
        "INIT", "ICE_MANEUVER", "CLEAR_BAFFLES", "ICE_MANEUVER"
    ]  # fmt: skip
    assert commands_sent(lines, "prop") == ["INIT", "SHIFT_TO_EPM", "SHIFT_TO_TURBINE"]
    # the resumed transit answers bells at ahead two-thirds on the EPM until the main lube
    # oil is restored, then at standard speed on the turbines (asserted above)
    resumed = [at(lines, c)["world"] for c in range(res_to + 40, shifting[0])]
    assert resumed and {(w["speed"], w["shaft"]) for w in resumed} == {(5.1, "EPM")}
    last = lines[-1]["world"]
    assert last["depth"] == 120.0 and last["speed"] == 7.7 and last["shaft"] == "TURBINE"


def test_fire_under_ice_clears_baffles_only_as_far_as_the_ice_allows():
    """Both together: the fire breaks out short of two keels. The turn to clear baffles
    looks for ice along its heading and ends when it sees some; Helm's maneuver then keeps
    the ship clear of the keels while it prepares, ventilates and completes the mission."""
    final, lines = played("fire_under_ice")
    assert final["status"] == "DONE"
    assert min(line["world"]["clearance"] for line in lines) >= 100.0
    phases = fire_phases(lines)
    prep_from, prep_to = phases["prep"]
    baffles = spans(lines, "sm", "BAFFLES")
    assert len(baffles) == 1 and baffles[0][0] == prep_from
    turned = (
        at(lines, baffles[0][1])["world"]["heading"] - at(lines, prep_from)["world"]["heading"]
    ) % 360.0
    assert 0.0 < turned < BAFFLE_TURN - 5.0, "the turn ended early, on ice"
    assert at(lines, prep_to)["world"]["periscope_raised"]
    assert lines[-1]["world"]["co_ppm"] <= CO_SAFE
    assert commands_sent(lines, "sm").count("SUBMERGED_TRANSIT") == len(route("bering.route")) + 1
    assert commands_sent(lines, "sm").count("PREP_SUBMERGED_TRANSIT") == 1


CLOSE_CONTACT = 3000.0  # helm.yaml: a ship nearer than this is a close contact
NO_CONTACT = 8000.0  # the passive sonar's "none heard" (submarine_hooks/sim.py HEARING)


def test_a_close_contact_in_the_baffles_keeps_the_ship_deep_until_it_has_opened():
    """Section 4.1.3, coming to periscope depth: "Clearing baffles. Checking for sonar
    contacts, close contacts. Slowing and changing depth." A ship dead astern, in the
    baffles, is not heard on the transit; the baffle turn brings it into hearing, close.
    The helm holds the heading, deep, and reports the areas of concern clear (Figure 31)
    only once the contact has opened beyond CLOSE_CONTACT; then ship maneuver slows and
    comes up, and the ship is prepared at periscope depth."""
    final, lines = played("fire_close_contact")
    assert final["status"] == "DONE"
    world = [line["world"] for line in lines]
    baffles = spans(lines, "sm", "BAFFLES")
    assert len(baffles) == 1
    turn_from, clear_at = baffles[0]
    # astern, in the baffles: not heard on the transit (it is within hearing all the while)
    assert all(w["contact_range"] == NO_CONTACT for w in world[: turn_from - 1])
    heard = next(line["cycle"] for line in lines if line["world"]["contact_range"] < NO_CONTACT)
    assert turn_from < heard < clear_at
    turned = (at(lines, heard)["world"]["heading"] - at(lines, turn_from)["world"]["heading"]) % 360
    assert 20.0 < turned < BAFFLE_TURN, "heard once the turn brings the arc astern into view"
    assert at(lines, heard)["world"]["contact_range"] <= CLOSE_CONTACT
    # the helm holds in CONTACT, the ship deep and at transit speed, while the contact is
    # close (the helm reads the range the sonar, later in the process, wrote the cycle before)
    held = spans(lines, "helm", "CONTACT")
    assert len(held) == 1 and held[0][1] - held[0][0] >= 30
    for cycle in range(held[0][0], held[0][1] + 1):
        assert at(lines, cycle - 1)["world"]["contact_range"] <= CLOSE_CONTACT
        w = at(lines, cycle)["world"]
        assert w["depth_cmd"] == 120.0 and w["speed_cmd"] == 7.7 and w["depth"] >= 119.0
    # opened beyond CLOSE_CONTACT: the helm's DONE, then slow and come up
    assert at(lines, held[0][1])["world"]["contact_range"] > CLOSE_CONTACT
    assert at(lines, held[0][1] + 1)["modules"]["helm"]["status"] == "DONE"
    assert at(lines, clear_at + 1)["modules"]["sm"]["state"] == "SLOWING"
    assert at(lines, clear_at + 1)["world"]["depth_cmd"] == 18.0
    assert world[-1]["periscope_raised"] and world[-1]["depth"] <= 19.0
    # without the contact (engine_room_fire) the same turn is not held
    _, plain = played("engine_room_fire")
    assert spans(plain, "helm", "CONTACT") == []
    assert spans(plain, "sm", "BAFFLES")[0][1] <= held[0][0] < clear_at


def test_generated_keels_are_random_in_size_and_fractal_in_shape_along_the_path(hooks):
    """Sections 4.3.2 and 4.6.5: keels "generated randomly, in their sizes and shapes, and
    continuously throughout the paths", with fractals, before the run: the same seed gives
    the same keels, another seed others; sizes differ, outlines are not circles, and every
    keel stands near the path, one after another along it."""
    _, mission, sim, _ = hooks
    settings = {"route": "maps/bering.route", "keels": "maps/open_sea.keels", "ice_seed": "4"}
    keels = sim.new_ice(settings).shapes
    assert keels == sim.new_ice(settings).shapes
    assert keels != sim.new_ice({**settings, "ice_seed": "3"}).shapes
    path = [(0.0, 0.0), *mission.load_route(SUBMARINE / "maps" / "bering.route").route]
    assert len(keels) >= 6
    reaches = [k.reach for k in keels]
    assert max(reaches) - min(reaches) > 30.0, "random sizes"
    for keel in keels:
        radii = [math.dist(p, (keel.x, keel.y)) for p in keel.points]
        assert max(radii) > 1.3 * min(radii), "a fractal outline, not a circle"
        off_path = min(
            abs((b[0] - a[0]) * (a[1] - keel.y) - (a[0] - keel.x) * (b[1] - a[1])) / math.dist(a, b)
            for a, b in zip(path, path[1:], strict=False)
        )
        assert off_path <= 350.0 + 1e-6 and math.hypot(keel.x, keel.y) >= 800.0
    gaps = [math.dist((a.x, a.y), (b.x, b.y)) for a, b in zip(keels, keels[1:], strict=False)]
    assert max(gaps) < 2000.0, "continuously along the path"
    with pytest.raises(ValueError, match="ice_seed must be a whole number"):
        sim.new_ice({**settings, "ice_seed": "many"})
    # the sonar sees an outline: a beam stops at its edge, not at a circle around it
    keel = keels[0]
    ahead = sim.ping(sim.Sea([], [], [keel]), keel.x, keel.y - 500.0, 0.0)
    edge = min(y for x, y in keel.points if abs(x - keel.x) < 15.0)
    assert abs(ahead[6] + ahead[7] - 2 * (edge - (keel.y - 500.0))) < 60.0
    assert 0.0 < ahead[14] <= min(ahead[:14])


def test_the_transit_among_generated_keels_avoids_them_all():
    """`fractal_ice`, read from its golden trace (test_golden re-runs it): the mission
    completes, helm avoided ice several times, and the ship never came within 100 m of an
    outline's edge."""
    trace = stored_trace(GOLDEN_DIR / "fractal_ice.jsonl")
    assert trace.columns["cc"]["status"][-1] == "DONE"
    states = trace.columns["helm"]["state"]
    episodes = sum(1 for a, b in zip(states, states[1:], strict=False) if b == "S2" != a)
    assert episodes >= 3
    assert min(trace.world["clearance"]) >= 100.0


def haven_offsets(lines: list[dict]) -> list[float]:
    """How far the ship is from its moving haven's centre (the larger of east and north),
    in each cycle ship maneuver executes a transit."""
    return [
        max(abs(w["pos_x"] - w["haven_x"]), abs(w["pos_y"] - w["haven_y"]))
        for line in lines
        for w in [line["world"]]
        if line["modules"]["sm"]["command"] == "SUBMERGED_TRANSIT"
        and line["modules"]["sm"]["status"] == "EXECUTING"
    ]


@pytest.mark.parametrize(
    "name", ["ice_transit", "ice_replan", "engine_room_fire", "fire_under_ice"]
)
def test_the_ship_stays_in_its_moving_haven_which_moves_along_the_leg(name):
    """Figure 19: the moving haven is a box around the submarine that moves with the plan;
    the ship may be anywhere in it, never outside. It moves towards the waypoint."""
    final, lines = played(name)
    assert final["status"] == "DONE"
    offsets = haven_offsets(lines)
    assert offsets and max(offsets) <= MOVING_HAVEN
    transit = [
        line["world"] for line in lines if line["modules"]["sm"]["command"] == "SUBMERGED_TRANSIT"
    ]
    moved = math.hypot(
        transit[-1]["haven_x"] - transit[0]["haven_x"],
        transit[-1]["haven_y"] - transit[0]["haven_y"],
    )
    assert moved > 1000.0, "the haven moves with the ship, it is no box at a waypoint"


def test_a_ship_that_falls_out_of_its_moving_haven_fails_the_mission():
    """lost_propulsion: the shaft comes off the turbines; the haven moves on at the ordered
    speed, the coasting ship falls behind, and the cycle it is outside ship maneuver
    reports ERROR OUT_OF_HAVEN, which the command controller passes up by name."""
    final, lines = played("lost_propulsion")
    assert final["status"] == "ERROR" and final["reason"] == "OUT_OF_HAVEN"
    failed = next(line for line in lines if line["modules"]["sm"]["status"] == "ERROR")
    # what sm compared: the ship's position of the cycle before (the ship runs after sm),
    # the haven it moved on at the start of this cycle (its every-cycle rule)
    ship, haven = at(lines, failed["cycle"] - 1)["world"], failed["world"]
    off = max(abs(ship["pos_x"] - haven["haven_x"]), abs(ship["pos_y"] - haven["haven_y"]))
    assert off > MOVING_HAVEN
    assert all(offset <= MOVING_HAVEN for offset in haven_offsets(lines)[:-2])
    assert failed["modules"]["sm"]["reason"] == "OUT_OF_HAVEN"
    assert at(lines, failed["cycle"] + 1)["modules"]["cc"]["status"] == "ERROR"


def test_the_access_matrix_is_figure_29s():
    """Section 4.7.3: the OOD commands the mission and makes the depth decision asked of
    him (DEPTH_CASUALTY); the EOOW only responds to requests (CHANGE_TO_EPM); the
    helmsman may override helm and rudder; the BCP monitors."""
    import yaml

    roles = yaml.safe_load((SUBMARINE / "system.yaml").read_text())["operators"]["roles"]
    assert roles["ood"].get("command") == ["cc"]
    assert roles["ood"].get("respond") == ["ood"], "the OOD answers DEPTH_CASUALTY (4.7.3)"
    assert roles["eoow"] == {"doc": roles["eoow"]["doc"], "respond": ["eoow"]}
    assert roles["helmsman"].get("override") == ["helm", "rudder"]
    assert set(roles["bcp"]) == {"doc"}, "monitors only"


# ---- the hooks' geometry


@pytest.fixture(scope="module")
def hooks():
    import sys

    sys.path.insert(0, str(SUBMARINE))
    try:
        from submarine_hooks import helm, mission, sea, sim

        yield helm, mission, sim, sea
    finally:
        sys.path.remove(str(SUBMARINE))
        for name in [m for m in sys.modules if m.startswith("submarine_hooks")]:
            del sys.modules[name]


def test_sonar_beams_meet_a_keel_ahead(hooks):
    _, _, sim, _ = hooks
    keels = [(0.0, 500.0, 100.0)]  # 500 m north, radius 100
    *ranges, clearance = sim.ping(sim.Sea(keels), 0.0, 0.0, 0.0)
    assert len(ranges) == 14
    assert clearance == 400.0
    # the two beams either side of the centre line (-3 and +3 degrees) hit it at 402.8 m
    expected = 500.0 * math.cos(math.radians(3)) - math.sqrt(
        100.0**2 - (500.0 * math.sin(math.radians(3))) ** 2
    )
    assert ranges[6] == ranges[7] == round(expected, 3)
    assert ranges[0] == ranges[13] == sim.SONAR_RANGE, "the outer beams miss"
    # turned east, the keel is off the port bow: only port beams see it
    *east, _ = sim.ping(sim.Sea(keels), 0.0, 0.0, 45.0)
    assert all(r == sim.SONAR_RANGE for r in east[7:])


def test_ice_assessment_blocks_the_course_and_recommends_a_clear_heading(hooks):
    helm, _, sim, _ = hooks
    keels = [(0.0, 500.0, 100.0)]
    ranges = sim.ping(sim.Sea(keels), 0.0, 0.0, 0.0)[:14]
    seen, avoid = helm.assess_ice(helm.new_cmac({}), 0.0, 0.0, 0.0, 0.0, *ranges)
    assert 10.0 <= avoid <= 60.0, "starboard first, just clear of the keel"
    assert seen == (1 if avoid <= helm.PASSAGE_LIMIT else 2), "2: no passage near the course"
    h = math.radians(avoid)
    assert abs(sim.ping(sim.Sea(keels), 0.0, 0.0, avoid)[14] - 400.0) < 1e-6
    # along the recommended heading, the keel's centre is wider than the corridor + radius
    lateral = abs(0.0 * math.cos(h) - 500.0 * math.sin(h))
    assert lateral >= helm.HALF_WIDTH - 50.0
    open_sea = [sim.SONAR_RANGE] * 14
    assert helm.assess_ice(helm.new_cmac({}), 123.0, 0.0, 0.0, 120.0, *open_sea) == (0, 123.0)


def test_the_cmac_generalizes_the_detections_into_an_ice_map_it_keeps(hooks):
    """Section 4.3.2: the CMAC "receives the data, generalizes for an estimated ice
    distribution map, stores the map in the control world model, and computes an ice
    avoidance recommended heading". Trained on the pings of a ship closing a keel, its map
    says ice at and near the detections (not only at them), open water along the beams,
    nothing where no beam has been; and it remembers the keel once the beams have turned
    away from it, so the course through it stays blocked."""
    helm, _, sim, _ = hooks
    keel = (0.0, 800.0, 100.0)
    cmac = helm.new_cmac({})
    for step in range(6):
        y = 20.0 * step
        helm.assess_ice(cmac, 0.0, 0.0, y, 0.0, *sim.ping(sim.Sea([keel]), 0.0, y, 0.0)[:14])
    edge = 700.0  # the keel's near edge, dead ahead
    assert cmac.estimate(0.0, edge) > helm.ICE
    assert cmac.estimate(helm.TILE / 4, edge + 10.0) > helm.ICE, "generalized around the hits"
    assert abs(cmac.estimate(0.0, 300.0)) < 0.1, "open water where the beams passed"
    assert cmac.estimate(2000.0, 2000.0) == 0.0, "nothing known where no beam has been"
    # the beams turned away (east): the keel is out of their view, but the map keeps it
    east = sim.ping(sim.Sea([keel]), 0.0, 100.0, 90.0)[:14]
    assert all(r == sim.SONAR_RANGE for r in east)
    seen, avoid = helm.assess_ice(cmac, 0.0, 0.0, 100.0, 90.0, *east)
    assert seen != 0 and avoid != 0.0, "the course north is still blocked by the stored map"
    # the same ping twice in a cycle (Helm assesses once or twice) trains once
    before = dict(cmac.weights)
    helm.assess_ice(cmac, 0.0, 0.0, 100.0, 90.0, *east)
    assert cmac.weights == before


def test_course_and_waypoints(hooks):
    helm, mission, sim, _ = hooks
    assert helm.course_to(100.0, 0.0, 0.0, 0.0) == 90.0
    assert helm.course_to(0.0, -100.0, 0.0, 0.0) == 180.0
    assert helm.course_to(-100.0, 100.0, 0.0, 0.0) == 315.0
    assert sim.advance(0.0, 0.0, 90.0, 10.0) == (10.0, 0.0)
    plan = mission.Mission([(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)], {(3.0, 4.0): (-3.0, 4.0)})
    assert mission.plan_route(plan, 0, 0) == [(1.0, 2.0), (3.0, 4.0), (5.0, 6.0)], "the route"
    # blocked at step 1: the rest of the plan, the blocked waypoint replaced by its alternate
    assert mission.plan_route(plan, 1, 3) == [(-3.0, 4.0), (5.0, 6.0)]
    # blocked again at the alternate, which has none: the same waypoint is tried again
    assert mission.plan_route(plan, 0, 2) == [(-3.0, 4.0), (5.0, 6.0)]


# ---- a leg blocked by ice: the plan


def plan_of(line: dict) -> dict:
    return line["modules"]["cc"]["plans"]["route"]


def test_a_blocked_leg_is_replanned_by_its_alternate_and_the_mission_completes():
    """ice_replan: Helm finds no passage towards the second waypoint (a ridge of keels across
    the path), reports BLOCKED; SM passes the reason up; cc replans once (one replan of the
    declared two used), makes for the alternate waypoint instead, and finishes DONE."""
    final, lines = played("ice_replan")
    assert final["status"] == "DONE"
    helm_errors = [ln for ln in lines if ln["modules"]["helm"]["rule"] == "ICE_MANEUVER/S2/4"]
    assert len(helm_errors) == 1, "Helm reports BLOCKED once"
    blocked = helm_errors[0]["cycle"]
    assert at(lines, blocked + 1)["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S1/4"
    replanned = at(lines, blocked + 2)
    assert replanned["modules"]["cc"]["rule"] == "RUN_MISSION/TRANSIT/3"
    before = plan_of(at(lines, blocked + 1))
    assert before == {"replans_left": 2, "step": 1, "steps": 3}, "blocked on the second leg"
    assert plan_of(replanned) == {"replans_left": 1, "step": 0, "steps": 2}
    # the rest of the run follows the new plan: the alternate, then the last waypoint
    waypoints = route("ridge.route")
    alternate = (-1600.0, 6800.0)  # ridge.route: the second waypoint's alternate
    sent = [
        ln for ln in lines[blocked + 1 :] if ln["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S0/1"
    ]
    assert len(sent) == 2
    done = [ln for ln in lines if ln["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S1/3"]
    for line, (x, y) in zip(done, [waypoints[0], alternate, waypoints[2]], strict=True):
        assert abs(line["world"]["pos_x"] - x) < HAVEN and abs(line["world"]["pos_y"] - y) < HAVEN
    assert plan_of(lines[-1]) == {"replans_left": 1, "step": 2, "steps": 2}, "done"
    assert min(ln["world"]["min_clearance"] for ln in lines) >= 100.0


def test_a_blocked_leg_fails_the_mission_once_no_replans_are_left():
    """ice_no_way: the same ridge with no alternate in the route; each replan tries the
    blocked waypoint again; after the two declared replans cc reports ERROR, BLOCKED."""
    final, lines = played("ice_no_way")
    assert final["status"] == "ERROR"
    cc = [ln["modules"]["cc"]["rule"] for ln in lines]
    replans = [i for i, rule in enumerate(cc) if rule == "RUN_MISSION/TRANSIT/3"]
    assert [plan_of(lines[i])["replans_left"] for i in replans] == [1, 0], "both replans used"
    assert all(plan_of(lines[i])["steps"] == 2 for i in replans), "the same waypoint again"
    assert cc[-1] == "RUN_MISSION/TRANSIT/4", "then blocked with no replans left: ERROR"
    assert lines[-2]["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S1/4", "SM: BLOCKED"
    assert min(ln["world"]["min_clearance"] for ln in lines) >= 100.0


# ---- a rudder casualty


def test_a_jammed_rudder_s_error_climbs_one_level_a_cycle():
    final, lines = played("rudder_jam")
    assert final["status"] == "ERROR"
    scenario = load_scenario(SCENARIOS / "rudder_jam.yaml")
    jam = next(e.cycle for e in scenario.events if e.world.get("rudder_jammed"))
    angle = at(lines, jam - 1)["world"]["rudder_angle"]
    assert all(line["world"]["rudder_angle"] == angle for line in lines[jam - 1 :]), "jammed"

    def first_error(module: str) -> int:
        return next(line["cycle"] for line in lines if line["modules"][module]["status"] == "ERROR")

    chain = ["rudder_sim", "rudder", "helm", "sm", "cc"]  # bottom to top
    start = first_error("rudder_sim")
    assert start >= jam
    assert at(lines, start)["modules"]["rudder_sim"]["command"] in ("PLUS_VOLT", "MINUS_VOLT")
    assert [first_error(m) for m in chain] == [start + k for k in range(len(chain))]
    assert lines[-1]["cycle"] == start + len(chain) - 1, "the run stops when cc reports"


def test_a_malformed_route_or_keel_line_is_named_with_its_line(hooks, tmp_path):
    _, mission, sim, _ = hooks
    route = tmp_path / "r.route"
    route.write_text("# a comment\n10 20  # first\n\n30 forty\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"r\.route:4: expected `X Y` \(numbers\), got '30 forty'"):
        mission.load_route(route)
    route.write_text("10 20  # first\n30 40 -30 40\n", encoding="utf-8")
    loaded = mission.load_route(route)
    assert loaded.route == [(10.0, 20.0), (30.0, 40.0)]
    assert loaded.alternates == {(30.0, 40.0): (-30.0, 40.0)}
    keels = tmp_path / "k.keels"
    keels.write_text("1 2 3\n1 2\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"k\.keels:2: expected `X Y RADIUS`"):
        sim.load_keels(keels)
    keels.write_text("1 2 nan\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"k\.keels:1:"):
        sim.load_keels(keels)
    contacts = tmp_path / "c.contacts"
    contacts.write_text("# a ship\n0 -300 180 3\n0 -300 180\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"c\.contacts:3: expected `X Y COURSE SPEED`"):
        sim.load_contacts(contacts)


def test_helm_reports_a_rudder_error_instead_of_ordering_the_rudder_again() -> None:
    """A rudder ERROR wins over a new order (helm.yaml): in the cycle helm reads the rudder's
    ERROR while the course error has changed by more than the deadband (Evt5 would re-order),
    helm reports ERROR and sends the rudder nothing new (it used to send GOTO_ANGLE again,
    replacing the erred order, and the ERROR was lost)."""
    harness = Harness.load(ROOT / "generated" / "submarine", hooks_dir=SUBMARINE)
    try:
        harness.world.update({"pos_x": 0.0, "pos_y": 0.0, "heading": 0.0})
        harness.command(
            "helm", "ICE_MANEUVER", x=0.0, y=10000.0, from_x=0.0, from_y=0.0
        )  # due north: course 0
        harness.step("helm")  # S0: the course
        harness.world.update({"heading": -10.0})
        harness.step("helm")  # Evt5: 10 degrees off, order 15 degrees of rudder
        first = harness.sent("rudder")
        assert (first.command, first.args) == ("GOTO_ANGLE", {"angle": 15.0})
        harness.reply("rudder", "ERROR")
        harness.world.update({"heading": -5.0})  # Evt5 holds again: order 7.5 degrees
        harness.step("helm")
        assert harness.status("helm").status == "ERROR"
        assert harness.sent("rudder") == first, "helm ordered the rudder after its ERROR"
    finally:
        harness.close()


def test_fresh_water_run_off_sinks_the_ship_until_variable_ballast_is_blown():
    """Section 4.1.2: lighter water at a fresh water run-off sinks the ship; the planes
    (the ship's depth response) cannot hold it, so ship maneuver blows variable ballast
    (4.1.1) while the depth is more than DEPTH_LIMIT off, and the depth is held again."""
    final, lines = played("fresh_water_runoff")
    assert final["status"] == "DONE"
    scenario = load_scenario(SCENARIOS / "fresh_water_runoff.yaml")
    drop, back = (e.cycle for e in scenario.events if "water_density" in e.world)
    before = at(lines, drop - 1)["world"]
    assert before["depth"] == before["depth_gauge"] == 120.0 and before["ballast"] == 0.0
    # two depths (4.6.4): the actual one and the depth sensor's, a pressure gauge calibrated
    # for 1025 kg/m3 that reads shallow in the lighter water; the controllers read the gauge
    for c in range(drop + 1, back):
        w = at(lines, c)["world"]
        assert w["depth_gauge"] == pytest.approx(w["depth"] * w["water_density"] / 1025.0)
        assert w["depth"] - w["depth_gauge"] > 3.0
    deepest = max(line["world"]["depth_gauge"] for line in lines)
    assert 120.0 + 5.0 < deepest < 130.0, "sank past what the planes hold, not far"
    blowing = [
        line["cycle"] for line in lines if line["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S1/5"
    ]
    assert blowing and all(drop < c < back for c in blowing)
    for c in blowing:  # blown only while the gauge reads more than DEPTH_LIMIT deeper
        assert at(lines, c - 1)["world"]["depth_gauge"] > 125.0
    held = [at(lines, c)["world"]["depth_gauge"] for c in range(blowing[-1] + 30, back)]
    assert held and all(abs(d - 120.0) <= 1.0 for d in held)
    after = [line["world"]["depth"] for line in lines if line["cycle"] > back + 30]
    assert all(abs(d - 120.0) <= 1.0 for d in after), (
        "the blown ballast is within the planes' reach"
    )
    assert min(line["world"]["below_keel"] for line in lines) == final_below_keel(lines)


def test_the_sea_bottom_is_a_fractal_profile_made_before_the_run(hooks):
    """Section 4.6.5: "The ice keel and sea bottom profiles were generated using fractals,
    which allowed a complex structure of indefinite size and extent without the need for
    long and complex mappings. They are generated prior to test runs." The bottom is fixed
    by the run's seed before the run (the same seed, the same bottom; another, another),
    defined everywhere, rough at every scale (the mean change over a distance grows with
    it, from 125 m to 4 km, roughly as a power: fractal, not smooth and not white), and the
    sea simulator's water under the keel is that bottom under the traced position."""
    *_, sea = hooks
    bottom = sea.new_bottom({})
    assert bottom == sea.new_bottom({"bottom_seed": "1"})
    other = sea.new_bottom({"bottom_seed": "2"})
    points = [(x * 97.0, y * 89.0) for x in range(-30, 30) for y in range(0, 100, 3)]
    assert any(bottom.depth(x, y) != other.depth(x, y) for x, y in points)
    far = [bottom.depth(x + 1e6, y - 3e6) for x, y in points[:50]]
    assert all(sea.MEAN_DEPTH - sea.RELIEF <= d <= sea.MEAN_DEPTH + sea.RELIEF for d in far)

    def change(d: float) -> float:
        return sum(abs(bottom.depth(x, y + d) - bottom.depth(x, y)) for x, y in points) / len(
            points
        )

    scales = [change(d) for d in (125.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0)]
    assert scales == sorted(scales) and scales[0] > 0.2
    ratios = [b / a for a, b in zip(scales, scales[1:], strict=False)]
    assert all(1.3 < r < 2.1 for r in ratios), ratios  # 2**H, H about 0.5-1
    with pytest.raises(ValueError, match="bottom_seed must be a whole number"):
        sea.new_bottom({"bottom_seed": "x"})
    _, lines = played("salinity_planes")
    for line in lines[::50]:
        w = line["world"]
        assert w["below_keel"] + w["depth"] == pytest.approx(
            bottom.depth(w["pos_x"], w["pos_y"]), abs=1e-6
        )
    under = [ln["world"]["below_keel"] + ln["world"]["depth"] for ln in lines]
    assert max(under) - min(under) > 10.0, "not a flat bottom"


def final_below_keel(lines: list[dict]) -> float:
    """The sea simulator's running minimum of the water under the keel, at the end."""
    return lines[-1]["world"]["min_below_keel"]


def test_the_eoow_refusing_the_epm_fails_the_mission_with_his_reason():
    """eoow_refuses: the EOOW answers CHANGE_TO_EPM with ERROR REFUSED. Propulsion clutches
    the turbines in again and fails with his reason; ship maneuver halts the helm, waits for
    it to stop, and passes the reason up; the command controller fails with it."""
    final, lines = played("eoow_refuses")
    assert final["status"] == "ERROR" and final["reason"] == "REFUSED"
    refused = next(ln["cycle"] for ln in lines if ln["modules"]["prop"]["status"] == "ERROR")
    assert at(lines, refused - 1)["world"]["shaft"] == "DISENGAGED"
    assert at(lines, refused)["world"]["shaft"] == "TURBINE"
    halted = at(lines, refused + 1)["modules"]
    assert halted["sm"]["state"] == "PROP_FAILED" and halted["helm"]["command"] == "HALT"
    sm_error = next(ln["cycle"] for ln in lines if ln["modules"]["sm"]["status"] == "ERROR")
    assert at(lines, sm_error - 1)["modules"]["helm"]["status"] == "DONE", "after helm stopped"
    assert at(lines, sm_error)["modules"]["sm"]["reason"] == "REFUSED"
    assert lines[-1]["cycle"] == sm_error + 1
    assert not any(ln["world"]["periscope_raised"] for ln in lines)


def depth_casualty(lines: list[dict]) -> tuple[int, int]:
    """(the cycle ship maneuver asks the OOD, the cycle his answer is in the trace)."""
    asked = next(ln["cycle"] for ln in lines if ln["modules"]["ood/sm"]["state"] == "ASKING")
    answered = next(
        ln["cycle"]
        for ln in lines
        if ln["cycle"] > asked and ln["modules"]["ood/sm"]["status"] != "EXECUTING"
    )
    return asked, answered


def test_a_depth_the_ballast_cannot_hold_is_the_ood_s_choice_and_he_chooses_the_planes():
    """Section 4.7.3: a salinity disturbance the depth controller cannot hold. Ship maneuver
    blows its variable ballast to the tanks' limit (20 kg/m3), and only then, the ship
    still sinking more than 5 m below its order, asks the OOD (DEPTH_CASUALTY, the depth on
    his screen) and waits in DEPTH_ASKED; his choice, the planes, is the task's result, read
    by ship maneuver in the cycle his DONE reaches it, which goes back to S1 with full
    planes in that cycle (no completion state), and full planes bring the depth back."""
    final, lines = played("salinity_planes")
    assert final["status"] == "DONE"
    asked, answered = depth_casualty(lines)
    before = at(lines, asked - 1)["world"]
    assert before["ballast"] == 20.0 and before["depth_gauge"] > 125.0, "spent, still sinking"
    assert at(lines, asked)["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/S1/8"
    assert at(lines, asked)["modules"]["sm"]["state"] == "DEPTH_ASKED"
    channel = at(lines, answered)["modules"]["ood/sm"]
    assert channel["status"] == "DONE" and channel["result"] == {"choice": "PLANES"}
    assert answered - asked >= 10, "he answers 10 s after taking the request up"
    assert all(at(lines, c)["world"]["planes"] == "NORMAL" for c in range(1, answered + 1))
    chose = at(lines, answered + 1)
    assert chose["modules"]["sm"]["rule"] == "SUBMERGED_TRANSIT/DEPTH_ASKED/3"
    assert chose["modules"]["sm"]["state"] == "S1" and chose["world"]["planes"] == "FULL"
    deepest = max(ln["world"]["depth"] for ln in lines)
    assert deepest == max(at(lines, c)["world"]["depth"] for c in range(asked, answered + 2))
    # held where full planes balance the sinking (1.5 m on the gauge; float rounding aside),
    # and again once the sea is as dense as before (the gauge then reads the actual depth)
    back = [e.cycle for e in load_scenario(SCENARIOS / "salinity_planes.yaml").events][-1]
    held = [ln["world"]["depth_gauge"] for ln in lines if answered + 60 <= ln["cycle"] < back]
    after = [ln["world"]["depth"] for ln in lines if back + 30 <= ln["cycle"]]
    assert held and after and all(abs(d - 120.0) <= 1.5 + 1e-9 for d in held + after)
    assert not any(ln["world"]["mbt_blown"] for ln in lines)
    assert all(ln["modules"]["ood/sm"]["state"] == "NOP" for ln in lines[: asked - 1])


def test_the_ood_s_last_resort_blows_the_main_ballast_tanks_and_the_ship_surfaces():
    """Section 4.7.3: "Blowing MBTs may be the last resort that disallows the submarine to
    re-submerge". The OOD chooses MBT_BLOW: in the cycle his answer reaches ship maneuver
    the tanks are blown and the helm halted; once it has stopped the transit fails with
    SURFACED, which cc passes up; the ship rises to the surface."""
    final, lines = played("salinity_mbt_blow")
    assert final["status"] == "ERROR" and final["reason"] == "SURFACED"
    asked, answered = depth_casualty(lines)
    assert at(lines, answered)["modules"]["ood/sm"]["result"] == {"choice": "MBT_BLOW"}
    assert not at(lines, answered)["world"]["mbt_blown"]
    blown = at(lines, answered + 1)
    assert blown["world"]["mbt_blown"] and blown["world"]["depth_cmd"] == 0.0
    assert blown["modules"]["sm"]["state"] == "SURFACING"
    assert blown["modules"]["helm"]["command"] == "HALT"
    failed = next(ln["cycle"] for ln in lines if ln["modules"]["sm"]["status"] == "ERROR")
    assert at(lines, failed - 1)["modules"]["helm"]["status"] == "DONE", "after the helm stopped"
    assert at(lines, failed)["modules"]["sm"]["reason"] == "SURFACED"
    assert at(lines, failed + 1)["modules"]["cc"]["reason"] == "SURFACED"
    depths = [ln["world"]["depth"] for ln in lines if ln["cycle"] > answered]
    assert depths == sorted(depths, reverse=True) and depths[-1] == 0.0, "rises to the surface"
    assert all(ln["world"]["planes"] == "NORMAL" for ln in lines)


def test_the_ood_refusing_to_choose_fails_the_transit_with_his_reason_up_to_cc():
    """Section 4.7.3, the other answer to a system request: the OOD answers DEPTH_CASUALTY
    with ERROR REFUSED (`ood_refuses`). In the cycle his refusal reaches ship maneuver the
    helm is halted (no planes, no MBT blow: the depth is not held); once the helm has
    stopped, sm fails with REFUSED, and the next cycle cc fails with it, the chain naming
    where it came from."""
    final, lines = played("ood_refuses")
    assert final["status"] == "ERROR" and final["reason"] == "REFUSED"
    asked, answered = depth_casualty(lines)
    refused = at(lines, answered)["modules"]["ood/sm"]
    assert refused["status"] == "ERROR" and refused["command"] == "DEPTH_CASUALTY"
    assert at(lines, answered)["modules"]["sm"]["state"] == "DEPTH_ASKED"
    halted = at(lines, answered + 1)
    assert halted["modules"]["sm"]["state"] == "OOD_FAILED"
    assert halted["modules"]["helm"]["command"] == "HALT"
    failed = next(ln["cycle"] for ln in lines if ln["modules"]["sm"]["status"] == "ERROR")
    assert at(lines, failed - 1)["modules"]["helm"]["status"] == "DONE", "after the helm stopped"
    assert at(lines, failed)["modules"]["sm"]["reason"] == "REFUSED"
    top = at(lines, failed + 1)["modules"]["cc"]
    assert top["status"] == "ERROR" and top["reason"] == "REFUSED"
    assert top["cause"] == "sm: REFUSED <- ood: REFUSED"
    assert all(at(lines, c)["modules"]["cc"]["status"] == "EXECUTING" for c in range(7, failed + 1))
    assert all(ln["world"]["planes"] == "NORMAL" and not ln["world"]["mbt_blown"] for ln in lines)


def fidelity_counts(page: Path) -> tuple[dict[str, int], str]:
    """The verdicts of a case study's fidelity table, counted, and its summary line."""
    import re
    from collections import Counter

    text = page.read_text(encoding="utf-8")
    table = text[text.index("## Fidelity to") :]
    summary = re.search(r"Of (\d+) rows: \*\*(.+?)\*\*", table)
    assert summary, f"{page.name}: no 'Of N rows: **...**' summary under its fidelity table"
    rows = [ln for ln in table[: summary.start()].splitlines() if re.match(r"\| \d+ \|", ln)]
    verdicts = Counter(ln.rstrip(" |").split("|")[-1].strip().split(":")[0] for ln in rows)
    assert set(verdicts) <= {"faithful", "simplified", "missing", "invented"}, verdicts
    numbers = [int(ln.split("|")[1]) for ln in rows]
    assert numbers == list(range(1, len(rows) + 1)), "rows numbered 1..N in order"
    said = f"Of {len(rows)} rows: **" + ", ".join(
        f"{verdicts[v]} {v}" for v in ("faithful", "simplified", "missing", "invented")
    )
    return dict(verdicts), said


@pytest.mark.parametrize("page", ["submarine.md", "inspection.md"])
def test_the_fidelity_tables_summaries_count_their_rows(page):
    """The summary under each fidelity table is the table's own count of verdicts."""
    path = ROOT / "docs" / page
    verdicts, said = fidelity_counts(path)
    assert said in path.read_text(encoding="utf-8"), (
        f"docs/{page}: the summary should read {said}**"
    )
    assert verdicts["faithful"] > verdicts["simplified"]


def test_the_access_matrix_holds_at_the_console():
    """Figure 29 on the running submarine (paced, as OS processes): the EOOW and the BCP may
    not command the mission, the OOD may, but may not stop the helm; the helmsman may take
    the rudder in manual override (an emergency turn), and the rudder answers him."""
    import importlib

    from conftest import wait_for
    from test_ctl import Running

    from rcsgen.tools.harness import import_package

    package = ROOT / "generated" / "submarine"
    layout = importlib.import_module(f"{import_package(package, SUBMARINE).__name__}.layout")
    system = Running(package, SUBMARINE, layout)
    try:
        for role in ("eoow", "bcp"):
            refused = system.ctl("--role", role, "send", "cc", "RUN_MISSION")
            assert refused.returncode == 1 and "needs command on cc" in refused.stderr, role
        stop = system.ctl("--role", "ood", "stop", "helm")
        assert stop.returncode == 1 and "needs override on helm" in stop.stderr
        sent = system.ctl("--role", "ood", "send", "cc", "RUN_MISSION", "--seen")
        assert sent.returncode == 0, sent.stderr
        wait_for(lambda: system.module("helm")["command"] == "ICE_MANEUVER", "the helm steering")
        turn = system.ctl(
            "--role", "helmsman", "send", "rudder", "GOTO_ANGLE", "angle=-20", "--override"
        )
        assert turn.returncode == 0, turn.stderr
        wait_for(lambda: system.module("rudder")["args"] == {"angle": -20.0}, "his order")
        assert system.module("helm")["run"] == "STOP", "the helm's orders are suspended"
        wait_for(lambda: system.json()["world"]["rudder_angle"] <= -10.0, "the rudder turning")
    finally:
        out = system.stop()
    assert "ship: stopped" in out


def test_the_fire_is_reported_by_the_propulsion_system_s_sensor_as_by_the_ventilation_s():
    """Section 4.7.1: "A lube oil fire is reported through the sensors in both the propulsion
    and the ventilation control systems". The fire heats the main lube oil pumps (the
    atmosphere simulator), propulsion infers fire there from its sensor, and the command
    controller takes that report alone, with the ventilation sensors still clean, for the
    fire: the alarm, and ship maneuver to prepare for emergency ventilation."""
    harness = Harness.load(ROOT / "generated" / "submarine", hooks_dir=SUBMARINE)
    try:
        harness.world.update({"fire": True})
        harness.step("atmosphere")
        harness.step("atmosphere")
        assert harness.world["lube_oil_temp"] == 70.0  # two cycles of fire at the pumps
        harness.world.update({"fire": False})
        harness.step("atmosphere")
        assert harness.world["lube_oil_temp"] == 69.0  # cooling once it is out
        harness.world.update({"lube_oil_temp": 65.0})
        harness.step("prop")
        assert harness.world["pumps_fire"] is False  # at the alarm level, not above
        harness.world.update({"lube_oil_temp": 66.0})
        harness.step("prop")
        assert harness.world["pumps_fire"] is True
        harness.world.update({"pumps_fire": False})
        harness.command("cc", "RUN_MISSION")
        harness.step("cc")  # S0: the route planned
        harness.step("cc")  # S1: the transit to the first waypoint
        assert harness.sent("sm").command == "SUBMERGED_TRANSIT"
        harness.step("cc")  # TRANSIT: nothing reported yet
        assert harness.sent("sm").command == "SUBMERGED_TRANSIT"
        harness.world.update({"engine_room_contaminated": False, "pumps_fire": True})
        harness.step("cc")
        assert harness.sent("sm").command == "PREP_EMERGENCY_VENT"
        assert harness.world["announcement"] == "ENGINE ROOM FIRE, ALL HANDS ON EABS"
    finally:
        harness.close()


def test_the_general_alarm_musters_the_crew_whose_damage_control_party_puts_the_fire_out():
    """Section 4.1.3: "Upon hearing the general alarm the crew proceeds to their assigned
    general emergency (battle) stations, relief of the section watchstanders occurs"; "The
    damage control party fights the fire"; once secured from general emergency "The normal
    underway watch section will resume the watch". The fire burns on, unfought, until the
    alarm has mustered the crew; then the party puts it out."""
    harness = Harness.load(ROOT / "generated" / "submarine", hooks_dir=SUBMARINE)
    try:
        harness.world.update({"fire": True})
        for _ in range(60):  # no alarm: the crew stands its section watch, the fire burns
            harness.step("crew")
            harness.step("atmosphere")
        assert harness.world["fire"] is True and harness.world["watch"] == "SECTION"
        harness.world.update({"general_alarm": True})
        mustered = 0
        while harness.world["watch"] == "SECTION":
            assert mustered < 20, "the crew never reached its battle stations"
            harness.step("crew")
            harness.step("atmosphere")
            mustered += 1
        assert mustered == 8  # the alarm heard for 7 s: seen in 8 consecutive cycles
        fought = 0
        while harness.world["fire"]:
            assert fought < 40, "the damage control party never put the fire out"
            harness.step("crew")
            harness.step("atmosphere")
            fought += 1
        assert fought == 20  # on scene since the muster's cycle: 21 cycles, fought for 20 s
        harness.world.update({"general_alarm": False})
        harness.step("crew")
        assert harness.world["watch"] == "SECTION"
    finally:
        harness.close()
