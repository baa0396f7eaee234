"""`make bench`: run every part of the benchmark and write bench/RESULTS.md.

Each part runs in its own interpreter (so one part's imports, garbage and sys.path do
not touch another's) and hands back JSON; this script turns it into the report. It exits
non-zero if the versions of co do not all leave the same trace, or a part fails. The
targets are reported as PASS/FAIL lines; they do not change the exit status.

    python bench/run.py [--quick] [--out bench/RESULTS.md]

`--quick` runs every part briefly (a smoke test of the benchmark, not a measurement).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import BENCH, machine, ns, ratio, verdict

PARTS = {
    "co": ("bench_co.py", [], ["--cycles", "20000", "--slow-cycles", "2000", "--rounds", "2"]),
    "ablation": ("prototypes/ablation.py", [], ["--cycles", "20000", "--rounds", "2"]),
    "system": ("bench_system.py", [], ["--cycles", "2000", "--rounds", "2"]),
    "scaling": ("bench_scaling.py", [], ["--sizes", "10,100,200", "--repeat", "1"]),
    "startup": ("bench_startup.py", [], ["--rounds", "3"]),
}

# Targets of issue 5.
BASELINE_MAX = 1.0  # generated / hand-written
FLOOR_MAX = 1.5  # generated / minimal
TRANSITIONS_MIN = 8.0  # transitions / generated
SISMIC_MIN = 50.0  # sismic / generated
MODULE_MAX_NS = 1500.0  # whole system, ns per module per cycle
BUILD_1000_MAX_S = 10.0
DOUBLING_MAX = 2.1


def run_part(key: str, quick: bool, scratch: Path) -> tuple[dict | list | None, str | None]:
    script, full, short = PARTS[key]
    out = scratch / f"{key}.json"
    command = [sys.executable, str(BENCH / script), *(short if quick else full), "--json", str(out)]
    print(f"== {key}: {' '.join(command[1:])}", file=sys.stderr, flush=True)
    done = subprocess.run(command, cwd=BENCH.parent)
    data = json.loads(out.read_text()) if out.is_file() else None
    problem = None if done.returncode == 0 else f"`{script}` exited with status {done.returncode}"
    return data, problem


# ---------------------------------------------------------------- report sections


def section_machine(
    info: dict, started: datetime.datetime, seconds: float, quick: bool, load: tuple
) -> list[str]:
    peers = ", ".join(f"{name} {version}" for name, version in info["peers"].items())
    tools = ", ".join(f"{name} {version}" for name, version in info["tools"].items())
    lines = [
        "# rcsgen benchmarks",
        "",
        f"Written by `make bench` (bench/run.py) on {started:%Y-%m-%d %H:%M} UTC in "
        f"{seconds / 60:.1f} min. Do not edit: run `make bench` again. How to run it and what "
        "each file is: [README.md](README.md).",
        "",
    ]
    if quick:
        lines += ["**QUICK RUN (`--quick`): a smoke test, too short to be a measurement.**", ""]
    return lines + [
        "| machine | |",
        "|---|---|",
        f"| CPU | {info['cpu']}, {info['cores']} cores |",
        f"| Python | {info['python']} ({info['os']}) |",
        f"| rcsgen | revision {info['revision']}; {tools} |",
        f"| peers | {peers}, installed in bench/.venv |",
        f"| load average | {load[0]:.2f} before, {load[1]:.2f} after (1 min; other work on "
        "the machine widens the min–max) |",
        "",
    ]


def co_versions(co: dict) -> dict[str, dict]:
    return {v["key"]: v for v in co["versions"]}


def round_ratio(co: dict, a: str, b: str) -> float:
    """Median over the rounds of a's cost / b's cost in the same round. Versions take turns
    within a round, so the ratio of one round is steadier than the ratio of two medians."""
    v = co_versions(co)
    return statistics.median(
        x / y for x, y in zip(v[a]["rounds_ns"], v[b]["rounds_ns"], strict=True)
    )


def section_targets(co, system, scaling) -> list[str]:
    lines = ["## Targets", "", "They do not gate CI; each line gives the measured value.", ""]

    def add(ok: bool, text: str) -> None:
        lines.append(f"- **{verdict(ok)}** {text}")

    if co:
        v = co_versions(co)

        def r(a: str, b: str) -> float:
            return round_ratio(co, a, b)

        add(
            r("generated", "handwritten") <= BASELINE_MAX,
            f"generated co ≤ {BASELINE_MAX}× the hand-written baseline: "
            f"{ratio(r('generated', 'handwritten'))} "
            f"({ns(v['generated']['ns_per_cycle']['median'])} per cycle)",
        )
        add(
            r("generated", "minimal") <= FLOOR_MAX,
            f"generated co within {FLOOR_MAX}× the minimal floor: "
            f"{ratio(r('generated', 'minimal'))}",
        )
        for peer, target in (("transitions", TRANSITIONS_MIN), ("sismic", SISMIC_MIN)):
            add(
                r(peer, "generated") >= target,
                f"generated co ≥ {target:.0f}× faster than {peer}: {ratio(r(peer, 'generated'))} "
                f"({peer}: {ns(v[peer]['ns_per_cycle']['median'])} per cycle; the minimal floor "
                f"is {ratio(r(peer, 'minimal'))} faster)",
            )
        add(co["traces_identical"], "every version of co leaves the same trace")
    if system:
        per_module = system["ns_per_module"]["median"]
        hooks, generated = hooks_share(system)
        add(
            per_module <= MODULE_MAX_NS,
            f"whole miner system ≤ {MODULE_MAX_NS / 1000:g} µs per module per cycle: "
            f"{ns(per_module)} ({len(system['modules'])} modules, "
            f"{ns(system['ns_per_cycle']['median'])} per system cycle, of which "
            f"{ns(hooks)} in hand-written hooks; generated code alone {ns(generated)} per module)",
        )
    if scaling:
        sizes = {s["controllers"]: s for s in scaling["sizes"]}
        if 1000 in sizes:
            build, cli = sizes[1000]["build_s"], sizes[1000]["cli_build_s"]
            add(
                build <= BUILD_1000_MAX_S,
                f"1,000-controller build ≤ {BUILD_1000_MAX_S:g} s: {build:.1f} s "
                f"(front end {sizes[1000]['front_s']:.1f} s; the CLI, start-up and "
                f"diagnostics included: {cli:.1f} s)",
            )
        growth = scaling["per_doubling"]["build_s"]["from_100_to_1000"]
        if growth is not None:
            add(
                growth <= DOUBLING_MAX,
                f"build time growth ≤ {DOUBLING_MAX}× per doubling: {growth:.2f}×",
            )
    return [*lines, ""]


def section_co(co: dict, ablation: list | None) -> list[str]:
    v = co_versions(co)
    gen = v["generated"]["ns_per_cycle"]["median"]
    traces = (
        f"**All {len(v)} versions leave identical traces** (per cycle: co's status number, "
        "status and state; each subordinate's command number and command; vg's goal), "
        f"compared cycle by cycle with the generated controller's (seed {co['seed']})."
        if co["traces_identical"]
        else "**THE TRACES DIFFER** (see the table): the benchmark fails."
    )
    lines = [
        "## 1. One controller, seven ways: co's Appendix C table",
        "",
        "co's `SUMP_SHEAR_CUSP`, `INIT` and `HALT` tables, generated from the frozen spec "
        "bench/co_spec/miner with the current templates, against a hand-written QQ1 "
        "controller (the baseline), three state-machine libraries and a minimal one-function "
        "floor. All run on the same block and are driven by the same seeded closed loop "
        "(bench/co_plant.py: subordinates answering after random delays, pop-outs, loose "
        "coal, operator commands, interruptions and dont_run/single-step holds).",
        "",
        traces,
        "",
        "Per-cycle cost: the plant's recorded inputs replayed open loop, less the replay loop "
        f"itself ({ns(co['idle_ns']['median'])} per cycle, timed in every round); median of "
        f"{co['rounds']} rounds, in each of which the versions take turns every 10,000 cycles "
        "(rotating order), so that other work on the machine hits them alike. The ratios are "
        "medians of the ratios within a round.",
        "",
        "| version | code (in bench/) | cycles | ns/cycle (median) | min–max "
        "| × baseline (median of rounds) | × floor | trace |",
        "|---|---|--:|--:|--:|--:|--:|---|",
    ]
    for item in co["versions"]:
        s = item["ns_per_cycle"]
        to_base = round_ratio(co, item["key"], "handwritten")
        to_floor = round_ratio(co, item["key"], "minimal")
        lines.append(
            f"| {item['title']} | {item['module']} | {item['cycles']:,} | {s['median']:,.0f} "
            f"| {s['min']:,.0f}–{s['max']:,.0f} | {ratio(to_base)} | {ratio(to_floor)} "
            f"| {item['trace']} |"
        )
    exercised = ", ".join(f"{k} {v:,}" for k, v in co["exercised"].items())
    lines += ["", f"What the reference run exercised: {exercised}.", ""]
    steps = co.get("steps_ns")
    if steps:
        total = sum(steps.values())
        lines += [
            "### Where the generated co's cycle goes",
            "",
            "Each QQ1 step timed on its own over the same inputs, less the cost of reading "
            f"the clock. Timing each step adds its own overhead (they add up to {ns(total)}, "
            f"the uninstrumented cycle above is {ns(gen)}): read the shares.",
            "",
            "| step | ns per cycle | share |",
            "|---|--:|--:|",
            *(f"| {name} | {value:,.0f} | {value / total:.0%} |" for name, value in steps.items()),
            "",
        ]
    if ablation:
        steps = [
            step for step in ablation["versions"] if step["key"] not in ("handwritten", "minimal")
        ]
        applied = [step for step in steps if step["applied"]]
        lines += [
            "### Proposed template changes, measured (bench/prototypes/ablation.py)",
            "",
            "The generated co.py with one change after another (each on top of the ones "
            "above it), traces checked, timed like the table above in rounds of their own, "
            "with the baseline and the floor for the ratios. bench/prototypes/co_fast.py is "
            "the result written out (the prototype row above).",
            "",
            "| step | change | ns/cycle | × the step before | × baseline | × floor |",
            "|---|---|--:|--:|--:|--:|",
        ]
        for step in steps:
            if not step["applied"]:
                lines.append(
                    f"| {step['key']} | {step['change']} "
                    "| not applicable: the template changed | | | |"
                )
                continue
            before = applied[applied.index(step) - 1] if step is not applied[0] else None
            gain = (
                "" if before is None else ratio(round_ratio(ablation, step["key"], before["key"]))
            )
            lines.append(
                f"| {step['key']} | {step['change']} | {step['ns_per_cycle']['median']:,.0f} "
                f"| {gain} | {ratio(round_ratio(ablation, step['key'], 'handwritten'))} "
                f"| {ratio(round_ratio(ablation, step['key'], 'minimal'))} |"
            )
        lines.append("")
    lines += [
        "### How the libraries were used (semantics adapted)",
        "",
        "- The QQ1 wrapper is the baseline's, unchanged (bench/co_library.py): reading and "
        "writing the block, the command-number handshake, subordinates counting as EXECUTING "
        "until they echo, modes and the performance buffer. The library replaces only the "
        "state tables, so the difference to the baseline is the library's.",
        "- States NOP, S0..S4 are machine states whose values are co's state codes; each "
        "command (INIT, HALT, SUMP_SHEAR_CUSP) is an event fired once per cycle in which the "
        "table runs; its transitions from the current state are the command's rules in table "
        "order; guards are conditions, sends are actions; a rule without `next` is an internal "
        "transition. A new command number fires `new_command` (any state → S0) first, in the "
        "same cycle.",
        "- A cycle in which no rule holds must not be an error: transitions "
        "`ignore_invalid_triggers=True`; python-statemachine `allow_event_without_transition "
        "= True` (the classic `StateMachine` flavour, no SCXML error events); sismic ignores "
        "such events by itself.",
        "- First match wins: transitions and python-statemachine try an event's transitions "
        "in declaration order; sismic rejects two enabled transitions of one state as "
        "non-deterministic, so the four rules of S2 carry priorities 4..1 "
        "(bench/co_statechart.yaml).",
        "- sismic: guards are the table's guards as Python expressions over the wrapper "
        "(`co`); state entry actions write co's state code; a cycle queues the event and runs "
        "one `execute_once()`.",
        "",
    ]
    return lines


def hooks_share(system: dict) -> tuple[float, float]:
    """(ns per system cycle in hand-written hooks, ns per module per cycle of the generated
    code alone), both from the instrumented pass."""
    hooks = sum(system.get("hook_ns", {}).values())
    modules = system["module_ns"]
    return hooks, (sum(modules.values()) - hooks) / len(modules)


def section_system(system: dict) -> list[str]:
    costs = system["module_ns"]
    total = sum(costs.values())
    ordered = sorted(costs.items(), key=lambda item: -item[1])
    hooks, generated = hooks_share(system)
    s, m = system["ns_per_cycle"], system["ns_per_module"]
    lines = [
        "## 2. The whole miner system, one process",
        "",
        f"generated/miner, process `{system['process']}` ({len(system['modules'])} modules), "
        f"running {system['scenario']} over and over (fresh block and controllers each "
        f"time, INIT at start-up, until the stop module is done): {system['cycles_per_round']:,} "
        f"system cycles per round ({system['scenario_runs_per_round']} scenario runs), "
        f"median of {system['rounds']} rounds.",
        "",
        "| | median | min–max |",
        "|---|--:|--:|",
        f"| ns per system cycle | {s['median']:,.0f} | {s['min']:,.0f}–{s['max']:,.0f} |",
        f"| ns per module per cycle | {m['median']:,.0f} | {m['min']:,.0f}–{m['max']:,.0f} |",
        f"| of which hand-written hooks, per system cycle (instrumented) | {hooks:,.0f} | |",
        f"| generated code alone, per module per cycle (instrumented) | {generated:,.0f} | |",
        "",
        f"Per module, from an instrumented pass (clock cost subtracted; they add up to "
        f"{ns(total)}), and the hook functions the modules call:",
        "",
        "| module | ns per cycle | share |",
        "|---|--:|--:|",
        *(f"| {name} | {value:,.0f} | {value / total:.1%} |" for name, value in ordered),
        "",
        "| hook (hand-written) | ns per system cycle | share of the cycle |",
        "|---|--:|--:|",
        *(
            f"| {name} | {value:,.0f} | {value / total:.1%} |"
            for name, value in sorted(system.get("hook_ns", {}).items(), key=lambda i: -i[1])
        ),
        "",
        "Several processes over named shared memory: **not yet measured** (the runtime issue).",
        "",
    ]
    return lines


def section_scaling(scaling: dict) -> list[str]:
    lines = [
        "## 3. Generator scaling",
        "",
        "Synthetic systems (bench/synthetic.py): a tree of fan-out 4; every controller has "
        "three commands of three or four states, every leaf a world field its supervisor "
        "reads; processes of at most 250 modules. *build* is what `rcsgen build` does, run "
        "in a fresh worker interpreter and timed step by step (the run of median build time "
        f"of {scaling['repeat']}); *CLI* is one `rcsgen build` as a user runs it (wall clock, "
        "with interpreter start-up and the printing of the diagnostics).",
        "",
        "| controllers | build | front end (validate) | render (Jinja) | format (ruff) "
        "| write | CLI | peak RSS | output |",
        "|--:|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for s in scaling["sizes"]:
        lines.append(
            f"| {s['controllers']:,} | {s['build_s']:.2f} s | {s['front_s']:.2f} s "
            f"| {s['render_s']:.2f} s | {s['format_s']:.2f} s | {s['write_s']:.2f} s "
            f"| {s['cli_build_s']:.2f} s | {s['rss_peak_kb'] / 1024:.0f} MiB "
            f"| {s['files']} files, {s['lines']:,} lines, {s['warnings']:,} warnings |"
        )
    phases = list(scaling["sizes"][-1]["phases_s"])
    lines += [
        "",
        "The front end by phase (seconds):",
        "",
        "| controllers | " + " | ".join(phases) + " | other |",
        "|--:|" + "--:|" * (len(phases) + 1),
    ]
    for s in scaling["sizes"]:
        other = s["front_s"] - sum(s["phases_s"].values())
        cells = " | ".join(f"{s['phases_s'][p]:.2f}" for p in phases)
        lines.append(f"| {s['controllers']:,} | {cells} | {other:.2f} |")
    lines += [
        "",
        "Growth per doubling of the system: (t(1000) / t(100)) ** (log 2 / log 10), and "
        "2 ** (the log-log slope over every size from 100 up):",
        "",
        "| | from 100 to 1,000 | fit |",
        "|---|--:|--:|",
    ]
    names = {
        "build_s": "build",
        "cli_build_s": "CLI `rcsgen build`",
        "front_s": "front end",
        "render_s": "render",
        "format_s": "format",
        "rss_peak_kb": "peak RSS",
    }
    for key, growth in scaling["per_doubling"].items():
        ten, fit = growth["from_100_to_1000"], growth["fit_100_up"]
        lines.append(
            f"| {names.get(key, key)} | {'' if ten is None else f'{ten:.2f}×'} "
            f"| {'' if fit is None else f'{fit:.2f}×'} |"
        )
    return [*lines, ""]


def section_startup(startup: dict) -> list[str]:
    lines = [
        "## 4. Start-up",
        "",
        f'`python -c "import ..."` in a fresh interpreter, bytecode already compiled; median '
        f"of {startup['rounds']} interleaved rounds less the bare interpreter; `-X importtime` "
        "is Python's own count of the same imports.",
        "",
        "| import | wall | import cost | `-X importtime` |",
        "|---|--:|--:|--:|",
    ]
    for t in startup["targets"]:
        lines.append(
            f"| {t['title']} | {t['wall_ms']:.1f} ms | {t['import_ms']:.1f} ms "
            f"| {t['importtime_ms']:.1f} ms |"
        )
    cumulative = ", ".join(f"`{k}` {v:.1f} ms" for k, v in startup["miner_cumulative_ms"].items())
    heaviest = ", ".join(f"`{k}` {v:.1f} ms" for k, v in startup["miner_heaviest_self_ms"])
    lines += [
        "",
        f"In the generated miner, cumulative: {cumulative}. Heaviest single modules (self "
        f"time): {heaviest}.",
        "",
    ]
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=BENCH / "RESULTS.md")
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated subset")
    args = parser.parse_args()
    started_at = datetime.datetime.now(datetime.UTC)
    started = time.perf_counter()
    load_before = os.getloadavg()[0]
    results, problems = {}, []
    with tempfile.TemporaryDirectory(prefix="rcsgen-bench-") as scratch:
        for key in args.parts.split(","):
            results[key], problem = run_part(key, args.quick, Path(scratch))
            if problem:
                problems.append(problem)
    co, ablation = results.get("co"), results.get("ablation")
    system, scaling, startup = results.get("system"), results.get("scaling"), results.get("startup")
    load = (load_before, os.getloadavg()[0])
    seconds = time.perf_counter() - started
    lines = section_machine(machine(), started_at, seconds, args.quick, load)
    if problems:
        lines += ["## Problems", "", *(f"- {p}" for p in problems), ""]
    lines += section_targets(co, system, scaling)
    if co:
        lines += section_co(co, ablation)
    if system:
        lines += section_system(system)
    if scaling:
        lines += section_scaling(scaling)
    if startup:
        lines += section_startup(startup)
    args.out.write_text("\n".join(lines).rstrip() + "\n")
    print(f"wrote {args.out} in {time.perf_counter() - started:.0f} s", file=sys.stderr)
    return 1 if problems or (co and not co["traces_identical"]) else 0


if __name__ == "__main__":
    sys.exit(main())
