"""Headless Chromium, from the distribution's packages, driven through its command line.

`load(url)` runs the page twice: once dumping the DOM after the page's scripts ran (with
every console message Chromium logged), once taking a screenshot. Virtual time lets the
scripts (and animations) run without waiting. Without Chromium the tests that need it are
skipped with a line saying how to install it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

CHROMIUM = next(
    (found for name in ("chromium", "chromium-browser") if (found := shutil.which(name))), None
)
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None,
    reason="Chromium is not installed: apt-get install chromium (the browser tests load "
    "the HTML pages in it)",
)
FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-extensions",
    "--hide-scrollbars",
)


@dataclass
class Page:
    dom: str
    console: list[str]  # every console message the page logged (errors included)
    screenshot: Path | None

    def body(self) -> dict[str, str]:
        """The attributes of <body>: the pages report their state there."""
        tag = re.search(r"<body([^>]*)>", self.dom)
        assert tag is not None, self.dom[:500]
        return dict(re.findall(r'([\w-]+)="([^"]*)"', tag.group(1)))


def load(
    url: str,
    artifacts: Path,
    name: str,
    size: tuple[int, int] = (1400, 900),
    budget_ms: int = 3000,
    screenshot: bool = True,
) -> Page:
    """The page after `budget_ms` of virtual time: its DOM, console, and a screenshot saved
    as `<artifacts>/<name>.png`."""
    assert CHROMIUM is not None
    common = [
        CHROMIUM,
        *FLAGS,
        f"--user-data-dir={artifacts / 'chromium-profile'}",
        f"--virtual-time-budget={budget_ms}",
        f"--window-size={size[0]},{size[1]}",
    ]
    dumped = subprocess.run(
        [*common, "--enable-logging=stderr", "--v=0", "--dump-dom", url],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert dumped.returncode == 0, dumped.stderr[-2000:]
    console = [line for line in dumped.stderr.splitlines() if ":CONSOLE" in line]
    if not screenshot:
        return Page(dumped.stdout, console, None)
    shot = artifacts / f"{name}.png"
    taken = subprocess.run(
        [*common, f"--screenshot={shot}", url],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert taken.returncode == 0 and shot.is_file(), taken.stderr[-2000:]
    return Page(dumped.stdout, console, shot)
