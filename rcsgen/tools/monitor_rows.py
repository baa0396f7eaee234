"""A monitor panel of one row per named thing (a device, a process): its columns declared
once, each cell redrawn only when its text or style changed (the refresh runs several times
a second; textual re-lays a table on every update_cell)."""

from __future__ import annotations

from rich.text import Text
from textual.widgets import DataTable


class RowsPanel(DataTable[Text]):
    """Rows keyed by `names`, columns by `columns` ((key, label), the first the name's)."""

    def __init__(self, panel_id: str, names: list[str], columns: tuple[tuple[str, str], ...]):
        super().__init__(id=panel_id, cursor_type="none", show_cursor=False, zebra_stripes=False)
        self.names, self.columns_declared = names, columns
        self.drawn: dict[tuple[str, str], str] = {}

    def on_mount(self) -> None:
        for key, label in self.columns_declared:
            self.add_column(label, key=key)
        for name in self.names:
            self.add_row(*(Text(name), *(Text("") for _ in self.columns_declared[1:])), key=name)

    def draw(self, name: str, cells: dict[str, Text]) -> None:
        """`name`'s row: each cell whose text or style is not what is on screen."""
        for key, cell in cells.items():
            drawn = f"{cell.plain}|{cell.style}"
            if self.drawn.get((name, key)) != drawn:
                self.drawn[(name, key)] = drawn
                self.update_cell(name, key, cell, update_width=True)
