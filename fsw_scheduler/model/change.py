"""Execution reports, removals and change documents.

These are formats, shared by the replan rules, the engine and the bus
messages: an :class:`ExecutionReport` from the spacecraft, a
:class:`Removal` with the rule that caused it (:data:`RULES`),
and the change documents ``fsw-scheduler replan`` reads
(:func:`decode_change`: a goal or an event).
"""

from __future__ import annotations

from typing import Literal

import msgspec

from .codec import decode_strict
from .goal import Goal, decode_goal

__all__ = [
    "ActivityFailed",
    "ExecutionReport",
    "LevelsMeasured",
    "Removal",
    "decode_change",
]


#: ``missed``: the engine's own record of an activity it never dispatched
#: because its whole interval had passed (executors report the others).
ReportState = Literal["running", "completed", "failed", "missed"]


Outcome = Literal["completed", "failed", "interrupted"]


#: Removal rule names, in the order the rules run.
RULES = (
    "finished",
    "failed_delete",
    "preemption_delete",
    "obsolete",
    "tight_cascade",
    "window_passed",
    "alternative",
)


class ExecutionReport(msgspec.Struct, frozen=True):
    """An execution report from the spacecraft (``telemetry/activities``).

    Attributes
    ----------
    task
        The task reported on.
    state
        ``running``, ``completed`` or ``failed`` (or ``missed``, see
        :data:`ReportState`).
    at
        Time unit of the report.
    """

    task: str
    state: ReportState
    at: int


class Removal(msgspec.Struct, frozen=True):
    """A task that left the pending list, and why.

    Attributes
    ----------
    task
        Task id.
    rule
        One of :data:`RULES` (or ``unscheduled`` in a :class:`PlanDiff`).
    detail
        Plain-words explanation.
    """

    task: str
    rule: str
    detail: str = ""


class ActivityFailed(
    msgspec.Struct, frozen=True, tag="activity_failed", tag_field="event"
):
    """Event document: ``{"event": "activity_failed", "task", "at"}``."""

    task: str
    at: int


class LevelsMeasured(
    msgspec.Struct, frozen=True, tag="levels", tag_field="event"
):
    """Event document: ``{"event": "levels", "levels": {...}, "at"}``."""

    levels: dict[str, float]
    at: int


Event = ActivityFailed | LevelsMeasured


Change = Goal | ActivityFailed | LevelsMeasured


def decode_change(data: bytes | str) -> Change:
    """Decode a goal or an event document, telling them apart.

    A document with an ``event`` key is an event (``activity_failed`` or
    ``levels``); any other is a goal.

    Raises
    ------
    InputError
        Paths name the field (``at``, ``tasks[0].length``).
    """
    head = decode_strict(data, dict, "change")
    if "event" in head:
        return decode_strict(data, Event, "event")  # type: ignore[arg-type]
    return decode_goal(data)
