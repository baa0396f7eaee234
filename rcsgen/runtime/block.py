"""Block: a size (and a segment name) -> the memory the modules exchange their buffers through.

A private in-process buffer, or a named `multiprocessing.shared_memory` segment that several
processes attach to. Standard library only: copied verbatim into every generated package.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # imported when a named block is used: it costs ~10 ms of start-up
    from multiprocessing import shared_memory


class Block:
    """The shared block: a private in-process buffer, or a named `shared_memory` segment."""

    def __init__(self, size: int, name: str | None = None, create: bool = True) -> None:
        self.shm: shared_memory.SharedMemory | None = None
        self.owner = create and name is not None
        self.buf: memoryview
        if name is None:
            self.buf = memoryview(bytearray(size))
            return
        from multiprocessing import shared_memory

        if create:
            self.shm = shared_memory.SharedMemory(name=name, create=True, size=size)
        else:
            self.shm = _attach(name)
        if self.shm.size < size:
            raise ValueError(f"shared block {name!r} has {self.shm.size} bytes, {size} needed")
        assert self.shm.buf is not None  # None only once closed
        self.buf = self.shm.buf

    def close(self) -> None:
        """Release the view; the creator also removes the named segment."""
        self.buf.release()
        if self.shm is not None:
            self.shm.close()
            if self.owner:
                self.shm.unlink()


def _attach(name: str) -> shared_memory.SharedMemory:
    """Attach to a segment without registering it with the resource tracker.

    Only the creator owns the segment; an attaching process must neither unlink it when it
    exits nor cancel the creator's registration (which unregistering afterwards would do
    when both share a tracker). Python 3.13 has `track=False`; before it, registration is
    suppressed for the duration of the call.
    """
    from multiprocessing import resource_tracker, shared_memory

    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name=name, track=False)  # type: ignore[call-arg,unused-ignore]
    register = resource_tracker.register
    resource_tracker.register = lambda *args, **kwargs: None
    try:
        return shared_memory.SharedMemory(name=name)
    finally:
        resource_tracker.register = register
