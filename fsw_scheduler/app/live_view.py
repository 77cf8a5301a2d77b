"""The bus side of ``fsw-scheduler view``: samples onto Foxglove channels.

:class:`LiveBridge` subscribes to everything under ``fsw/<sc>/`` on a
session it is given, asks the scheduler's queryables for its plan, status
and profiles once at start (a view opened after the first plan shows it at
once), and republishes each message on the :class:`LiveServer` channel of
its key. It derives, as the journal does and with the journal's own
:class:`~fsw_scheduler.journal.annotate.Annotator`, the channels the node
does not publish: level checks (``scheduler/levels``) and ``foxglove.Log``
entries (``scheduler/log``).

Read-only: it declares one subscriber and sends queries, never a
publisher or a put, so the monitor certificate of the secure profile is
enough. The Zenoh callback only queues the sample; one loop
(:meth:`LiveBridge.spin_once`) does the rest.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..bus.client import query_payload
from ..journal.annotate import Annotator, schema_lookup
from ..journal.channels import channel_spec
from ..wire import topics as keys
from ..wire.profiles import Profiles

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..view.live import LiveServer

__all__ = ["QUERIED", "LiveBridge"]

log = logging.getLogger("fsw_scheduler.view")

#: What is asked of the scheduler at start, in this order.
QUERIED = (keys.PLAN, keys.STATUS, keys.PROFILES, keys.NODE_INFO)

_JSON = ("application/json", "text/json")
_profiles_decoder = msgspec.json.Decoder(Profiles)


class LiveBridge:
    """Republish a spacecraft's bus traffic on a :class:`LiveServer`.

    Parameters
    ----------
    session
        An open Zenoh session (the caller owns it).
    server
        Where the messages go; its channels were declared up front.
    spacecraft
        The spacecraft id of the keys.
    wall_ns
        The clock that stamps messages (ns since the epoch).
    backlog
        Samples kept while the loop is behind; beyond it the oldest are
        dropped and counted in :attr:`dropped` (a view must never hold
        the bus back).

    Attributes
    ----------
    received
        Bus samples handled.
    dropped
        Samples lost because the loop fell ``backlog`` behind.
    skipped
        Samples not shown: not JSON.
    seeded
        Topics filled from the start-up queries.
    """

    def __init__(
        self,
        session: zenoh.Session,
        server: LiveServer,
        spacecraft: str = keys.DEFAULT_SPACECRAFT,
        *,
        wall_ns: Callable[[], int] = time.time_ns,
        backlog: int = 10_000,
    ) -> None:
        self.session = session
        self.server = server
        self.topics = keys.Topics(spacecraft)
        self._wall_ns = wall_ns
        self._lookup = schema_lookup(spacecraft)
        self._annotator = Annotator(self.topics)
        self._cond = threading.Condition()
        self._samples: collections.deque[tuple[str, bytes, str]] = (
            collections.deque(maxlen=backlog)
        )
        self._poked = False
        # Topics filled by a query: the same message seen live right
        # after is the one already shown (a plan answered and published).
        self._from_query: set[str] = set()
        self.received = 0
        self.dropped = 0
        self.skipped = 0
        self.seeded: list[str] = []
        self._subscriber: Any = None

    # -- life cycle --------------------------------------------------------

    def start(self, timeout: float = 3.0) -> list[str]:
        """Subscribe, then ask the scheduler for its current state.

        Parameters
        ----------
        timeout
            Seconds to wait for each answer; with no scheduler on the bus
            the view starts empty and fills as messages arrive.

        Returns
        -------
        list of str
            The key suffixes the scheduler answered (see :data:`QUERIED`).
        """
        # Subscribed first: nothing published during the queries is lost.
        self._subscriber = self.session.declare_subscriber(
            self.topics.everything, self._on_sample
        )
        answered = []
        for suffix in QUERIED:
            key = self.topics.key(suffix)
            try:
                payload = query_payload(self.session, key, timeout)
            except zenoh.ZError as error:  # e.g. refused by the policy
                log.warning("query %s failed: %s", key, error)
                continue
            if payload is None:
                continue
            answered.append(suffix)
            self._show(key, payload)
            self._from_query.add(key)
            self.seeded.append(key)
        return answered

    def close(self) -> None:
        """Undeclare the subscriber (idempotent); the session stays."""
        subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            try:
                subscriber.undeclare()
            except zenoh.ZError as error:
                log.debug("undeclare: %s", error)

    def __enter__(self) -> LiveBridge:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def poke(self) -> None:
        """Wake :meth:`spin_once` (a client subscribed: give it the
        latest); safe from any thread."""
        with self._cond:
            self._poked = True
            self._cond.notify_all()

    # -- the loop ----------------------------------------------------------

    def spin_once(self, timeout: float = 0.2) -> int:
        """Handle what arrived (or wait up to ``timeout`` for something).

        Returns
        -------
        int
            Samples handled plus latest messages sent to new subscribers.
        """
        with self._cond:
            self._cond.wait_for(
                lambda: bool(self._samples) or self._poked, timeout
            )
            batch = list(self._samples)
            self._samples.clear()
            self._poked = False
        for key, payload, encoding in batch:
            self._handle(key, payload, encoding)
        return len(batch) + self.server.replay_pending()

    def run(self, stop: threading.Event, tick: float = 0.2) -> None:
        """:meth:`spin_once` until ``stop`` is set; a fault in one message
        is logged and the view goes on."""
        while not stop.is_set():
            try:
                self.spin_once(tick)
            except Exception:
                log.exception("live view: a message could not be shown")

    # -- internals ---------------------------------------------------------

    def _on_sample(self, sample: zenoh.Sample) -> None:
        # A Zenoh thread: queue only, never raise (Zenoh would only log).
        try:
            item = (
                str(sample.key_expr),
                sample.payload.to_bytes(),
                str(sample.encoding),
            )
        except Exception:
            log.exception("unreadable sample")
            return
        with self._cond:
            if len(self._samples) == self._samples.maxlen:
                self.dropped += 1
            self._samples.append(item)
            self._cond.notify_all()

    def _handle(self, key: str, payload: bytes, encoding: str) -> None:
        self.received += 1
        if encoding.split(";", 1)[0].strip() not in _JSON:
            self.skipped += 1
            return
        if key in self._from_query:
            self._from_query.discard(key)
            if self.server.latest(key) == payload:
                return
        self._show(key, payload)

    def _show(self, key: str, payload: bytes) -> None:
        """Publish on the key's channel, then what the journal derives."""
        now = self._wall_ns()
        self._publish(key, payload, now)
        if self.topics.suffix(key) == keys.PROFILES:
            self._on_profiles(payload)
        for derived in self._annotator.observe(key, payload, now):
            if not derived.publish:  # published ones come from the bus
                self._publish(
                    self.topics.key(derived.suffix), derived.payload, now
                )

    def _on_profiles(self, payload: bytes) -> None:
        try:
            profiles = _profiles_decoder.decode(payload)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return
        # The node's own prediction: level checks compare with it.
        self._annotator.profiles = profiles
        # Its resources are those whose levels will be measured: their
        # channels exist before the first level, for panels to subscribe.
        for resource in profiles.levels:
            self._declared(self.topics.resource_level(resource))

    def _publish(self, key: str, payload: bytes, now: int) -> None:
        # The journal's channels: every dispatch on one, declared up
        # front. Keys with a name chunk (a report, a resource) get their
        # channel at first sight; the server gives that first message to
        # whoever subscribes next, so it is not lost.
        key = keys.journal_key(key)
        self._declared(key)
        self.server.publish(key, payload, now)

    def _declared(self, key: str) -> None:
        """Declare the channel of ``key`` unless it exists (its spec is
        built only then: this runs for every message)."""
        if key not in self.server:
            self.server.declare(channel_spec(key, self._lookup))
