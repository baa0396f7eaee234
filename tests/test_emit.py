"""The back end's text helpers, as the generated code shows a spec's own words: a docstring
is triple-quoted when that is plainly safe, and a `repr` on one line otherwise."""

from __future__ import annotations

import ast

import pytest

from rcsgen.compiler.back_end.emit import comment, docstring


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("A plain line.", '"""A plain line."""'),
        ("Two\nlines", '"""Two\n    lines\n    """'),
        ("A bell\x07 rings", "'A bell\\\\x07 rings'"),  # a control character: escaped
        ('Ends with "', "'Ends with \"'"),
        ("A back\\slash", "'A back\\\\slash'"),
        ("", "''"),
    ],
)
def test_a_docstring_is_triple_quoted_only_when_plainly_safe(text: str, shown: str) -> None:
    assert docstring(text, 4) == shown
    # either way it is one Python string literal, whose value keeps the words
    value = ast.literal_eval(shown)
    assert " ".join(value.split()) == " ".join(text.replace("\x07", "\\x07").split())


def test_a_comment_is_one_line_with_control_characters_escaped() -> None:
    assert comment("two\nlines\x00") == "# two lines\\x00"
