"""What recorded a trace (rcsgen/tools/traces/recording.py), in the unit tier: the systems
whose files declare every module of a trace (a text scan, nothing compiled), and the
scenario a replay page takes its settings from (named, else the one named like the trace).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from rcsgen.tools.traces.recording import recording_scenario, systems_naming

SPECS = Path(__file__).resolve().parent.parent / "specs"


def system_dir(root: Path, name: str, declared: dict[str, str]) -> Path:
    folder = root / name
    folder.mkdir(parents=True)
    (folder / "system.yaml").write_text(f"system: {name}\n")
    for file, text in declared.items():
        (folder / file).write_text(text)
    return folder


def test_only_the_systems_declaring_every_module_of_a_trace_are_named(tmp_path: Path) -> None:
    both = system_dir(
        tmp_path,
        "a_both",
        {
            "co.yaml": "# the cutter\ncontroller: co\ndoc: x\n",
            "op.yaml": 'operator: "op"\n',
            "sb.yaml": "doc: the shuttle\ncontroller:   sb  # spaced\n",
            "notes.txt": "controller: hidden\n",  # not a spec file
        },
    )
    one = system_dir(tmp_path, "b_one", {"co.yaml": "controller: 'co'\n"})
    system_dir(tmp_path, "c_none", {"co.yaml": "  controller: co\n"})  # not at a line's start
    assert systems_naming([tmp_path], {"co"}) == [both, one]
    assert systems_naming([tmp_path], {"co", "sb", "op"}) == [both]  # every one, exactly
    assert systems_naming([tmp_path], {"co", "sb", "op", "xx"}) == []
    assert systems_naming([tmp_path], {"hidden"}) == []
    assert systems_naming([tmp_path], set()) == [both, one, tmp_path / "c_none"]


def test_a_file_that_cannot_be_read_as_text_is_passed_over(tmp_path: Path) -> None:
    folder = system_dir(tmp_path, "sys", {})
    for i in range(8):  # (wherever the listing puts them: every good file is still read)
        (folder / f"bad{i}.yaml").write_bytes(b"controller: \xff\xfe\n")
    (folder / "b_good.yaml").write_text("controller: co\n")
    (folder / "c_good.yaml").write_text("controller: cd\n")
    assert systems_naming([tmp_path], {"co", "cd"}) == [folder]


def test_a_replay_takes_the_settings_of_the_scenario_that_recorded_the_trace(
    tmp_path: Path,
) -> None:
    system = SimpleNamespace(source="inspection/system.yaml")
    folder, settings, name = recording_scenario(
        system,  # type: ignore[arg-type]
        SPECS,
        tmp_path / "machine_fault.jsonl",
        None,
    )
    assert folder == SPECS / "inspection" and name == "machine_fault"
    assert settings == {
        "program": "programs/bracket.dmi",
        "part": "parts/nominal.part",
        "seed": "1",
    }
    folder, settings, name = recording_scenario(
        system,  # type: ignore[arg-type]
        SPECS,
        tmp_path / "not_a_scenario.jsonl",
        None,
    )
    assert (folder, settings, name) == (SPECS / "inspection", {}, "")
    named = SPECS / "inspection" / "scenarios" / "console_refusal.yaml"
    _, settings, name = recording_scenario(
        system,  # type: ignore[arg-type]
        SPECS,
        tmp_path / "machine_fault.jsonl",
        named,
    )
    assert name == "console_refusal" and settings["seed"] == "1"
