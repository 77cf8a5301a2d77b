"""Start-time domains tightened by precedences (pure).

Every task starts in ``[earliest, latest]`` given by horizon, feasible
interval and pin (:meth:`Problem.start_bounds`). Precedences shrink these
ranges further whenever both ends would be scheduled together; the ILP uses
the result to create fewer variables, and the explanations use it to say
when a precedence alone makes a task impossible. The rules, for a
precedence ``i -> j`` with gap ``g = length_i + offset``:

* any kind: ``j`` scheduled implies ``i`` scheduled with ``s_j >= s_i + g``,
  so ``earliest_j >= earliest_i + g``;
* tight: also ``s_j <= s_i + g``, so ``latest_j <= latest_i + g``;
* scope ``both``: ``i`` scheduled implies ``j`` scheduled, so
  ``latest_i <= latest_j - g`` and, when tight,
  ``earliest_i >= earliest_j - g``.

A task whose range becomes empty can never be scheduled; with scope
``both`` that empties its partner too.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

if TYPE_CHECKING:
    from .model import Problem


class Domain(msgspec.Struct, frozen=True):
    """Allowed start times ``[earliest, latest]`` of one task.

    ``cause`` says what emptied the range (``window`` or ``precedence``)
    and ``detail`` says how, when :attr:`empty`.
    """

    earliest: int
    latest: int
    cause: str = ""
    detail: str = ""

    @property
    def empty(self) -> bool:
        """True when no start time is allowed."""
        return self.earliest > self.latest


def start_domains(problem: Problem) -> dict[str, Domain]:
    """Return each task's start domain after precedence propagation.

    Parameters
    ----------
    problem
        A validated problem.

    Returns
    -------
    dict[str, Domain]
        Keyed by task id, in problem task order.
    """
    length = {task.id: task.length for task in problem.tasks}
    low: dict[str, int] = {}
    high: dict[str, int] = {}
    cause: dict[str, tuple[str, str]] = {}
    for task in problem.tasks:
        low[task.id], high[task.id] = problem.start_bounds(task)
        if low[task.id] > high[task.id]:
            cause[task.id] = (
                "window",
                "feasible interval and horizon leave no start time",
            )

    def empty(name: str) -> bool:
        return low[name] > high[name]

    def kill(name: str, why: str) -> bool:
        if empty(name):
            return False
        high[name] = low[name] - 1
        cause[name] = ("precedence", why)
        return True

    # Each pass only shrinks ranges, so this terminates; the cap bounds
    # the work on long positive lax cycles, where any intermediate state
    # is still a valid relaxation.
    for _ in range(2 * len(length) + 4):
        changed = False
        for prec in problem.precedences:
            i, j = prec.before, prec.after
            gap = length[i] + prec.offset
            if empty(i):
                changed |= kill(j, f"needs {i}, which cannot be placed")
            if prec.scope == "both" and empty(j):
                changed |= kill(
                    i, f"must be scheduled with {j}, which cannot be placed"
                )
            if empty(i) or empty(j):
                continue
            bounds = [(j, "low", low[i] + gap)]
            if prec.kind == "tight":
                bounds.append((j, "high", high[i] + gap))
            if prec.scope == "both":
                bounds.append((i, "high", high[j] - gap))
                if prec.kind == "tight":
                    bounds.append((i, "low", low[j] - gap))
            for name, side, value in bounds:
                if side == "low" and value > low[name]:
                    low[name], changed = value, True
                elif side == "high" and value < high[name]:
                    high[name], changed = value, True
                if empty(name) and name not in cause:
                    cause[name] = (
                        "precedence",
                        f"{prec.kind} precedence {i} -> {j} "
                        f"(offset {prec.offset}) leaves no start time "
                        "inside the windows",
                    )
        if not changed:
            break
    return {
        name: Domain(low[name], high[name], *cause.get(name, ("", "")))
        for name in length
    }
