"""Large parts and replans: the neighbourhood search with a bound.

Parts of :attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_min_tasks`
tasks or more under a time limit are not handed whole to CBC at first
(its root LP alone can take longer than the limit):

* :func:`improved`: the start plan improved by neighbourhood search
  (:mod:`fsw_scheduler.solving.improve`), bounded by the kept-set
  relaxation, then the whole model narrowed around the incumbent with
  what is left; the plan carries its bound (``stats.bound``);
* :func:`replanned`: a replan from the plan in force, repaired
  (:mod:`fsw_scheduler.solving.repair`) and searched around what changed.

:func:`fsw_scheduler.solving.solve.solve` calls them and adds the gap.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

from ..analysis.bounds import KeptSetProof, better_start, kept_set_bound
from ..analysis.domains import start_count
from ..analysis.greedy import greedy_plan
from ..analysis.insert import inserted
from ..model.plan import SolverStats, SolveStatus
from .budget import BOUND_SHARE, BUDGET, stop_at
from .forced import forced_start
from .improve import MIN_ROUND_S, improve, meets
from .incumbent import a_task_above, narrow, whole_model, worth_a_probe
from .polishing import POLISH_MAX_S, POLISH_SHARE, Polishing, shift_deadline
from .relaxed import RelaxedAnswer, fresh_min_left, relaxable
from .relaxed import around as relaxed_around
from .repair import changed_tasks, holding, repair
from .rounds import OVERTIME, SHARE, rounds
from .stats import higher, method_label

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem


def searched(problem: Problem) -> bool:
    """True if a part under a time limit goes to the neighbourhood search
    (:func:`improved`, :func:`replanned`) rather than whole to CBC: from
    :attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_min_tasks` tasks.

    Parts of 20-29 tasks whose model had over 15,000 columns were sent
    here too for a while: on the large suite's seed 47 (not tuned on) a
    29-task part over H = 1440 that CBC proves in 7 s went unproved, and
    on the fresh campaign's f25-h1440-0 (seed 5) the search's plan and
    bound were both worse than CBC's.
    """
    return problem.num_tasks >= BUDGET.lns_min_tasks


#: Share of a replan's time its repair (the start heuristic) may take.
REPAIR_SHARE = 0.7

#: Search nodes of a replan's kept-set bound: its default 20,000 took
#: 0.2-0.6 s on 60 tasks, a third of a replan; 5,000 found the same bound
#: on 5 of the 6 large parts (30-60 tasks) where 20,000 found one, in a
#: tenth of a second.
REPLAN_BOUND_NODES = 5_000


#: A replan runs the disjunctive relaxation (:mod:`.relaxed`) after its
#: repair when at least this long is left, for this share of it. A
#: fresh solve has its own minimum (:func:`~fsw_scheduler.solving.
#: relaxed.fresh_min_left`, 1-5 s by size); a replan has 2 s in all.
#: At a share of 0.5 the relaxation was stopped by its time in 17 of
#: the 26 replans of seeds 17-23 that ran it; at 0.75, 22 of 42 replans
#: were no worse than the fresh solve against 20 (better on 7, worse on
#: 2, same median 1.46 s).
REPLAN_RELAX_MIN_S = 0.6
REPLAN_RELAX_SHARE = 0.75


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
    the share when it is small. The kept-set bound says whether it is
    optimal, and its gap.
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
        stop=_until(end, BOUND_SHARE),
    )
    if relaxed.bound is None:
        # Out of nodes: once more with a fresh solve's (seed 12's
        # r45-h1440-1 of the replan suite: a bound in 0.13 s, and from
        # its kept set a plan leaving out 53 instead of 56).
        relaxed = kept_set_bound(
            problem, repaired, domains, stop=_until(end, BOUND_SHARE)
        )
    if relaxed.plan is not None:
        return _proved_start(
            relaxed.plan,
            began,
            time_limit,
            "replan: the plan in force, repaired, meets the kept-set bound",
        )
    bound = None if relaxed.bound is None else float(relaxed.bound)
    if worth_a_probe(problem, repaired, relaxed):
        # The repaired plan leaves out more than the bound: the plan in
        # force was poor on the new day (its start heuristic stopped
        # early). The relaxed optimum's tasks list-scheduled alone, as a
        # fresh solve does (replan suite, seed 15's r60-h1440-0: 82 left
        # out instead of 88, as the fresh solve; seed 13's r45-h1440-1:
        # 44 instead of 45).
        repaired = (
            better_start(
                problem, repaired, relaxed, stop=_until(end, BOUND_SHARE)
            )
            or repaired
        )
    # The repair puts the new tasks into gaps only: a task that needs a
    # placed one moved is left out (replan suite, seed 20's r60-h1440-0:
    # a task the fresh solve keeps, 725,323 above it).
    inserting = len(repaired.unscheduled)
    repaired = _inserting(problem, repaired, domains, end)
    inserting -= len(repaired.unscheduled)
    said = f"; {inserting} left-out tasks inserted" if inserting else ""
    left = end - time.perf_counter()
    if relaxable(run, problem, domains, left, REPLAN_RELAX_MIN_S):
        # The disjunctive relaxation proves some parts at once that the
        # search around the change cannot (replan suite, seed 20's
        # r45-h1440-1: the fresh solve proved it in 0.34 s this way, the
        # replan without it ended 140 units worse).
        caught = _relaxation(
            problem, repaired, domains, relaxed, run, REPLAN_RELAX_SHARE * left
        )
        said += f"; the disjunctive relaxation: {caught.said}"
        if caught.plan is not None and caught.plan.objective is not None:
            return _answer(
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
        narrowed = _narrowed(problem, best, domains, relaxed, _until(end))
    if narrowed is not None and start_count(narrowed) <= SMALL_COLUMNS:
        # The search ran out of neighbourhoods with time left: around a
        # good plan the whole model is small (replan suite, seed 52's
        # r45-h1440-1: 0.6 s, gap 794; the fresh solve proved the same
        # plan in 0.15 s this way).
        best, bound, answered = whole_model(
            problem, best, bound, run, narrowed, end - time.perf_counter()
        )
        said += f"; the whole model, narrowed: {answered}"
    # The shift windows may run past the replan's share, within the limit.
    last = end if full_limit is None else end - time_limit + full_limit
    best = polish.shifted(best, run, shift_deadline(last, end))
    said += polish.said()
    answer = _answer(
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
    2 s, 8,191,196 afresh). So the part is solved afresh (:func:`_afresh`
    from the start heuristic) in what is left of ``full_limit``, and the
    better plan is the answer, the replan's on a tie. A replan whose gap
    is only delay answers at its share of the limit.
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
    if fresh is None or fresh.objective is None:
        return answer
    other = improved(problem, fresh, domains, run, now, left)
    better = (
        other
        if other.objective is not None
        and other.objective.total < answer.objective.total
        else answer
    )
    bound = higher(stats.bound, other.stats.bound if other.stats else None)
    said = (
        "solved afresh in the rest of the limit: its plan kept"
        if better is other
        else "solved afresh in the rest of the limit: no better"
    )
    label = better.stats.solver if better.stats else stats.solver
    return _answer(
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
    (:func:`improved`), from the better of the start heuristic's plan and
    what of the plan in force holds by itself (:func:`~fsw_scheduler.
    solving.repair.holding`), or None when neither is a plan.

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
        return None
    # On a tie, what the plan in force keeps.
    start = min(starts, key=lambda p: p.objective.total if p.objective else 0)
    # The relaxation from a replan's minimum and share, as after a repair:
    # a fresh solve proves some such parts by it at once (replan suite,
    # seed 23's r45-h1440-1: proved in 0.78 s this way; 627,089 above the
    # fresh solve's optimum without it).
    return improved(
        problem,
        start,
        domains,
        run,
        began,
        time_limit,
        REPLAN_RELAX_MIN_S,
        REPLAN_RELAX_SHARE,
    )


#: Seconds (at most; a tenth of what is left) that the whole model run
#: after the neighbourhood search leaves of the limit for its own end.
FULL_MARGIN_S = 1.0

#: The whole model is run after the neighbourhood search only with at
#: least this long left: a 60-task model's building and CBC's start took
#: all of 1.7 s, and the search had lost that time for nothing.
FULL_MIN_S = 2.0

#: A large part whose whole model, narrowed around its start plan, has at
#: most this many columns (start times) is given to CBC first, for
#: :data:`SMALL_SHARE` of the time left; the search gets the rest. The
#: root probe's threshold (:data:`~fsw_scheduler.solving.incumbent.
#: ROOT_PROBE_COLUMNS`): below it CBC's root takes well under a second.
SMALL_COLUMNS = 5_000
SMALL_SHARE = 0.5

#: A sweep of the search that finds nothing hands the rest of the time
#: over to the whole model when, narrowed around the incumbent, it has at
#: most this many columns (CBC proved a 12,126-column one in 5 s).
HAND_OVER_COLUMNS = 15_000


def improved(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    run: Callable[..., Plan],
    began: float,
    time_limit: float,
    relax_min_s: float | None = None,
    relax_share: float = SHARE,
) -> Plan:
    """The start plan improved by
    :func:`fsw_scheduler.solving.improve.improve`, with a proven bound.

    For large problems under a limit: the whole model does not get
    through CBC's root LP in seconds (on the scaling set CBC never
    improved the start plan), small neighbourhood models do. Where the
    whole model narrowed around the start plan is small
    (:data:`SMALL_COLUMNS`), CBC gets it first, for :data:`SMALL_SHARE`
    of the time; a stalled sweep hands the rest over to it as soon as
    the incumbent makes it small (:data:`HAND_OVER_COLUMNS`). Left-out
    tasks are first inserted into the start plan where moving what is in
    their way pays (:func:`_inserting`), and again into a plan the
    relaxation or the search improved. The
    kept-set relaxation (:func:`~fsw_scheduler.analysis.bounds.
    kept_set_plan`) bounds every plan from the start, and the search
    stops when its incumbent meets the bound. Otherwise, once a sweep of
    the largest neighbourhoods finds nothing or its share of the limit
    (:attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_share`) is
    spent, the whole model, narrowed around the incumbent (every plan at
    least as good fits in it), gets the rest of the limit: CBC may prove
    the incumbent, improve it, or at least raise the bound. The plan
    carries the best bound found (``stats.bound``) and its ``gap``.
    The disjunctive relaxation's rounds run first when at least
    ``relax_min_s`` is left, for ``relax_share`` of it (a fresh solve's
    :func:`~fsw_scheduler.solving.relaxed.fresh_min_left` and
    :data:`~fsw_scheduler.solving.rounds.SHARE` by default).
    """
    deadline = began + time_limit - BUDGET.lns_margin_s
    if relax_min_s is None:
        relax_min_s = fresh_min_left(problem)
    relaxed = kept_set_bound(
        problem, start, domains, stop=_until(deadline, BOUND_SHARE)
    )
    if relaxed.plan is None and worth_a_probe(problem, start, relaxed):
        # The start plan leaves out more than the bound: the relaxed
        # optimum's tasks, list-scheduled alone, often leave out much
        # less (b45-h1440 of the large suite, seed 31: 5.4 M instead of
        # 7.1 M, which the search had not found in 20 s). It takes as
        # long as the start plan did, so only here.
        start = (
            better_start(
                problem, start, relaxed, stop=_until(deadline, BOUND_SHARE)
            )
            or start
        )
    if relaxed.plan is not None:
        return _proved_start(
            relaxed.plan,
            began,
            time_limit,
            "every kept task at its earliest start, and no other choice "
            "of tasks to keep costs less: no solve",
        )
    before = len(start.unscheduled)
    start = _inserting(problem, start, domains, deadline)
    bound = None if relaxed.bound is None else float(relaxed.bound)
    said = ""
    if len(start.unscheduled) < before:
        said = (
            f"{before - len(start.unscheduled)} left-out tasks inserted "
            "into the start plan; "
        )
    if relaxable(
        run, problem, domains, deadline - time.perf_counter(), relax_min_s
    ):
        caught = _relaxation(
            problem,
            start,
            domains,
            relaxed,
            run,
            relax_share * (deadline - time.perf_counter()),
            more=True,
            end=deadline,
        )
        if caught.plan is not None and caught.plan.objective is not None:
            return _answer(
                caught.plan,
                float(caught.plan.objective.total),
                method_label(run, "relaxed"),
                caught.said,
                began,
                time_limit,
            )
        if caught.better is not None:
            start = _inserting(problem, caught.better, domains, deadline)
        # Not a bound for the caps (they add each task's delay to the
        # kept-set bound, and this one counts delays already): only for
        # the search's stop and the gap.
        bound = higher(bound, caught.bound)
        said += f"the disjunctive relaxation: {caught.said}; "
    polish = Polishing(problem, domains, deadline, bound)
    start = polish.shifted(polish(start), run, shift_deadline(deadline))
    # Tasks moved earlier may leave room for a left-out one.
    start = _inserting(problem, start, domains, deadline)
    narrowed = _narrowed(problem, start, domains, relaxed, _until(deadline))
    if narrowed is not None and start_count(narrowed) <= SMALL_COLUMNS:
        # Around a good start plan the whole model can be as small as a
        # 15-task part's, which CBC proves at once where the search has
        # no bound to stop at (b30-h1440 of the large suite, seed 31:
        # 2,637 columns, proved in 4 s; 11 s by the search first).
        left = deadline - time.perf_counter()
        start, bound, answered = whole_model(
            problem, start, bound, run, narrowed, SMALL_SHARE * left
        )
        said += f"the whole model, narrowed: {answered}; "
        if meets(start, bound):
            return _answer(
                start,
                bound,
                method_label(run, "lns"),
                said.rstrip("; "),
                began,
                time_limit,
            )
    now = time.perf_counter()
    lns_end = deadline
    if (1 - BUDGET.lns_share) * (deadline - now) >= FULL_MIN_S:
        lns_end = now + BUDGET.lns_share * (deadline - now)
    around: list[tuple[Plan, KeptSetProof, dict[str, Domain]]] = []

    def small(plan: Plan) -> bool:
        # The whole model narrowed around a better incumbent can be
        # small enough for CBC to prove (f45-h2880 of the large suite,
        # seed 31: the search held the optimum and swept on until the
        # limit; 12,126 columns around it, proved by CBC in 5 s).
        again = kept_set_bound(
            problem, plan, domains, stop=_until(deadline, BOUND_SHARE)
        )
        narrowed = _narrowed(problem, plan, domains, again, _until(deadline))
        if narrowed is None:
            return False
        around[:] = [(plan, again, narrowed)]
        return start_count(narrowed) <= HAND_OVER_COLUMNS

    best, improved = improve(
        problem,
        start,
        domains,
        run,
        lns_end,
        bound,
        # With less than this left the whole model is not run: the
        # search keeps the time rather than end with the gap open.
        hand_over_s=FULL_MIN_S if lns_end == deadline else 0.0,
        # Without a bound at the start (the kept-set search ran out of
        # nodes) it would run out again at each stalled sweep, for
        # nothing: b45-h1440 of the large suite, seed 47, left out more
        # (10.4 M against 9.0 M without those searches).
        hand_over=None if bound is None else small,
    )
    said += f"neighbourhood search: {improved} improvements of the start plan"
    if not meets(best, bound):
        # The search's moves may have opened room for a left-out task.
        best = _inserting(problem, best, domains, deadline)
    left = deadline - time.perf_counter()
    if meets(best, bound):
        said += "; it meets the kept-set bound"
    elif left >= FULL_MIN_S:
        if around and around[0][0] is best:
            _, again, narrowed = around[0]
        else:
            # The search costs up to a second here: only when it can say
            # more than it did of the start plan.
            again = (
                kept_set_bound(
                    problem, best, domains, stop=_until(deadline, BOUND_SHARE)
                )
                if improved
                else relaxed
            )
            narrowed = narrow(problem, best, domains, again, _until(deadline))
        bound = higher(bound, again.bound)
        if relaxable(run, problem, domains, left):
            # Around a better incumbent the relaxation's domains are
            # narrower and its big-M rows tighter.
            caught = relaxed_around(
                problem, best, narrowed, run, END_SHARE * left
            )
            said += "; then the disjunctive relaxation: " + caught.said
            if caught.plan is not None and caught.plan.objective is not None:
                return _answer(
                    caught.plan,
                    float(caught.plan.objective.total),
                    method_label(run, "relaxed"),
                    said,
                    began,
                    time_limit,
                )
            if caught.better is not None:
                best = caught.better
                narrowed = narrow(
                    problem, best, domains, again, _until(deadline)
                )
            bound = higher(bound, caught.bound)
            left = deadline - time.perf_counter()
        best, bound, answered = whole_model(
            problem,
            best,
            bound,
            run,
            narrowed,
            # A large model's CBC, killed at its deadline, and its
            # answer read back, ran up to 1.6 s past a 20 s limit.
            left - min(FULL_MARGIN_S, 0.1 * left),
        )
        said += "; then the whole model, narrowed: " + answered
        best = polish(best)
    if (
        not meets(best, bound)
        and deadline - time.perf_counter() >= MIN_ROUND_S
        and (lns_end == deadline or left >= FULL_MIN_S)
    ):
        # The search goes on rather than leave the time unused with the
        # gap open: the insertion took the whole model's time (a 30-task
        # part at 8 s answered after 5.8 s), or that model was too large
        # for it (seed 68's f45-h2880: 42,010 columns, stopped at once to
        # leave its kill's grace, the answer at 16.3 s of 20).
        best, more = improve(
            problem, best, domains, run, deadline, bound, hand_over_s=math.inf
        )
        said += f"; then {more} more"
    said += polish.said()
    return _answer(
        best, bound, method_label(run, "lns"), said, began, time_limit
    )


#: Share of the time left that inserting left-out tasks may take (its
#: own bound is in moves tried; this only guards the deadline).
INSERT_SHARE = 0.2


def _inserting(
    problem: Problem, plan: Plan, domains: dict[str, Domain], deadline: float
) -> Plan:
    """``plan`` with left-out tasks inserted where that is better
    (:func:`~fsw_scheduler.analysis.insert.inserted`).

    Moving what blocks a left-out task often makes room for it (the
    large suite's b60-h1440 of seed 47: 20 left out instead of 27,
    CP-SAT 17, in under a second; the search found one gain in 20 s).
    """
    now = time.perf_counter()
    stop = stop_at(now + INSERT_SHARE * max(0.0, deadline - now))
    return inserted(problem, plan, domains, stop=stop)


#: Share of the time left after the search that the relaxation gets
#: before the whole model (:func:`improved`).
END_SHARE = 0.5


def _relaxation(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    relaxed: KeptSetProof,
    run: Callable[..., Plan],
    limit: float,
    *,
    more: bool = False,
    end: float | None = None,
) -> RelaxedAnswer:
    """:func:`~fsw_scheduler.solving.relaxed.around` ``start``, over the
    domains every plan at least as good keeps; with ``more``, in
    :func:`~fsw_scheduler.solving.rounds.rounds` of growing node limits
    for all of ``limit`` (and an overtime up to the part's ``end``, see
    :data:`~fsw_scheduler.solving.rounds.OVERTIME`)."""
    stop = stop_at(time.perf_counter() + NARROW_SHARE * limit)

    def renarrow(plan: Plan) -> dict[str, Domain]:
        narrowed = _narrowed(problem, plan, domains, relaxed, stop)
        return narrow(problem, plan, domains) if narrowed is None else narrowed

    if more:
        deadline = time.perf_counter() + limit
        return rounds(
            problem,
            start,
            renarrow(start),
            run,
            limit,
            renarrow,
            lambda plan: _inserting(problem, plan, domains, deadline),
            lambda narrowed: start_count(narrowed) <= SMALL_COLUMNS,
            0.0 if end is None else OVERTIME * max(0.0, end - deadline),
        )
    return relaxed_around(problem, start, renarrow(start), run, limit)


def _narrowed(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    relaxed: KeptSetProof,
    stop: Callable[[], bool] | None = None,
) -> dict[str, Domain] | None:
    """:func:`~fsw_scheduler.solving.incumbent.narrow` around ``plan``,
    or None when ``plan`` leaves out more than the bound allows
    (:func:`~fsw_scheduler.solving.incumbent.worth_a_probe`): its caps
    then cut nothing (the slack is worth a whole horizon of delay), and
    its fixings, a search per left-out task, took the whole second of a
    60-task part's 1.5 s limit."""
    if relaxed.bound is None or worth_a_probe(problem, plan, relaxed):
        return None
    return narrow(problem, plan, domains, relaxed, stop)


#: Share of the time left that narrowing a model around a plan may take
#: (its per-task searches, :func:`~fsw_scheduler.analysis.bounds.fixings`):
#: a replan's fresh start on a 45-task part spent 3 s of its 2 s there.
NARROW_SHARE = 0.25


def _until(deadline: float, share: float = NARROW_SHARE) -> Callable[[], bool]:
    """A stop at ``share`` (:data:`NARROW_SHARE` by default) of the time
    left before ``deadline``."""
    now = time.perf_counter()
    return stop_at(now + share * (deadline - now))


def _answer(
    plan: Plan,
    bound: float | None,
    solver: str,
    said: str,
    began: float,
    time_limit: float,
) -> Plan:
    """``plan`` as a large part's answer: ``optimal`` when it meets
    ``bound`` (which is then its own objective), else ``feasible``."""
    status = SolveStatus.FEASIBLE
    if meets(plan, bound) and plan.objective is not None:
        status, bound = SolveStatus.OPTIMAL, float(plan.objective.total)
    return plan.replace(
        status=status,
        why=(),
        stats=SolverStats(
            solver=solver,
            wall_s=time.perf_counter() - began,
            bound=bound,
            solver_status=said,
            time_limit_s=time_limit,
        ),
    )


def _proved_start(
    plan: Plan, began: float, time_limit: float | None, proof: str
) -> Plan:
    """``plan`` proved optimal without a solver, with its statistics."""
    return plan.replace(
        status=SolveStatus.OPTIMAL,
        stats=SolverStats(
            solver="greedy",
            wall_s=time.perf_counter() - began,
            bound=plan.objective.total if plan.objective else None,
            solver_status=proof,
            time_limit_s=time_limit,
        ),
    )
