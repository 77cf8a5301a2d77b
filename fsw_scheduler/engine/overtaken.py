"""A plan overtaken by its own commands: keep what was commanded.

While a replan is computed, the current plan keeps dispatching (see
:class:`~fsw_scheduler.engine.core.Engine`). The replan was posed before
those dispatches, so it is free to move or drop an activity the spacecraft
has been commanded to fly meanwhile; adopting it as is would command that
activity a second time, elsewhere (for an activity that may be preempted
that is preemption, which the rules allow; for one that may not, it is
flying it twice). A commanded activity is a fact: the
plan is patched to hold it where it was commanded, activities that then
conflict with it are left out, and the independent checker decides. When
only leaving out a mandatory task would make room, there is no plan that
keeps the commands, and the caller keeps the current one.

Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..analysis.check import check_plan
from ..model.plan import Activity, Plan, SolveStatus

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ..model.problem import Problem


def keep_commanded(
    problem: Problem, plan: Plan, commanded: Mapping[str, tuple[int, int]]
) -> tuple[Plan | None, tuple[str, ...]]:
    """``plan`` with each commanded activity where it was commanded.

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The plan the solver returned (it has a plan).
    commanded
        Tasks of ``problem`` dispatched after the problem was posed, with
        the ``(start, end)`` they were commanded at.

    Returns
    -------
    plan, moved
        ``plan`` itself and ``()`` when it keeps every command; otherwise
        a checked plan (status ``feasible``: no longer proven optimal)
        holding the commands, and the tasks that had to be put back; or
        None when no plan keeps them without leaving a mandatory task out.
    """
    tasks = {task.id: task for task in problem.tasks}
    wanted = {
        task: span for task, span in sorted(commanded.items()) if task in tasks
    }
    moved = tuple(
        task
        for task, (start, end) in wanted.items()
        if (found := plan.activity(task)) is None
        or (found.start, found.end) != (start, end)
    )
    if not moved:
        return plan, ()
    spans = [wanted[task] for task in moved]
    touched = {
        name
        for task in moved
        for name, amount in tasks[task].uses.items()
        if amount and name in problem.resources.consumable
    }
    partners = {
        end
        for prec in problem.precedences
        if prec.before in moved or prec.after in moved
        for end in (prec.before, prec.after)
    }
    kept = [
        a for a in plan.activities if a.task in wanted and a.task not in moved
    ]
    kept += [Activity(task, *wanted[task]) for task in moved]
    for activity in sorted(
        (a for a in plan.activities if a.task not in wanted),
        key=lambda a: (a.start, a.task),
    ):
        # Only what meets a put-back activity can conflict with it.
        meets = (
            any(
                activity.start < end and start < activity.end
                for start, end in spans
            )
            or activity.task in partners
            or any(tasks[activity.task].uses.get(name) for name in touched)
        )
        if not meets or _fits(problem, [*kept, activity]):
            kept.append(activity)
    kept.sort(key=lambda a: (a.start, a.task))
    placed = {a.task for a in kept}
    candidate = plan.replace(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=tuple(kept),
        unscheduled=tuple(t for t in tasks if t not in placed),
        why=(),
    )
    report = check_plan(problem, candidate)
    if not report.ok:
        return None, moved
    return candidate.replace(objective=report.objective), moved


def _fits(problem: Problem, activities: list[Activity]) -> bool:
    """Whether ``activities`` break no rule among themselves."""
    names = {a.task for a in activities}
    sub = problem.replace(
        tasks=tuple(t for t in problem.tasks if t.id in names),
        precedences=tuple(
            p
            for p in problem.precedences
            if p.before in names and p.after in names
        ),
    )
    plan = Plan(SolveStatus.FEASIBLE, None, tuple(activities))
    return all(
        v.rule in ("coverage", "mandatory", "objective")
        for v in check_plan(sub, plan).violations
    )
