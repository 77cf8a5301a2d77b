"""The node's inbox and worker: what Zenoh callbacks hand to the loop.

Zenoh callbacks only put raw samples and queries into the :class:`Inbox`
and never block: telemetry and clock samples are coalesced (the latest
per key wins; the others are counted as superseded), goals wait up to a
count and byte limit and beyond it are refused by name, never dropped
silently. An execution report that ends an activity (completed, failed)
is never replaced by a later one on the same key: the next waits behind
it. :class:`Worker` runs solves on a thread of their own, so that
dispatches keep their timing; results come back through the same inbox.
"""

from __future__ import annotations

import concurrent.futures
import queue
import threading
from collections import deque
from typing import TYPE_CHECKING, Any

import zenoh

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

    Every method is safe from any thread and returns at once; the loop
    takes items with :meth:`get`. Items are lists ``[kind, key, payload,
    arrived, origin]`` (``payload`` is any object for internal kinds;
    ``origin`` what a bus sample says of its sender, see
    :mod:`~fsw_scheduler.bus.provenance`).
    """

    def counters(self) -> dict[str, int]:
        """What the inbox refused or superseded, by status counter name."""
        return {
            "inputs_dropped": self.lost,
            "telemetry_superseded": self.superseded,
            "clock_superseded": self.clock_superseded,
            "goals_busy": self.busy,
            "queries_dropped": self.queries_dropped,
        }

    def __init__(self, max_goals: int, max_bytes: int) -> None:
        self.max_goals = max_goals
        self.max_bytes = max_bytes
        self._cond = threading.Condition(threading.Lock())
        self._items: deque[list[Any]] = deque()
        self._latest: dict[str, list[Any]] = {}
        self.goals = 0
        self.bytes = 0
        self.queries = 0
        self.busy_notices = 0
        self.superseded = 0
        self.clock_superseded = 0
        self.lost = 0
        self.busy = 0
        self.queries_dropped = 0

    def __len__(self) -> int:
        return len(self._items)

    def put_goal(
        self,
        key: str,
        payload: bytes,
        arrived: float,
        origin: Origin | None = None,
    ) -> bool:
        """Queue a goal; False when the limits are reached (not queued)."""
        with self._cond:
            if (
                self.goals >= self.max_goals
                or self.bytes + len(payload) > self.max_bytes
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
            self._items.append(["busy", goal_id, waiting, 0.0, None])
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
            if pending is not None:
                self.bytes += len(payload) - len(pending[2])
                pending[2] = payload
                pending[4] = origin
                if kind == "clock":
                    self.clock_superseded += 1
                else:
                    self.superseded += 1
                return
            if (
                self.bytes + len(payload) > self.max_bytes
                or len(self._latest) >= MAX_PENDING_KEYS
            ):
                self.lost += 1
                return
            self.bytes += len(payload)
            item = [kind, key, payload, 0.0, origin]
            self._latest[key] = item
            self._items.append(item)
            self._cond.notify()

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
            if not self._items and not self._cond.wait_for(
                lambda: bool(self._items), timeout
            ):
                return None
            item = self._items.popleft()
            kind = item[0]
            if kind == "goal":
                self.goals -= 1
                self.bytes -= len(item[2])
            elif kind == "busy":
                self.busy_notices -= 1
            elif kind == "query":
                self.queries -= 1
            elif self._latest.get(item[1]) is item:
                del self._latest[item[1]]
                self.bytes -= len(item[2])
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
