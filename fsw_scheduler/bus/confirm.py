"""A goal accepted waits for a standby's word that it holds the step.

A goal's ``goal_accepted`` is a promise: the goal will be planned, by
this node or by whichever takes over. A standby that takes over holds
what was shared with it, and a standby that boots after both computers
were reset holds what it saved. So before a step whose outputs accept
a goal reach the bus, the commander waits until a standby says
(``scheduler/saved``) it holds the state up to that step: in its folder
and synced, when it has one.

The wait is bounded (:data:`CONFIRM_WAIT_S`): a standby that does not
answer in time (stopped, its disk slow) costs one wait, after which the
commander no longer waits until a standby answers again; it says so in
its log. A commander with no standby on the bus never waits.
"""

from __future__ import annotations

import logging
import threading
from typing import TYPE_CHECKING, Any

import msgspec
import zenoh

from ..wire import messages, topics

if TYPE_CHECKING:
    from .standby import SharedState

log = logging.getLogger("fsw_scheduler.node")
JSON = zenoh.Encoding.APPLICATION_JSON

#: Longest wait for a standby's word before a goal accepted goes out anyway.
CONFIRM_WAIT_S = 0.5

#: The verdict that is a promise to keep: a goal rejected is not
#: planned, and a flood of rejected inputs must not cost a save each.
PROMISE = "goal_accepted"


def holds_verdict(outputs: list[tuple[str, msgspec.Struct]]) -> bool:
    """Whether a step's outputs accept a goal."""
    return any(
        isinstance(message, messages.Status) and message.event == PROMISE
        for _, message in outputs
    )


class StandbyConfirmations:
    """What the standbys said they hold (``scheduler/saved``), and the
    commander's bounded wait for it.

    Parameters
    ----------
    session
        The commander's Zenoh session.
    keys
        Its key expressions.
    wait_s
        The bound of one wait.

    Attributes
    ----------
    waits, late, volatile
        Waits, waits that ran out, and confirmations from a standby that
        holds the state in memory only.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: topics.Topics,
        wait_s: float = CONFIRM_WAIT_S,
    ) -> None:
        self.wait_s = wait_s
        self.waits = self.late = self.volatile = 0
        self._cond = threading.Condition()
        self._held: dict[str, int] = {}
        # After a wait that ran out, none until a standby answers again.
        self._lagging = False
        self._subscriber: Any = session.declare_subscriber(
            keys.key(topics.SAVED), self._on_saved
        )

    def _on_saved(self, sample: zenoh.Sample) -> None:
        try:
            saved = msgspec.json.decode(
                sample.payload.to_bytes(), type=messages.Saved
            )
        except msgspec.DecodeError:
            return
        with self._cond:
            if saved.seq > self._held.get(saved.stream, 0):
                self._held[saved.stream] = saved.seq
            self.volatile += not saved.durable
            self._lagging = False
            self._cond.notify_all()

    def wait(self, stream: str, seq: int) -> bool:
        """Wait until a standby holds message ``seq`` of ``stream``; False
        if none said so within the bound (or one did not before)."""
        with self._cond:
            if self._lagging:
                return False
            self.waits += 1
            if self._cond.wait_for(
                lambda: self._held.get(stream, 0) >= seq, self.wait_s
            ):
                return True
            self.late += 1
            self._lagging = True
        log.warning(
            "no standby said it holds the state of %s #%d within %g s: "
            "goals are accepted without it until one does",
            stream,
            seq,
            self.wait_s,
        )
        return False

    def close(self) -> None:
        """Stop listening (idempotent)."""
        subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            try:
                subscriber.undeclare()
            except zenoh.ZError as error:  # session already closed
                log.debug("undeclare: %s", error)


def say_saved(
    session: zenoh.Session,
    keys: topics.Topics,
    node_id: str,
    shared: SharedState,
) -> None:
    """A standby says (``scheduler/saved``) that it holds the record a
    commander waits on: called from its loop after it followed the
    records and saved them (forced when one is awaited)."""
    due, shared.confirm_due = shared.confirm_due, None
    if due is None:
        return
    store = shared.store
    durable = store is not None and store.fault is None
    try:
        session.put(
            keys.key(topics.SAVED),
            messages.encode(messages.Saved(due[0], due[1], node_id, durable)),
            encoding=JSON,
        )
    except zenoh.ZError as error:
        log.warning("saying what is saved: %s", error)
