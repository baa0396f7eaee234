"""Deployment file: a JSON file naming each host, its processes and endpoints -> a checked plan.

Where each process runs is configuration, not spec: `python -m <system> --deploy FILE
[HOST]` runs the processes the file puts on HOST with the endpoints it gives that host,
over Zenoh. The file is JSON because this module is vendored into every generated package,
which needs nothing but Python (no YAML); positions are kept for every key and value, so a
mistake is one line `FILE:LINE:COL: error[E43x]: ...`. Standard library only.

    {"system": "miner",
     "hosts": {"vehicle": {"processes": ["pc1"], "listen": ["tcp/192.0.2.10:7447"],
                           "connect": ["tcp/192.0.2.20:7447"]},
               "planner": {"processes": ["pc2"], "listen": ["tcp/192.0.2.20:7447"]}}}
"""

from __future__ import annotations

import difflib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .contract import shared
from .transport import check_endpoint

HOST_KEYS = ("processes", "listen", "connect")
TOP_KEYS = ("system", "hosts")
UNREADABLE, UNKNOWN_HOST = "E430", "E437"


@shared
class DeployError(Exception):
    """A deployment file that cannot be used: its one-line message names file:line:col."""


@dataclass(frozen=True)
class Host:
    """One host of a deployment: the processes it runs and its Zenoh endpoints."""

    name: str
    processes: tuple[str, ...]
    listen: tuple[str, ...]
    connect: tuple[str, ...]


@dataclass(frozen=True)
class Deployment:
    path: str
    hosts: dict[str, Host]

    def host(self, name: str | None, default: str) -> Host:
        """The host called `name` (or `default`, this machine's name, when None), or a
        located error (E437) listing the hosts there are."""
        wanted = default if name is None else name
        if wanted in self.hosts:
            return self.hosts[wanted]
        how = (
            "no host"
            if name is not None
            else "no HOST given, and no host named after this machine,"
        )
        raise DeployError(
            f"{self.path}:1:1: error[{UNKNOWN_HOST}]: {how} `{wanted}` in the deployment"
            f"{_hint(wanted, list(self.hosts))}; its hosts: {', '.join(self.hosts)}"
        )


@dataclass(frozen=True)
class Node:
    """A JSON value with where it starts (1-based line and column)."""

    value: Any  # dict[str, tuple[Node, Node]] (key node, value node), list[Node], or a scalar
    line: int
    col: int


def load(path: str, system: str, processes: list[str]) -> Deployment:
    """Read and check a deployment file against the system's name and processes."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) else "not UTF-8"
        raise DeployError(
            f"{path}: error[{UNREADABLE}]: cannot read the deployment file: {reason}"
        ) from None
    try:
        json.loads(text)
    except json.JSONDecodeError as error:
        raise DeployError(
            f"{path}:{error.lineno}:{error.colno}: error[{UNREADABLE}]: not JSON: {error.msg}"
        ) from None
    return check(_Parser(text).value(), path, system, processes)


def check(root: Node, path: str, system: str, processes: list[str]) -> Deployment:
    """The hosts of a parsed deployment file; the first mistake as a located DeployError."""

    def fail(node: Node, code: str, message: str) -> DeployError:
        return DeployError(f"{path}:{node.line}:{node.col}: error[{code}]: {message}")

    def keys(node: Node, allowed: tuple[str, ...], what: str) -> None:
        expect(node, dict, "an object", what)
        for key, (key_node, _) in node.value.items():
            if key not in allowed:
                raise fail(key_node, "E431", f"unknown key `{key}` in {what}{_hint(key, allowed)}")

    def expect(node: Node, kind: type, name: str, what: str) -> None:
        if not isinstance(node.value, kind):
            raise fail(node, "E432", f"{what} must be {name}, not {_kind(node.value)}")

    keys(root, TOP_KEYS, "the deployment")
    for key in TOP_KEYS:
        if key not in root.value:
            raise fail(root, "E431", f"the deployment has no `{key}`")
    system_node = root.value["system"][1]
    expect(system_node, str, "a string", "`system`")
    if system_node.value != system:
        raise fail(
            system_node,
            "E436",
            f"the deployment is for system `{system_node.value}`, not `{system}`",
        )
    hosts_node = root.value["hosts"][1]
    expect(hosts_node, dict, "an object", "`hosts`")
    if not hosts_node.value:
        raise fail(hosts_node, "E431", "`hosts` names no host")
    placed: dict[str, str] = {}
    endpoints: dict[str, str] = {}
    hosts: dict[str, Host] = {}
    for name, (name_node, host_node) in hosts_node.value.items():
        keys(host_node, HOST_KEYS, f"host `{name}`")
        if "processes" not in host_node.value:
            raise fail(host_node, "E431", f"host `{name}` has no `processes`")
        lists: dict[str, list[str]] = {}
        for key in HOST_KEYS:
            if key not in host_node.value:
                lists[key] = []
                continue
            node = host_node.value[key][1]
            expect(node, list, "a list of strings", f"`{key}` of host `{name}`")
            for item in node.value:
                expect(item, str, "a string", f"an item of `{key}` of host `{name}`")
            lists[key] = [item.value for item in node.value]
            for item in node.value:
                if key == "processes":
                    if item.value not in processes:
                        raise fail(
                            item,
                            "E433",
                            f"`{system}` has no process `{item.value}`"
                            f"{_hint(item.value, processes)}",
                        )
                    if item.value in placed:
                        raise fail(
                            item,
                            "E434",
                            f"process `{item.value}` is on host `{placed[item.value]}` already",
                        )
                    placed[item.value] = name
                    continue
                try:
                    check_endpoint(item.value)
                except ValueError as error:
                    raise fail(item, "E435", str(error)) from None
                if key == "listen":
                    if item.value in endpoints:
                        raise fail(
                            item,
                            "E439",
                            f"host `{endpoints[item.value]}` listens on {item.value} already",
                        )
                    endpoints[item.value] = name
        if not lists["processes"]:
            raise fail(host_node, "E431", f"host `{name}` runs no process")
        if len(hosts_node.value) > 1 and not (lists["listen"] or lists["connect"]):
            raise fail(
                name_node,
                "E438",
                f"host `{name}` neither listens nor connects: no other host can reach it",
            )
        hosts[name] = Host(
            name,
            tuple(lists["processes"]),
            tuple(lists["listen"]),
            tuple(lists["connect"]),
        )
    missing = [p for p in processes if p not in placed]
    if missing:
        raise fail(
            hosts_node,
            "E434",
            f"process(es) {', '.join(missing)} of `{system}` are on no host",
        )
    return Deployment(path, hosts)


def _hint(name: str, choices: list[str] | tuple[str, ...]) -> str:
    close = difflib.get_close_matches(name, list(choices), n=1)
    return f" (did you mean `{close[0]}`?)" if close else ""


def _kind(value: object) -> str:
    if isinstance(value, bool):
        return "true/false"
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "an object"
    if isinstance(value, list):
        return "a list"
    return "a string" if isinstance(value, str) else "a number"


NUMBER = re.compile(r"-?(?:0|[1-9]\d*)(?:\.\d+)?(?:[eE][-+]?\d+)?")
SPACE = re.compile(r"[ \t\n\r]*")
STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)


class _Parser:
    """JSON already known to be valid (json.loads accepted it) -> Nodes with positions."""

    def __init__(self, text: str) -> None:
        self.text, self.at = text, 0

    def _skip(self) -> None:
        match = SPACE.match(self.text, self.at)
        assert match is not None
        self.at = match.end()

    def _where(self) -> tuple[int, int]:
        line = self.text.count("\n", 0, self.at) + 1
        return line, self.at - (self.text.rfind("\n", 0, self.at) + 1) + 1

    def value(self) -> Node:
        self._skip()
        line, col = self._where()
        char = self.text[self.at]
        if char == "{":
            self.at += 1
            found: dict[str, tuple[Node, Node]] = {}
            self._skip()
            while self.text[self.at] != "}":
                key = self.value()
                self._skip()
                self.at += 1  # the colon
                found[key.value] = (key, self.value())  # a repeated key: the last wins, as json
                self._skip()
                if self.text[self.at] == ",":
                    self.at += 1
                    self._skip()
            self.at += 1
            return Node(found, line, col)
        if char == "[":
            self.at += 1
            items: list[Node] = []
            self._skip()
            while self.text[self.at] != "]":
                items.append(self.value())
                self._skip()
                if self.text[self.at] == ",":
                    self.at += 1
                    self._skip()
            self.at += 1
            return Node(items, line, col)
        if char == '"':
            match = STRING.match(self.text, self.at)
            assert match is not None
            self.at = match.end()
            return Node(json.loads(match.group()), line, col)
        words: tuple[tuple[str, object], ...] = (("true", True), ("false", False), ("null", None))
        words += (("NaN", 0.0), ("Infinity", 0.0), ("-Infinity", 0.0))  # json.loads takes them
        for word, meaning in words:
            if self.text.startswith(word, self.at):
                self.at += len(word)
                return Node(meaning, line, col)
        match = NUMBER.match(self.text, self.at)
        assert match is not None
        self.at = match.end()
        return Node(json.loads(match.group()), line, col)
