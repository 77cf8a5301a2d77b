"""A TCP forwarder whose link can fall silent: partitions without root.

Bytes are relayed both ways between each accepted connection and the
target. :meth:`SilentLink.silence` keeps every connection open but drops
what crosses it, as a radio link that fades does: Zenoh notices only after
its lease. :meth:`SilentLink.heal` relays again.
"""

from __future__ import annotations

import contextlib
import socket
import threading


class SilentLink:
    """Listens on a loopback port and relays to ``target_port``."""

    def __init__(self, target_port: int) -> None:
        self.target_port = target_port
        self._server = socket.socket()
        self._server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._server.bind(("127.0.0.1", 0))
        self._server.listen(16)
        self.port = self._server.getsockname()[1]
        self._quiet = threading.Event()
        self._closed = threading.Event()
        self._sockets: list[socket.socket] = []
        self._lock = threading.Lock()
        threading.Thread(target=self._accept, daemon=True).start()

    def silence(self) -> None:
        """Drop every byte from now on; connections stay open."""
        self._quiet.set()

    def heal(self) -> None:
        """Relay again."""
        self._quiet.clear()

    def close(self) -> None:
        """Close the listener and every connection."""
        self._closed.set()
        with contextlib.suppress(OSError):
            self._server.close()
        with self._lock:
            for sock in self._sockets:
                with contextlib.suppress(OSError):
                    sock.close()

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                inner, _ = self._server.accept()
            except OSError:
                return
            try:
                outer = socket.create_connection(
                    ("127.0.0.1", self.target_port)
                )
            except OSError:
                inner.close()
                continue
            with self._lock:
                self._sockets += [inner, outer]
            for src, dst in ((inner, outer), (outer, inner)):
                threading.Thread(
                    target=self._pump, args=(src, dst), daemon=True
                ).start()

    def _pump(self, src: socket.socket, dst: socket.socket) -> None:
        try:
            while True:
                data = src.recv(65536)
                if not data:
                    break
                if not self._quiet.is_set():
                    dst.sendall(data)
        except OSError:
            pass
        finally:
            for sock in (src, dst):
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)
