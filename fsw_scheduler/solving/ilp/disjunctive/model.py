"""The disjunctive model built, and its solution read back as a plan."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ....errors import SolverError
from ..decode import Formulation
from .blocks import MAX_BLOCKS, modelled
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
        (:func:`.rule.pick`); binary windows and capacity steps in use
        are modelled by pinned blocks (:mod:`.blocks`), consumables'
        external rates not at all (:class:`~fsw_scheduler.errors.
        SolverError`).
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
        wide = modelled(problem, domains)
        if wide is None:
            raise SolverError(
                "the disjunctive model reads one capacity per resource and "
                f"holds at most {MAX_BLOCKS} stretches of binary windows or "
                "capacity steps; external rates and more stretches need the "
                "time-indexed model"
            )
        model_problem, model_domains = wide
        super().__init__(
            model_problem,
            dict(model_domains),
            Variables,
            Constraints,
            objective,
            stability,
        )
        # Plans name the problem's tasks as given: the blocks are read
        # by no decoder, the solver's rules or the caller.
        self.problem, self.domains = problem, domains
