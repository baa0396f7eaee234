"""Block: a layout (and a segment name) -> the memory the modules exchange their buffers through.

A private in-process buffer, or a named POSIX shared-memory segment (a file in /dev/shm,
mapped) that several processes attach to. The segment belongs to whoever created it (the
launcher, or a process run on its own): no other process's death removes it (no resource
tracker is involved, so a crashed creator does not unlink it under the processes still
attached). The file is mapped directly rather than through `multiprocessing.shared_memory`,
whose imports (multiprocessing, secrets, hashlib, pickle, socket) cost a process ~25 ms of
its start for nothing it uses. It is
created mode 0600 (its creator's alone), or 0660 with the group the system declares
(`operators.segment_group`). An attaching process checks the segment's mode and owner first
(nothing open to every user, no group but the declared one, no other owner unless the group
is the declared one) and then the header's layout hash, and refuses another layout.
Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import mmap
import os
from types import ModuleType

from .contract import HEADER, MAGIC, release_words, shared


@shared
class BlockError(Exception):
    """A segment that cannot be used: missing, taken, too small, or of another layout."""


class Block:
    """The shared block: a private in-process buffer, or a named shared-memory `Segment`.

    `create=True` makes a new segment (refusing a name already taken) and initialises it
    from the layout; `create=False` attaches to one and checks its layout hash. Only the
    creator unlinks the segment (`close`)."""

    def __init__(self, layout: ModuleType, name: str | None = None, create: bool = True) -> None:
        self.layout = layout
        self.name = name
        self.shm: Segment | None = None
        self.owner = create and name is not None
        self.buf: memoryview
        if name is None:
            self.buf = memoryview(bytearray(layout.SIZE))
            layout.initialise(self.buf)
            return
        if create:
            try:
                self.shm = Segment(name, layout.SIZE)
            except FileExistsError:
                raise BlockError(
                    f"shared-memory segment {name!r} already exists: another run of "
                    f"{layout.SYSTEM} is using it (or one crashed: remove /dev/shm/{name})"
                ) from None
        else:
            try:
                self.shm = Segment(name)
            except FileNotFoundError:
                raise BlockError(
                    f"no shared-memory segment {name!r}: is the system running?"
                ) from None
            except ValueError:  # an empty file: its creator has not sized it yet, or died
                raise BlockError(
                    f"shared-memory segment {name!r} is empty: being created (try again), or "
                    f"left by a run that died before sizing it (remove /dev/shm/{name})"
                ) from None
        self.buf = self.shm.buf
        if create:
            self._protect()
            layout.initialise(self.buf)
        else:
            self._check_access()
            self._check_identity()

    def _protect(self) -> None:
        """Mode 0600, or 0660 with the declared group: no one else may open the segment."""
        group = getattr(self.layout, "SEGMENT_GROUP", None)
        path = _path(str(self.name))
        try:
            if group is not None:
                os.chown(path, -1, _gid(group))
            os.chmod(path, 0o660 if group is not None else 0o600)
        except (KeyError, OSError) as error:
            why = (
                f"no group {group} on this host"
                if isinstance(error, KeyError)
                else f"you are not a member of group {group}"
                if isinstance(error, PermissionError)
                else str(error)
            )
            self._refuse(
                f"segment {self.name!r}: cannot give it to the group {self.layout.SYSTEM} "
                f"declares (operators.segment_group: {group}): {why}"
            )

    def _check_access(self) -> None:
        """Refuse a segment open to every user, shared with another group than the declared
        one, or owned by another user unless its group is the declared one (only a member
        of a group, or root, can give a file to it)."""
        group = getattr(self.layout, "SEGMENT_GROUP", None)
        try:
            found = os.stat(_path(str(self.name)))
        except OSError:
            return  # not a file this host shows (the name was unlinked meanwhile)
        mode = found.st_mode & 0o777
        declared = _gid(group) if group is not None and _has_group(group) else None
        problem = ""
        if mode & 0o007:
            problem = f"is open to every user (mode {mode:04o})"
        elif mode & 0o070 and found.st_gid != declared:
            problem = f"is shared with group {group_name(found.st_gid)} (mode {mode:04o}), and " + (
                f"the declared group is {group}" if group else "no group is declared"
            )
        elif found.st_uid != os.geteuid() and (declared is None or found.st_gid != declared):
            problem = f"belongs to user {user_name(found.st_uid)}, not to you"
        if problem:
            self._refuse(
                f"segment {self.name!r} {problem}: refused (docs/access.md); it is not one "
                f"this system's launcher made, or its mode was changed"
            )

    def _check_identity(self) -> None:
        layout, name = self.layout, self.name
        if self.shm is not None and self.shm.size < HEADER.size:
            self._refuse(f"segment {name!r} has {self.shm.size} bytes: it is not an rcsgen block")
        magic, found, system, size = HEADER.unpack_from(self.buf, 0)
        if magic != MAGIC and magic[:6] == MAGIC[:6]:  # another layout version's block
            self._refuse(
                f"segment {name!r} is a block of layout version {magic[6:].decode('ascii', '?')}"
                f" (this package's runtime has {MAGIC[6:].decode()}): rebuild and restart "
                "every process from the same rcsgen"
            )
        if magic != MAGIC:
            self._refuse(f"segment {name!r} is not an rcsgen block (no rcsgen header)")
        found_hash = found.decode("ascii", "replace")
        found_system = system.rstrip(b"\0").decode("ascii", "replace")
        if found_hash != layout.LAYOUT_HASH or size != layout.SIZE:
            self._refuse(
                f"segment {name!r} holds layout {found_hash} of system {found_system!r}; this "
                f"package has layout {layout.LAYOUT_HASH} of system {layout.SYSTEM!r} (from "
                f"{layout.SOURCE}): rebuild and restart every process from the same specs"
            )

    def _refuse(self, message: str) -> None:
        self.close()
        raise BlockError(message)

    def close(self) -> None:
        """Release the view (and its word view); the creator also removes the named segment."""
        release_words(self.buf)
        self.buf.release()
        if self.shm is not None:
            self.shm.close()
            if self.owner:
                unlink(self.shm.name)
            self.shm = None

    def disown(self) -> None:
        """Leave the segment to someone else: `close` will not remove it."""
        self.owner = False


def _path(name: str) -> str:
    return f"/dev/shm/{name.lstrip('/')}"


def _has_group(name: str) -> bool:
    try:
        _gid(name)
    except KeyError:
        return False
    return True


def _gid(name: str) -> int:
    import grp

    return grp.getgrnam(name).gr_gid


def group_name(gid: int) -> str:
    """A group's name, or its number when the host does not name it."""
    import grp

    try:
        return grp.getgrgid(gid).gr_name
    except KeyError:
        return str(gid)


def user_name(uid: int) -> str:
    """A user's name, or its number when the host does not name it (a container's)."""
    import pwd

    try:
        return pwd.getpwuid(uid).pw_name
    except KeyError:
        return str(uid)


def unlink(name: str) -> bool:
    """Remove a named segment; False when it was already gone."""
    try:
        os.unlink(_path(name))
    except FileNotFoundError:
        return False
    return True


def exists(name: str) -> bool:
    """Whether a named segment exists (Linux keeps them in /dev/shm)."""
    return os.path.exists(_path(name))


class Segment:
    """A named POSIX shared-memory segment, mapped: `size` > 0 creates it (mode 0600,
    refusing a name already taken: FileExistsError), 0 attaches to it (FileNotFoundError
    when there is none; ValueError when it is empty, its creator not having sized it yet).
    What `shm_open(3)` does on Linux: a file in /dev/shm, opened without following a
    symbolic link. `close` unmaps it; only `unlink` removes it."""

    def __init__(self, name: str, size: int = 0) -> None:
        self.name = name
        flags = os.O_RDWR | os.O_NOFOLLOW | os.O_CLOEXEC
        fd = os.open(_path(name), flags | (os.O_CREAT | os.O_EXCL if size else 0), 0o600)
        try:
            if size:
                try:
                    os.ftruncate(fd, size)
                except OSError:  # no room: the name is not left behind, empty
                    os.unlink(_path(name))
                    raise
            else:
                size = os.fstat(fd).st_size
                if size == 0:
                    raise ValueError(f"shared-memory segment {name!r} is empty")
            self.size = size
            self._map = mmap.mmap(fd, size)
        finally:
            os.close(fd)  # the mapping stays
        self.buf = memoryview(self._map)

    def close(self) -> None:
        """Unmap the segment (the file stays): the view is released first."""
        self.buf.release()
        self._map.close()
