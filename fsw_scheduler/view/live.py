"""A Foxglove WebSocket server that gives new subscribers the latest message.

foxglove-sdk's server (``foxglove.start_server``) sends a client only what
is logged after it subscribed, and a channel it learns of at its first
message loses that message. :class:`LiveServer` therefore declares its
channels before the server starts, keeps the latest message of each, and
sends it again when a client subscribes, so that a Foxglove window opened
at any time shows the current plan and status at once. Clients reach it
through :class:`~.subprotocol.SubprotocolBridge`, so that one offering
only the older ``foxglove.websocket.v1`` is served too. Channels are those
of the journal (:mod:`fsw_scheduler.journal.channels`): the same layout
opens a recording and a running scheduler.

No bus here: :mod:`fsw_scheduler.app.live_view` feeds it from Zenoh.
foxglove-sdk is the optional ``view`` extra, imported only when a server
is built.
"""

from __future__ import annotations

import logging
import queue
from typing import TYPE_CHECKING, Any

from .subprotocol import SubprotocolBridge

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable

    from ..journal.channels import ChannelSpec

__all__ = [
    "LIVE_INSTALL_HINT",
    "LiveServer",
    "have_foxglove",
]

log = logging.getLogger("fsw_scheduler.view")

#: How to get what :class:`LiveServer` needs.
LIVE_INSTALL_HINT = "pip install 'fsw-scheduler[view]'"


def have_foxglove() -> bool:
    """Whether foxglove-sdk (the ``view`` extra) can be imported."""
    try:
        import foxglove  # noqa: F401
    except ImportError:
        return False
    return True


def _listener(subscribed: Callable[[int], None]) -> Any:
    """The server's callbacks: only hand the subscribed channel id over.

    They run on the server's own thread; logging from there could wait on
    the server itself, so the owner's loop sends the message instead.
    """
    from foxglove.websocket import ChannelView, Client, ServerListener

    class Listener(ServerListener):
        def on_subscribe(self, client: Client, channel: ChannelView) -> None:
            subscribed(channel.id)

    return Listener()


class LiveServer:
    """Channels declared up front, served over the Foxglove WebSocket
    protocol, each new subscriber given the channel's latest message.

    Not thread-safe: one thread calls :meth:`publish`, :meth:`declare` and
    :meth:`replay_pending` (the server's callbacks only enqueue).

    Parameters
    ----------
    channels
        The channels to declare before the server starts.
    host
        Address to bind (``127.0.0.1``: this computer only).
    port
        TCP port; 0 picks a free one (see :attr:`port`).
    name
        The server name clients show.
    no_replay
        Topics whose latest message is not sent again to a new
        subscriber: event streams (log entries), where everyone already
        subscribed would see the repeat as a new event.
    on_subscribe
        Called (on the server's thread) when a client subscribes, e.g. to
        wake the loop that calls :meth:`replay_pending`.

    Raises
    ------
    ImportError
        If foxglove-sdk is not installed (:data:`LIVE_INSTALL_HINT`).
    RuntimeError
        If the server cannot start (the port is taken).
    """

    def __init__(
        self,
        channels: Iterable[ChannelSpec],
        *,
        host: str = "127.0.0.1",
        port: int = 8765,
        name: str = "fsw-scheduler",
        no_replay: Iterable[str] = (),
        on_subscribe: Callable[[], None] | None = None,
    ) -> None:
        import foxglove

        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        self._topic_of: dict[int, str] = {}
        self._latest: dict[str, tuple[bytes, int]] = {}
        self._no_replay = frozenset(no_replay)
        self._subscribed: queue.SimpleQueue[int] = queue.SimpleQueue()
        self._wake = on_subscribe
        #: Messages sent again to new subscribers so far.
        self.replayed = 0
        for spec in channels:
            self.declare(spec)
        self.host = host
        # The SDK's server on a loopback port of its own, reached through
        # a relay that also takes the older subprotocol name.
        self._server: Any = foxglove.start_server(
            name=name,
            host="127.0.0.1",
            port=0,
            context=self._context,
            server_listener=_listener(self._on_subscribe),
        )
        try:
            self._relay = SubprotocolBridge(
                ("127.0.0.1", int(self._server.port)), host, port
            )
        except OSError:
            self._server.stop()
            raise

    # -- channels ----------------------------------------------------------

    def declare(self, spec: ChannelSpec) -> bool:
        """Declare a channel (clients are told at once); False if known."""
        if spec.topic in self._channels:
            return False
        schema = (
            self._foxglove.Schema(
                name=spec.schema_name,
                encoding=spec.schema_encoding,
                data=spec.schema,
            )
            if spec.schema_name
            else None
        )
        channel = self._foxglove.Channel(
            spec.topic,
            schema=schema,
            message_encoding=spec.message_encoding,
            context=self._context,
        )
        self._channels[spec.topic] = channel
        self._topic_of[channel.id()] = spec.topic
        return True

    def __contains__(self, topic: object) -> bool:
        return topic in self._channels

    @property
    def topics(self) -> list[str]:
        """Every declared topic, in declaration order."""
        return list(self._channels)

    def latest(self, topic: str) -> bytes | None:
        """The last payload published on ``topic`` (None before one)."""
        found = self._latest.get(topic)
        return None if found is None else found[0]

    def publish(self, topic: str, payload: bytes, log_time_ns: int) -> None:
        """Send ``payload`` to the subscribers of ``topic`` and keep it.

        Parameters
        ----------
        topic
            A declared topic.
        payload
            The JSON bytes.
        log_time_ns
            When it was seen, ns since the epoch.

        Raises
        ------
        KeyError
            If ``topic`` was not declared.
        """
        channel = self._channels[topic]
        self._latest[topic] = (payload, log_time_ns)
        channel.log(payload, log_time=log_time_ns)

    def replay_pending(self) -> int:
        """Send the latest message of each channel a client subscribed to
        since the last call; returns how many were sent.

        foxglove-sdk sends to every subscriber of a channel: those already
        subscribed get the latest message once more, with its first log
        time, which a state (a plan, a status) does not mind.
        """
        sent = 0
        while True:
            try:
                channel_id = self._subscribed.get_nowait()
            except queue.Empty:
                return sent
            topic = self._topic_of.get(channel_id)
            if topic is None or topic in self._no_replay:
                continue
            found = self._latest.get(topic)
            if found is None:
                continue
            payload, log_time_ns = found
            self._channels[topic].log(payload, log_time=log_time_ns)
            sent += 1
            self.replayed += 1

    def _on_subscribe(self, channel_id: int) -> None:
        self._subscribed.put(channel_id)
        if self._wake is not None:
            self._wake()

    # -- addresses ---------------------------------------------------------

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return self._relay.port

    @property
    def url(self) -> str:
        """``ws://host:port``: what Foxglove's "Open connection" takes."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def app_url(self, *, desktop: bool = False) -> str:
        """The app.foxglove.dev link that opens this server (in the
        desktop app with ``desktop``), as foxglove-sdk builds it."""
        from urllib.parse import quote

        link = str(self._server.app_url(open_in_desktop=desktop) or "")
        # The SDK names its own port; clients come in through the relay.
        inner = f"127.0.0.1:{self._server.port}"
        return link.replace(
            quote(inner, safe=""), quote(self.url[5:], safe="")
        )

    @property
    def open_url(self) -> str:
        """``foxglove://open?...``: opens the desktop app directly."""
        from urllib.parse import quote

        return "foxglove://open?ds=foxglove-websocket&ds.url=" + quote(
            self.url, safe=""
        )

    def close(self) -> None:
        """Stop the server and close the channels (idempotent)."""
        server, self._server = self._server, None
        if server is None:
            return
        self._relay.close()
        server.stop()
        for channel in self._channels.values():
            channel.close()

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()
