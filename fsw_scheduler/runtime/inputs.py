"""From bus samples to engine events (shared by the node and replay).

The node and deterministic replay must turn the same bytes into the same
events, so the decoding rules live here once: oversized or malformed
payloads, wrong types, a report on another task's key, a clock going back
all become :class:`~fsw_scheduler.engine.InputRejected` events, which the
engine reports on the status key; nothing here raises.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

import msgspec

from ..engine.events import (
    ClockStalled,
    Event,
    Explained,
    FactsArrived,
    ForecastArrived,
    GoalArrived,
    InputRejected,
    LevelArrived,
    NodePaused,
    ReportArrived,
    TermBegan,
    Tick,
)
from ..errors import FieldIssue, InputError
from ..model.limits import MAX_ID_LENGTH, MAX_TIME
from ..wire import messages
from ..wire.topics import GOALS, Topics, input_kind

if TYPE_CHECKING:
    from ..model.problem import Resources


class InputDecoder:
    """Decodes input samples into events, keeping the bus clock's state.

    Parameters
    ----------
    topics
        The spacecraft's keys.
    clock
        ``bus``: clock messages are ticks; ``wall``: the node keeps its own
        time, clock messages are ignored and its ticks come from the
        ``scheduler/ticks`` journal channel.
    max_clock_step
        Largest forward step of one bus clock message, in units (None: no
        limit); a bigger step is rejected and time stays where it was.
        Clock values are integers in ``[0, MAX_TIME]`` in any case.
    resources
        The resources of the node's problem (they never change over a
        run): a goal is checked against them in the same pass as its
        shape, so that every mistake comes back in one rejection.
    """

    def __init__(
        self,
        topics: Topics,
        clock: str,
        max_clock_step: int | None = None,
        resources: Resources | None = None,
    ) -> None:
        self.topics = topics
        self.clock = clock
        self.max_clock_step = max_clock_step
        self.resources = resources
        self.bus_now: int | None = None

    def event(self, key: str, payload: bytes) -> Event | None:
        """The event for a sample on ``key`` (None: not an input)."""
        kind = input_kind(self.topics, key, self.clock)
        if kind is None:
            return None
        try:
            message = messages.decode_input(
                "clock" if kind == "tick" else kind, payload, self.resources
            )
            return self._event(kind, key, message)
        except InputError as error:
            return InputRejected(
                key, kind, tuple(error.issues), _goal_id(kind, payload)
            )

    def _event(self, kind: str, key: str, message: Any) -> Event | None:
        if kind == "tick":
            return Tick(message.now)
        if kind == "stalled":
            return ClockStalled(message.seconds, message.last)
        if kind == "paused":
            return NodePaused(message.seconds, message.last)
        if kind == "explanation":
            return Explained(message.solve_id, message.plan_id, message.why)
        if kind == "term":
            return TermBegan(
                message.term,
                message.node_id,
                message.reason,
                message.lost,
                message.unverified,
            )
        if kind == "facts":
            return FactsArrived(message)
        if kind == "clock":
            self._check_clock(message.now)
            if self.bus_now is not None and message.now < self.bus_now:
                raise InputError(
                    [
                        FieldIssue(
                            "now",
                            f"clock went back from {self.bus_now} to "
                            f"{message.now}",
                        )
                    ],
                    "clock",
                )
            self.bus_now = message.now
            return Tick(message.now)
        if kind == "goal":
            return GoalArrived(message)
        if kind == "busy":
            return InputRejected(
                self.topics.key(GOALS),
                "goal",
                (FieldIssue("", f"busy: {message.waiting} goals waiting"),),
                message.goal_id,
            )
        if kind == "dropped":
            return InputRejected(
                message.key,
                message.kind,
                (FieldIssue("", dropped_reason(message)),),
            )
        # The name chunk: the last, or the one before ``/forecast``.
        name = key.rsplit("/", 2)[-2 if kind == "resource_forecast" else -1]
        field = "task" if kind == "activity_report" else "resource"
        value = getattr(message, field)
        if value != name:
            raise InputError(
                [
                    FieldIssue(
                        field, f"{value!r} reported on the key of {name!r}"
                    )
                ],
                kind,
            )
        if kind == "activity_report":
            return ReportArrived(message)
        if kind == "resource_forecast":
            return ForecastArrived(message)
        return LevelArrived(message)

    def _check_clock(self, now: int) -> None:
        if not 0 <= now <= MAX_TIME:
            raise InputError(
                [FieldIssue("now", f"{now} is outside [0, {MAX_TIME}]")],
                "clock",
            )
        step = self.max_clock_step
        if (
            step is not None
            and self.bus_now is not None
            and now - self.bus_now > step
        ):
            raise InputError(
                [
                    FieldIssue(
                        "now",
                        f"clock jumped from {self.bus_now} to {now}: more "
                        f"than {step} units in one message "
                        "(max-clock-step)",
                    )
                ],
                "clock",
            )


def dropped_reason(message: messages.Dropped) -> str:
    """The reason of the ``input_rejected`` answering dropped telemetry:
    the limit, its value, and what the sender can do about it."""
    samples = f"{message.count} sample{'s' if message.count > 1 else ''}"
    if message.size > message.limit:
        why = (
            f"one of {message.size} bytes is larger than the whole inbox "
            f"({message.limit} bytes, inbox-bytes); send smaller samples "
            "or raise inbox-bytes"
        )
    else:
        why = (
            f"the inbox held its limit of {message.limit} bytes "
            "(inbox-bytes); send less often (the latest per key is kept "
            "while one waits), or raise inbox-bytes"
        )
    return f"dropped: {samples} unread, {why}"


class _GoalHead(msgspec.Struct):
    goal_id: str


_GOAL_ID_RE = re.compile(rb'"goal_id"\s*:\s*"((?:[^"\\]|\\.){0,256})"')


def goal_id_of(payload: bytes) -> str | None:
    """Best-effort goal id of a goal document that may be invalid.

    Used to name the goal in a rejection. A document too deep for the
    decoder is searched as text. Ids longer than four times the id limit
    are cut (and marked ``...``) so a rejection never echoes a huge string.
    """
    try:
        head = msgspec.json.decode(payload, type=_GoalHead)
        found: str | None = head.goal_id
    except (msgspec.DecodeError, RecursionError):
        match = _GOAL_ID_RE.search(payload)
        try:
            found = (
                msgspec.json.decode(b'"' + match.group(1) + b'"', type=str)
                if match
                else None
            )
        except msgspec.DecodeError:
            found = None
    if found is not None and len(found) > 4 * MAX_ID_LENGTH:
        found = found[: 4 * MAX_ID_LENGTH] + "..."
    return found


def _goal_id(kind: str, payload: bytes) -> str | None:
    """Best-effort goal id of a goal that failed to decode."""
    return goal_id_of(payload) if kind == "goal" else None
