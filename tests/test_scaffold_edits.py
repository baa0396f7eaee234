"""`rcsgen new controller`'s text edits (rcsgen/tools/scaffold.py), in the unit tier: a
module put into a process's list, flow (`[a, b]`) or block (`- a`), after its supervisor's
subtree or at the end; a subordinate added to a supervisor's list or as a new list right
after its title; the process a supervisor runs in. Each edit leaves every other byte of the
file as it was. test_new runs whole `rcsgen new` commands (each validated, slower)."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.compiler.front_end import loader
from rcsgen.tools import scaffold


def items(text: str, *path: str) -> object:
    data = loader.load_text(text, "system.yaml")
    for key in path:
        data = data[key]
    return data


FLOW = "processes:\n  p: {modules: [sup, arm, exe]}  # kept\n"
BLOCK = "processes:\n  p:\n    modules:\n      - sup\n      - arm\n    doc: kept\n"


@pytest.mark.parametrize(
    ("text", "after", "want"),
    [
        (FLOW, None, "processes:\n  p: {modules: [sup, arm, exe, new]}  # kept\n"),
        (FLOW, "sup", "processes:\n  p: {modules: [sup, new, arm, exe]}  # kept\n"),
        (FLOW, "arm", "processes:\n  p: {modules: [sup, arm, new, exe]}  # kept\n"),
        (FLOW, "exe", "processes:\n  p: {modules: [sup, arm, exe, new]}  # kept\n"),
        (
            BLOCK,
            None,
            "processes:\n  p:\n    modules:\n      - sup\n      - arm\n      - new\n"
            "    doc: kept\n",
        ),
        (
            BLOCK,
            "sup",
            "processes:\n  p:\n    modules:\n      - sup\n      - new\n      - arm\n"
            "    doc: kept\n",
        ),
    ],
)
def test_a_module_goes_into_a_process_list_where_it_runs(text, after, want) -> None:
    modules = items(text, "processes", "p", "modules")
    assert scaffold._insert_module(text, modules, "new", after) == want


def test_an_empty_list_is_refused() -> None:
    text = "processes:\n  p: {modules: []}\n"
    with pytest.raises(scaffold.ScaffoldError, match="an empty list cannot be extended here"):
        scaffold._insert_module(text, items(text, "processes", "p", "modules"), "new", None)


def test_a_subordinate_joins_the_list_or_starts_one_right_after_the_title() -> None:
    listed = "controller: sup\ntitle: Top\nsubordinates: [arm]\nstates: [S0]\n"
    assert scaffold._add_subordinate(listed, items(listed), "new") == (
        "controller: sup\ntitle: Top\nsubordinates: [arm, new]\nstates: [S0]\n"
    )
    bare = "controller: sup\ntitle: Top\n\n# the states\nstates: [S0]\n"
    assert scaffold._add_subordinate(bare, items(bare), "new") == (
        "controller: sup\ntitle: Top\nsubordinates: [new]\n\n# the states\nstates: [S0]\n"
    )
    last = "controller: sup\ntitle: Top\n"
    assert scaffold._add_subordinate(last, items(last), "new") == (
        "controller: sup\ntitle: Top\nsubordinates: [new]\n"
    )


def test_a_new_subordinate_runs_after_its_supervisors_whole_subtree(tmp_path: Path) -> None:
    (tmp_path / "sup.yaml").write_text("controller: sup\nsubordinates: [a, b]\n")
    (tmp_path / "a.yaml").write_text("controller: a\nsubordinates: [a1]\n")
    (tmp_path / "a1.yaml").write_text("controller: a1\nsubordinates: [a]\n")  # a cycle: once
    (tmp_path / "b.yaml").write_text("controller: b\n")
    modules = ["sup", "a", "x", "a1", "b", "y"]
    assert scaffold._last_of_subtree(tmp_path, modules, "sup") == "b"
    assert scaffold._last_of_subtree(tmp_path, modules, "a") == "a1"
    assert scaffold._last_of_subtree(tmp_path, modules, "x") == "x"  # no file: itself
    assert scaffold._last_of_subtree(tmp_path, modules, "zz") is None
    assert scaffold._last_of_subtree(tmp_path, modules, None) is None
    processes = {"p": {"modules": ["sup"]}, "q": {"modules": ["a", "b"]}, "r": {}}
    assert scaffold._process_of(processes, "b") == "q"
    assert scaffold._process_of(processes, "sup") == "p"
    assert scaffold._process_of(processes, "zz") is None
