"""Pairs no plan holds together, in either formulation.

:func:`~fsw_scheduler.analysis.exclusions.exclusive_pairs` finds tasks
whose companions, held at fixed offsets by tight precedences, overlap on
a resource when both are scheduled. Each such pair gets ``y_a + y_b <=
1`` on the "scheduled" columns: the LP relaxation otherwise keeps both at
a fraction, and its bound stays at the delays of a plan that holds them
all (broad seed 130's b15-multiple-4: CBC searched 10 s at a bound of
1,524 under a plan of 45,843, the optimum, which leaves out T008).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...analysis.exclusions import exclusive_pairs
from .program import LE

if TYPE_CHECKING:
    from ...model.problem import Problem
    from .alternatives import Columns
    from .program import Program, Terms


def exclusive_rows(
    program: Program, problem: Problem, columns: Columns
) -> int:
    """Add ``y_a + y_b <= 1`` for each exclusive pair of placeable tasks;
    return how many pairs were written."""
    written = 0
    for first, second in exclusive_pairs(problem):
        if not (columns.placeable(first) and columns.placeable(second)):
            continue
        terms: Terms = {}
        # Tasks may share one column (a tight `both` pair of the
        # time-indexed model): the row then reads 2 y <= 1.
        for name in (first, second):
            column = columns.scheduled(name)
            terms[column] = terms.get(column, 0.0) + 1.0
        program.add_row(terms, LE, 1.0)
        written += 1
    return written
