"""Mandatory groups of alternatives none of whose options fits (pure).

A group of cost 0 must have one option scheduled, but no member task is
required on its own (:meth:`~fsw_scheduler.model.problem.Problem.
required`), so :func:`~fsw_scheduler.analysis.proofs.infeasibility`, which
looks at the tasks every plan must hold, never sees it. Here each option
is tried in turn: the problem with that option's tasks mandatory and the
other options' tasks gone (with their precedences: a task that needed
one of them is free in this relaxation, never wrongly held). When the
cheap proofs reject every option, no plan exists.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.plan import Blocker
from .domains import start_domains
from .proofs import infeasibility

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.problem import Alternative, Problem


def impossible_group(
    problem: Problem, stop: Callable[[], bool] | None = None
) -> tuple[Blocker, ...]:
    """A proof that a mandatory group has no option that fits, or ``()``.

    Parameters
    ----------
    problem
        A validated problem.
    stop
        True when time is up (the caller's deadline): no proof then.

    Returns
    -------
    tuple[Blocker, ...]
        Every member of the first such group, cause ``combination``, the
        detail naming each option's proof; empty when none is found.
    """
    for group in problem.alternatives:
        if group.schedule_cost != 0:
            continue
        why = []
        for idx, option in enumerate(group.options):
            if stop is not None and stop():
                return ()
            variant = _with_option(problem, group, idx)
            found = infeasibility(variant, start_domains(variant), stop)
            if not found:
                break
            why.append(
                f"option {idx} ({', '.join(option)}): {found[0].detail}"
            )
        else:
            detail = (
                f"one option of group {group.id} must be scheduled and none "
                f"fits: {'; '.join(why)}"
            )
            return tuple(
                Blocker(name, "combination", detail)
                for option in group.options
                for name in option
            )
    return ()


def _with_option(problem: Problem, group: Alternative, index: int) -> Problem:
    """``problem`` with option ``index`` of ``group`` mandatory, the other
    options' tasks and their precedences gone, and the group dissolved."""
    chosen = set(group.options[index])
    others = {name for option in group.options for name in option} - chosen
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(task, schedule_cost=0)
            if task.id in chosen
            else task
            for task in problem.tasks
            if task.id not in others
        ),
        precedences=tuple(
            prec
            for prec in problem.precedences
            if prec.before not in others and prec.after not in others
        ),
        alternatives=tuple(
            other for other in problem.alternatives if other.id != group.id
        ),
    )
