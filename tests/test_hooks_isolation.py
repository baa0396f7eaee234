"""Two copies of a spec directory never share hook modules (rcsgen/tools/harness.py
`_use_hooks_from`), in the unit tier: a hook module or package of the same name imported
from another directory is forgotten, so the next import takes this directory's; one that
came from this directory stays imported; the directory is first on the path, once."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

from rcsgen.tools.harness import _use_hooks_from


def spec_copy(root: Path, which: str, top: str, pkg: str) -> Path:
    folder = root / which
    (folder / pkg).mkdir(parents=True)
    (folder / f"{top}.py").write_text(f"WHICH = {which!r}\n")
    (folder / pkg / "__init__.py").write_text(f"WHICH = {which!r}\n")
    (folder / pkg / "part.py").write_text(f"WHICH = {which!r}\n")
    return folder


def test_the_hooks_of_another_copy_are_forgotten_and_this_ones_kept(tmp_path: Path) -> None:
    top, pkg = f"hk_{tmp_path.name}", f"hkp_{tmp_path.name}"
    one = spec_copy(tmp_path, "one", top, pkg)
    two = spec_copy(tmp_path, "two", top, pkg)
    saved = list(sys.path)
    try:
        _use_hooks_from(one)
        assert importlib.import_module(top).WHICH == "one"
        assert importlib.import_module(f"{pkg}.part").WHICH == "one"
        first = sys.modules[top]
        _use_hooks_from(one)  # again: nothing of its own is forgotten, the path holds it once
        assert sys.modules[top] is first and sys.path.count(str(one)) == 1
        _use_hooks_from(two)
        assert top not in sys.modules and pkg not in sys.modules
        assert f"{pkg}.part" not in sys.modules
        assert sys.path[0] == str(two)
        assert importlib.import_module(top).WHICH == "two"
        assert importlib.import_module(f"{pkg}.part").WHICH == "two"
    finally:
        sys.path[:] = saved
        for name in [m for m in sys.modules if m.split(".")[0] in (top, pkg)]:
            del sys.modules[name]
