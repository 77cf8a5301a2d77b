"""Why tasks are left out, found by solving relaxed models.

Nothing here is guessed from the plan: each reason is the outcome of a
solve.

* A task with no allowed start time is blocked by its ``window`` (feasible
  interval and horizon) or by a ``precedence`` (see
  :mod:`fsw_scheduler.analysis.domains`).
* For an infeasible problem, the mandatory tasks are made optional and the
  relaxed model is solved: the mandatory tasks it leaves out are the ones
  that cannot all be placed.
* For each such task, and each task a plan leaves out, the model is solved
  again with that task forced in. If it then fits, leaving it out was the
  cheaper choice (``cost``: the plan would lose other tasks or start later).
  If not, the task's precedences are dropped first (then, to name one,
  each alone), then its resources one at a time; the first relaxation
  that lets it in names the blocker (``precedence``, ``binary``,
  ``multiple`` or ``consumable``), else ``combination``. Precedences come
  first because dropping a resource for every task also lets in a
  partner that cannot be placed, and the resource would then be blamed
  for what the precedence does. For a consumable with a capacity, one
  more solve without the capacity says whether charge lost while the
  store is full is what keeps the task out.
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from ..model.plan import Blocker, Plan, SolveStatus
from ..model.problem import Problem, Resources, Task
from .domains import start_domains

SolveFn = Callable[[Problem], Plan]

#: Tasks explained in detail per plan; the rest get ``not_analysed``.
MAX_EXPLAINED = 8
#: Precedences of one task dropped one at a time to name the blocking one.
MAX_LINKS_TRIED = 4


def explain(
    problem: Problem, plan: Plan, solve: SolveFn
) -> tuple[Blocker, ...]:
    """Return a Blocker for each task ``plan`` leaves out.

    Parameters
    ----------
    problem
        The problem that was solved.
    plan
        Its plan (any status).
    solve
        Solves a problem (same backend and limits as the original solve).

    Returns
    -------
    tuple[Blocker, ...]
        For ``infeasible``: the mandatory tasks that cannot be placed. For
        plans: every unscheduled task. Empty for ``unknown``.
    """
    if plan.status is SolveStatus.UNKNOWN:
        return ()
    domains = start_domains(problem)
    infeasible = plan.status is SolveStatus.INFEASIBLE
    if infeasible:
        culprits, problem, plan = _infeasible_mandatory(
            problem, domains, solve
        )
    else:
        culprits = list(plan.unscheduled)
    blockers = []
    for idx, task_id in enumerate(culprits):
        domain = domains[task_id]
        if domain.empty:
            blockers.append(Blocker(task_id, domain.cause, domain.detail))
        elif idx >= MAX_EXPLAINED:
            blockers.append(
                Blocker(task_id, "not_analysed", "too many to analyse")
            )
        else:
            blockers.append(_forced(problem, plan, task_id, solve, infeasible))
    return tuple(blockers)


def _infeasible_mandatory(
    problem: Problem, domains: dict, solve: SolveFn
) -> tuple[list[str], Problem, Plan]:
    """Mandatory tasks that cannot be placed, with the relaxed model.

    Forcing one of them into the relaxed model (the other mandatory tasks
    optional) then tells what blocks it, as for an unscheduled task.
    """
    mandatory = [t.id for t in problem.tasks if t.mandatory]
    relaxed = problem.replace(
        tasks=tuple(
            _optional(task) if task.mandatory else task
            for task in problem.tasks
        )
    )
    stuck = [name for name in mandatory if domains[name].empty]
    if stuck:
        return stuck, relaxed, Plan(SolveStatus.UNKNOWN, None)
    plan = solve(relaxed)
    if not plan.status.has_plan:
        return mandatory, relaxed, plan
    left_out = set(plan.unscheduled)
    return [n for n in mandatory if n in left_out], relaxed, plan


def _optional(task: Task) -> Task:
    return msgspec.structs.replace(task, schedule_cost=5, fixed_start=None)


def _force(problem: Problem, task_id: str) -> Problem:
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(task, schedule_cost=0)
            if task.id == task_id
            else task
            for task in problem.tasks
        )
    )


def _without_resource(problem: Problem, name: str) -> Problem:
    res = problem.resources
    resources = Resources(
        binary=tuple(r for r in res.binary if r != name),
        multiple={k: v for k, v in res.multiple.items() if k != name},
        consumable={k: v for k, v in res.consumable.items() if k != name},
    )
    tasks = tuple(
        msgspec.structs.replace(
            task, uses={k: v for k, v in task.uses.items() if k != name}
        )
        for task in problem.tasks
    )
    return problem.replace(resources=resources, tasks=tasks)


def _without_precedences(problem: Problem, task_id: str) -> Problem:
    return problem.replace(
        precedences=tuple(
            p
            for p in problem.precedences
            if task_id not in (p.before, p.after)
        )
    )


def _forced(
    problem: Problem,
    plan: Plan,
    task_id: str,
    solve: SolveFn,
    mandatory: bool = False,
) -> Blocker:
    forced = _force(problem, task_id)
    attempt = solve(forced)
    if attempt.status.has_plan and attempt.objective and plan.objective:
        lost = sorted(
            set(attempt.unscheduled) - set(plan.unscheduled) - {task_id}
        )
        detail = (
            f"fits, but placing it raises the objective from "
            f"{plan.objective.total} to {attempt.objective.total}"
        )
        if mandatory:
            return Blocker(
                task_id,
                "combination",
                "fits alone but not together with the other mandatory "
                f"tasks {', '.join(lost)}",
            )
        if lost:
            detail += f" (it would push out {', '.join(lost)})"
        return Blocker(task_id, "cost", detail)
    if attempt.status is SolveStatus.UNKNOWN:
        return _not_analysed(task_id)
    task = problem.task(task_id)
    links = [
        idx
        for idx, prec in enumerate(problem.precedences)
        if task_id in (prec.before, prec.after)
    ]
    if links:
        # Precedence partners first: dropping a resource for everyone can
        # also let in the partner that really keeps the task out, and the
        # resource would then be blamed for it.
        outcome = solve(_without_precedences(forced, task_id)).status
        if outcome is SolveStatus.UNKNOWN:
            return _not_analysed(task_id)
        if outcome.has_plan:
            return _precedence_blocker(problem, forced, task_id, links, solve)
    for name in sorted(task.uses, key=problem.resources.names.index):
        outcome = solve(_without_resource(forced, name)).status
        if outcome is SolveStatus.UNKNOWN:
            return _not_analysed(task_id)
        if outcome.has_plan:
            return Blocker(
                task_id,
                problem.resources.kind_of(name) or "resource",
                _resource_detail(problem, name)
                + _capacity_note(forced, name, solve),
            )
    return Blocker(
        task_id,
        "combination",
        "no single resource or precedence relaxation lets it in",
    )


def _precedence_blocker(
    problem: Problem,
    forced: Problem,
    task_id: str,
    links: list[int],
    solve: SolveFn,
) -> Blocker:
    """Name the precedence that keeps ``task_id`` out, when one alone does.

    Without all its precedences the task fits. With a single precedence
    that one is named; with a few, each is dropped alone in turn and the
    first that lets the task in is named; else all of them.
    """
    named = links if len(links) == 1 else []
    for idx in links[:MAX_LINKS_TRIED] if len(links) > 1 else []:
        relaxed = forced.replace(
            precedences=tuple(
                p for k, p in enumerate(forced.precedences) if k != idx
            )
        )
        outcome = solve(relaxed).status
        if outcome is SolveStatus.UNKNOWN:
            break
        if outcome.has_plan:
            named = [idx]
            break
    if not named:
        return Blocker(
            task_id,
            "precedence",
            "its precedences cannot all be met with "
            + ", ".join(sorted(_partners(problem, task_id, links))),
        )
    prec = problem.precedences[named[0]]
    partner = prec.after if prec.before == task_id else prec.before
    return Blocker(
        task_id,
        "precedence",
        f"precedences[{named[0]}] ({prec.kind}, {prec.scope}) "
        f"{prec.before} -> {prec.after}: it cannot be met with {partner} "
        "placed too",
    )


def _partners(problem: Problem, task_id: str, links: list[int]) -> set[str]:
    found = set()
    for idx in links:
        prec = problem.precedences[idx]
        found.add(prec.after if prec.before == task_id else prec.before)
    return found


def _not_analysed(task_id: str) -> Blocker:
    return Blocker(task_id, "not_analysed", "the analysis ran out of time")


def _resource_detail(problem: Problem, name: str) -> str:
    res = problem.resources
    kind = res.kind_of(name)
    if kind == "binary":
        return f"{name} is busy whenever it could run"
    if kind == "multiple":
        return f"{name} capacity {res.multiple[name]:g} would be exceeded"
    ceiling = res.ceiling(name)
    capacity = "" if ceiling is None else f", capacity {ceiling:g}"
    return (
        f"{name} level (initial {res.initial(name):g}{capacity}) would go "
        "below 0"
    )


def _capacity_note(forced: Problem, name: str, solve: SolveFn) -> str:
    """What the capacity of consumable ``name`` has to do with it.

    One more solve, without the capacity: when the forced task then fits,
    the charge a full store loses is what keeps it out.
    """
    ceiling = forced.resources.ceiling(name)
    if ceiling is None:
        return ""
    unbounded = forced.replace(
        resources=msgspec.structs.replace(
            forced.resources,
            consumable={
                **forced.resources.consumable,
                name: forced.resources.initial(name),
            },
        )
    )
    if not solve(unbounded).status.has_plan:
        return ""
    return (
        f"; it would fit if the {ceiling:g} capacity did not lose what is "
        "generated while it is full"
    )
