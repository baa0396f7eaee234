"""`rcsgen prove`'s own check of itself (rcsgen/tools/prove_seeds.py `trial`) on
test_prove_small's tank and two small systems of test_prove_catalogue's, word for word: each
planted handshake bug with its verdict and why - caught (the first new finding at the
controller it changed), refused by the build's own checks (the code), equivalent (no bug:
another rule handles the ERROR, the subordinate cannot end the command with ERROR or has
always answered where the rule is tried, its HALT sets no actuator, the HALT it sends stops
nothing), masked (the unchanged system already has that finding there) or missed. Each
system in a second or two (the model alone, no replay)."""

from __future__ import annotations

from pathlib import Path

import pytest
import test_prove_catalogue as catalogue
import test_prove_small as small

from rcsgen.tools.prove_seeds import trial

EXPECTED = Path(__file__).parent / "cases" / "prove_small"
# GO stops sub once it is done (HALT on its DONE), then waits for that echo: reading the
# first DONE as "not ERROR" only stops sub early, which is safe
STOPS = """\
  GO:
    states:
      S0:
        - do: [send: sub.MOVE]
          next: S1
      S1:
        - when: sub.status == DONE
          do: [send: sub.HALT]
          next: S2
        - when: sub.status == ERROR
          do: [report: ERROR]
      S2:
        - when: sub.status == DONE
          do: [report: DONE]
        - when: sub.status == ERROR
          do: [report: ERROR]
"""
# name -> (its directory's name, {file stem: text})
SYSTEMS = (
    {
        variant: ("tank", dict(zip(("system", "sup", "tank"), files[:3], strict=True)))
        for variant, files in small.variants().items()
        if variant != "errors_reported"  # its verdicts are retries' and two_processes' again
    }
    | {
        case: ("tiny", dict(zip(("system", "sub", "top"), catalogue.CASES[case], strict=True)))
        for case in ("stale_done",)
    }
    | {
        "stops": (
            "tiny",
            {
                "system": catalogue.TINY_SYSTEM,
                "sub": catalogue.TINY_SUB,
                "top": catalogue.TOP + STOPS,
            },
        )
    }
)


def verdicts(tmp_path: Path, name: str) -> str:
    folder, files = SYSTEMS[name]
    directory = tmp_path / folder
    directory.mkdir()
    for stem, text in files.items():
        (directory / f"{stem}.yaml").write_text(text)
    (tmp_path / "work").mkdir()
    return "".join(
        f"{o.seed.kind} | {o.seed.where} | {o.verdict}" + (f" | {o.why}" if o.why else "") + "\n"
        for o in trial(directory, tmp_path / "work")
    )


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_each_planted_bug_with_its_verdict_and_why(tmp_path: Path, name: str) -> None:
    assert verdicts(tmp_path, name) == (EXPECTED / f"{name}.seeds.txt").read_text()
