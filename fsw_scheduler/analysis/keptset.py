"""The depth-first search over kept sets behind the kept-set proofs (pure).

:class:`KeptSetSearch` finds the cheapest set of tasks to keep under the
relaxation of :mod:`.bounds`: every kept task at its earliest start, each
consumable's level rows (:func:`level_rows`: consumers as late as their
domains allow, generators as early), the energy rows of binary and
multiple resources (:func:`energy`), the precedence scopes and the pairs
no plan holds together (:mod:`.exclusions`). It
decides tasks depth first, mandatory ones and the most valuable first,
and cuts a node when the values still to come, or one row's fractional
knapsack, cannot reach a better set. :func:`finished` runs it to its end
within a node budget.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..model.plan import objective_weight
from .energetic import energy_rows
from .exclusions import exclusive_pairs
from .sequencing import Job, job, machine_delay

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator, Mapping, Sequence

    from ..model.problem import Problem, Task
    from .domains import Domain

#: Nodes between two questions to a search's ``stop`` (about 20 ms).
STOP_EVERY = 1_024

#: Row entries the search may touch in all (nodes times rows), so that a
#: part with many tasks and checkpoints gives up within milliseconds.
#: The rows' knapsacks (:meth:`KeptSetSearch._knapsack`) are not counted:
#: they read each row's undecided users at a node they may cut, and on
#: the large suite's parts of seed 76 took searches that ran out to their
#: end (all the fixings of a 59-task part in 1.5 s, a stop still asked
#: every :data:`STOP_EVERY` nodes).
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


#: Energy rows: each task's entries and the rows' limits.
Rows = tuple[dict[str, list[float]], list[float]]

#: A choice no plan makes: every task of the first set kept and every
#: task of the second left out (:class:`KeptSetSearch`'s ``nogoods``).
Nogood = tuple[frozenset[str], frozenset[str]]


def energy(problem: Problem, domains: Mapping[str, Domain]) -> Rows:
    """The energy rows over the placeable tasks (:func:`~.energetic.
    energy_rows`; a capacity that changes over time read at its peak)."""
    placeable = [t for t in problem.tasks if not domains[t.id].empty]
    return energy_rows(problem, domains, placeable)


def finished(
    problem: Problem,
    domains: Mapping[str, Domain],
    cutoff: int,
    max_nodes: int,
    stop: Callable[[], bool] | None,
    energy: Rows,
    force: tuple[str, bool] | None = None,
    nogoods: Sequence[Nogood] = (),
) -> KeptSetSearch | None:
    """A kept-set search run to its end, or None when it ran out.

    With the ``energy`` rows (:func:`energy`) first; a search that runs
    out of nodes with them (each node copies every row, so its node
    budget shrinks with them) and has any runs again without them. Seed
    63's b45-h1440 of the large suite: 7,505,611 without the rows, out
    of nodes with them.
    """
    search = KeptSetSearch(
        problem, domains, cutoff, force, energy=energy, nogoods=nogoods
    )
    if search.run(max_nodes, stop):
        return search
    if not energy[1]:
        return None
    search = KeptSetSearch(problem, domains, cutoff, force, nogoods=nogoods)
    return search if search.run(max_nodes, stop) else None


def keep_values(problem: Problem, weight: int) -> tuple[int, dict[str, int]]:
    """The unscheduled cost of keeping no task, and what keeping each
    task saves of it, ``weight`` (W) included.

    A task that is no group member saves its own schedule cost. A group
    costs its schedule cost once when none of its tasks is kept, and its
    members' own costs are never counted (:func:`~fsw_scheduler.model.
    groups.unscheduled_cost`): the tasks of each option share the
    group's cost (in whole units, the remainder to the first), so a
    plan, which keeps one whole option or none, saves exactly the
    group's cost with it and its kept set costs here what it costs in
    the plan. Sets that keep parts of options or several options are not
    plans and may cost less: the relaxation only gets lower, so it is
    still a bound.
    """
    member = problem.groups.member
    names = {t.id for t in problem.tasks}
    saved = {
        t.id: 0 if t.id in member else weight * t.schedule_cost
        for t in problem.tasks
    }
    total = sum(saved.values())
    for group in problem.alternatives:
        options = [[n for n in o if n in names] for o in group.options]
        if not any(options):
            continue  # a group of another part
        cost = weight * group.schedule_cost
        total += cost
        for option in options:
            share = cost // max(1, len(option))
            for name in option:
                saved[name] = share
            if option:
                # The remainder to the first: a whole option saves the
                # group's cost exactly, so a plan's relaxed cost is its
                # real one and a proof by equality still holds.
                saved[option[0]] += cost - share * len(option)
    return total, saved


def _rivals(problem: Problem) -> Iterator[tuple[str, str]]:
    """Each pair of tasks in two options of one group (:meth:`~fsw_scheduler.
    model.groups.Groups.rivals`), once: no plan keeps both, and without
    them a set keeping every option would save the group's cost once per
    option (:func:`keep_values`)."""
    indexed = problem.groups
    for task in problem.tasks:
        for other in indexed.rivals(task.id):
            if task.id < other:
                yield task.id, other


class KeptSetSearch:
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
        binary and multiple resources (:func:`energy`); None: none.
    machines
        Sets of tasks no two of which run at once, each task in one at
        most (:func:`~.sequencing.machines`): a kept set then also costs
        the delay its tasks on each machine cannot avoid
        (:func:`~.sequencing.machine_delay`), so the relaxed optimum is
        a higher bound. Its kept sets' costs are then no longer the sums
        of per-task values that :func:`~.bounds.delay_caps` reads.
    nogoods
        Choices no plan makes: each a set of tasks no plan keeps all of
        while it leaves out every task of a second set (the tasks that
        could supply what the first needs; each such pair a set the
        solver proved has no plan, :mod:`fsw_scheduler.solving.refuted`).
        No kept set searched makes one of them.
    """

    def __init__(
        self,
        problem: Problem,
        domains: Mapping[str, Domain],
        cutoff: int,
        force: tuple[str, bool] | None = None,
        *,
        energy: Rows | None = None,
        machines: Sequence[tuple[str, ...]] = (),
        nogoods: Sequence[Nogood] = (),
    ) -> None:
        weight = objective_weight(
            [t.delay_cost for t in problem.tasks], problem.horizon
        )
        placeable = [t for t in problem.tasks if not domains[t.id].empty]
        self.too_large = len(placeable) > MAX_TASKS
        # Cost of a kept set: weight * (cost of all) - its value.
        self.total, saved = keep_values(problem, weight)
        value = {
            t.id: saved[t.id]
            - t.delay_cost * (domains[t.id].earliest - problem.start)
            for t in placeable
        }
        required = {t.id for t in placeable if problem.required(t)}
        self.need = self.total - cutoff + 1  # value of a better kept set
        uses, self.limits = level_rows(problem, domains, placeable)
        if energy is not None:
            self.limits += energy[1]
            for task_id, row in energy[0].items():
                uses[task_id] = uses[task_id] + row
        # Mandatory tasks are decided first (kept), then by value: leaving
        # out a valuable task drops the bound at once.
        self.order = sorted(
            placeable, key=lambda t: (t.id not in required, -value[t.id], t.id)
        )
        self.required = [t.id in required for t in self.order]
        self.values = [value[t.id] for t in self.order]
        self.uses = [uses[t.id] for t in self.order]
        index = {t.id: k for k, t in enumerate(self.order)}
        self.links = self._links(problem, index)
        # Each task's machine (-1: none) and its job there.
        self.machine_of = [-1] * len(self.order)
        for m, names in enumerate(machines):
            for name in names:
                if name in index:
                    self.machine_of[index[name]] = m
        self.jobs: list[Job] = [job(t, domains) for t in self.order]
        #: The kept jobs on each machine, and their delay bound, as the
        #: search goes down.
        self.on_machine: list[list[Job]] = [[] for _ in machines]
        self.machine_cost = [0] * len(machines)
        self.apart = self._apart(problem, index)
        self.nogoods = self._nogoods(nogoods, index)
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
        self.held = [
            forced.get(t.id, needed)
            for t, needed in zip(self.order, self.required, strict=True)
        ]
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

    def _links(
        self, problem: Problem, index: dict[str, int]
    ) -> list[list[tuple[int, bool, bool]]]:
        """Precedence scopes, at the later decided task of each pair.

        Each entry is ``(other, both, is_after)``: ``other`` the earlier
        decided task (-1: one that is never kept), ``both`` the scope,
        ``is_after`` whether the task holding the entry is the later one
        of the precedence. ``index`` is each task's place in the order.
        """
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

    def _apart(
        self, problem: Problem, index: dict[str, int]
    ) -> list[list[int]]:
        """The earlier decided partners of each task in the pairs no plan
        holds together (:func:`~.exclusions.exclusive_pairs`, and the
        tasks of two options of a group: :func:`_rivals`)."""
        apart: list[list[int]] = [[] for _ in self.order]
        for first, second in [*exclusive_pairs(problem), *_rivals(problem)]:
            a, b = index.get(first), index.get(second)
            if a is not None and b is not None:
                apart[max(a, b)].append(min(a, b))
        return apart

    def _nogoods(
        self, nogoods: Sequence[Nogood], index: dict[str, int]
    ) -> list[list[tuple[bool, list[int], list[int]]]]:
        """Each no-good at its last decided task: that task's decision
        that completes it, and the others' (kept, left out). A no-good
        with a task of its kept side that is never kept (not placeable)
        holds of itself; a task of its other side that is never kept is
        always left out, and drops from it."""
        at: list[list[tuple[bool, list[int], list[int]]]] = [
            [] for _ in self.order
        ]
        for kept, out in nogoods:
            if not kept or any(n not in index for n in kept):
                continue
            sides = [(index[n], True) for n in kept] + [
                (index[n], False) for n in out if n in index
            ]
            sides.sort()
            last, keeps = sides.pop()
            at[last].append(
                (
                    keeps,
                    [k for k, side in sides if side],
                    [k for k, side in sides if not side],
                )
            )
        return at

    def _allowed(self, k: int, kept: bool) -> bool:
        keep = self.keep
        if kept and any(keep[other] for other in self.apart[k]):
            return False
        for keeps, kept_side, out_side in self.nogoods[k]:
            if (
                kept is keeps
                and all(keep[other] for other in kept_side)
                and not any(keep[other] for other in out_side)
            ):
                return False
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

    def _search(
        self, k: int, got: int, rows: list[float], extra: int = 0
    ) -> bool:
        """Explore kept sets extending the first ``k`` decisions; False
        when the node budget is spent.

        ``extra`` is the machines' delay bound of the tasks kept so far:
        every set extending them pays at least that much (the bound
        grows with the set).
        """
        self.nodes_left -= 1
        if self.nodes_left < 0 or (
            self.stop is not None
            and self.nodes_left % STOP_EVERY == 0
            and self.stop()
        ):
            self.out_of_budget = True
            return False
        if got + self.rest[k] - extra < self.need:
            return True
        if k < len(self.order) and self._knapsack(k, got - extra, rows):
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
            self.best_cost = self.total - got + extra
            self.need = got - extra + 1
            return True
        task = self.order[k]
        if self.force is not None and self.force[0] == task.id:
            choices: tuple[bool, ...] = (self.force[1],)
        elif self.required[k]:
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
                done = self._kept(k, got + self.values[k], grown, extra)
            else:
                done = self._search(k + 1, got, rows, extra)
            if not done:
                return False
        return True

    def _kept(self, k: int, got: int, rows: list[float], extra: int) -> bool:
        """:meth:`_search` below task ``k`` kept, with its machine's delay
        bound grown by it."""
        m = self.machine_of[k]
        if m < 0:
            return self._search(k + 1, got, rows, extra)
        jobs = self.on_machine[m]
        before = self.machine_cost[m]
        jobs.append(self.jobs[k])
        self.machine_cost[m] = machine_delay(jobs)
        try:
            return self._search(
                k + 1, got, rows, extra + self.machine_cost[m] - before
            )
        finally:
            jobs.pop()
            self.machine_cost[m] = before
