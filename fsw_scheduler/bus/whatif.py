"""The node's what-if desk: ``scheduler/what-if`` queries, answered aside.

A what-if query carries a goal as it would be sent; the answer is what
sending it now would do (:func:`fsw_scheduler.engine.whatif.what_if`),
computed from a copy of the engine's state on a thread of its own, so that
it never delays a goal: the node's solves run on their own worker as
before. While a solve is in flight the state is about to change, so the
query waits (up to its ``timeout``) for it to end; past that it is
answered ``busy``. Each answer is journaled on ``scheduler/what-if`` with
the state it was computed from (``inputs_seen``) and its solves, for
``replay --verify``, and counted in ``counters.what_ifs``.

The querier says how long it waits in the selector's parameters,
``fsw/<sc>/scheduler/what-if?timeout=30`` (seconds, default
:data:`DEFAULT_TIMEOUT_S`): a query waits behind a solve for at most
:data:`HOLD_SHARE` of it, and the rest is for its own solve.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import zenoh

from ..engine.whatif import WhatIf, rejected, what_if
from ..errors import FieldIssue, InputError
from ..runtime.inputs import goal_id_of
from ..runtime.policy import deadline_config, run_explain
from ..solving.ilp.cbc import Cancel, cancel_scope
from ..wire import messages
from ..wire.messages import WhatIfAnswer, WhatIfRecord
from .inbox import Inbox, Worker
from .outputs import FATAL

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.core import Engine
    from ..engine.events import StartSolve
    from ..model.goal import Goal
    from ..model.plan import Plan
    from ..runtime.config import NodeConfig

log = logging.getLogger("fsw_scheduler.node")

JSON = zenoh.Encoding.APPLICATION_JSON

#: Seconds a querier waits when its selector does not say (zenoh's own
#: default query timeout).
DEFAULT_TIMEOUT_S = 10.0

#: Share of a query's timeout it may wait behind a solve in flight.
HOLD_SHARE = 0.5

#: What-ifs waiting for a solve to end; more are answered ``busy`` at once.
MAX_HELD = 16


@dataclass
class Asked:
    """A what-if query: its goal, when it came and until when it waits."""

    query: Any
    document: str
    goal: Goal
    arrived: float
    hold_until: float


def query_timeout(query: Any) -> float:
    """The ``timeout`` parameter of a query's selector, in seconds."""
    try:
        text = query.parameters.get("timeout")
        value = float(text) if text else DEFAULT_TIMEOUT_S
    except (AttributeError, TypeError, ValueError):
        return DEFAULT_TIMEOUT_S
    return value if value > 0 else DEFAULT_TIMEOUT_S


class WhatIfs:
    """What-if queries of one node (see the module docstring).

    Parameters
    ----------
    engine
        The node's engine: read on the loop thread only (its snapshot).
    config
        The node's settings: a what-if solves as a goal would.
    inbox
        Where answers computed aside come back to the loop.
    journal
        Writes a journal record ``(key, payload)`` (the loop's writer).
    key
        The full key of ``scheduler/what-if``.
    solve_fn
        The node's solve.
    seconds
        Monotonic clock in seconds.
    cancel
        Stops a what-if's solve when the node closes.
    """

    def __init__(
        self,
        engine: Engine,
        config: NodeConfig,
        inbox: Inbox,
        journal: Callable[[str, bytes], None],
        key: str,
        solve_fn: Callable[[NodeConfig, StartSolve], Plan],
        seconds: Callable[[], float] = time.monotonic,
        cancel: Cancel | None = None,
    ) -> None:
        self.engine = engine
        self._config = config
        self._inbox = inbox
        self._journal = journal
        self._key = key
        self._solve_fn = solve_fn
        self._seconds = seconds
        self._cancel = cancel or Cancel()
        self._held: list[Asked] = []
        self._worker: Worker | None = None

    def ask(self, query: Any) -> None:
        """A what-if query reached the loop: refuse it, hold it, or start."""
        payload = query.payload.to_bytes() if query.payload else b""
        document = payload.decode(errors="replace")
        try:
            goal = messages.decode_input("goal", payload)
        except InputError as error:
            self._answer(
                query, document, rejected(goal_id_of(payload), error.issues)
            )
            return
        now = self._seconds()
        timeout = query_timeout(query)
        asked = Asked(query, document, goal, now, now + HOLD_SHARE * timeout)
        if len(self._held) >= MAX_HELD:
            self._answer(
                query, document, self._busy(goal, "too many what-ifs wait")
            )
            return
        self._held.append(asked)
        self.poll()

    def poll(self) -> None:
        """Start the held what-ifs once no solve is in flight; answer
        ``busy`` those that waited their share of the timeout."""
        now = self._seconds()
        for asked in list(self._held):
            if not self.engine.busy:
                self._held.remove(asked)
                self._start(asked)
            elif now >= asked.hold_until:
                self._held.remove(asked)
                waited = now - asked.arrived
                self._answer(
                    asked.query,
                    asked.document,
                    self._busy(
                        asked.goal,
                        f"a solve is in flight ({waited:.1f} s waited for "
                        "it): ask again",
                    ),
                )

    def seconds_to_next(self) -> float | None:
        """Seconds until a held what-if must be answered busy (None: none
        is held)."""
        if not self._held:
            return None
        first = min(a.hold_until for a in self._held)
        return max(first - self._seconds(), 0.001)

    def finish(self, asked: Asked, record: WhatIfRecord) -> None:
        """An answer computed aside is back on the loop: journal, count,
        reply."""
        self._answer(asked.query, asked.document, record.answer, record)

    def close(self) -> None:
        """Stop the worker; held queries get no answer (their querier's
        timeout ends them)."""
        if self._worker is not None:
            self._worker.shutdown()
        for asked in self._held:
            _drop(asked.query)
        self._held.clear()

    # -- internals --------------------------------------------------------

    def _start(self, asked: Asked) -> None:
        engine = self.engine
        snapshot = engine.snapshot()
        inputs, now = engine.inputs_seen, engine.now
        # The limits a goal arriving with this query would get.
        config = deadline_config(
            self._config, [self._seconds() - asked.arrived], 0
        )
        later = config.explain and config.explain_after_plan

        def compute() -> WhatIf:
            with cancel_scope(self._cancel):
                return what_if(
                    snapshot,
                    engine.config,
                    asked.goal,
                    lambda command: self._solve_fn(config, command),
                    (
                        (lambda p, plan: run_explain(config, p, plan))
                        if later
                        else None
                    ),
                )

        if self._worker is None:
            self._worker = Worker("fsw-what-if")
        future = self._worker.submit(compute)

        def done(future: Any) -> None:
            error = future.exception()
            if error is None:
                result: WhatIf = future.result()
            else:
                log.error("what-if failed: %s", error)
                result = WhatIf(
                    rejected(
                        asked.goal.goal_id,
                        [FieldIssue("", f"no plan with this goal: {error}")],
                    )
                )
            record = WhatIfRecord(
                asked.document, result.answer, inputs, now, result.solves
            )
            self._inbox.put("what_if", (asked, record))

        future.add_done_callback(done)

    def _busy(self, goal: Goal, why: str) -> WhatIfAnswer:
        return WhatIfAnswer(
            verdict="busy",
            reasons=(FieldIssue("", why),),
            goal_id=goal.goal_id,
        )

    def _answer(
        self,
        query: Any,
        document: str,
        answer: WhatIfAnswer,
        record: WhatIfRecord | None = None,
    ) -> None:
        engine = self.engine
        if record is None:
            record = WhatIfRecord(
                document, answer, engine.inputs_seen, engine.now
            )
        self._journal(self._key, messages.encode(record))
        engine.note_what_if()
        try:
            query.reply(self._key, messages.encode(answer), encoding=JSON)
        except FATAL:
            raise
        except BaseException as error:  # ZError, or a panic in zenoh
            log.warning("what-if reply failed: %s", error)
        finally:
            _drop(query)


def _drop(query: Any) -> None:
    try:
        query.drop()
    except BaseException as error:
        log.debug("query drop: %s", error)


__all__ = [
    "DEFAULT_TIMEOUT_S",
    "HOLD_SHARE",
    "Asked",
    "WhatIfs",
    "query_timeout",
]
