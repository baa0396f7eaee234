"""The size figures the case-study pages quote are the specs' own: each hierarchy table's
"spec lines" column, and sentences like "`system.yaml` is 120 lines", counted again from
the files (issue 26: the submarine's and the inspection workstation's had gone stale)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = {
    "miner": "miner.md",
    "submarine": "submarine.md",
    "inspection": "inspection.md",
    "platoon": "platoon.md",
}
# "`system.yaml` is 120 lines", "(`vehicle/template.yaml`, 55 lines)"; not a count of
# some lines of a file ("39 lines of YAML then", "15 lines with its comment")
SENTENCE = re.compile(r"`([\w/]+\.yaml)`(?: is| \(|, )\s*(\d+) lines(?! of| with)")


def lines(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def spec_of(system: str, row: str, module: str) -> Path:
    """The file a hierarchy row's module is written in: its own, a file the row names
    (`vehicle/veh.yaml`), or an instance's template file (`alpha_loco`: vehicle/loco.yaml)."""
    root = ROOT / "specs" / system
    named = [root / m for m in re.findall(r"`([\w/]+\.yaml)`", row)]
    candidates = [root / f"{module}.yaml", *named]
    if "_" in module:
        candidates += sorted(root.glob(f"*/{module.split('_', 1)[1]}.yaml"))
    found = [c for c in candidates if c.is_file()]
    assert found, f"docs/{PAGES[system]}: no spec file for `{module}`"
    return found[0]


def quoted(system: str) -> list[tuple[str, Path, int]]:
    """(what, file, lines quoted) for every size the page quotes."""
    text = (ROOT / "docs" / PAGES[system]).read_text(encoding="utf-8")
    sizes = []
    table = False
    for line in text.splitlines():
        if line.startswith("|") and line.rstrip().endswith("spec lines |"):
            table = "module" in line
            continue
        if table and line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if set(cells[0]) <= {"-"}:
                continue
            module = re.findall(r"`(\w+)`", cells[0])[0]
            sizes.append((f"`{module}`'s row", spec_of(system, line, module), int(cells[-1])))
            continue
        table = False
        for name, count in SENTENCE.findall(line):
            sizes.append((f"`{name}`", ROOT / "specs" / system / name, int(count)))
    return sizes


@pytest.mark.parametrize("system", sorted(PAGES))
def test_the_sizes_a_case_study_quotes_are_the_files(system: str) -> None:
    sizes = quoted(system)
    assert len(sizes) >= 5, f"docs/{PAGES[system]} quotes no spec sizes any more"
    stale = [
        f"{what}: says {said}, {path.relative_to(ROOT)} has {lines(path)}"
        for what, path, said in sizes
        if lines(path) != said
    ]
    assert not stale, f"docs/{PAGES[system]} is stale:\n" + "\n".join(stale)
