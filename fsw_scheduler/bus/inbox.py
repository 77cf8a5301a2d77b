"""The node's inbox and worker: what Zenoh callbacks hand to the loop.

Zenoh callbacks only put raw samples and queries into the :class:`Inbox`
and never block: telemetry and clock samples are coalesced (the latest
per key wins; the others are counted as superseded), goals wait up to a
count and byte limit and beyond it are refused by name, never dropped
silently; telemetry that finds the bytes spent is dropped unread and
answered too, one counted answer per key and :data:`DROP_NOTICE_S`. An
execution report that ends an activity (completed, failed) is never
replaced by a later one on the same key: the next waits behind
it. :class:`Worker` runs solves on a thread of their own, so that
dispatches keep their timing; results come back through the same inbox.
"""

from __future__ import annotations

import concurrent.futures
import heapq
import queue
import threading
import time
from collections import deque
from typing import TYPE_CHECKING, Any

import zenoh

from ..runtime.inputs import goal_id_of
from ..wire import topics
from ..wire.messages import Busy, Dropped
from .recent import Recent

if TYPE_CHECKING:
    from collections.abc import Callable

    from .provenance import Origin


#: Queries waiting for the loop; more are dropped (the querier gets no
#: reply) and counted.
MAX_WAITING_QUERIES = 256


#: Telemetry and clock keys with a sample waiting; a sample on one more
#: key is dropped and counted (``inputs_dropped``). Far above the keys a
#: node has (one per live task and consumable), it bounds the memory a
#: flood of made-up keys can take.
MAX_PENDING_KEYS = 4096


#: Goals refused unread whose rejection waits to be published; beyond
#: it, a refused goal is only counted in :attr:`Inbox.busy` (never seen in
#: practice: publishing one takes far less time than receiving one).
MAX_BUSY_NOTICES = 65536
#: Accepted goal ids an inbox remembers (as many as the largest ledger).
MAX_ACCEPTED_IDS = 65536


#: Seconds between two answers to telemetry dropped on one key. The first
#: drop on a key is answered at once; the drops within this interval after
#: an answer are answered together, with their count, when it ends. A
#: flood of dropped samples (each of which would otherwise be answered by
#: a status message as large as itself or larger) thus costs at most one
#: ``input_rejected`` per key and second, and the sender still learns of
#: every sample it lost, and how many.
DROP_NOTICE_S = 1.0

#: Keys whose drops wait for their answer; drops on one more key are
#: counted into a single answer for all keys (see ``Inbox(others=)``), so
#: a flood of made-up keys cannot grow the tallies without bound.
MAX_DROP_KEYS = 1024


#: The node's notices of inputs refused unread, journaled on these keys
#: (items ``[kind, key, message, 0.0, origin]``).
NOTICES = {"busy": topics.BUSY, "dropped": topics.DROPPED}


#: Inbox kinds of :meth:`Inbox.put_latest`: one waits per key.
COALESCED = frozenset(
    {
        "clock",
        "activity_report",
        "resource_level",
        "resource_forecast",
        "facts",
    }
)


#: Inbox kinds that are samples from the bus (the others are the node's
#: own notices: busy, stalled, explained...): only these have a source.
BUS_INPUTS = frozenset(
    {
        "goal",
        "clock",
        "activity_report",
        "resource_level",
        "resource_forecast",
    }
)


class Worker:
    """One daemon thread running jobs in order (the solves).

    Daemon, unlike ``ThreadPoolExecutor``'s threads, which the interpreter
    joins at exit: a stopping node must not wait for a solve to finish.
    """

    def __init__(self, name: str) -> None:
        self._jobs: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(
            target=self._run, name=name, daemon=True
        )
        self._thread.start()

    def submit(
        self, fn: Callable[..., Any], *args: Any
    ) -> concurrent.futures.Future:
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._jobs.put((future, fn, args))
        return future

    def shutdown(self) -> None:
        self._jobs.put(None)

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            future, fn, args = job
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(fn(*args))
            except BaseException as error:  # reported as SolveFailed
                future.set_exception(error)


def _ends_activity(kind: str, payload: bytes) -> bool:
    """Whether a waiting sample is a report that ends an activity (or
    answers a cancel), or facts handed over at a heal: never replaced."""
    return kind == "facts" or (
        kind == "activity_report"
        and (
            b'"failed"' in payload
            or b'"completed"' in payload
            or b'"cancelled"' in payload
        )
    )


class Inbox:
    """What the Zenoh callbacks hand to the loop: bounded, never blocking.

    Parameters
    ----------
    max_goals
        Undecoded goals that may wait.
    max_bytes
        Payload bytes that may wait (goals and telemetry together).
    seconds
        The shell's monotonic clock, in seconds (paces drop answers).
    others
        The key that names "any key" in the answer to drops beyond
        :data:`MAX_DROP_KEYS` keys (the node gives ``<root>/**``).

    Every method is safe from any thread and returns at once; the loop
    takes items with :meth:`get`. Items are lists ``[kind, key, payload,
    arrived, origin]`` (``payload`` is any object for internal kinds;
    ``origin`` what a bus sample says of its sender, see
    :mod:`~fsw_scheduler.bus.provenance`).
    """

    def __init__(
        self,
        max_goals: int,
        max_bytes: int,
        seconds: Callable[[], float] = time.monotonic,
        others: str = "**",
    ) -> None:
        self.max_goals = max_goals
        self.max_bytes = max_bytes
        self._seconds = seconds
        self._others = others
        self._cond = threading.Condition(threading.Lock())
        self._items: deque[list[Any]] = deque()
        self._latest: dict[str, list[Any]] = {}
        # Drops not answered yet: key -> [kind, count, size, origin]; the
        # keys whose answer is due, and (due time, key) of those held back
        # by DROP_NOTICE_S; key -> when its last answer was handed out.
        self._drops: dict[str, list[Any]] = {}
        self._due: deque[str] = deque()
        self._held: list[tuple[float, str]] = []
        self._answered: dict[str, float] = {}
        self.goals = 0
        self.bytes = 0
        self.queries = 0
        self.busy_notices = 0
        self.superseded = 0
        self.clock_superseded = 0
        self.lost = 0
        self.busy = 0
        self.queries_dropped = 0
        #: Goal ids accepted (the newest :data:`MAX_ACCEPTED_IDS`): a goal
        #: sent again under one of them is queued past the count limit, to
        #: be answered that its verdict stands, not "busy".
        self._accepted: Recent[None] = Recent(MAX_ACCEPTED_IDS)

    def note_verdict(self, goal_id: str | None, event: str) -> None:
        """A goal's verdict (from the loop): an id ``goal_accepted`` is
        remembered."""
        if goal_id is None or event != "goal_accepted":
            return
        with self._cond:
            self._accepted.put(goal_id, None)

    def counters(self) -> dict[str, int]:
        """What the inbox refused or superseded, by status counter name."""
        return {
            "inputs_dropped": self.lost,
            "telemetry_superseded": self.superseded,
            "clock_superseded": self.clock_superseded,
            "goals_busy": self.busy,
            "queries_dropped": self.queries_dropped,
        }

    def __len__(self) -> int:
        return len(self._items)

    def put_goal(
        self,
        key: str,
        payload: bytes,
        arrived: float,
        origin: Origin | None = None,
    ) -> bool:
        """Queue a goal; False when the limits are reached (not queued).

        Past the count limit (not the byte limit), a goal whose id was
        accepted is queued all the same: the sender sends it again for
        want of a verdict, and "busy" would be a second verdict.
        """
        with self._cond:
            if self.bytes + len(payload) > self.max_bytes or (
                self.goals >= self.max_goals
                and goal_id_of(payload) not in self._accepted
            ):
                return False
            self.goals += 1
            self.bytes += len(payload)
            self._items.append(["goal", key, payload, arrived, origin])
            self._cond.notify()
            return True

    def put_busy(self, goal_id: str | None, waiting: int) -> None:
        """Queue the rejection of a goal refused by :meth:`put_goal`."""
        with self._cond:
            self.busy += 1
            if self.busy_notices >= MAX_BUSY_NOTICES:
                return
            self.busy_notices += 1
            notice = Busy(goal_id, waiting)
            self._items.append(["busy", goal_id, notice, 0.0, None])
            self._cond.notify()

    def put_latest(
        self,
        kind: str,
        key: str,
        payload: bytes,
        origin: Origin | None = None,
    ) -> None:
        """Queue a sample; a newer one on the same key replaces it.

        Except an execution report that ends an activity (``failed``,
        ``completed``, ``cancelled``) and facts handed over at a heal:
        it is never replaced, the newer sample queues
        behind it, so that a failure followed at once by a new ``running``
        still triggers its replan. (The test is on the raw bytes, to stay
        cheap in the callback; a false match only means less coalescing.)
        """
        with self._cond:
            pending = self._latest.get(key)
            if pending is not None and _ends_activity(kind, pending[2]):
                pending = None
                del self._latest[key]
            grown = len(payload) - (0 if pending is None else len(pending[2]))
            if self.bytes + grown > self.max_bytes or (
                pending is None and len(self._latest) >= MAX_PENDING_KEYS
            ):
                # Also a replacement: a huge sample must not pass the
                # bytes bound by taking a waiting one's place.
                self.lost += 1
                self._drop(kind, key, len(payload), origin)
                return
            if pending is not None:
                self.bytes += grown
                pending[2] = payload
                pending[4] = origin
                if kind == "clock":
                    self.clock_superseded += 1
                else:
                    self.superseded += 1
                return
            self.bytes += len(payload)
            item = [kind, key, payload, 0.0, origin]
            self._latest[key] = item
            self._items.append(item)
            self._cond.notify()

    def _drop(
        self, kind: str, key: str, size: int, origin: Origin | None
    ) -> None:
        """Count a dropped sample into the answer its key will get."""
        tally = self._drops.get(key)
        if tally is None and len(self._drops) >= MAX_DROP_KEYS:
            key, kind = self._others, "telemetry"
            tally = self._drops.get(key)
        if tally is not None:
            tally[1] += 1
            tally[2] = max(tally[2], size)
            tally[3] = origin  # the latest sender is named
            return
        self._drops[key] = [kind, 1, size, origin]
        last = self._answered.get(key)
        if last is not None and self._seconds() < last + DROP_NOTICE_S:
            heapq.heappush(self._held, (last + DROP_NOTICE_S, key))
        else:
            self._due.append(key)
            self._cond.notify()

    def _ready(self) -> bool:
        """Whether :meth:`get` has an item (under the lock)."""
        return bool(self._items or self._due) or bool(
            self._held and self._held[0][0] <= self._seconds()
        )

    def _answer_drops(self) -> list[Any] | None:
        """The answer to the drops on one key, if one is due (under the
        lock): ``["dropped", key, Dropped, 0.0, origin]``."""
        now = self._seconds()
        while self._held and self._held[0][0] <= now:
            self._due.append(heapq.heappop(self._held)[1])
        if not self._due:
            return None
        key = self._due.popleft()
        kind, count, size, origin = self._drops.pop(key)
        # Keys answered longer ago than the interval need no memory (the
        # dict is in answer order: the oldest first).
        while self._answered:
            oldest = next(iter(self._answered))
            if self._answered[oldest] + DROP_NOTICE_S > now:
                break
            del self._answered[oldest]
        self._answered.pop(key, None)
        self._answered[key] = now
        message = Dropped(key, kind, count, size, self.max_bytes)
        return ["dropped", key, message, 0.0, origin]

    def put_query(self, item: Any) -> bool:
        """Queue a query; False when too many wait (caller drops it)."""
        with self._cond:
            if self.queries >= MAX_WAITING_QUERIES:
                self.queries_dropped += 1
                return False
            self.queries += 1
            self._items.append(["query", "", item, 0.0, None])
            self._cond.notify()
            return True

    def put(self, kind: str, item: Any) -> None:
        """Queue an internal item (solve results, wake-ups): unbounded."""
        with self._cond:
            self._items.append([kind, "", item, 0.0, None])
            self._cond.notify()

    def get(self, timeout: float) -> list[Any] | None:
        """The oldest item, waiting up to ``timeout`` s (None: nothing)."""
        with self._cond:
            if self._held:  # wait no longer than until they are due
                due = self._held[0][0] - self._seconds()
                timeout = max(min(timeout, due), 0.0)
            if not self._ready() and not self._cond.wait_for(
                self._ready, timeout
            ):
                return None
            # Answers to drops first: they are few (one per key and
            # DROP_NOTICE_S) and must not wait behind the flood itself.
            item = self._answer_drops() or self._items.popleft()
            kind = item[0]
            if kind == "goal":
                self.goals -= 1
                self.bytes -= len(item[2])
            elif kind == "busy":
                self.busy_notices -= 1
            elif kind == "query":
                self.queries -= 1
            elif kind in COALESCED:
                # Its bytes even when it left _latest for a newer sample
                # behind it (a report that ends an activity).
                self.bytes -= len(item[2])
                if self._latest.get(item[1]) is item:
                    del self._latest[item[1]]
            return item


def direct(callback: Callable[[Any], None]) -> zenoh.handlers.Callback:
    """Run ``callback`` on the Zenoh network thread itself.

    By default zenoh-python hands every callback to a thread of its own, so
    samples of different keys (a clock tick, then a goal, then a status
    query) could reach the inbox out of their arrival order, and the loop
    would see another order than the bus did. Our callbacks only enqueue,
    so running them directly is cheap and keeps the order.
    """
    return zenoh.handlers.Callback(callback, indirect=False)
