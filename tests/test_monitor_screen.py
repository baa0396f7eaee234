"""The live monitor's screen and keys (rcsgen/tools/monitor.py, monitor_devices.py) through
textual's pilot, against the duo system run in this process: the harness's processes on a
named shared-memory segment, cycled by the test, the monitor's console attached to it as to
a running system. What test_monitor.py checks against real OS processes, here in a second
and in the process a line tracer sees (`make mutate-sample` maps these tests); the cells
are read as a person reads them: their text and colour.
"""

from __future__ import annotations

import asyncio
import importlib
import os
import re
import shutil
import threading
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from itertools import count
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import pytest

pytest.importorskip("textual")

from conftest import until  # noqa: E402
from rich.text import Text  # noqa: E402
from test_monitor import screen_text  # noqa: E402
from textual.pilot import Pilot  # noqa: E402
from textual.widgets import DataTable, Input, Static  # noqa: E402
from textual.widgets.data_table import ColumnKey  # noqa: E402

from rcsgen.tools import monitor_devices, monitor_periodicity  # noqa: E402
from rcsgen.tools.harness import Harness, generate, import_package  # noqa: E402
from rcsgen.tools.monitor import COLUMNS, Monitor  # noqa: E402

DUO = Path(__file__).resolve().parent / "fixtures" / "runtime" / "duo"
_segments = count(1)


@pytest.fixture(scope="module")
def package() -> Iterator[ModuleType]:
    scratch, name = generate(DUO)
    yield import_package(scratch / name, DUO)
    shutil.rmtree(scratch, ignore_errors=True)


@pytest.fixture
def system(package: ModuleType) -> Iterator[tuple[Harness, str]]:
    """Both processes of duo in this process, on a segment of their own (INIT sent, three
    cycles run): the harness and the segment's name. The segment is removed after."""
    blocks = importlib.import_module(f"{package.__name__}.rcs.block")
    layout = importlib.import_module(f"{package.__name__}.layout")
    segment = f"rcsgen_monscreen_{os.getpid()}_{next(_segments)}"
    named = blocks.Block(layout, segment, True)
    private = blocks.Block
    blocks.Block = lambda layout: named  # the harness's block: the named one
    try:  # a harness that cannot be made or run (a broken package) leaves no segment
        try:
            harness = Harness(package, send_init=True)
        finally:
            blocks.Block = private
        try:
            harness.cycle(3)
            yield harness, segment
        finally:
            harness.close()
    finally:
        named.close()
    assert not Path(f"/dev/shm/{segment}").exists()


@contextmanager
def cycling(harness: Harness) -> Iterator[None]:
    """The system's cycles run on their own (a thread, every 10 ms) while inside."""
    stop = threading.Event()

    def run() -> None:
        while not stop.wait(0.01):
            harness.cycle(1)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(10)


async def send(pilot: Pilot[None], app: Monitor, text: str) -> None:
    """`c`, the form filled with `text` at once (not typed key by key: slow on a busy
    host), then enter."""
    await pilot.press("c")
    app.query_one("#send", Input).value = text
    await pilot.press("enter")


def row(app: Monitor, module: str) -> dict[str, Text]:
    table = app.query_one("#modules", DataTable)
    return {key: table.get_cell(module, key) for key, _ in COLUMNS}


def said(app: Monitor) -> str:
    return str(app.query_one("#message").render())


def drive(
    harness: Harness, segment: str, steps: Callable[[Monitor, Pilot[None]], Awaitable[None]]
) -> None:
    async def run() -> None:
        app = Monitor(harness.layout, segment, interval=0.05)
        async with app.run_test(size=(160, 40)) as pilot:
            table = app.query_one("#modules", DataTable)
            await until(pilot, lambda: table.row_count > 0, "the first screen drawn")
            await steps(app, pilot)

    asyncio.run(run())


def test_the_tree_shows_each_modules_command_status_and_mode_coloured_by_status(
    system: tuple[Harness, str],
) -> None:
    harness, segment = system

    async def steps(app: Monitor, pilot: Pilot[None]) -> None:
        assert app.sub_title == f"duo on {segment}"
        assert app.selected() == "top"
        seen: dict[str, Any] = {}

        def alive() -> bool:
            """Both processes beating on the screen (what was shown kept, at that moment)."""
            seen.update(top=row(app, "top"), arm=row(app, "arm"))
            seen["processes"] = str(app.query_one("#processes").render())
            world = app.query_one("#world", DataTable)
            seen["arm_power"] = [world.get_cell("arm_power", k) for k in ("value", "override")]
            beats = all(seen[m]["beat"].plain != "dead" for m in ("top", "arm"))
            return beats and all(f"{p}: running" in seen["processes"] for p in ("p1", "p2"))

        with cycling(harness):  # beating as a running system's processes do (a busy host too)
            await until(pilot, alive, "both processes alive on the screen")
        top, arm = seen["top"], seen["arm"]
        assert top["module"].plain == "top" and arm["module"].plain == "└─ arm"
        for cells in (top, arm):
            assert (cells["command"].plain, cells["cnum"].plain) == ("INIT", "1")
            assert (cells["status"].plain, cells["snum"].plain) == ("DONE", "1")
            assert cells["state"].plain == "NOP" and cells["rule"].plain == "-"
            assert cells["mode"].plain == "RUN AUTO REAL"
            assert cells["status"].style == "green" and cells["module"].style == "green"
            last, low, high = (float(t) for t in cells["cycle"].plain.split("/"))
            assert 0 < low <= high and low <= last <= high
            assert re.fullmatch(r"\d+\.\d\ds", cells["beat"].plain), cells["beat"].plain
        # the screen as a person reads it: the headers, the tree, the keys in the footer
        # (drawn after the tables: waited for)
        await until(pilot, lambda: "answer request" in screen_text(app), "the footer drawn")
        text = screen_text(app)
        for header in ("module", "command", "status", "state", "last rule fired", "mode"):
            assert header in text, header
        assert "cycle us last/min/max" in text and "└─ arm" in text
        for key in ("stop", "run", "step", "simulate", "slower", "faster", "send command"):
            assert key in text, key
        assert "answer request" in text and "quit" in text
        for process in ("p1", "p2"):
            line = rf"{process}: running, \d+ cycles, beat \d+\.\d\ds ago, 0 overruns, slow x1"
            assert re.search(line, seen["processes"]), seen["processes"]
        # the world table (as drawn while both beat): every field, its value, no override
        assert [cell.plain for cell in seen["arm_power"]] == ["0.0", ""]
        # a command under way: the arm's HOLD stays in S1, EXECUTING in yellow, the rule
        # that fired kept; the top's RUN waits on it
        await pilot.press("c", *"RUN", "enter")
        await until(pilot, lambda: "sent top.RUN #2" in said(app), "the RUN sent")
        harness.cycle(3)
        app.refresh_rows()
        top, arm = row(app, "top"), row(app, "arm")
        assert (arm["command"].plain, arm["cnum"].plain) == ("HOLD", "2")
        assert arm["status"].plain == "EXECUTING" and arm["status"].style == "yellow"
        assert arm["state"].plain == "S1"
        assert (top["status"].plain, top["state"].plain) == ("EXECUTING", "S1")
        assert app.query_one("#world", DataTable).get_cell("arm_power", "value").plain == "1.0"
        # nothing cycles any more: past the heartbeat timeout the rows turn grey, `dead`
        await until(
            pilot, lambda: row(app, "arm")["beat"].plain == "dead", "the silent arm shown dead"
        )
        assert row(app, "arm")["status"].style == "grey50"
        assert row(app, "top")["beat"].plain == "dead"
        # the arm's power is the last value p2 wrote: nobody keeps it current, the world
        # table says so (grey, and why), as `ctl status --world` does
        power = app.query_one("#world", DataTable)

        def power_stale() -> bool:
            return str(power.get_cell("arm_power", "value").plain) == "1.0 (stale: p2 lost)"

        await until(pilot, power_stale, "arm_power shown stale")
        assert power.get_cell("arm_power", "value").style == "grey50"
        # (the arm's stand-in, which would write sim_power, runs in p2 too)
        assert power.get_cell("sim_power", "value").plain == "0.0 (stale: p2 lost)"
        from rcsgen.runtime.operate import ctl

        console = ctl.Console(harness.layout, segment)
        try:
            lines = ctl.world_lines(console.snapshot())
        finally:
            console.close()
        assert any(re.fullmatch(r"arm_power +1\.0 \(stale: p2 lost\) *", x) for x in lines), lines

    drive(harness, segment, steps)


def test_the_keys_act_on_the_selected_module_and_say_what_they_did(
    system: tuple[Harness, str],
) -> None:
    harness, segment = system

    def arm() -> dict[str, Any]:
        return _console_row(harness, segment, "arm")

    async def steps(app: Monitor, pilot: Pilot[None]) -> None:
        await pilot.press("down")
        await until(pilot, lambda: app.selected() == "arm", "the arm selected")
        await pilot.press("s")
        await until(pilot, lambda: said(app) == "arm: STOP", "STOP said")
        assert arm()["run"] == "STOP" and row(app, "arm")["mode"].plain == "STOP AUTO REAL"
        with cycling(harness):  # a step waits until the arm's process has run it
            await pilot.press("n")
            await until(pilot, lambda: said(app) == "arm: stepped one cycle (SINGLE)", "step")
        assert arm()["step"] == "SINGLE"
        await pilot.press("r")
        await until(pilot, lambda: said(app) == "arm: RUN AUTO", "RUN said")
        assert (arm()["run"], arm()["step"]) == ("RUN", "AUTO")
        await pilot.press("i")
        await until(pilot, lambda: said(app) == "arm: SIMU", "SIMU said")
        assert arm()["sim"] == "SIMU"
        await pilot.press("i")
        await until(pilot, lambda: said(app) == "arm: REAL", "REAL said")
        assert arm()["sim"] == "REAL"
        # slower doubles every process's slow-down, faster halves it, never under x1
        await pilot.press("plus")
        await until(pilot, lambda: said(app) == "slow x2", "slow x2")
        await pilot.press("plus")
        await until(pilot, lambda: said(app) == "slow x4", "slow x4")
        harness.cycle(1)
        app.refresh_rows()
        assert "slow x4" in str(app.query_one("#processes").render())
        await pilot.press("minus")
        await until(pilot, lambda: said(app) == "slow x2", "back to x2")
        await pilot.press("minus", "minus")
        await until(pilot, lambda: said(app) == "slow x1", "x1, not under")
        # `a` with nothing asked
        await pilot.press("a")
        await until(pilot, lambda: said(app) == "no module is asking anything", "no request")
        message = app.query_one("#message", Static).content
        assert isinstance(message, Text) and message.style == "bold red"

    drive(harness, segment, steps)


def _console_row(harness: Harness, segment: str, module: str) -> dict[str, Any]:
    from rcsgen.runtime.operate.ctl import Console

    console = Console(harness.layout, segment)
    try:
        return dict(console.modules()[module])
    finally:
        console.close()


def test_the_send_form_lists_the_commands_and_refuses_what_is_wrong_in_one_line(
    system: tuple[Harness, str],
) -> None:
    harness, segment = system

    async def steps(app: Monitor, pilot: Pilot[None]) -> None:
        await pilot.press("down")
        await until(pilot, lambda: app.selected() == "arm", "the arm selected")
        await pilot.press("c")
        form = app.query_one("#send", Input)
        await until(pilot, lambda: form.has_class("open"), "the form open")
        assert form.placeholder == (
            "arm: COMMAND NAME=VALUE ... [--override]  commands: INIT, HALT, POWER level=, HOLD"
        )
        await pilot.press("enter")
        await until(pilot, lambda: said(app) == "no command given", "an empty form refused")
        assert not form.has_class("open")
        await send(pilot, app, "POWER levl=0.5")
        await until(pilot, lambda: "did you mean 'level'" in said(app), "a misspelt parameter")
        await send(pilot, app, "POWER level=0.5")
        await until(pilot, lambda: "arm is commanded by top" in said(app), "override needed")
        with cycling(harness):  # the override is taken while the system runs
            await send(pilot, app, "POWER level=0.5 --override")
            await until(pilot, lambda: "sent arm.POWER" in said(app), "sent with the override")
            assert "top is in manual override" in said(app)
            await until(pilot, lambda: harness.world["arm_power"] == 0.5, "the arm powered")
        # escape closes the form, nothing sent
        await pilot.press("c", *"HALT", "escape")
        await until(pilot, lambda: not form.has_class("open"), "the form closed")
        assert "sent arm.POWER" in said(app)

    drive(harness, segment, steps)


def test_a_segment_that_cannot_be_read_is_said_in_red_and_the_last_values_stay(
    system: tuple[Harness, str],
) -> None:
    harness, segment = system

    async def steps(app: Monitor, pilot: Pilot[None]) -> None:
        await until(pilot, lambda: row(app, "top")["status"].plain == "DONE", "drawn once")
        real = app.ctl.snapshot

        def torn(world: Any = None) -> dict[str, Any]:
            raise OSError("the segment is gone")

        app.ctl.snapshot = torn  # type: ignore[method-assign]
        await until(pilot, lambda: "cannot read" in said(app), "the failed read said")
        assert said(app) == (f"cannot read {segment}: the segment is gone; showing the last values")
        assert row(app, "top")["status"].plain == "DONE"
        app.ctl.snapshot = real  # type: ignore[method-assign]
        await until(pilot, lambda: said(app) == "", "the message gone once readable")

    drive(harness, segment, steps)


# ------------------------------------------------------------ the devices panel's rows


def test_a_devices_row_reads_up_stale_or_lost_as_an_operator_reads_it() -> None:
    seen = monitor_devices.seen_as
    online = {"state": "ONLINE", "poll_period_s": 0.1}
    assert seen(online | {"last_answer_age_s": 0.05}) == "up"
    assert seen(online | {"last_answer_age_s": 0.2}) == "up"  # two polls: not yet stale
    assert seen(online | {"last_answer_age_s": 0.21}) == "stale"
    assert seen(online) == "stale"  # online, never answered
    assert seen({"state": "LOST"}) == "lost"
    assert seen({"state": "CONNECTING"}) == "connecting"
    assert seen({}) == "?"

    cells = monitor_devices.row_of(
        "tank",
        {
            "state": "ONLINE",
            "poll_period_s": 0.1,
            "last_answer_age_s": 0.125,
            "protocol": "modbus",
            "address": "127.0.0.1:5020",
            "reads": 12,
            "writes": 3,
            "timeouts": 1,
            "retries": 2,
            "errors": 0,
            "last_error": "none",
        },
    )
    assert {k: v.plain for k, v in cells.items()} == {
        "device": "tank",
        "where": "modbus 127.0.0.1:5020",
        "state": "up",
        "reads": "12",
        "writes": "3",
        "timeouts": "1",
        "retries": "2",
        "errors": "0",
        "last_error": "-",
        "answered": "0.12s ago",
    }
    assert cells["state"].style == "green" and cells["device"].style == "green"
    assert cells["reads"].style == ""
    lost = monitor_devices.row_of("tank", {"state": "LOST", "last_error": "timed out"})
    assert lost["state"].style == "bold red" and lost["last_error"].plain == "timed out"
    assert lost["answered"].plain == "never" and lost["reads"].plain == "?"
    assert lost["where"].plain == "? ?"
    stale = monitor_devices.row_of("tank", {"state": "ONLINE", "poll_period_s": 0.1})
    assert stale["state"].style == "yellow"
    assert monitor_devices.row_of("tank", {"state": "STOPPED"})["state"].style == "grey50"


def test_the_devices_panel_draws_a_row_per_declared_device_and_a_missing_one_as_unknown() -> None:
    layout = SimpleNamespace(IO_DEVICES={"tank": object(), "pumps": object()})

    async def run() -> tuple[dict[str, dict[str, str]], str]:
        from textual.app import App, ComposeResult

        class One(App[None]):
            def compose(self) -> ComposeResult:
                yield monitor_devices.DevicesPanel(layout)  # type: ignore[arg-type]

        app = One()
        async with app.run_test(size=(160, 10)) as pilot:
            panel = app.query_one(monitor_devices.DevicesPanel)
            panel.show({"tank": {"state": "LOST", "last_error": LONG_ERROR}})
            error = panel.columns[ColumnKey("last_error")]
            await until(pilot, lambda: error.content_width >= len(LONG_ERROR), "the column grown")
            rows = {
                name: {key: panel.get_cell(name, key).plain for key, _ in monitor_devices.COLUMNS}
                for name in ("tank", "pumps")
            }
            return rows, screen_text(app)  # type: ignore[arg-type]

    rows, text = asyncio.run(run())
    assert rows["tank"]["state"] == "lost" and rows["tank"]["device"] == "tank"
    assert rows["pumps"]["state"] == "?" and rows["pumps"]["answered"] == "never"
    # every header whole, and a cell wider than its header grows the column, never cut
    for _, label in monitor_devices.COLUMNS:
        assert label in text, label
    assert LONG_ERROR in text, text


LONG_ERROR = "connection refused by 127.0.0.1:1502 (errno 111)"


def test_a_process_row_shows_its_period_and_turns_red_when_it_wakes_up_late() -> None:
    figures = {
        "period_ms": 20.0,
        "wakeups": 500,
        "period_error_mean_us": 12.5,
        "period_error_max_us": 480.0,
        "lateness_p99_us": 9000.0,
        "lateness_max_us": 15000.0,
        "lateness_warnings": 2,
    }
    proc = {"state": "RUNNING", "last_cycle_us": 40, "max_cycle_us": 95, "periodicity": figures}
    cells = monitor_periodicity.row_of("p1", proc, ("arm", 80.5))
    assert {k: v.plain for k, v in cells.items()} == {
        "process": "p1",
        "period": "20 ms",
        "wakeups": "500",
        "error": "12.5/480",
        "lateness": "9000/15000",
        "warnings": "2",
        "cycle": "40/95",
        "slowest": "arm (80.5)",
    }
    assert cells["lateness"].style == cells["process"].style == ""  # p99 under half the period
    late = monitor_periodicity.row_of(
        "p1", proc | {"periodicity": figures | {"lateness_p99_us": 10001.0}}, None
    )
    assert late["lateness"].style == late["process"].style == "bold red"
    assert late["period"].style == "" and late["slowest"].plain == "-"
    flat = monitor_periodicity.row_of("p2", {"state": "RUNNING"}, None)
    assert {k: v.plain for k, v in flat.items()} == {
        "process": "p2",
        "period": "not paced",
        "wakeups": "-",
        "error": "-",
        "lateness": "-",
        "warnings": "-",
        "cycle": "?/?",
        "slowest": "-",
    }
    gone = monitor_periodicity.row_of("p3", {"state": "?"}, ("arm", 1.0))
    assert all(v.plain == "?" and v.style == "grey50" for k, v in gone.items() if k != "process")
    assert gone["process"].plain == "p3"
