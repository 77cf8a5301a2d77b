"""Degraded plans: shed mandatory tasks the world has made impossible.

A replan caused by telemetry or a failure can find that the mandatory tasks
(schedule cost 0, or pinned because they are running and cannot be
preempted) no longer fit together: the battery is lower than planned, a
failed activity took the time another one needed. The plan being flown is
then contradicted by the measurements, and keeping it is the worst answer.
Instead the scheduler flies the best plan still possible, found in two
solves:

1. **Which mandatory tasks to keep** (:func:`shedding_problem`): the
   mandatory tasks, and the tasks they cannot run without (precedence
   partners that ``both`` or ``at_least_first`` tie to them), all made
   optional. Mandatory tasks cost :data:`MANDATORY_LOSS`, their partners
   :data:`PARTNER_LOSS`, so the solver keeps as many mandatory tasks as fit
   (the fewest losses first) and pinned tasks keep their start through a
   one-unit window instead of ``fixed_start``.
2. **The plan without them** (:func:`without_tasks`): the replan's
   problem minus the mandatory tasks step 1 left out, and minus what the
   paper's removal cascade takes with them, solved as usual. Every
   remaining mandatory task fits (step 1 placed them all), so this problem
   has a plan.

A mandatory group of alternatives (schedule cost 0) is shed as a whole:
in step 1 it is made optional at :data:`MANDATORY_LOSS`, and when the
shedding plan leaves it out, step 2 drops its tasks (each recorded as
shed).

The plan is published with status ``degraded``; its ``why`` names each
shed task and the constraint that forced it (from the infeasible solve's
explanation where it named the task). Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model import groups
from ..model.change import Removal
from ..model.limits import MAX_COST
from ..model.plan import Blocker, Plan
from .rules import cascade

if TYPE_CHECKING:
    from ..model.problem import Problem, Task
    from .schedule import Replan

#: Cost of losing a mandatory task in the shedding problem.
MANDATORY_LOSS = MAX_COST
#: Cost of losing a task a mandatory one needs (it only matters through
#: the mandatory tasks that need it).
PARTNER_LOSS = 1
#: The removal rule of a shed task.
SHED_RULE = "shed"


def mandatory_closure(problem: Problem) -> list[str]:
    """The mandatory tasks and every task they need, in problem order.

    A task needs the ``before`` task of any of its precedences (``both``:
    both or neither; ``at_least_first``: the follower needs the first),
    and the ``after`` task of its ``both`` precedences.

    Parameters
    ----------
    problem
        Any problem.

    Returns
    -------
    list of str
        Task ids, in the order of ``problem.tasks``.
    """
    needed = {t.id for t in problem.tasks if problem.required(t)}
    needed |= {
        name
        for group in problem.alternatives
        if group.schedule_cost == 0
        for option in group.options
        for name in option
    } & {t.id for t in problem.tasks}
    grew = True
    while grew:
        grew = False
        for prec in problem.precedences:
            partners = []
            if prec.after in needed:
                partners.append(prec.before)
            if prec.before in needed and prec.scope == "both":
                partners.append(prec.after)
            for partner in partners:
                if partner not in needed:
                    needed.add(partner)
                    grew = True
    return [t.id for t in problem.tasks if t.id in needed]


def _optional(task: Task, loss: int) -> Task:
    """``task`` made optional at cost ``loss``, keeping a pinned start."""
    if task.fixed_start is None:
        return msgspec.structs.replace(task, schedule_cost=loss)
    return msgspec.structs.replace(
        task,
        schedule_cost=loss,
        fixed_start=None,
        feasible_interval=(task.fixed_start, task.fixed_start),
        feasible_interval_applies_to="start",
    )


def shedding_problem(problem: Problem) -> Problem:
    """Step 1: the mandatory tasks and their partners, all optional.

    Parameters
    ----------
    problem
        A replan problem whose mandatory tasks do not fit together.

    Returns
    -------
    Problem
        Same window and resources; the tasks of
        :func:`mandatory_closure`, mandatory ones at cost
        :data:`MANDATORY_LOSS`, partners at :data:`PARTNER_LOSS`; the
        precedences among them. Always has a plan (the empty one).
    """
    keep = set(mandatory_closure(problem))
    mandatory_groups = [
        group
        for group in groups.kept_alternatives(problem, keep)
        if group.schedule_cost == 0
    ]
    members = {n for g in mandatory_groups for o in g.options for n in o}
    tasks = tuple(
        _optional(
            t,
            MANDATORY_LOSS
            if problem.required(t) or t.id in members
            else PARTNER_LOSS,
        )
        for t in problem.tasks
        if t.id in keep
    )
    precedences = tuple(
        p for p in problem.precedences if p.before in keep and p.after in keep
    )
    alternatives = tuple(
        msgspec.structs.replace(g, schedule_cost=MANDATORY_LOSS)
        for g in mandatory_groups
    )
    return problem.replace(
        tasks=tasks, precedences=precedences, alternatives=alternatives
    )


def shed_tasks(problem: Problem, shedding_plan: Plan) -> tuple[str, ...]:
    """The mandatory tasks of ``problem`` the shedding plan left out.

    Parameters
    ----------
    problem
        The replan problem (not the shedding problem).
    shedding_plan
        The plan of :func:`shedding_problem` of ``problem``.

    Returns
    -------
    tuple of str
        Task ids in problem order.
    """
    out = set(shedding_plan.unscheduled)
    shed = [t.id for t in problem.tasks if problem.required(t) and t.id in out]
    # A mandatory group left out is shed whole: its tasks go.
    shed += [
        name
        for group in problem.alternatives
        if group.schedule_cost == 0 and group.id in out
        for option in group.options
        for name in option
    ]
    return tuple(shed)


def without_tasks(
    replan: Replan, dropped: tuple[str, ...], why: str
) -> Replan:
    """Step 2: ``replan`` without the shed tasks and their cascade.

    Parameters
    ----------
    replan
        The replan whose problem was infeasible.
    dropped
        Mandatory tasks to shed (:func:`shed_tasks`).
    why
        Plain words for the removals, e.g. the trigger.

    Returns
    -------
    Replan
        The same replan with a smaller problem; the removals are recorded
        with rule :data:`SHED_RULE` (cascaded ones with
        ``tight_cascade``), the warm start keeps only remaining tasks.
    """
    tasks = {t.id: t for t in replan.problem.tasks}
    removed = list(replan.removed)
    for name in dropped:
        if tasks.pop(name, None) is not None:
            removed.append(Removal(name, SHED_RULE, why))

    def take(name: str, detail: str) -> None:
        del tasks[name]
        removed.append(Removal(name, "tight_cascade", detail))

    precedences = cascade(
        replan.problem.precedences,
        dropped,
        lambda name: name in tasks,
        take,
        "shed task",
    )
    problem = replan.problem.replace(
        tasks=tuple(tasks.values()),
        precedences=tuple(precedences),
        alternatives=groups.kept_alternatives(replan.problem, tasks),
    )
    continuing = tuple(n for n in replan.continuing if n in tasks)
    warm = replan.warm
    if warm is not None:
        warm = warm.replace(
            activities=tuple(a for a in warm.activities if a.task in tasks),
            unscheduled=tuple(n for n in warm.unscheduled if n in tasks),
        )
    following = msgspec.structs.replace(
        replan.following, problem=problem, continuing=continuing
    )
    return msgspec.structs.replace(
        replan,
        problem=problem,
        removed=tuple(removed),
        continuing=continuing,
        warm=warm,
        readded=tuple(n for n in replan.readded if n in tasks),
        following=following,
    )


def shed_blockers(
    removed: tuple[Removal, ...], infeasible: Plan
) -> tuple[Blocker, ...]:
    """One reason per task shed, for the degraded plan's ``why``.

    Parameters
    ----------
    removed
        The removals of :func:`without_tasks`.
    infeasible
        The infeasible plan of the original replan; where its ``why`` names
        a shed task, that cause (the resource or window) is given.

    Returns
    -------
    tuple of Blocker
        Cause ``shed`` for every task removed by shedding or its cascade;
        the detail says what forced it.
    """
    causes = {b.task: b for b in infeasible.why}
    out = []
    for removal in removed:
        if removal.rule == SHED_RULE:
            cause = causes.get(removal.task)
            forced = (
                f"{cause.cause}: {cause.detail}"
                if cause is not None
                else "the mandatory tasks no longer fit together"
            )
            out.append(
                Blocker(
                    removal.task,
                    SHED_RULE,
                    f"mandatory task shed ({removal.detail}); {forced}",
                )
            )
        elif removal.rule == "tight_cascade" and "shed task" in (
            removal.detail
        ):
            out.append(Blocker(removal.task, SHED_RULE, removal.detail))
    return tuple(out)
