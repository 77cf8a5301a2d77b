"""A client of a scheduler node: publish goals and reports, wait for answers.

:class:`SchedulerClient` talks to a running node over an open Zenoh
session the way the autonomy layer and the spacecraft do: it publishes
goals, clock ticks, execution reports and levels, and waits (on matching
and on the node's answers, never on bare sleeps) for statuses, plans and
dispatches. The pytest plugin (:mod:`fsw_scheduler.testing`) builds on it.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from typing import TYPE_CHECKING, Any, TypeVar

import msgspec
import zenoh

from ..wire import messages
from ..wire import topics as keys
from .fence import Fence
from .session import (
    wait_matching,
    wait_until,
)

if TYPE_CHECKING:
    from collections.abc import Callable


__all__ = [
    "Fence",
    "SchedulerClient",
    "query_payload",
]


log = logging.getLogger("fsw_scheduler.testing")


JSON = zenoh.Encoding.APPLICATION_JSON


T = TypeVar("T")


#: Default deadline of the harness's waits, in seconds. Generous: a busy
#: CI machine may take a few seconds for a solve.
WAIT_S = 10.0

#: Seconds between two queries that no one answered (:func:`query_payload`).
REASK_S = 0.05


def _payload(message: object) -> bytes:
    """JSON bytes of a dict, a Struct, a str or bytes (passed through)."""
    if isinstance(message, bytes):
        return message
    if isinstance(message, str):
        return message.encode()
    if isinstance(message, msgspec.Struct):
        return messages.encode(message)
    return json.dumps(message).encode()


class SchedulerClient:
    """The rest of the spacecraft, as the scheduler sees it, on a session.

    Publishes clock ticks, goals and telemetry; records every plan,
    dispatch, status and solve record the scheduler publishes; asks its
    queryables. Works with any scheduler reachable from ``session``: the
    in-process one of :class:`SchedulerHarness` or a separate process.
    Create it before the scheduler publishes anything: :meth:`settle`
    waits until every plan and dispatch the scheduler has counted since
    its start has been received.

    Parameters
    ----------
    session
        An open Zenoh session (the caller owns it).
    spacecraft
        The spacecraft id of the scheduler's keys.
    timeout
        Default deadline of every wait, in seconds.
    answer_fences
        Answer ``scheduler/fences/<zid>`` (False: a receiver that cannot).

    Attributes
    ----------
    plans, dispatches, statuses, solves
        Every message received on ``scheduler/plan``,
        ``scheduler/dispatch/*``, ``scheduler/status`` and
        ``scheduler/solves``, in arrival order (the lists only grow).
    samples
        Every ``(key, payload)`` received under ``fsw/<sc>/scheduler/**``.
    decode_errors
        Samples that could not be decoded, as ``(key, error)``.
    """

    def __init__(
        self,
        session: zenoh.Session,
        spacecraft: str = keys.DEFAULT_SPACECRAFT,
        *,
        timeout: float = WAIT_S,
        answer_fences: bool = True,
    ) -> None:
        self.client = session
        self.topics = keys.Topics(spacecraft)
        self.timeout = timeout
        self._cond = threading.Condition()
        self.plans: list[messages.PlanMessage] = []
        self.dispatches: list[messages.Dispatch] = []
        self.statuses: list[messages.Status] = []
        self.solves: list[messages.SolveRecord] = []
        self.samples: list[tuple[str, bytes]] = []
        self.decode_errors: list[tuple[str, str]] = []
        #: The receiver's fence, the dispatches it let through (each
        #: ``dispatch_id`` once, no stale term), the cancels it obeyed and
        #: the blind dispatches it answered with an earlier run's report:
        #: what an executor that follows the README would have done.
        self.fence = Fence()
        self.executed: list[messages.Dispatch] = []
        self.cancels: list[messages.Dispatch] = []
        self.blind: list[messages.Dispatch] = []
        self._subscriber: Any = session.declare_subscriber(
            self.topics.key("scheduler/**"), self._on_sample
        )
        # A scheduler about to command asks what terms are in use: a
        # receiver's fence remembers one its own folder may have lost.
        self._fence_key = self.topics.key(
            f"{keys.FENCES}/{session.info.zid()}"
        )
        self._fence_answer: Any = None
        try:
            if answer_fences:
                self._fence_answer = session.declare_queryable(
                    self._fence_key, self._on_fence_query
                )
        except zenoh.ZError as error:  # refused (a secure profile's ACL)
            log.debug("no fence queryable: %s", error)

    def close(self) -> None:
        """Stop listening (idempotent); the session stays open."""
        subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            _undeclare(subscriber)
        answer, self._fence_answer = self._fence_answer, None
        if answer is not None:
            _undeclare(answer)

    def __enter__(self) -> SchedulerClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_scheduler(self, timeout: float | None = None) -> None:
        """Wait until a scheduler's inputs and queryables are reachable.

        Raises
        ------
        TimeoutError
            If no scheduler shows up in time.
        """
        timeout = timeout or self.timeout
        for key in (
            self.topics.key(keys.CLOCK),
            self.topics.key(keys.GOALS),
            self.topics.activity_report("probe"),
            self.topics.resource_level("probe"),
        ):
            wait_matching(self.client, key, timeout)
        for suffix in (keys.STATUS, keys.PLAN):
            self._wait_queryable(self.topics.key(suffix), timeout)

    def find_scheduler(self, timeout: float | None = None) -> None:
        """:meth:`wait_scheduler`, told early when it waits in vain.

        After a short wait the bus is asked which spacecraft have a
        scheduler alive: when others do and this one does not (a wrong
        ``--spacecraft``), waiting longer cannot help.

        Raises
        ------
        LookupError
            Schedulers of other spacecraft are alive, and none of this
            one; the message names them.
        TimeoutError
            No scheduler of this spacecraft in time.
        """
        timeout = timeout or self.timeout
        start = time.monotonic()
        first = min(timeout, _FIND_FIRST_S)
        try:
            self.wait_scheduler(first)
            return
        except TimeoutError:
            seen = spacecraft_on_bus(self.client)
            if seen and self.topics.spacecraft not in seen:
                raise LookupError(
                    f"no scheduler of {self.topics.spacecraft} on the bus; "
                    f"schedulers alive: {', '.join(seen)} (--spacecraft "
                    f"{seen[0]}?)"
                ) from None
        self.wait_scheduler(max(timeout - (time.monotonic() - start), 0.1))

    def put(self, key: str, message: object) -> None:
        """Publish ``message`` as JSON on ``key``.

        Parameters
        ----------
        key
            A full key (``fsw/sat1/clock``) or a suffix (``clock``).
        message
            A dict, a msgspec Struct, or raw bytes / str sent as given.
        """
        if self.topics.suffix(key) is None:
            key = self.topics.key(key)
        # Blocking congestion control: a test's inputs must never be
        # dropped by Zenoh's transmit queue, only by the node itself.
        self.client.put(
            key,
            _payload(message),
            encoding=JSON,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )

    def clock(self, now: int) -> None:
        """Publish ``{"now": now}`` on the clock key, without waiting."""
        self.put(keys.CLOCK, {"now": now})

    def tick(self, now: int, timeout: float | None = None) -> messages.Status:
        """Move the bus clock to ``now`` and wait until the node is idle.

        A clock going back is rejected by the scheduler, so ``tick`` would
        time out; send such a tick with :meth:`clock` and call
        :meth:`settle` without ``now``.

        Returns
        -------
        Status
            The node's status once it has processed the tick, no solve is
            running, and every plan and dispatch it reports has arrived.
        """
        self.clock(now)
        return self.settle(now, timeout)

    def publish_goal(self, goal: dict | bytes | str | msgspec.Struct) -> None:
        """Publish a goal document on ``scheduler/goals``."""
        self.put(keys.GOALS, goal)

    def verdicts(self, goal_id: str) -> set[str]:
        """The verdicts received for ``goal_id`` (``goal_accepted``,
        ``goal_rejected``), as a set: one element when all agree."""
        with self._cond:
            return {
                s.event
                for s in self.statuses
                if s.goal_id == goal_id and s.event in _VERDICTS
            }

    def send_goals(
        self,
        goals: list[dict],
        *,
        resend_s: float = 2.0,
        timeout: float | None = None,
    ) -> dict[str, set[str]]:
        """Publish ``goals`` and re-send, unchanged, each one still without
        a verdict every ``resend_s`` seconds: the sender's rule
        (docs/redundancy.md, "What a sender must do"), safe since a goal id
        is answered once.

        Returns
        -------
        dict
            Goal id -> its verdicts (see :meth:`verdicts`); empty for a
            goal still unanswered at ``timeout``.
        """
        deadline = time.monotonic() + (timeout or self.timeout)
        waiting = {g["goal_id"]: g for g in goals}
        for goal in goals:
            self.publish_goal(goal)
        last = time.monotonic()
        while waiting and time.monotonic() < deadline:
            with self._cond:
                self._cond.wait(0.1)
            waiting = {
                k: g for k, g in waiting.items() if not self.verdicts(k)
            }
            if waiting and time.monotonic() - last >= resend_s:
                for goal in waiting.values():
                    self.publish_goal(goal)
                last = time.monotonic()
        return {g["goal_id"]: self.verdicts(g["goal_id"]) for g in goals}

    def report(
        self, task: str, state: str, at: int, *, key_task: str | None = None
    ) -> None:
        """Publish an execution report of ``task``.

        It names the last dispatch of ``task`` received (its
        ``dispatch_id`` and ``term``), as an executor should.
        ``key_task`` publishes it on another task's key (a faulty
        executor).
        """
        report: dict[str, object] = {"task": task, "state": state, "at": at}
        with self._cond:
            last = next(
                (d for d in reversed(self.dispatches) if d.task == task), None
            )
        if last is not None and last.dispatch_id:
            report.update(dispatch_id=last.dispatch_id, term=last.term)
        self.put(self.topics.activity_report(key_task or task), report)

    def level(
        self,
        resource: str,
        level: float,
        at: int,
        *,
        key_resource: str | None = None,
    ) -> None:
        """Publish a measured level of ``resource``."""
        self.put(
            self.topics.resource_level(key_resource or resource),
            {"resource": resource, "level": level, "at": at},
        )

    def forecast(
        self,
        resource: str,
        at: int,
        **profile: list[list[float]],
    ) -> None:
        """Publish a forecast of ``resource`` from ``at`` on.

        ``profile`` is one of ``available`` (binary windows), ``steps``
        (multiple capacities) or ``external`` (a consumable's rate).
        """
        self.put(
            self.topics.resource_forecast(resource),
            {"resource": resource, "at": at, **profile},
        )

    # -- queries -------------------------------------------------------------

    def query_status(self, timeout: float | None = None) -> messages.Status:
        """Ask the node for its status.

        Raises
        ------
        TimeoutError
            If the node does not answer.
        """
        payload = self._query(keys.STATUS, timeout)
        if payload is None:
            raise TimeoutError("the scheduler did not answer a status query")
        return msgspec.json.decode(payload, type=messages.Status)

    def query_plan(
        self, timeout: float | None = None
    ) -> messages.PlanMessage | None:
        """Ask the node for its plan (None before the first plan)."""
        payload = self._query(keys.PLAN, timeout)
        if payload is None:
            return None
        return msgspec.json.decode(payload, type=messages.PlanMessage)

    def query_config(
        self, timeout: float | None = None
    ) -> messages.NodeInfo | None:
        """Ask the node for its settings and problem (``scheduler/config``);
        None from a node too old to answer, or one that does not."""
        payload = self._query(keys.NODE_INFO, timeout)
        if payload is None:
            return None
        try:
            return msgspec.json.decode(payload, type=messages.NodeInfo)
        except msgspec.DecodeError:  # a newer node's settings: not needed
            return None

    def what_if(
        self,
        goal: dict | bytes | str | msgspec.Struct,
        timeout: float | None = None,
    ) -> messages.WhatIfAnswer | None:
        """Ask what sending ``goal`` now would do (``scheduler/what-if``).

        Nothing changes on the node. The query says how long it waits
        (``?timeout=``), so that a node busy with a solve answers
        ``busy`` in time rather than never.

        Returns
        -------
        WhatIfAnswer or None
            None when no scheduler's what-if answered within ``timeout``
            (waiting for its queryable included).
        """
        timeout = timeout or self.timeout
        began = time.monotonic()
        try:
            # The queryable is declared with the node's other outputs:
            # a scheduler just seen alive may not have it yet.
            self._wait_queryable(self.topics.key(keys.WHAT_IF), timeout)
        except TimeoutError:
            return None
        timeout = max(timeout - (time.monotonic() - began), 0.1)
        key = f"{self.topics.key(keys.WHAT_IF)}?timeout={timeout:g}"
        answer = query_payload(
            self.client, key, timeout, payload=_payload(goal)
        )
        if answer is None:
            return None
        return msgspec.json.decode(answer, type=messages.WhatIfAnswer)

    def _query(self, suffix: str, timeout: float | None) -> bytes | None:
        return query_payload(
            self.client, self.topics.key(suffix), timeout or self.timeout
        )

    # -- waiting -------------------------------------------------------------

    def settle(
        self, now: int | None = None, timeout: float | None = None
    ) -> messages.Status:
        """Wait until the node has caught up and is not solving.

        The status query travels on the same link as the client's earlier
        puts and lands in the node's inbox behind them, so its answer
        reflects every input sent before. If a solve is running, the
        harness waits for the node's next output and asks again.

        Parameters
        ----------
        now
            Also wait until the node's time is ``now``.
        timeout
            Deadline in seconds.

        Returns
        -------
        Status
            The settled status.
        """
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            seen = len(self.samples)
            status = self.query_status(max(deadline - time.monotonic(), 0.1))
            if not status.busy and (now is None or status.now == now):
                break
            if time.monotonic() >= deadline:
                raise TimeoutError(
                    f"scheduler did not settle at now={now}: {status}"
                )
            # A solve finishing always publishes something: wake on it,
            # and re-ask at least every 50 ms anyway.
            with self._cond:
                self._cond.wait_for(
                    lambda seen=seen: len(self.samples) > seen,  # type: ignore[misc]
                    min(0.05, max(deadline - time.monotonic(), 0.0)),
                )
        self._await_outputs(status, deadline)
        return status

    def _await_outputs(self, status: messages.Status, deadline: float) -> None:
        """Wait until the client has every plan and dispatch counted."""

        def caught_up() -> bool:
            plans_ok = status.plan_id is None or any(
                p.plan_id >= status.plan_id for p in self.plans
            )
            return plans_ok and (
                len(self.dispatches) >= status.counters.dispatches
            )

        with self._cond:
            if not self._cond.wait_for(
                caught_up, max(deadline - time.monotonic(), 0.0)
            ):
                raise TimeoutError(
                    f"outputs missing: status says plan {status.plan_id} "
                    f"and {status.counters.dispatches} dispatches, client "
                    f"has {[p.plan_id for p in self.plans]} and "
                    f"{len(self.dispatches)}"
                )

    def wait_plan(
        self,
        predicate: Callable[[messages.PlanMessage], bool] | None = None,
        timeout: float | None = None,
        *,
        since: int = 0,
    ) -> messages.PlanMessage:
        """The newest received plan satisfying ``predicate``.

        Parameters
        ----------
        predicate
            Condition on the plan; None accepts any plan.
        timeout
            Deadline in seconds.
        since
            Ignore plans received before ``self.plans[since]``.
        """
        return self._wait_for(
            self.plans, predicate or (lambda _: True), timeout, since, "plan"
        )

    def wait_dispatch(
        self,
        task: str,
        timeout: float | None = None,
        *,
        plan_id: int | None = None,
        since: int = 0,
    ) -> messages.Dispatch:
        """The newest received dispatch of ``task`` (of ``plan_id``)."""
        return self._wait_for(
            self.dispatches,
            lambda d: (
                d.task == task and (plan_id is None or d.plan_id == plan_id)
            ),
            timeout,
            since,
            f"dispatch of {task}",
        )

    def wait_status(
        self,
        predicate: Callable[[messages.Status], bool],
        timeout: float | None = None,
        *,
        since: int = 0,
    ) -> messages.Status:
        """The newest received status message satisfying ``predicate``."""
        return self._wait_for(
            self.statuses, predicate, timeout, since, "status"
        )

    def wait_new(self, items: list[T], since: int, timeout: float) -> list[T]:
        """What this client's ``items`` (:attr:`statuses`, :attr:`plans`,
        ...) received from index ``since`` on, after waiting up to
        ``timeout`` seconds for the first (empty if none came)."""
        with self._cond:
            self._cond.wait_for(lambda: len(items) > since, timeout)
            return items[since:]

    def _wait_for(
        self,
        items: list[T],
        predicate: Callable[[T], bool],
        timeout: float | None,
        since: int,
        what: str,
    ) -> T:
        found: list[T] = []

        def ready() -> bool:
            found[:] = [m for m in items[since:] if predicate(m)][-1:]
            return bool(found)

        with self._cond:
            if self._cond.wait_for(ready, timeout or self.timeout):
                return found[0]
        raise TimeoutError(
            f"no matching {what} within {timeout or self.timeout} s "
            f"(received {len(items) - since})"
        )

    def _wait_queryable(self, key: str, timeout: float) -> None:
        querier = self.client.declare_querier(key)
        try:
            wait_until(
                lambda: _matching(querier.matching_status),
                timeout,
                what=f"a queryable on {key}",
            )
        finally:
            querier.undeclare()

    # -- the client's subscriber (runs on a Zenoh thread) --------------------

    def _on_sample(self, sample: zenoh.Sample) -> None:
        # Zenoh only logs an exception raised here; keep it visible to the
        # test through decode_errors instead.
        key = str(sample.key_expr)
        try:
            payload = sample.payload.to_bytes()
            kind = self.topics.schema_kind(key)
            decoded: Any = None
            target: list[Any] | None = None
            if kind in _KINDS:
                target = getattr(self, _KINDS[kind][0])
                decoded = msgspec.json.decode(payload, type=_KINDS[kind][1])
        except Exception as error:
            log.exception("cannot decode a sample on %s", key)
            with self._cond:
                self.decode_errors.append((key, repr(error)))
                self._cond.notify_all()
            return
        with self._cond:
            if target is not None:
                target.append(decoded)
            if kind == "dispatch" and self.fence.earlier_run(decoded):
                self.blind.append(decoded)
            elif kind == "dispatch" and self.fence.execute(decoded):
                self.executed.append(decoded)
            elif kind == "dispatch" and self.fence.cancel(decoded):
                self.cancels.append(decoded)
            elif decoded is not None:
                self.fence.admit(decoded)
            elif kind == "term":
                try:
                    term = msgspec.json.decode(payload, type=messages.Term)
                except msgspec.DecodeError as error:  # a forged one
                    self.decode_errors.append((key, repr(error)))
                else:
                    self.fence.admit(term)
            self.samples.append((key, payload))
            self._cond.notify_all()

    def _on_fence_query(self, query: zenoh.Query) -> None:
        """Answer the highest term this receiver's fence holds."""
        try:
            with self._cond:
                term = self.fence.term
            if term > 0:
                query.reply(
                    self._fence_key,
                    messages.encode(messages.Term(term, reason="fence")),
                )
        except Exception:  # zenoh only logs what a callback raises
            log.exception("answering a fence query")


#: Seconds :meth:`SchedulerClient.find_scheduler` waits before it asks
#: which spacecraft are on the bus.
_FIND_FIRST_S = 1.5


def spacecraft_on_bus(
    session: zenoh.Session, timeout: float = 1.0
) -> list[str]:
    """The spacecraft whose scheduler is alive on the bus, sorted.

    Read from the ``fsw/<spacecraft>/scheduler/alive`` liveliness tokens;
    empty when none answers within ``timeout``.
    """
    found: set[str] = set()
    try:
        replies = session.liveliness().get(
            f"{keys.PREFIX}/*/{keys.ALIVE}", timeout=timeout
        )
        for reply in replies:
            if reply.ok is not None:
                parts = str(reply.ok.key_expr).split("/")
                if len(parts) > 1:
                    found.add(parts[1])
    except zenoh.ZError:
        return []
    return sorted(found)


def query_payload(
    session: zenoh.Session,
    key: str,
    timeout: float,
    *,
    payload: bytes | None = None,
) -> bytes | None:
    """The payload of the first good reply to a query on ``key``.

    Parameters
    ----------
    session
        An open session; a query only reads, so a monitor may send it.
    key
        The full key of a queryable, e.g. ``fsw/sat1/scheduler/plan``.
    timeout
        Seconds to wait for the replies.
    payload
        What the query carries (a what-if's goal), if anything.

    Returns
    -------
    bytes or None
        None when nobody answered within ``timeout``, or only with an
        error (no plan yet).

    Notes
    -----
    A query that no one answers at all ends at once; it is asked again
    every :data:`REASK_S` until ``timeout``. A router that has just
    (re)joined the mesh can report a queryable it does not route to yet:
    such a query came back empty 1 time in 8 in the two-router test.
    """
    deadline = time.monotonic() + timeout
    while True:
        answered, found = False, None
        for reply in session.get(
            key,
            timeout=max(deadline - time.monotonic(), REASK_S),
            payload=payload,
        ):
            answered = True
            if reply.ok is not None and found is None:
                found = reply.ok.payload.to_bytes()
        left = deadline - time.monotonic()
        if answered or left <= 0:
            return found
        time.sleep(min(REASK_S, left))


#: The final answers to a goal.
_VERDICTS = frozenset({"goal_accepted", "goal_rejected"})

_KINDS: dict[str, tuple[str, type]] = {
    "plan": ("plans", messages.PlanMessage),
    "dispatch": ("dispatches", messages.Dispatch),
    "status": ("statuses", messages.Status),
    "solve_record": ("solves", messages.SolveRecord),
}


def _matching(status: object) -> bool:
    # Zenoh releases differ: a bool, or an object with ``.matching``.
    return bool(getattr(status, "matching", status))


def _undeclare(entity: Any) -> None:
    try:
        entity.undeclare()
    except zenoh.ZError as error:  # the session is already closed
        log.debug("undeclare: %s", error)
