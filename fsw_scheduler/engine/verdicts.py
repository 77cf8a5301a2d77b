"""Statuses and verdicts: what the engine says about itself and its inputs.

:class:`Verdicts` turns the engine's state into ``scheduler/status``
messages: the full status a query gets, the status a step publishes (with
the lifecycle entries that ``changed`` since the previous one), and the
verdicts on rejected goals and inputs, each logged and counted. Every
input that is refused goes through here, so each gets exactly one
published verdict.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import msgspec

from ..wire import topics
from ..wire.messages import Status
from .events import Command, Log, Publish

if TYPE_CHECKING:
    from ..errors import FieldIssue
    from .queue import SolveQueue
    from .state import EngineState


class Verdicts:
    """Statuses of the engine and verdicts on what it refuses.

    Parameters
    ----------
    state
        The engine's state (read; counters are updated).
    queue
        The solve queue (a status says whether a solve is in flight).
    """

    def __init__(self, state: EngineState, queue: SolveQueue) -> None:
        self._state = state
        self._queue = queue

    def status(self, event: str = "heartbeat", **extra: object) -> Status:
        """The current status with the whole lifecycle map (queries).

        Publishing goes through :meth:`update`, which also says what
        changed since the previous published status.
        """
        state = self._state
        return Status(
            state=extra.pop("state", state.health),  # type: ignore[arg-type]
            plan_id=state.plan_id,
            now=state.now,
            event=event,
            detail=str(extra.pop("detail", state.health_detail)),
            busy=self._queue.busy,
            activities=dict(sorted(state.dispatches.lifecycle.items())),
            counters=state.counters,
            last_solve=state.last_solve,
            node_id=state.config.node_id,
            term=state.term,
            **extra,  # type: ignore[arg-type]
        )

    def update(self, event: str, full: bool = False, **extra: Any) -> Status:
        """A status to publish: ``changed`` since the last one published.

        Verdicts and events carry only the lifecycle entries that changed
        since the previous published status; heartbeats (``full``) carry
        the whole map too. Applying every ``changed`` in order to the last
        full map gives the current map.
        """
        changed = self._state.dispatches.changed()
        status = self.status(event, **extra)
        return msgspec.structs.replace(
            status,
            activities=status.activities if full else {},
            changed=changed,
        )

    def publish(self, event: str, full: bool = False, **extra: Any) -> Publish:
        """:meth:`update` as the command that publishes it."""
        return Publish(topics.STATUS, self.update(event, full, **extra))

    def reject_goal(
        self,
        goal_id: str | None,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
        *,
        forget: bool = True,
    ) -> None:
        """Refuse a goal: count it, log it, publish ``goal_rejected``.

        ``forget`` frees the goal id in the ledger (the goal may come
        again); a goal refused because its id is taken keeps the id's
        record.
        """
        state = self._state
        if forget and goal_id is not None:
            state.ledger.forget(goal_id)
        state.count(goals_rejected=state.counters.goals_rejected + 1)
        self.report_rejection(
            f"goal {goal_id} rejected",
            errors,
            out,
            event="goal_rejected",
            goal_id=goal_id,
        )

    def reject_input(
        self,
        key: str,
        kind: str,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
    ) -> None:
        """Refuse an input other than a goal (``input_rejected``)."""
        state = self._state
        state.count(inputs_rejected=state.counters.inputs_rejected + 1)
        what = f"{kind} on {key} ignored"
        self.report_rejection(
            what, errors, out, event="input_rejected", detail=what
        )

    def report_rejection(
        self,
        what: str,
        errors: list[FieldIssue] | tuple[FieldIssue, ...],
        out: list[Command],
        event: str,
        **fields: Any,
    ) -> None:
        """Log a rejection and publish it on the status key."""
        text = "; ".join(str(e) for e in errors)
        out.append(Log("warning", f"{what}: {text}"))
        out.append(self.publish(event, errors=tuple(errors), **fields))
