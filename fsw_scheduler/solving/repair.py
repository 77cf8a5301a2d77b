"""Replanning from the plan in force: repair first, then search nearby.

A goal that arrives on a busy day changes a few tasks of a plan that a
solve already spent its limit on. Solving the new problem from scratch
pays that limit again (a replan of a 30-60 task plan took 9.7-9.9 s of
its 10 s, as long as a fresh solve), and the previous plan as a MIP start
bought nothing: the start heuristic and the neighbourhood search sweep the
whole horizon whatever changed. Here, as in CASPER's iterative repair, a
replan pays for what changed:

1. :func:`repair`: every task the plan in force schedules is pinned where
   it is, and the start heuristic places the others (the new goal's
   tasks, and those the old plan left out) into the gaps. A task that
   must be scheduled and that the old plan lacks forces moves: the old
   tasks where it could run are set free and placed again with it.
2. :func:`changed_tasks` names the tasks the neighbourhood search works
   around (:func:`fsw_scheduler.solving.improve.improve` with
   ``around``): the ones the plan in force did not schedule where they
   now are.

The caller (:func:`fsw_scheduler.solving.solve.solve`) decides the
budget, and reports the bound and gap of what it returns.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..analysis.check import check_plan
from ..analysis.greedy import greedy_plan
from ..analysis.proofs import forced_tasks, precedence_needs
from ..model import groups
from ..model.plan import Activity, Plan, SolveStatus

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.problem import Problem


def repair(
    problem: Problem,
    in_force: Plan,
    domains: dict[str, Domain],
    *,
    stop: Callable[[], bool] | None = None,
) -> Plan | None:
    """``in_force`` with the tasks it lacks list-scheduled into its gaps.

    Parameters
    ----------
    problem
        The new problem (after the replan rules).
    in_force
        The plan in force mapped onto ``problem`` (the replan's warm
        plan): its activities are kept where they are when they can be.
    domains
        ``problem``'s start domains.
    stop
        Passed to the start heuristic (true when time is up).

    Returns
    -------
    Plan or None
        A plan of ``problem`` the checker accepts (status ``feasible``,
        objective computed), or None when the tasks every plan must hold
        do not fit even after moving the old tasks in their way.
    """
    starts = {
        name: start
        for name, start in in_force.starts().items()
        if name in domains
        and domains[name].earliest <= start <= domains[name].latest
    }
    # Pinned tasks are forced, so the heuristic's first plan (the forced
    # tasks alone, cheap) says at once whether the forced tasks the old
    # plan lacks (a mandatory new task, a running one rescheduled in
    # full) fit among them; only then is the whole heuristic run. Even
    # stopped early, it keeps every pinned task.
    if _pinned_greedy(problem, starts, _at_once) is not None:
        return _pinned_greedy(problem, starts, stop)
    # They do not: the old tasks where they could run are set free and
    # placed again with them.
    lengths = {t.id: t.length for t in problem.tasks}
    missing = [
        domains[n]
        for n in forced_tasks(problem)
        if n not in starts and not domains[n].empty
    ]
    longest = max(lengths.values(), default=0)
    kept = {
        name: start
        for name, start in starts.items()
        if not any(
            start < dom.latest + longest
            and start + lengths[name] > dom.earliest
            for dom in missing
        )
    }
    if len(kept) == len(starts):
        return None
    return _pinned_greedy(problem, kept, stop)


def holding(
    problem: Problem, in_force: Plan, domains: dict[str, Domain]
) -> Plan | None:
    """What of ``in_force`` holds on ``problem`` by itself, as a plan.

    For a plan in force that :func:`repair` cannot start from (a task
    restarted at the replan drains the battery a second time, and the
    old plan overdraws it): a kept task that follows a task no longer
    kept is dropped; then, for each resource violation the checker
    reports, the kept task of that resource's kind that starts last at
    or before it (an optional one before one every plan must hold),
    with what follows it by a precedence; and the checker is asked
    again until the rest holds (a few rounds: one per report, not one
    per task). Every other task is left out. None when what is left is
    not a valid plan (a task every plan must hold was dropped).
    Deterministic: the checker's report and the starts decide.
    """
    kept = {
        name: start
        for name, start in in_force.starts().items()
        if name in domains
        and domains[name].earliest <= start <= domains[name].latest
    }
    tasks = {task.id: task for task in problem.tasks}
    forced = forced_tasks(problem)
    kinds = {
        "binary": set(problem.resources.binary),
        "multiple": set(problem.resources.multiple),
        "consumable": set(problem.resources.consumable),
    }
    # Who cannot be kept without a task: what follows it, and what leads
    # it by a ``both`` precedence (seed 206's r60-h1440-0 of the replan
    # suite kept the first of a ``both`` pair whose second it dropped,
    # and so held nothing).
    after: dict[str, list[str]] = {}
    for name, needs in precedence_needs(problem).items():
        for other in needs:
            after.setdefault(other, []).append(name)
    while kept:
        report = check_plan(problem, _plan(problem, kept))
        dropped = [
            follower
            for v in report.of_rule("scope")
            if v.task is not None and v.task not in kept
            for follower in after.get(v.task, [])
            if follower in kept
        ]
        faults = [] if dropped else report.violations
        for fault in faults:
            if fault.rule not in kinds or fault.time is None:
                continue
            culprits = [
                name
                for name, start in kept.items()
                if start <= fault.time
                and name not in dropped
                and any(
                    amount > 0 and use in kinds[fault.rule]
                    for use, amount in tasks[name].uses.items()
                )
            ]
            pool = [n for n in culprits if n not in forced] or culprits
            if pool:
                dropped.append(max(pool, key=lambda n: (kept[n], n)))
        if not dropped:
            break
        while dropped:
            # What follows it by a precedence may need it: set free too.
            name = dropped.pop()
            if kept.pop(name, None) is not None:
                dropped += after.get(name, [])
    return _checked(problem, kept)


def _at_once() -> bool:
    """A stop that is always due: the heuristic's trivial plan alone."""
    return True


def _pinned_greedy(
    problem: Problem,
    starts: dict[str, int],
    stop: Callable[[], bool] | None,
) -> Plan | None:
    """The start heuristic on ``problem`` with ``starts`` pinned, checked
    on ``problem`` itself (pinning makes a task mandatory there)."""
    # A task already fixed is in ``starts`` at its own pin (its domain).
    plan = greedy_plan(problem.pinned(starts), stop=stop)
    if plan is None:
        return None
    return _checked(problem, plan.starts())


def _checked(problem: Problem, starts: dict[str, int]) -> Plan | None:
    """The plan of ``starts`` (every other task left out) if the checker
    accepts it on ``problem``, with its objective."""
    plan = _plan(problem, starts)
    report = check_plan(problem, plan)
    if not report.ok:
        return None
    return plan.replace(objective=report.objective)


def _plan(problem: Problem, starts: dict[str, int]) -> Plan:
    """The plan of ``starts``, every other task left out; no objective."""
    lengths = {t.id: t.length for t in problem.tasks}
    return Plan(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=tuple(
            sorted(
                (
                    Activity(name, start, start + lengths[name])
                    for name, start in starts.items()
                ),
                key=lambda a: (a.start, a.task),
            )
        ),
        unscheduled=groups.left_out(problem, starts),
        chosen=groups.chosen(problem, starts),
    )


def changed_tasks(problem: Problem, in_force: Plan, plan: Plan) -> list[str]:
    """Tasks of ``problem`` that ``plan`` does not hold as ``in_force``
    did: new or left out there, moved, or left out here.

    The ones ``plan`` leaves out come first, the most valuable first (a
    new goal's tasks that found no gap: the search around them starts
    there, where leaving less out is worth more than any delay), then the
    others in problem order.
    """
    before, after = in_force.starts(), plan.starts()
    changed = [
        task
        for task in problem.tasks
        if task.id not in before or before[task.id] != after.get(task.id)
    ]
    order = {task.id: idx for idx, task in enumerate(changed)}
    changed.sort(
        key=lambda t: (
            t.id in after,
            -t.schedule_cost if t.id not in after else 0,
            order[t.id],
        )
    )
    return [task.id for task in changed]
