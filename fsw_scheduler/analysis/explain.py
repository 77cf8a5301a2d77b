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
* A group left out (its id in ``unscheduled``) is forced in the same way
  (made mandatory): ``cost`` when an option then fits, else the reason
  shared by its options. Each option a plan did not choose is solved
  alone (the group reduced to it, mandatory): cause ``alternative``, with
  what it would cost or why it cannot be scheduled.
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from ..model.plan import Blocker, Plan, SolveStatus
from ..model.problem import (
    Alternative,
    Consumable,
    Problem,
    Resources,
    Task,
)
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
    by_group = {group.id: group for group in problem.alternatives}
    blockers = []
    for idx, task_id in enumerate(culprits):
        if task_id in by_group:
            blockers.append(
                _group_blocker(problem, plan, by_group[task_id], solve)
                if idx < MAX_EXPLAINED
                else Blocker(task_id, "not_analysed", "too many to analyse")
            )
            continue
        domain = domains[task_id]
        if domain.empty:
            blockers.append(Blocker(task_id, domain.cause, domain.detail))
        elif idx >= MAX_EXPLAINED:
            blockers.append(
                Blocker(task_id, "not_analysed", "too many to analyse")
            )
        else:
            blockers.append(_forced(problem, plan, task_id, solve, infeasible))
    if not infeasible:
        blockers += _options_not_chosen(problem, plan, solve)
    return tuple(blockers)


def _with_group(problem: Problem, group: Alternative) -> Problem:
    """``problem`` with ``group`` in place of the group of the same id."""
    return problem.replace(
        alternatives=tuple(
            group if g.id == group.id else g for g in problem.alternatives
        )
    )


def _only_option(problem: Problem, group: Alternative, k: int) -> Problem:
    """``problem`` where ``group`` must have its option ``k``: the group
    reduced to it, mandatory, and the other options' tasks taken out
    (with their precedences), so that nothing else stands in for them."""
    option = group.options[k]
    others = {
        name
        for idx, other in enumerate(group.options)
        if idx != k
        for name in other
    }
    reduced = _with_group(
        problem,
        msgspec.structs.replace(group, schedule_cost=0, options=(option,)),
    )
    return reduced.replace(
        tasks=tuple(t for t in reduced.tasks if t.id not in others),
        precedences=tuple(
            p
            for p in reduced.precedences
            if p.before not in others and p.after not in others
        ),
    )


def _group_blocker(
    problem: Problem, plan: Plan, group: Alternative, solve: SolveFn
) -> Blocker:
    """Why no option of ``group`` is scheduled: forced in, what then."""
    domains = start_domains(problem)
    stuck = [
        next((n for n in option if n in domains and domains[n].empty), None)
        for option in group.options
    ]
    if all(name is not None for name in stuck):
        return Blocker(
            group.id,
            domains[stuck[0]].cause or "window",  # type: ignore[index]
            "no option can be placed: "
            + "; ".join(
                f"option {k}: {name} {domains[name].detail}"  # type: ignore[index]
                for k, name in enumerate(stuck)
            ),
        )
    forced = _with_group(
        problem, msgspec.structs.replace(group, schedule_cost=0)
    )
    attempt = solve(forced)
    if attempt.status is SolveStatus.UNKNOWN:
        return _not_analysed(group.id)
    if attempt.status.has_plan and attempt.objective and plan.objective:
        return Blocker(
            group.id,
            "cost",
            f"option {attempt.picks.get(group.id, 0)} fits, but placing it "
            f"raises the objective from {plan.objective.total} to "
            f"{attempt.objective.total}",
        )
    return Blocker(
        group.id,
        "combination",
        "no option fits with the tasks every plan must hold",
    )


def _options_not_chosen(
    problem: Problem, plan: Plan, solve: SolveFn
) -> list[Blocker]:
    """One ``alternative`` blocker per option a plan did not choose."""
    found = []
    explained = 0
    for group in problem.alternatives:
        pick = plan.picks.get(group.id)
        if pick is None:
            continue
        for k, option in enumerate(group.options):
            if k == pick:
                continue
            head = (
                f"option {k} ({', '.join(option)}) not chosen, option "
                f"{pick} is"
            )
            if explained >= MAX_EXPLAINED:
                found.append(
                    Blocker(group.id, "alternative", f"{head}: not analysed")
                )
                continue
            explained += 1
            alone = _only_option(problem, group, k)
            attempt = solve(alone)
            if attempt.status is SolveStatus.UNKNOWN:
                reason = "the analysis ran out of time"
            elif (
                attempt.status.has_plan
                and attempt.objective
                and plan.objective
            ):
                total = attempt.objective.total
                reason = (
                    f"with it the objective would be {total}, not "
                    f"{plan.objective.total}"
                    if total != plan.objective.total
                    else f"a tie: with it the objective would be {total} too"
                )
            else:
                reason = "it cannot be scheduled with the tasks every plan "
                reason += "must hold"
            found.append(Blocker(group.id, "alternative", f"{head}: {reason}"))
    return found


def _infeasible_mandatory(
    problem: Problem, domains: dict, solve: SolveFn
) -> tuple[list[str], Problem, Plan]:
    """Mandatory tasks that cannot be placed, with the relaxed model.

    Forcing one of them into the relaxed model (the other mandatory tasks
    optional) then tells what blocks it, as for an unscheduled task.
    """
    mandatory = [t.id for t in problem.tasks if problem.required(t)]
    mandatory += [g.id for g in problem.alternatives if g.schedule_cost == 0]
    members = problem.groups.member
    relaxed = problem.replace(
        tasks=tuple(
            _optional(task)
            if problem.required(task)
            or (task.id in members and task.schedule_cost == 0)
            else task
            for task in problem.tasks
        ),
        alternatives=tuple(
            msgspec.structs.replace(g, schedule_cost=5)
            if g.schedule_cost == 0
            else g
            for g in problem.alternatives
        ),
    )
    stuck = [
        name for name in mandatory if name in domains and domains[name].empty
    ]
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
        binary={k: v for k, v in res.binary.items() if k != name}
        if isinstance(res.binary, dict)
        else tuple(r for r in res.binary if r != name),
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
        value = res.multiple[name]
        words = (
            f"{value:g}"
            if isinstance(value, int | float)
            else "(in steps) "
            + ", ".join(f"{c} from {t}" for t, c in value.steps)
        )
        return f"{name} capacity {words} would be exceeded"
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
                name: Consumable(
                    forced.resources.initial(name),
                    external=getattr(
                        forced.resources.consumable[name], "external", ()
                    ),
                ),
            },
        )
    )
    if not solve(unbounded).status.has_plan:
        return ""
    return (
        f"; it would fit if the {ceiling:g} capacity did not lose what is "
        "generated while it is full"
    )
