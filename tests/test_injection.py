"""Spec text cannot break out of generated code.

Every payload below (quotes, triple quotes, line breaks of every kind, backslashes, dunder
access, imports, NUL, tabs, f-string and Jinja braces, bidi controls, surrogates, ...) is put
into every text field of a spec. Where the field is free text the build must succeed, every
generated module must compile, the payload's marker may appear only inside string literals
and comments (checked with `tokenize`), the token stream outside strings and comments must
equal that of the same system built with plain text, and importing and running the package
must never create the canary file. Where the field is one line (titles, rule docs) a
payload with a line break is a located E602. Where a name or an expression is expected the
payload is a located error.
"""

from __future__ import annotations

import io
import os
import shutil
import tokenize
from pathlib import Path

import pytest

from rcsgen.compiler.back_end import emit
from rcsgen.compiler.checks.naming import LINE_BREAKS
from rcsgen.compiler.diagnostics import Diagnostic
from rcsgen.compiler.frontend import compile_paths
from rcsgen.tools.harness import Harness

CANARY = "CANARY"
BREAKOUT = f"import os; os.system('touch {CANARY}')"
PAYLOADS = [
    f'"""; {BREAKOUT} #',
    f"'''; {BREAKOUT} #",
    f'"; {BREAKOUT} #',
    f"'; {BREAKOUT} #",
    f"\n{BREAKOUT}\n#",
    f"\r{BREAKOUT}\r#",
    f"\r\n{BREAKOUT}\r\n",
    f"\u2028{BREAKOUT}",
    f"\u2029{BREAKOUT}",
    f"\x85{BREAKOUT}",
    f"\x0b{BREAKOUT}\x0c{BREAKOUT}",
    f"\x1c\x1d\x1e{BREAKOUT}",
    "ends with a backslash \\",
    '\\"""; ' + BREAKOUT,
    "\\N{BULLET} \\x41 \\u0041 \\\n" + BREAKOUT,
    "__import__('os').system('touch CANARY')",
    "().__class__.__bases__[0].__subclasses__()",
    "{{ 7*7 }} {% import os %} {# comment #} {{ self.__init__.__globals__ }}",
    "{% raw %}{{ cycler.__init__.__globals__.os.system('touch CANARY') }}{% endraw %}",
    "f\"{__import__('os').system('touch CANARY')}\"",
    "{0.__class__} %s %(x)s {}",
    "nul\x00byte",
    "\ttabbed\tdoc\t",
    "# looks like a comment",
    'ends with a quote"',
    '"""',
    "''''''",
    "lone \ud800 surrogate",
    "trojan \u202e\u2066 source \u2069\u202c bidi \ufeff\u200b",
    "A" * 3000,
    "${HOME} $(touch CANARY) `touch CANARY`",
    "\x1b[31mANSI\x1b[0m \x07 bell \x7f",
    "emoji \U0001f642 and \u00e9",
    "   padded   ",
    '"""\n' + BREAKOUT + '\n"""',
    "*/ --> ]]> \\",
    "if True:\n    import os",
]
MARKS = [f"ZQJ{i:02d}" for i in range(len(PAYLOADS))]
TEXTS = [f"{mark} {payload} {mark}" for mark, payload in zip(MARKS, PAYLOADS, strict=True)]
HOOKS = "def h():\n    return None\n"


def q(text: str) -> str:
    """A YAML double-quoted scalar holding exactly `text` (non-printables escaped)."""
    out = []
    for char in text:
        code = ord(char)
        if char in '"\\':
            out.append("\\" + char)
        elif char.isprintable():
            out.append(char)
        else:
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")
    return '"' + "".join(out) + '"'


def one_line(text: str) -> bool:
    return not any(ch in LINE_BREAKS for ch in text)


def spec_files(texts: list[str], plain: bool = False, raw: bool = False) -> dict[str, str]:
    """A system with one controller per text, carrying it in every text field.

    One-line fields (titles, rule docs) get the text with its line breaks folded into
    spaces, or as it is with `raw`; `plain` builds the twin with neutral text.
    """
    shown = ["plain text"] * len(texts) if plain else texts
    names = [f"c{i:02d}" for i in range(len(texts))]
    single = " | ".join(t for t in shown if one_line(t)) if not raw else shown[0]
    world = "".join(
        f"  w{i:02d}:\n    type: int\n    initial: 0\n    doc: {q(t)}\n    unit: {q(t)}\n"
        for i, t in enumerate(shown)
    )
    files = {
        "system.yaml": (
            f"system: inj\ntitle: {q(single)}\ndoc: {q(chr(10).join(shown))}\n"
            f"cycle_period: 0.01\nworld:\n{world}processes:\n  p:\n"
            f"    doc: {q(chr(10).join(shown))}\n    modules: [{', '.join(names)}]\n"
        ),
        "inj_hooks/__init__.py": "",
        "inj_hooks/all.py": HOOKS,
    }
    for name, text in zip(names, shown, strict=True):
        line = text if raw or one_line(text) else " ".join(text.split())
        files[f"{name}.yaml"] = f"""\
controller: {name}
title: {q(line)}
doc: {q(text)}
hooks_module: inj_hooks.all
locals:
  v:
    type: int
    initial: 0
    doc: {q(text)}
hooks:
  h:
    doc: {q(text)}
every_cycle:
  - doc: {q(line)}
    when: v < 0
    do:
      - set: {{v: 0}}
commands:
  GO:
    doc: {q(text)}
    params:
      p:
        type: int
        doc: {q(text)}
    states:
      S0:
        - doc: {q(line)}
          do:
            - call: h
            - set: {{v: p}}
            - report: DONE
"""
    return files


def write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
    return root


def structure(source: str) -> tuple[list[tuple[int, str]], list[tokenize.TokenInfo]]:
    """The tokens outside strings and comments, and the string and comment tokens."""
    code, text = [], []
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type in (tokenize.STRING, tokenize.COMMENT):
            text.append(token)
        elif token.type not in (tokenize.NL, tokenize.NEWLINE):
            code.append((token.type, token.string))
    return code, text


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict, dict]:
    """The payload system and its plain twin, rendered; the payload package written out."""
    base = tmp_path_factory.mktemp("injection")
    spec = write(base / "spec", spec_files(TEXTS))
    plain = write(base / "plain", spec_files(TEXTS, plain=True))
    systems = {}
    for name, directory in (("payload", spec), ("plain", plain)):
        front = compile_paths([directory])
        assert not front.diagnostics.errors, "\n".join(d.render() for d in front.diagnostics)
        systems[name] = emit.render_all(front.systems)
    write(base / "out", systems["payload"])
    return base, systems["payload"], systems["plain"]


def test_every_generated_module_compiles(built: tuple[Path, dict, dict]) -> None:
    _, files, _ = built
    assert len(files) > len(TEXTS)
    for rel, source in files.items():
        compile(source, rel, "exec", dont_inherit=True)


def test_payloads_stay_inside_strings_and_comments(built: tuple[Path, dict, dict]) -> None:
    """Outside strings and comments the payload build is token for token the plain build."""
    _, files, plain = built
    assert files.keys() == plain.keys()
    seen: set[str] = set()
    for rel, source in files.items():
        code, text = structure(source)
        assert code == structure(plain[rel])[0], f"{rel}: spec text changed the code"
        for token_type, string in code:
            assert not any(m in string for m in MARKS), (rel, token_type, string)
            assert CANARY not in string, (rel, string)
        seen.update(m for token in text for m in MARKS if m in token.string)
    assert seen == set(MARKS), f"payloads never emitted: {sorted(set(MARKS) - seen)}"


def test_templates_do_not_render_spec_text(built: tuple[Path, dict, dict]) -> None:
    """Jinja delimiters in spec text come out verbatim (a template never re-renders text)."""
    _, files, _ = built
    controller = files["inj/c17.py"]
    assert "{{ 7*7 }}" in controller and "{% import os %}" in controller
    assert "49" not in controller


def test_running_the_package_never_runs_a_payload(
    built: tuple[Path, dict, dict], monkeypatch: pytest.MonkeyPatch
) -> None:
    base, _, _ = built
    monkeypatch.chdir(base)
    with Harness.load(base / "out" / "inj", base / "spec", send_init=True) as h:
        h.cycle(2)
        for index in range(0, len(TEXTS), 3):
            module = f"c{index:02d}"
            h.command(module, "GO", p=index)
            h.step(module)
            assert h.status(module).status == "DONE"
            assert h.controller(module).var_v == index
        h.cycle(2)
    assert not list(base.rglob(CANARY)) and not Path(CANARY).exists()
    assert not (Path(os.sep) / CANARY).exists()


def _errors_at(directory: Path) -> list[Diagnostic]:
    front = compile_paths([directory])
    assert not front.systems
    errors = front.diagnostics.errors
    for d in errors:
        path = Path(d.span.file)
        assert path.resolve().is_relative_to(directory.resolve()), d.render()
        assert d.span.line >= 1 and d.span.col >= 1, d.render()
    return errors


def _line_of(text: str, needle: str) -> int:
    return text[: text.index(needle)].count("\n") + 1


def test_line_breaks_in_one_line_texts_are_located_errors(tmp_path: Path) -> None:
    """A title or rule doc with a line break is E602 at that title or doc, and nothing else
    is an error: multi-line docs may hold every payload."""
    breaking = [t for t in TEXTS if not one_line(t)]
    assert len(breaking) >= 10
    files = spec_files(breaking, raw=True)
    write(tmp_path, files)
    errors = _errors_at(tmp_path)
    assert {d.code for d in errors} == {"E602"}
    located = {(Path(d.span.file).name, d.span.line) for d in errors}
    assert ("system.yaml", 2) in located
    for index in range(len(breaking)):
        rel = f"c{index:02d}.yaml"
        lines = files[rel].split("\n")
        docs = [n for n, line in enumerate(lines, 1) if line.strip().startswith("- doc:")]
        assert len(docs) == 2  # the every_cycle rule's and the S0 rule's
        for line in (2, *docs):  # the title is line 2
            assert (rel, line) in located, (rel, line, sorted(located))


NAME_SLOTS = [
    ("system.yaml", "modules: [top]", "modules: [top, {p}]"),
    ("top.yaml", "      S0:\n", "      {p}:\n        - next: S0\n      S0:\n"),
    ("top.yaml", "  GO:\n", "  {p}:\n    states:\n      S0:\n        - next: S0\n  GO:\n"),
    ("top.yaml", "locals:\n", "locals:\n  {p}:\n    type: int\n    initial: 0\n"),
    ("top.yaml", "        - do:\n", "        - next: {p}\n        - do:\n"),
    (
        "top.yaml",
        "            - report: DONE\n",
        "            - call: {p}\n            - report: DONE\n",
    ),
    (
        "top.yaml",
        "            - report: DONE\n",
        "            - set: {{{p}: 1}}\n            - report: DONE\n",
    ),
    (
        "top.yaml",
        "            - report: DONE\n",
        "            - send: {p}\n            - report: DONE\n",
    ),
    ("top.yaml", "constants:\n", "constants:\n  {p}: 1\n"),
    ("system.yaml", "world:\n", "world:\n  {p}:\n    type: int\n    initial: 0\n"),
]
NAME_BASE = {
    "system.yaml": "system: names\ntitle: Names\ncycle_period: 0.1\nworld:\n  w:\n"
    "    type: int\n    initial: 0\nprocesses:\n  p:\n    modules: [top]\n",
    "top.yaml": "controller: top\ntitle: Top\nlocals:\n  v:\n    type: int\n    initial: 0\n"
    "constants:\n  K: 1\ncommands:\n  GO:\n    states:\n      S0:\n        - do:\n"
    "            - report: DONE\n",
}


@pytest.mark.parametrize("slot", NAME_SLOTS, ids=[f"{s[0]}:{s[1].strip()}" for s in NAME_SLOTS])
def test_payloads_as_names_are_located_errors(tmp_path: Path, slot: tuple[str, str, str]) -> None:
    """Where a name is expected, every payload is an error located on its own line."""
    rel, old, new = slot
    for index, text in enumerate(TEXTS):
        directory = tmp_path / f"p{index:02d}"
        files = dict(NAME_BASE)
        files[rel] = files[rel].replace(old, new.format(p=q(text)), 1)
        write(directory, files)
        errors = _errors_at(directory)
        line = _line_of(files[rel], q(text))
        assert (rel, line) in {(Path(d.span.file).name, d.span.line) for d in errors}, [
            d.render() for d in errors
        ]


def test_payloads_as_expressions_are_located_errors(tmp_path: Path) -> None:
    """Where an expression is expected, every payload is an error on that expression's line."""
    rules, predicates = [], []
    for index, text in enumerate(TEXTS):
        predicates.append(f"  p{index:02d}: {q(text)}\n")
        rules.append(
            f"        - when: {q(text)}\n          do:\n            - set: {{v: {q(text)}}}\n"
        )
        rules.append(f"          next: S{index:02d}\n")
    states = "".join(
        f"      S{i:02d}:\n        - do:\n            - report: DONE\n" for i in range(len(TEXTS))
    )
    top = (
        "controller: top\ntitle: Top\nlocals:\n  v:\n    type: int\n    initial: 0\n"
        "predicates:\n"
        + "".join(predicates)
        + "commands:\n  GO:\n    states:\n      S0:\n"
        + "".join(rules)
        + states
    )
    files = dict(NAME_BASE, **{"top.yaml": top})
    write(tmp_path, files)
    errors = _errors_at(tmp_path)
    located = {d.span.line for d in errors if d.code.startswith("E1")}
    lines = top.split("\n")
    for index, text in enumerate(TEXTS):
        for prefix in (f"  p{index:02d}: ", "        - when: "):
            wanted = [n for n, line in enumerate(lines, 1) if line == prefix + q(text)]
            assert wanted and wanted[0] in located, (index, prefix, text[:40])
        value = [n for n, line in enumerate(lines, 1) if line.endswith(f"{{v: {q(text)}}}")]
        assert value and value[0] in located, (index, "set", text[:40])


def test_spec_directory_name_cannot_inject(tmp_path: Path, monkeypatch) -> None:
    """The spec directory's name (never validated) is in headers and SOURCES: neutralised."""
    name = "x\"\nimport os; os.system('touch CANARY')\n#\u2028'"
    spec = tmp_path / name
    write(spec, {**NAME_BASE})
    front = compile_paths([spec])
    assert not front.diagnostics.errors
    files = emit.render_all(front.systems)
    for rel, source in files.items():
        compile(source, rel, "exec", dont_inherit=True)
        for token_type, string in structure(source)[0]:
            assert CANARY not in string, (rel, token_type, string)
    out = tmp_path / "out"
    write(out, files)
    monkeypatch.chdir(tmp_path)
    with Harness.load(out / "names", spec, send_init=True) as h:
        h.cycle(3)
    assert not list(tmp_path.rglob(CANARY))
    shutil.rmtree(out)


@pytest.mark.parametrize("indent", [0, 4, 8])
def test_filters_keep_any_text_in_one_token(indent: int) -> None:
    """`docstring` gives one string literal, `comment` one comment, for every payload."""
    pad = " " * indent
    for text in [*TEXTS, *PAYLOADS, "", " ", "\n", '"', "\\", "a\\", "x\n\n\ny"]:
        literal = emit.docstring(text, indent + 4)
        source = (
            f"{pad}def f():\n{pad}    {literal}\n{pad}    {emit.comment(text)}\n{pad}    return 1\n"
        )
        if indent:
            source = "class C:\n" + source if indent == 4 else "class C:\n    class D:\n" + source
        compile(source, "<filters>", "exec", dont_inherit=True)
        code, strings = structure(source)
        plain = source.replace(literal, '"""x"""').replace(emit.comment(text), "# x")
        assert code == structure(plain)[0], repr(text)
        assert [t.type for t in strings] == [tokenize.STRING, tokenize.COMMENT], repr(text)
        value = eval(literal)  # a plain string literal: safe to evaluate
        assert isinstance(value, str)
        for mark in MARKS:
            if mark in text:
                assert mark in value and mark in strings[1].string


def test_output_paths_come_only_from_validated_names(tmp_path: Path) -> None:
    """emit refuses to render a path that is not `<name>/<name>.py` (a last line of defence:
    the checker has already rejected every such name)."""
    from dataclasses import replace

    write(tmp_path, NAME_BASE)
    system = compile_paths([tmp_path]).systems[0]
    assert set(emit.render_system(system)) >= {"names/top.py", "names/layout.py"}
    for bad in ("../escape", "Names", "x/y", "names\n", "names.py"):
        with pytest.raises(ValueError, match="unsafe output path"):
            emit.render_system(replace(system, name=bad))
