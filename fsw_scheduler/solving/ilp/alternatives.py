"""Alternatives in either formulation: rows on the "scheduled" columns.

Both formulations have a "scheduled" column ``y_i`` per placeable task.
An option is *viable* when every task it names is in the problem and has
a start time; its first task's column then stands for the option (its
*head*). The rows: the tasks of a viable option share one value
(``y_head = y_k``), a task of an option that is not viable is left out
(``y_k <= 0``), and the heads of a group sum to at most 1 (exactly 1 for
a mandatory group, schedule cost 0). The objective's part that reads the
groups is :func:`fsw_scheduler.solving.ilp.objective.unscheduled_terms`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from .program import EQ, LE

if TYPE_CHECKING:
    from ...model.problem import Alternative, Problem
    from .program import Program, Terms


class Columns(Protocol):
    """What the rows read of a formulation's variables."""

    def placeable(self, task_id: str) -> bool:
        """True if the task has at least one allowed start time."""

    def scheduled(self, task_id: str) -> int:
        """The column that is 1 iff the task is scheduled."""


def heads(
    problem: Problem, columns: Columns, group: Alternative
) -> list[int | None]:
    """The head column of each option of ``group``; None if not viable."""
    present = {task.id for task in problem.tasks}
    found: list[int | None] = []
    for option in group.options:
        viable = all(
            name in present and columns.placeable(name) for name in option
        )
        found.append(columns.scheduled(option[0]) if viable else None)
    return found


def alternative_rows(
    program: Program, problem: Problem, columns: Columns
) -> None:
    """Add the rows of every group of ``problem`` (see the module)."""
    present = {task.id for task in problem.tasks}
    for group in problem.alternatives:
        option_heads = heads(problem, columns, group)
        pick: Terms = {}
        for option, head in zip(group.options, option_heads, strict=True):
            for name in option:
                if name not in present or not columns.placeable(name):
                    continue
                column = columns.scheduled(name)
                if head is None:
                    program.add_row({column: 1.0}, LE, 0.0)
                elif column != head:
                    program.add_row({head: 1.0, column: -1.0}, EQ, 0.0)
            if head is not None:
                pick[head] = pick.get(head, 0.0) + 1.0
        if not pick:
            continue
        mandatory = group.schedule_cost == 0
        program.add_row(pick, EQ if mandatory else LE, 1.0)


def impossible_groups(problem: Problem, columns: Columns) -> list[str]:
    """Mandatory groups present in ``problem`` with no viable option."""
    present = {task.id for task in problem.tasks}
    return [
        group.id
        for group in problem.alternatives
        if group.schedule_cost == 0
        and any(n in present for option in group.options for n in option)
        and all(head is None for head in heads(problem, columns, group))
    ]
