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

from ..model.plan import Activity, Plan, SolveStatus, objective_weight
from .check import check_plan
from .domains import start_domains
from .energetic import energy_rows
from .greedy import greedy_plan

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Set

    from ..model.problem import Problem, Task
    from .domains import Domain

#: Search nodes after which :func:`kept_set_plan` gives up (no proof).
#: At 15 tasks the proofs it finds take well under 1 000 nodes; a cap keeps
#: hundreds of tasks from costing more than the solve it would spare
#: (:data:`MAX_WORK` caps parts with many rows sooner). It was 20,000:
#: a replan of the replan suite's seed 47 r30-h1440-0 (29 tasks, the
#: start leaving out 12) ran out in 0.04 s, so the solve went on with
#: no bound, no readmission and the start plan's 12 left out (4,129,758
#: at the end of its 2 s); with 100,000 the bound and its plan (9 left
#: out) came in 0.06 s and the replan proved the optimum, 3,767,014. No
#: part of the 105 problems of 15 tasks of seeds 98-99 ran out at 20,000.
MAX_NODES = 100_000

#: Nodes between two questions to a search's ``stop`` (about 20 ms).
STOP_EVERY = 1_024

#: Row entries the search may touch in all (nodes times rows), so that a
#: part with many tasks and checkpoints gives up within milliseconds.
MAX_WORK = 400_000

#: Parts with more placeable tasks are not searched (the recursion is one
#: level per task).
MAX_TASKS = 200

_EPS = 1e-9


def _units(task: Task, start: int, point: int) -> int:
    """Units of ``task`` started at ``start`` run in ``[start, point]``."""
    return max(0, min(point - start + 1, task.length))


def _checkpoints(
    problem: Problem,
    domains: Mapping[str, Domain],
    users: list[tuple[Task, float]],
) -> list[int]:
    """Units at whose end some relaxed level can be lowest.

    With consumers fixed at their latest start and generators at their
    earliest, a level falls only while consumers run and rises only while
    generators do: its minima lie at the last unit of a consumer, the unit
    before a generator starts, or the end of the horizon.
    """
    points = {problem.end - 1}
    for task, amount in users:
        domain = domains[task.id]
        if amount > 0:
            points.add(domain.latest + task.length - 1)
        else:
            points.add(domain.earliest - 1)
    return sorted(p for p in points if problem.start <= p < problem.end)


def level_rows(
    problem: Problem, domains: Mapping[str, Domain], kept: list[Task]
) -> tuple[dict[str, list[float]], list[float]]:
    """Relaxed level rows: each task's use by each checkpoint, and limits.

    Returns the use per task id (one entry per row, of every consumable
    together) and each row's limit: the initial level with the external
    rate's net change up to the checkpoint (a level never ends above
    what was put in, the ceiling only takes away, so the tasks' net use
    by then is within that). Consumables that the tasks cannot exhaust,
    even drained, get no row.
    """
    uses: dict[str, list[float]] = {task.id: [] for task in kept}
    limits: list[float] = []
    res = problem.resources
    for name, initial in res.initial_levels.items():
        users = [
            (task, task.uses[name])
            for task in kept
            if task.uses.get(name, 0) != 0
        ]
        before = res.external_before(name, problem.start, problem.horizon)
        if (
            sum(a * t.length for t, a in users if a > 0)
            <= initial + min(before) + _EPS
        ):
            continue
        for point in _checkpoints(problem, domains, users):
            limits.append(initial + before[point + 1 - problem.start])
            for task in kept:
                amount = task.uses.get(name, 0)
                domain = domains[task.id]
                start = domain.latest if amount > 0 else domain.earliest
                uses[task.id].append(amount * _units(task, start, point))
    return uses, limits


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
    """

    plan: Plan | None
    bound: int | None
    better: Plan | None = None
    kept: frozenset[str] | None = None


def kept_set_plan(
    problem: Problem,
    plan: Plan,
    domains: Mapping[str, Domain],
    max_nodes: int = MAX_NODES,
    *,
    list_scheduled: bool = True,
    stop: Callable[[], bool] | None = None,
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
        Asked every :data:`STOP_EVERY` nodes; True ends the search as if
        its nodes were spent (no bound). The caller's deadline: the
        nodes alone took a second on 150 tasks, past a 1 s limit.

    Returns
    -------
    KeptSetProof
        The optimal plan (status ``optimal``) if proved, and the bound.
    """
    if plan.objective is None or problem.alternatives:
        # The relaxation prices tasks one by one: a group's choice is the
        # solver's to decide. Changing capacities are read at their peak
        # (the energy rows) and external rates as they add up (the level
        # rows), both relaxations still.
        return KeptSetProof(None, None)
    search = _finished(
        problem,
        domains,
        plan.objective.total,
        max_nodes,
        stop,
        _energy(problem, domains),
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
    # No row (no consumable, no overloaded resource): the relaxed set is
    # every task the scopes let keep, which the start heuristic has
    # already tried to place (on the paper's multiple class this cost
    # 9 ms a solve, for nothing).
    kept = frozenset(search.best) if search.limits else None
    found = KeptSetProof(None, search.best_cost, kept=kept)
    if not list_scheduled:
        return found
    return found._replace(better=better_start(problem, plan, found, stop=stop))


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
    if proof.kept is None or plan.objective is None:
        return None
    better = _scheduled(problem, proof.kept, stop)
    if (
        better is None
        or better.objective is None
        or better.objective.total >= plan.objective.total
    ):
        return None
    return better


def kept_only(problem: Problem, kept: Set[str]) -> Problem:
    """``problem`` with only the tasks ``kept``, each made mandatory.

    Its plans, with the other tasks left out, are plans of ``problem``
    when the relaxation accepts ``kept`` (leaving the others out breaks
    no precedence scope): see :func:`widened`. Every kept task is made
    mandatory: the start heuristic then places generators before the
    consumers that need them (its supply-first rule) rather than leaving
    out a consumer the charge would carry.
    """
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(t, schedule_cost=0)
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
    plan = plan.replace(
        objective=None,
        status=SolveStatus.FEASIBLE,
        why=(),
        stats=None,
        unscheduled=tuple(
            t.id for t in problem.tasks if t.id not in plan.starts()
        ),
    )
    report = check_plan(problem, plan)
    if not report.ok:
        return None
    return plan.replace(objective=report.objective)


def _scheduled(
    problem: Problem, kept: Set[str], stop: Callable[[], bool] | None = None
) -> Plan | None:
    """The start plan heuristic on ``kept`` alone, the rest left out."""
    plan = greedy_plan(kept_only(problem, kept), stop=stop)
    if plan is None:
        return None
    return widened(problem, plan)


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
) -> dict[str, int]:
    """Latest starts that every plan of cost at most ``cutoff`` keeps.

    A plan's cost is its kept set's relaxed cost, at least ``bound``,
    plus ``d (s - e)`` for each kept task started at ``s`` after its
    earliest start ``e``. So no task of delay cost ``d`` starts after
    ``e + (cutoff - bound) // d`` in a plan of cost at most ``cutoff``.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its start domains.
    cutoff
        The cost of a known plan (the start plan's objective).
    bound
        :attr:`KeptSetProof.bound` for that plan.

    Returns
    -------
    dict[str, int]
        Task id to latest start, for placeable tasks with a delay cost.
    """
    slack = max(0, cutoff - bound)
    return {
        task.id: domains[task.id].earliest + slack // task.delay_cost
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
        Asked before each task's search and every :data:`STOP_EVERY`
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
    caps = delay_caps(problem, domains, cutoff, proof.bound)
    # The energy rows are the same for every search here: read once (6-19
    # ms each on parts of 50-60 tasks, and a search per left-out task).
    energy = _energy(problem, domains)
    relaxed = _finished(problem, domains, cutoff + 1, max_nodes, stop, energy)
    if relaxed is None or relaxed.best is None:
        return Fixings(frozenset(), caps)
    dropped = set()
    for task in problem.tasks:
        if task.id in relaxed.best or domains[task.id].empty:
            continue
        if stop is not None and stop():
            break
        search = _finished(
            problem,
            domains,
            cutoff + 1,
            max_nodes,
            stop,
            energy,
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


_Rows = tuple[dict[str, list[float]], list[float]]


def _energy(problem: Problem, domains: Mapping[str, Domain]) -> _Rows:
    """The energy rows over the placeable tasks (:func:`~.energetic.
    energy_rows`; a capacity that changes over time read at its peak)."""
    placeable = [t for t in problem.tasks if not domains[t.id].empty]
    return energy_rows(problem, domains, placeable)


def _finished(
    problem: Problem,
    domains: Mapping[str, Domain],
    cutoff: int,
    max_nodes: int,
    stop: Callable[[], bool] | None,
    energy: _Rows,
    force: tuple[str, bool] | None = None,
) -> _KeptSetSearch | None:
    """A kept-set search run to its end, or None when it ran out.

    With the ``energy`` rows (:func:`_energy`) first; a search that runs
    out of nodes with them (each node copies every row, so its node
    budget shrinks with them) and has any runs again without them. Seed
    63's b45-h1440 of the large suite: 7,505,611 without the rows, out
    of nodes with them.
    """
    search = _KeptSetSearch(problem, domains, cutoff, force, energy=energy)
    if search.run(max_nodes, stop):
        return search
    if not energy[1]:
        return None
    search = _KeptSetSearch(problem, domains, cutoff, force)
    return search if search.run(max_nodes, stop) else None


class _KeptSetSearch:
    """Branch and bound over kept sets for the relaxed optimum.

    Parameters
    ----------
    problem, domains
        As for :func:`kept_set_plan`.
    cutoff
        Only kept sets of relaxed cost below this are searched for.
    force
        One task's decision imposed (id, kept), or None.
    energy
        Rows added to the consumables' level rows: the energy rows of
        binary and multiple resources (:func:`_energy`); None: none.
    """

    def __init__(
        self,
        problem: Problem,
        domains: Mapping[str, Domain],
        cutoff: int,
        force: tuple[str, bool] | None = None,
        *,
        energy: _Rows | None = None,
    ) -> None:
        weight = objective_weight(
            [t.delay_cost for t in problem.tasks], problem.horizon
        )
        placeable = [t for t in problem.tasks if not domains[t.id].empty]
        self.too_large = len(placeable) > MAX_TASKS
        # Cost of a kept set: weight * (cost of all) - its value.
        self.total = weight * sum(t.schedule_cost for t in problem.tasks)
        value = {
            t.id: weight * t.schedule_cost
            - t.delay_cost * (domains[t.id].earliest - problem.start)
            for t in placeable
        }
        self.need = self.total - cutoff + 1  # value of a better kept set
        uses, self.limits = level_rows(problem, domains, placeable)
        if energy is not None:
            self.limits += energy[1]
            for task_id, row in energy[0].items():
                uses[task_id] = uses[task_id] + row
        # Mandatory tasks are decided first (kept), then by value: leaving
        # out a valuable task drops the bound at once.
        self.order = sorted(
            placeable, key=lambda t: (not t.mandatory, -value[t.id], t.id)
        )
        self.values = [value[t.id] for t in self.order]
        self.uses = [uses[t.id] for t in self.order]
        self.links = self._links(problem)
        num = len(self.order)
        self.rest = [0] * (num + 1)  # best value still to come
        # Generators still undecided can lower each row by this much.
        self.credit = [[0.0] * len(self.limits) for _ in range(num + 1)]
        for k in range(num - 1, -1, -1):
            self.rest[k] = self.rest[k + 1] + max(0, self.values[k])
            self.credit[k] = [
                c + min(0.0, u)
                for c, u in zip(self.credit[k + 1], self.uses[k], strict=True)
            ]
        self._fractional(force)
        self.keep = [False] * num
        self.best: set[str] | None = None
        self.best_cost = cutoff
        #: One task's decision imposed (id, kept), or None.
        self.force = force
        self.nodes_left = 0
        self.out_of_budget = False
        self.stop: Callable[[], bool] | None = None

    def _fractional(self, force: tuple[str, bool] | None) -> None:
        """What :meth:`_knapsack` reads, per row and per depth.

        A task is *held* when every kept set searched keeps it (forced
        kept, or mandatory and not forced out), *barred* when none does
        (forced out), *free* otherwise. For each row: its free tasks of
        positive value that use it, by value per unit used (best first),
        and from each depth on the sums of their values and uses.
        """
        num = len(self.order)
        forced = {} if force is None else {force[0]: force[1]}
        # The imposed decision holds even against a mandatory task.
        self.held = [forced.get(t.id, t.mandatory) for t in self.order]
        barred = [forced.get(t.id) is False for t in self.order]
        free = [
            not h and not b and v > 0
            for h, b, v in zip(self.held, barred, self.values, strict=True)
        ]
        rows = len(self.limits)
        # From depth k on: the held tasks' value and positive uses, and the
        # free tasks' value.
        self.held_value = [0.0] * (num + 1)
        self.held_uses = [[0.0] * rows for _ in range(num + 1)]
        self.free_value = [0.0] * (num + 1)
        for k in range(num - 1, -1, -1):
            uses = self.uses[k]
            self.held_value[k] = self.held_value[k + 1] + (
                self.values[k] if self.held[k] else 0
            )
            self.held_uses[k] = [
                h + (u if self.held[k] and u > 0 else 0.0)
                for h, u in zip(self.held_uses[k + 1], uses, strict=True)
            ]
            self.free_value[k] = self.free_value[k + 1] + (
                self.values[k] if free[k] else 0
            )
        self.by_ratio: list[list[int]] = []
        self.user_value: list[list[float]] = []
        self.user_use: list[list[float]] = []
        for r in range(rows):
            users = [
                k for k in range(num) if free[k] and self.uses[k][r] > _EPS
            ]
            ratio = {k: self.values[k] / self.uses[k][r] for k in users}
            users.sort(key=lambda k: (-ratio[k], k))
            self.by_ratio.append(users)
            value = [0.0] * (num + 1)
            use = [0.0] * (num + 1)
            user = set(users)
            for k in range(num - 1, -1, -1):
                value[k] = value[k + 1] + (self.values[k] if k in user else 0)
                use[k] = use[k + 1] + (self.uses[k][r] if k in user else 0)
            self.user_value.append(value)
            self.user_use.append(use)
        self.row_order = list(range(rows))
        self._after: dict[tuple[int, int], list[int]] = {}

    def _knapsack(self, k: int, got: int, rows: list[float]) -> bool:
        """True when no kept set extending the first ``k`` decisions can
        reach :attr:`need`, by one row's fractional knapsack.

        Row by row: the held tasks still to decide are kept, every free
        task that does not use the row is kept, the undecided generators
        lend the row all they can (its credit), and the free users fill
        what is left best value per unit first, the last one in part.
        That bounds the value of every kept set the row allows (the
        precedences are dropped), so the least over the rows bounds it
        too. The sum of positive values alone (the test before this one)
        ignores the rows, and on a replan's narrowing left 40,000 nodes
        per task to search.
        """
        base = got + self.held_value[k]
        free = self.free_value[k]
        credit = self.credit[k]
        held = self.held_uses[k]
        need = self.need
        values, uses = self.values, self.uses
        for r in self.row_order:
            room = self.limits[r] - rows[r] - credit[r] - held[r]
            if room < -_EPS:
                return True
            if self.user_use[r][k] <= room + _EPS:
                continue  # the row holds all its users: no cut
            value = base + free - self.user_value[r][k]
            for j in self._undecided(r, k):
                use = uses[j][r]
                if use <= room:
                    room -= use
                    value += values[j]
                else:
                    value += values[j] * room / use
                    break
            if value < need - _EPS:
                if r != self.row_order[0]:
                    # The row that cut is asked first at the next node:
                    # neighbouring nodes are cut by the same row.
                    self.row_order.remove(r)
                    self.row_order.insert(0, r)
                return True
        return False

    def _undecided(self, r: int, k: int) -> list[int]:
        """Row ``r``'s free users from depth ``k`` on, best value per unit
        first (each list built once)."""
        key = (r, k)
        users = self._after.get(key)
        if users is None:
            users = [j for j in self.by_ratio[r] if j >= k]
            self._after[key] = users
        return users

    def _links(self, problem: Problem) -> list[list[tuple[int, bool, bool]]]:
        """Precedence scopes, at the later decided task of each pair.

        Each entry is ``(other, both, is_after)``: ``other`` the earlier
        decided task (-1: one that is never kept), ``both`` the scope,
        ``is_after`` whether the task holding the entry is the later one
        of the precedence.
        """
        index = {t.id: k for k, t in enumerate(self.order)}
        links: list[list[tuple[int, bool, bool]]] = [[] for _ in self.order]
        for prec in problem.precedences:
            a, b = index.get(prec.before), index.get(prec.after)
            if b is None:
                if a is not None and prec.scope == "both":
                    links[a].append((-1, True, True))  # a is never kept
                continue
            if a is None:
                links[b].append((-1, True, True))  # b needs a: never kept
                continue
            first, second = min(a, b), max(a, b)
            links[second].append((first, prec.scope == "both", second == b))
        return links

    def _allowed(self, k: int, kept: bool) -> bool:
        keep = self.keep
        for other, both, is_after in self.links[k]:
            if other < 0:
                if kept:
                    return False
            elif both:
                if keep[other] != kept:
                    return False
            elif is_after:
                if kept and not keep[other]:
                    return False
            elif keep[other] and not kept:
                return False
        return True

    def run(
        self, max_nodes: int, stop: Callable[[], bool] | None = None
    ) -> bool:
        """Search; True if it finished within ``max_nodes`` (and before
        ``stop``, asked every :data:`STOP_EVERY` nodes, said True).

        :attr:`best` is then the kept set of least relaxed cost under the
        cutoff, or None when there is none.
        """
        if self.too_large or (stop is not None and stop()):
            return False
        # Each node copies the rows: bound the work, not only the nodes.
        self.nodes_left = min(max_nodes, MAX_WORK // (len(self.limits) + 1))
        self.stop = stop
        self.out_of_budget = False
        self._search(0, 0, [0.0] * len(self.limits))
        return not self.out_of_budget

    def _search(self, k: int, got: int, rows: list[float]) -> bool:
        """Explore kept sets extending the first ``k`` decisions; False
        when the node budget is spent."""
        self.nodes_left -= 1
        if self.nodes_left < 0 or (
            self.stop is not None
            and self.nodes_left % STOP_EVERY == 0
            and self.stop()
        ):
            self.out_of_budget = True
            return False
        if got + self.rest[k] < self.need:
            return True
        if k < len(self.order) and self._knapsack(k, got, rows):
            return True
        credit = self.credit[k]
        if any(
            r + c > lim + _EPS
            for r, c, lim in zip(rows, credit, self.limits, strict=True)
        ):
            return True
        if k == len(self.order):
            # A better kept set: remember it, and look for better still.
            self.best = {
                t.id for t, kept in zip(self.order, self.keep) if kept
            }
            self.best_cost = self.total - got
            self.need = got + 1
            return True
        task = self.order[k]
        if self.force is not None and self.force[0] == task.id:
            choices: tuple[bool, ...] = (self.force[1],)
        elif task.mandatory:
            choices = (True,)
        else:
            choices = (True, False)
        for kept in choices:
            if not self._allowed(k, kept):
                continue
            self.keep[k] = kept
            if kept:
                grown = [
                    r + u for r, u in zip(rows, self.uses[k], strict=True)
                ]
                done = self._search(k + 1, got + self.values[k], grown)
            else:
                done = self._search(k + 1, got, rows)
            if not done:
                return False
        return True


def kept_set_bound(
    problem: Problem,
    plan: Plan,
    domains: Mapping[str, Domain],
    max_nodes: int = MAX_NODES,
    stop: Callable[[], bool] | None = None,
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
        problem, plan, domains, max_nodes, list_scheduled=False, stop=stop
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
