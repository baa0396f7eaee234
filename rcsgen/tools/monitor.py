"""Monitor: a running system's segment -> a live terminal screen of its hierarchy (textual).

The debug screen of the mining paper and the RCS diagnostics tools' hierarchy view in one:
every module as a row of a tree (supervisor above subordinate), with its command and
number, status and number, state, the last rule that fired, RUN/STOP SINGLE/AUTO SIMU/REAL,
cycle times and its process's heartbeat, coloured by status (done green, executing yellow,
error red, a dead or silent process grey). Keys act on the selected module through the
runtime's console (`rcsgen.runtime.operate.ctl.Console`): it reads with consistent reads and writes
only mode, pacing and command buffers, so it never blocks a controller; the operator's role
(`--role`) decides what the keys may do, and a refusal is shown, not a crash. What the
modules ask of the operator is shown under the table; `a` answers it. A system with
fieldbus devices gets a panel of them (monitor_devices.py); every system a panel of how
well each process holds its period (monitor_periodicity.py), and one of each controller's
time per state since start (monitor_state_time.py). textual is an
optional extra (`pip install rcsgen[monitor]`), imported only here.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding
from textual.css.query import NoMatches
from textual.widgets import DataTable, Footer, Input, Static

from ..runtime import contract
from ..runtime.operate.command import Command, parse_command
from ..runtime.operate.command import shown as shown_value
from ..runtime.operate.ctl import Console, CtlError
from .monitor_devices import DevicesPanel
from .monitor_periodicity import PeriodicityPanel
from .monitor_state_time import StateTimePanel

COLOURS = {"DONE": "green", "EXECUTING": "yellow", "ERROR": "bold red"}
WORLD_COLUMNS = ("field", "value", "override")
COLUMNS = (
    ("module", "module"),
    ("command", "command"),
    ("cnum", "#"),
    ("status", "status"),
    ("snum", "#"),
    ("state", "state"),
    ("rule", "last rule fired"),
    ("mode", "mode"),
    ("cycle", "cycle us last/min/max"),
    ("beat", "beat"),
)


def tree_order(layout: ModuleType) -> list[tuple[str, str]]:
    """Every module with its tree prefix, depth first from the roots, in layout order."""
    subordinates = {
        m: [s for s in layout.SUBORDINATES.get(m, ()) if s in layout.COMMAND_IN]
        for m in layout.MODULES
    }
    below = {s for subs in subordinates.values() for s in subs}
    rows: list[tuple[str, str]] = []

    def visit(module: str, prefix: str, last: bool, root: bool) -> None:
        rows.append((module, "" if root else prefix + ("└─ " if last else "├─ ")))
        inner = "" if root else prefix + ("   " if last else "│  ")
        subs = subordinates[module]
        for i, sub in enumerate(subs):
            visit(sub, inner, i == len(subs) - 1, False)

    for module in layout.MODULES:
        if module not in below:
            visit(module, "", True, True)
    return rows


class Monitor(App[None]):
    """The live screen over `Console(layout, segment)`."""

    TITLE = "rcsgen monitor"
    CSS = """
    DataTable { height: 1fr; }
    #world { height: auto; max-height: 12; }
    #devices { height: auto; max-height: 8; }
    #periodicity { height: auto; max-height: 10; }
    #state_time { height: auto; max-height: 12; }
    #processes { height: auto; color: $text-muted; }
    #requests { height: auto; color: $warning; text-style: bold; }
    #message { height: auto; }
    #send { display: none; }
    #send.open { display: block; }
    """
    BINDINGS = [
        Binding("s", "stop", "stop"),
        Binding("r", "run", "run"),
        Binding("n", "step", "step"),
        Binding("i", "simulate", "simulate"),
        Binding("plus,equals_sign", "slower", "slower"),
        Binding("minus", "faster", "faster"),
        Binding("c", "send", "send command"),
        Binding("a", "answer", "answer request"),
        Binding("escape", "close_send", "close form", show=False),
        Binding("q", "quit", "quit"),
    ]

    def __init__(
        self,
        layout: ModuleType,
        segment: str,
        interval: float = 0.25,
        role: str | None = None,
        connect: tuple[str, ...] = (),
        world: tuple[str, ...] | None = None,
    ) -> None:
        super().__init__()
        self.layout, self.interval = layout, interval
        # CtlError, BlockError, TransportError: the caller reports it. `connect`: through Zenoh.
        self.ctl = Console(layout, segment, role, connect)
        self.segment = self.ctl.segment
        self.open_requests: list[dict[str, Any]] = []
        self.closed = False
        self.rows = tree_order(layout)
        self.last_rule: dict[str, str] = {}
        # The world fields shown under the modules: those named, else every one (a misspelt
        # name is a CtlError, reported by the caller).
        self.world_fields = self.ctl.world_names(world) if world else list(layout.WORLD)
        self.unreadable = ""  # why the last refresh could not read the segment, if it could not
        self.drawn: dict[tuple[str, str, str], tuple[str, str]] = {}  # each cell as drawn
        self.widths: dict[tuple[str, str], int] = {}  # each column's widest value so far

    def compose(self) -> ComposeResult:
        yield DataTable(id="modules", cursor_type="row", zebra_stripes=False)
        yield DataTable(id="world", cursor_type="none", zebra_stripes=False, show_cursor=False)
        if getattr(self.layout, "IO_DEVICES", None):  # fieldbus devices: their own panel
            yield DevicesPanel(self.layout)
        yield PeriodicityPanel(self.layout)
        yield StateTimePanel(self.layout, [module for module, _ in self.rows])
        yield Static(id="processes")
        yield Static(id="requests")
        yield Static(id="message")
        yield Input(id="send", placeholder="COMMAND name=value ... [--override]")
        yield Footer()

    def on_mount(self) -> None:
        role = self.ctl.access.role
        who = f" as {role}" if role else (" (monitor only)" if self.ctl.access.roles else "")
        self.sub_title = f"{self.layout.SYSTEM} on {self.segment}{who}"
        table = self.query_one("#modules", DataTable)
        for key, label in COLUMNS:
            table.add_column(label, key=key)
        for module, prefix in self.rows:
            table.add_row(*([prefix + module] + [""] * (len(COLUMNS) - 1)), key=module)
        world = self.query_one("#world", DataTable)
        for key in WORLD_COLUMNS:
            world.add_column(key, key=key)
        for name in self.world_fields:
            world.add_row(name, "", "", key=name)
        self.refresh_rows()
        self.timer = self.set_interval(self.interval, self.refresh_rows)

    def on_unmount(self) -> None:
        self.timer.stop()  # no refresh may run on a closed segment or a torn-down screen
        self.closed = True
        self.ctl.close()

    # ------------------------------------------------------------ the screen

    def refresh_rows(self) -> None:
        """Read the segment and redraw. Never raises: a read that stays torn shows as
        `stale`, and a segment that cannot be read at all is said under the table."""
        if self.closed:
            return
        try:
            snapshot = self.ctl.snapshot(self.world_fields)
        except Exception as error:  # the segment went away, or a record stayed unreadable
            self.unreadable = f"cannot read {self.segment}: {error}; showing the last values"
            self.say(self.unreadable, error=True)
            return
        if self.unreadable:  # readable again
            self.unreadable = ""
            self.say("")
        try:
            table = self.query_one("#modules", DataTable)
            world = self.query_one("#world", DataTable)
            processes = self.query_one("#processes", Static)
            requests = self.query_one("#requests", Static)
        except NoMatches:  # the app is shutting down: its widgets are gone
            return
        for module, prefix in self.rows:
            row = snapshot["modules"][module]
            for key, value in self.cells(module, prefix, row).items():
                self.update(table, module, key, value)
        held, stale = snapshot.get("overrides") or {}, snapshot.get("stale") or {}
        for name, value in snapshot["world"].items():
            state = held.get(name, {}).get("state", "")
            for key, cell in self.world_cells(name, value, state, stale.get(name, "")).items():
                self.update(world, name, key, cell)
        lines = []
        for name, proc in snapshot["processes"].items():
            age = proc.get("heartbeat_age_s")
            lines.append(
                f"{name}: {str(proc.get('state', '?')).lower()}, {proc.get('heartbeat')} cycles, "
                f"beat {'-' if age is None else f'{age:.2f}s'} ago, {proc.get('overruns')} "
                f"overruns, slow x{proc.get('slow', 1.0):g}"
            )
        processes.update("   ".join(lines))
        for panel in self.query(DevicesPanel):
            panel.show(snapshot.get("io") or {})
        for timing in self.query(PeriodicityPanel):
            timing.show(snapshot)
        for states in self.query(StateTimePanel):
            states.show(snapshot)
        self.open_requests = snapshot["requests"]
        asks = [
            f"{r['by']} asks {r['operator']}: {r['task']}: {r['doc']} (a: answer {r['name']})"
            if "task" in r
            else f"{r['by']} asks: {r['doc']} (a: answer {r['name']})"
            for r in self.open_requests
        ]
        requests.update("\n".join(asks))

    def update(self, table: DataTable[Any], row: str, column: str, value: Text) -> None:
        """Change a cell whose text or colour changed (only those: a redraw costs). Its
        column grows to its widest value, so nothing is cut (`EXECUT`, `#1` of #11)."""
        key = (table.id or "", row, column)
        seen = (value.plain, str(value.style))
        if self.drawn.get(key) == seen:
            return
        self.drawn[key] = seen
        width = (table.id or "", column)
        wider = value.cell_len > self.widths.get(width, 0)  # only then are widths measured again
        self.widths[width] = max(self.widths.get(width, 0), value.cell_len)
        table.update_cell(row, column, value, update_width=wider)

    def world_cells(
        self, name: str, value: Any, state: str = "", stale: str = ""
    ) -> dict[str, Text]:
        """A world field's row: its name, its value now (`stale` when unreadable; grey and
        `(stale: why)` while nothing keeps it current, `Console.stale`) and its override:
        FORCED (an operator's `ctl force`) or SAFE (latched at its safe value)."""
        shown = "stale" if value is None else shown_value(value)
        if stale:
            shown += f" (stale: {stale})"
        style = "grey50" if value is None or stale else ("bold magenta" if state else "")
        return {
            "field": Text(name, style=style),
            "value": Text(shown, style=style),
            "override": Text(state, style="bold magenta" if state else ""),
        }

    def cells(self, module: str, prefix: str, row: dict[str, Any]) -> dict[str, Text]:
        rule = row.get("rule")
        if rule:
            self.last_rule[module] = rule
        if not row.get("alive") or row.get("skipped_by"):
            style = "grey50"
        else:
            style = COLOURS.get(str(row.get("status")), "")
        times = "/".join(str(row.get(f"{k}_cycle_us", "?")) for k in ("last", "min", "max"))
        age = row.get("heartbeat_age_s")
        status = contract.status_text(
            str(row.get("status", "stale")), row.get("reason"), str(row.get("cause", ""))
        )
        values = {
            "module": prefix + module,
            "command": str(row.get("command", "?")),
            "cnum": str(row.get("command_num", "?")),
            "status": status,
            "snum": str(row.get("status_num", "?")),
            "state": str(row.get("state", "?")),
            "rule": self.last_rule.get(module, "-"),
            "mode": f"skipped: {row['skipped_by']} SIMU"
            if row.get("skipped_by")
            else f"{row.get('run', '?')} {row.get('step', '?')} {row.get('sim', '?')}",
            "cycle": times,
            "beat": "dead" if not row.get("alive") or age is None else f"{age:.2f}s",
        }
        return {key: Text(value, style=style) for key, value in values.items()}

    def selected(self) -> str:
        table = self.query_one("#modules", DataTable)
        key = table.coordinate_to_cell_key(table.cursor_coordinate).row_key.value
        return str(key)

    def say(self, text: str, error: bool = False) -> None:
        self.query_one("#message", Static).update(Text(text, style="bold red" if error else ""))

    def act(self, what: str, action: Any) -> None:
        """Run `action` through the console: say `what` (or the text the action returns)
        and refresh, or say why the console refused."""
        try:
            said = action()
        except CtlError as error:
            self.say(str(error), error=True)
            return
        self.say(said if isinstance(said, str) else what)
        self.refresh_rows()

    # ------------------------------------------------------------ keys

    def action_stop(self) -> None:
        module = self.selected()
        self.act(f"{module}: STOP", lambda: self.ctl.set_mode(module, dont_run=True))

    def action_run(self) -> None:
        module = self.selected()
        self.act(
            f"{module}: RUN AUTO",
            lambda: self.ctl.set_mode(module, dont_run=False, single_step=False),
        )

    def action_step(self) -> None:
        module = self.selected()
        self.act(f"{module}: stepped one cycle (SINGLE)", lambda: self.ctl.step(module, 1))

    def action_simulate(self) -> None:
        module = self.selected()
        on = self.ctl.modules()[module].get("sim") != "SIMU"
        self.act(f"{module}: {'SIMU' if on else 'REAL'}", lambda: self.ctl.simulate(module, on))

    def _slow(self, factor: float) -> None:
        now = max([p.get("slow", 1.0) for p in self.ctl.processes().values()] or [1.0])
        target = max(1.0, now * factor)
        self.act(f"slow x{target:g}", lambda: self.ctl.slow(target))

    def action_slower(self) -> None:
        self._slow(2.0)

    def action_faster(self) -> None:
        self._slow(0.5)

    def action_send(self) -> None:
        module = self.selected()
        form = self.query_one("#send", Input)
        form.add_class("open")
        takes = self.layout.PARAMS.get(module, {})
        commands = ", ".join(
            " ".join([name, *(f"{p}=" for p in takes.get(name, ()))])
            for name in self.layout.COMMAND_NAMES[module][1:]
        )
        form.placeholder = f"{module}: COMMAND NAME=VALUE ... [--override]  commands: {commands}"
        form.value = ""
        form.focus()
        self.sending = module

    def action_answer(self) -> None:
        """Answer the selected module's request, else the first one open: a world field's
        at once; an operator module's task asks DONE or ERROR [REASON] in the form."""
        if not self.open_requests:
            self.say("no module is asking anything", error=True)
            return
        module = self.selected()
        request = next(
            (r for r in self.open_requests if module in (r["by"], r["name"])),
            self.open_requests[0],
        )
        name = request["name"]
        if "task" in request:  # an operator module's channel: DONE, or ERROR with a reason
            form = self.query_one("#send", Input)
            form.add_class("open")
            reasons = ", ".join(request["reasons"]) or "none"
            results = " ".join(f"{k}={v}" for k, v in (request.get("results") or {}).items())
            done = f"DONE {results}" if results else "DONE"
            form.placeholder = (
                f"{name} {request['task']}: {done} | ERROR [REASON]  reasons: {reasons}"
            )
            form.value = "DONE"
            form.focus()
            self.answering = name
            return

        def answer() -> str:
            sent, number = self.ctl.answer(name)
            return f"answered {name}: sent {sent} #{number}"

        self.act("", answer)

    def _answer(self, name: str, words: list[str]) -> None:
        """The answer form submitted: `DONE [NAME=VALUE ...]` (the task's results), or
        `ERROR [REASON]`; values that do not fit the task are refused in one line."""
        self.action_close_send()
        status = words[0].upper() if words else ""
        given = [w.partition("=") for w in words[1:]]
        if status == "DONE" and all(eq and key for key, eq, _ in given):
            results, reason = {key: value for key, _, value in given}, ""
        elif status == "ERROR" and len(words) <= 2:
            results, reason = {}, words[1] if len(words) == 2 else ""
        else:
            self.say(f"answer {name} with DONE [NAME=VALUE ...] or ERROR [REASON]", error=True)
            return

        def answer() -> str:
            request = self.ctl.answer_channel(name, status, reason, results)
            why = f" ({reason})" if reason else ""
            values = "".join(f" {k}={v}" for k, v in results.items())
            return f"answered {name}: {request['task']} #{request['number']} {status}{why}{values}"

        self.act("", answer)

    def action_close_send(self) -> None:
        form = self.query_one("#send", Input)
        form.remove_class("open")
        self.query_one("#modules", DataTable).focus()

    def on_input_submitted(self, event: Input.Submitted) -> None:
        answering, self.answering = getattr(self, "answering", None), None
        if answering is not None:
            self._answer(answering, event.value.split())
            return
        module = getattr(self, "sending", self.selected())
        words = event.value.split()
        override = "--override" in words
        words = [w for w in words if w != "--override"]
        self.action_close_send()
        if not words:
            self.say("no command given", error=True)
            return
        try:
            command: Command = parse_command(self.layout, module, words[0], words[1:])
        except ValueError as error:
            self.say(str(error), error=True)
            return

        def send() -> str:
            number, notes = self.ctl.send(command, override)
            return "; ".join([*notes, f"sent {command} #{number}"])

        self.act("", send)
