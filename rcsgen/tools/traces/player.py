"""The replay pages' common part (`rcsgen trace mine`, `trace sea`, `trace station`): one shell
(assets/replay_shell.html) with the header, play/pause, a cycle back and on, the speed, the
cycle slider, the clock, the keys, a script error shown on the page,
`#cycle=N` and `#play` in the address, the HUD's table style and the data, and each view's
own asset: a `<style>` block, its body (with `{{NAME}}` slots the view fills, its SVG) and
a `<script>` block that defines `frame(i)`, drawing cycle index i from `D`, the data.
"""

from __future__ import annotations

import html
import json
from importlib import resources
from typing import Any

from .read import Trace
from .view import StringTable, runs

SHELL = "replay_shell.html"


def panel(trace: Trace, names: tuple[str, ...], table: StringTable) -> list[dict[str, Any]]:
    """The HUD's controllers (those of `names` the trace has), each its command, state and
    status as runs of the page's string table."""
    return [
        {
            "module": name,
            **{
                key: runs(trace.columns[name][key], None, table)
                for key in ("command", "state", "status")
            },
        }
        for name in names
        if name in trace.columns
    ]


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath("assets", name).read_text("utf-8")


def _block(text: str, tag: str) -> tuple[str, str]:
    """The inside of the asset's one `<tag>` block, and the asset without it."""
    start, end = text.index(f"<{tag}>"), text.index(f"</{tag}>")
    return text[start + len(tag) + 2 : end].strip("\n"), text[:start] + text[end + len(tag) + 3 :]


def page(view: str, title: str, fills: dict[str, str], data: dict[str, Any]) -> str:
    """The replay page of `view` (its asset assets/<view>_view.html): `title`, the body's
    slots filled from `fills`, `data` as the page's JSON (sorted, no NaN, safe in a script)."""
    asset = _asset(f"{view}_view.html")
    style, rest = _block(asset, "style")
    script, body = _block(rest, "script")
    body = body[body.index("-->") + 3 :] if body.lstrip().startswith("<!--") else body
    for name, value in fills.items():
        body = body.replace("{{" + name + "}}", value)
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    parts = {
        "{{VIEW}}": view,
        "{{TITLE}}": html.escape(title),
        "{{STYLE}}": style,
        "{{BODY}}": body.strip("\n"),
        "{{SCRIPT}}": script,
    }
    out = _asset(SHELL)
    for slot, value in parts.items():
        out = out.replace(slot, value)
    return out.replace("{{DATA}}", text.replace("</", "<\\/"))
