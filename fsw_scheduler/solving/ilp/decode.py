"""A solution read back as a plan, the same for either formulation, and
what both hand to the solver run (:class:`Formulation`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ...model import groups
from ...model.plan import Activity, Objective, Plan
from ...model.stability import Stability, rescored
from .moves import add_move_terms
from .objective import weight
from .program import Program

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ...analysis.domains import Domain
    from ...model.plan import SolveStatus
    from ...model.problem import Problem


class Formulation:
    """A problem's program built by one formulation, and its decoder.

    Parameters
    ----------
    problem
        The problem modelled.
    domains
        Its start domains.
    variables, constraints, objective
        The formulation's Variables and Constraints classes and objective
        function (one documented method per constraint family each).
    stability
        The previous starts and the price of moving them (default: none,
        the paper's objective); see :mod:`.moves`.
    options
        Passed on to the Variables class (the time-indexed model's
        ``candidates``).
    """

    def __init__(
        self,
        problem: Problem,
        domains: dict[str, Domain],
        variables: Any,
        constraints: Any,
        objective: Callable[..., Any],
        stability: Stability | None = None,
        **options: Any,
    ) -> None:
        self.problem = problem
        self.domains = domains
        self.stability = stability or Stability()
        self.program = Program()
        self.vars = variables(self.program, problem, domains, **options)
        self.constraints = constraints(self.program, problem, self.vars)
        self.constraints.add_all()
        big, _ = self.stability.weights(problem)
        terms, constant = objective(problem, self.vars, big)
        add_move_terms(terms, problem, self.vars, self.stability)
        self.program.set_objective(terms, constant)

    @property
    def num_variables(self) -> int:
        """Number of variables handed to the solver."""
        return self.program.num_columns

    @property
    def num_constraints(self) -> int:
        """Number of rows handed to the solver."""
        return self.program.num_rows

    def decode(self, status: SolveStatus, values: Sequence[float]) -> Plan:
        """Read solution ``values`` into a Plan, objective recomputed."""
        plan = decode_plan(self.problem, self.vars.start_of, status, values)
        return rescored(self.problem, plan, self.stability)


def decode_plan(
    problem: Problem,
    start_of: Callable[[str, Sequence[float]], int | None],
    status: SolveStatus,
    values: Sequence[float],
) -> Plan:
    """The plan of solution ``values``, read by a model's ``start_of``.

    The objective is recomputed from the starts, not taken from the solver.
    """
    activities = []
    delay = 0
    for task in problem.tasks:
        start = start_of(task.id, values)
        if start is None:
            continue
        activities.append(Activity(task.id, start, start + task.length))
        delay += task.delay_cost * (start - problem.start)
    activities.sort(key=lambda a: (a.start, a.task))
    scheduled = {a.task for a in activities}
    unscheduled_cost = groups.unscheduled_cost(problem, scheduled)
    total = weight(problem) * unscheduled_cost + delay
    return Plan(
        status=status,
        objective=Objective(unscheduled_cost, delay, total),
        activities=tuple(activities),
        unscheduled=groups.left_out(problem, scheduled),
        chosen=groups.chosen(problem, scheduled),
    )
