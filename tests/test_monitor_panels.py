"""The monitor's screen as a person reads it, in process and in a fraction of a second: the
hierarchy's tree prefixes, every panel's headers and cells (text and colour), the processes
and requests lines, what each key asks of the console and says back, the send and answer
forms' checks. The console is a recording stand-in that serves snapshots (the monitor reads
only those) and answers or refuses as the real one does (CtlError); test_monitor_screen and
test_monitor run the same screen against a real segment and real processes.
"""

from __future__ import annotations

import asyncio
import re
import sys
from collections.abc import Awaitable, Callable
from pathlib import Path
from types import ModuleType, SimpleNamespace
from typing import Any

import pytest

pytest.importorskip("textual")

from rich.text import Text  # noqa: E402
from test_monitor import screen_text, until  # noqa: E402
from textual.widgets import DataTable, Input, Static  # noqa: E402
from textual.widgets.data_table import ColumnKey  # noqa: E402

from rcsgen.runtime.operate.ctl import CtlError  # noqa: E402
from rcsgen.tools import monitor, monitor_devices, monitor_state_time  # noqa: E402
from rcsgen.tools.harness import import_layout  # noqa: E402
from rcsgen.tools.monitor_rows import RowsPanel  # noqa: E402

CELL = Path(__file__).resolve().parents[1] / "generated" / "cell"


@pytest.fixture(scope="module")
def cell() -> ModuleType:
    """The committed cell package's layout: sup over pln and exe, arm a root of its own."""
    return import_layout(CELL)


def module_row(**over: Any) -> dict[str, Any]:
    row = {
        "command": "RUN",
        "command_num": 3,
        "status": "EXECUTING",
        "status_num": 3,
        "state": "S1",
        "rule": "2",
        "run": "RUN",
        "step": "AUTO",
        "sim": "REAL",
        "last_cycle_us": 40,
        "min_cycle_us": 30,
        "max_cycle_us": 95,
        "heartbeat_age_s": 0.0312,
        "alive": True,
    }
    return row | over


def snapshot(**over: Any) -> dict[str, Any]:
    shot: dict[str, Any] = {
        "modules": {m: module_row() for m in ("sup", "pln", "exe", "arm")},
        "world": {"arm_x": 1.5, "arm_speed": 0.0},
        "overrides": {},
        "stale": {},
        "processes": {
            "cell": {
                "state": "RUNNING",
                "heartbeat": 120,
                "heartbeat_age_s": 0.015,
                "overruns": 2,
                "slow": 4.0,
            }
        },
        "requests": [],
    }
    return shot | over


class FakeConsole:
    """What the monitor asks of `Console`, recorded; `refuse` makes the next action a CtlError."""

    def __init__(self, layout: ModuleType, segment: str, role: Any, connect: Any) -> None:
        self.layout, self.segment = layout, f"seg_{segment}"
        self.access = SimpleNamespace(role=role, roles=ROLES)
        self.shot: dict[str, Any] | Exception = snapshot()
        self.calls: list[tuple[Any, ...]] = []
        self.refuse = ""
        self.sims = {"sup": "REAL", "pln": "SIMU", "exe": "REAL", "arm": "REAL"}
        self.slows = {"cell": {"slow": 4.0}}

    def world_names(self, names: tuple[str, ...]) -> list[str]:
        return list(names)

    def snapshot(self, fields: list[str]) -> dict[str, Any]:
        self.calls.append(("snapshot", tuple(fields)))
        if isinstance(self.shot, Exception):
            raise self.shot
        return self.shot | {"world": {f: self.shot["world"][f] for f in fields}}

    def close(self) -> None:
        self.calls.append(("close",))

    def _do(self, *call: Any) -> Any:
        self.calls.append(call)
        if self.refuse:
            raise CtlError(self.refuse)
        return None

    def set_mode(self, module: str, **how: bool) -> None:
        self._do("set_mode", module, tuple(sorted(how.items())))

    def step(self, module: str, n: int) -> None:
        self._do("step", module, n)

    def simulate(self, module: str, on: bool) -> None:
        self._do("simulate", module, on)

    def slow(self, factor: float) -> None:
        self._do("slow", factor)

    def modules(self) -> dict[str, dict[str, str]]:
        return {m: {"sim": s} for m, s in self.sims.items()}

    def processes(self) -> dict[str, dict[str, float]]:
        return self.slows

    def send(self, command: Any, override: bool) -> tuple[int, list[str]]:
        self._do("send", str(command), override)
        return 7, ["note: sup is in STOP"] if override else []

    def answer(self, name: str) -> tuple[str, int]:
        self._do("answer", name)
        return "DONE", 4

    def answer_channel(
        self, name: str, status: str, reason: str, results: dict[str, str]
    ) -> dict[str, Any]:
        self._do("answer_channel", name, status, reason, tuple(results.items()))
        return {"task": "weigh", "number": 5}


ROLES = {"op": {"sup": 1}}  # as the cell declared operator roles (the title says the role)
Scenario = Callable[[monitor.Monitor, FakeConsole, Any], Awaitable[None]]


def on_screen(layout: ModuleType, scenario: Scenario, **kw: Any) -> FakeConsole:
    """Run the monitor on `layout` with a FakeConsole through textual's pilot."""
    made: list[FakeConsole] = []

    def console(*args: Any) -> FakeConsole:
        made.append(FakeConsole(*args))
        return made[-1]

    async def run() -> None:
        original = monitor.Console
        monitor.Console = console  # type: ignore[assignment,misc]
        try:
            app = monitor.Monitor(layout, "cellseg", interval=30.0, **kw)
        finally:
            monitor.Console = original  # type: ignore[misc]
        async with app.run_test(size=(120, 36)) as pilot:
            app.query_one("#send", Input).cursor_blink = False  # (a blink is a repaint)
            await pilot.pause()
            await scenario(app, made[0], pilot)

    asyncio.run(run())
    return made[0]


def cell_text(table: DataTable[Any], row: str, column: str) -> Text:
    value = table.get_cell(row, column)
    return value if isinstance(value, Text) else Text(str(value))


def said(app: monitor.Monitor) -> Text:
    shown = app.query_one("#message", Static).content
    assert isinstance(shown, Text)
    return shown


def footer(app: monitor.Monitor) -> str:
    """The screen's last line: the footer with its keys."""
    return screen_text(app).rstrip().splitlines()[-1]


def static_text(app: monitor.Monitor, which: str) -> str:
    return str(app.query_one(which, Static).render())


# ------------------------------------------------------------ the tree


def test_the_tree_draws_each_supervisor_above_its_subordinates_in_layout_order() -> None:
    layout = SimpleNamespace(
        MODULES=("top", "a", "a1", "a2", "b", "lone", "stand"),
        SUBORDINATES={"top": ("a", "b"), "a": ("a1", "a2", "gone"), "lone": ()},
        COMMAND_IN=dict.fromkeys(("top", "a", "a1", "a2", "b", "lone", "stand")),
    )
    assert monitor.tree_order(layout) == [  # type: ignore[arg-type]
        ("top", ""),
        ("a", "├─ "),
        ("a1", "│  ├─ "),
        ("a2", "│  └─ "),
        ("b", "└─ "),
        ("lone", ""),
        ("stand", ""),
    ]
    # a subordinate under the last one of its level is drawn without the bar
    deep = SimpleNamespace(
        MODULES=("r", "x", "y"),
        SUBORDINATES={"r": ("x",), "x": ("y",)},
        COMMAND_IN=dict.fromkeys(("r", "x", "y")),
    )
    assert monitor.tree_order(deep) == [("r", ""), ("x", "└─ "), ("y", "   └─ ")]  # type: ignore[arg-type]


# ------------------------------------------------------------ the modules and the world


def test_the_screen_shows_every_module_world_field_and_process_as_read(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        table = app.query_one("#modules", DataTable)
        got["headers"] = [str(c.label) for c in table.columns.values()]
        got["rows"] = {
            m: {k: cell_text(table, m, k).plain for k, _ in monitor.COLUMNS}
            for m in ("sup", "pln", "exe", "arm")
        }
        got["styles"] = {m: str(cell_text(table, m, "status").style) for m in ("sup", "arm")}
        world = app.query_one("#world", DataTable)
        got["world_headers"] = [str(c.label) for c in world.columns.values()]
        # the modules' rows a cursor moves over, the world's read only; no row striped
        got["display"] = [(t.cursor_type, t.zebra_stripes) for t in (table, world)]
        got["world"] = {
            f: [cell_text(world, f, k).plain for k in monitor.WORLD_COLUMNS]
            for f in ("arm_x", "arm_speed")
        }
        got["processes"] = static_text(app, "#processes")
        got["title"] = app.sub_title
        got["panels"] = [w.id for w in app.query(RowsPanel)]
        # textual's Footer draws its keys a refresh after the screen's bindings are published:
        # one pause may end before that on a slow host (a line tracer, a loaded machine)
        await until(pilot, lambda: "quit" in footer(app), "the footer's keys drawn")
        got["footer"] = footer(app)

    console = on_screen(cell, look)
    assert got["headers"] == [
        "module",
        "command",
        "#",
        "status",
        "#",
        "state",
        "last rule fired",
        "mode",
        "cycle us last/min/max",
        "beat",
    ]
    assert got["rows"]["pln"] == {
        "module": "├─ pln",
        "command": "RUN",
        "cnum": "3",
        "status": "EXECUTING",
        "snum": "3",
        "state": "S1",
        "rule": "2",
        "mode": "RUN AUTO REAL",
        "cycle": "40/30/95",
        "beat": "0.03s",
    }
    assert got["rows"]["exe"]["module"] == "└─ exe" and got["rows"]["arm"]["module"] == "arm"
    assert got["styles"] == {"sup": "yellow", "arm": "yellow"}
    assert got["world_headers"] == ["field", "value", "override"]
    assert got["display"] == [("row", False), ("none", False)]
    assert got["world"] == {"arm_x": ["arm_x", "1.5", ""], "arm_speed": ["arm_speed", "0.0", ""]}
    assert got["processes"] == "cell: running, 120 cycles, beat 0.01s ago, 2 overruns, slow x4"
    assert got["title"] == "cell on seg_cellseg (monitor only)"
    assert got["panels"] == ["periodicity", "state_time"]  # cell declares no devices
    keys = ("stop", "run", "step", "simulate", "slower", "faster", "send command")
    for said_in_footer in (*keys, "answer request", "quit"):
        assert re.search(rf"(?<!\w){said_in_footer}(?!\w)", got["footer"]), got["footer"]
    assert "close form" not in got["footer"]  # escape: said in the form, not the footer
    assert console.calls[0] == ("snapshot", ("arm_x", "arm_speed"))


def test_a_role_is_in_the_title_and_the_world_shown_is_the_fields_named(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        got["title"] = app.sub_title
        got["world"] = [str(key.value) for key in app.query_one("#world", DataTable).rows]

    on_screen(cell, look, role="op", world=("arm_speed",))
    assert got == {"title": "cell on seg_cellseg as op", "world": ["arm_speed"]}
    roles = dict(ROLES)
    ROLES.clear()
    try:
        on_screen(cell, look)
    finally:
        ROLES.update(roles)
    assert got["title"] == "cell on seg_cellseg"  # no roles declared: nothing to say


def test_a_module_row_reads_its_error_mode_and_liveness(cell: ModuleType) -> None:
    app = SimpleNamespace(last_rule={})

    def cells(row: dict[str, Any], prefix: str = "") -> dict[str, Text]:
        return monitor.Monitor.cells(app, "exe", prefix, row)  # type: ignore[arg-type]

    error = cells(module_row(status="ERROR", reason="TIMED_OUT", cause="arm: REFUSED"))
    assert error["status"].plain == "ERROR(TIMED_OUT <- arm: REFUSED)"
    assert {str(t.style) for t in error.values()} == {"bold red"}
    done = cells(module_row(status="DONE", rule=None), "│  ")
    assert done["module"].plain == "│  exe" and str(done["state"].style) == "green"
    assert done["rule"].plain == "2"  # the last rule that fired stays when none fires now
    dead = cells(module_row(alive=False))
    assert dead["beat"].plain == "dead" and str(dead["module"].style) == "grey50"
    assert cells(module_row(heartbeat_age_s=None))["beat"].plain == "dead"
    skipped = cells(module_row(skipped_by="exe_sim"))
    assert skipped["mode"].plain == "skipped: exe_sim SIMU"
    assert str(skipped["command"].style) == "grey50"
    blank = monitor.Monitor.cells(SimpleNamespace(last_rule={}), "arm", "", {})  # type: ignore[arg-type]
    assert {k: v.plain for k, v in blank.items()} == {
        "module": "arm",
        "command": "?",
        "cnum": "?",
        "status": "stale",
        "snum": "?",
        "state": "?",
        "rule": "-",
        "mode": "? ? ?",
        "cycle": "?/?/?",
        "beat": "dead",
    }
    assert {str(v.style) for v in blank.values()} == {"grey50"}
    unknown = cells(module_row(status="IDLE"))
    assert {str(v.style) for v in unknown.values()} == {""}


def test_a_world_field_shows_stale_forced_and_safe_values_apart() -> None:
    cells = monitor.Monitor.world_cells

    def seen(*args: Any) -> list[tuple[str, str]]:
        row = cells(None, *args)  # type: ignore[arg-type]
        return [(row[k].plain, str(row[k].style)) for k in monitor.WORLD_COLUMNS]

    assert seen("x", True) == [("x", ""), ("true", ""), ("", "")]
    assert seen("x", None) == [("x", "grey50"), ("stale", "grey50"), ("", "")]
    assert seen("x", 2.5, "FORCED") == [
        ("x", "bold magenta"),
        ("2.5", "bold magenta"),
        ("FORCED", "bold magenta"),
    ]
    assert seen("x", 2.5, "SAFE", "writer dead") == [
        ("x", "grey50"),
        ("2.5 (stale: writer dead)", "grey50"),
        ("SAFE", "bold magenta"),
    ]


def test_overrides_stale_fields_and_requests_are_drawn_from_the_snapshot(
    cell: ModuleType,
) -> None:
    got: dict[str, Any] = {}
    requests = [
        {"by": "sup", "name": "arm_x", "doc": "place the part"},
        {
            "by": "exe",
            "name": "weigh",
            "operator": "op",
            "task": "WEIGH",
            "doc": "weigh it",
            "reasons": [],
        },
    ]

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        console.shot = snapshot(
            overrides={"arm_x": {"state": "FORCED"}},
            stale={"arm_speed": "no writer"},
            requests=requests,
        )
        app.refresh_rows()
        world = app.query_one("#world", DataTable)
        got["x"] = [cell_text(world, "arm_x", k).plain for k in monitor.WORLD_COLUMNS]
        got["speed"] = cell_text(world, "arm_speed", "value").plain
        got["asks"] = static_text(app, "#requests")

    on_screen(cell, look)
    assert got["x"] == ["arm_x", "1.5", "FORCED"]
    assert got["speed"] == "0.0 (stale: no writer)"
    assert got["asks"] == (
        "sup asks: place the part (a: answer arm_x)\nexe asks op: WEIGH: weigh it (a: answer weigh)"
    )


def test_an_unreadable_segment_is_said_in_red_and_cleared_when_readable(cell: ModuleType) -> None:
    got: list[tuple[str, str]] = []

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        console.shot = OSError("gone")
        app.refresh_rows()
        got.append((said(app).plain, str(said(app).style)))
        console.shot = snapshot()
        app.refresh_rows()
        got.append((said(app).plain, str(said(app).style)))

    on_screen(cell, look)
    assert got == [
        ("cannot read seg_cellseg: gone; showing the last values", "bold red"),
        ("", ""),
    ]


def test_a_cell_is_redrawn_only_when_its_text_or_colour_changes(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        table = app.query_one("#modules", DataTable)
        updates: list[tuple[str, str, bool]] = []
        original = table.update_cell

        def update_cell(row: Any, column: Any, value: Any, *, update_width: bool = False) -> None:
            updates.append((str(row), str(column), update_width))
            original(row, column, value, update_width=update_width)

        table.update_cell = update_cell  # type: ignore[method-assign]
        app.refresh_rows()
        got["same"] = list(updates)
        rows = dict(snapshot()["modules"])
        rows["arm"] = module_row(state="S10")  # wider: the column grows
        console.shot = snapshot(modules=rows)
        app.refresh_rows()
        rows["arm"] = module_row(state="S2")  # as wide as the widest yet: no measuring
        console.shot = snapshot(modules=rows)
        app.refresh_rows()
        rows["arm"] = module_row(state="S2", status="DONE")  # the colour of every cell
        console.shot = snapshot(modules=rows)
        app.refresh_rows()
        got["changed"] = updates[len(got["same"]) :]

    on_screen(cell, look)
    assert got["same"] == []
    assert got["changed"][:2] == [("arm", "state", True), ("arm", "state", False)]
    assert len(got["changed"]) == 2 + len(monitor.COLUMNS)
    assert {c for _, c, _ in got["changed"][2:]} == {k for k, _ in monitor.COLUMNS}


# ------------------------------------------------------------ keys


def test_each_key_asks_the_console_for_the_selected_module_and_says_so(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def keys(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        messages = []
        await pilot.press("down")  # pln
        for key in ("s", "r", "n", "i", "down i", "plus", "minus", "equals_sign"):
            await pilot.press(*key.split())
            messages.append(said(app).plain)
        console.slows = {"cell": {"slow": 1.0}}
        await pilot.press("minus")  # never faster than real time
        messages.append(said(app).plain)
        console.slows = {}
        await pilot.press("plus")  # no process read: from real time
        messages.append(said(app).plain)
        got["messages"] = messages
        got["calls"] = [c for c in console.calls if c[0] != "snapshot"]

    on_screen(cell, keys)
    assert got["messages"] == [
        "pln: STOP",
        "pln: RUN AUTO",
        "pln: stepped one cycle (SINGLE)",
        "pln: REAL",
        "exe: SIMU",
        "slow x8",
        "slow x2",
        "slow x8",
        "slow x1",
        "slow x2",
    ]
    assert got["calls"] == [
        ("set_mode", "pln", (("dont_run", True),)),
        ("set_mode", "pln", (("dont_run", False), ("single_step", False))),
        ("step", "pln", 1),
        ("simulate", "pln", False),
        ("simulate", "exe", True),
        ("slow", 8.0),
        ("slow", 2.0),
        ("slow", 8.0),
        ("slow", 1.0),
        ("slow", 2.0),
    ]


def test_a_refused_key_is_said_in_red_and_nothing_is_redrawn(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def keys(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        console.refuse = "role op may not stop sup"
        before = len(console.calls)
        await pilot.press("s")
        got["said"] = (said(app).plain, str(said(app).style))
        got["calls"] = console.calls[before:]

    on_screen(cell, keys)
    assert got["said"] == ("role op may not stop sup", "bold red")
    assert got["calls"] == [("set_mode", "sup", (("dont_run", True),))]  # no snapshot after


def test_the_send_form_lists_the_commands_and_sends_what_is_typed(cell: ModuleType) -> None:
    got: dict[str, Any] = {}

    async def send(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        form = app.query_one("#send", Input)
        await pilot.press("c")
        got["placeholder"] = form.placeholder
        got["open"] = form.has_class("open") and form.has_focus
        for typed in ("RUN moves=3", "RUN moves=4 --override", "", "RUN moves=x", "HALT"):
            form.value = typed  # typed into the form `c` opened for sup, then enter
            app.on_input_submitted(Input.Submitted(form, typed))
            got.setdefault("said", []).append((said(app).plain, str(said(app).style)))
        got["closed"] = not form.has_class("open")
        got["sent"] = [c for c in console.calls if c[0] == "send"]
        await pilot.press("down", "down", "down", "c")  # arm: no parameters at all
        got["arm"] = form.placeholder
        await pilot.press("escape")
        got["escaped"] = not form.has_class("open") and app.query_one("#modules").has_focus

    on_screen(cell, send)
    assert got["placeholder"] == (
        "sup: COMMAND NAME=VALUE ... [--override]  commands: INIT, HALT, RUN moves="
    )
    assert got["open"] and got["closed"] and got["escaped"]
    assert got["arm"] == "arm: COMMAND NAME=VALUE ... [--override]  commands: INIT, HALT"
    assert got["said"] == [
        ("sent sup.RUN moves=3 #7", ""),
        ("note: sup is in STOP; sent sup.RUN moves=4 #7", ""),
        ("no command given", "bold red"),
        ("sup.RUN: parameter moves is 'x', not a whole number (64-bit)", "bold red"),
        ("sent sup.HALT #7", ""),
    ]
    assert got["sent"] == [
        ("send", "sup.RUN moves=3", False),
        ("send", "sup.RUN moves=4", True),
        ("send", "sup.HALT", False),
    ]


def test_a_request_is_answered_at_once_or_through_the_task_form(cell: ModuleType) -> None:
    got: dict[str, Any] = {}
    field = {"by": "sup", "name": "arm_x", "doc": "place the part"}
    task = {
        "by": "exe",
        "name": "weigh",
        "operator": "op",
        "task": "WEIGH",
        "doc": "weigh it",
        "reasons": ["EMPTY", "JAMMED"],
        "results": {"grams": 0},
    }

    async def answer(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        form = app.query_one("#send", Input)
        await pilot.press("a")
        got["none"] = (said(app).plain, str(said(app).style))
        console.shot = snapshot(requests=[field, task])
        app.refresh_rows()
        await pilot.press("a")  # sup selected: its own request, a world field's
        got["field"] = said(app).plain
        await pilot.press("down", "down", "a")  # exe: its task, through the form
        got["placeholder"], got["value"] = form.placeholder, form.value
        for typed in ("DONE grams=12 ok=yes", "ERROR JAMMED", "ERROR", "DONE grams", "ERROR A B"):
            app.answering = "weigh"  # the form `a` opened for exe's task, typed into, enter
            form.value = typed
            app.on_input_submitted(Input.Submitted(form, typed))
            got.setdefault("said", []).append(said(app).plain)
        got["closed"] = not form.has_class("open")  # each answer, right or wrong, closes it
        got["wrong"] = str(said(app).style)  # the last one typed was wrong: said in red
        await pilot.press("down", "a")  # arm asks nothing: the first request open
        got["first"] = said(app).plain
        console.shot = snapshot(requests=[dict(task, reasons=[], results={})])
        app.refresh_rows()
        await pilot.press("a")
        got["bare"] = form.placeholder
        got["calls"] = [c for c in console.calls if c[0].startswith("answer")]

    on_screen(cell, answer)
    assert got["none"] == ("no module is asking anything", "bold red")
    assert got["field"] == "answered arm_x: sent DONE #4"
    assert (
        got["placeholder"] == "weigh WEIGH: DONE grams=0 | ERROR [REASON]  reasons: EMPTY, JAMMED"
    )
    assert got["value"] == "DONE" and got["closed"] and got["wrong"] == "bold red"
    wrong = "answer weigh with DONE [NAME=VALUE ...] or ERROR [REASON]"
    assert got["said"] == [
        "answered weigh: weigh #5 DONE grams=12 ok=yes",
        "answered weigh: weigh #5 ERROR (JAMMED)",
        "answered weigh: weigh #5 ERROR",
        wrong,
        wrong,
    ]
    assert got["first"] == "answered arm_x: sent DONE #4"
    assert got["bare"] == "weigh WEIGH: DONE | ERROR [REASON]  reasons: none"
    assert got["calls"] == [
        ("answer", "arm_x"),
        ("answer_channel", "weigh", "DONE", "", (("grams", "12"), ("ok", "yes"))),
        ("answer_channel", "weigh", "ERROR", "JAMMED", ()),
        ("answer_channel", "weigh", "ERROR", "", ()),
        ("answer", "arm_x"),
    ]


def test_closing_the_screen_stops_its_refresh_and_closes_the_console(cell: ModuleType) -> None:
    held: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        held["app"] = app
        await pilot.press("q")
        held["code"] = app.return_code

    console = on_screen(cell, look)
    assert held["code"] == 0  # `q`: the screen ends
    before = len(console.calls)
    held["app"].refresh_rows()  # after unmount: reads nothing
    assert console.calls[before - 1] == ("close",) and len(console.calls) == before


# ------------------------------------------------------------ the rows panels


def test_a_state_time_row_ranks_the_states_and_bolds_the_one_it_is_in() -> None:
    row = {
        "state": "S1",
        "state_cycles": 1000,
        "time_in_state": {"NOP": 5.0, "S1": 80.0, "S0": 15.0},
    }
    cells = monitor_state_time.row_of("sup", row)
    assert {k: v.plain for k, v in cells.items()} == {
        "module": "sup",
        "cycles": "1000",
        "states": "S1 80%  S0 15%  NOP 5%",
    }
    states = cells["states"]
    styled = [(states.plain[s.start : s.end], str(s.style)) for s in states.spans]
    assert styled == [("S1 80%", "bold")]  # the others plain
    many = {f"S{i}": float(20 - i) for i in range(9)}  # 20 19 ... 12: six shown, three summed
    crowded = monitor_state_time.row_of("sup", {"time_in_state": many})
    assert crowded["states"].plain == (
        "S0 20%  S1 19%  S2 18%  S3 17%  S4 16%  S5 15%  others 39.0%"
    )
    assert crowded["cycles"].plain == "0"
    assert [str(s.style) for s in crowded["states"].spans][-1] == "grey50"
    none = monitor_state_time.row_of("arm", {"state": "S0"})
    assert {k: v.plain for k, v in none.items()} == {"module": "arm", "cycles": "-", "states": "-"}


def test_the_rows_panels_draw_their_headers_and_only_what_changed(cell: ModuleType) -> None:
    got: dict[str, Any] = {}
    devices = SimpleNamespace(IO_DEVICES={"tank": object()})

    async def run() -> None:
        from textual.app import App, ComposeResult

        class Panels(App[None]):
            def compose(self) -> ComposeResult:
                yield monitor_state_time.StateTimePanel(cell, ["arm", "sup", "ghost"])
                yield monitor_devices.DevicesPanel(devices)  # type: ignore[arg-type]

        app = Panels()
        async with app.run_test(size=(200, 20)) as pilot:
            await pilot.pause()
            states = app.query_one(monitor_state_time.StateTimePanel)
            tank = app.query_one(monitor_devices.DevicesPanel)
            got["state headers"] = [str(c.label) for c in states.columns.values()]
            got["device headers"] = [str(c.label) for c in tank.columns.values()]
            got["names"] = states.names
            got["display"] = [
                (p.cursor_type, p.show_cursor, p.zebra_stripes) for p in (states, tank)
            ]
            got["blank"] = [cell_text(tank, "tank", k).plain for k, _ in monitor_devices.COLUMNS]
            updates: list[tuple[str, str]] = []
            original = states.update_cell

            def update_cell(
                row: Any, column: Any, value: Any, *, update_width: bool = False
            ) -> None:
                updates.append((str(row), str(column)))
                original(row, column, value, update_width=update_width)

            states.update_cell = update_cell  # type: ignore[method-assign]
            shot = {
                "modules": {
                    "sup": {"state": "S0", "state_cycles": 9, "time_in_state": {"S0": 100.0}}
                }
            }
            states.show(shot)
            states.show(shot)
            got["first"] = list(updates)
            shot["modules"]["sup"]["state_cycles"] = 10
            states.show(shot)
            got["then"] = updates[len(got["first"]) :]
            got["sup"] = [cell_text(states, "sup", k).plain for k, _ in monitor_state_time.COLUMNS]

    asyncio.run(run())
    assert got["state headers"] == ["module", "cycles", "% of cycles per state since start"]
    assert got["device headers"] == [
        "device",
        "protocol, address",
        "state",
        "reads",
        "writes",
        "timeouts",
        "retries",
        "errors",
        "last error",
        "answered",
    ]
    # a panel to read, not to act on: no cursor to move, every row on the same background
    assert got["display"] == [("none", False, False)] * 2
    assert got["names"] == ["arm", "sup"]  # in the tree's order, those with a state clock
    assert got["blank"] == ["tank"] + [""] * 9  # not drawn yet: empty, not made up
    assert sorted(got["first"]) == sorted(
        [("arm", "module"), ("arm", "cycles"), ("arm", "states")]
        + [("sup", "module"), ("sup", "cycles"), ("sup", "states")]
    )
    assert got["then"] == [("sup", "cycles")]
    assert got["sup"] == ["sup", "10", "S0 100%"]


def test_a_row_is_coloured_done_green_executing_yellow_error_red_dead_or_skipped_grey() -> None:
    """Every cell of a module's row takes its status's colour; a dead process's modules and
    a module its stand-in replaces are grey whatever their status; the last rule fired stays
    shown through the cycles in which none fires."""
    app = monitor.Monitor.__new__(monitor.Monitor)  # the row's cells alone: no screen needed
    app.last_rule = {}

    def styles(**over: Any) -> set[str]:
        return {str(cell.style) for cell in app.cells("arm", "", module_row(**over)).values()}

    assert styles(status="DONE") == {"green"}
    assert styles(status="EXECUTING") == {"yellow"}
    assert styles(status="ERROR") == {"bold red"}
    assert styles(status="NOP") == {""}
    assert styles(status="DONE", alive=False) == {"grey50"}
    assert styles(status="EXECUTING", skipped_by="cr") == {"grey50"}
    dead = app.cells("arm", "", module_row(alive=False))
    assert dead["beat"].plain == "dead"
    skipped = app.cells("arm", "└─ ", module_row(skipped_by="cr"))
    assert (skipped["module"].plain, skipped["mode"].plain) == ("└─ arm", "skipped: cr SIMU")
    assert app.cells("arm", "", module_row(rule="S1/3"))["rule"].plain == "S1/3"
    assert app.cells("arm", "", module_row(rule=None))["rule"].plain == "S1/3"
    assert app.cells("exe", "", module_row(rule=None))["rule"].plain == "-"
    failed = app.cells("arm", "", module_row(status="ERROR", reason="BLOCKED", cause="jam"))
    assert failed["status"].plain == "ERROR(BLOCKED <- jam)"


def test_the_periodicity_panel_draws_each_process_and_a_missing_one_as_unknown() -> None:
    """A row per process of the layout: from its control record in the snapshot (its
    slowest module from the modules' own cycle times), '?' in grey when the snapshot has
    none for it (a process not started, or not readable)."""
    from rcsgen.tools.monitor_periodicity import PeriodicityPanel

    panel = PeriodicityPanel.__new__(PeriodicityPanel)  # its rows alone: no screen needed
    panel.names = ["cell", "other"]
    drawn: dict[str, dict[str, Text]] = {}
    panel.draw = lambda name, cells: drawn.__setitem__(name, cells)  # type: ignore[method-assign]
    modules = {"arm": module_row(process="cell", max_cycle_us=95)}
    panel.show(
        {
            "processes": {"cell": {"state": "running", "last_cycle_us": 40, "max_cycle_us": 95}},
            "modules": modules,
        }
    )
    assert {k: c.plain for k, c in drawn["cell"].items()} == {
        "process": "cell",
        "period": "not paced",
        "wakeups": "-",
        "error": "-",
        "lateness": "-",
        "warnings": "-",
        "cycle": "40/95",
        "slowest": "arm (95)",
    }
    assert {c.plain for k, c in drawn["other"].items() if k != "process"} == {"?"}
    assert {str(c.style) for c in drawn["other"].values()} == {"grey50"}
    panel.show({})
    assert drawn["cell"]["period"].plain == "?"


def test_each_table_keeps_its_own_cells_and_column_widths(cell: ModuleType) -> None:
    """Two tables with a row and a column of one key: each draws its own cell (the same
    text drawn in one is still drawn in the other), and each column grows to its own widest
    value, however wide the other table's column of that key is."""
    got: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        tables = [app.query_one(f"#{name}", DataTable) for name in ("modules", "world")]
        for table in tables:
            table.add_column("x", key="same")
            table.add_row(*[""] * len(table.columns), key="same")
        await pilot.pause()  # the new row measured: from here only a wider cell grows it
        for table in tables:
            app.update(table, "same", "same", Text("wider than the other"))
        await pilot.pause()
        got["cells"] = [cell_text(table, "same", "same").plain for table in tables]
        got["widths"] = [table.columns[ColumnKey("same")].content_width for table in tables]

    on_screen(cell, look)
    assert got["cells"] == ["wider than the other"] * 2
    assert got["widths"] == [len("wider than the other")] * 2


def test_a_device_with_no_record_shows_what_it_cannot_know_as_unknown() -> None:
    """A device whose record says nothing (not started, or unreadable): `?` in every cell
    read from the record, `never` answered; its name as given."""
    cells = {key: value.plain for key, value in monitor_devices.row_of("tank", {}).items()}
    assert cells == {
        "device": "tank",
        "where": "? ?",
        "state": "?",
        "reads": "?",
        "writes": "?",
        "timeouts": "?",
        "retries": "?",
        "errors": "?",
        "last_error": "?",
        "answered": "never",
    }


def test_a_module_row_has_a_cell_under_each_header_an_operator_reads() -> None:
    """The modules table's columns, in order, as their headers read, each one of a row's
    cells; the world table's likewise (no screen needed)."""
    app = monitor.Monitor.__new__(monitor.Monitor)
    app.last_rule = {}
    assert " | ".join(label for _, label in monitor.COLUMNS) == (
        "module | command | # | status | # | state | last rule fired | mode "
        "| cycle us last/min/max | beat"
    )
    assert [key for key, _ in monitor.COLUMNS] == list(app.cells("arm", "", module_row()))
    world = ["field", "value", "override"]
    assert list(monitor.WORLD_COLUMNS) == list(app.world_cells("arm_x", 1.5)) == world


def test_the_periodicity_panels_headers_say_what_each_figure_is_and_its_unit() -> None:
    """The periodicity panel's columns, in order, as their headers read, each one of a
    process row's cells (no screen needed)."""
    from rcsgen.tools import monitor_periodicity

    assert " | ".join(label for _, label in monitor_periodicity.COLUMNS) == (
        "process | period | wake-ups | period error mean/max us | lateness p99/max us "
        "| warnings | cycle last/max us | slowest module (max us)"
    )
    cells = monitor_periodicity.row_of("cell", {"state": "running"}, None)
    assert [key for key, _ in monitor_periodicity.COLUMNS] == list(cells)


def test_a_segment_unreadable_from_the_start_shows_each_module_with_blank_cells(
    cell: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Nothing read yet: each module's row is its name and a blank under every other header
    (never a `None` a person would take for a value), the world table likewise empty."""
    got: dict[str, Any] = {}

    async def look(app: monitor.Monitor, console: FakeConsole, pilot: Any) -> None:
        table = app.query_one("#modules", DataTable)
        got["said"] = said(app).plain
        got["arm"] = [cell_text(table, "arm", k).plain for k, _ in monitor.COLUMNS]

    module = sys.modules[__name__]
    monkeypatch.setattr(module, "snapshot", lambda: OSError("not there yet"))
    on_screen(cell, look)
    assert got["said"] == "cannot read seg_cellseg: not there yet; showing the last values"
    assert got["arm"] == ["arm"] + [""] * (len(monitor.COLUMNS) - 1)
