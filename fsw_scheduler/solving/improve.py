"""Large-neighbourhood search: better plans for large problems (core).

From 30 tasks on, the whole time-indexed model is too large for CBC to
improve the start plan within seconds (its root LP alone took longer than
the limit). Here CBC solves small models instead: the same ILP, with every
task outside a *neighbourhood* pinned to its place in the incumbent (a
one-start domain, so CBC may still drop it) or kept out, and the tasks in
the neighbourhood free over their whole domains (:func:`_neighbourhood`).
Any solution of such a model is a plan of the whole problem (the model is
the full one with narrower domains), so an improvement is taken as soon
as it is found and checked, and the next window starts from it.

Neighbourhoods are time windows swept over the horizon, each holding the
tasks the incumbent runs there and the left-out tasks that could start
there, up to :data:`MAX_FREE` of them, in a fixed order: the same input
and the same number of rounds give the same plan.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING

from ..analysis.check import check_plan
from ..analysis.domains import Domain
from ..analysis.proofs import precedence_needs
from ..model.plan import Plan, SolveStatus

if TYPE_CHECKING:
    from collections.abc import Callable, Collection

    from ..model.problem import Problem

    SolveIlp = Callable[..., Plan]

#: Tasks set free in one neighbourhood: at first, at most, and the step
#: by which a sweep that found nothing grows it.
MIN_FREE, MAX_FREE, STEP_FREE = 6, 18, 4
#: Tasks set free at most once the time left is the search's alone
#: (``hand_over_s``): the sweeps go on, shifted by a quarter window and
#: larger, up to this size, instead of ending with the gap open.
LAST_FREE = 34
#: Seconds one sub-model may take: a quarter of the time left, between
#: :data:`ROUND_MIN_S` and this. At 1 s (the earlier fixed limit) most
#: sub-models of 30 tasks over H = 1440 with a battery were stopped before
#: CBC had read its MIP start (their root LP alone: 0.7 s, a round 1.9 s
#: under load), and the search made 1 improvement in 20 s.
ROUND_S = 3.0
ROUND_MIN_S = 1.0
#: Below this much time left no round is started: CBC is not started
#: with less than its stop margin (0.3 s), its least run (0.05 s) and the
#: model's reading left, and such rounds only returned "time limit spent
#: before CBC started" (rounds given 0.44 s and less, measured in 2 s
#: replans).
MIN_ROUND_S = 0.45
#: Seconds between two progress lines on the solver's logger.
PROGRESS_S = 3.0

log = logging.getLogger("fsw_scheduler.solver")


def improve(
    problem: Problem,
    incumbent: Plan,
    domains: dict[str, Domain],
    run: SolveIlp,
    deadline: float,
    bound: float | None = None,
    around: Collection[str] | None = None,
    hand_over_s: float = 0.0,
    hand_over: Callable[[Plan], bool] | None = None,
) -> tuple[Plan, int]:
    """Improve ``incumbent`` by solving sub-models until ``deadline``.

    Parameters
    ----------
    problem
        A validated problem.
    incumbent
        A valid plan of it, with its objective.
    domains
        The problem's start domains.
    run
        :func:`~fsw_scheduler.solving.ilp.solve_ilp` with the solver
        settings bound: called with the problem, ``domains``, ``warm`` and
        ``time_limit``.
    deadline
        :func:`time.perf_counter` value by which to return.
    bound
        A proven lower bound on every plan's objective, if known: the
        search stops as soon as its incumbent meets it (it is optimal).
    around
        Tasks to search around (a replan's changed tasks,
        :func:`fsw_scheduler.solving.repair.changed_tasks`): the windows
        are those about where each runs or could run, not a sweep of the
        whole horizon, and the search ends when they have all been tried
        at the largest size without a gain.
    hand_over_s
        Time left below which the caller has no better use for it: a
        sweep over the whole horizon that found nothing at the largest
        size then goes on (windows shifted by a quarter of their width,
        and larger, up to :data:`LAST_FREE` tasks) instead of ending
        with the gap open. With more left the search ends there, and the
        caller spends the rest.
    hand_over
        Asked of the incumbent each time a sweep finds nothing (once per
        incumbent): True ends the search there, for the caller to spend
        the rest (the whole model, when the incumbent makes it small).

    Returns
    -------
    tuple[Plan, int]
        The best plan found (status ``feasible``) and the number of rounds
        that improved it.
    """
    best = incumbent
    improved = 0
    began = last_log = time.perf_counter()
    size = MIN_FREE
    shift = 0.0

    def sweep() -> list[tuple[int, int]]:
        if around is None:
            return _windows(problem, size, shift)
        return _windows_around(problem, best, domains, around, size)

    windows = sweep()
    stale = index = 0
    asked: Plan | None = None
    while True:
        now = time.perf_counter()
        left = deadline - now
        if left < MIN_ROUND_S or meets(best, bound):
            break
        if now - last_log >= PROGRESS_S and best.objective is not None:
            last_log = now
            log.info(
                "neighbourhood search %.0f s on %d tasks: incumbent left-out "
                "cost %d, delay %d; %d improvements, neighbourhoods of %d "
                "tasks, bound %s",
                now - began,
                problem.num_tasks,
                best.objective.unscheduled_cost,
                best.objective.delay_cost,
                improved,
                size,
                "none" if bound is None else f"{bound:.0f}",
            )
        if (
            stale >= len(windows)
            and hand_over is not None
            and asked is not best
        ):
            asked = best
            if hand_over(best):
                break
        if stale >= len(windows):
            # A whole sweep found nothing: larger neighbourhoods.
            if size >= MAX_FREE and (
                around is not None
                or size >= LAST_FREE
                or deadline - time.perf_counter() >= hand_over_s
            ):
                break
            if size >= MAX_FREE:
                # The time is the search's alone: shifted windows cut
                # the plan where no sweep cut it yet.
                shift = 0.25 - shift
                size = min(LAST_FREE, size + STEP_FREE)
            else:
                size = min(MAX_FREE, size + STEP_FREE)
            windows = sweep()
            stale = index = 0
        if not windows:
            break
        low, high = windows[index % len(windows)]
        index += 1
        narrowed = _neighbourhood(
            problem, best, domains, low, high, size, settled(best, bound)
        )
        if narrowed is None:
            stale += 1
            continue
        plan = run(
            problem,
            domains=narrowed,
            warm=best.starts(),
            time_limit=min(ROUND_S, max(ROUND_MIN_S, left / 4), left),
            candidates=candidate_starts(problem, best, narrowed),
        )
        better = (
            plan.status.has_plan
            and plan.objective is not None
            and best.objective is not None
            and plan.objective.total < best.objective.total
            and check_plan(problem, plan).ok
        )
        if better:
            best = plan.replace(status=SolveStatus.FEASIBLE, why=())
            improved += 1
            stale = 0
        else:
            stale += 1
    return best, improved


def meets(plan: Plan, bound: float | None) -> bool:
    """True if ``plan``'s objective is within half a unit of ``bound``
    (every objective is an integer): nothing can be better."""
    return (
        bound is not None
        and plan.objective is not None
        and plan.objective.total <= bound + 0.5
    )


def settled(plan: Plan, bound: float | None) -> bool:
    """True if ``bound`` proves that no plan leaves out less than
    ``plan`` does.

    A plan's total is ``W u`` plus its delay (and move) part, which is
    under ``W``; a plan leaving out ``u' < u`` costs less than ``W u``.
    So a bound at least ``W u`` (the plan's gap at most its delay and
    move part) rules every such plan out. Under the lexicographic move
    term the objective does not carry the weight of a move, and nothing
    is settled here.
    """
    if bound is None or plan.objective is None:
        return False
    objective = plan.objective
    rest = objective.delay_cost
    if isinstance(objective.moves, int):
        if not isinstance(objective.move_cost, int):
            return False
        rest += objective.move_cost * objective.moves
    return bound >= objective.total - rest - 0.5


def _windows(
    problem: Problem, size: int, shift: float = 0.0
) -> list[tuple[int, int]]:
    """Windows over the horizon, overlapping by half, the first starting
    ``shift`` of a width after the horizon's start.

    A window of width ``w`` meets about ``n (mean length + w) / H`` tasks;
    ``w`` is chosen for about ``size`` of them.
    """
    span, count = problem.horizon, problem.num_tasks
    mean = sum(t.length for t in problem.tasks) / count
    width = int(min(span, max(8, size * span / count - mean)))
    step = max(1, width // 2)
    first = int(shift * width) if width < span else 0
    return [
        (problem.start + low, problem.start + min(span, low + width))
        for low in range(first, max(first + 1, span - step), step)
    ]


def _windows_around(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    names: Collection[str],
    size: int,
) -> list[tuple[int, int]]:
    """Windows of :func:`_windows`' width about where each of ``names``
    runs in ``plan``, or about the middle of its domain when it is left
    out; without repeats, in the order of ``names``."""
    span, count = problem.horizon, problem.num_tasks
    mean = sum(t.length for t in problem.tasks) / count
    width = int(min(span, max(8, size * span / count - mean)))
    lengths = {t.id: t.length for t in problem.tasks}
    starts = plan.starts()
    found: list[tuple[int, int]] = []
    for name in names:
        domain = domains.get(name)
        if name in starts:
            centre = starts[name] + lengths[name] // 2
        elif domain is not None and not domain.empty:
            centre = (domain.earliest + domain.latest + lengths[name]) // 2
        else:
            continue
        low = max(problem.start, min(centre - width // 2, problem.end - width))
        window = (low, min(problem.end, low + width))
        if window not in found:
            found.append(window)
    return found


def _neighbourhood(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    low: int,
    high: int,
    size: int,
    settled: bool = False,
) -> dict[str, Domain] | None:
    """Domains freeing up to ``size`` tasks around ``[low, high)``,
    pinning the rest.

    The free tasks may move anywhere in their domains, not only near the
    window (they were held within 15 units of it): what keeps a left-out
    task out is often a task that fits only far away. On ``tools/fuzz
    --large`` seed 531 (58 tasks, H = 300, a power resource
    of capacity 3 over [100, 200) and 1 after): a mandatory 10-unit task
    placed at 112 kept two tasks with windows there out, and its only
    other room was past 300. Held near the window the search ended at 28
    schedule-cost units left out (1,505,419), at 10 s and 30 s alike;
    free over their domains, at 23 (1,238,971; CP-SAT's best in 20 s:
    17). The free tasks' candidate starts (:func:`candidate_starts`)
    keep such models small. On the large and orbit suites (seed 143,
    20 s) and the replan suite (seed 142) every answer was the same or
    within a rerun's spread; of 23 such shapes that were not infeasible
    (seeds 500-599, 10 s), 1 far better, 4 a little better and 3 a
    little worse (at most 0.04 %).

    Left-out tasks take up to half the places, the placed ones in the
    window the rest, unless ``settled`` (:func:`settled`: the bound
    proves no plan leaves out less): then the placed tasks come first,
    since only their order can still gain. On the large suite of seed
    197 and the orbit suite of seed 202 (20 s), four plans came out
    lower (32 to 2,639), one 130 higher, none lost a proof.

    None when nothing there can change.
    """
    tasks = {t.id: t for t in problem.tasks}
    starts = plan.starts()
    lengths = {t.id: t.length for t in problem.tasks}
    placed = [
        name
        for name, start in starts.items()
        if start < high and start + lengths[name] > low
    ]
    waiting = [
        t.id
        for t in problem.tasks
        if t.id not in starts
        and not domains[t.id].empty
        and domains[t.id].earliest < high
        and domains[t.id].latest + t.length > low
    ]
    # Left-out tasks first, the most valuable first: leaving less out is
    # the objective's first criterion; then the tasks in their way.
    waiting.sort(key=lambda name: -tasks[name].schedule_cost)
    free = set() if settled else set(waiting[: size // 2])
    for name in placed:
        if len(free) >= size:
            break
        free.add(name)
    for name in waiting:
        if len(free) >= size:
            break
        free.add(name)
    if not free:
        return None
    partners = _partners(problem, starts, free)
    narrowed: dict[str, Domain] = {}
    for task in problem.tasks:
        domain = domains[task.id]
        start = starts.get(task.id)
        if (task.id in partners or task.id in free) and not domain.empty:
            narrowed[task.id] = domain
        elif start is not None:
            narrowed[task.id] = Domain(start, start)
        else:
            narrowed[task.id] = Domain(1, 0, "lns", "kept out")
    return narrowed


def _partners(
    problem: Problem, starts: dict[str, int], free: set[str]
) -> set[str]:
    """Left-out tasks outside ``free`` that a left-out task in it cannot
    run without, free over their whole domains.

    A precedence's first task must run for its second to (and a
    ``both`` one's second for its first): a neighbourhood that frees a
    left-out task and keeps such a partner out, because the partner
    could only run far from the window, can never place it. On seed
    63's f45-h2880 of the large suite the plans left out 49 schedule-cost
    units where CP-SAT's leave out 36, its better plan keeping a chain of
    four tasks whose last could only run 600 units after the others;
    every window kept that one out. At most :data:`MAX_PARTNERS` are
    added, the first found (the freed tasks taken in id order, last
    first), so the same neighbourhood comes out on every run.
    """
    needs = precedence_needs(problem)
    added: set[str] = set()
    queue = sorted(n for n in free if n not in starts)
    while queue:
        name = queue.pop()
        for other in needs[name]:
            if other in starts or other in free or other in added:
                continue
            if len(added) >= MAX_PARTNERS:
                return added
            added.add(other)
            queue.append(other)
    return added


#: Left-out partners (:func:`_partners`) added at most to a neighbourhood.
MAX_PARTNERS = 4
#: A free task of a neighbourhood with more starts than this gets
#: candidate starts (:func:`candidate_starts`) instead of all of them.
DENSE_STARTS = 48
#: Candidate starts on a grid: about this many over a free task's domain.
GRID_STARTS = 32


def candidate_starts(
    problem: Problem, plan: Plan, narrowed: dict[str, Domain]
) -> dict[str, list[int]]:
    """Candidate starts of a neighbourhood's free tasks with wide domains.

    A sub-model of a dozen free tasks over H = 2,880 had 2,000-2,400
    columns (a start time each) and CBC took 0.3-1.5 s to say it held
    nothing better. Shifting a task earlier until something stops it
    never costs more (the objective only counts delays), and what stops
    it is its domain's start, the end of a task before it, or a
    precedence; so each free task keeps its domain's ends, its start in
    ``plan``, the ends of the other tasks ``plan`` places and the starts
    its precedences with them ask for, and a grid of about
    :data:`GRID_STARTS` starts for what it waits for otherwise (a
    battery's charge, a free task's new end). Its sub-model is smaller
    and its every solution a plan: a neighbourhood may miss a gain that
    lies between candidates, which a later one or the polish (tasks
    moved earlier) can still find.
    """
    starts = plan.starts()
    lengths = {task.id: task.length for task in problem.tasks}
    ends = sorted({start + lengths[name] for name, start in starts.items()})
    found: dict[str, list[int]] = {}
    for name, domain in narrowed.items():
        if domain.empty or domain.latest - domain.earliest + 1 <= DENSE_STARTS:
            continue
        low, high = domain.earliest, domain.latest
        points = {low, high}
        if name in starts:
            points.add(starts[name])
        points.update(ends)
        for prec in problem.precedences:
            gap = lengths[prec.before] + prec.offset
            if prec.after == name and prec.before in starts:
                points.add(starts[prec.before] + gap)
            elif prec.before == name and prec.after in starts:
                points.add(starts[prec.after] - gap)
        stride = max(1, (high - low) // GRID_STARTS)
        points.update(range(low, high, stride))
        found[name] = sorted(p for p in points if low <= p <= high)
    return found
