"""A start plan from the solver when list scheduling cannot place the
tasks every plan must hold.

List scheduling, every rule of it and the forced tasks planned apart
(:func:`~fsw_scheduler.analysis.greedy.greedy_plan`), can fail on a
feasible problem: tasks pinned where a replan found them running, tight
windows and a battery leave the rules no order that fits. Without a
start plan a part of 30 tasks or more went whole to CBC, whose root LP
took the whole limit, and the answer was ``unknown`` (replan suite, seed
38's r60-h1440-0 solved afresh at 10 s: 58 tasks, 10 of them forced, no
plan; the replan, from the plan in force, had one). Here the forced
tasks and the tasks that supply a consumable the forced ones alone can
run out of (optional, as they are: the forced ones may need some of
them, as there), a model a fraction of the size, go to the solver for a
share of the limit, without the consumables they cannot run out of
(:func:`without_slack`: its model may then be the disjunctive one);
its plan, pinned, has the other tasks list-scheduled around it, and
that is the start plan the neighbourhood search and the insertion of
left-out tasks work from (there: 11 tasks, proved in 1.7 s; the forced
tasks alone are infeasible, their battery needs a supply). When the
solver finds no plan of them in its share, a list schedule with a supply
made to run beside each consumer that draws more than its capped store
holds may (:func:`~fsw_scheduler.analysis.paired.paired_plan`), or list
schedules in perturbed orders
(:func:`~fsw_scheduler.analysis.sampling.sampled_plan`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import msgspec

from ..analysis.domains import start_domains
from ..analysis.greedy import around_core, checked_starts, forced_alone
from ..analysis.paired import paired_plan
from ..analysis.proofs import forced_tasks, with_needs
from ..analysis.sampling import sampled_plan
from ..analysis.stores import never_short
from ..model.plan import Blocker, Plan, SolverStats, SolveStatus
from .budget import stop_at, stop_share
from .relaxed import around, relaxable

if TYPE_CHECKING:
    from collections.abc import Callable, Set

    from ..model.problem import Problem

#: Share of the time left that the solver gets for the forced tasks and
#: supplies: without a start plan the whole model is the only other way
#: to a plan, and on a large part its root LP takes the whole limit (at
#: 0.3 the 11-task core of the example above, proved in 1.7 s, was
#: stopped without a plan at a 5 s limit).
FORCED_SHARE = 0.5
#: Seconds at least for it (CBC's start and the model's reading); with
#: less, only list schedules in perturbed orders are tried.
FORCED_MIN_S = 0.5
#: Share of the time left that the perturbed orders of
#: :func:`~fsw_scheduler.analysis.sampling.sampled_plan` may take: a part
#: whose orders all fail keeps time for its own solve (a small part's CBC
#: may find the plan no order gives).
SAMPLED_SHARE = 0.5
#: Share of that which the disjunctive relaxation gets first when the
#: core keeps a consumable (:func:`_relaxed_core`).
RELAXED_CORE_SHARE = 0.75
#: What a solve says when the forced tasks and supplies are its whole
#: part and their plan is proved (:func:`forced_start`).
WHOLE_CORE = (
    "the tasks every plan must hold and the supplies they need are the "
    "whole part: the solver proved their plan"
)
#: How a start plan from :func:`forced_start` was built (its
#: ``stats.solver_status``; the solve's status line repeats it).
SOLVED_CORE = "built around the solver's plan of them and the supplies"
SAMPLED_CORE = (
    "built around a list schedule of them and the supplies in a perturbed "
    "order (no plan of them from the solver in its share)"
)
PAIRED_CORE = (
    "built around a list schedule of them and the supplies with a supply "
    "beside each consumer its capped store cannot feed (no plan of them "
    "from the solver in its share)"
)


def forced_start(
    problem: Problem,
    run: Callable[..., Plan],
    deadline: float | None,
) -> Plan | None:
    """A start plan built around the solver's plan of the forced tasks
    and the supplies.

    Parameters
    ----------
    problem
        A part whose start heuristic found no plan.
    run
        The solver (:func:`~fsw_scheduler.solving.ilp.solve_ilp` with the
        caller's options); called with ``time_limit``.
    deadline
        When the caller's limit ends (:func:`time.perf_counter`); None
        without a limit.

    Returns
    -------
    Plan or None
        Status ``feasible``, the checker's objective (``optimal`` when the
        forced tasks and supplies are the whole part and the solver
        proved their plan); status ``infeasible`` when the solver proved
        that the forced tasks and supplies have no plan and every plan
        of the part would be one of theirs (:func:`relaxes`); None when
        there is nothing forced, neither the solver in its share nor
        list schedules with a supply beside each consumer a capped
        store cannot feed (:func:`~fsw_scheduler.analysis.paired.
        paired_plan`) nor in perturbed orders (:func:`~fsw_scheduler.
        analysis.sampling.sampled_plan`) find a plan of the forced tasks
        and supplies (or theirs does not hold on the whole part). The
        plan's ``stats.solver_status`` says which built it
        (:data:`SOLVED_CORE`, :data:`PAIRED_CORE`, :data:`SAMPLED_CORE`).
    """
    forced = forced_tasks(problem)
    if not forced:
        return None
    # Supplies of the consumables the forced tasks alone can run out of:
    # with the others the core is a choice of optional tasks, not a
    # placement (seed 66's b60-h1440 below: 12 forced tasks proved in
    # 0.3 s, with nine supplies of a battery they cannot exhaust still
    # open at 8.9 s).
    short = without_slack(forced_alone(problem, forced)).resources.consumable
    supplies = {
        task.id
        for task in problem.tasks
        if any(
            amount < 0 and name in short for name, amount in task.uses.items()
        )
    }
    limit = None
    stop = None
    began = time.perf_counter()
    if deadline is not None:
        limit = FORCED_SHARE * (deadline - began)
        # Placing the others around the core may take what is left.
        stop = stop_at(deadline)
    # The options of a group that may not be left out: every plan holds
    # one of them, so the core chooses one (a mandatory group, an option
    # above half of a multiple resource, beside three forced users of
    # 45 % of it in three lengths less a unit: the forced tasks alone
    # fit, and the whole model found nothing in 10 s).
    options = {
        name
        for group in problem.alternatives
        if group.schedule_cost == 0
        for option in group.options
        for name in option
    }
    # With what the supplies and options need (a supply that must follow
    # an optional task): a core plan without it does not hold on the part
    # (replan suite, seed 147's r60-h1440-1: the core's battery supply
    # needed a lax predecessor; the core was planned in 0.1 s, refused on
    # the part, and the part answered `unknown` at 10 s).
    alone = without_slack(
        forced_alone(problem, with_needs(problem, forced | supplies | options))
    )
    core = None
    if limit is None or limit >= FORCED_MIN_S:
        solved = _solved_core(alone, run, limit, began)
        if solved.status is SolveStatus.INFEASIBLE and relaxes(problem, alone):
            return _no_plan(problem, alone, forced, solved)
        if solved.status.has_plan:
            core, origin = solved, SOLVED_CORE
    if core is None:
        # Too little time for the solver, or none found in its share: list
        # schedules, each way with :data:`SAMPLED_SHARE` of what is left.
        # First with a supply beside each consumer that draws more than
        # its capped store holds, which no order places there (seed 1519
        # of ``tools/fuzz --large``: ``unknown`` at 5 s before). Then in
        # perturbed orders: ``tools/fuzz --large`` seed 1192, 53 tasks
        # over H = 700, 20 s: the relaxation's plans of the 23-task core
        # broke a battery, the time-indexed model found none in 1.9 s, nor
        # the whole part's in 9.8 s, and the answer was `unknown`; the
        # first order tried places the core, in 14 ms. ``tools/fuzz`` seed
        # 60053, a 21-task part at 0.3 s and 1 s: `unknown` before; its
        # 6-task core is placed by the first order, in under a millisecond.
        for build, origin in (
            (paired_plan, PAIRED_CORE),
            (sampled_plan, SAMPLED_CORE),
        ):
            core = build(
                alone,
                stop=None
                if deadline is None
                else stop_share(deadline, SAMPLED_SHARE),
            )
            if core is not None:
                break
        if core is None:
            return None
    if (
        len(alone.tasks) == problem.num_tasks
        and core.status is SolveStatus.OPTIMAL
    ):
        # The core is the whole part (the forced tasks and the supplies
        # they need, nothing else; the consumables dropped bind no plan):
        # its optimum is the part's.
        whole = checked_starts(problem, core.starts())
        if whole is not None:
            return whole.replace(status=SolveStatus.OPTIMAL, stats=core.stats)
    # Where no rule places the others around it (replan suite, seed 40's
    # r60-h1440-0 afresh: 7 forced tasks planned in 0.09 s, then no
    # plan), the core alone: the insertion of left-out tasks and the
    # search fill it in.
    start = around_core(problem, core.starts(), stop) or checked_starts(
        problem, core.starts()
    )
    if start is None:
        return None
    return start.replace(
        stats=SolverStats(
            solver=core.stats.solver if core.stats else "greedy",
            solver_status=origin,
        )
    )


def _solved_core(
    core: Problem, run: Callable[..., Plan], limit: float | None, began: float
) -> Plan:
    """The solver's plan of ``core``: the disjunctive relaxation's when it
    holds one (:func:`_relaxed_core`), else the model's in what is left of
    ``limit`` (counted from ``began``)."""
    found = _relaxed_core(core, run, limit)
    if found is not None:
        return found
    if limit is not None:
        limit = max(0.0, limit - (time.perf_counter() - began))
    return run(core, time_limit=limit)


def relaxes(problem: Problem, sub: Problem) -> bool:
    """True when every plan of ``problem``, cut to the tasks of ``sub``,
    is a plan of ``sub``: a sub-problem without a plan then proves that
    ``problem`` has none.

    Leaving tasks out frees binary and multiple resources and raises
    every consumable's level (the level rule is monotone in what tasks
    take), and a precedence or a consumable dropped is a rule less, so
    the cut holds unless ``sub`` lost a task that *supplies* a
    consumable it keeps, or a group that may not be left out is stricter
    in ``sub`` than in the problem: with an option fewer, or not kept
    while a member is, which would stand alone there as mandatory (a
    member's cost is its group's; :func:`~fsw_scheduler.model.groups.
    kept_alternatives`). A group that may be left out constrains plans
    less with fewer options (at most one of them, each whole) and a
    member standing alone is optional: the cut holds. (``tools/fuzz
    --large`` seed 655, 56 tasks over H = 120, 5 s: a forced task was the
    one option of such a group kept by the core; the core was proved
    infeasible in 0.8 s, and the part was answered ``unknown``.)
    """
    held = {task.id for task in sub.tasks}
    kept = sub.resources.consumable
    if any(
        amount < 0 and name in kept
        for task in problem.tasks
        if task.id not in held
        for name, amount in task.uses.items()
    ):
        return False
    whole = {group.id: group for group in problem.alternatives}
    same = {
        group.id
        for group in sub.alternatives
        if group.options == whole[group.id].options
    }
    if any(
        group.schedule_cost == 0 and group.id not in same
        for group in sub.alternatives
    ):
        return False
    return all(
        group.id in same
        for group in problem.alternatives
        if group.schedule_cost == 0
        and any(name in held for option in group.options for name in option)
    )


def _no_plan(
    problem: Problem, core: Problem, forced: Set[str], answer: Plan
) -> Plan:
    """The part's answer when the solver proved its forced tasks and
    supplies (``core``) have no plan: ``infeasible``, each forced task
    named with the argument."""
    more = len(core.tasks) - len(forced)
    detail = (
        f"the {len(forced)} tasks every plan must hold"
        + (
            f" (with {more} more: the supplies of their consumables and "
            "the options of groups that may not be left out)"
            if more
            else ""
        )
        + " have no plan among themselves: the solver proved it"
    )
    return Plan(
        status=SolveStatus.INFEASIBLE,
        objective=None,
        unscheduled=tuple(task.id for task in problem.tasks),
        why=tuple(
            Blocker(task.id, "combination", detail)
            for task in problem.tasks
            if task.id in forced
        ),
        stats=msgspec.structs.replace(
            answer.stats or SolverStats(solver="cbc"),
            solver_status=f"infeasible: {detail}",
        ),
    )


def _relaxed_core(
    core: Problem, run: Callable[..., Plan], limit: float | None
) -> Plan | None:
    """The core's optimum from the disjunctive relaxation, when it holds
    a consumable and that optimum is a valid plan; else None.

    A core that keeps a consumable goes to the time-indexed model, whose
    rows per unit for the consumable and per binary resource make a
    model of thousands of columns over a long horizon even for a few
    tasks: the replan suite's seed 53 r60-h1440-0 solved afresh has 7
    forced tasks and a supply over H = 1440, 7,840 columns, and CBC
    found no plan in 4 s (the answer was ``unknown``). The relaxation
    (:func:`~fsw_scheduler.solving.relaxed.around`: the
    disjunctive model, the levels written on the starts where its optimum
    breaks them) proves the core's optimum in 1.0 s there, CP-SAT's. It
    gets :data:`RELAXED_CORE_SHARE` of ``limit``; the time-indexed model
    gets what it leaves.
    """
    domains = start_domains(core)
    if not relaxable(run, core, domains, None):
        return None
    nothing = Plan(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=(),
        unscheduled=tuple(task.id for task in core.tasks),
    )
    share = None if limit is None else RELAXED_CORE_SHARE * limit
    return around(core, nothing, domains, run, share, nodes=None).plan


def without_slack(problem: Problem) -> Problem:
    """``problem`` without the consumables its tasks cannot run out of.

    A consumable whose users, all run in full, and its external drain
    take no more than its initial level never binds: no plan breaks it,
    and dropping it from the resources and the tasks' uses leaves the
    same plans. A model without it may be the disjunctive one, which
    reads no consumable: the large suite's b60-h1440 of seed 66 has 12
    forced tasks that list scheduling cannot place (three binary
    resources packed to the unit) and that take 2,311 of a battery's
    2,312; their time-indexed model (13,145 columns) gave CBC no plan in
    9.6 s and the answer was ``unknown``, where the disjunctive model
    without the battery is proved in 0.4 s.
    """
    resources = problem.resources
    slack = {
        name
        for name, initial in resources.initial_levels.items()
        if never_short(
            initial,
            resources.external_profile(name, problem.start, problem.horizon),
            [(t, t.uses[name]) for t in problem.tasks if name in t.uses],
        )
    }
    if not slack:
        return problem
    return problem.replace(
        resources=msgspec.structs.replace(
            resources,
            consumable={
                n: v for n, v in resources.consumable.items() if n not in slack
            },
        ),
        tasks=tuple(
            msgspec.structs.replace(
                task,
                uses={n: a for n, a in task.uses.items() if n not in slack},
            )
            if any(n in slack for n in task.uses)
            else task
            for task in problem.tasks
        ),
    )
