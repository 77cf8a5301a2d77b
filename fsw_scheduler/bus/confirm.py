"""A goal accepted waits for a standby's word that it holds the step.

A goal's ``goal_accepted`` is a promise: the goal will be planned, by
this node or by whichever takes over. A standby that takes over holds
what was shared with it, and a standby that boots after both computers
were reset holds what it saved. So the ``goal_accepted`` of a step is
held back until a standby says (``scheduler/saved``) it holds the state
up to that step: in its folder and synced, when it has one. Only the
verdict waits: the step's plan and dispatches go out at once, and the
commander goes on with its next inputs meanwhile (a loop that stopped
for it would hold clock ticks back behind the executors' reports).

The wait is bounded (:data:`CONFIRM_WAIT_S`): a standby that does not
answer in time (stopped, its disk slow, cut off) costs one wait, after
which verdicts go out at once until a standby answers again. That, and
a standby that answers but cannot save (its disk full), leave goals
accepted meanwhile held by the commander alone (or in the standby's
memory): the commander says so, status ``alarm`` (state ``degraded``,
on the bus only: it is not a decision a replay reproduces), once per
episode. A commander with no standby on the bus never waits.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from typing import TYPE_CHECKING, Any, TypeGuard

import msgspec
import zenoh

from ..wire import messages, topics
from .recent import Recent

if TYPE_CHECKING:
    from collections.abc import Callable

    from .standby import SharedState

log = logging.getLogger("fsw_scheduler.node")
JSON = zenoh.Encoding.APPLICATION_JSON

#: Longest wait for a standby's word before a goal accepted goes out anyway.
CONFIRM_WAIT_S = 0.5

#: Goal ids a commander remembers as held by a standby.
MAX_KEPT = 65536

#: The verdict that is a promise to keep: a goal rejected is not
#: planned, and a flood of rejected inputs must not cost a save each.
PROMISE = "goal_accepted"


def is_promise(message: msgspec.Struct) -> TypeGuard[messages.Status]:
    """Whether ``message`` accepts a goal."""
    return isinstance(message, messages.Status) and message.event == PROMISE


class StandbyConfirmations:
    """What the standbys said they hold (``scheduler/saved``), and the
    verdicts held back until they do.

    Parameters
    ----------
    session
        The commander's Zenoh session.
    keys
        Its key expressions.
    wait_s
        The bound of one wait.
    say
        Publishes an alarm (from the commander's loop).
    wake
        Called when a standby's word comes (from a Zenoh callback: it
        only wakes the commander's loop).

    Attributes
    ----------
    waits, late, volatile
        Verdicts held back, waits that ran out, and confirmations from a
        standby that holds the state in memory only.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: topics.Topics,
        wait_s: float = CONFIRM_WAIT_S,
        say: Callable[[str], None] | None = None,
        wake: Callable[[], None] | None = None,
    ) -> None:
        self.wait_s = wait_s
        self.waits = self.late = self.volatile = 0
        self._say = say
        self._wake = wake
        self._lock = threading.Lock()
        self._held: dict[str, int] = {}
        # After a wait that ran out, none until a standby answers again.
        self._lagging = False
        # A standby's save fault: the one said last, the one seen last.
        self._fault_said = self._fault = ""
        #: Held back: (deadline, stream, seq, the step's verdicts, their
        #: goal ids).
        self._waiting: deque[
            tuple[float, str, int, list[Any], tuple[str, ...]]
        ] = deque()
        # Goal ids whose acceptance a standby said it holds (the newest
        # MAX_KEPT): the same verdict again, for a re-sent goal, need not
        # wait nor cost the standby a save.
        self._kept: Recent[None] = Recent(MAX_KEPT)
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
        with self._lock:
            if saved.seq > self._held.get(saved.stream, 0):
                self._held[saved.stream] = saved.seq
            self.volatile += not saved.durable
            self._lagging = False
            self._fault = (
                f"standby {saved.node_id} cannot save its copy "
                f"({saved.fault[:200]})"
                if saved.fault
                else ""
            )
        if self._wake is not None:
            self._wake()

    def healthy(self) -> bool:
        """Whether the standby's last word came in time and said saved
        (so that no alarm of this episode stands)."""
        with self._lock:
            return not self._lagging and not self._fault

    def kept(self, goal_id: str | None) -> bool:
        """Whether a standby said it holds ``goal_id``'s acceptance."""
        return goal_id in self._kept

    def hold(
        self,
        stream: str,
        seq: int,
        verdicts: list[Any],
        goal_ids: tuple[str, ...] = (),
    ) -> bool:
        """Hold ``verdicts`` (accepting ``goal_ids``) back until a standby
        holds message ``seq`` of ``stream`` (see :meth:`release`); False
        when they need not wait (a wait ran out before and no standby
        answered since)."""
        with self._lock:
            if self._lagging and not self._waiting:
                return False
            self.waits += 1
        deadline = time.monotonic() + self.wait_s
        self._waiting.append((deadline, stream, seq, verdicts, goal_ids))
        return True

    def release(self) -> tuple[list[Any], float | None]:
        """The verdicts free to go now, in order, and the seconds until
        the next one is due anyway (None: none waits)."""
        free: list[Any] = []
        now = time.monotonic()
        while self._waiting:
            deadline, stream, seq, verdicts, goal_ids = self._waiting[0]
            with self._lock:
                said = self._held.get(stream, 0) >= seq
                held = said or self._lagging
                fault = self._fault
            if not held and now < deadline:
                return free, deadline - now
            if not held:
                with self._lock:
                    self.late += 1
                    self._lagging = True
                self._alarm(
                    f"no standby said within {self.wait_s:g} s that it "
                    f"holds the state of {stream} #{seq}"
                )
            elif fault and fault != self._fault_said:
                self._alarm(fault)
            self._fault_said = fault
            self._waiting.popleft()
            free += verdicts
            for goal_id in goal_ids if said and not fault else ():
                self._kept.put(goal_id, None)
        return free, None

    def _alarm(self, why: str) -> None:
        """Say that goals accepted now may be held by this node alone."""
        detail = (
            f"{why}: goals accepted until a standby holds them again are "
            "lost if both computers are reset"
        )
        log.warning("%s", detail)
        if self._say is not None:
            self._say(detail)

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
    fault = store.fault if store is not None else None
    saved = messages.Saved(
        due[0], due[1], node_id, store is not None and not fault, fault or ""
    )
    try:
        session.put(
            keys.key(topics.SAVED), messages.encode(saved), encoding=JSON
        )
    except zenoh.ZError as error:
        log.warning("saying what is saved: %s", error)
