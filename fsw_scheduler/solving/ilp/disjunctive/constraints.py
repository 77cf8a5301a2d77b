"""Constraint families of the disjunctive model, one method each.

Rows are written over the columns of :mod:`.variables`: ``s`` (start),
``y`` (scheduled) and ``x`` (order). Every big-M is the largest value the
left-hand side can take over the start domains, so a relaxed row never
cuts a start the domains allow, and no row is written that could never
bind. Resources are modelled by pairs: two users that together exceed a
capacity and whose windows let them overlap are put in an order; where
three or more users can exceed a capacity only together, the load is
also bounded at every user's start. Consumables are not modelled at all
(see :mod:`.rule`).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from ..alternatives import alternative_rows
from ..constraints import identical_tasks
from ..exclusive import exclusive_rows
from ..program import EQ, GE, LE
from .energy import add_busy_rows, add_energy_rows
from .rule import pairwise_exact

if TYPE_CHECKING:
    from ....model.problem import Precedence, Problem, Task
    from ..program import Program
    from .variables import Variables


class Constraints:
    """Adds every constraint family of ``problem`` to ``program``.

    Parameters
    ----------
    program
        The program being built.
    problem
        The scheduling problem (no consumable in use).
    variables
        The start, scheduled and order columns.
    """

    #: Whether :meth:`add_all` writes the energy rows
    #: (:func:`.energy.add_energy_rows`).
    energy_rows = True

    def __init__(
        self, program: Program, problem: Problem, variables: Variables
    ) -> None:
        self.program = program
        self.problem = problem
        self.vars = variables
        #: Classes of identical tasks, ordered by :meth:`_identical_tasks`.
        self.twins = identical_tasks(problem, variables.domains)
        #: Task id to (class, position) for tasks in :attr:`twins`.
        self._twin_at = {
            name: (group_idx, position)
            for group_idx, group in enumerate(self.twins)
            for position, name in enumerate(group)
        }
        #: Pairs already made disjunctive.
        self._apart: set[frozenset[str]] = set()

    def add_all(self) -> None:
        """Add every family, in a fixed order (stable row numbering)."""
        self._binary_resources()
        self._multiple_resources()
        add_busy_rows(self.program, self.vars, self.problem, self._users)
        if self.energy_rows:
            add_energy_rows(self.program, self.vars, self.problem)
        for prec in self.problem.precedences:
            self._precedence(prec)
        self._identical_tasks()
        # All or none of an option, at most one option per group.
        alternative_rows(self.program, self.problem, self.vars)
        exclusive_rows(self.program, self.problem, self.vars)

    # -- helpers ------------------------------------------------------------

    def _users(self, resource: str) -> list[tuple[Task, float]]:
        return [
            (task, task.uses[resource])
            for task in self.problem.tasks
            if task.uses.get(resource, 0) != 0 and self.vars.placeable(task.id)
        ]

    def _may_overlap(self, first: Task, second: Task) -> bool:
        """True if some starts in the domains make the two tasks overlap."""
        dom_a = self.vars.domains[first.id]
        dom_b = self.vars.domains[second.id]
        return (
            dom_a.earliest < dom_b.latest + second.length
            and dom_b.earliest < dom_a.latest + first.length
        )

    def _orders(self, first: Task, second: Task) -> tuple[int, int]:
        """``x[a, b]`` and ``x[b, a]``; of identical tasks the earlier in
        problem order goes first (the symmetry rows of
        :meth:`_identical_tasks` already say so), so the other is 0."""
        ahead = self.vars.order(first.id, second.id)
        behind = self.vars.order(second.id, first.id)
        twin_a = self._twin_at.get(first.id)
        twin_b = self._twin_at.get(second.id)
        if (
            twin_a is not None
            and twin_b is not None
            and twin_a[0] == twin_b[0]
        ):
            later = behind if twin_a[1] < twin_b[1] else ahead
            self.program.upper[later] = 0
        return ahead, behind

    def _end_before(self, first: Task, second: Task, order: int) -> None:
        """``s_a + p_a <= s_b`` when ``x[a, b] = 1``, relaxed by tight M.

        ``s_a + p_a - s_b <= M (1 - x)`` with ``M = l_a + p_a - e_b``, the
        most the left-hand side can be; positive since the two may overlap.
        """
        if self.program.upper[order] == 0:
            return
        big = (
            self.vars.domains[first.id].latest
            + first.length
            - self.vars.domains[second.id].earliest
        )
        self.program.add_row(
            {
                self.vars.start(first.id): 1.0,
                self.vars.start(second.id): -1.0,
                order: float(big),
            },
            LE,
            big - first.length,
        )

    # -- families -------------------------------------------------------------

    def _disjunctive_pair(self, first: Task, second: Task) -> None:
        """Two tasks that cannot overlap: one ends before the other starts.

        ``x[a, b] + x[b, a] >= y_a + y_b - 1`` (both scheduled need an
        order) and each order row of :meth:`_end_before`; once per pair,
        whatever resources the two share.
        """
        pair = frozenset((first.id, second.id))
        if pair in self._apart or not self._may_overlap(first, second):
            return
        self._apart.add(pair)
        ahead, behind = self._orders(first, second)
        self.program.add_row(
            {
                ahead: 1.0,
                behind: 1.0,
                self.vars.scheduled(first.id): -1.0,
                self.vars.scheduled(second.id): -1.0,
            },
            GE,
            -1.0,
        )
        self._end_before(first, second, ahead)
        self._end_before(second, first, behind)

    def _binary_resources(self) -> None:
        """Paper eq. (1): two users of a binary resource never overlap."""
        for resource in self.problem.resources.binary:
            users = self._users(resource)
            for (a, _), (b, _) in itertools.combinations(users, 2):
                self._disjunctive_pair(a, b)

    def _multiple_resources(self) -> None:
        """Paper eq. (2): running users' amounts within the capacity.

        Two users over the capacity together are a disjunctive pair. If
        that is all (:func:`.rule.pairwise_exact`), nothing more is needed;
        otherwise the load is also bounded at every user's start
        (:meth:`_load_at_starts`).
        """
        # Only constant capacities come here: a changing one in use is
        # read at its peak beside its blocks (blocks.modelled).
        multiple = {
            name: self.problem.resources.peak_capacity(name)
            for name in self.problem.resources.multiple
        }
        fitting: dict[str, list[tuple[Task, float]]] = {}
        for resource, capacity in multiple.items():
            users = self._users(resource)
            for task, amount in users:
                if amount > capacity:
                    # Never fits, even alone.
                    self.program.add_row(
                        {self.vars.scheduled(task.id): 1.0}, LE, 0
                    )
            fitting[resource] = [(t, a) for t, a in users if a <= capacity]
            for (a, amount_a), (b, amount_b) in itertools.combinations(
                fitting[resource], 2
            ):
                if amount_a + amount_b > capacity:
                    self._disjunctive_pair(a, b)
        # After every pair: a pair kept apart by any resource needs no
        # load columns on another.
        for resource, capacity in multiple.items():
            amounts = [a for _, a in fitting[resource]]
            if not pairwise_exact(amounts, capacity):
                self._load_at_starts(fitting[resource], capacity)

    def _load_at_starts(
        self, users: list[tuple[Task, float]], capacity: float
    ) -> None:
        """The load at each user's start is within the capacity.

        The load is highest at some start, that of the last user to start
        among those running then. For two users that fit together and may
        overlap, ``o[i, j] = 1`` says "``i`` runs when ``j`` starts",
        with ``s_i + e_ij <= s_j`` (``e_ij = 1`` when ``i`` comes after
        ``j`` in problem order: ties start in problem order, so the
        ``o`` of running users form no cycle). Both scheduled, the pair
        is ordered or one runs at the other's start:
        ``x[i, j] + x[j, i] + o[i, j] + o[j, i] >= y_i + y_j - 1``; and at
        the start of ``j``, ``a_j y_j + sum_i a_i o[i, j] <= capacity``.
        In any plan these values exist (``o`` set by the starts and
        problem order), and conversely at any time the last user to start
        among the running ones counts all the others.
        """
        position = {task.id: idx for idx, task in enumerate(self.vars.tasks)}
        load: dict[str, dict[int, float]] = {
            task.id: {self.vars.scheduled(task.id): amount}
            for task, amount in users
        }
        for (a, amount_a), (b, amount_b) in itertools.combinations(users, 2):
            if (
                amount_a + amount_b > capacity
                or frozenset((a.id, b.id)) in self._apart
                or not self._may_overlap(a, b)
            ):
                continue
            ahead, behind = self._orders(a, b)
            runs_a = self._runs_at_start(a, b, position)
            runs_b = self._runs_at_start(b, a, position)
            self.program.add_row(
                {
                    ahead: 1.0,
                    behind: 1.0,
                    runs_a: 1.0,
                    runs_b: 1.0,
                    self.vars.scheduled(a.id): -1.0,
                    self.vars.scheduled(b.id): -1.0,
                },
                GE,
                -1.0,
            )
            self._end_before(a, b, ahead)
            self._end_before(b, a, behind)
            load[b.id][runs_a] = amount_a
            load[a.id][runs_b] = amount_b
        for terms in load.values():
            if len(terms) > 1:
                self.program.add_row(terms, LE, capacity)

    def _runs_at_start(
        self, first: Task, second: Task, position: dict[str, int]
    ) -> int:
        """The column "``first`` runs when ``second`` starts" and its row.

        ``s_a + e - s_b <= M (1 - o)`` with ``M = l_a + e - e_b``; fixed
        to 0 when ``first`` cannot start by ``second``'s latest start.
        """
        (column,) = self.program.add_binaries(1)
        tie = 1 if position[first.id] > position[second.id] else 0
        dom_a = self.vars.domains[first.id]
        dom_b = self.vars.domains[second.id]
        if dom_a.earliest + tie > dom_b.latest:
            self.program.upper[column] = 0
            return column
        self.vars.runs_at.append((first.id, second.id, column, tie))
        big = dom_a.latest + tie - dom_b.earliest
        if big > 0:
            self.program.add_row(
                {
                    self.vars.start(first.id): 1.0,
                    self.vars.start(second.id): -1.0,
                    column: float(big),
                },
                LE,
                big - tie,
            )
        return column

    def _precedence(self, prec: Precedence) -> None:
        """Tight/lax x both/at_least_first, on starts and ``y``.

        With ``g = length_before + offset`` and ``i -> j``:

        * every kind: ``s_j >= s_i + g`` when ``j`` is scheduled (then
          ``i`` is too), ``s_i + g - s_j <= M (1 - y_j)``;
        * tight: also ``s_j - s_i - g <= M' (1 - y_j)``;
        * both: ``y_i = y_j``; at_least_first: ``y_j <= y_i``.
        """
        i, j = prec.before, prec.after
        vars_ = self.vars
        add = self.program.add_row
        if not vars_.placeable(j):
            if prec.scope == "both" and vars_.placeable(i):
                add({vars_.scheduled(i): 1.0}, LE, 0)
            return
        if not vars_.placeable(i):
            add({vars_.scheduled(j): 1.0}, LE, 0)
            return
        gap = vars_.lengths[i] + prec.offset
        dom_i, dom_j = vars_.domains[i], vars_.domains[j]
        s_i, s_j = vars_.start(i), vars_.start(j)
        y_i, y_j = vars_.scheduled(i), vars_.scheduled(j)
        # Where a big-M is not positive the row holds for every start in
        # the domains: it is not written.
        big = dom_i.latest + gap - dom_j.earliest
        if big > 0:
            # s_i - s_j + M y_j <= M - g
            add({s_i: 1.0, s_j: -1.0, y_j: float(big)}, LE, big - gap)
        if prec.kind == "tight":
            big = dom_j.latest - dom_i.earliest - gap
            if big > 0:
                # s_j - s_i + M' y_j <= M' + g
                add({s_j: 1.0, s_i: -1.0, y_j: float(big)}, LE, big + gap)
        if prec.scope == "both":
            add({y_i: 1.0, y_j: -1.0}, EQ, 0)
        else:
            add({y_j: 1.0, y_i: -1.0}, LE, 0)

    def _identical_tasks(self) -> None:
        """Symmetry breaking: of identical tasks, the first starts first.

        As in the time-indexed model (see
        :func:`~fsw_scheduler.solving.ilp.constraints.identical_tasks`):
        for consecutive ``a``, ``b`` of a class, ``y_b <= y_a`` and
        ``s_a <= s_b`` when ``b`` is scheduled,
        ``s_a - s_b <= M (1 - y_b)`` with ``M = l - e``.
        """
        vars_ = self.vars
        for group in self.twins:
            domain = vars_.domains[group[0]]
            big = domain.latest - domain.earliest
            for a, b in itertools.pairwise(group):
                y_a, y_b = vars_.scheduled(a), vars_.scheduled(b)
                self.program.add_row({y_b: 1.0, y_a: -1.0}, LE, 0)
                if big > 0:
                    self.program.add_row(
                        {
                            vars_.start(a): 1.0,
                            vars_.start(b): -1.0,
                            y_b: float(big),
                        },
                        LE,
                        big,
                    )
