"""The disjunctive relaxation in rounds of growing node limits, each
around the best plan the one before found.

One run of the relaxation (:func:`~fsw_scheduler.solving.relaxed.around`)
stops at :data:`~fsw_scheduler.solving.relaxed.NODES` nodes: a second on
45 tasks, and the same answer on every machine. Many parts it leaves
unproved are proved by the same model searched to its end: the large
suite's b30-h1440 of seed 71 in 5 s from its start plan (CP-SAT 0.5 s;
20 s of neighbourhood search had left it 71 delay units above the
optimum and its bound 242,367 below), the 42-task part of seed 73's
f45-h1440 in 11 s and the 29-task part of seed 71's f30-h1440 in 12 s
once their domains were narrowed around a better plan (the time-indexed
model did not get through 100 nodes in a minute on either). The
relaxation's big-M rows are as wide as the domains: around a better
plan they are narrower, and its search closes sooner.

:func:`rounds` runs it again while it stops on its node limit, each
round with :data:`GROWTH` times the nodes of the one before, from the
best plan found so far and over the domains narrowed around it
(``renarrow``); the rounds after the first with CBC's probing on
(:data:`~fsw_scheduler.solving.relaxed.PROBING`). Every round but one cut
by the time limit ends on nodes,
so the answer is the same on every machine unless the limit stops it,
as for any CBC run under a limit.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from .relaxed import NODES, RelaxedAnswer, around
from .stats import higher, stopped_on_nodes

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..analysis.domains import Domain
    from ..model.plan import Plan
    from ..model.problem import Problem

#: Share of the time left that the rounds may take before the rest of a
#: part's solve (one round had :data:`~fsw_scheduler.solving.relaxed.
#: SHARE`, 0.3).
SHARE = 0.6

#: A part under 30 tasks whose time-indexed model, narrowed, has at
#: least :data:`LONG_COLUMNS` columns gives the rounds :data:`LONG_SHARE`
#: of what is left instead: CBC did not get through the root of such a
#: model in the rest of a 20 s limit (the large suite's f30-h1440 of
#: seed 71, 21,630 columns: killed at the deadline after 7 s), while the
#: rounds prove its 29-task part in 8-12 s. At 15,000 the fresh
#: campaign's f25-h1440-1 of seed 138 (10,705 columns, whose root CBC
#: did not get through in 3.7 s) had its last round cut at 6 s of 10
#: and answered `feasible`; at 10,000, `optimal` in 5.5 s, as is seed
#: 140's f25-h336-2 (8.7 s). On the fresh campaign's seeds 138-141 (72
#: problems, 10 s) nothing else changed by more than 0.3 s; three parts
#: of 12,000-12,600 columns that the time-indexed model proves after the
#: rounds took 0.3-0.4 s longer (the large suite's b30-h1440 of seed 82,
#: 9.7 -> 10.0 s of 20).
LONG_COLUMNS = 10_000
LONG_SHARE = 0.9

#: Each round has this many times the nodes of the one before: the
#: rounds that found nothing cost at most a third of the last one.
GROWTH = 4

#: Share of what the rounds leave of a large part's time that one more
#: round may take when the limit ended one that found a better plan
#: (:func:`rounds`' ``overtime``): the large suite's b30-h1440 of seed
#: 60: the third round found the optimum at 11 s of 20, stopped on its
#: nodes with a gap of 627 delay units, and the neighbourhood search
#: then spent 8 s finding nothing; a round around that plan proves it
#: in 5.9 s.
OVERTIME = 0.75

#: A round is not started with less than this many seconds left: CBC
#: takes about as long to read and start the model of 45-60 tasks.
MIN_ROUND_S = 0.5

#: A part of this many tasks (from the first to the second) has CBC's
#: probing from its first round (:func:`rounds`' ``probing``), not only
#: from the second: the fixings probing finds take most of the nodes off
#: (the 42 first rounds of the 15-task `all` problems of seeds 217-219:
#: 2,404 nodes to 442, CBC's time 2.47 -> 2.09 s; the one round stopped
#: on its 500 nodes proved in 89). The product's solve on the 15-task
#: `all` class, one run each, paper and broad, on seeds 225-228 (not
#: looked at before; their parts have 14 or 15 tasks): summed time lower
#: on 7 of 8 (paper 228: 5.37 -> 4.39 s, broad 226: 4.17 -> 3.26 s;
#: broad 228: 0.47 -> 0.48 s), the median lower on 5 (paper 227:
#: 0.077 -> 0.043 s) and 0.002-0.005 s higher on 3, every problem
#: proved. On 10-task parts (the 10-task `all` problems of seed 225,
#: three runs each) it was slower, by up to 0.07 s a problem: their
#: searches are short, and probing costs at every node. Larger parts
#: keep a first round without it: 500 nodes from a poor start over wide
#: domains did not end in 10 s with probing (see
#: :data:`~fsw_scheduler.solving.relaxed.PROBING`); with parts up to 29
#: tasks, the fresh campaign (15-25 tasks) of seeds 230-233 gained one
#: proof (230's f20-h336-1: `feasible` at 19.5 s -> `optimal` in 4.4 s)
#: but most 25-task problems took 0.2-1.7 s more (seed 231: 4.0 -> 6.5 s
#: in all, seed 232: 4.0 -> 5.9 s).
PROBING_TASKS = (12, 15)

#: The rounds stop after one (not the first) that found no better plan
#: and raised the bound by less than this share of the gap it started
#: from: on 66 large-suite problems of 30-45 tasks (seeds 60-70), no
#: round after such a one ever found a better plan or a proof (none after
#: one under a fifth of the gap either), and seven went on for nothing,
#: up to 13 s of seed 69's f30-h2880 (20 s limit: +1,096 and +85 on a gap
#: of 222,000), time the neighbourhood search then has.
STALL_SHARE = 0.05


def rounds(
    problem: Problem,
    start: Plan,
    narrowed: dict[str, Domain],
    run: Callable[..., Plan],
    limit: float,
    renarrow: Callable[[Plan], dict[str, Domain]],
    polish: Callable[[Plan], Plan] | None = None,
    small: Callable[[dict[str, Domain]], bool] | None = None,
    overtime: float = 0.0,
    level_rounds: int | None = None,
    nodes: int = NODES,
    probing: bool = False,
) -> RelaxedAnswer:
    """The relaxation around ``start`` over ``narrowed``, again and again
    with more nodes while it stops on its node limit, for ``limit``
    seconds in all.

    Parameters
    ----------
    problem, start, narrowed, run
        As for :func:`~fsw_scheduler.solving.relaxed.around`.
    limit
        Seconds for all the rounds.
    renarrow
        The domains every plan at least as good as a given plan keeps
        (:func:`~fsw_scheduler.solving.incumbent.narrow` with what the
        caller knows): a better plan found by a round narrows the next.
    polish
        A plan at least as good as a given valid plan (left-out tasks
        inserted, :func:`~fsw_scheduler.analysis.insert.inserted`): applied
        to a better plan a round finds before the next starts from it.
    small
        True for domains whose time-indexed model CBC proves sooner than
        more rounds would: no round follows once the domains are such
        (the large suite's b30-h1440 of seed 31: 2,461 columns after the
        first round; the whole model proved it in about 3 s, a second
        round in 6 s).
    overtime
        Seconds past ``limit`` that one more round may take when a round
        found a better plan and less of ``limit`` is left than it took
        (stopped on its nodes or by the limit; :data:`OVERTIME`).
    level_rounds
        For each round (:func:`~fsw_scheduler.solving.relaxed.around`);
        given, no round follows one that wrote levels.
    nodes
        The first round's node limit (:data:`~fsw_scheduler.solving.
        relaxed.NODES` by default; each next round has :data:`GROWTH`
        times the one before): a caller whose own run of the relaxation
        already stopped on those nodes over the same domains starts at
        the next round's.
    probing
        CBC's probing from the first round (:data:`PROBING_TASKS`);
        the rounds after the first have it anyway.

    Returns
    -------
    RelaxedAnswer
        The optimum when a round proves one that is a valid plan; else
        the best bound of all rounds (each bounds every plan at least as
        good as its own start, and so the optimum), the best plan found
        better than ``start``, and what each round said.
    """
    end = time.perf_counter() + limit
    bound: float | None = None
    better: Plan | None = None
    said: list[str] = []
    levels: tuple[int, ...] = ()
    while True:
        began = time.perf_counter()
        before = bound  # the rounds' bound so far
        answer = around(
            problem,
            start,
            narrowed,
            run,
            end - time.perf_counter(),
            nodes,
            # The first round as one round ran before: cheap nodes, a
            # better plan to narrow around; the next ones with CBC's
            # probing, which closes the search in far fewer nodes.
            probing=probing or nodes > NODES,
            # The levels a round wrote hold over narrower domains too.
            levels=levels,
            level_rounds=level_rounds,
            # An optimum CBC claims after its restart is confirmed in the
            # overtime too: the search after the rounds seldom betters
            # it (the large suite's f60-h1440 and b30-h1440 of seed 197
            # held their optimum unproved to the limit).
            confirm_until=end + overtime,
        )
        levels = answer.levels
        bound = higher(bound, answer.bound)
        said.append(f"{nodes} nodes: {answer.said}")
        if answer.plan is not None:
            return answer._replace(
                said=f"{len(said)} rounds; " + "; ".join(said)
            )
        if answer.better is not None:
            # A round's plan often leaves out tasks that fit once what is
            # in their way moves (the large suite's b30-h1440 of seed 79:
            # 1,815,234 to 1,460,654 by inserting three): from that plan
            # the next round's domains are far narrower.
            start = better = (
                answer.better if polish is None else polish(answer.better)
            )
            narrowed = renarrow(start)
        # Anything but the node limit (its optimum proved but not a valid
        # plan, the time limit, no plan) means more nodes over these
        # domains say nothing more.
        now = time.perf_counter()
        more = stopped_on_nodes(answer.said)
        if (
            before is not None
            and answer.bound is not None
            and answer.better is None
            and start.objective is not None
            and answer.bound - before
            < STALL_SHARE * (start.objective.total - before)
        ):
            more = False  # the bound has stalled (see STALL_SHARE)
        if level_rounds is not None and answer.levels:
            # A part given few runs with levels goes on in its time-indexed
            # model: more nodes over the levels cost more than that
            # (relaxed.SMALL_LEVEL_ROUNDS).
            more = False
        if (
            answer.better is not None
            and overtime > 0
            and end - now < now - began
        ):
            # This round found a better plan and what is left (if any)
            # would not see the next one through: one more round around
            # that plan, in the overtime (see OVERTIME).
            end, overtime, more = end + overtime, 0.0, True
        if (
            not more
            or (small is not None and small(narrowed))
            or end - time.perf_counter() < MIN_ROUND_S
            or (
                bound is not None
                and start.objective is not None
                and bound >= start.objective.total - 0.5
            )
        ):
            break
        nodes *= GROWTH
    return RelaxedAnswer(
        bound, None, better, f"{len(said)} rounds; " + "; ".join(said)
    )
