"""Working from an incumbent: the plans the solver may return, the
model narrowed around a known plan, and probes for a better one.

A known valid plan (the start plan, a probe's answer) bounds what the
solver needs to look at: every plan at least as good keeps within the
caps and fixings of :mod:`fsw_scheduler.analysis.bounds`, so the model
shrinks and keeps its optimum (:func:`narrow`). When the start plan is
far from the kept-set bound, left-out tasks are readmitted first where
that gives a better plan (:mod:`fsw_scheduler.analysis.readmit`), then
CBC run with a node limit finds a better one to narrow around
(:func:`probed`); the large parts and replans run the whole model
narrowed around their plan when it is small (:func:`whole_model`).
Whatever the solver returns goes through the independent checker first
(:func:`checked`).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import msgspec

from ..analysis.bounds import KeptSetProof, fixings, kept_set_plan
from ..analysis.check import check_plan
from ..analysis.domains import cost_caps, start_count, start_domains
from ..analysis.readmit import readmitted
from ..analysis.sampling import sampled_around
from ..model.plan import Plan, SolverStats, SolveStatus, objective_weight
from .budget import BUDGET, stop_at, stop_within
from .ilp.disjunctive.rule import used_kinds
from .improve import MIN_ROUND_S, improve
from .relaxed import MIN_LEFT_S, SMALL_LEVEL_ROUNDS, around, relaxable
from .rounds import (
    LONG_COLUMNS,
    LONG_SHARE,
    PROBING_TASKS,
    SHARE,
    rounds,
)
from .stats import higher, method_label, stopped_on_nodes

if TYPE_CHECKING:
    import functools
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.problem import Problem
    from ..model.stability import Stability


def checked(
    problem: Problem, plan: Plan, stability: Stability | None = None
) -> Plan:
    """The solver's plan if the independent checker accepts it.

    CBC stopped by its time limit before any integer solution can hand back
    the values of its last relaxation; read as a plan they break
    constraints. Such a plan is refused (status ``unknown``), never flown.
    """
    if not plan.status.has_plan:
        return plan
    report = check_plan(problem, plan, stability)
    if report.ok:
        return plan
    rules = ", ".join(sorted(report.rules))
    stats = plan.stats
    if stats is not None:
        stats = msgspec.structs.replace(
            stats,
            solver_status=f"{stats.solver_status}; refused: breaks {rules}",
        )
    return Plan(
        status=SolveStatus.UNKNOWN,
        objective=None,
        unscheduled=tuple(t.id for t in problem.tasks),
        stats=stats,
    )


#: The probe (:func:`probed`) may explore this many search nodes per
#: column of its model, between :data:`PROBE_NODES` bounds, and take at
#: most :data:`PROBE_SHARE` of what is left of the limit.
PROBE_WORK = 500_000
PROBE_NODES = (20, 500)
PROBE_SHARE = 0.3


#: From this many columns on, a part with a good start plan still gets a
#: root probe: CBC's root with its heuristics on (a diving heuristic found
#: the optimum of fresh f20-h1440-1 at the root, where the search with
#: heuristics off had not in 20 s).
ROOT_PROBE_COLUMNS = 5_000

#: From this many columns on, a part with a consumable and a binary or
#: multiple resource is first given to the disjunctive relaxation
#: (:mod:`fsw_scheduler.solving.relaxed`), which proves it when its
#: optimum is valid and otherwise may give a better start plan: the
#: root probe's threshold (on the large suite's f30-h1440 of seed 53 a
#: part of 28 tasks, 5,079 columns, took 5.6 s in the root probe and
#: 10 s more in CBC).
RELAXED_COLUMNS = ROOT_PROBE_COLUMNS

#: Under :data:`~fsw_scheduler.solving.relaxed.MIN_LEFT_S` left (a
#: replan's 2 s), such a part still gets the relaxation from this much
#: left on (for :data:`SHORT_ROUNDS_SHARE` of it): CBC does not get
#: through the root of a model this large in that time (the replan
#: suite's seed 22 r30-h1440-0, 16,251 columns: "time limit spent
#: before CBC started"), while the relaxation finds better plans or
#: proves the part. A small part's rounds under a short limit take at
#: most :data:`SHORT_SHARE` of what is left (see :data:`SMALL_FLOOR_S`).
SHORT_MIN_S = 0.8
SHORT_SHARE = 0.6

#: Under :data:`~fsw_scheduler.solving.relaxed.MIN_LEFT_S` left, such a
#: part's relaxation runs in rounds (:func:`~fsw_scheduler.solving.
#: rounds.rounds`) for this share of what is left: the time-indexed
#: model of 5,000 columns or more seldom gets through its root in the
#: rest, while the second round (2,000 nodes, probing on) proves many
#: (the replan suite's seed 47 r30-h1440-0, 29 tasks, 10,965 columns:
#: the fresh solve proved it in its second round at 1.7 s; the replan's
#: one round of 0.6 of its 2 s stopped on its nodes and CBC's model was
#: interrupted at the deadline with nothing).
SHORT_ROUNDS_SHARE = 0.9

#: A smaller part with a consumable beside a binary or multiple resource
#: (the campaign's ``all`` class) gets the relaxation's rounds too
#: (:func:`~fsw_scheduler.solving.rounds.rounds`, from
#: :data:`~fsw_scheduler.solving.relaxed.NODES` nodes), in at most
#: :data:`SMALL_SHARE` of what is left, from :data:`SMALL_MIN_S` left on.
#: Its optimum is most often a valid plan (the battery is rarely what
#: decides): on the 35 problems of ``--only 15-all`` of seed 81 (broad)
#: and seeds 82-83 of both generators it proved 30 in 0.02-0.44 s that
#: the time-indexed model proved in 0.02-7.1 s (median 0.14 -> 0.04 s);
#: where it was not valid, the run cost 0.03-0.2 s before the model.
#: From 0.2 s left on, not 0.6 s: under 0.6 s the rounds leave the
#: time-indexed model too little to end its root, while the relaxation's
#: optimum takes milliseconds (``tools/fuzz`` seed 64078, 6 tasks at
#: 0.3 s: `feasible` after CBC's cuts cut off valid plans -> `optimal` in
#: 13 ms). On the 56 ``all`` problems of seeds 201-204 (both
#: generators) 33 -> 41 proved at 0.4 s, 34 -> 41 at 0.5 s, 17 -> 22 of
#: the 28 of seeds 203-204 at 0.3 s; no plan worse.
SMALL_MIN_S = 0.2
SMALL_SHARE = 0.3

#: Under a short limit the small part's rounds get at least this many
#: seconds, at most :data:`SHORT_SHARE` of what is left: CBC is not
#: started with less than ``MIN_CBC_S`` and its stop margin (0.1 s on a
#: 15-task model, 0.35 s on a large one) of its limit, and the
#: relaxation's optimum is the likelier proof there (the time-indexed
#: model of a 15-task part seldom ends its root in 0.5 s).
#: From 0.35 / :data:`SHORT_SHARE` (0.58 s) left on, CBC has its minimum
#: after the rounds; under that the rounds' answer is the answer.
SMALL_FLOOR_S = 0.5


def worth_a_probe(
    problem: Problem, start: Plan | None, relaxed: KeptSetProof | None
) -> bool:
    """True if the kept-set bound leaves out less cost than ``start``.

    The caps then say nothing (the gap is a whole unscheduled cost, more
    than any delay), and neither do the fixings, until a better
    incumbent is known: :func:`probed` looks for one. Where the start
    plan already leaves out as little as the bound, a probe is mostly
    lost time (measured on the fresh shapes: 3 of 8 slow solves went
    unproved with one).
    """
    if (
        start is None
        or start.objective is None
        or relaxed is None
        or relaxed.bound is None
    ):
        return False
    return a_task_above(problem, start.objective.total, relaxed.bound)


def a_task_above(problem: Problem, total: float, bound: float) -> bool:
    """True if an objective of ``total`` is at least the weight of one
    schedule cost unit (the objective's ``W``) above ``bound``: a plan
    as good as the bound may leave out a whole task less."""
    weight = objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    return total - bound >= weight


def probed(
    problem: Problem,
    run: functools.partial[Plan],
    start: Plan | None,
    domains: dict[str, Domain],
    narrowed: dict[str, Domain],
    relaxed: KeptSetProof | None,
    began: float,
    time_limit: float | None,
) -> tuple[Plan | None, Plan | None, dict[str, Domain], float | None]:
    """A short search for a better incumbent, and the smaller model it
    allows, where one is worth it.

    The kept-set bound caps starts by how far the incumbent is above it
    (:func:`narrow`), and leaves out the tasks no plan as good keeps:
    a start plan far from the optimum caps little. CBC is run on the
    model with a node limit (the same answer on every machine, unlike a
    time limit); when it proves its answer, that is the answer. When it
    finds a better plan, the model is narrowed again around that plan
    for the full run (a paper-shaped consumable problem CBC had not
    proved in 20 s: proved in 3 s after it).

    First, when :func:`worth_a_probe`, left-out tasks are readmitted to
    the start plan where that is better (:func:`_readmitting`: a few
    list schedules, each with one left-out task first); the probe then
    starts from that plan, and runs only if it is still far from the
    bound.

    Where the part has a consumable beside a binary or multiple resource
    (:func:`~fsw_scheduler.solving.relaxed.relaxable`), the disjunctive
    relaxation runs next, in rounds (:data:`SMALL_SHARE` of what is left
    on a small model); its optimum, when valid, is the answer, and its
    best plan the new incumbent. After it a small model gets no probe.

    Which probe: a node-limited search when :func:`worth_a_probe`; else,
    on models of :data:`ROOT_PROBE_COLUMNS` or more, CBC's root alone
    with its heuristics on; else none (``start`` and ``narrowed`` are
    returned as they are).

    Returns
    -------
    tuple
        The proved answer (None when the full run must follow), the
        incumbent, the domains for the full run, and the disjunctive
        relaxation's bound when it ran (None otherwise): it bounds every
        plan at least as good as the incumbent, not the caps.
    """
    bound = None
    if start is None or relaxed is None:
        return None, start, narrowed, bound
    if worth_a_probe(problem, start, relaxed):
        start, relaxed, narrowed = _readmitting(
            problem, start, domains, relaxed, narrowed, began, time_limit
        )
    left = (
        None
        if time_limit is None
        else time_limit - (time.perf_counter() - began)
    )
    small = start_count(narrowed) < RELAXED_COLUMNS
    if relaxable(
        run, problem, domains, left, SMALL_MIN_S if small else SHORT_MIN_S
    ):
        # A time-indexed model with a consumable: its root LP can take
        # the whole limit on a large part, and seconds of cut passes on
        # a small one; the relaxation's optimum, valid more often than
        # not, takes milliseconds.
        # A small part's time-indexed model is proved in about a second:
        # few runs again with levels (relaxed.SMALL_LEVEL_ROUNDS).
        level_rounds = SMALL_LEVEL_ROUNDS if small else None
        # A part of 12-15 tasks has CBC's probing from its first round
        # (rounds.PROBING_TASKS): its searches are long enough to pay.
        fewest, most = PROBING_TASKS
        probing = fewest <= problem.num_tasks <= most
        if left is None:
            # Without a limit the time-indexed model proves the part.
            caught = around(
                problem,
                start,
                narrowed,
                run,
                None,
                probing=probing,
                level_rounds=level_rounds,
            )
        else:
            for_rounds = SHARE * left
            if small:
                for_rounds = max(
                    SMALL_SHARE * left, min(SMALL_FLOOR_S, SHORT_SHARE * left)
                )
            elif left < MIN_LEFT_S:
                for_rounds = SHORT_ROUNDS_SHARE * left
            elif start_count(narrowed) >= LONG_COLUMNS:
                for_rounds = LONG_SHARE * left
            caught = rounds(
                problem,
                start,
                narrowed,
                run,
                for_rounds,
                lambda plan: narrow(problem, plan, domains, relaxed),
                # A large part's rounds stop once its model is small; a
                # small part's go on while they end on their nodes.
                small=None
                if small
                else lambda narrowed: start_count(narrowed) < RELAXED_COLUMNS,
                level_rounds=level_rounds,
                probing=probing,
            )
        if caught.plan is not None:
            return caught.plan, start, narrowed, bound
        bound = caught.bound
        if caught.better is not None:
            # The caps read the kept-set bound only: the relaxation's
            # bound counts delays the caps would count again.
            start = caught.better
            narrowed = narrow(problem, start, domains, relaxed)
        if small:
            # The rounds' best plan is the incumbent and the model is
            # narrowed around it: a probe of the time-indexed model would
            # run the full run's first nodes, and one stopped by time is
            # thrown away (paper seed 91's c15-all-6: 7.7 s of probe,
            # 16.8 s in all; without it 9.4 s, the same optimum; on the
            # other 59 `all` and fresh problems of seeds 90-93 nothing
            # moved by more than 0.05 s).
            return None, start, narrowed, bound
    heuristics = False
    if worth_a_probe(problem, start, relaxed):
        low, high = PROBE_NODES
        nodes = max(
            low, min(high, PROBE_WORK // max(1, start_count(narrowed)))
        )
    elif start_count(narrowed) >= ROOT_PROBE_COLUMNS:
        nodes, heuristics = 0, True
    else:
        return None, start, narrowed, bound
    limit = None
    if time_limit is not None:
        limit = PROBE_SHARE * (time_limit - (time.perf_counter() - began))
    probe = checked(
        problem,
        run(
            problem,
            warm=start.starts(),
            domains=narrowed,
            time_limit=limit,
            max_nodes=nodes,
            heuristics=heuristics,
        ),
    )
    if probe.status in (SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE):
        return probe, start, narrowed, bound
    # A time limit ("on time", or our interrupt) makes the answer
    # machine-dependent: only a probe stopped on its nodes is taken.
    said = probe.stats.solver_status if probe.stats is not None else ""
    if (
        not stopped_on_nodes(said)
        or probe.objective is None
        or start.objective is None
        or probe.objective.total >= start.objective.total
    ):
        return None, start, narrowed, bound
    better = probe.replace(status=SolveStatus.FEASIBLE, why=())
    relaxed = kept_set_plan(
        problem, better, domains, stop=stop_within(began, time_limit)
    )
    return None, better, narrow(problem, better, domains, relaxed), bound


#: Share of what is left of the limit that :func:`_readmitting` may take
#: (its own bound is in list schedules; this only guards the deadline).
READMIT_SHARE = 0.1


def _readmitting(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    relaxed: KeptSetProof,
    narrowed: dict[str, Domain],
    began: float,
    time_limit: float | None,
) -> tuple[Plan, KeptSetProof, dict[str, Domain]]:
    """The start plan with left-out tasks readmitted where that is better
    (:func:`~fsw_scheduler.analysis.readmit.readmitted`), with the
    kept-set result and the model narrowed around it."""
    stop = None
    if time_limit is not None:
        stop = stop_at(
            time.perf_counter()
            + READMIT_SHARE * (time_limit - (time.perf_counter() - began))
        )
    better = readmitted(problem, start, domains, stop=stop)
    if better is start:
        return start, relaxed, narrowed
    relaxed = kept_set_plan(
        problem, better, domains, stop=stop_within(began, time_limit)
    )
    return better, relaxed, narrow(problem, better, domains, relaxed)


#: Orders in a row that found nothing better after which
#: :func:`kept_set_start` stops drawing orders around a small part's
#: start plan (:func:`~fsw_scheduler.analysis.sampling.sampled_around`;
#: 0.2-0.9 ms a list schedule of 15 tasks).
SMALL_STALE = 30
#: Share of the time left that those orders may take at most.
SMALL_ORDER_SHARE = 0.05
#: Parts of at least this many tasks draw those orders whatever their
#: resources, and wait longer for a better one (:data:`LONG_STALE`
#: orders): CBC's search there takes seconds, and a long horizon's
#: time-indexed model may not find in 20 s what the orders find in a
#: second (the large suite's f30-h1440 of seed 253, a 28-task part with
#: a battery over H = 1,440: 1,001 above CP-SAT's optimum at 20 s; 30
#: orders took the start plan from 1,905 above it to 563 in 0.14 s, 120
#: to 300 in 0.46 s).
SAMPLED_MIN_TASKS = 25
LONG_STALE = 120
#: A smaller part draws them only when its model, narrowed around the
#: start plan, has at least this many start times: CBC proves a smaller
#: one in 10-40 ms, of which the orders took 3-6 ms for nothing (the 56
#: multiple-resource problems of 15 tasks of seeds 243-246, both
#: generators: 21 of the 24 parts under 600 start times were faster
#: without them, the other 3 by at most 1.1 ms with them; every gain of
#: more than 5 ms came from a part of 620 or more).
SAMPLED_MIN_STARTS = 600


def kept_set_start(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    began: float,
    time_limit: float | None,
    *,
    replan: bool = False,
) -> tuple[Plan, KeptSetProof]:
    """A small part's start plan and its kept-set result
    (:func:`~fsw_scheduler.analysis.bounds.kept_set_plan`), the plan
    proved optimal when ``result.plan`` is not None.

    When the kept set does not prove the start plan and the part uses a
    multiple resource and no consumable, or has at least
    :data:`SAMPLED_MIN_TASKS` tasks, list schedules of orders drawn
    around its own are tried first (until :data:`SMALL_STALE` in a row,
    :data:`LONG_STALE` on such a long part, find nothing better), a
    smaller part only when its narrowed model has at least
    :data:`SAMPLED_MIN_STARTS` start times: CBC
    spends most of a 15-task multiple-resource model's search
    finding the optimum that one of those orders gives (broad seed 241's
    b15-multiple-3: 0.89 s from the rules' plan, 135 delay units above;
    0.35 s from the optimum, which the 4th order gives). On the 28
    multiple-resource problems of 15 tasks of seeds 240-241 (both
    generators) the solves took 3.5 s in all instead of 5.2 s, the
    slowest 1.5 s -> 0.4 s, the fastest a few milliseconds more. On
    the other classes the orders cost more than they save (a battery
    makes a list schedule 0.5-2 ms; 140 problems: binary 1.8 -> 1.9 s,
    consumable 0.7 -> 0.9 s, all 6.8 -> 7.4 s), so they are not drawn
    there below :data:`SAMPLED_MIN_TASKS` tasks. A ``replan`` draws them
    by its resources only, whatever its size: it starts from the plan in
    force and answers in its share (the replan suite's r30-h1440-1 of
    seed 241, 27 tasks: 0.07 s, 0.52 s with 120 orders, the same optimum).
    """
    relaxed = kept_set_plan(
        problem, start, domains, stop=stop_within(began, time_limit)
    )
    if relaxed.better is not None:
        start = relaxed.better
    if relaxed.plan is not None:
        return relaxed.plan, relaxed
    long = problem.num_tasks >= SAMPLED_MIN_TASKS and not replan
    if not long:
        kinds = used_kinds(problem, domains)
        if "multiple" not in kinds or "consumable" in kinds:
            return start, relaxed
        if start_count(narrow(problem, start, domains, relaxed)) < (
            SAMPLED_MIN_STARTS
        ):
            return start, relaxed  # CBC proves it sooner than orders pay
    sampled = sampled_around(
        problem,
        start,
        domains,
        stale=LONG_STALE if long else SMALL_STALE,
        stop=stop_within(began, time_limit, SMALL_ORDER_SHARE),
    )
    if sampled is start:
        return start, relaxed
    relaxed = kept_set_plan(
        problem, sampled, domains, stop=stop_within(began, time_limit)
    )
    if relaxed.plan is not None:
        return relaxed.plan, relaxed
    return relaxed.better or sampled, relaxed


def narrow(
    problem: Problem,
    start: Plan | None,
    domains: dict[str, Domain],
    relaxed: KeptSetProof | None = None,
    stop: Callable[[], bool] | None = None,
) -> dict[str, Domain]:
    """``domains`` cut by what ``start`` already achieves, if it can.

    Every plan at least as good as ``start`` fits in them (:func:`cost_caps`
    and, given the kept-set search's result ``relaxed``,
    :func:`~fsw_scheduler.analysis.bounds.fixings`: tasks no such plan
    keeps get an empty domain), so the model gets smaller and keeps its
    optimum. ``stop`` (a deadline) ends the fixings' searches early: the
    domains are then wider, never wrong.
    """
    if start is None or start.objective is None:
        return domains
    caps = cost_caps(problem, domains, start) or {}
    fixed = (
        None
        if relaxed is None
        else fixings(
            problem, domains, start.objective.total, relaxed, stop=stop
        )
    )
    if fixed is not None:
        for name, latest in fixed.caps.items():
            caps[name] = min(latest, caps.get(name, latest))
        for name in fixed.dropped:
            caps[name] = domains[name].earliest - 1
    return start_domains(problem, caps) if caps else domains


def whole_model(
    problem: Problem,
    best: Plan,
    bound: float | None,
    run: Callable[..., Plan],
    narrowed: dict[str, Domain],
    limit: float,
) -> tuple[Plan, float | None, str]:
    """The whole model, narrowed around ``best``, run with ``limit``.

    Returns the better plan (CBC's answer when it is no worse and
    proved, or strictly better), the bound raised by CBC's where that
    bounds the whole problem, and what CBC said.
    """
    answer = checked(
        problem,
        run(problem, warm=best.starts(), domains=narrowed, time_limit=limit),
    )
    found = answer.stats.bound if answer.stats is not None else None
    if answer.status is SolveStatus.OPTIMAL and (
        answer.objective is not None
        and best.objective is not None
        and answer.objective.total <= best.objective.total
    ):
        best = answer
        found = float(answer.objective.total)
    elif (
        answer.status.has_plan
        and answer.objective is not None
        and best.objective is not None
        and answer.objective.total < best.objective.total
    ):
        best = answer
    if (
        found is not None
        and best.objective is not None
        and found <= best.objective.total + 0.5
    ):
        # A bound of the narrowed model bounds the whole problem: the
        # optimum fits in it. Above the incumbent it bounds nothing
        # (a stopped CBC's last LP, not its root's).
        bound = higher(bound, found)
    said = answer.stats.solver_status if answer.stats else "no answer"
    return best.replace(status=SolveStatus.FEASIBLE, why=()), bound, said


#: :func:`finished` searches a long model's part only when less than
#: this share of its limit is left: rounds that ended early (not on their
#: nodes) leave CBC the time the whole model had before.
LONG_SEARCH_LEFT = 0.5


def finished(
    problem: Problem,
    run: Callable[..., Plan],
    start: Plan | None,
    domains: dict[str, Domain],
    narrowed: dict[str, Domain],
    began: float,
    time_limit: float | None,
    bound: float | None,
) -> Plan:
    """The rest of a part's limit after :func:`probed`: the whole model,
    narrowed, from ``start``; or, when that model is too long for CBC to
    get through its root in what the relaxation's rounds left of the
    limit (at least :data:`~.rounds.LONG_COLUMNS` columns, the rounds had
    :data:`~.rounds.LONG_SHARE`, and less than :data:`LONG_SEARCH_LEFT`
    of the limit is left), the neighbourhood search from ``start``
    (:func:`~.improve.improve`: windows of a few tasks, which CBC starts
    at once) until the limit or ``bound``.

    The large suite's f30-h2880 of seed 69 (a 28-task part, 3 of its
    rounds without a better plan in 17.7 s): CBC was not started in the
    2.3 s left and the start plan, 9,032 above CP-SAT's optimum, was the
    answer.
    """
    left = (
        None
        if time_limit is None
        else time_limit - (time.perf_counter() - began)
    )
    if (
        start is not None
        and left is not None
        and time_limit is not None
        and MIN_ROUND_S <= left < LONG_SEARCH_LEFT * time_limit
        and start_count(narrowed) >= LONG_COLUMNS
    ):
        best, improved = improve(
            problem,
            start,
            domains,
            run,
            time.perf_counter() + left - BUDGET.lns_margin_s,
            bound,
        )
        return best.replace(
            stats=SolverStats(
                solver=method_label(run, "lns"),
                wall_s=time.perf_counter() - began,
                bound=bound,
                solver_status=f"the whole model ({start_count(narrowed)} "
                "columns) too long for the time left: neighbourhood "
                f"search, {improved} improvements",
                time_limit_s=time_limit,
            )
        )
    return checked(
        problem,
        run(
            problem,
            warm=start.starts() if start else None,
            domains=narrowed,
            # The start plan's time counts against the limit.
            time_limit=left,
        ),
    )
