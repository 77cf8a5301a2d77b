"""The older Foxglove WebSocket subprotocol, in front of foxglove-sdk.

foxglove-sdk's server accepts the subprotocols ``foxglove.sdk.v1`` and
``foxglove.sdk.v1.1`` and answers HTTP 400 to a client that offers only
``foxglove.websocket.v1``, the name the same protocol had before
(Foxglove Studio, the ``@foxglove/ws-protocol`` clients, Lichtblick, the
Python ``foxglove-websocket`` examples). The messages are the same:
``foxglove.sdk.v1`` is ``foxglove.websocket.v1`` renamed, with optional
capabilities a server only uses when a client asks for them.

:class:`SubprotocolBridge` listens where the view is reached and relays
each connection to the SDK's server, byte for byte, except for the
opening handshake of a client that offers only the older name: the
request asks for ``foxglove.sdk.v1`` instead, and the answer names the
protocol the client asked for. A client that offers the newer name is
relayed untouched. Plain sockets and one thread per direction of a
connection: no bus, no Foxglove import.
"""

from __future__ import annotations

import contextlib
import logging
import re
import socket
import threading

__all__ = ["NEW", "OLD", "SubprotocolBridge", "rewrite_request"]

log = logging.getLogger("fsw_scheduler.view")

#: The subprotocol foxglove-sdk's server speaks.
NEW = "foxglove.sdk.v1"
#: Its older name, which the server refuses.
OLD = "foxglove.websocket.v1"

_HEAD_END = b"\r\n\r\n"
#: Longest opening handshake read (browsers send a few hundred bytes).
_MAX_HEAD = 64 * 1024
_PROTOCOL = re.compile(rb"(?im)^sec-websocket-protocol:[ \t]*(.*?)[ \t]*\r$")


def rewrite_request(head: bytes) -> tuple[bytes, bool]:
    """The handshake ``head`` as the SDK's server accepts it.

    Parameters
    ----------
    head
        The client's HTTP request, up to and including the blank line.

    Returns
    -------
    bytes, bool
        The request to forward, and whether it was changed (the client
        offered :data:`OLD` and not :data:`NEW`, so the answer must be
        changed back).
    """
    offered = [
        name.strip()
        for match in _PROTOCOL.finditer(head)
        for name in match.group(1).decode("latin-1").split(",")
    ]
    if OLD not in offered or any(n.startswith(NEW) for n in offered):
        return head, False
    changed = _PROTOCOL.sub(
        lambda m: (
            b"Sec-WebSocket-Protocol: "
            + m.group(1).replace(OLD.encode(), NEW.encode())
            + b"\r"
        ),
        head,
    )
    return changed, True


def _rewrite_answer(head: bytes) -> bytes:
    """The server's answer naming :data:`OLD`, as the client asked."""
    return _PROTOCOL.sub(
        lambda m: b"Sec-WebSocket-Protocol: " + OLD.encode() + b"\r", head
    )


def _read_head(sock: socket.socket) -> tuple[bytes, bytes]:
    """Bytes up to the end of an HTTP head, and what came after it."""
    data = b""
    while _HEAD_END not in data:
        chunk = sock.recv(4096)
        if not chunk:
            break
        data += chunk
        if len(data) > _MAX_HEAD:
            break
    head, sep, rest = data.partition(_HEAD_END)
    return head + sep, rest


class SubprotocolBridge:
    """A TCP relay to foxglove-sdk's server that also takes the old name.

    Parameters
    ----------
    upstream
        ``(host, port)`` of the SDK's server.
    host, port
        Where to listen (port 0: a free one, see :attr:`port`).
    """

    def __init__(
        self, upstream: tuple[str, int], host: str, port: int
    ) -> None:
        self._upstream = upstream
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.socket(family, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind((host, port))
        self._listener.listen(16)
        self._open: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._closed = False
        self._thread = threading.Thread(
            target=self._accept, name="fsw-view-relay", daemon=True
        )
        self._thread.start()

    @property
    def port(self) -> int:
        """The port clients connect to."""
        return int(self._listener.getsockname()[1])

    def close(self) -> None:
        """Stop listening and end every relayed connection."""
        with self._lock:
            self._closed = True
            sockets = [self._listener, *self._open]
            self._open.clear()
        for sock in sockets:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()
        self._thread.join(5.0)

    def _keep(self, *socks: socket.socket) -> bool:
        with self._lock:
            if self._closed:
                return False
            self._open.update(socks)
            return True

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return  # closed
            threading.Thread(
                target=self._serve,
                args=(client,),
                name="fsw-view-relay-conn",
                daemon=True,
            ).start()

    def _serve(self, client: socket.socket) -> None:
        try:
            upstream = socket.create_connection(self._upstream, timeout=10)
            upstream.settimeout(None)
        except OSError as error:
            log.warning("view: cannot reach the Foxglove server: %s", error)
            client.close()
            return
        if not self._keep(client, upstream):
            client.close()
            upstream.close()
            return
        try:
            head, rest = _read_head(client)
            head, renamed = rewrite_request(head)
            upstream.sendall(head + rest)
            if renamed:
                answer, after = _read_head(upstream)
                client.sendall(_rewrite_answer(answer) + after)
        except OSError:
            self._drop(client, upstream)
            return
        back = threading.Thread(
            target=self._pipe,
            args=(upstream, client),
            name="fsw-view-relay-back",
            daemon=True,
        )
        back.start()
        self._pipe(client, upstream)
        back.join()
        self._drop(client, upstream)

    @staticmethod
    def _pipe(source: socket.socket, sink: socket.socket) -> None:
        """Copy ``source`` to ``sink`` until either side ends."""
        try:
            while chunk := source.recv(65536):
                sink.sendall(chunk)
        except OSError:
            pass
        with contextlib.suppress(OSError):
            sink.shutdown(socket.SHUT_WR)

    def _drop(self, *socks: socket.socket) -> None:
        with self._lock:
            for sock in socks:
                self._open.discard(sock)
        for sock in socks:
            sock.close()
