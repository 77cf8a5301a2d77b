"""The solve entry point: one call from problem to explained plan."""

from __future__ import annotations

import functools
import logging
import time
from typing import TYPE_CHECKING

import msgspec

from ..analysis.bounds import (
    KeptSetProof,
    at_lower_bound,
    proved_by,
)
from ..analysis.check import check_plan
from ..analysis.domains import start_count, start_domains
from ..analysis.explain import explain as explain_plan
from ..analysis.greedy import greedy_plan
from ..analysis.linked import linked
from ..analysis.options import impossible_group
from ..analysis.proofs import infeasibility
from ..analysis.sampling import sampled_better
from ..errors import SolverError
from ..model import groups
from ..model.plan import (
    Plan,
    SolverStats,
    SolveStatus,
)
from ..model.stability import Stability, rescored
from . import large, replanning
from .budget import BUDGET, stop_at, stop_within
from .forced import SOLVED_CORE, WHOLE_CORE, forced_start
from .incumbent import checked, finished, kept_set_start, narrow, probed
from .joined import after, joined, starved
from .polishing import Polishing, shift_deadline
from .repair import holding
from .rounds import LONG_COLUMNS
from .single import one_task
from .stats import with_call_stats, with_gap

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.problem import Problem


log = logging.getLogger("fsw_scheduler.solver")


def solve(
    problem: Problem,
    solver: str = "cbc",
    *,
    time_limit: float | None = None,
    threads: int = 1,
    seed: int = 0,
    explain: bool = False,
    warm: Plan | None = None,
    explain_budget: float | None = None,
    stability: Stability | None = None,
) -> Plan:
    """Solve ``problem`` and return its plan with an honest status.

    Parameters
    ----------
    problem
        A validated problem (see
        :func:`fsw_scheduler.model.problem.decode_problem`).
    solver
        ``cbc`` (default, through PuLP) or ``highs``.
    time_limit
        Seconds for the solve, start plan and model building included. At
        the limit the best plan found is returned with status ``feasible``,
        or ``unknown`` when none was found.
    threads
        Solver threads; keep 1 for reproducible plans.
    seed
        Solver random seed.
    explain
        Also say why each left-out task is out (and, when infeasible, which
        mandatory tasks cannot be placed); costs extra solves.
    warm
        The plan in force, mapped onto ``problem`` (a replan): a candidate
        MIP start (see :func:`best_start`). Under a time limit a replan
        with a part of :attr:`~fsw_scheduler.solving.budget.SolveBudget.
        lns_min_tasks` tasks or more takes :meth:`~fsw_scheduler.solving.
        budget.SolveBudget.replan_limit` of it, and such a part is
        repaired from this plan and searched around what changed instead
        of solved afresh; smaller parts have the whole limit, from this
        plan as their MIP start.
    explain_budget
        Seconds all explanation solves may take together (default: the
        time limit, else
        :attr:`~fsw_scheduler.solving.budget.SolveBudget.explain_budget_s`).
    stability
        The previous starts and the price of moving them
        (:mod:`fsw_scheduler.model.stability`; default none, the paper's
        objective). With a move part, the start plans are scored with
        it (the previous plan, ``warm``, first) and the shortcuts that
        bound only the unscheduled and delay parts (the at-lower-bound
        and kept-set proofs, cost caps and probes, the neighbourhood
        search and the replan's repair) are off: the solver proves the
        whole objective.

    Returns
    -------
    Plan
        Every task appears once, in ``activities`` or ``unscheduled``.
    """
    began = time.perf_counter()
    # The backend is imported here so that importing fsw_scheduler does not
    # import PuLP (the pure core must stay free of it).
    from .ilp import SOLVERS, backend_ready, solve_ilp

    if solver not in SOLVERS:
        # Said before any work: a problem the proofs or the start plan
        # answer would otherwise take any name without a word.
        raise SolverError(
            f"unknown solver {solver!r} (choose from {', '.join(SOLVERS)})"
        )
    # On the clock, before the limit is shared out (once per process).
    backend_ready(solver)
    run = functools.partial(
        solve_ilp,
        solver=solver,
        time_limit=time_limit,
        threads=threads,
        seed=seed,
    )
    if stability is not None and stability.active:
        run = functools.partial(run, stability=stability)
    else:
        stability = None
    limit = time_limit
    parts = components(problem)
    if (
        warm is not None
        and time_limit is not None
        and max(map(len, parts), default=0) >= BUDGET.lns_min_tasks
    ):
        # A replan of a large part pays for what changed (repair.py), not
        # a fresh solve. Parts CBC proves get the whole limit: in a share,
        # those it left unproved were solved again from its plan in the
        # rest, and took longer than one solve (replan suite, seed 73's
        # r30-h1440-0 and -1: 3.8 and 4.3 s against 1.8 and 2.8 s, the
        # same optima; seed 70's r30-h1440-0 4.9 s against 3.0 s).
        limit = BUDGET.replan_limit(time_limit)
    domains = start_domains(problem)
    proving = stop_within(began, limit, BUDGET.proof_share)
    proof = infeasibility(problem, domains, stop=proving) or impossible_group(
        problem, stop=proving
    )
    if proof:
        # Tasks every plan must hold cannot all be placed: no solve.
        return Plan(
            status=SolveStatus.INFEASIBLE,
            objective=None,
            unscheduled=tuple(task.id for task in problem.tasks),
            why=proof,
            stats=SolverStats(
                solver="proof",
                wall_s=time.perf_counter() - began,
                solver_status=f"infeasible without a solve: {proof[0].detail}",
                time_limit_s=time_limit,
            ),
        )
    plan = _solved(
        problem,
        parts,
        run,
        began,
        limit,
        warm,
        domains,
        stability,
        time_limit,
        replan=warm is not None and time_limit is not None,
    )
    plan = with_gap(plan)
    if explain and (
        plan.unscheduled or not plan.status.has_plan or plan.picks
    ):
        budget = explain_budget
        if budget is None:
            # Explanations share the caller's limit: whatever the solve
            # left of it (tasks get not_analysed when nothing is left).
            budget = (
                BUDGET.explain_budget_s
                if time_limit is None
                else time_limit - (time.perf_counter() - began)
            )
        # Why a task is out does not depend on moves: the paper's terms.
        plain = functools.partial(run, stability=None)
        plan = plan.replace(
            why=explain_plan(problem, plan, BUDGET.budgeted(plain, budget))
        )
    return plan


def _solved(
    problem: Problem,
    parts: list[list[str]],
    run: functools.partial[Plan],
    began: float,
    time_limit: float | None,
    warm: Plan | None,
    domains: dict[str, Domain],
    stability: Stability | None,
    full_limit: float | None,
    *,
    replan: bool = False,
) -> Plan:
    """``problem`` solved part by part (:func:`_solve_parts`) when it has
    independent ``parts``, else whole (:func:`_solve_whole`); ``replan``
    when ``warm`` is the plan in force under a time limit."""
    if len(parts) > 1:
        return _solve_parts(
            problem,
            parts,
            run,
            began,
            time_limit,
            warm,
            domains,
            stability,
            full_limit,
            replan=replan,
        )
    return _solve_whole(
        problem,
        run,
        began,
        time_limit,
        warm,
        domains,
        stability,
        full_limit,
        replan=replan,
    )


def components(problem: Problem) -> list[list[str]]:
    """Independent parts: tasks linked by a precedence or a shared resource.

    No constraint crosses two parts, and the lexicographic objective is a
    sum over tasks, so the best plan of the whole is the union of the best
    plans of the parts (least left out in each, then least delay in each).
    Parts are listed by their first task, tasks in problem order.
    """
    pairs = [(prec.before, prec.after) for prec in problem.precedences]
    present = {task.id for task in problem.tasks}
    for group in problem.alternatives:
        # The options of a group exclude each other: one part.
        names = [n for o in group.options for n in o if n in present]
        pairs += [(names[0], name) for name in names[1:]]
    first_user: dict[str, str] = {}
    for task in problem.tasks:
        for name, amount in task.uses.items():
            if amount:
                pairs.append((task.id, first_user.setdefault(name, task.id)))
    return linked((task.id for task in problem.tasks), pairs)


def _solve_parts(
    problem: Problem,
    parts: list[list[str]],
    run: functools.partial[Plan],
    began: float,
    time_limit: float | None,
    warm: Plan | None,
    domains: dict[str, Domain],
    stability: Stability | None = None,
    full_limit: float | None = None,
    *,
    replan: bool = False,
) -> Plan:
    """Solve each independent part alone and join the plans.

    Smaller models are solved much faster than their union (the search
    of one part no longer branches over the others'), and parts without
    a resource or a precedence need no solver at all. Each part gets a
    share of what is left of the limit, by its number of start times,
    the smallest first. A replan's part whose gap asks for a second look
    (:func:`~.replanning.replanned`) gets the same share of what is left of
    ``full_limit``.
    """
    # A part of one task needs no solver (its earliest start, or a check
    # of each start with a move part): its share goes to the others.
    weights = [
        1
        if len(part) == 1
        else 1 + start_count({name: domains[name] for name in part})
        for part in parts
    ]
    # Smallest parts first: they are done at once, and what they leave of
    # the limit goes to the large one instead of waiting unused.
    order = sorted(range(len(parts)), key=lambda k: (weights[k], k))
    weights = [weights[k] for k in order]
    subs = [_part(problem, parts[k], warm) for k in order]
    plans = []
    for idx, (sub, sub_warm) in enumerate(subs):
        limit = part_full = None
        now = time.perf_counter()
        if time_limit is not None:
            left = time_limit - (now - began)
            limit = BUDGET.part_share(left, weights[idx:])
        if full_limit is not None:
            left = full_limit - (now - began)
            part_full = BUDGET.part_share(left, weights[idx:])
        plans.append(
            _solve_whole(
                sub,
                run,
                now,
                limit,
                sub_warm,
                {t.id: domains[t.id] for t in sub.tasks},
                stability,
                part_full,
                replan=replan,
            )
        )
        if plans[-1].status is SolveStatus.INFEASIBLE:
            # The whole is infeasible whatever the others hold: solving
            # them would only spend the limit (a 2-task part proved so in
            # 0.2 s, then 9 s on a 33-task part for nothing).
            break
    skipped = len(subs) - len(plans)
    if time_limit is not None and not skipped:
        _reopen(
            plans,
            subs,
            weights,
            run,
            began,
            time_limit,
            domains,
            stability,
            replan=replan,
        )
    return joined(
        problem,
        plans,
        [sub for sub, _ in subs[: len(plans)]],
        began,
        time_limit,
        stability,
        skipped,
    )


def _part(
    problem: Problem, part: list[str], warm: Plan | None
) -> tuple[Problem, Plan | None]:
    """The sub-problem of ``part``, and the part of ``warm`` that is its."""
    members = set(part)
    sub = problem.replace(
        tasks=tuple(t for t in problem.tasks if t.id in members),
        precedences=tuple(
            p for p in problem.precedences if p.before in members
        ),
        alternatives=groups.kept_alternatives(problem, members),
    )
    if warm is None:
        return sub, None
    return sub, warm.replace(
        objective=None,
        activities=tuple(a for a in warm.activities if a.task in members),
        unscheduled=tuple(n for n in warm.unscheduled if n in members),
        why=(),
    )


def _reopen(
    plans: list[Plan],
    subs: list[tuple[Problem, Plan | None]],
    weights: list[int],
    run: functools.partial[Plan],
    began: float,
    time_limit: float,
    domains: dict[str, Domain],
    stability: Stability | None = None,
    *,
    replan: bool = False,
) -> None:
    """Solve the unproved parts again with what the others left unused.

    Parts proved at once (most are) leave most of their shares; a part
    that stopped at its own share, before the large parts were done,
    gets that time now, warm-started from its plan. A part that handed
    most of its share back unproved (too short for CBC to start: many
    parts under a short limit) gets at least :attr:`~.budget.SolveBudget.
    min_start_s` when that much is left, and what is left when that is
    less but at least twice its first share. ``plans`` is updated in place:
    a part's new plan replaces its plan when it is proved or better.
    """
    still = [
        idx
        for idx, plan in enumerate(plans)
        if plan.status in (SolveStatus.FEASIBLE, SolveStatus.UNKNOWN)
    ]
    for pos, idx in enumerate(still):
        now = time.perf_counter()
        left = time_limit - (now - began)
        limit = BUDGET.part_share(left, [weights[k] for k in still[pos:]])
        before = plans[idx]
        least = BUDGET.min_part_s
        if starved(before, BUDGET.min_start_s):
            limit = max(limit, min(left, BUDGET.min_start_s))
            # Any more than its first share may let CBC start: a 1-task
            # part with a group had 0.06 s of a 0.3 s limit, CBC did not
            # start, and 0.16 s were left unused (``tools/fuzz`` seed
            # 62092: `feasible` where the plan was optimal).
            had = before.stats.time_limit_s if before.stats else None
            least = min(BUDGET.min_start_s, 2 * (had or 0.0))
        if limit < least or limit <= 0:
            continue  # no more than the first pass had: nothing to gain
        sub, _ = subs[idx]
        again = _solve_whole(
            sub,
            run,
            now,
            limit,
            before if before.status.has_plan else None,
            {t.id: domains[t.id] for t in sub.tasks},
            stability,
            replan=replan,
        )
        gained = again.status is SolveStatus.OPTIMAL or (
            again.objective is not None
            and (
                before.objective is None
                or again.objective.total < before.objective.total
            )
        )
        if gained or not before.status.has_plan:
            plans[idx] = after(before, again)


#: Parts at least this large say when their start plan begins and ends
#: (150 tasks took 15 s there, without a word).
LOUD_TASKS = 50
#: Seconds between two progress lines of a long start plan.
PROGRESS_S = 5.0

#: Share of the time left that a large part's start plan may spend on
#: perturbed list-scheduling orders after the rules
#: (:func:`~fsw_scheduler.analysis.sampling.sampled_better`; its 50
#: orders take 0.1-1 s on 30-60 tasks).
SAMPLED_START_SHARE = 0.05


def _solve_whole(
    problem: Problem,
    run: functools.partial[Plan],
    began: float,
    time_limit: float | None,
    warm: Plan | None,
    domains: dict[str, Domain],
    stability: Stability | None = None,
    full_limit: float | None = None,
    *,
    replan: bool = False,
) -> Plan:
    """Start plan, then the solver or the neighbourhood search; no ``why``.

    ``full_limit`` is the caller's limit where ``time_limit`` is a
    replan's share of it (see :func:`~.replanning.replanned`). In a
    ``replan`` a part under :attr:`~.budget.SolveBudget.lns_min_tasks`
    tasks whose model, narrowed around its start plan, is long (at least
    :data:`~.rounds.LONG_COLUMNS` start times) has the replan's share of
    its limit (:meth:`~.budget.SolveBudget.replan_limit`): CBC does not
    get through such a model's root in the limit, and the relaxation's
    rounds and the neighbourhood search that take its place would spend
    all of it.

    With a move part (``stability``) the shortcuts are off, each for the
    same reason: the replan's repair, the at-lower-bound and kept-set
    proofs, the cost caps of :func:`narrow` and the probe bound the
    unscheduled and delay parts only, and a plan they call optimal may
    move what a stable one keeps; the neighbourhood search compares parts
    of a plan whose move weights are the whole's. The solver, with the
    start plan as its MIP start, proves the whole objective instead.
    """
    if (
        stability is None
        and warm is not None
        and time_limit is not None
        and large.searched(problem)
    ):
        replanned = replanning.replanned(
            problem, warm, domains, run, began, time_limit, full_limit
        )
        if replanned is not None:
            return replanned
    stop = None
    if time_limit is not None:
        # The heuristic gets a share of the limit; its trivial plan (the
        # forced tasks alone) is always completed.
        stop = stop_at(began + BUDGET.greedy_share * time_limit)

    # A large part spends seconds here before CBC says anything: say so.
    loud = problem.num_tasks >= LOUD_TASKS
    if loud:
        log.info(
            "start plan: list scheduling %d tasks over [%d, %d)...",
            problem.num_tasks,
            problem.start,
            problem.end,
        )
        stop = _saying_progress(stop, began)
    start = best_start(
        problem, warm, stop=stop, domains=domains, stability=stability
    )
    if start is not None and stability is None and large.searched(problem):
        # The search keeps the arrangement its start plan has; on a day a
        # battery binds, another order of the list scheduler may be far
        # better (:func:`~fsw_scheduler.analysis.sampling.sampled_better`).
        start = sampled_better(
            problem,
            start,
            domains,
            stop=stop_within(began, time_limit, SAMPLED_START_SHARE),
        )
    around_forced = ""  # how the start plan was built, if around the core
    if start is None and stability is None:
        # No rule placed the forced tasks: the solver plans them alone.
        start = forced_start(
            problem, run, None if time_limit is None else began + time_limit
        )
        if start is not None and start.status is SolveStatus.INFEASIBLE:
            return with_call_stats(start, began, time_limit)  # no plan
        if start is not None:
            around_forced = (
                start.stats.solver_status if start.stats else SOLVED_CORE
            )
    if loud:
        log.info(
            "start plan: %s after %.1f s",
            "none"
            if start is None or start.objective is None
            else f"objective {start.objective.total:g}",
            time.perf_counter() - began,
        )
    proof = None
    relaxed: KeptSetProof | None = None
    if stability is not None and problem.num_tasks == 1:
        # One task alone (most parts of a problem without resources): a
        # share of the limit too small for CBC is common; trying every
        # start proves the best, moves included, without it.
        return one_task(problem, domains, stability, began, time_limit)
    if stability is not None:
        plan = _keep_better(
            checked(
                problem,
                run(
                    problem,
                    warm=start.starts() if start else None,
                    domains=domains,
                    time_limit=None
                    if time_limit is None
                    else time_limit - (time.perf_counter() - began),
                ),
                stability,
            ),
            start,
        )
        return with_call_stats(plan, began, time_limit)
    if start is not None:
        if start.status is SolveStatus.OPTIMAL:  # its solver said below
            proof = WHOLE_CORE
        elif at_lower_bound(problem, start, domains):
            proof = "every task at its earliest start: no solve"
        elif not large.searched(problem):
            start, relaxed = kept_set_start(
                problem, start, domains, began, time_limit, replan=replan
            )
            if relaxed.plan is not None:
                proof = f"{proved_by(relaxed)}: no solve"
    if start is not None and proof is not None:
        plan = start.replace(
            status=SolveStatus.OPTIMAL,
            stats=SolverStats(
                solver=start.stats.solver if start.stats else "greedy",
                wall_s=time.perf_counter() - began,
                bound=start.objective.total if start.objective else None,
                solver_status=proof,
                time_limit_s=time_limit,
            ),
        )
    elif (
        start is not None
        and time_limit is not None
        and time.perf_counter() - began >= time_limit
    ):
        # The start plan took the whole limit (hundreds of tasks).
        plan = start.replace(
            stats=SolverStats(
                solver="greedy",
                wall_s=time.perf_counter() - began,
                solver_status="time limit spent on the start plan: no solve",
                time_limit_s=time_limit,
            )
        )
    elif (
        start is not None
        and time_limit is not None
        and large.searched(problem)
    ):
        plan = large.improved(problem, start, domains, run, began, time_limit)
    else:
        narrowed = narrow(problem, start, domains, relaxed)
        if (
            replan
            and time_limit is not None
            and start_count(narrowed) >= LONG_COLUMNS
        ):
            # A replan pays for what changed: the replan suite's
            # r30-h1440-1 of seed 217 (27 tasks, 12,423 columns) took
            # 9.5 s of 10 in rounds and a search that found nothing, the
            # same plan its share gives in 1.7 s.
            time_limit = min(time_limit, BUDGET.replan_limit(time_limit))
        answer, start, narrowed, caught = probed(
            problem, run, start, domains, narrowed, relaxed, began, time_limit
        )
        if answer is None:
            answer = finished(
                problem,
                run,
                start,
                domains,
                narrowed,
                began,
                time_limit,
                caught,
            )
        plan = _keep_better(answer, start)
        if stability is None and time_limit is not None:
            plan = _polishing(problem, plan, domains, began + time_limit, run)
        if start is None and not plan.status.has_plan and plan.stats:
            # Rare: say why there is not even the start plan to fly.
            plan = plan.replace(
                stats=msgspec.structs.replace(
                    plan.stats,
                    solver_status=f"{plan.stats.solver_status}; no start "
                    "plan: list scheduling could not place the tasks every "
                    "plan must hold",
                )
            )
        plan = with_call_stats(
            plan,
            began,
            time_limit,
            None if relaxed is None else relaxed.lowest,
            caught,
        )
    if around_forced and plan.stats is not None:
        plan = plan.replace(
            stats=msgspec.structs.replace(
                plan.stats,
                solver_status="start plan: list scheduling could not place "
                f"the tasks every plan must hold; {around_forced}; "
                f"{plan.stats.solver_status}",
            )
        )
    return plan


def _saying_progress(
    stop: Callable[[], bool] | None, began: float
) -> Callable[[], bool]:
    """``stop`` (the heuristic asks it often) that also logs a line every
    :data:`PROGRESS_S` seconds, so a long start plan is never silent."""
    said = [began]

    def asked() -> bool:
        now = time.perf_counter()
        if now - said[0] >= PROGRESS_S:
            said[0] = now
            log.info("start plan: still list scheduling (%.0f s)", now - began)
        return stop is not None and stop()

    return asked


def best_start(
    problem: Problem,
    warm: Plan | None,
    *,
    stop: Callable[[], bool] | None = None,
    domains: dict[str, Domain] | None = None,
    stability: Stability | None = None,
) -> Plan | None:
    """The better valid plan of ``warm`` and the greedy heuristic's.

    The greedy plan is valid by construction (:func:`greedy_plan` returns
    only plans the checker accepts); ``warm`` is used only if the checker
    accepts it on ``problem``, with its objective recomputed there, else
    what of it holds (:func:`~fsw_scheduler.solving.repair.holding`, not
    with a move part). None when neither is valid. ``stop`` and
    ``domains`` are passed on to :func:`greedy_plan`. With ``stability``
    both are scored with the move part: the previous plan (``warm``,
    which keeps the old positions) comes first and wins ties.
    """
    candidates = []
    if warm is not None:
        if stability is not None:
            # Its objective, if any, has no move part: recomputed.
            warm = warm.replace(objective=None)
        report = check_plan(problem, warm, stability)
        if report.ok:
            candidates.append(
                warm.replace(
                    status=SolveStatus.FEASIBLE, objective=report.objective
                )
            )
        elif stability is None and domains is not None:
            # A plan in force the new problem breaks: what of it holds.
            candidates += [p for p in [holding(problem, warm, domains)] if p]
    greedy = greedy_plan(problem, stop=stop, domains=domains)
    if greedy is not None:
        # On a tie, the previous plan is kept.
        candidates.append(rescored(problem, greedy, stability or Stability()))
    if not candidates:
        return None
    return min(
        candidates,
        key=lambda p: p.objective.total if p.objective else float("inf"),
    )


def _polishing(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    end: float,
    run: Callable[..., Plan],
) -> Plan:
    """An unproved answer polished (:class:`~.polishing.Polishing`, and
    its shift windows with ``run``) in what the solver left of the limit,
    its status line saying what that saved.

    CBC stopped at its deadline hands back its incumbent or the start
    plan, often with single moves left (replan suite, seeds 36-37: parts
    of 24-29 tasks, 46-162 delay units in 0.01 s, one of them to a plan
    better than the fresh solve's with the whole limit).
    """
    if plan.status is not SolveStatus.FEASIBLE or plan.stats is None:
        return plan
    last = end - BUDGET.lns_margin_s
    polish = Polishing(problem, domains, last, None)
    better = polish.shifted(polish(plan), run, shift_deadline(last))
    if better is plan:
        return plan
    return better.replace(
        stats=msgspec.structs.replace(
            plan.stats,
            solver_status=plan.stats.solver_status + polish.said(),
        )
    )


def _keep_better(plan: Plan, start: Plan | None) -> Plan:
    """The solver's plan, unless the start plan is better or contradicts it.

    At a time limit CBC may return no plan, or a worse one than its own MIP
    start; the start is a valid plan, so it is kept, with status
    ``feasible``, the solver's statistics and a note saying so. The same
    holds when CBC's claim cannot be true: "infeasible" although the start
    plan is valid, or "optimal" for a plan worse than the start (both seen
    when numerical trouble in root cuts cut off every solution).
    """
    if start is None or start.objective is None:
        return plan
    if plan.objective is not None and (
        plan.objective.total <= start.objective.total
    ):
        return plan
    if plan.status is SolveStatus.INFEASIBLE:
        note = "solver said infeasible, but the start plan is valid"
    elif plan.status is SolveStatus.OPTIMAL:
        note = "solver's optimum is worse than the start plan"
    else:
        note = "start plan kept"
    if plan.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE):
        log.warning("%s; keeping the start plan as feasible", note)
    stats = plan.stats
    if stats is not None:
        stats = msgspec.structs.replace(
            stats, solver_status=f"{stats.solver_status}; {note}"
        )
    return start.replace(status=SolveStatus.FEASIBLE, stats=stats, why=())
