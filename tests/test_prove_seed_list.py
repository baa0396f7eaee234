"""The seeded bugs `rcsgen prove`'s own check plants (rcsgen/tools/prove_seeds.py `seeds`),
listed for a small system written by hand, in the unit tier: each send left out, an ERROR
branch left out, a DONE echo read as "not ERROR", a HALT table removed, a supervisor run
after its subordinate; each where it is, in words, and the file as it would be written.
test_prove_seeds proves them (z3, slow)."""

from __future__ import annotations

from pathlib import Path

import yaml

from rcsgen.tools.prove_seeds import seeds

SUP = """\
controller: sup
subordinates: [arm]
commands:
  RUN:
    states:
      S0:
        - when: arm.status == DONE
          do: [{send: arm.GO}, {set: {n: 1}}]
        - when: arm.status == ERROR
          do: [{report: ERROR}]
        - use: common
        - a line of text, not a rule
  NOTE: a command written as text, not a table (passed over; the next are still read)
  HALT:
    states:
      S0:
        - do: [{send: arm.HALT}]
"""
ARM = "controller: arm\ncommands:\n  GO:\n    states:\n      S0:\n        - do: [{report: DONE}]\n"
SYSTEM = "system: tiny\nprocesses:\n  p: {modules: [sup, arm]}\n  q: {modules: [arm]}\n"


def test_every_seed_of_a_small_system_in_a_stable_order(tmp_path: Path) -> None:
    directory = tmp_path / "tiny"
    directory.mkdir()
    for name, text in {"sup.yaml": SUP, "arm.yaml": ARM, "system.yaml": SYSTEM}.items():
        (directory / name).write_text(text)
    found = seeds(directory)
    assert [(s.kind, s.system, s.file, s.controller, s.command, s.where) for s in found] == [
        ("drop-send", "tiny", "sup.yaml", "sup", "RUN", "sup RUN/S0/1: send arm.GO left out"),
        (
            "forget-echo",
            "tiny",
            "sup.yaml",
            "sup",
            "RUN",
            "sup RUN/S0/1: `arm.status == DONE` read as `arm.status != ERROR`",
        ),
        (
            "drop-error-branch",
            "tiny",
            "sup.yaml",
            "sup",
            "RUN",
            "sup RUN/S0/2: the ERROR branch `arm.status == ERROR` left out",
        ),
        ("drop-send", "tiny", "sup.yaml", "sup", "HALT", "sup HALT/S0/1: send arm.HALT left out"),
        ("remove-halt", "tiny", "sup.yaml", "sup", "HALT", "sup: its HALT table left out"),
        ("swap-order", "tiny", "system.yaml", "sup", "", "p: sup and arm swapped"),
    ]
    texts = [yaml.safe_load(s.text) for s in found]
    run = lambda i: texts[i]["commands"]["RUN"]["states"]["S0"]  # noqa: E731
    assert run(0)[0] == {"when": "arm.status == DONE", "do": [{"set": {"n": 1}}]}
    assert run(1)[0]["when"] == "arm.status != ERROR"
    assert run(2)[0]["when"] == "arm.status == DONE" and len(run(2)) == 3  # the branch gone
    assert texts[3]["commands"]["HALT"]["states"]["S0"] == [{}]  # its only action gone
    assert "HALT" not in texts[4]["commands"] and "RUN" in texts[4]["commands"]
    assert texts[5]["processes"] == {"p": {"modules": ["arm", "sup"]}, "q": {"modules": ["arm"]}}
    assert yaml.safe_load(SUP) == yaml.safe_load((directory / "sup.yaml").read_text())  # untouched


def test_a_seed_is_masked_only_by_a_finding_it_would_cause_at_its_own_place() -> None:
    """A finding the unchanged system already has hides a seed that would cause it (it could
    not show as new): a rule's seed (an ERROR branch left out, a DONE echo forgotten) only
    in that rule's state, a command's seed (a send left out) anywhere in the command; never
    a finding of another code, controller or command."""
    from rcsgen.compiler.diagnostics import Span
    from rcsgen.compiler.prove.properties import Finding
    from rcsgen.compiler.prove.system import SystemProof
    from rcsgen.tools.prove_seeds import Seed, _masked

    def had(*found: tuple[str, str, str, str]) -> SystemProof:
        return SystemProof(
            "tiny", [Finding(c, m, cmd, s, 1, Span("sup.yaml"), "", "") for c, m, cmd, s in found]
        )

    def seed(kind: str, where: str) -> Seed:
        return Seed(kind, "tiny", "sup.yaml", "sup", "RUN", f"sup RUN/S0/1: {where}", "")

    echo = seed("forget-echo", "`arm.status == DONE` read as `arm.status != ERROR`")
    branch = seed("drop-error-branch", "the ERROR branch `arm.status == ERROR` left out")
    send = seed("drop-send", "send arm.GO left out")
    elsewhere = had(("W708", "sup", "RUN", "S1"), ("W705", "sup", "RUN", "S1"))
    assert _masked(echo, elsewhere) == "" and _masked(branch, elsewhere) == ""
    assert _masked(echo, had(("W708", "sup", "RUN", "S0"))) == (
        "the unchanged system already has W708 at sup RUN S0"
    )
    assert _masked(branch, had(("W705", "sup", "RUN", "S0"))) == (
        "the unchanged system already has W705 at sup RUN S0"
    )
    assert _masked(send, had(("W704", "sup", "RUN", "S1"))) == (
        "the unchanged system already has W704 at sup RUN S1"
    )
    others = had(("W708", "sup", "RUN", "S0"), ("W704", "arm", "RUN", "S0"))
    assert _masked(send, others) == ""
    assert _masked(send, had(("W704", "sup", "HALT", "S0"))) == ""


def test_a_done_after_an_error_in_one_guard_and_a_templates_controllers_are_seeded(
    tmp_path: Path,
) -> None:
    """Each `.status == DONE` of a guard is an echo to forget, after an ERROR test too; a
    template's controllers (a directory beside system.yaml holding a template.yaml) are
    seeded as the system's are, each in its own file."""
    directory = tmp_path / "tiny"
    (directory / "cell").mkdir(parents=True)
    either = SUP.replace(
        "when: arm.status == DONE", "when: arm.status == ERROR or arm.status == DONE"
    )
    files = {"sup.yaml": either, "arm.yaml": ARM, "system.yaml": SYSTEM}
    files |= {
        "cell/template.yaml": "template: cell\n",
        "cell/boss.yaml": SUP.replace("sup", "boss"),
    }
    for name, text in files.items():
        (directory / name).write_text(text)
    found = [(s.kind, s.file, s.where) for s in seeds(directory)]
    assert (
        "forget-echo",
        "sup.yaml",
        "sup RUN/S0/1: `arm.status == DONE` read as `arm.status != ERROR`",
    ) in found
    assert ("drop-send", "cell/boss.yaml", "boss RUN/S0/1: send arm.GO left out") in found
