"""A scenario's device faults, replies, figures and operator script checked before anything
runs (rcsgen/tools/scenario/check.py), word for word, in the unit tier: a device unplugged
twice or thawed while up, a plant that is not a spec directory, a device declared but not
served, a reply to a module that is not there, a reason asked of a module that declares
none, and a wrong answer entry beside a default that is right. test_scenarios runs such
scenarios against real soft PLCs; here only what the check says. (`said` and the compiled
shipped systems are test_scenario_checks'.)
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_scenario_checks import SPECS, said, systems, written  # noqa: F401  (a fixture)

from rcsgen.compiler.frontend import compile_paths
from rcsgen.compiler.ir import IRSystem
from rcsgen.tools.scenario.check import check_scenario

ORDER_HINT = "a device is unplugged then replugged, frozen then thawed, in that order"


@pytest.fixture(scope="module")
def hil() -> IRSystem:
    front = compile_paths([SPECS / "miner_hil"])
    assert not front.diagnostics.errors
    return front.systems[0]


def faults(*steps: str) -> str:
    """`devices: {plc: {}}` and one event per step (`unplug`, `replug`, ...) from cycle 2."""
    events = "".join(
        f"  - cycle: {2 + i}\n    device: {{name: plc, do: {do}}}\n" for i, do in enumerate(steps)
    )
    return "devices: {plc: {}}\nevents:\n" + events


@pytest.mark.parametrize(
    ("steps", "want"),
    [
        (("unplug", "replug", "freeze", "thaw", "unplug", "replug"), []),
        (("unplug", "unplug"), ["cannot unplug device `plc` here: it is unplugged"]),
        (("freeze", "unplug"), ["cannot unplug device `plc` here: it is frozen"]),
        (("thaw",), ["cannot thaw device `plc` here: it is up"]),
        (("replug",), ["cannot replug device `plc` here: it is up"]),
        (("freeze", "replug"), ["cannot replug device `plc` here: it is frozen"]),
        (("unplug", "replug", "replug"), ["cannot replug device `plc` here: it is up"]),
        (("unplug", "thaw", "replug"), ["cannot thaw device `plc` here: it is unplugged"]),
    ],
)
def test_device_faults_follow_one_another_in_order(hil, tmp_path, steps, want) -> None:
    got = said(tmp_path, hil, faults(*steps))
    assert got == [("E426", message, ORDER_HINT) for message in want]


def test_a_checked_device_fault_is_the_events_fault_in_order(hil, tmp_path) -> None:
    path = written(tmp_path, hil, "scenario: s\ntitle: S\n" + faults("freeze", "thaw"))
    scenario, found = check_scenario(path, hil)
    assert scenario is not None and not found.errors
    assert [(e.cycle, e.device and (e.device.name, e.device.do)) for e in scenario.events] == [
        (2, ("plc", "freeze")),
        (3, ("plc", "thaw")),
    ]


def test_a_device_fault_names_a_device_served_and_declared(hil, tmp_path) -> None:
    unserved = "events:\n  - cycle: 2\n    device: {name: conveyor, do: freeze}\n"
    assert said(tmp_path, hil, "devices: {plc: {}}\n" + unserved) == [
        (
            "E426",
            "device `conveyor` is not served by this scenario: no soft PLC to fault",
            "add `devices: {conveyor: {}}` (with its `plant:`) to the scenario",
        )
    ]
    assert said(tmp_path, hil, "devices: {plx: {}}\n") == [
        ("E426", "`miner_hil` has no I/O device `plx`", "did you mean `plc`?")
    ]
    assert said(tmp_path, hil, "devices: {zzz: {}}\n") == [  # far from every name
        ("E426", "`miner_hil` has no I/O device `zzz`", "declared devices: `conveyor`, `plc`")
    ]


def test_a_plant_that_is_no_spec_directory_is_named_with_where_it_was_looked_for(
    hil, tmp_path
) -> None:
    (tmp_path / "empty").mkdir()
    got = said(tmp_path, hil, "devices:\n  plc: {plant: empty}\n  conveyor: {}\n")
    assert len(got) == 1
    code, message, hint = got[0]
    assert code == "E426"
    assert message.startswith("plant `empty` of device `plc` is not a spec directory: ")
    assert " no system.yaml in " in message and message.endswith(f"/{tmp_path.name}/empty")
    assert hint == (
        "name the directory of the system whose simulators run in the PLC, relative to "
        "this system's (e.g. ../miner)"
    )
    # an unknown device first: the devices after it are still checked
    both = said(tmp_path, hil, "devices:\n  plx: {}\n  plc: {plant: empty}\n")
    assert [(c, m.split(":")[0]) for c, m, _ in both] == [
        ("E426", "`miner_hil` has no I/O device `plx`"),
        ("E426", "plant `empty` of device `plc` is not a spec directory"),
    ]
    # a wrong plant first: the devices after it are still served (and may be faulted)
    fault = "events:\n  - cycle: 2\n    device: {name: conveyor, do: freeze}\n"
    later = said(tmp_path, hil, "devices:\n  plc: {plant: empty}\n  conveyor: {}\n" + fault)
    assert [(c, m.split(":")[0]) for c, m, _ in later] == [
        ("E426", "plant `empty` of device `plc` is not a spec directory")
    ]
    # a plant that is one: the scenario serves both devices
    (tmp_path / "plant").mkdir()
    (tmp_path / "plant" / "system.yaml").write_text("system: plant\n")
    assert said(tmp_path, hil, "devices:\n  plc: {plant: plant}\n  conveyor: {}\n") == []


def test_a_reply_names_a_controller_and_a_reason_figure_a_module_with_reasons(
    systems,  # noqa: F811
    tmp_path,
) -> None:
    cell = systems["cell"]
    reply = "events:\n  - cycle: 2\n    reply: {spu: DONE}\n"
    assert said(tmp_path, cell, reply) == [
        ("E405", "reply to `spu` is not a controller of `cell`", "did you mean `sup`?")
    ]
    figure = "expect:\n  figures: {sup.reason: NONE}\n"
    assert said(tmp_path, cell, figure) == [
        (
            "E415",
            "expected figure `sup.reason`: `sup` declares no reasons, so it never gives one",
            "declare `reasons:` on its commands, or expect its `status`",
        )
    ]


def test_a_wrong_answer_entry_is_the_one_error_even_beside_a_default(
    systems,  # noqa: F811
    tmp_path,
) -> None:
    """The script is dropped at the first wrong entry: the default is not then checked
    against what the (incomplete) entries cover, which would say more than is wrong."""
    body = (
        "operator:\n  answers:\n    - {operator: lrd, task: SPOT_REPORT, answer: DONE}\n"
        "  default: {answer: DONE}\n"
    )
    assert said(tmp_path, systems["platoon"], body) == [
        ("E285", "`lrd` is not an operator module of `platoon`", "did you mean `ldr`?")
    ]


MINIMAL = "scenario: s\ntitle: A scenario\nmax_cycles: 20\n"


def test_a_scenario_out_of_a_system_directory_or_of_one_that_does_not_build(
    tmp_path: Path,
) -> None:
    (tmp_path / "lone.yaml").write_text(MINIMAL)
    (tmp_path / "sys" / "scenarios").mkdir(parents=True)
    (tmp_path / "sys" / "system.yaml").write_text("system: broken\nprocesses: 3\n")
    (tmp_path / "sys" / "scenarios" / "s.yaml").write_text(MINIMAL)
    said = {}
    for name in ("lone.yaml", "sys/scenarios/s.yaml"):
        scenario, found = check_scenario(tmp_path / name)
        assert scenario is None and len(found.errors) == 1
        said[name] = found.errors[0]
    lone, inside = said["lone.yaml"], said["sys/scenarios/s.yaml"]
    assert (lone.code, lone.hint) == (
        "E403",
        "keep scenarios in the system's scenarios/ directory, or name the system's directory "
        "with `system:`",
    )
    assert lone.message.startswith("no system.yaml above `") and lone.message.endswith("lone.yaml`")
    assert (inside.code, inside.message) == ("E403", "the system this scenario runs does not build")
    assert inside.hint.startswith("run `rcsgen validate ")


def test_a_scenario_names_its_system_with_system(tmp_path: Path) -> None:
    """`system:` (relative to the file) says which system a scenario runs, wherever the
    file is (`rcsgen prove --counterexamples DIR` writes it outside the system's folder);
    a directory without a system.yaml is E403 at the value."""
    (tmp_path / "sys").mkdir()
    (tmp_path / "sys" / "system.yaml").write_text("system: broken\nprocesses: 3\n")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "named.yaml").write_text(MINIMAL + "system: ../sys\n")
    (tmp_path / "out" / "wrong.yaml").write_text(MINIMAL + "system: ../nowhere\n")
    _, found = check_scenario(tmp_path / "out" / "named.yaml")
    assert [(d.code, d.message) for d in found.errors] == [
        ("E403", "the system this scenario runs does not build")  # found: it is sys's
    ]
    _, found = check_scenario(tmp_path / "out" / "wrong.yaml")
    assert [(d.code, d.span.line, d.span.col, d.message) for d in found.errors] == [
        ("E403", 4, 9, "no system.yaml in `../nowhere` (this scenario's `system:`)")
    ]
