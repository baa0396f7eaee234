"""Block: a layout (and a segment name) -> the memory the modules exchange their buffers through.

A private in-process buffer, or a named `multiprocessing.shared_memory` segment that several
processes attach to. The segment belongs to whoever created it (the launcher, or a process
run on its own): no other process's death removes it, and Python's resource tracker is kept
out of it, so a crashed creator does not unlink it under the processes still attached. An
attaching process checks the header's layout hash first and refuses another layout.
Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import TYPE_CHECKING

from .contract import HEADER, MAGIC, shared

if TYPE_CHECKING:  # imported when a named block is used: it costs ~10 ms of start-up
    from multiprocessing import shared_memory


@shared
class BlockError(Exception):
    """A segment that cannot be used: missing, taken, too small, or of another layout."""


class Block:
    """The shared block: a private in-process buffer, or a named `shared_memory` segment.

    `create=True` makes a new segment (refusing a name already taken) and initialises it
    from the layout; `create=False` attaches to one and checks its layout hash. Only the
    creator unlinks the segment (`close`)."""

    def __init__(self, layout: ModuleType, name: str | None = None, create: bool = True) -> None:
        self.layout = layout
        self.name = name
        self.shm: shared_memory.SharedMemory | None = None
        self.owner = create and name is not None
        self.buf: memoryview
        if name is None:
            self.buf = memoryview(bytearray(layout.SIZE))
            layout.initialise(self.buf)
            return
        from multiprocessing import shared_memory

        if create:
            try:
                self.shm = _untracked(shared_memory.SharedMemory, name, layout.SIZE)
            except FileExistsError:
                raise BlockError(
                    f"shared-memory segment {name!r} already exists: another run of "
                    f"{layout.SYSTEM} is using it (or one crashed: remove /dev/shm/{name})"
                ) from None
        else:
            try:
                self.shm = _untracked(shared_memory.SharedMemory, name, 0)
            except FileNotFoundError:
                raise BlockError(
                    f"no shared-memory segment {name!r}: is the system running?"
                ) from None
        assert self.shm.buf is not None  # None only once closed
        self.buf = self.shm.buf
        if create:
            layout.initialise(self.buf)
        else:
            self._check_identity()

    def _check_identity(self) -> None:
        layout, name = self.layout, self.name
        if self.shm is not None and self.shm.size < HEADER.size:
            self._refuse(f"segment {name!r} has {self.shm.size} bytes: it is not an rcsgen block")
        magic, found, system, size = HEADER.unpack_from(self.buf, 0)
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
        """Release the view; the creator also removes the named segment."""
        self.buf.release()
        if self.shm is not None:
            self.shm.close()
            if self.owner:
                unlink(self.shm.name)
            self.shm = None

    def disown(self) -> None:
        """Leave the segment to someone else: `close` will not remove it."""
        self.owner = False


def unlink(name: str) -> bool:
    """Remove a named segment; False when it was already gone."""
    from multiprocessing import shared_memory

    try:
        segment = _untracked(shared_memory.SharedMemory, name, 0)
    except FileNotFoundError:
        return False
    segment.close()
    with _no_tracker():
        try:
            segment.unlink()
        except FileNotFoundError:
            return False
    return True


def exists(name: str) -> bool:
    """Whether a named segment exists (Linux keeps them in /dev/shm)."""
    return os.path.exists(f"/dev/shm/{name.lstrip('/')}")


def _untracked(
    factory: type[shared_memory.SharedMemory], name: str, size: int
) -> shared_memory.SharedMemory:
    """Create (size > 0) or attach to (size 0) a segment without the resource tracker.

    Python's tracker unlinks every segment a process created or attached to when that
    process ends, under the processes still using it. Python 3.13 has `track=False`; before
    it, registration is suppressed for the duration of the call.
    """
    create = size > 0
    if sys.version_info >= (3, 13):
        return factory(name=name, create=create, size=size, track=False)  # type: ignore[call-arg,unused-ignore]
    with _no_tracker():
        return factory(name=name, create=create, size=size)


@contextmanager
def _no_tracker() -> Iterator[None]:
    """Keep Python's resource tracker from registering or unregistering a segment."""
    from multiprocessing import resource_tracker

    register, unregister = resource_tracker.register, resource_tracker.unregister
    resource_tracker.register = resource_tracker.unregister = _nothing
    try:
        yield
    finally:
        resource_tracker.register = register
        resource_tracker.unregister = unregister


def _nothing(*args: object, **kwargs: object) -> None:
    return None
