"""Access that means something (docs/access.md): who may open the segment, who holds a role.

The system is `tests/fixtures/runtime/fleet` with operators added: a role `holder` held by
a group this test's user is in (its primary group, from the OS) and a role `stranger`
held by a user and a group it is not (names no host has), and the segment shared with the
primary group. No OS user is created: "member" and "not a member" are this user's real
answers, asked of the OS the way `--role` asks them. The segment's mode is read from
/dev/shm; an attach is refused for a segment open to everyone, shared with another group,
or owned by another user (that one by making the attaching process see another effective
uid: a test cannot create users). Nothing is left in /dev/shm, no child survives.
"""

from __future__ import annotations

import grp
import importlib
import itertools
import os
import shutil
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

from rcsgen.tools.harness import generate, import_package

FLEET = Path(__file__).resolve().parent / "fixtures" / "runtime" / "fleet"
MINE = grp.getgrgid(os.getgid()).gr_name  # this user's primary group
NOBODY_GROUP = "rcs-no-such-group"  # a group no host has: nobody is in it
NOBODY_USER = "rcs-no-such-user"
_names = itertools.count(1)

OPERATORS = f"""
operators:
  segment_group: {MINE}
  roles:
    holder:
      groups: [{MINE}]
      override: all
    stranger:
      users: [{NOBODY_USER}]
      groups: [{NOBODY_GROUP}]
      override: all
"""


def segment_name() -> str:
    return f"rcsgen_acc_{os.getpid()}_{next(_names)}"


def ours() -> set[str]:
    return {n for n in os.listdir("/dev/shm") if n.startswith(f"rcsgen_acc_{os.getpid()}_")}


def build(tmp: Path, operators: str) -> tuple[Path, Path]:
    """The fleet with `operators` appended to its system.yaml, generated: (spec, package)."""
    spec = tmp / "fleet"
    shutil.copytree(FLEET, spec)
    system = spec / "system.yaml"
    system.write_text(system.read_text() + operators)
    scratch, name = generate(spec)
    return spec, scratch / name


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    spec, package = build(tmp_path_factory.mktemp("access"), OPERATORS)
    yield spec, package
    shutil.rmtree(package.parent, ignore_errors=True)
    assert ours() == set()


@pytest.fixture(scope="module")
def package(fleet: tuple[Path, Path]) -> ModuleType:
    return import_package(fleet[1], fleet[0])


def part(package: ModuleType, name: str) -> ModuleType:
    return importlib.import_module(f"{package.__name__}.{name}")


def python_m(fleet: tuple[Path, Path], *args: str) -> subprocess.CompletedProcess[str]:
    spec, package = fleet
    path = os.pathsep.join([str(package.parent), str(spec), *sys.path])
    return subprocess.run(
        [sys.executable, "-m", package.name, *args],
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=path),
        timeout=60,
    )


# ---------------------------------------------------------------- roles


def test_a_role_is_granted_to_its_holders_and_refused_to_everyone_else(
    package: ModuleType,
) -> None:
    """In-process, as ctl and the monitor make it: this user holds `holder` (a member of
    its group) and not `stranger`, whose refusal names who holds it and who this user is."""
    layout, ctl = part(package, "layout"), part(package, "rcs.operate.ctl")
    assert layout.ROLE_HOLDERS == {
        "holder": ((), (MINE,)),
        "stranger": ((NOBODY_USER,), (NOBODY_GROUP,)),
    }
    assert ctl.Access(layout, "holder").level("lead") == 3  # override
    assert ctl.holder_problem(layout, "holder") == ""
    with pytest.raises(ctl.CtlError) as refused:
        ctl.Access(layout, "stranger")
    assert refused.value.code == 1
    me = ctl.user_name(os.geteuid())
    groups = sorted({ctl.group_name(g) for g in {os.getgid(), os.getegid(), *os.getgroups()}})
    assert MINE in groups
    assert str(refused.value) == (
        f"refused: role stranger of fleet is held by user {NOBODY_USER} and members of "
        f"{NOBODY_GROUP}; you are {me} (groups {', '.join(groups)})"
    )


def test_a_user_named_in_a_role_holds_it_whatever_their_groups(tmp_path: Path) -> None:
    """`users:` alone: this user by name holds `named`; a system whose only role names
    another user refuses it. (The compiler's side: E810, W811 in tests/cases/invalid.)"""
    from rcsgen.runtime.operate import ctl

    me = ctl.user_name(os.geteuid())

    class Layout:
        SYSTEM = "tiny"
        ROLES = {"named": {"top": 3}, "other": {"top": 3}}
        ROLE_HOLDERS = {"named": ((me,), ()), "other": ((NOBODY_USER,), ())}

    assert ctl.holder_problem(Layout, "named") == ""  # type: ignore[arg-type]
    assert ctl.holder_problem(Layout, "other").startswith(  # type: ignore[arg-type]
        f"role other of tiny is held by user {NOBODY_USER}; you are {me} (groups "
    )


def test_ctl_the_launcher_and_the_monitor_refuse_a_role_to_a_non_holder_in_one_line(
    fleet: tuple[Path, Path], package: ModuleType
) -> None:
    """`ctl --role stranger`, `python -m fleet --role stranger` (what `rcsgen up` runs) and
    the monitor: one line, exit 1 (refused, README), before anything is attached or
    started; `--role holder` goes on (here to a missing segment: exit 1 for that reason)."""
    segment = segment_name()
    refused = python_m(fleet, "ctl", "--shm", segment, "--role", "stranger", "status")
    assert refused.returncode == 1
    (line,) = refused.stderr.splitlines()
    assert line.startswith("ctl: error: refused: role stranger of fleet is held by user ")
    held = python_m(fleet, "ctl", "--shm", segment, "--role", "holder", "status")
    assert held.returncode == 1
    assert held.stderr.splitlines() == [
        f"ctl: error: no shared-memory segment {segment!r}: is the system running?"
    ]
    launch = python_m(fleet, "--shm", segment, "--role", "stranger", "--cycles", "1")
    assert launch.returncode == 1
    (line,) = launch.stderr.splitlines()
    assert line.startswith("fleet: refused: role stranger of fleet is held by ")
    assert ours() == set(), "a refused launch made no segment"
    from rcsgen.runtime.operate.ctl import CtlError
    from rcsgen.tools.monitor import Monitor

    with pytest.raises(CtlError, match="refused: role stranger of fleet"):
        Monitor(part(package, "layout"), segment, role="stranger")


def test_the_launcher_checks_send_against_the_role_it_acts_in(
    fleet: tuple[Path, Path],
) -> None:
    """`--role holder --send lead.CONVOY`: held and allowed, the launch runs (two cycles);
    the same send as `stranger` is refused before a process starts."""
    segment = segment_name()
    done = python_m(
        fleet, "--shm", segment, "--role", "holder", "--send", "lead.CONVOY", "--cycles", "3"
    )
    assert done.returncode == 0, done.stderr
    refused = python_m(fleet, "--shm", segment, "--role", "stranger", "--send", "lead.CONVOY")
    assert refused.returncode == 1 and "refused: role stranger" in refused.stderr
    assert ours() == set()


# ---------------------------------------------------------------- the segment


def mode_and_group(name: str) -> tuple[int, int]:
    found = os.stat(f"/dev/shm/{name}")
    return stat.S_IMODE(found.st_mode), found.st_gid


def test_the_segment_is_shared_with_the_declared_group_only(package: ModuleType) -> None:
    """Created 0660 with the declared group; another process of the system attaches."""
    layout, block = part(package, "layout"), part(package, "rcs.block")
    made = block.Block(layout, segment_name(), create=True)
    try:
        assert mode_and_group(made.name) == (0o660, os.getgid())
        other = block.Block(layout, made.name, create=False)
        other.close()
    finally:
        made.close()
    assert ours() == set()


def test_without_a_declared_group_the_segment_is_its_creator_s_alone(tmp_path: Path) -> None:
    spec, built = build(tmp_path, "")
    try:
        package = import_package(built, spec)
        layout, block = part(package, "layout"), part(package, "rcs.block")
        assert layout.SEGMENT_GROUP is None and layout.ROLE_HOLDERS == {}
        made = block.Block(layout, segment_name(), create=True)
        try:
            assert mode_and_group(made.name)[0] == 0o600
        finally:
            made.close()
    finally:
        shutil.rmtree(built.parent, ignore_errors=True)
    assert ours() == set()


@pytest.mark.parametrize(
    ("mode", "message"),
    [
        (0o666, "is open to every user (mode 0666)"),
        (0o604, "is open to every user (mode 0604)"),
    ],
)
def test_a_segment_open_to_every_user_is_refused_on_attach(
    package: ModuleType, mode: int, message: str
) -> None:
    layout, block = part(package, "layout"), part(package, "rcs.block")
    made = block.Block(layout, segment_name(), create=True)
    try:
        os.chmod(f"/dev/shm/{made.name}", mode)
        with pytest.raises(block.BlockError) as refused:
            block.Block(layout, made.name, create=False)
        assert str(refused.value) == (
            f"segment {made.name!r} {message}: refused (docs/access.md); it is not one this "
            "system's launcher made, or its mode was changed"
        )
    finally:
        made.close()
    assert ours() == set()


def test_a_segment_shared_with_a_group_the_system_does_not_declare_is_refused(
    tmp_path: Path, package: ModuleType
) -> None:
    """A system that declares no segment group refuses a segment with group access."""
    spec, built = build(tmp_path, "")
    try:
        plain = import_package(built, spec)
        layout, block = part(plain, "layout"), part(plain, "rcs.block")
        made = block.Block(layout, segment_name(), create=True)
        try:
            os.chmod(f"/dev/shm/{made.name}", 0o660)
            with pytest.raises(
                block.BlockError,
                match=r"is shared with group .* \(mode 0660\), "
                "and no group is declared: refused",
            ):
                block.Block(layout, made.name, create=False)
        finally:
            made.close()
    finally:
        shutil.rmtree(built.parent, ignore_errors=True)
    assert ours() == set()


def test_a_segment_of_another_owner_is_refused_unless_its_group_is_the_declared_one(
    tmp_path: Path, package: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Seen as another user (the attaching process's effective uid, patched: a test cannot
    make users): a 0600 segment of someone else is refused; a 0660 one of the declared group
    is the system's (only the group's members, or root, can give a file to it)."""
    spec, built = build(tmp_path, "")
    plain = import_package(built, spec)
    shared_layout, block = part(package, "layout"), part(package, "rcs.block")
    plain_layout, plain_block = part(plain, "layout"), part(plain, "rcs.block")
    alone = plain_block.Block(plain_layout, segment_name(), create=True)
    shared = block.Block(shared_layout, segment_name(), create=True)
    someone_else = os.geteuid() + 4242
    try:
        monkeypatch.setattr(os, "geteuid", lambda: someone_else)
        owner = block.user_name(os.getuid())
        with pytest.raises(plain_block.BlockError) as refused:
            plain_block.Block(plain_layout, alone.name, create=False)
        assert f"{alone.name!r} belongs to user {owner}, not to you: refused" in str(refused.value)
        attached = block.Block(shared_layout, shared.name, create=False)
        attached.close()
    finally:
        monkeypatch.undo()
        alone.close()
        shared.close()
        shutil.rmtree(built.parent, ignore_errors=True)
    assert ours() == set()


def test_a_creator_outside_the_declared_group_is_refused_and_leaves_nothing(
    tmp_path: Path,
) -> None:
    """A declared group the host does not have: the launch says so in one line, exit 1, and
    removes the segment it began."""
    spec, built = build(
        tmp_path,
        f"\noperators:\n  segment_group: {NOBODY_GROUP}\n",
    )
    try:
        package = import_package(built, spec)
        layout, block = part(package, "layout"), part(package, "rcs.block")
        name = segment_name()
        with pytest.raises(block.BlockError) as refused:
            block.Block(layout, name, create=True)
        assert str(refused.value) == (
            f"segment {name!r}: cannot give it to the group fleet declares "
            f"(operators.segment_group: {NOBODY_GROUP}): no group {NOBODY_GROUP} on this host"
        )
        assert ours() == set()
        launch = python_m((spec, built), "--shm", name, "--cycles", "1")
        assert launch.returncode == 1
        assert launch.stderr.splitlines()[-1].endswith(f"no group {NOBODY_GROUP} on this host")
    finally:
        shutil.rmtree(built.parent, ignore_errors=True)
    assert ours() == set()


def test_any_refusal_on_attach_leaves_the_segment_to_its_owner(package: ModuleType) -> None:
    layout, block = part(package, "layout"), part(package, "rcs.block")
    made = block.Block(layout, segment_name(), create=True)
    try:
        os.chmod(f"/dev/shm/{made.name}", 0o666)
        with pytest.raises(block.BlockError):
            block.Block(layout, made.name, create=False)
        assert block.exists(made.name), "a refused attach does not remove another's segment"
    finally:
        made.close()
    assert ours() == set()
