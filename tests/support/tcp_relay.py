"""TCP relay: a listening port and a target -> bytes forwarded both ways, cut and mended on signal.

The network between two "hosts" on one machine, so that a test can cut the link while both
keep running: `python tests/tcp_relay.py TARGET_PORT` listens on a free port of 127.0.0.1
(printed on stdout's first line) and forwards each connection to 127.0.0.1:TARGET_PORT.
SIGUSR1 cuts the link the way a pulled cable does: nothing more is delivered either way and
no new connection is answered, but no connection is closed (neither side is told; each
must notice the silence). SIGUSR2 mends it: the connections that lived through the cut (their
streams lost bytes) are closed, and new ones are accepted and forwarded again. SIGTERM
closes everything and exits 0. Standard library only.
"""

from __future__ import annotations

import selectors
import signal
import socket
import sys
from types import FrameType

CHUNK = 65536


class Relay:
    def __init__(self, target: int) -> None:
        self.target = target
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.setblocking(False)
        self.selector = selectors.DefaultSelector()
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.peer: dict[socket.socket, socket.socket] = {}  # each end -> the other
        self.cut = False
        self.mend = False
        self.listening = True
        self.done = False

    @property
    def port(self) -> int:
        return int(self.listener.getsockname()[1])

    def _accept(self) -> None:
        client, _ = self.listener.accept()
        try:
            upstream = socket.create_connection(("127.0.0.1", self.target), timeout=2)
        except OSError:
            client.close()
            return
        for end, other in ((client, upstream), (upstream, client)):
            end.setblocking(False)
            end.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.peer[end] = other
            self.selector.register(end, selectors.EVENT_READ)

    def _close(self, end: socket.socket) -> None:
        other = self.peer.pop(end, None)
        for each in (end, other):
            if each is None:
                continue
            self.peer.pop(each, None)
            try:
                self.selector.unregister(each)
            except (KeyError, ValueError):
                pass
            each.close()

    def _forward(self, end: socket.socket) -> None:
        try:
            data = end.recv(CHUNK)
        except OSError:
            data = b""
        if not data:
            self._close(end)
            return
        if self.cut:
            return  # the cable is out: the bytes go nowhere, nobody is told
        try:
            self.peer[end].setblocking(True)
            self.peer[end].sendall(data)
            self.peer[end].setblocking(False)
        except OSError:
            self._close(end)

    def run(self) -> None:
        while not self.done:
            if self.mend:
                self.mend, self.cut = False, False
                for end in list(self.peer):
                    self._close(end)
                if not self.listening:
                    self.selector.register(self.listener, selectors.EVENT_READ)
                    self.listening = True
            for key, _ in self.selector.select(0.05):
                if key.fileobj is self.listener:
                    if not self.cut:
                        self._accept()
                else:
                    self._forward(key.fileobj)  # type: ignore[arg-type]
            if self.cut and self.listening:  # no new connection answered while cut
                self.selector.unregister(self.listener)
                self.listening = False
        for end in list(self.peer):
            self._close(end)
        self.listener.close()


def main() -> int:
    relay = Relay(int(sys.argv[1]))

    def on(signum: int, frame: FrameType | None) -> None:
        if signum == signal.SIGUSR1:
            relay.cut = True
        elif signum == signal.SIGUSR2:
            relay.mend = True
        else:
            relay.done = True

    for signum in (signal.SIGUSR1, signal.SIGUSR2, signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, on)
    print(relay.port, flush=True)
    relay.run()
    return 0


if __name__ == "__main__":
    sys.exit(main())
