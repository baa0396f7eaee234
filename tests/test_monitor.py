"""The live monitor (rcsgen/tools/monitor.py) driven through textual's test pilot (simulated
keys on a headless terminal) against the duo system running as real OS processes: the tree,
the colours, stop/run/step/simulate/slow keys and the send form act on the running system.
"""

from __future__ import annotations

import asyncio
import importlib
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

pytest.importorskip("textual")

from conftest import until, wait_for  # noqa: E402
from support.running import at_ease  # noqa: E402
from test_ctl import DUO, Running  # noqa: E402
from textual.widgets import DataTable, Input  # noqa: E402

from rcsgen.tools.harness import generate, import_package  # noqa: E402
from rcsgen.tools.monitor import Monitor, tree_order  # noqa: E402


@pytest.fixture(scope="module")
def duo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """The duo at ease (support.running.at_ease): what the screen shows and its keys do is
    checked here, not the duo's detection bounds."""
    import shutil

    scratch, name = generate(at_ease(DUO, tmp_path_factory.mktemp("duo")))
    yield scratch / name
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture(scope="module")
def layout(duo: Path) -> ModuleType:
    return importlib.import_module(f"{import_package(duo, DUO).__name__}.layout")


@pytest.fixture
def running(duo: Path, layout: ModuleType) -> Iterator[Running]:
    system = Running(duo, DUO, layout)
    yield system
    system.stop()


def test_the_tree_puts_each_subordinate_under_its_supervisor() -> None:
    layout = importlib.import_module(
        f"{import_package(Path('generated/miner').resolve(), None).__name__}.layout"
    )
    rows = dict(tree_order(layout))
    assert list(rows)[:4] == ["sec", "sb", "co", "cr"]
    assert rows["sec"] == "" and rows["sb"] == "└─ "
    assert rows["co"] == "   ├─ " and rows["cr"] == "   │  ├─ "
    assert rows["wm"] == "   └─ ", "world modelling, the shift boss's last subordinate"
    assert rows["pp"].endswith("├─ ") and rows["oi"] == ""


def screen_text(app: Monitor) -> str:
    """What the terminal shows, as plain text: the SVG screenshot's text runs, each put at
    its column (x over the width of one character, from the runs' textLength)."""
    import html
    import re

    svg = app.export_screenshot()
    pattern = r'<text[^>]*x="([\d.]+)" y="([\d.]+)" textLength="([\d.]+)"[^>]*>([^<]*)</text>'
    runs = [
        (float(x), float(y), float(length), html.unescape(t).replace("\xa0", " "))
        for x, y, length, t in re.findall(pattern, svg)
    ]
    width = max((length / len(text) for _, _, length, text in runs if text), default=1.0)
    lines: dict[float, str] = {}
    for x, y, _, text in sorted(runs, key=lambda r: (r[1], r[0])):
        lines[y] = lines.get(y, "").ljust(round(x / width)) + text
    return "\n".join(line.rstrip() for _, line in sorted(lines.items()))


def said(app: Monitor) -> str:
    """The monitor's message line."""
    return str(app.query_one("#message").render())


def requests(app: Monitor) -> str:
    """The requests shown under the table."""
    return str(app.query_one("#requests").render())


def form(app: Monitor) -> str:
    """What the send form's empty field says (an answer form shows what it takes)."""
    return str(app.query_one("#send", Input).placeholder)


def slowed(running: Running) -> object:
    """p1's slow-down factor, as the console says."""
    return running.json()["processes"]["p1"]["slow"]  # type: ignore[index]


def test_keys_and_the_send_form_operate_the_running_system(
    running: Running, layout: ModuleType, tmp_path: Path
) -> None:
    async def drive() -> str:
        app = Monitor(layout, running.segment, interval=0.1)
        async with app.run_test(size=(150, 20)) as pilot:
            table = app.query_one("#modules")
            await until(pilot, lambda: table.row_count == 2, "both modules drawn")
            assert app.selected() == "top"
            # the send form: MOVE to the root, numbered after the command it has (INIT #1,
            # or a HALT had a watchdog tripped on a busy host)
            given = running.module("top")["command_num"]
            assert isinstance(given, int)
            await pilot.press("c")
            await pilot.press(*"MOVE", "enter")
            await until(pilot, lambda: "sent top.MOVE #" in said(app), "the MOVE sent")
            assert f"sent top.MOVE #{given + 1}" in said(app)
            wait_for(lambda: running.module("top")["status"] == "DONE", "top DONE")
            # keys on the arm: stop, step, run, simulate
            await pilot.press("down")
            await until(pilot, lambda: app.selected() == "arm", "the arm selected")
            await pilot.press("s")
            await until(pilot, lambda: running.module("arm")["run"] == "STOP", "arm stopped")
            await pilot.press("n")
            await until(pilot, lambda: running.module("arm")["step"] == "SINGLE", "arm stepped")
            await pilot.press("r")
            await until(
                pilot,
                lambda: (
                    (running.module("arm")["run"], running.module("arm")["step"]) == ("RUN", "AUTO")
                ),
                "arm running again",
            )
            await pilot.press("i")
            await until(pilot, lambda: running.module("arm")["runs"] == "arm_sim", "the stand-in")
            await pilot.press("i")
            await until(pilot, lambda: running.module("arm")["runs"] == "arm", "the arm again")
            # a command to the arm needs the override: refused, then given
            await pilot.press("c")
            await pilot.press(*"POWER level=0.5", "enter")
            await until(pilot, lambda: "arm is commanded by top" in said(app), "override needed")
            await pilot.press("c")
            await pilot.press(*"POWER levl=0.5", "enter")
            await until(pilot, lambda: "did you mean 'level'" in said(app), "a misspelt parameter")
            await pilot.press("c")
            await pilot.press(*"POWER level=0.5 --override", "enter")
            await until(pilot, lambda: "top is in manual override" in said(app), "override told")
            # slow-down
            await pilot.press("plus")
            await until(pilot, lambda: slowed(running) == 2.0, "p1 slowed x2")
            await pilot.press("minus")
            await until(pilot, lambda: slowed(running) == 1.0, "p1 at x1 again")
            # the periodicity panel (issue 24 item 4): each process paced at 20 ms
            panel = app.query_one("#periodicity", DataTable)
            await until(
                pilot,
                lambda: all(
                    panel.get_cell(p, "wakeups").plain not in ("", "-", "0") for p in ("p1", "p2")
                ),
                "the wake-ups of both processes on the panel",
            )
            (tmp_path / "periodicity.svg").write_text(app.export_screenshot())
            return screen_text(app)

    text = asyncio.run(drive())
    assert "top" in text and "└─ arm" in text and "POWER" in text
    assert "p1: running" in text
    assert "lateness p99/max us" in text and "slowest module (max us)" in text, text
    for name, module in (("p1", "top"), ("p2", "arm")):
        row = next(line for line in text.splitlines() if line.lstrip().startswith(f"{name} "))
        assert " 20 ms " in row and f" {module} (" in row, row


def test_the_periodicity_panel_marks_a_process_that_wakes_up_late_in_red() -> None:
    from rcsgen.tools.monitor_periodicity import row_of

    figures = {
        "period_ms": 10.0,
        "wakeups": 100,
        "period_error_mean_us": 40.0,
        "period_error_max_us": 3900.0,
        "lateness_p99_us": 6000.0,
        "lateness_max_us": 7000.0,
        "lateness_warnings": 1,
    }
    proc = {"periodicity": figures, "last_cycle_us": 50.5, "max_cycle_us": 80.0}
    late = row_of("p1", proc, ("b", 35.5))
    assert late["lateness"].plain == "6000/7000" and str(late["lateness"].style) == "bold red"
    assert late["slowest"].plain == "b (35.5)" and late["warnings"].plain == "1"
    on_time = row_of("p1", {**proc, "periodicity": {**figures, "lateness_p99_us": 400.0}}, None)
    assert str(on_time["lateness"].style) == "" and on_time["slowest"].plain == "-"
    unpaced = row_of("p2", {**proc, "periodicity": None}, None)
    assert unpaced["period"].plain == "not paced" and unpaced["cycle"].plain == "50.5/80.0"
    unreadable = row_of("p3", {"state": "?"}, None)
    assert unreadable["lateness"].plain == "?"


def test_the_role_limits_the_keys_and_requests_are_answered_on_screen() -> None:
    """The miner with its operator at the console, watched as the crew: a key the crew may
    not use is refused on screen and changes nothing; ct's conveyor-tail request appears
    under the table, and `a` answers it."""
    from test_ctl import running_miner

    system = running_miner("--send", "sec.BOX_CUT:depth=1.5")
    layout = system.layout

    async def drive() -> tuple[str, str]:
        app = Monitor(layout, system.segment, interval=0.1, role="crew")
        async with app.run_test(size=(160, 40)) as pilot:
            await until(pilot, lambda: app.selected() == "sec", "sec selected")
            assert app.sub_title.endswith(" as crew")
            await pilot.press("s")
            await until(pilot, lambda: "refused: " in said(app), "the key refused")
            assert "refused: changing sec's mode needs override on sec" in said(app)
            assert system.module("sec")["run"] == "RUN"
            # ct asks at the first sump: seconds, more on a busy host
            await until(pilot, lambda: "ct asks:" in requests(app), "ct asks for the tail", 180)
            asking = screen_text(app)
            await pilot.press("a")
            await until(pilot, lambda: "answered tail: " in said(app), "the answer said")
            assert "answered tail: sent oi.TAIL_IN_POSITION" in said(app)
            wait_for(lambda: system.module("ct")["status"] == "DONE", "ct done", 60)
            await until(pilot, lambda: not requests(app).strip(), "the request gone")
            return asking, screen_text(app)

    try:
        asking, after = asyncio.run(drive())
    finally:
        system.stop()
    assert "ct asks: Put the conveyor tail over the haulage, then answer. (a: answer tail)" in (
        asking
    )
    assert "ct asks" not in after


def test_the_status_column_shows_why_a_module_is_in_error() -> None:
    """The results fixture, its operator refusing: the mission's and fixturing's status cells
    read ERROR(OPERATOR_REFUSED <- fx: REFUSED) and ERROR(REFUSED), not a bare ERROR."""
    import shutil

    fixture = Path(__file__).resolve().parent / "fixtures" / "language" / "results"
    scratch, name = generate(fixture)
    try:
        layout = importlib.import_module(
            f"{import_package(scratch / name, fixture).__name__}.layout"
        )
        system = Running(scratch / name, fixture, layout, "--world", "answer=2")
        try:
            assert system.ctl("send", "mission", "GO").returncode == 0
            wait_for(lambda: system.module("mission")["status"] == "ERROR", "mission ERROR")

            async def drive() -> str:
                app = Monitor(layout, system.segment, interval=0.1)
                async with app.run_test(size=(150, 20)) as pilot:
                    await until(pilot, lambda: "OPERATOR_REFUSED" in screen_text(app), "why")
                    return screen_text(app)

            text = asyncio.run(drive())
        finally:
            system.stop()
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    mission = next(line for line in text.splitlines() if "mission" in line)
    assert "ERROR(OPERATOR_REFUSED <- fx: REFUSED)" in mission, text  # and why: fx refused
    fx = next(line for line in text.splitlines() if "└─ fx" in line)
    assert "ERROR(REFUSED)" in fx, text


OPERATOR_DESK = Path(__file__).resolve().parent / "cases" / "valid" / "operator-module"


def test_an_operator_modules_requests_show_their_text_and_a_answers_them() -> None:
    """Two clients ask one operator module (tests/cases/valid/operator-module, run as OS
    processes): each request is shown with its client, task and instruction text, the
    parameter filled in; `a` on a client's row opens the answer form, and Enter answers
    that client's request DONE, through its own channel only; `ERROR REFUSED` refuses."""
    import shutil

    scratch, name = generate(OPERATOR_DESK)
    package = scratch / name
    layout = importlib.import_module(f"{import_package(package, OPERATOR_DESK).__name__}.layout")
    system = Running(package, OPERATOR_DESK, layout)

    async def drive() -> tuple[str, str]:
        app = Monitor(layout, system.segment, interval=0.1)
        async with app.run_test(size=(160, 40)) as pilot:
            await until(pilot, lambda: requests(app).count(" asks op:") == 2, "fx and tl ask op")
            shown = requests(app)
            table = app.query_one(DataTable)
            table.move_cursor(row=[m for m, _ in tree_order(layout)].index("tl"))
            await pilot.press("a")
            await until(pilot, lambda: "op/tl " in form(app), "the answer form for tl")
            assert "op/tl LOAD_PROBE: DONE | ERROR [REASON]" in form(app)
            await pilot.press("enter")
            await until(pilot, lambda: "answered op/tl" in said(app), "tl answered")
            first = said(app)
            wait_for(lambda: system.module("tl")["status"] == "DONE", "tl done", 30)
            assert system.module("fx")["status"] == "EXECUTING", "fx's request is still open"
            assert system.module("op/fx")["state"] == "ASKING"
            table.move_cursor(row=[m for m, _ in tree_order(layout)].index("fx"))
            await pilot.press("a", *["backspace"] * 4, *"ERROR", "space", *"REFUSED", "enter")
            await until(pilot, lambda: "answered op/fx" in said(app), "fx answered")
            return shown, first + "\n" + said(app)

    try:
        for command in (("fx", "PLACE"), ("tl", "LOAD", "probe=7")):
            assert system.ctl("send", *command).returncode == 0
        shown, answers = asyncio.run(drive())
        assert answers.splitlines() == [
            "answered op/tl: LOAD_PROBE #2 DONE",
            "answered op/fx: PLACE_PART #2 ERROR (REFUSED)",
        ]
        wait_for(lambda: system.module("fx")["status"] == "ERROR", "fx refused", 30)
    finally:
        system.stop()
        shutil.rmtree(scratch, ignore_errors=True)
    assert (
        "fx asks op: PLACE_PART: Place the part in the fixture and clamp it, then answer. "
        "(a: answer op/fx)" in shown
    )
    assert "tl asks op: LOAD_PROBE: Load probe 7 into the probe head, then answer." in shown


RESULTS_DESK = Path(__file__).resolve().parent / "cases" / "valid" / "operator-results"


def test_the_answer_form_takes_a_tasks_results_and_refuses_what_does_not_fit() -> None:
    """tests/cases/valid/operator-results run as OS processes: `a` on fx's row opens the form
    showing what a DONE gives; a gap above its maximum is refused in one line and the
    request stays open; the answer with fitting values closes it, and fx reads them."""
    import shutil

    scratch, name = generate(RESULTS_DESK)
    package = scratch / name
    layout = importlib.import_module(f"{import_package(package, RESULTS_DESK).__name__}.layout")
    system = Running(package, RESULTS_DESK, layout)
    good = "gap=1.5 verdict=REWORK count=3 ok=true note=fine"

    async def drive() -> tuple[str, str, str]:
        app = Monitor(layout, system.segment, interval=0.1)
        async with app.run_test(size=(200, 40)) as pilot:
            await until(pilot, lambda: " asks op:" in requests(app), "fx asks op")
            table = app.query_one(DataTable)
            table.move_cursor(row=[m for m, _ in tree_order(layout)].index("fx"))
            await pilot.press("a")
            await until(pilot, lambda: "op/fx " in form(app), "the answer form for fx")
            shown = form(app)
            await pilot.press(*["backspace"] * 4, *"DONE gap=9 verdict=KEEP count=1 ok=true note=x")
            await pilot.press("enter")
            await until(pilot, lambda: "result gap" in said(app), "the gap refused")
            refused = said(app)
            await pilot.press("a", *["backspace"] * 4, *f"DONE {good}", "enter")
            await until(pilot, lambda: "answered op/fx" in said(app), "fx answered")
            return shown, refused, said(app)

    try:
        assert system.ctl("send", "fx", "CHECK").returncode == 0
        placeholder, refused, answer = asyncio.run(drive())
        wait_for(lambda: system.module("fx")["status"] == "DONE", "fx done", 30)
        results = system.module("fx")["results"]
    finally:
        system.stop()
        shutil.rmtree(scratch, ignore_errors=True)
    assert placeholder.startswith(
        "op/fx MEASURE: DONE gap=0.0..5.0 verdict=KEEP|REWORK|SCRAP count=1..9 ok=true|false "
        "note=text | ERROR [REASON]"
    ), placeholder
    assert "result gap is 9.0: above its maximum 5.0" in refused, refused
    assert answer == f"answered op/fx: MEASURE #2 DONE {good}", answer
    assert results == {"gap": 1.5, "reworked": True}


def test_the_devices_panel_shows_each_device_up_then_lost_with_its_counts(
    tmp_path: Path,
) -> None:
    """The rig on its two soft PLCs (tank on Modbus TCP, pumps on OPC UA): the devices
    panel shows both up, with their reads and writes; the tank PLC frozen, its row turns
    lost, its timeouts count and its last error says `timeout`, the pumps still up. What
    the screen shows is checked as text from the SVG screenshot (kept in tmp_path)."""
    import shutil
    import signal

    from test_io import RIG, Plc, Running, environment

    scratch, name = generate(RIG)
    rig = scratch / name
    plcs = {device: Plc(rig, device, tmp_path) for device in ("tank", "pumps")}
    running = None
    try:
        for plc in plcs.values():
            plc.wait()
        package = import_package(rig)
        running = Running(rig, package, environment(plcs), tmp_path / "rig.log")
        layout = running.layout

        def cell(app: Monitor, device: str, column: str) -> str:
            return str(app.query_one("#devices", DataTable).get_cell(device, column).plain)

        async def drive() -> tuple[str, str]:
            app = Monitor(layout, running.segment, interval=0.1)
            async with app.run_test(size=(160, 40)) as pilot:
                await until(
                    pilot,
                    lambda: (
                        [cell(app, d, "state") for d in ("tank", "pumps")] == ["up", "up"]
                        and int(cell(app, "tank", "reads")) > 0
                        and int(cell(app, "pumps", "writes")) > 0
                    ),
                    "both devices up, the tank read and the pumps written",
                )
                assert cell(app, "pumps", "reads") == "0", "the pumps device has outputs only"
                up = screen_text(app)
                plcs["tank"].popen.send_signal(signal.SIGSTOP)
                await until(pilot, lambda: cell(app, "tank", "state") == "lost", "tank lost")
                await until(
                    pilot, lambda: cell(app, "tank", "last_error") == "timeout", "the timeout"
                )
                assert int(cell(app, "tank", "timeouts")) >= 1
                assert cell(app, "pumps", "state") == "up", "the other device still answers"
                (tmp_path / "devices.svg").write_text(app.export_screenshot())
                (tmp_path / "devices.txt").write_text(screen_text(app))
                return up, screen_text(app)

        up, lost = asyncio.run(drive())
    finally:
        if running is not None:
            running.stop()
        for plc in plcs.values():
            plc.stop()
        shutil.rmtree(scratch, ignore_errors=True)
    tank = next(line for line in up.splitlines() if line.lstrip().startswith("tank "))
    assert "modbus_tcp 127.0.0.1:" in tank and " up " in tank, tank
    tank = next(line for line in lost.splitlines() if line.lstrip().startswith("tank "))
    assert " lost " in tank and " timeout " in tank, tank
    pumps = next(line for line in lost.splitlines() if line.lstrip().startswith("pumps "))
    assert "opcua opc.tcp://127.0.0.1:" in pumps and " up " in pumps, pumps


def test_the_time_per_state_panel_shows_each_controllers_share_of_cycles_per_state(
    running: Running, layout: ModuleType, tmp_path: Path
) -> None:
    """Issue 26 (the paper's "% of execution time per state"): a row per controller, its
    cycles since start and the share of them in each state, largest first, summing to 100,
    the state it is in now in bold; top sent RUN has S1 among its states, and the share of
    the state it is in grows. Read from the screen (the SVG screenshot, kept in tmp_path)
    and the panel's cells. A watchdog tripped on a busy host may halt top out of S1: the
    test then follows the state top is in (NOP), as the panel does."""

    def shares(app: Monitor, module: str) -> dict[str, float]:
        text = app.query_one("#state_time", DataTable).get_cell(module, "states").plain
        if text in ("", "-"):
            return {}
        pairs = [part.rsplit(" ", 1) for part in text.split("  ")]
        return {state: float(share.rstrip("%")) for state, share in pairs}

    def bold(app: Monitor, module: str) -> list[str]:
        cell = app.query_one("#state_time", DataTable).get_cell(module, "states")
        return [cell.plain[s.start : s.end] for s in cell.spans if "bold" in str(s.style)]

    def now(app: Monitor, module: str) -> str:
        return str(app.query_one("#modules", DataTable).get_cell(module, "state").plain)

    async def drive() -> tuple[str, dict[str, float], dict[str, float]]:
        app = Monitor(layout, running.segment, interval=0.1)
        async with app.run_test(size=(150, 30)) as pilot:
            panel = app.query_one("#state_time", DataTable)
            assert [str(key.value) for key in panel.rows] == ["top", "arm"]
            await until(pilot, lambda: all(shares(app, m) for m in ("top", "arm")), "both counted")
            sent = running.ctl("send", "top", "RUN")
            assert sent.returncode == 0, sent.stderr
            await until(pilot, lambda: "S1" in shares(app, "top"), "top's S1 counted")
            await until(
                pilot,
                lambda: [b.rsplit(" ", 1)[0] for b in bold(app, "top")] == [now(app, "top")],
                "the state top is in, in bold",
            )
            first, state = shares(app, "top"), now(app, "top")
            await until(
                pilot,
                lambda: (
                    (now(app, "top") != state and shares(app, "top") != first)
                    or shares(app, "top").get(state, 0.0) > first.get(state, 0.0) + 0.5
                ),
                f"the share of {state}, the state top is in, growing from {first}",
            )
            (tmp_path / "state_time.svg").write_text(app.export_screenshot())
            return screen_text(app), first, shares(app, "top")

    text, first, later = asyncio.run(drive())
    assert "% of cycles per state since start" in text, text
    row = next(ln for ln in text.splitlines() if ln.lstrip().startswith("top ") and "%" in ln)
    assert "S1 " in row and "NOP " in row, row
    for figures in (first, later):
        assert abs(sum(figures.values()) - 100.0) <= 0.5, figures
        assert list(figures.values()) == sorted(figures.values(), reverse=True), "largest first"
    assert later != first
