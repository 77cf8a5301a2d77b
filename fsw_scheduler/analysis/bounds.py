"""Optimality proofs for start plans that leave tasks out (pure).

:func:`at_lower_bound` proves a start plan
optimal when every task is at its earliest start. Many plans of problems
with a scarce consumable have that shape except that some tasks are left
out: no plan can start anything sooner, and the question is only whether
another choice of tasks to keep leaves less out. :func:`kept_set_plan`
answers it with a relaxation that needs no solver:

* every kept task is placed at its earliest start for the delay it
  costs (no plan starts it sooner);
* for each consumable, the level must stay ``>= 0`` at each checkpoint
  when consumers run as *late* as their domains allow and generators as
  *early* (any real placement consumes at least as much and generates at
  most as much by then, and a capacity only lowers a level);
* precedence scopes hold (``both``: both or neither; ``at_least_first``:
  the later one needs the earlier one);
* binary and multiple resources hold only as energy: over an interval,
  the kept users' least overlaps with it, by amount, within capacity
  times its length (:mod:`.energetic`; a search that runs out of nodes
  with those rows is run again without them, as it was before them).

Every valid plan keeps a set of tasks that the relaxation accepts, at a
cost no lower than the relaxed one. If no accepted set costs less than the
start plan, the start plan is optimal. A depth-first search over kept sets
decides it, bounded by :data:`MAX_NODES` (beyond it: no proof, the solver
decides). On the paper campaign's consumable problems this proves 4 of
the 7 at 15 tasks that used to need CBC (each ~0.1-0.3 s there).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import msgspec

from ..model import groups
from ..model.plan import Activity, Plan, SolveStatus
from .check import check_plan
from .domains import start_domains
from .greedy import greedy_plan, unplaced
from .keptset import KeptSetSearch, energy, finished
from .sequencing import job, machine_delay, machines
from .supply import charges_a_store

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence, Set

    from ..model.problem import Problem
    from .domains import Domain
    from .keptset import Nogood, Rows

#: Search nodes after which :func:`kept_set_plan` gives up (no proof).
#: At 15 tasks the proofs it finds take well under 1 000 nodes; a cap keeps
#: hundreds of tasks from costing more than the solve it would spare
#: (:data:`~.keptset.MAX_WORK` caps parts with many rows sooner). It was
#: 20,000: a replan of the replan suite's seed 47 r30-h1440-0 (29 tasks, the
#: start leaving out 12) ran out in 0.04 s, so the solve went on with
#: no bound, no readmission and the start plan's 12 left out (4,129,758
#: at the end of its 2 s); with 100,000 the bound and its plan (9 left
#: out) came in 0.06 s and the replan proved the optimum, 3,767,014. No
#: part of the 105 problems of 15 tasks of seeds 98-99 ran out at 20,000.
MAX_NODES = 100_000


class KeptSetProof(NamedTuple):
    """What the kept-set relaxation says of a start plan.

    Attributes
    ----------
    plan
        An optimal plan (the start plan, or a better one every kept task
        of which starts at its earliest), None when none is proved.
    bound
        A lower bound on the objective of every plan at least as good as
        the start plan (the relaxed optimum, or the start plan's own
        objective when nothing relaxed costs less); None when the search
        stopped at its budget.
    better
        When no plan is proved: a valid plan better than the start plan,
        list-scheduled on the relaxed optimum's kept set, if there is one.
    kept
        When no plan is proved and the relaxation has rows (consumables,
        overloaded resources):
        the relaxed optimum's kept set, which :func:`better_start`
        list-schedules without searching again (None otherwise).
    floor
        When no plan is proved and tasks share machines: the relaxation
        that also prices the delay each machine's kept tasks cannot
        avoid (:mod:`.sequencing`), a lower bound on every plan at least
        as good as the start plan, at least ``bound``; None when it is
        ``bound`` or its search ran out. The start caps
        (:func:`delay_caps`) read it for the tasks on no machine only,
        and ``bound`` for the others: ``floor`` counts a machine's delay
        once for all its tasks.
    """

    plan: Plan | None
    bound: int | None
    better: Plan | None = None
    kept: frozenset[str] | None = None
    floor: int | None = None

    @property
    def lowest(self) -> int | None:
        """The best lower bound known: :attr:`floor`, else :attr:`bound`."""
        return self.floor if self.floor is not None else self.bound


def kept_set_plan(
    problem: Problem,
    plan: Plan,
    domains: Mapping[str, Domain],
    max_nodes: int = MAX_NODES,
    *,
    list_scheduled: bool = True,
    stop: Callable[[], bool] | None = None,
    nogoods: Sequence[Nogood] = (),
) -> KeptSetProof:
    """An optimal plan proved by the kept-set relaxation, if there is one.

    The search finds the relaxed optimum: the kept set of least relaxed
    cost. If that is no lower than ``plan``'s, ``plan`` is optimal; if it
    is lower and the set, every task at its earliest start, passes the
    checker, that plan reaches the lower bound and is optimal. Either way
    the relaxed optimum bounds every plan (see :func:`delay_caps`).

    Parameters
    ----------
    problem
        A validated problem.
    plan
        A valid plan of ``problem`` with its objective (a start plan).
    domains
        The problem's :func:`~fsw_scheduler.analysis.domains.start_domains`.
    max_nodes
        Search nodes before giving up.
    list_scheduled
        Whether to list-schedule the relaxed optimum's set into a better
        start (``better``) when nothing is proved (see
        :func:`kept_set_bound`).
    stop
        Asked every :data:`~.keptset.STOP_EVERY` nodes; True ends the
        search as if its nodes were spent (no bound). The caller's
        deadline: the nodes alone took a second on 150 tasks, past a 1 s
        limit.
    nogoods
        Choices no plan makes (see :class:`~.keptset.KeptSetSearch`):
        the relaxed optimum makes none of them.

    Returns
    -------
    KeptSetProof
        The optimal plan (status ``optimal``) if proved, and the bound.
    """
    if plan.objective is None:
        # Changing capacities are read at their peak (the energy rows) and
        # external rates as they add up (the level rows), and a group's
        # cost is shared among each option's tasks (:func:`~.keptset.
        # keep_values`): relaxations still.
        return KeptSetProof(None, None)
    rows = energy(problem, domains)
    search = finished(
        problem,
        domains,
        plan.objective.total,
        max_nodes,
        stop,
        rows,
        nogoods=nogoods,
    )
    if search is None:
        return KeptSetProof(None, None)
    if search.best is None:
        return KeptSetProof(
            plan.replace(status=SolveStatus.OPTIMAL), search.best_cost
        )
    proved = _at_earliest(problem, domains, search.best, search.best_cost)
    if proved is not None:
        return KeptSetProof(proved, search.best_cost)
    floor = _sequenced(
        problem,
        domains,
        plan.objective.total,
        search,
        max_nodes,
        stop,
        rows,
        nogoods,
    )
    if floor is not None and floor.best is None:
        # No kept set, its machines sequenced, costs less: the start
        # plan is optimal.
        return KeptSetProof(
            plan.replace(status=SolveStatus.OPTIMAL),
            search.best_cost,
            floor=plan.objective.total,
        )
    # No row (no consumable, no overloaded resource): the relaxed set is
    # every task the scopes let keep, which the start heuristic has
    # already tried to place (on the paper's multiple class this cost
    # 9 ms a solve, for nothing).
    kept = frozenset(search.best) if search.limits else None
    found = KeptSetProof(
        None,
        search.best_cost,
        kept=kept,
        floor=None if floor is None else floor.best_cost,
    )
    if not list_scheduled:
        return found
    return found._replace(better=better_start(problem, plan, found, stop=stop))


def proved_by(proof: KeptSetProof) -> str:
    """What proved :attr:`KeptSetProof.plan` optimal, for a status."""
    if proof.floor is not None:
        return (
            "no choice of tasks to keep costs less, with the tasks sharing "
            "each machine sequenced"
        )
    return (
        "every kept task at its earliest start, and no other choice of "
        "tasks to keep costs less"
    )


def _sequenced(
    problem: Problem,
    domains: Mapping[str, Domain],
    cutoff: int,
    relaxed: KeptSetSearch,
    max_nodes: int,
    stop: Callable[[], bool] | None,
    rows: Rows,
    nogoods: Sequence[Nogood] = (),
) -> KeptSetSearch | None:
    """The kept-set search with the machines' delay (:mod:`.sequencing`),
    run to its end, or None where it cannot raise the bound.

    It is run only when the relaxed optimum's own tasks cannot all start
    at their earliest on their machines: otherwise that set, at no more
    cost, is its optimum too. Seed 1111 of ``tools/fuzz --large`` (36
    tasks, one camera with long tasks): the whole gap of the start plan
    (2,078 above the relaxed optimum) is the camera's sequencing, of
    which this prices 1,350.
    """
    found = machines(problem, domains)
    if not found or relaxed.best is None:
        return None
    tasks = {t.id: t for t in problem.tasks}
    if not any(
        machine_delay(
            [job(tasks[n], domains) for n in names if n in relaxed.best]
        )
        for names in found
    ):
        return None
    search = KeptSetSearch(
        problem, domains, cutoff, energy=rows, machines=found, nogoods=nogoods
    )
    return search if search.run(max_nodes, stop) else None


def better_start(
    problem: Problem,
    plan: Plan,
    proof: KeptSetProof,
    stop: Callable[[], bool] | None = None,
) -> Plan | None:
    """A valid plan better than ``plan``, list-scheduled on the relaxed
    optimum's kept set of ``proof`` (:attr:`KeptSetProof.kept`), if
    there is one: what :func:`kept_set_plan` gives as ``better``, for a
    caller that asked :func:`kept_set_bound` first (no second search).
    ``stop`` is passed on to the list scheduler (on 6 tasks over H =
    100,000 it took 6 s of a 1 s limit without one)."""
    if plan.objective is None:
        return None
    better = min(
        kept_set_starts(problem, proof, stop),
        key=lambda p: p.objective.total if p.objective else 0,
        default=None,
    )
    if (
        better is None
        or better.objective is None
        or better.objective.total >= plan.objective.total
    ):
        return None
    return better


def kept_set_starts(
    problem: Problem,
    proof: KeptSetProof,
    stop: Callable[[], bool] | None = None,
    *,
    thorough: bool = False,
) -> list[Plan]:
    """The valid plans list scheduling finds on the relaxed optimum's
    kept set of ``proof`` (none without one), in the order tried.

    The kept tasks are made mandatory (the start heuristic then places
    the supplies the consumers need first); when no rule places them
    all, only their supplies. ``thorough`` (a large part, whose start
    plan took as long) tries two more: when neither places the set, the
    tasks a rule could not place let go (:func:`_released`); and every
    kept task optional. Those two doubled the time of a small part's
    call (4 to 8 ms on 15 tasks) for no better plan on seed 210's
    15-task campaigns, hence only there.
    """
    if proof.kept is None:
        return []
    found = [_scheduled(problem, proof.kept, stop)]
    if found[0] is None and _supplies(problem, proof.kept):
        found.append(_scheduled(problem, proof.kept, stop, supplies_only=True))
    if thorough and not any(found):
        found.append(_released(problem, proof.kept, stop))
    if thorough:
        # Every kept task optional: the heuristic on the relaxed
        # optimum's tasks alone. The large suite's f60-h2880 of seed 210:
        # 26.60 M where the kept tasks made mandatory gave 29.25 M (the
        # start 30.29 M).
        found.append(
            _scheduled(problem, proof.kept, stop, released=proof.kept)
        )
    return [p for p in found if p is not None and p.objective is not None]


def kept_only(
    problem: Problem,
    kept: Set[str],
    *,
    supplies_only: bool = False,
    released: Set[str] = frozenset(),
) -> Problem:
    """``problem`` with only the tasks ``kept``, each made mandatory.

    Its plans, with the other tasks left out, are plans of ``problem``
    when the relaxation accepts ``kept`` (leaving the others out breaks
    no precedence scope): see :func:`widened`. Every kept task is made
    mandatory: the start heuristic then places generators before the
    consumers that need them (its supply-first rule) rather than leaving
    out a consumer the charge would carry. With ``supplies_only``, only
    the kept tasks that put into a consumable (:func:`_supplies`) are
    made mandatory, and the others may still be left out; the tasks
    ``released`` keep their own schedule cost (optional, as in
    ``problem``) either way.
    """
    forced = (_supplies(problem, kept) if supplies_only else kept) - released
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(t, schedule_cost=0)
            if t.id in forced
            else t
            for t in problem.tasks
            if t.id in kept
        ),
        precedences=tuple(
            p
            for p in problem.precedences
            if p.before in kept and p.after in kept
        ),
    )


def widened(problem: Problem, plan: Plan) -> Plan | None:
    """A plan of :func:`kept_only` as a plan of ``problem``.

    Every task the plan does not schedule is left out; None when the
    checker refuses the result on ``problem``.
    """
    starts = plan.starts()
    plan = plan.replace(
        objective=None,
        status=SolveStatus.FEASIBLE,
        why=(),
        stats=None,
        unscheduled=tuple(t.id for t in problem.tasks if t.id not in starts),
        # The options the plan holds, of ``problem``'s groups (a plan of
        # kept_only's problem names those of its own, or none).
        chosen=groups.chosen(problem, starts),
    )
    report = check_plan(problem, plan)
    if not report.ok:
        return None
    return plan.replace(objective=report.objective)


def _scheduled(
    problem: Problem,
    kept: Set[str],
    stop: Callable[[], bool] | None = None,
    *,
    supplies_only: bool = False,
    released: Set[str] = frozenset(),
) -> Plan | None:
    """The start plan heuristic on ``kept`` alone, the rest left out
    (:func:`kept_only`)."""
    plan = greedy_plan(
        kept_only(
            problem, kept, supplies_only=supplies_only, released=released
        ),
        stop=stop,
        # With every kept task mandatory, "the forced tasks alone" is the
        # same problem again (0.3 s lost on a 45-task day).
        apart=supplies_only or bool(released),
    )
    if plan is None:
        return None
    return widened(problem, plan)


#: Sets of tasks :func:`_released` tries to let go, at most.
RELEASED_TRIED = 3


def _released(
    problem: Problem, kept: Set[str], stop: Callable[[], bool] | None
) -> Plan | None:
    """A plan of ``kept`` when no rule places it whole: the tasks one
    rule's pass could not place (:func:`~.greedy.unplaced`) made optional
    again, the smallest such set first, up to :data:`RELEASED_TRIED`
    sets; the first that gives a plan.

    The large suite's b60-h1440 of seed 210 (60 tasks): the relaxed
    optimum kept the 52 tasks CP-SAT's plan keeps (5.51 M), no rule
    placed them all (a charger with a narrow window, a long camera
    task), and the start stayed the heuristic's 16.45 M (22 left out);
    the deadline rule placed all but two, and with those two optional
    the start is 7.99 M. A set that fails costs a whole heuristic run
    (0.3-1.2 s on 45 tasks over H = 2,880), hence the first found ends
    it, and no plan of the forced tasks apart is tried.
    """
    whole = kept_only(problem, kept)
    for names in unplaced(whole, stop=stop)[:RELEASED_TRIED]:
        plan = greedy_plan(
            kept_only(problem, kept, released=names), stop=stop, apart=False
        )
        if plan is not None:
            return widened(problem, plan)
    return None


def _supplies(problem: Problem, kept: Set[str]) -> set[str]:
    """The tasks of ``kept`` that put into a consumable (a negative use).

    When the relaxed optimum's set does not list-schedule whole (its
    relaxation is optimistic), the start heuristic is run on it again
    with only these made mandatory: left optional, a generator with an
    early window lost its camera to a long task worth more, and every
    consumer it feeds went with it. The large suite's b45-h1440 of seed
    197: the start plan left out 13 tasks (8.83 M), 20 s of search 15
    units of schedule cost (2.64 M); the kept set with its supplies
    placed first leaves out 4 (2.24 M) in 0.09 s.
    """
    return {
        t.id
        for t in problem.tasks
        if t.id in kept and charges_a_store(problem, t)
    }


def _at_earliest(
    problem: Problem, domains: Mapping[str, Domain], kept: set[str], cost: int
) -> Plan | None:
    """``kept`` at their earliest starts, if valid and of cost ``cost``."""
    starts = Plan(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=tuple(
            sorted(
                (
                    Activity(
                        task.id,
                        domains[task.id].earliest,
                        domains[task.id].earliest + task.length,
                    )
                    for task in problem.tasks
                    if task.id in kept
                ),
                key=lambda a: (a.start, a.task),
            )
        ),
    )
    plan = widened(problem, starts)
    if plan is None or plan.objective is None:
        return None
    if plan.objective.total != cost:
        return None  # cannot happen: the relaxed cost is the real one
    return plan.replace(status=SolveStatus.OPTIMAL)


def delay_caps(
    problem: Problem,
    domains: Mapping[str, Domain],
    cutoff: int,
    bound: int,
    floor: int | None = None,
) -> dict[str, int]:
    """Latest starts that every plan of cost at most ``cutoff`` keeps.

    A plan's cost is its kept set's relaxed cost, at least ``bound``,
    plus ``d (s - e)`` for each kept task started at ``s`` after its
    earliest start ``e``. So no task of delay cost ``d`` starts after
    ``e + (cutoff - bound) // d`` in a plan of cost at most ``cutoff``.
    With ``floor`` the same holds of it for a task on no machine
    (:func:`~.sequencing.machines`): the floor prices its kept set with
    each machine's delay, and that task's own delay is no machine's.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its start domains.
    cutoff
        The cost of a known plan (the start plan's objective, or a
        better plan's).
    bound
        :attr:`KeptSetProof.bound` for that plan.
    floor
        :attr:`KeptSetProof.floor` for that plan, or None.

    Returns
    -------
    dict[str, int]
        Task id to latest start, for placeable tasks with a delay cost.
    """
    slack = max(0, cutoff - bound)
    free_slack = slack
    on_machines: set[str] = set()
    if floor is not None:
        free_slack = min(slack, max(0, cutoff - floor))
        on_machines = {
            n for names in machines(problem, domains) for n in names
        }
    return {
        task.id: domains[task.id].earliest
        + (slack if task.id in on_machines else free_slack) // task.delay_cost
        for task in problem.tasks
        if task.delay_cost > 0 and not domains[task.id].empty
    }


class Fixings(NamedTuple):
    """What the relaxation proves of each task, for the model.

    Attributes
    ----------
    dropped
        Tasks that no plan of cost at most the cutoff keeps.
    caps
        Latest starts (as :func:`delay_caps`, per task where its own bound
        is higher).
    """

    dropped: frozenset[str]
    caps: dict[str, int]


def fixings(
    problem: Problem,
    domains: Mapping[str, Domain],
    cutoff: int,
    proof: KeptSetProof,
    max_nodes: int = MAX_NODES,
    stop: Callable[[], bool] | None = None,
) -> Fixings | None:
    """Per-task consequences of the relaxation for plans of cost at most
    ``cutoff``.

    For each task the relaxed optimum leaves out, the search is run
    again with the task kept: if no kept set under ``cutoff`` holds it,
    no plan that good does, and the model can leave it out; else its own
    relaxed bound gives it a tighter cap than :func:`delay_caps`.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its start domains.
    cutoff
        The cost of a known valid plan.
    proof
        :func:`kept_set_plan`'s result for that plan (with a bound).
    max_nodes
        Search nodes per task before giving up on it (no fixing for it).
    stop
        Asked before each task's search and every :data:`~.keptset.STOP_EVERY`
        nodes: True ends the searches, and the fixings found so far are
        returned (each holds alone). A caller's deadline: a 45-task part
        with many tasks left out ran 15 searches, 179,000 nodes, about
        3 s, inside a replan of 2 s.

    Returns
    -------
    Fixings or None
        None without a bound.
    """
    if proof.bound is None:
        return None
    caps = delay_caps(problem, domains, cutoff, proof.bound, proof.floor)
    # The energy rows are the same for every search here: read once (6-19
    # ms each on parts of 50-60 tasks, and a search per left-out task).
    rows = energy(problem, domains)
    relaxed = finished(problem, domains, cutoff + 1, max_nodes, stop, rows)
    if relaxed is None or relaxed.best is None:
        return Fixings(frozenset(), caps)
    dropped = set()
    for task in problem.tasks:
        if task.id in relaxed.best or domains[task.id].empty:
            continue
        if stop is not None and stop():
            break
        search = finished(
            problem,
            domains,
            cutoff + 1,
            max_nodes,
            stop,
            rows,
            (task.id, True),
        )
        if search is None:
            continue
        if search.best is None:
            dropped.add(task.id)
        elif task.delay_cost > 0:
            slack = max(0, cutoff - search.best_cost)
            caps[task.id] = min(
                caps[task.id],
                domains[task.id].earliest + slack // task.delay_cost,
            )
    return Fixings(frozenset(dropped), caps)


def kept_set_bound(
    problem: Problem,
    plan: Plan,
    domains: Mapping[str, Domain],
    max_nodes: int = MAX_NODES,
    stop: Callable[[], bool] | None = None,
    nogoods: Sequence[Nogood] = (),
) -> KeptSetProof:
    """:func:`kept_set_plan` without its list-scheduled plan.

    :func:`kept_set_plan` also list-schedules the relaxed optimum's set
    when it proves nothing (``better``), which takes as long as the start
    plan did: seconds on parts of 50 tasks (3.6 of the 3.9 s it took on
    one). A caller that needs the proof and the bound alone (a large
    part's neighbourhood search, which improves its own incumbent) asks
    for this: ``better`` is always None (:func:`better_start` gives it
    from this proof, without a second search).
    """
    return kept_set_plan(
        problem,
        plan,
        domains,
        max_nodes,
        list_scheduled=False,
        stop=stop,
        nogoods=nogoods,
    )


def at_lower_bound(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain] | None = None,
) -> bool:
    """True if ``plan`` is optimal by a bound that needs no solver.

    When every task is scheduled at the earliest start its domain allows
    (windows, horizon and precedences: :func:`start_domains`, computed
    unless given as ``domains``), or left out because its domain is empty
    (no plan can hold it), no plan can leave less out or start anything
    sooner, so the plan is optimal. (The second case spared the solver on
    13 of the 69 parts of the broad campaign that needed one.)
    """
    if domains is None:
        domains = start_domains(problem)
    starts = plan.starts()
    return all(
        domains[task.id].empty
        if task.id not in starts
        else starts[task.id] == domains[task.id].earliest
        for task in problem.tasks
    )
