"""Decision variables of the disjunctive model: starts, scheduled, orders.

For task ``i`` with start domain ``[e, l]``: an integer start
``s[i] in [e, l]`` and a binary ``y[i]``, 1 iff the task is scheduled
(fixed to 1 when mandatory). A left-out task keeps a start, which no row
binds (every row that reads it is relaxed by ``y``), so at an optimum it
sits at ``e``. For a pair of tasks that could collide, ``x[i, j] = 1``
says "both scheduled and ``i`` ends before ``j`` starts".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..program import GE, LE

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ....analysis.domains import Domain
    from ....model.problem import Problem, Task
    from ..program import Program, Terms


class Variables:
    """Start, "scheduled" and order columns.

    Parameters
    ----------
    program
        The program that owns the columns.
    problem
        The problem being modelled.
    domains
        Start domains from
        :func:`~fsw_scheduler.analysis.domains.start_domains`.
    """

    def __init__(
        self,
        program: Program,
        problem: Problem,
        domains: dict[str, Domain],
    ) -> None:
        self.program = program
        self.problem = problem
        self.domains = domains
        self.tasks: list[Task] = list(problem.tasks)
        self.lengths = {task.id: task.length for task in self.tasks}
        self.starts: dict[str, int] = {}
        self.chosen: dict[str, int] = {}
        for task in self.tasks:
            domain = domains[task.id]
            if domain.empty:
                continue
            self.starts[task.id] = program.add_column(
                domain.earliest, domain.latest, integer=True
            )
            (self.chosen[task.id],) = program.add_binaries(1)
            if problem.required(task):
                program.lower[self.chosen[task.id]] = 1
        #: Order columns by (first, second) task id.
        self.orders: dict[tuple[str, str], int] = {}
        #: The "``first`` runs when ``second`` starts" columns: (first,
        #: second, column, tie offset of its row: 1 when ``first`` comes
        #: after ``second`` in problem order). A pair has one on each
        #: resource whose load at starts it shares (see
        #: :meth:`.constraints.Constraints._load_at_starts`).
        self.runs_at: list[tuple[str, str, int, int]] = []

    @property
    def num_placeable(self) -> int:
        """Number of tasks with at least one allowed start time."""
        return len(self.starts)

    def placeable(self, task_id: str) -> bool:
        """True if the task has at least one allowed start time."""
        return task_id in self.starts

    def start(self, task_id: str) -> int:
        """The column of the task's start time."""
        return self.starts[task_id]

    def scheduled(self, task_id: str) -> int:
        """The column that is 1 iff the task is scheduled."""
        return self.chosen[task_id]

    def starts_at(self, task_id: str, time: int) -> Terms:
        """ "Scheduled and starts at ``time``", as one new binary ``k``.

        ``k <= y`` and ``e + (time - e) k <= s <= l - (l - time) k``: with
        ``k = 1`` the start is ``time``, with ``k = 0`` anywhere in its
        domain ``[e, l]``. Empty where the task cannot start at ``time``.
        """
        domain = self.domains[task_id]
        if not self.placeable(task_id) or not (
            domain.earliest <= time <= domain.latest
        ):
            return {}
        (kept,) = self.program.add_binaries(1)
        start, low, high = self.start(task_id), domain.earliest, domain.latest
        self.program.add_row({kept: 1.0, self.scheduled(task_id): -1.0}, LE, 0)
        self.program.add_row({start: 1.0, kept: -(time - low)}, GE, low)
        self.program.add_row({start: 1.0, kept: high - time}, LE, high)
        return {kept: 1.0}

    def order(self, first: str, second: str) -> int:
        """The column "``first`` ends before ``second`` starts" (made once).

        The column is fixed to 0 when ``first`` cannot end before the
        latest start of ``second``.
        """
        key = (first, second)
        column = self.orders.get(key)
        if column is None:
            (column,) = self.program.add_binaries(1)
            self.orders[key] = column
            earliest_end = self.domains[first].earliest + self.lengths[first]
            if earliest_end > self.domains[second].latest:
                self.program.upper[column] = 0
        return column

    def start_of(self, task_id: str, values: Sequence[float]) -> int | None:
        """The start time in solution ``values``, None if unscheduled."""
        if task_id not in self.starts or values[self.chosen[task_id]] < 0.5:
            return None
        return round(values[self.starts[task_id]])

    def initial(self, starts: dict[str, int], columns: int) -> list[float]:
        """Column values of a warm start from ``starts``.

        Tasks absent from ``starts`` start as unscheduled at their earliest
        start (mandatory ones scheduled there); starts outside a task's
        domain are ignored. Order columns, and the columns saying a task
        runs when another starts, follow the starts.
        """
        values = [0.0] * columns
        placed: dict[str, int] = {}
        for task in self.tasks:
            if task.id not in self.starts:
                continue
            domain = self.domains[task.id]
            start = starts.get(task.id)
            chosen = start is not None and (
                domain.earliest <= start <= domain.latest
            )
            if not chosen and self.problem.required(task):
                start, chosen = domain.earliest, True
            time = start if chosen and start is not None else domain.earliest
            values[self.starts[task.id]] = float(time)
            if chosen:
                values[self.chosen[task.id]] = 1.0
                placed[task.id] = time
        for (first, second), column in self.orders.items():
            if (
                first in placed
                and second in placed
                and placed[first] + self.lengths[first] <= placed[second]
            ):
                values[column] = 1.0
        # Without these a start in which two users of a multiple resource
        # overlap breaks its pair's row, and CBC drops the whole start.
        for first, second, column, tie in self.runs_at:
            if (
                first in placed
                and second in placed
                and placed[first] + tie
                <= placed[second]
                < placed[first] + self.lengths[first]
            ):
                values[column] = 1.0
        return values
