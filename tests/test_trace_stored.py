"""How a trace is stored (rcsgen/tools/traces/stored.py): a full line every KEYFRAME cycles
and the first, then change lines that say only what changed (`changed`, `removed`).
Expanding what was condensed gives back every full line byte for byte, and the reader sees
the same trace either way; a change line is the difference of two full lines and, applied
to the first, makes the second."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rcsgen.tools.traces import read as traces
from rcsgen.tools.traces import stored

GOLDEN = Path(__file__).resolve().parent / "golden"
# small ones of three systems (operators' channels, world fields coming and going, reasons)
SMALL = ["platoon/lost_vehicle.jsonl", "inspection/guardian_lot.jsonl", "sump_shear_cusp.jsonl"]


@pytest.mark.parametrize("name", SMALL)
def test_a_golden_trace_condensed_and_expanded_is_itself(name: str) -> None:
    full = traces.full_lines(GOLDEN / name)
    kept = list(stored.condensed(full))
    assert len(kept) == len(full) and len(full) > 3
    for line, text in zip(full, kept, strict=True):
        record = json.loads(line)
        if "modules" not in record:  # the timing record or an interruption: as it is
            assert text == line
        elif record["cycle"] % stored.KEYFRAME == 0 or line is full[0]:
            assert text == line  # a keyframe: the full line
        else:
            assert stored.is_delta(json.loads(text)) and len(text) < len(line)
    assert list(stored.expanded(kept)) == full
    as_full, as_kept = traces.parse_lines(full, "t"), traces.parse_lines(kept, "t")
    assert (as_kept.cycles, as_kept.modules, as_kept.columns, as_kept.world) == (
        as_full.cycles,
        as_full.modules,
        as_full.columns,
        as_full.world,
    )


def test_a_keyframe_every_so_many_cycles_and_the_first() -> None:
    lines = [f'{{"cycle":{c},"modules":{{"m":{{"x":{c % 2}}}}}}}' for c in range(1, 8)]
    kept = list(stored.condensed(lines, keyframe=3))
    full_at = [json.loads(t)["cycle"] for t in kept if "modules" in json.loads(t)]
    assert full_at == [1, 3, 6]
    assert kept[1] == '{"cycle":2,"changed":{"modules":{"m":{"x":0}}}}'
    assert list(stored.expanded(kept)) == lines


def test_a_change_line_says_what_changed_and_what_went() -> None:
    last = {"cycle": 4, "modules": {"co": {"rule": "S1/2", "reason": "NONE"}}, "world": {"a": 1}}
    now = {"cycle": 5, "modules": {"co": {"rule": None}}, "world": {"a": 1.0, "b": 2}}
    assert stored.delta_line(last, now) == (
        '{"cycle":5,"changed":{"modules":{"co":{"rule":null}},"world":{"a":1.0,"b":2}},'
        '"removed":[["modules","co","reason"]]}'
    )
    # nothing changed but the cycle: the cycle alone
    assert stored.delta_line(now, now | {"cycle": 6}) == '{"cycle":6}'


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        (['{"cycle": 2, "changed": {}}'], "no `modules` object, nor a full line before it"),
        (['{"cycle": 1, "modules": {}}', '{"cycle": 2, "changed": []}'], "`changed` is not an"),
        (['{"cycle": 1, "modules": {}}', '{"cycle": 2, "removed": {}}'], "`removed` not a list"),
        (['{"cycle": 1, "modules": {}}', '{"cycle": 2, "removed": [[]]}'], "`removed` holds []"),
        (['{"cycle": 1, "modules": {}}', '{"cycle": 2, "removed": [[1]]}'], "`removed` holds [1]"),
        (
            [
                '{"cycle": 1, "modules": {"m": 3}}',
                '{"cycle": 2, "removed": [["modules", "m", "x"]]}',
            ],
            "`removed` names modules.m.x, which is not there",
        ),
    ],
)
def test_a_change_line_that_cannot_be_applied_says_why(lines: list[str], message: str) -> None:
    with pytest.raises(ValueError) as caught:
        list(stored.expanded(lines))
    assert message in str(caught.value)


def test_lines_that_are_not_records_of_modules_pass_as_they_are() -> None:
    timing = '{"cycle": 3, "timing": {"cycles": 2}}'
    lines = ['{"cycle": 1, "modules": {"m": {"x": 1}}}', '{"cycle": 2, "modules": {"m": {"x": 2}}}']
    assert list(stored.condensed([*lines, timing]))[-1] == timing
    assert stored.is_delta({"cycle": 2}) and stored.is_delta({"cycle": 2, "removed": []})
    assert not stored.is_delta({"cycle": 2, "modules": {}})
    assert not stored.is_delta({"cycle": 2, "timing": {}})
    # what is no object (a blank line, a list) is left as it is, for the reader to refuse
    full = ['{"cycle": 1, "modules": {"m": {"x": 1}}}', "", "  ", "[1, 2]", '{"cycle": 2}']
    assert list(stored.expanded(full)) == [*full[:4], '{"cycle":2,"modules":{"m":{"x":1}}}']


scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 3),
    st.sampled_from([0.0, 1.0, 2.5]),
    st.text("ab", max_size=2),
)
trees = st.recursive(
    scalars, lambda inner: st.dictionaries(st.sampled_from("pqrs"), inner, max_size=3), max_leaves=8
)
records = st.dictionaries(st.sampled_from("abcd"), trees, max_size=4)


@settings(max_examples=100, deadline=None)
@given(records, records)
def test_the_difference_applied_to_the_old_makes_the_new(
    old: dict[str, Any], new: dict[str, Any]
) -> None:
    changed, removed = stored.difference(old, new)
    made = stored.applied(old, changed)
    for path in removed:
        made = stored.without(made, path)
    assert stored.dumps(made) == stored.dumps(new)  # the same values, of the same types
    assert stored.difference(new, new) == ({}, [])
    if old == new and stored.dumps(old) == stored.dumps(new):
        assert changed == {} and removed == []


def test_applying_and_removing_leave_the_old_record_untouched() -> None:
    old = {"m": {"x": 1, "y": {"z": 2}}, "w": 3}
    kept = json.dumps(old)
    new = stored.applied(old, {"m": {"y": {"z": 5}}, "v": 1})
    assert new == {"m": {"x": 1, "y": {"z": 5}}, "w": 3, "v": 1}
    assert stored.without(new, ["m", "y", "z"]) == {"m": {"x": 1, "y": {}}, "w": 3, "v": 1}
    assert json.dumps(old) == kept
    with pytest.raises(KeyError):
        stored.without(old, ["w", "q"])  # not a mapping to remove from
    with pytest.raises(KeyError):
        stored.without(old, ["m", "q"])


def test_full_lines_whose_modules_are_the_last_ones_share_them_decoded_once() -> None:
    """A long run's full lines mostly repeat the modules of the line before (only the world
    moved): the reader decodes such a line's modules once and shares the object, so a
    trace held in memory holds one copy of them; other modules, or a line of another
    shape, are decoded as written."""
    modules = {"sup": {"state": "S1", "status": "EXECUTING"}}

    def full(cycle: int, world: float, mods: dict[str, Any] = modules) -> str:
        record = {"cycle": cycle, "modules": mods, "world": {"x": world}}
        return json.dumps(record, sort_keys=True, separators=(",", ":"))

    other = {"sup": {"state": "S2", "status": "DONE"}}
    lines = [full(1, 0.5), full(2, 1.5), full(3, 2.5), full(4, 3.5, other), full(5, 4.5, other)]
    records = [record for _, record in traces._records(lines, "t.jsonl")]
    assert [r["world"]["x"] for r in records] == [0.5, 1.5, 2.5, 3.5, 4.5]
    assert [r["modules"] for r in records] == [modules] * 3 + [other] * 2
    assert records[1]["modules"] is records[0]["modules"] is records[2]["modules"]
    assert records[4]["modules"] is records[3]["modules"] is not records[2]["modules"]
    spaced = json.dumps({"cycle": 6, "modules": other, "world": {"x": 5.5}})  # not rcsgen's
    [(_, record)] = traces._records([spaced], "t.jsonl")
    assert record == {"cycle": 6, "modules": other, "world": {"x": 5.5}}
