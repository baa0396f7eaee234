"""Synthetic systems for the benchmarks: n controllers in a tree of fan-out 4, or a chain.

Controller i supervises 4i+1 .. 4i+4 (those below n); with fan-out 1 the system is a chain,
c0000 -> c0001 -> ... Every controller has three or four commands of three to five states
each, and every leaf owns a world field (a sensor) that its supervisor reads in a guard.
Modules are split over processes in tree (breadth-first) order, so a supervisor runs
before its subordinates: processes of at most 250 (the scaling benchmark), or a given
number of processes of equal share (the lockstep benchmark: a chain over N processes).

    python bench/synthetic.py N DIR [PROCESSES [FAN_OUT]]   # write the system `synth` into DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

FAN_OUT = 4
PER_PROCESS = 250


def name(i: int) -> str:
    return f"c{i:04d}"


def children(i: int, n: int, fan_out: int = FAN_OUT) -> list[int]:
    return [c for c in range(fan_out * i + 1, fan_out * i + fan_out + 1) if c < n]


def all_done(subs: list[str]) -> str:
    return " and ".join(f"{s}.status == DONE" for s in subs)


def supervisor(i: int, n: int, fan_out: int = FAN_OUT) -> str:
    subs = [name(c) for c in children(i, n, fan_out)]
    sensors = [f"world.level_{s}" for s in subs if not children(int(s[1:]), n, fan_out)]
    sends = "\n".join(f"            - send: {s}.RUN" for s in subs)
    moves = "\n".join(
        f"            - send: {s}.MOVE\n              with: {{speed: speed}}" for s in subs
    )
    halts = "\n".join(f"            - send: {s}.HALT" for s in subs)
    high = " or ".join(f"{w} > LIMIT" for w in sensors) or "runs > 1000"
    reads = (
        f"\nworld:\n  reads: [{', '.join(w.split('.')[1] for w in sensors)}]\n" if sensors else ""
    )
    return f"""controller: {name(i)}
title: Synthetic supervisor {i}
subordinates: [{", ".join(subs)}]
{reads}
constants:
  LIMIT: 5.0

locals:
  runs:
    type: int
    initial: 0

commands:
  RUN:
    doc: Run every subordinate, then count the run.
    states:
      S0:
        - do:
{sends}
          next: S1
      S1:
        - when: {all_done(subs)}
          do:
            - set: {{runs: runs + 1}}
          next: S2
      S2:
        - do:
            - report: DONE
  MOVE:
    params:
      speed:
        type: float
    states:
      S0:
        - do:
{moves}
          next: S1
      S1:
        - when: {all_done(subs)}
          next: S2
      S2:
        - when: {high}
          do:
{halts}
          next: S3
        - when: not ({high})
          do:
            - report: DONE
      S3:
        - when: {all_done(subs)}
          do:
            - report: DONE
  PAUSE:
    states:
      S0:
        - do:
{halts}
          next: S1
      S1:
        - when: {all_done(subs)}
          next: S2
      S2:
        - do:
            - report: DONE
"""


def leaf(i: int) -> str:
    return f"""controller: {name(i)}
title: Synthetic leaf {i}

world:
  writes: [level_{name(i)}]

constants:
  TICKS: {3 + i % 5}

locals:
  ticks:
    type: int
    initial: 0

commands:
  RUN:
    states:
      S0:
        - do:
            - set: {{ticks: 0}}
          next: S1
      S1:
        - when: ticks < TICKS
          do:
            - set: {{ticks: ticks + 1}}
        - when: ticks >= TICKS
          next: S2
      S2:
        - do:
            - set: {{world.level_{name(i)}: world.level_{name(i)} + 1.0}}
            - report: DONE
  MOVE:
    params:
      speed:
        type: float
    states:
      S0:
        - do:
            - set: {{ticks: 0}}
          next: S1
      S1:
        - when: ticks < TICKS
          do:
            - set: {{ticks: ticks + 1}}
        - when: ticks >= TICKS
          do:
            - set: {{world.level_{name(i)}: speed}}
          next: S2
      S2:
        - do:
            - report: DONE
  PAUSE:
    states:
      S0:
        - next: S1
      S1:
        - next: S2
      S2:
        - do:
            - report: DONE
"""


def system(n: int, processes: int | None = None, fan_out: int = FAN_OUT) -> str:
    leaves = [name(i) for i in range(n) if not children(i, n, fan_out)]
    world = "".join(
        f"  level_{leaf_name}:\n    type: float\n    initial: 0.0\n" for leaf_name in leaves
    )
    modules = [name(i) for i in range(n)]
    share = PER_PROCESS if processes is None else -(-n // processes)  # ceil(n / processes)
    processes = "".join(
        f"  p{k}:\n    modules: [{', '.join(modules[start : start + share])}]\n"
        for k, start in enumerate(range(0, n, share))
    )
    return f"""system: synth
title: Synthetic system of {n} controllers
cycle_period: 0.01

world:
{world}
processes:
{processes}"""


def write(n: int, directory: Path, processes: int | None = None, fan_out: int = FAN_OUT) -> Path:
    """Write the system of `n` controllers into `directory`/synth; returns that path.
    `processes`: split the modules over that many processes (else at most 250 a process);
    `fan_out` 1 makes a chain."""
    root = directory / "synth"
    root.mkdir(parents=True, exist_ok=True)
    (root / "system.yaml").write_text(system(n, processes, fan_out))
    for i in range(n):
        text = supervisor(i, n, fan_out) if children(i, n, fan_out) else leaf(i)
        (root / f"{name(i)}.yaml").write_text(text)
    return root


if __name__ == "__main__":
    args = [int(a) for a in sys.argv[3:]]
    write(int(sys.argv[1]), Path(sys.argv[2]), *args)
