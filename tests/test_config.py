"""`[tool.rcsgen]` read directly (rcsgen/tools/config.py): which pyproject.toml applies, what a
configuration holds, and each misuse as one message naming the file. tests/test_report.py
runs the same through the command line."""

from __future__ import annotations

from pathlib import Path

import pytest

from rcsgen.tools import config


def pyproject(directory: Path, text: str | bytes) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "pyproject.toml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def test_the_nearest_pyproject_with_the_table_applies(tmp_path: Path) -> None:
    outer = pyproject(tmp_path, '[tool.rcsgen]\nselect = ["W5"]\nstrict = true\n')
    inner = tmp_path / "a" / "b"
    pyproject(tmp_path / "a", '[project]\nname = "no rcsgen table here"\n')
    inner.mkdir()
    assert config.find(inner) == outer  # a pyproject.toml without the table is passed over
    found = config.load(inner)
    assert found == config.Config(outer, ("W5",), (), True, frozenset({"select", "strict"}))
    ignored = pyproject(tmp_path / "a", '[tool.rcsgen]\nignore = ["W503", "W3"]\n')
    assert config.load(inner) == config.Config(
        ignored, (), ("W503", "W3"), None, frozenset({"ignore"})
    )


def test_no_configuration_is_the_empty_one(tmp_path: Path) -> None:
    assert config.find(tmp_path) is None
    assert config.load(tmp_path) == config.Config()
    assert config.Config().strict is None and config.Config().keys == frozenset()
    (tmp_path / "pyproject.toml").mkdir()  # not a file: not a configuration
    assert config.find(tmp_path) is None


def test_the_table_named_only_in_a_comment_configures_nothing(tmp_path: Path) -> None:
    path = pyproject(tmp_path, "# settings for [tool.rcsgen] would go here\n[project]\n")
    assert config.find(tmp_path) == path  # found by its text ...
    assert config.load(tmp_path) == config.Config(path)  # ... and it sets nothing
    bare = pyproject(tmp_path / "bare", "# [tool.rcsgen]\n")  # not even a [tool] table
    assert config.load(bare.parent) == config.Config(bare)


def test_bytes_that_are_not_utf8_outside_the_table_are_tolerated(tmp_path: Path) -> None:
    path = pyproject(tmp_path, b"# caf\xe9\n[tool.rcsgen]\nstrict = false\n")
    assert config.load(tmp_path) == config.Config(path, strict=False, keys=frozenset({"strict"}))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "# [tool.rcsgen]\n[tool]\nrcsgen = 1\n",
            "[tool.rcsgen] must be a table",
        ),
        (
            "[tool.rcsgen]\nzzz = 1\n",
            "[tool.rcsgen]: unknown key `zzz`; the keys are ignore, select, strict",
        ),
        (
            "[tool.rcsgen]\nselct = []\n",
            "[tool.rcsgen]: unknown key `selct`; did you mean `select`?",
        ),
        (
            '[tool.rcsgen]\nselect = ["W5", 3]\n',
            "[tool.rcsgen]: `select` must be a list of warning codes",
        ),
        (
            '[tool.rcsgen]\nignore = ["W9"]\n',
            "[tool.rcsgen]: `ignore`: no warning code starts with `W9`; the warnings are ",
        ),
        (
            "[tool.rcsgen]\nstrict = 1\n",
            "[tool.rcsgen]: `strict` must be true or false",
        ),
        ("[tool.rcsgen]\nstrict = \n", "invalid TOML: "),
    ],
)
def test_a_misused_configuration_names_its_file(tmp_path: Path, text: str, message: str) -> None:
    path = pyproject(tmp_path, text)
    with pytest.raises(config.ConfigError) as caught:
        config.load(tmp_path)
    assert str(caught.value).startswith(f"{path}: {message}")
    assert "\n" not in str(caught.value)
