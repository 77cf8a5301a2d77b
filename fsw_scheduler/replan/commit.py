"""The commit window, and what a replan moved of the plan it replaces.

A replan at ``now`` may move any activity that has not been dispatched.
With a commit window of ``w`` units, every planned activity that starts in
``[now, now + w)`` keeps its start (:func:`commit_pins`,
:func:`pinned_problem`): the executor and the ground can count on what is
about to happen, as with the commit window of the Mars 2020 on-board
scheduler. A pin keeps a start, never an activity against the paper's
rules: a task the rules removed (obsolete, a failed tight chain) is not in
the replan's problem, so it has no pin. When the pins leave no plan (a
mandatory task cannot fit), the replan is solved without them and the plan
names each pin it broke (:func:`broken_pins`).

:func:`moved_activities` says what a new plan moved: the activities
scheduled in both plans at different starts, among those that were
planned and not yet dispatched when the replan started. One the new plan
leaves out is not moved (it is unscheduled). Pure: no solver, no bus, no
clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..model.plan import Blocker, Moved

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..model.plan import Plan
    from ..model.problem import Problem

__all__ = [
    "PIN_CAUSE",
    "Moved",
    "broken_pins",
    "commit_pins",
    "moved_activities",
    "pin_blockers",
    "pinned_problem",
]

#: The ``why`` cause of a pin the degraded path broke.
PIN_CAUSE = "commit_window"


def commit_pins(
    problem: Problem, previous: Mapping[str, int], window: int
) -> dict[str, int]:
    """The starts a replan keeps: planned starts inside the window.

    Parameters
    ----------
    problem
        The replan's problem; its ``start`` is the replan's ``now``.
    previous
        Task id to start, of the activities planned and not dispatched in
        the plan in force (:func:`moved_activities` compares with them).
    window
        The commit window in units (0: none).

    Returns
    -------
    dict
        Task id to the start it keeps, in problem order: tasks of
        ``problem`` (the rules let them stay) planned to start in
        ``[problem.start, problem.start + window)``, whose start the
        problem still allows (a task already fixed keeps its own pin).
    """
    if window <= 0:
        return {}
    pins = {}
    for task in problem.tasks:
        start = previous.get(task.id)
        if start is None or task.fixed_start is not None:
            continue
        if not problem.start <= start < problem.start + window:
            continue
        earliest, latest = problem.start_bounds(task)
        if earliest <= start <= latest:
            pins[task.id] = start
    return pins


def pinned_problem(problem: Problem, pins: Mapping[str, int]) -> Problem:
    """``problem`` with each pinned task fixed at its start.

    A fixed start makes the task mandatory: the window keeps it, in the
    plan, where it was announced.
    """
    return problem.pinned(pins)


def broken_pins(pins: Mapping[str, int], plan: Plan) -> dict[str, int | None]:
    """The pins ``plan`` does not keep: task id to its new start (None:
    left out), in pin order."""
    starts = plan.starts()
    return {
        task: starts.get(task)
        for task, start in pins.items()
        if starts.get(task) != start
    }


def pin_blockers(
    pins: Mapping[str, int], plan: Plan, now: int, window: int
) -> tuple[Blocker, ...]:
    """One ``commit_window`` reason per pin ``plan`` broke (see
    :func:`broken_pins`), for the degraded plan's ``why``."""
    out = []
    for task, start in broken_pins(pins, plan).items():
        was = pins[task]
        where = f"moved to {start}" if start is not None else "left out"
        out.append(
            Blocker(
                task,
                PIN_CAUSE,
                f"planned at {was}, inside the commit window [{now}, "
                f"{now + window}): {where}, since no plan keeps every "
                "activity of the window",
            )
        )
    return tuple(out)


def moved_activities(
    previous: Mapping[str, int],
    plan: Plan,
    reasons: Mapping[str, str] | None = None,
) -> tuple[Moved, ...]:
    """What ``plan`` moved of the activities planned before it.

    Parameters
    ----------
    previous
        Task id to start of the activities planned and not yet
        dispatched when the replan started.
    plan
        The new plan.
    reasons
        Task id to why it moved, where known.

    Returns
    -------
    tuple of Moved
        In the new plan's order (by start, then task).
    """
    reasons = reasons or {}
    return tuple(
        Moved(a.task, previous[a.task], a.start, reasons.get(a.task, ""))
        for a in plan.activities
        if a.task in previous and previous[a.task] != a.start
    )
