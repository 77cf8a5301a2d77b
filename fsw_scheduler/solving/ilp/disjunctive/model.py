"""The disjunctive model built, and its solution read back as a plan."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..decode import Formulation
from .constraints import Constraints
from .objective import objective
from .variables import Variables

if TYPE_CHECKING:
    from ....analysis.domains import Domain
    from ....model.problem import Problem
    from ....model.stability import Stability


class DisjunctiveModel(Formulation):
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

    vars: Variables
    constraints: Constraints

    #: CBC options added after those of its formulation
    #: (:func:`~fsw_scheduler.solving.ilp.model.run_cbc`).
    cbc_options: tuple[str, ...] = ()

    def __init__(
        self,
        problem: Problem,
        domains: dict[str, Domain],
        stability: Stability | None = None,
    ) -> None:
        super().__init__(
            problem, domains, Variables, Constraints, objective, stability
        )
