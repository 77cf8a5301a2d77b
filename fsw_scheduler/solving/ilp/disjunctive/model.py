"""The disjunctive model built, and its solution read back as a plan."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..decode import decode_plan
from ..program import Program
from .constraints import Constraints
from .objective import objective
from .variables import Variables

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ....analysis.domains import Domain
    from ....model.plan import Plan, SolveStatus
    from ....model.problem import Problem


class DisjunctiveModel:
    """A problem's disjunctive ILP: the program and its decoder.

    The same interface as the time-indexed
    :class:`~fsw_scheduler.solving.ilp.model.BuiltModel`, so the same CBC
    or HiGHS run solves either.

    Parameters
    ----------
    problem
        A validated problem without consumables in use
        (:func:`.rule.pick`).
    domains
        Start domains to model.
    """

    def __init__(self, problem: Problem, domains: dict[str, Domain]) -> None:
        self.problem = problem
        self.domains = domains
        self.program = Program()
        self.vars = Variables(self.program, problem, domains)
        self.constraints = Constraints(self.program, problem, self.vars)
        self.constraints.add_all()
        self.program.set_objective(*objective(problem, self.vars))

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
        return decode_plan(self.problem, self.vars.start_of, status, values)
