"""Where each input came from: the bus node's traceability.

Zenoh tells a subscriber little about a sample's sender:

- ``sample.source_info`` (session id, entity id, sequence number) is
  present only when the publisher sets it (``put(..., source_info=...)``);
  it is the sender's claim, not authenticated.
- The authenticated identity (the TLS certificate common name, or the
  user name) belongs to a *link*: ``session.info.links()`` gives it per
  directly connected session (``Link.auth_identifier``), but a sample does
  not say which link it arrived on.

With the secure profile the access-control policy closes the gap: a sample
on a key can only have come over a link whose certificate may publish on
that key. :class:`Provenance` combines the three: if the claimed session
has a direct link whose name the policy allows on the key, that name is
the identity (basis ``link``); otherwise the names of the connected links
the policy allows are (basis ``policy``). Behind a router, the only link
is the router's: the identity is the router's name.

The node calls :func:`capture` in its Zenoh callback (reading
the sample only) and the rest on its event loop: it journals each input's
:class:`~fsw_scheduler.wire.messages.Source` and sets ``source`` on the status
verdicts about that input, including a goal's later acceptance.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..engine.events import GoalArrived, InputRejected
from ..wire import messages
from .recent import Recent

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.events import Event

log = logging.getLogger("fsw_scheduler.node")

#: ``(zid, eid, sn)`` read from a sample in the Zenoh callback.
Origin = tuple[str, int | None, int | None]

#: Status events that are the verdict on the input being processed.
_VERDICTS = frozenset({"goal_rejected", "input_rejected", "activity", "drift"})

#: Goals waiting for their verdict, remembered at most (oldest forgotten).
MAX_PENDING_GOALS = 1024


def capture(sample: zenoh.Sample) -> Origin | None:
    """What a sample says about its sender (cheap; for Zenoh callbacks)."""
    info = sample.source_info
    if info is not None:
        return (str(info.source_id.zid), info.source_id.eid, info.source_sn)
    stamp = sample.timestamp
    if stamp is not None:
        return (str(stamp.get_id()), None, None)
    return None


class Provenance:
    """Sources of inputs, and of the verdicts about them.

    Parameters
    ----------
    publishers
        For a key, the certificate names the node's access-control policy
        lets publish on it (:func:`~fsw_scheduler.bus.security.
        policy_publishers`); None when there is no such policy.
    """

    def __init__(
        self,
        publishers: Callable[[str], frozenset[str] | None] | None = None,
    ) -> None:
        self._publishers = publishers
        self._lock = threading.Lock()
        self._links: dict[str, str] = {}
        self._goals: Recent[messages.Source] = Recent(MAX_PENDING_GOALS)
        self._current: messages.Source | None = None

    # -- links ---------------------------------------------------------------

    def declare(self, session: zenoh.Session) -> Any:
        """Follow the session's links; returns the listener to undeclare."""
        return session.info.declare_link_events_listener(
            zenoh.handlers.Callback(self._on_link, indirect=False),
            history=True,
        )

    def _on_link(self, event: Any) -> None:
        try:
            link = event.link
            zid = str(link.zid)
            with self._lock:
                if event.kind == zenoh.SampleKind.PUT:
                    self._links[zid] = link.auth_identifier or ""
                else:
                    self._links.pop(zid, None)
        except Exception:  # a raising callback fails silently in zenoh
            log.exception("link event not followed")

    # -- inputs ------------------------------------------------------------

    def resolve(self, key: str, origin: Origin | None) -> messages.Source:
        """The source of an input on ``key`` (see the module notes)."""
        zid, eid, sn = origin or ("", None, None)
        allowed = self._publishers(key) if self._publishers else None
        with self._lock:
            links = dict(self._links)
        identity, basis = "", ""
        name = links.get(zid, "")
        if name and (allowed is None or name in allowed):
            identity, basis = name, "link"
        elif allowed is not None:
            names = sorted({n for n in links.values() if n in allowed})
            if names:
                identity, basis = "|".join(names), "policy"
        return messages.Source(zid, eid, sn, identity, basis)

    def begin(self, event: Event | None, source: messages.Source) -> None:
        """An input's event is about to be processed."""
        self._current = source
        goal_id = None
        if isinstance(event, GoalArrived):
            goal_id = event.goal.goal_id
        elif isinstance(event, InputRejected):
            goal_id = event.goal_id
        if goal_id is not None:
            self._goals.put(goal_id, source)

    def end(self) -> None:
        """The input's event has been processed."""
        self._current = None

    # -- outputs ---------------------------------------------------------

    def annotate(self, message: msgspec.Struct) -> msgspec.Struct:
        """``message`` with the source of the input it is a verdict on."""
        if not isinstance(message, messages.Status):
            return message
        source = None
        if message.goal_id is not None and message.event in (
            "goal_accepted",
            "goal_rejected",
        ):
            source = self._goals.pop(message.goal_id)
        if source is None and message.event in _VERDICTS:
            source = self._current
        if source is None:
            return message
        return msgspec.structs.replace(message, source=source)
