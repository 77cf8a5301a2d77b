"""Replans of large parts: the plan in force repaired and searched around
what changed, then the rest of the replan's share where the gap is open.

:func:`replanned` is what :func:`fsw_scheduler.solving.solve.solve` runs
for a part of :attr:`~fsw_scheduler.solving.budget.SolveBudget.
lns_min_tasks` tasks or more given the plan in force (``warm``): the
repair (:mod:`fsw_scheduler.solving.repair`), the kept-set bound, the
disjunctive relaxation (:mod:`.relaxed`), the neighbourhood search
around the changed tasks and over the horizon (:mod:`.improve`), the
whole model when it is small around the plan, the relaxation again in
what is left, and a second look (the part solved afresh) when a whole
task may be left out too many. A part the repair cannot start is solved
as a fresh large part (:func:`~.large.improved`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from ..analysis.bounds import KeptSetProof, kept_set_bound
from ..analysis.domains import start_count
from ..analysis.greedy import greedy_plan
from . import large
from .budget import BOUND_SHARE, BUDGET, stop_at
from .forced import forced_start
from .ilp.disjunctive.rule import pick
from .improve import MIN_ROUND_S, improve, meets
from .incumbent import a_task_above, whole_model
from .polishing import POLISH_MAX_S, POLISH_SHARE, Polishing, shift_deadline
from .relaxed import NODES, relaxable
from .repair import changed_tasks, holding, repair
from .rounds import GROWTH
from .stats import higher, method_label

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem


#: Share of a replan's time its repair (the start heuristic) may take.
REPAIR_SHARE = 0.7

#: Search nodes of a replan's kept-set bound: its default 20,000 took
#: 0.2-0.6 s on 60 tasks, a third of a replan; 5,000 found the same bound
#: on 5 of the 6 large parts (30-60 tasks) where 20,000 found one, in a
#: tenth of a second.
REPLAN_BOUND_NODES = 5_000


#: A replan runs the disjunctive relaxation (:mod:`.relaxed`) after its
#: repair when at least this long is left, in rounds of growing node
#: limits (:func:`~fsw_scheduler.solving.rounds.rounds`, as a fresh
#: solve does) for this share of it. A fresh solve has its own minimum
#: (:func:`~fsw_scheduler.solving.relaxed.fresh_min_left`, 1-5 s by
#: size); a replan has 2 s in all. At a share of 0.5 the relaxation was
#: stopped by its time in 17 of the 26 replans of seeds 17-23 that ran
#: it; at 0.75 (one run), 22 of 42 replans were no worse than the fresh
#: solve against 20. One run at 0.9 or 1.0 was no better (17 of 24 on
#: seeds 55-58 against 18). In rounds at 0.9, from the plans in force
#: the replan suite's seeds 66-71 saved, 21 of 36 replans were no worse
#: than the fresh solve against 19 with one run at 0.75, medians 1.39 and
#: 1.36 s against 1.48 and 1.71 s: seed 67's r45-h1440-0 and -1 and
#: seed 70's r45-h1440-0 reach the optimum the fresh solve proves in its
#: second round; seed 66's r45-h1440-1 ends 5 units above it.
REPLAN_RELAX_MIN_S = 0.6
REPLAN_RELAX_SHARE = 0.9


def replanned(
    problem: Problem,
    in_force: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    time_limit: float,
    full_limit: float | None = None,
) -> Plan | None:
    """A large part replanned from the plan in force, or None.

    The plan in force is repaired (:func:`~fsw_scheduler.solving.repair.
    repair`: its tasks stay, the others go into its gaps), then the
    neighbourhood search works around the tasks that changed, within the
    limit (a replan's: :meth:`~fsw_scheduler.solving.budget.SolveBudget.
    replan_limit`), and stops when those neighbourhoods give nothing
    more; the whole model narrowed around its plan then gets the rest of
    the share when it is small, and the disjunctive relaxation runs again
    in rounds in what is left while the gap is open (:func:`_again`).
    The kept-set bound and the relaxation's say whether it is optimal,
    and its gap.
    When the repair finds no plan the part is solved afresh
    (:func:`_afresh`, then the same second look as below); None when
    that has no start plan either.

    With ``full_limit`` (the caller's limit, of which ``time_limit`` is
    the replan's share) a replan that may still leave out a whole task
    too many (its gap at least the weight of a schedule cost unit) gets
    a second look: the part solved afresh in what is left of the full
    limit, the better plan kept (:func:`_second_look`).
    """
    end = began + time_limit - BUDGET.lns_margin_s
    # The start heuristic under the repair took the whole replan on 60
    # tasks (1.9 of 2 s), and the bound after it ran past the limit: it
    # stops at REPAIR_SHARE of the time, keeping the rest for the bound
    # and the search around the change.
    stop = stop_at(began + REPAIR_SHARE * (end - began))
    repaired = repair(problem, in_force, domains, stop=stop)
    if repaired is None:
        # Solved afresh in the replan's share: it may leave out whole
        # tasks too many as well (replan suite, seed 38's r60-h1440-1:
        # 20.6 M at 1.7 s, the fresh solve 18.5 M), so the second look.
        afresh = _afresh(problem, in_force, domains, run, began, time_limit)
        if afresh is None:
            return None
        return _second_look(problem, afresh, domains, run, began, full_limit)
    relaxed = kept_set_bound(
        problem,
        repaired,
        domains,
        max_nodes=REPLAN_BOUND_NODES,
        stop=large.until(end, BOUND_SHARE),
    )
    if relaxed.bound is None:
        # Out of nodes: once more with a fresh solve's (seed 12's
        # r45-h1440-1 of the replan suite: a bound in 0.13 s, and from
        # its kept set a plan leaving out 53 instead of 56).
        relaxed = kept_set_bound(
            problem, repaired, domains, stop=large.until(end, BOUND_SHARE)
        )
    if relaxed.plan is not None:
        return large.proved_start(
            relaxed.plan,
            began,
            time_limit,
            "replan: the plan in force, repaired, meets the kept-set bound",
        )
    bound = None if relaxed.lowest is None else float(relaxed.lowest)
    # When the repaired plan leaves out more than the bound (the plan in
    # force was poor on the new day: its start heuristic stopped early),
    # the relaxed optimum's tasks list-scheduled alone, as a fresh solve
    # does (replan suite, seed 15's r60-h1440-0: 82 left out instead of
    # 88, as the fresh solve; seed 13's r45-h1440-1: 44 instead of 45).
    # The repair puts the new tasks into gaps only: a task that needs a
    # placed one moved is left out (replan suite, seed 20's r60-h1440-0:
    # a task the fresh solve keeps, 725,323 above it), so left-out tasks
    # are inserted into each; the repaired plan wins a tie.
    repaired, inserting = large.kept_set_started(
        problem, repaired, relaxed, domains, end
    )
    said = f"; {inserting} left-out tasks inserted" if inserting else ""
    left = end - time.perf_counter()
    relaxed_from = None  # the plan the relaxation ran around
    if relaxable(run, problem, domains, left, REPLAN_RELAX_MIN_S):
        relaxed_from = repaired
        # The disjunctive relaxation proves some parts at once that the
        # search around the change cannot (replan suite, seed 20's
        # r45-h1440-1: the fresh solve proved it in 0.34 s this way, the
        # replan without it ended 140 units worse).
        caught = large.relaxation(
            problem,
            repaired,
            domains,
            relaxed,
            run,
            REPLAN_RELAX_SHARE * left,
            more=True,
            end=end,
        )
        said += f"; the disjunctive relaxation: {caught.said}"
        if caught.plan is not None and caught.plan.objective is not None:
            return large.answer(
                caught.plan,
                float(caught.plan.objective.total),
                method_label(run, "relaxed"),
                "replan: " + caught.said,
                began,
                time_limit,
            )
        repaired = caught.better or repaired
        bound = higher(bound, caught.bound)
    polish = Polishing(problem, domains, end, bound)
    repaired = polish(repaired)
    changed = changed_tasks(problem, in_force, repaired)
    best, improved = repaired, 0
    # The search stops short of the end: the last moments polish its plan.
    search_end = end - min(
        POLISH_MAX_S, POLISH_SHARE * max(0.0, end - time.perf_counter())
    )
    if changed and not meets(best, bound):
        best, improved = improve(
            problem, repaired, domains, run, search_end, bound, around=changed
        )
    swept = 0
    if (
        not meets(best, bound)
        and search_end - time.perf_counter() >= MIN_ROUND_S
    ):
        # The neighbourhoods around the change gave all they could and
        # time is left: the sweep over the whole horizon goes on from
        # there, as a fresh solve's search would (a fresh solve of the
        # new day often found a better arrangement away from the change).
        best, swept = improve(problem, best, domains, run, search_end, bound)
    if improved or swept:
        best = polish(best)
    narrowed = None
    if not meets(best, bound) and end - time.perf_counter() >= MIN_ROUND_S:
        narrowed = large.narrowed_around(
            problem, best, domains, relaxed, large.until(end)
        )
    if narrowed is not None and (
        start_count(narrowed) <= large.SMALL_COLUMNS
        or pick(problem, narrowed) == "disjunctive"
    ):
        # The search ran out of neighbourhoods with time left: around a
        # good plan the whole model is small (replan suite, seed 52's
        # r45-h1440-1: 0.6 s, gap 794; the fresh solve proved the same
        # plan in 0.15 s this way). The disjunctive model's size does not
        # follow the starts: a few columns a task, whatever the domains
        # (seed 66's r45-h1440-0: 6,024 starts, answered `feasible` at
        # 0.68 s of 2 s with a gap of 1,182; the fresh solve proved the
        # same plan in its disjunctive model in 0.21 s, and so does the
        # replan now, in 0.9-1.1 s).
        best, bound, answered = whole_model(
            problem, best, bound, run, narrowed, end - time.perf_counter()
        )
        said += f"; the whole model, narrowed: {answered}"
    if not meets(best, bound):
        best, bound, again = _again(
            problem, best, bound, domains, relaxed, run, end, relaxed_from
        )
        said += again
    # The shift windows may run past the replan's share, within the limit.
    last = end if full_limit is None else end - time_limit + full_limit
    best = polish.shifted(best, run, shift_deadline(last, end))
    said += polish.said()
    answer = large.answer(
        best,
        bound,
        method_label(run, "repair"),
        f"replan from the plan in force: {len(changed)} tasks changed by "
        f"its repair; neighbourhood search around them: {improved} "
        f"improvements, then over the horizon: {swept}{said}",
        began,
        time_limit,
    )
    return _second_look(problem, answer, domains, run, began, full_limit)


def _again(
    problem: Problem,
    best: Plan,
    bound: float | None,
    domains: dict[str, Domain],
    relaxed: KeptSetProof,
    run: Callable[..., Plan],
    end: float,
    relaxed_from: Plan | None,
) -> tuple[Plan, float | None, str]:
    """The disjunctive relaxation in rounds around a replan's ``best``, in
    what is left of its share when the search has ended with the gap open.

    The search around the change often ends well before the share does,
    having found nothing, while the relaxation's first run stopped on its
    nodes (replan suite, seed 56's r60-h1440-0: answered at 1.25 of 2 s,
    68 units above the optimum the fresh solve proved at 1.9 s in its
    second round). The rounds start with the nodes of the first run's
    next round when ``best`` costs what ``relaxed_from``, the plan that
    run started from, cost: the domains narrowed around a plan read its
    objective only (:func:`~fsw_scheduler.analysis.domains.cost_caps`,
    the kept-set fixings), so that run again would search the same
    model; else with its nodes, over the domains narrowed around the
    better plan. On seeds 55-58 of
    the replan suite (24 replans, 10 s) 19 were no worse than the fresh
    solve against 18 without, medians 0.37-1.23 s against 0.35-0.97 s.

    Returns
    -------
    tuple
        The better plan, the higher bound (the plan's own objective when
        a round proves it), and what was done, for the answer's status.
    """
    left = end - time.perf_counter()
    if not relaxable(run, problem, domains, left, MIN_ROUND_S):
        return best, bound, ""
    same = (
        relaxed_from is not None
        and relaxed_from.objective is not None
        and best.objective is not None
        and relaxed_from.objective.total == best.objective.total
    )
    nodes = GROWTH * NODES if same else NODES
    last = large.relaxation(
        problem, best, domains, relaxed, run, left, more=True, nodes=nodes
    )
    said = f"; the relaxation again: {last.said}"
    if last.plan is not None and last.plan.objective is not None:
        return last.plan, float(last.plan.objective.total), said
    return last.better or best, higher(bound, last.bound), said


#: Seconds a second look (:func:`_second_look`) needs at least: a start
#: plan and a few neighbourhoods of a 60-task part.
SECOND_LOOK_MIN_S = 2.0


def _second_look(
    problem: Problem,
    answer: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    full_limit: float | None,
) -> Plan:
    """``answer``, or the part solved afresh when that is better.

    A replan keeps the plan in force and searches around the change; when
    the bound says it may still leave out a whole task too many (a gap of
    at least the objective's weight of one schedule cost unit), a fresh
    solve of the new day often finds the arrangement that holds it
    (replan suite, seed 26's r60-h1440-0: 9,260,008 after the repair's
    2 s, 8,191,196 afresh). So the part is solved afresh as a large part
    (:func:`~.large.improved`) in what is left of ``full_limit``, from the
    start heuristic's plan where that is better than the replan's, else
    from the replan's own plan, and the better plan is the answer, the
    replan's on a tie. From the heuristic's plan alone the search had a
    few seconds less than a fresh solve's and often ended worse than the
    replan (replan suite, seed 258's r60-h1440-0: 21,688,663 against the
    fresh solve's 21,683,184; from the replan's plan 21,682,966; seed
    241's r60-h1440-0 21,146,964 -> 21,146,580). A replan whose gap is
    only delay answers at its share of the limit.
    """
    stats = answer.stats
    if (
        full_limit is None
        or answer.objective is None
        or stats is None
        or stats.bound is None
    ):
        return answer
    now = time.perf_counter()
    left = began + full_limit - now
    if (
        not a_task_above(problem, answer.objective.total, stats.bound)
        or left < SECOND_LOOK_MIN_S
    ):
        return answer
    fresh = greedy_plan(
        problem,
        stop=stop_at(now + BUDGET.greedy_share * left),
        domains=domains,
    ) or forced_start(problem, run, now + left)  # as a fresh solve starts
    start, origin = answer.replace(stats=None), "the replan's plan"
    if (
        fresh is not None
        and fresh.objective is not None
        and fresh.objective.total < answer.objective.total
    ):
        start, origin = fresh, "the start heuristic's plan"
    other = large.improved(problem, start, domains, run, now, left)
    better = (
        other
        if other.objective is not None
        and other.objective.total < answer.objective.total
        else answer
    )
    bound = higher(stats.bound, other.stats.bound if other.stats else None)
    said = f"solved afresh in the rest of the limit from {origin}: " + (
        "its plan kept" if better is other else "no better"
    )
    label = better.stats.solver if better.stats else stats.solver
    return large.answer(
        better,
        bound,
        label,
        f"{stats.solver_status}; a whole task may be left out too many "
        f"(gap {answer.objective.total - stats.bound:.0f}), {said}",
        began,
        full_limit,
    )


def _afresh(
    problem: Problem,
    in_force: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    time_limit: float,
) -> Plan | None:
    """A replan the repair cannot start: solved as a fresh large part
    (:func:`~.large.improved`), from the better of the start heuristic's
    plan and what of the plan in force holds by itself
    (:func:`~fsw_scheduler.solving.repair.holding`), else from the
    solver's plan of the forced tasks (:func:`~.forced.forced_start`, as
    a fresh solve starts); None when none of these is a plan.

    The start heuristic has the same share of the limit as in a fresh
    solve; under load it is stopped early, with little more than the
    forced tasks placed, and what of the plan in force holds then leaves
    out far less (replan suite, the heuristic stopped at once: seed 13's
    r45-h1440-0 left out 50 instead of 102, seed 15's 79 instead of 84;
    the fresh solve 31 and 48). Unloaded, the heuristic's plan is the
    better start and nothing changes. The relaxation is tried from a
    replan's minimum and share (:data:`REPLAN_RELAX_MIN_S`,
    :data:`REPLAN_RELAX_SHARE`), as after a repair.
    """
    held = holding(problem, in_force, domains)
    fresh = greedy_plan(
        problem,
        stop=stop_at(began + BUDGET.greedy_share * time_limit),
        domains=domains,
    )
    starts = [p for p in (held, fresh) if p and p.objective is not None]
    if not starts:
        # No rule placed the forced tasks: the solver plans them alone, as
        # in a fresh solve (replan suite, seed 147's r60-h1440-1: a
        # finished mandatory task run again for its tight successor, the
        # battery short until a supply with a predecessor runs).
        core = forced_start(problem, run, began + time_limit)
        if core is None or core.objective is None:
            return None
        starts = [core]
    # On a tie, what the plan in force keeps.
    start = min(starts, key=lambda p: p.objective.total if p.objective else 0)
    # The relaxation from a replan's minimum and share, as after a repair:
    # a fresh solve proves some such parts by it at once (replan suite,
    # seed 23's r45-h1440-1: proved in 0.78 s this way; 627,089 above the
    # fresh solve's optimum without it).
    return large.improved(
        problem,
        start,
        domains,
        run,
        began,
        time_limit,
        REPLAN_RELAX_MIN_S,
        REPLAN_RELAX_SHARE,
    )
