"""Large parts: the neighbourhood search with a bound, fresh or replanned.

Parts of :attr:`~fsw_scheduler.solving.budget.SolveBudget.lns_min_tasks`
tasks or more under a time limit are not handed whole to CBC at first
(its root LP alone can take longer than the limit):
:func:`improved` improves the start plan by neighbourhood search
(:mod:`fsw_scheduler.solving.improve`), bounded by the kept-set
relaxation and the disjunctive relaxation, then runs the whole model
narrowed around the incumbent with what is left; the plan carries its
bound (``stats.bound``). A replan of such a part
(:mod:`.replanning`) uses the same pieces: :func:`relaxation`,
:func:`inserting`, :func:`narrowed_around`, :func:`answer`.

:func:`fsw_scheduler.solving.solve.solve` calls them and adds the gap.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

from ..analysis.bounds import (
    KeptSetProof,
    kept_set_bound,
    kept_set_starts,
    proved_by,
)
from ..analysis.domains import start_count
from ..analysis.grow import grown
from ..analysis.insert import inserted
from ..analysis.sampling import sampled_around
from ..model.plan import SolverStats, SolveStatus
from .budget import BOUND_SHARE, BUDGET, stop_at, stop_share
from .improve import MIN_ROUND_S, improve, meets
from .incumbent import narrow, whole_model, worth_a_probe
from .polishing import Polishing, shift_deadline
from .refuted import refuted
from .relaxed import NODES, RelaxedAnswer, fresh_min_left, relaxable
from .relaxed import around as relaxed_around
from .rounds import OVERTIME, SHARE, rounds
from .stats import higher, method_label

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem


def searched(problem: Problem) -> bool:
    """True if a part under a time limit goes to the neighbourhood search
    (:func:`improved`, :func:`~.replanning.replanned`) rather than whole
    to CBC: from :attr:`~fsw_scheduler.solving.budget.SolveBudget.
    lns_min_tasks` tasks.

    Parts of 20-29 tasks whose model had over 15,000 columns were sent
    here too for a while: on the large suite's seed 47 (not tuned on) a
    29-task part over H = 1440 that CBC proves in 7 s went unproved, and
    on the fresh campaign's f25-h1440-0 (seed 5) the search's plan and
    bound were both worse than CBC's.
    """
    return problem.num_tasks >= BUDGET.lns_min_tasks


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
    their way pays (:func:`inserting`), and again into a plan the
    relaxation or the search improved. While the start plan leaves out
    a whole task more than the kept-set bound, the kept set is grown
    (:func:`~fsw_scheduler.analysis.grow.grown`) and, after the
    disjunctive relaxation, list schedules of orders around the
    incumbent's are tried (:func:`~fsw_scheduler.analysis.sampling.
    sampled_around`). The
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
        problem, start, domains, stop=until(deadline, BOUND_SHARE)
    )
    if relaxed.plan is not None:
        return proved_start(
            relaxed.plan,
            began,
            time_limit,
            f"{proved_by(relaxed)}: no solve",
        )
    start, inserted_count = kept_set_started(
        problem, start, relaxed, domains, deadline
    )
    said = (
        f"{inserted_count} left-out tasks inserted into the start plan; "
        if inserted_count
        else ""
    )
    if worth_a_probe(problem, start, relaxed):
        # Still a whole task short of the bound: grow the kept set, list
        # scheduling judging each set (b60-h2880 of the large suite, seed
        # 217: 63 units left out -> 53, CP-SAT's plan 52; the search
        # and the relaxation had recovered none in 16 s).
        bigger = grown(problem, start, stop=until(deadline, GROW_SHARE))
        if (
            bigger is not None
            and bigger.objective is not None
            and start.objective is not None
            and _total(bigger) < _total(start)
        ):
            gained = (
                start.objective.unscheduled_cost
                - bigger.objective.unscheduled_cost
            )
            start = inserting(problem, bigger, domains, deadline)
            said += (
                f"the kept set grown ({gained} schedule cost units fewer "
                "left out); "
            )
    relaxing = relaxable(
        run, problem, domains, deadline - time.perf_counter(), relax_min_s
    )
    # Still short of the bound's kept set: the solver refutes sets or
    # places one (a dense day the search could not fill, fuzz seed 1462).
    # Where the disjunctive relaxation will run, only the cheap proofs:
    # the solver's runs took the time it needed (a 40-task day over H =
    # 200 with a battery: 340,915 -> 509,547 at 5 s).
    asked = refuted(
        problem, start, domains, relaxed, run, deadline, solver=not relaxing
    )
    relaxed, nogoods = asked.proof, asked.nogoods
    if asked.said:
        said += f"{asked.said}; "
    if relaxed.plan is not None:
        return proved_start(
            relaxed.plan,
            began,
            time_limit,
            f"{said}{proved_by(relaxed)}",
            solver=method_label(run, "refuted"),
        )
    if asked.plan is not None and _total(asked.plan) < _total(start):
        start = inserting(problem, asked.plan, domains, deadline)
    bound = None if relaxed.lowest is None else float(relaxed.lowest)
    if relaxing:
        caught = relaxation(
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
            return answer(
                caught.plan,
                float(caught.plan.objective.total),
                method_label(run, "relaxed"),
                caught.said,
                began,
                time_limit,
            )
        if caught.better is not None:
            start = inserting(problem, caught.better, domains, deadline)
        # Not a bound for the caps (they add each task's delay to the
        # kept-set bound, and this one counts delays already): only for
        # the search's stop and the gap.
        bound = higher(bound, caught.bound)
        said += f"the disjunctive relaxation: {caught.said}; "
    if worth_a_probe(problem, start, relaxed):
        # Still short after the relaxation (which proves many such
        # parts first: the large suite's b30-h1440 of seed 251 in 2.8 s,
        # 6.8 s with the orders before it).
        start, sampled = _sampled(problem, start, domains, deadline)
        said += sampled
    polish = Polishing(problem, domains, deadline, bound)
    start = polish.shifted(polish(start), run, shift_deadline(deadline))
    # Tasks moved earlier may leave room for a left-out one.
    start = inserting(problem, start, domains, deadline)
    narrowed = narrowed_around(
        problem, start, domains, relaxed, until(deadline)
    )
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
            return answer(
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
            problem,
            plan,
            domains,
            stop=until(deadline, BOUND_SHARE),
            nogoods=nogoods,
        )
        narrowed = narrowed_around(
            problem, plan, domains, again, until(deadline)
        )
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
        best = inserting(problem, best, domains, deadline)
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
                    problem,
                    best,
                    domains,
                    stop=until(deadline, BOUND_SHARE),
                    nogoods=nogoods,
                )
                if improved
                else relaxed
            )
            narrowed = narrow(problem, best, domains, again, until(deadline))
        bound = higher(bound, again.bound)
        if relaxable(run, problem, domains, left):
            # Around a better incumbent the relaxation's domains are
            # narrower and its big-M rows tighter.
            caught = relaxed_around(
                problem, best, narrowed, run, END_SHARE * left
            )
            said += "; then the disjunctive relaxation: " + caught.said
            if caught.plan is not None and caught.plan.objective is not None:
                return answer(
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
                    problem, best, domains, again, until(deadline)
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
    return answer(
        best, bound, method_label(run, "lns"), said, began, time_limit
    )


#: Share of the time left that growing the kept set may take
#: (:func:`~fsw_scheduler.analysis.grow.grown`; its own bound is in list
#: schedules tried, about 3.5 s on 60 tasks over H = 2880).
GROW_SHARE = 0.3

#: Share of the time left after the disjunctive relaxation that list
#: schedules of orders around the incumbent may take
#: (:func:`~fsw_scheduler.analysis.sampling.sampled_around`; its own
#: bound is in orders tried, 3.7 s on 45 tasks over H = 1440 with a
#: battery). At 0.25 the large suite's b45-h1440 of seed 241 (20 s) kept
#: 9 units left out; at 0.5 the search from the sampled plan found 7.
ORDER_SHARE = 0.5


def _sampled(
    problem: Problem, plan: Plan, domains: dict[str, Domain], deadline: float
) -> tuple[Plan, str]:
    """``plan``, or a better list schedule of an order drawn around its
    own (:func:`~fsw_scheduler.analysis.sampling.sampled_around`, for
    :data:`ORDER_SHARE` of the time left) with left-out tasks inserted,
    and what that gained for the status ("" when nothing).

    On a day a battery binds, which tasks stay is a matter of order
    (which task takes the charge first), and the neighbourhood search,
    which moves a few tasks of one kept set at a time, does not leave an
    arrangement: the large suite's b45-h1440 of seed 241 kept 9 units
    left out through 60 s of search, CP-SAT 6, its plan the list
    schedule of its own start order; from the plan after the
    relaxation, 7.
    """
    sampled = sampled_around(
        problem, plan, domains, stop=until(deadline, ORDER_SHARE)
    )
    if sampled is plan or sampled.objective is None or plan.objective is None:
        return plan, ""
    left_out = plan.objective.unscheduled_cost
    gained = left_out - sampled.objective.unscheduled_cost
    saved = plan.objective.delay_cost - sampled.objective.delay_cost
    said = "orders around it sampled (" + (
        f"{gained} schedule cost units fewer left out); "
        if gained > 0
        else f"the same left out, {saved} delay units saved); "
    )
    return inserting(problem, sampled, domains, deadline), said


#: Share of the time left that inserting left-out tasks may take (its
#: own bound is in moves tried; this only guards the deadline).
INSERT_SHARE = 0.2


def inserting(
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


def kept_set_started(
    problem: Problem,
    start: Plan,
    relaxed: KeptSetProof,
    domains: dict[str, Domain],
    deadline: float,
) -> tuple[Plan, int]:
    """``start``, or where it leaves out more than the kept-set bound the
    relaxed optimum's tasks list-scheduled alone (:func:`~fsw_scheduler.
    analysis.bounds.kept_set_starts`, ``thorough``), whichever is best
    once left-out tasks are inserted (:func:`best_inserted`; ``start``
    wins a tie), and how many were inserted into it.

    Those tasks alone often leave out much less (b45-h1440 of the large
    suite, seed 31: 5.4 M instead of 7.1 M, which the search had not
    found in 20 s); placing them takes as long as the start plan did,
    so only then.
    """
    starts = (
        kept_set_starts(
            problem, relaxed, until(deadline, BOUND_SHARE), thorough=True
        )
        if worth_a_probe(problem, start, relaxed)
        else []
    )
    return best_inserted(problem, [start, *starts], domains, deadline)


def best_inserted(
    problem: Problem,
    plans: Sequence[Plan],
    domains: dict[str, Domain],
    deadline: float,
) -> tuple[Plan, int]:
    """The best of ``plans`` once left-out tasks are inserted into each
    (:func:`inserting`), the first on a tie, and how many were inserted
    into it.

    The better start before insertion is not always the better one
    after: the large suite's b45-h2880 of seed 214, the relaxed kept set
    list-scheduled 12.54 M, the start heuristic's plan 13.97 M, which
    insertion took to 10.76 M and 9.69 M (four tasks in against one).
    Insertion takes 0.01-0.2 s on 45-60 tasks; all of them share one
    :data:`INSERT_SHARE` of the time left, the first plan first.
    """
    now = time.perf_counter()
    stop = stop_at(now + INSERT_SHARE * max(0.0, deadline - now))
    best: tuple[Plan, int] | None = None
    for plan in plans:
        after = inserted(problem, plan, domains, stop=stop)
        if best is None or _total(after) < _total(best[0]):
            best = (after, len(plan.unscheduled) - len(after.unscheduled))
    if best is None:
        raise ValueError("no plan to insert into")
    return best


def _total(plan: Plan) -> float:
    return plan.objective.total if plan.objective else float("inf")


#: Share of the time left after the search that the relaxation gets
#: before the whole model (:func:`improved`).
END_SHARE = 0.5


def relaxation(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    relaxed: KeptSetProof,
    run: Callable[..., Plan],
    limit: float,
    *,
    more: bool = False,
    end: float | None = None,
    nodes: int = NODES,
) -> RelaxedAnswer:
    """:func:`~fsw_scheduler.solving.relaxed.around` ``start`` with
    ``nodes`` nodes, over the domains every plan at least as good keeps;
    with ``more``, in :func:`~fsw_scheduler.solving.rounds.rounds` of
    growing node limits from ``nodes`` for all of ``limit`` (and an
    overtime up to the part's ``end``, see
    :data:`~fsw_scheduler.solving.rounds.OVERTIME`)."""
    stop = stop_at(time.perf_counter() + NARROW_SHARE * limit)

    def renarrow(plan: Plan) -> dict[str, Domain]:
        narrowed = narrowed_around(problem, plan, domains, relaxed, stop)
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
            lambda plan: inserting(problem, plan, domains, deadline),
            lambda narrowed: start_count(narrowed) <= SMALL_COLUMNS,
            0.0 if end is None else OVERTIME * max(0.0, end - deadline),
            nodes=nodes,
        )
    return relaxed_around(problem, start, renarrow(start), run, limit, nodes)


def narrowed_around(
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


def until(deadline: float, share: float = NARROW_SHARE) -> Callable[[], bool]:
    """A stop at ``share`` (:data:`NARROW_SHARE` by default) of the time
    left before ``deadline`` (:func:`~.budget.stop_share`)."""
    return stop_share(deadline, share)


def answer(
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


def proved_start(
    plan: Plan,
    began: float,
    time_limit: float | None,
    proof: str,
    solver: str = "greedy",
) -> Plan:
    """``plan`` proved optimal without a solver run of its own (``solver``
    names what proved it), with its statistics."""
    return plan.replace(
        status=SolveStatus.OPTIMAL,
        stats=SolverStats(
            solver=solver,
            wall_s=time.perf_counter() - began,
            bound=plan.objective.total if plan.objective else None,
            solver_status=proof,
            time_limit_s=time_limit,
        ),
    )
