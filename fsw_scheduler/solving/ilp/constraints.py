"""Constraint families of the ILP, one method each.

The rows are written over the step variables of :mod:`.variables`:
``Z(i, t)`` is "task ``i`` scheduled and started by ``t``" and
``R(i, t) = Z(i, t) - Z(i, t - length_i)`` is "task ``i`` runs at ``t``".
Rows that can never bind (one possible user, total demand under the
capacity) are skipped rather than handed to the solver.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from ...analysis.stores import never_short
from .alternatives import alternative_rows
from .exclusive import exclusive_rows
from .program import EQ, LE
from .strengthen import strengthening_rows

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ...analysis.domains import Domain
    from ...model.problem import Precedence, Problem, Task
    from .program import Program, Terms
    from .variables import Variables


def identical_tasks(
    problem: Problem, domains: Mapping[str, Domain]
) -> list[list[str]]:
    """Classes of two or more tasks the model cannot tell apart.

    Same length, costs, mandatory flag, resource uses and start domain,
    and in no precedence; each class lists its task ids in problem order.
    """
    # Members of groups are told apart by their options.
    linked = {
        name
        for prec in problem.precedences
        for name in (prec.before, prec.after)
    } | set(problem.groups.member)
    classes: dict[tuple, list[str]] = {}
    for task in problem.tasks:
        domain = domains[task.id]
        if task.id in linked or domain.empty:
            continue
        signature = (
            task.length,
            task.delay_cost,
            task.schedule_cost,
            problem.required(task),
            tuple(sorted((k, v) for k, v in task.uses.items() if v)),
            domain.earliest,
            domain.latest,
        )
        classes.setdefault(signature, []).append(task.id)
    return [group for group in classes.values() if len(group) > 1]


class Constraints:
    """Adds every constraint family of ``problem`` to ``program``.

    Parameters
    ----------
    program
        The program being built.
    problem
        The scheduling problem.
    variables
        The step variables.
    """

    def __init__(
        self, program: Program, problem: Problem, variables: Variables
    ) -> None:
        self.program = program
        self.problem = problem
        self.vars = variables
        #: Classes of identical tasks, ordered by :meth:`_identical_tasks`
        #: (tasks with candidate starts are told apart by them).
        self.twins = [
            twins
            for group in identical_tasks(problem, variables.domains)
            if len(
                twins := [n for n in group if n not in variables.candidates]
            )
            > 1
        ]

    def add_all(self) -> None:
        """Add every family, in a fixed order (stable row numbering)."""
        self._monotone_steps()
        self._binary_resources()
        self._multiple_resources()
        self._consumable_resources()
        for prec in self.problem.precedences:
            self._precedence(prec)
        self._identical_tasks()
        self._alternatives()
        exclusive_rows(self.program, self.problem, self.vars)

    # -- helpers ------------------------------------------------------------

    def _row(self, terms: Terms, sense: str, rhs: float) -> None:
        """Add ``terms (sense) rhs``; a constant row is validated elsewhere."""
        self.program.add_row(terms, sense, rhs)

    def _users(self, resource: str) -> list[tuple[Task, float]]:
        return [
            (task, task.uses[resource])
            for task in self.problem.tasks
            if task.uses.get(resource, 0) != 0 and self.vars.placeable(task.id)
        ]

    # -- families -------------------------------------------------------------

    def _monotone_steps(self) -> None:
        """Steps never go back: ``z[i, t-1] <= z[i, t]``."""
        rows = self.program.rows
        # Tasks that share steps (:func:`.variables.shared_steps`) share
        # the list: its rows are written once.
        unique = {id(steps): steps for steps in self.vars.steps.values()}
        for steps in unique.values():
            # Two distinct columns with non-zero coefficients: no cleaning.
            rows.extend(
                ({before: 1.0, after: -1.0}, LE, 0.0)
                for before, after in itertools.pairwise(steps)
            )

    def _capacity_rows(self, resource: str) -> None:
        """``sum_i amount_i * R(i, t) <= capacity(t)`` for every time unit.

        ``capacity(t)`` is the resource's capacity profile: 1 or 0 for a
        binary resource (inside or outside its windows), the step's
        capacity for a multiple one.
        """
        problem = self.problem
        start = problem.start
        capacity = problem.resources.capacity_profile(
            resource, start, problem.horizon
        )
        demand = [0.0] * problem.horizon  # most the users may need
        rows: list[Terms] = [{} for _ in range(problem.horizon)]
        for task, amount in self._users(resource):
            for time in self.vars.add_running(rows, task, amount, start):
                demand[time - start] += amount
        for need, terms, top in zip(demand, rows, capacity, strict=True):
            if need > top:
                self._row(terms, LE, top)

    def _binary_resources(self) -> None:
        """Paper eq. (1): at most one running user per time unit, none
        outside the resource's windows."""
        for resource in self.problem.resources.binary:
            self._capacity_rows(resource)

    def _multiple_resources(self) -> None:
        """Paper eq. (2): running users' amounts within the capacity of
        each unit, with the clique rows of those knapsacks
        (:mod:`.strengthen`: the knapsack's LP alone is weak)."""
        problem = self.problem
        for resource in problem.resources.multiple:
            self._capacity_rows(resource)
            capacity = problem.resources.capacity_profile(
                resource, problem.start, problem.horizon
            )
            for terms, bound in strengthening_rows(
                self.vars, self._users(resource), capacity, problem.start
            ):
                self._row(terms, LE, bound)

    def _alternatives(self) -> None:
        """All or none of an option, at most one option per group
        (:func:`.alternatives.alternative_rows`)."""
        alternative_rows(self.program, self.problem, self.vars)

    def _consumable_resources(self) -> None:
        """Paper eq. (3): the level never goes below zero.

        The level at the end of unit ``t`` is the initial level minus every
        amount times the units run up to and including ``t``. A continuous
        level column ``L >= 0`` carries it from one checkpoint to the next:
        ``L[c] = L[p] - sum_i amount_i * (units i runs in (p, c])``,
        ``L[start-1]`` being the initial level. Checkpoints are the units
        next to one in which generation can happen, and the last unit
        (:meth:`_checkpoints`): between two of them the level only falls,
        so its lowest value is at the later one, and a level row per unit
        there would only repeat it. The units a task runs in ``(p, c]`` are
        ``sum_{u=p+1}^{c} Z(i, u) - Z(i, u - length)``: two non-zeros per
        unit of a one-unit segment, at most ``2 length`` for a long one.
        Without generation a resource needs a single row, the knapsack of
        :meth:`_consumable_total` (tasks end inside the horizon). A
        resource whose consumers cannot exhaust it even if all are
        scheduled gets no rows at all. A consumable with a capacity gets
        ``L[c] <= L[p] - ...`` instead (see :meth:`_level_column`).
        """
        problem = self.problem
        consumables = problem.resources.initial_levels.items()
        for resource, initial in consumables:
            users = self._users(resource)
            external = problem.resources.external_profile(
                resource, problem.start, problem.horizon
            )
            if never_short(initial, external, users):
                continue
            self._consumable_total(resource, initial, users, sum(external))
            # Which tasks fit the budget is the hard part here: branch on
            # "scheduled" first (consumable class of the campaign: total
            # CBC time -23 %; on resource-only models it was slower).
            for task, _ in users:
                self.program.priorities[self.vars.scheduled(task.id)] = 1
            checkpoints = self._checkpoints(users, external)
            if len(checkpoints) > 1 or any(external):
                self._level_rows(
                    resource, initial, users, checkpoints, external
                )

    def _checkpoints(
        self, users: list[tuple[Task, float]], external: list[float]
    ) -> list[int]:
        """Units at whose end a level row of these users is needed.

        The unit before and the unit of every unit in which some generator
        (negative amount) may run or the external rate charges, and the
        last unit of the horizon; sorted. Only the last one when nothing
        generates.
        """
        end = self.problem.end
        start = self.problem.start
        points = {end - 1}
        for idx, rate in enumerate(external):
            if rate > 0:
                points.update((start + idx - 1, start + idx))
        for task, amount in users:
            if amount >= 0:
                continue
            domain = self.vars.domains[task.id]
            last = min(domain.latest + task.length, end) - 1
            for unit in range(domain.earliest, last + 1):
                points.update((unit - 1, unit))
        return sorted(p for p in points if self.problem.start <= p < end)

    def _level_rows(
        self,
        resource: str,
        initial: float,
        users: list[tuple[Task, float]],
        checkpoints: list[int],
        external: list[float],
    ) -> None:
        """The level balance from checkpoint to checkpoint (see above);
        the external rate of the units between adds to the right side."""
        start = self.problem.start
        add_step, add_steps = self.vars.add_step, self.vars.add_steps
        previous: int | None = None
        after = self.problem.start - 1  # the last unit already counted
        for point in checkpoints:
            level, sense = self._level_column(resource)
            # level - previous + sum amount * units = 0 (initial if first)
            terms: Terms = {level: 1.0}
            if previous is not None:
                terms[previous] = -1.0
            for task, amount in users:
                # The sum over the units u of z[u] - z[u - length].
                low, high, length = after + 1, point + 1, task.length
                if float(amount).is_integer():  # in any order: exact
                    add_steps(terms, task.id, low, high, amount)
                    add_steps(
                        terms, task.id, low - length, high - length, -amount
                    )
                    continue
                for unit in range(low, high):
                    add_step(terms, task.id, unit, amount)
                    add_step(terms, task.id, unit - length, -amount)
            rhs = initial if previous is None else 0.0
            rhs += sum(external[after + 1 - start : point + 1 - start])
            self._row(terms, sense, rhs)
            previous, after = level, point

    def _level_column(self, resource: str) -> tuple[int, str]:
        """A level column of ``resource`` and the sense of its balance row.

        Without a capacity: ``L[t] >= 0`` and the balance is an equality.
        With one, ``max``: ``0 <= L[t] <= max`` and ``L[t] <= L[t-1] -
        net use``. That is exact for feasibility: the true level
        ``min(max, L[t-1] - net use)`` is the largest value the row and
        the bound allow, and any lower value only restricts later units;
        so some ``L >= 0`` fits iff the true level stays ``>= 0``. The
        other rows stay valid: the true level is never above the level
        without a capacity, so the knapsack row of
        :meth:`_consumable_total` and the "cannot exhaust it" test (which
        counts no generation) hold as they are.
        """
        ceiling = self.problem.resources.ceiling(resource)
        if ceiling is None:
            return self.program.add_column(0), EQ
        return self.program.add_column(0, ceiling), LE

    def _consumable_total(
        self,
        resource: str,
        initial: float,
        users: list[tuple[Task, float]],
        charge: float,
    ) -> None:
        """The level rows summed up to the horizon's end, on "scheduled".

        Implied by the level rows, but over binaries only: a knapsack row
        that CBC's cover cuts can work on. A consumer counts the units it
        runs in the horizon at least (starting at its latest), a generator
        the units it can run at most (starting at its earliest); ``charge``
        is the external rate summed over the horizon (a full store only
        loses some of it, so the row stays valid).
        """
        end = self.problem.end
        terms: Terms = {}
        for task, amount in users:
            domain = self.vars.domains[task.id]
            start = domain.latest if amount > 0 else domain.earliest
            units = max(0, min(task.length, end - start))
            column = self.vars.scheduled(task.id)
            terms[column] = terms.get(column, 0.0) + amount * units
        self._row(terms, LE, initial + charge)

    def _identical_tasks(self) -> None:
        """Symmetry breaking: of identical tasks, the first starts first.

        Tasks alike in everything the model sees (:func:`identical_tasks`)
        can swap starts in any plan without changing its objective, so
        only plans where they start in problem order are kept:
        ``z[a, t] >= z[b, t]`` for consecutive ``a``, ``b`` of a class
        (``a`` has started whenever ``b`` has; ``b`` scheduled needs ``a``
        scheduled). Without these rows CBC explores every permutation.
        """
        for group in self.twins:
            steps = [self.vars.steps[name] for name in group]
            for first, second in itertools.pairwise(steps):
                self.program.rows.extend(
                    ({after: 1.0, before: -1.0}, LE, 0.0)
                    for before, after in zip(first, second, strict=True)
                )

    def _precedence(self, prec: Precedence) -> None:
        """Tight/lax x both/at_least_first, on the steps.

        With ``g = length_before + offset`` and ``i -> j``:

        * every kind: ``Z(j, t) <= Z(i, t - g)`` (``j`` cannot have started
          by ``t`` unless ``i`` had by ``t - g``; at the last step it also
          says ``j`` scheduled needs ``i`` scheduled);
        * tight: also ``Z(i, t - g) - Z(j, t) <= y_i - y_j``: when both are
          scheduled the steps coincide, so ``s_j = s_i + g`` exactly, and
          when only ``i`` is (``at_least_first``) the row is slack;
        * both: ``y_i = y_j``.
        """
        i, j = prec.before, prec.after
        vars_ = self.vars
        gap = self.problem.task(i).length + prec.offset
        if not vars_.placeable(j):
            if prec.scope == "both" and vars_.placeable(i):
                self._row({vars_.scheduled(i): 1.0}, LE, 0)
            return
        if not vars_.placeable(i):
            self._row({vars_.scheduled(j): 1.0}, LE, 0)
            return
        dom_i, dom_j = vars_.domains[i], vars_.domains[j]
        first = min(dom_j.earliest, dom_i.earliest + gap)
        last = max(dom_j.latest, dom_i.latest + gap)
        y_i, y_j = vars_.scheduled(i), vars_.scheduled(j)
        # Past its domain a task's step is its "scheduled" column, so many
        # rows repeat or are implied by one other row and the monotone
        # steps; only the strongest of each kind is written (see below).
        i_done = dom_i.latest + gap  # from here Z(i, t - g) is y_i
        j_done = dom_j.latest  # from here Z(j, t) is y_j
        tight = prec.kind == "tight"
        for time in range(first, last + 1):
            follows: Terms = {}
            vars_.add_step(follows, j, time, 1.0)
            vars_.add_step(follows, i, time - gap, -1.0)
            # Z(j, t) <= Z(i, t-g): once either side is clamped, the row
            # at t = j_done (y_j <= Z(i, j_done - g)) implies the rest.
            if time <= j_done and (time < i_done or time == j_done):
                self._row(follows, LE, 0)
            if not tight or time > i_done:
                # Z(i, t-g) <= Z(j, t) is strongest at t = i_done once
                # Z(i) is clamped (y_i <= Z(j, i_done)).
                continue
            if prec.scope == "at_least_first":
                if time >= j_done and time != i_done:
                    continue  # reduces to Z(i, t-g) <= y_i: monotone
                # Z(i, t-g) - Z(j, t) - y_i + y_j <= 0
                leads = {v: -c for v, c in follows.items()}
                leads[y_i] = leads.get(y_i, 0.0) - 1.0
                leads[y_j] = leads.get(y_j, 0.0) + 1.0
                self._row(leads, LE, 0)
            elif time < j_done or time == i_done:
                # Z(i, t-g) <= y_j for t >= j_done: implied at i_done.
                self._row({v: -c for v, c in follows.items()}, LE, 0)
        if prec.scope == "both" and y_i != y_j:
            # y_i is y_j where the two share steps (shared_steps).
            self._row({y_i: 1.0, y_j: -1.0}, EQ, 0)
