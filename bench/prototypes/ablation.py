"""What each proposed template change buys: the generated co, changed one step at a time.

Each step is a text edit of the generated co.py (as a template change would make it),
applied on top of the previous ones; a step whose key starts with R undoes an adopted
change instead (applied to the generated code alone), to show what that change buys.
Every variant must leave the generated controller's trace (checked over the first 20,000
cycles of the closed loop); then all variants are timed on the same recorded inputs,
interleaved, as in bench_co.py. An edit whose text is no longer in the generated code (the
template changed) is reported as not applicable. The hand-written baseline and the minimal
floor run in the same rounds, for the ratios. The co measured here is built with its
subordinates in another process (bench_co.build_package's cross_process): it checks the
sequence words of what they write, which the hand-written versions (all in one process) do
not, so its ratios to them are conservative.

Proposals adopted in the templates are no longer listed as proposals: one read for all
inputs, one write for adjacent world fields, comparisons instead of max()/min() (148c872);
run_cycle holding the four steps itself (44fa027), now their one copy; the seqlock read as
one look with the test inline and the retries out of line (R1 undoes it); world outputs
looked at only in a cycle in which a rule fired (R2 undoes it); predicates printed inline
in the guards that call them (R3 undoes it); sequence words stored and read again through
the block's 8-byte word view (rcs.contract.words) instead of SEQ.pack_into/unpack_from (R4
undoes it); no table method called while the module is idle in NOP (R5 undoes it); the
performance buffer kept in the module and published by its process every 0.1 s, at once
on the longest cycle yet (R6 writes it whole every cycle instead). G steps drop a
guarantee the hand-written versions do not give, to show what it costs: G1 the second read
of the command's sequence word (co's command comes from an operator in another process), G2
the status written again in the cycle after a rule fired (so that its `rule` shows only the
cycle's rule).
`--same-process` builds co with its subordinates in its process, as bench_co.py times it.

    python bench/prototypes/ablation.py [--cycles N] [--rounds R] [--json PATH] [--same-process]
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bench_co  # noqa: E402
from common import summary, write_json  # noqa: E402

PEERS = ["handwritten", "minimal"]  # timed in the same rounds, for the ratios

# (key, what the template would do, [(old text, new text), ...] or a function of the source)
# Keys starting with R undo an adopted change, to show what it buys; G drops a guarantee
# the hand-written versions do not give, to show what it costs; both apply to the
# generated code alone, and the proposals (P) go on from the generated code.
STEPS = [
    ("R1", "the seqlock read as a loop: for/range, a tuple of the words, for/else", "loop"),
    ("R2", "world outputs compared with the block every cycle, a rule fired or not", "compare"),
    (
        "R4",
        "sequence words stored with SEQ.pack_into and read again with SEQ.unpack_from",
        "packed",
    ),
    ("R5", "the command's table method called in NOP too (idle)", "idle"),
    (
        "R6",
        "the performance buffer written whole every cycle, not published by the process",
        "every",
    ),
    (
        "G1",
        "the command's sequence word not read again (a guarantee dropped: what it costs)",
        "unchecked",
    ),
    (
        "G2",
        "the status not written again the cycle after a rule fired (a guarantee dropped)",
        "norule",
    ),
    (
        "R3",
        "predicates called as methods from the guards that use them",
        [
            ("(self.world_loose_coal > LOOSE_COAL_LIMIT)", "self.too_much_loose_coal()"),
            (
                "elif self.world_loose_coal > LOOSE_COAL_LIMIT:",
                "elif self.too_much_loose_coal():",
            ),
        ],
    ),
]
FAST_READ = re.compile(
    r"        values = INPUTS.unpack_from\(buf, INPUTS_AT\)\n"
    r"        if (?P<torn>(?:.|\n)*?):\n"
    r"            self.read_inputs\(\).*\n"
    r"        else:\n"
    r"(?P<assign>(?:            .*\n)+?            \) = values\n)"
)
WORLD_GATE = (
    "        # a rule fired (it may have set world outputs), or a field is forced or latched safe\n"
    "        if self.rule or buf[OVERRIDDEN_AT]:\n"
)


def loop(source: str) -> str | None:
    """pre_process's read as the template wrote it before: every try in a for loop, the
    sequence words gathered in a tuple, the stale count in the loop's else."""
    found = FAST_READ.search(source)
    if found is None or "words[" not in found["torn"]:
        return None
    torn = found["torn"]
    indices = re.findall(r"values\[(\d+)\]", torn[: torn.index("words[")])
    indices = list(dict.fromkeys(indices))  # each word once, in order
    again = re.findall(r"words\[(\d+)\]", torn)  # their indices in the block's words
    words = [f"seqs[{n}]" for n in range(len(indices))]
    assign = "".join("    " + line + "\n" for line in found["assign"].splitlines())
    replaced = (
        "        for _ in range(READ_TRIES):\n"
        "            values = INPUTS.unpack_from(buf, INPUTS_AT)\n"
        f"            seqs = ({''.join(f'values[{i}], ' for i in indices)})\n"
        f"            if not ({' | '.join(words)}) & 1 and {' and '.join(words)}"
        f" and ({''.join(f'words[{w}], ' for w in again)}) == seqs:\n"
        + assign
        + "                break\n"
        "        else:  # another process kept writing: keep the inputs of the last whole read\n"
        "            self.stale_reads += 1\n"
    )
    return source[: found.start()] + replaced + source[found.end() :]


def compare(source: str) -> str | None:
    """The world outputs looked at every cycle: the gate removed, its block dedented."""
    start = source.find(WORLD_GATE)
    if start < 0:
        return None
    end = source.index("        # Its execution time:", start)
    block = source[start + len(WORLD_GATE) : end]
    return source[:start] + "".join(line[4:] + "\n" for line in block.splitlines()) + source[end:]


UNCHECKED = re.compile(
    r"        if values\[0\] & 1 or not values\[0\] or words\[\d+\] != values\[0\]:\n"
)


def unchecked(source: str) -> str | None:
    """The fast path's test without the second read of the sequence word (one input
    buffer written by another process: the command's): only odd/zero is looked at."""
    found = UNCHECKED.search(source)
    if found is None:
        return None
    return (
        source[: found.start()]
        + "        if values[0] & 1 or not values[0]:\n"
        + source[found.end() :]
    )


WORD_STORE = re.compile(r"words\[(\w+)_WORD\] = ")
WORD_READ = re.compile(r"words\[(\d+)\]")


PERF_TAIL = re.compile(r"        # Its execution time: (?:.|\n)*?        return end\n")
PERF_EVERY_CYCLE = """\
        end = perf_counter_ns()
        self.last_cycle_ns = end - cycle_start
        self.cycles += 1
        self.publish()
        return end
"""


def every_cycle(source: str) -> str | None:
    """The performance buffer written whole at the end of every cycle (its `publish`, the
    seqlocked pack), as before a process published it every 0.1 s."""
    found = PERF_TAIL.search(source)
    if found is None:
        return None
    return source[: found.start()] + PERF_EVERY_CYCLE + source[found.end() :]


def packed(source: str) -> str | None:
    """The sequence words as the template wrote them before the word view: each store a
    `SEQ.pack_into(buf, <buffer>_AT, word)`, each second look a `SEQ.unpack_from`."""
    if not WORD_STORE.search(source):
        return None
    lines = []
    for line in source.splitlines(keepends=True):
        store = WORD_STORE.search(line)
        if store:
            head, _, rest = line.partition(store[0])
            value, hash_, comment = rest.rstrip("\n").partition("  #")
            line = f"{head}SEQ.pack_into(buf, {store[1]}_AT, {value}){hash_ and '  #'}{comment}\n"
        line = WORD_READ.sub(lambda m: f"SEQ.unpack_from(buf, {int(m[1]) * 8})[0]", line)
        lines.append(line)
    return "from miner.rcs.contract import SEQ\n" + "".join(lines)


IDLE = re.compile(
    r"            if self\.state != NOP:  # idle.*\n(?P<chain>(?:                .*\n)+)"
)


def idle(source: str) -> str | None:
    """The table dispatched whatever the state: the NOP test removed, its block dedented."""
    found = IDLE.search(source)
    if found is None:
        return None
    chain = "".join(line[4:] + "\n" for line in found["chain"].splitlines())
    return source[: found.start()] + chain + source[found.end() :]


def norule(source: str) -> str | None:
    """The rule that fired last cycle is forgotten without writing the status again: the
    status keeps showing it until the next write (what recording the rule costs is that
    write in the cycle after a rule fired)."""
    clear = (
        "        if self.rule:  # the rule that fired last cycle is not news any more\n"
        "            self.rule = NO_RULE\n"
        "            self.status_dirty = True\n"
    )
    if clear not in source:
        return None
    return source.replace(clear, "        self.rule = NO_RULE\n")


def variants(generated: str) -> list[tuple[str, str, str | None]]:
    """(key, description, source or None if the edit no longer applies), cumulative."""
    source = generated.replace("from .layout import", "from miner.layout import")
    source = source.replace("from .rcs.", "from miner.rcs.")
    out = [("generated", "as generated today", source)]
    for key, description, edits in STEPS:
        changed: str | None = source
        if isinstance(edits, str):
            edit = {"loop": loop, "compare": compare, "unchecked": unchecked, "norule": norule}
            edit |= {"packed": packed, "idle": idle, "every": every_cycle}
            changed = edit[edits](source)
        else:
            for old, new in edits:
                changed = changed.replace(old, new) if changed and old in changed else None
        out.append((key, description, changed))
        if key.startswith("P"):
            source = changed or source
    return out


def load(name: str, source: str, directory: Path):
    path = directory / f"{name}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(f"ablation_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycles", type=int, default=bench_co.CYCLES)
    parser.add_argument("--rounds", type=int, default=bench_co.ROUNDS)
    parser.add_argument("--json", default=None)
    parser.add_argument(
        "--same-process",
        action="store_true",
        help="co with its subordinates in its process (as bench_co.py times it): only its "
        "command is read under the seqlock",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-ablation-") as scratch:
        # co alone in its process: its subordinates' status and the world fields they
        # write come from another process, read under the seqlock (the full guarantee)
        cross = not args.same_process
        generated = bench_co.build_package(Path(scratch), cross_process=cross).read_text()
        steps = variants(generated)
        makers = {}
        for key, _, source in steps:
            if source is not None:
                controller = load(key, source, Path(scratch)).CoController
                makers[key] = lambda buf, controller=controller: controller(buf).run_cycle
        versions = [
            bench_co.Version(key, key, "", make, args.cycles) for key, make in makers.items()
        ]
        makers |= {v.key: v.make for v in bench_co.versions(args.cycles, 0) if v.key in PEERS}
        reference, frames, _ = bench_co.closed_loop(versions[0], args.cycles, record=True)
        check = min(args.cycles, 20_000)
        for version in versions[1:]:
            trace, _, _ = bench_co.closed_loop(version, check)
            if trace != reference[:check]:
                raise SystemExit(
                    f"{version.key} changed the trace: "
                    f"{bench_co.first_difference(reference, trace)}"
                )
        timed = [bench_co.Version(key, key, "", make, args.cycles) for key, make in makers.items()]
        rounds, _ = bench_co.interleaved(frames, timed, args.rounds)
    changes = {key: (description, source is not None) for key, description, source in steps}
    changes |= {key: (f"({key}, for the ratios)", True) for key in PEERS}
    write_json(
        args.json,
        {
            "versions": [
                {
                    "key": key,
                    "change": description,
                    "applied": applied,
                    "ns_per_cycle": summary(rounds[key]) if applied else None,
                    "rounds_ns": rounds.get(key, []),
                }
                for key, (description, applied) in changes.items()
            ]
        },
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
