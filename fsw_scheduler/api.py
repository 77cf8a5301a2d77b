"""The library entry points, taking typed objects, plain dicts or JSON.

:func:`solve`, :func:`check_plan` and :func:`replan` accept a problem, a plan,
a goal or an event in any of the forms a caller is likely to hold:

* the typed object (:class:`~fsw_scheduler.model.problem.Problem`,
  :class:`~fsw_scheduler.model.plan.Plan`,
  :class:`~fsw_scheduler.model.goal.Goal`,
  an event of :mod:`fsw_scheduler.replan`), used as it is;
* a plain ``dict`` as :func:`json.load` returns it;
* JSON text (``str`` or ``bytes``), as read from a file or the bus;
* a :class:`pathlib.Path` to a JSON file (a ``str`` is always JSON text,
  never a file name).

Dicts and text go through the same strict decoding and validation as the
command line, so a mistake raises :class:`~fsw_scheduler.errors.InputError`
naming every field path and reason, never a bare ``KeyError``.

Like :mod:`fsw_scheduler.solving.solve`, this module imports the solver backend
only when a solve runs, so ``import fsw_scheduler`` stays free of PuLP.
(It imports :mod:`fsw_scheduler.solving.solve` eagerly on purpose: the package
top binds the name ``solve`` to a function, and a submodule imported for
the first time later would rebind it to the module.)
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import msgspec

from .analysis.check import CheckReport
from .analysis.check import check_plan as check_typed
from .analysis.moved import why_moved
from .errors import FieldIssue, InputError
from .model.change import ActivityFailed, Change, LevelsMeasured, decode_change
from .model.codec import decode_strict
from .model.goal import Goal
from .model.limits import MoveCost, Span
from .model.plan import Plan, SolveStatus
from .model.problem import Problem, decode_problem
from .model.stability import Mode, Stability
from .model.validation import validate_problem
from .replan.commit import commit_pins, pin_blockers, pinned_problem
from .replan.diff import PlanDiff, diff_plans
from .replan.schedule import Schedule, empty_plan
from .replan.triggers import apply_change
from .solving.solve import solve as solve_problem

__all__ = [
    "ChangeLike",
    "PlanLike",
    "ProblemLike",
    "ReplanSettings",
    "as_change",
    "as_plan",
    "as_problem",
    "check_plan",
    "replan",
    "solve",
]

#: A problem as a typed object, a dict, JSON text or a JSON file.
ProblemLike = Problem | Mapping[str, Any] | str | bytes | os.PathLike[str]
#: A plan as a typed object, a dict, JSON text or a JSON file.
PlanLike = Plan | Mapping[str, Any] | str | bytes | os.PathLike[str]
#: A goal or an event as a typed object, a dict, JSON text or a JSON file.
ChangeLike = (
    Goal
    | ActivityFailed
    | LevelsMeasured
    | Mapping[str, Any]
    | str
    | bytes
    | os.PathLike[str]
)


def _as_json(value: object, what: str) -> bytes | str:
    """JSON text of a dict or of a file, or the text itself."""
    if isinstance(value, os.PathLike):
        try:
            return Path(value).read_bytes()
        except OSError as error:
            raise InputError(
                [FieldIssue("", f"cannot read {value}: {error.strerror}")],
                what,
            ) from None
    if isinstance(value, str | bytes | bytearray):
        return bytes(value) if isinstance(value, bytearray) else value
    if isinstance(value, Mapping):
        try:
            return msgspec.json.encode(value)
        except (TypeError, msgspec.EncodeError) as error:
            raise InputError(
                [FieldIssue("", f"not JSON-like data: {error}")], what
            ) from None
    raise InputError(
        [
            FieldIssue(
                "",
                f"expected a {what}, a dict or JSON text, "
                f"got {type(value).__name__}",
            )
        ],
        what,
    )


def as_problem(value: ProblemLike, *, allow_empty: bool = False) -> Problem:
    """A validated :class:`Problem` from any accepted form.

    Parameters
    ----------
    value
        A :class:`Problem` (validated again, since a hand-built one may be
        wrong), a dict in the problem format, or its JSON text.
    allow_empty
        Accept a problem with no task.

    Returns
    -------
    Problem
        The problem.

    Raises
    ------
    InputError
        With one issue per mistake, each naming its field path.
    """
    if isinstance(value, Problem):
        issues = validate_problem(value, allow_empty=allow_empty)
        if issues:
            raise InputError(issues, "problem")
        return value
    return decode_problem(_as_json(value, "problem"), allow_empty=allow_empty)


def as_plan(value: PlanLike) -> Plan:
    """A :class:`Plan` from a plan, a dict in the plan format or JSON."""
    if isinstance(value, Plan):
        return value
    return decode_strict(_as_json(value, "plan"), Plan, "plan")


def as_change(value: ChangeLike) -> Change:
    """A goal or an event from a typed object, a dict or JSON text.

    A document with an ``event`` key is an event (``activity_failed`` or
    ``levels``); any other is a goal.
    """
    if isinstance(value, Goal | ActivityFailed | LevelsMeasured):
        return value
    return decode_change(_as_json(value, "goal or event"))


def solve(
    problem: ProblemLike,
    solver: str = "cbc",
    *,
    time_limit: float | None = None,
    threads: int = 1,
    seed: int = 0,
    explain: bool = False,
    warm: PlanLike | None = None,
    explain_budget: float | None = None,
) -> Plan:
    """Solve a problem given in any accepted form.

    Parameters
    ----------
    problem
        A :class:`Problem`, a dict in the problem format, or JSON text.
    solver, time_limit, threads, seed, explain, explain_budget
        As :func:`fsw_scheduler.solving.solve.solve`.
    warm
        A plan to start from, in any form :func:`as_plan` takes.

    Returns
    -------
    Plan
        The plan with its honest status (``optimal``, ``feasible``,
        ``infeasible`` or ``unknown``).

    Raises
    ------
    InputError
        The problem or the warm plan is malformed or invalid.

    Examples
    --------
    >>> import fsw_scheduler as fs
    >>> plan = fs.solve({"horizon": 5, "tasks": [
    ...     {"id": "a", "length": 2, "delay_cost": 1, "schedule_cost": 1}]})
    >>> plan.to_dict()["activities"]
    [{'task': 'a', 'start': 0, 'end': 2}]
    """
    return solve_problem(
        as_problem(problem),
        solver,
        time_limit=time_limit,
        threads=threads,
        seed=seed,
        explain=explain,
        warm=None if warm is None else as_plan(warm),
        explain_budget=explain_budget,
    )


def check_plan(problem: ProblemLike, plan: PlanLike) -> CheckReport:
    """Check a plan against a problem, both in any accepted form.

    Parameters
    ----------
    problem
        The problem, as :func:`as_problem` takes it.
    plan
        The plan, as :func:`as_plan` takes it.

    Returns
    -------
    CheckReport
        ``ok`` when no constraint is violated; every violation by name and
        the objective recomputed from the activities
        (see :func:`fsw_scheduler.analysis.check.check_plan`).
    """
    return check_typed(as_problem(problem), as_plan(plan))


def replan(
    problem: ProblemLike,
    plan: PlanLike,
    change: ChangeLike,
    now: int,
    *,
    solver: str = "cbc",
    time_limit: float | None = None,
    commit_window: int = 0,
    stability: Mode = "off",
    move_cost: int = 5,
) -> tuple[Problem, Plan, PlanDiff]:
    """Apply a goal or an event to a running plan at time ``now``.

    The paper's online rescheduling rules build the new problem over
    ``[now, now + horizon)``, which is then solved; as ``fsw-scheduler
    replan``. The predictable-replan settings mean what they mean to
    ``run`` (docs/rescheduling.md, "Predictable replans"); their
    defaults are the paper's replan.

    Parameters
    ----------
    problem, plan
        The running problem and its plan, in any accepted form.
    change
        A goal, or an event (``{"event": "activity_failed", "task": ...,
        "at": ...}`` or ``{"event": "levels", "levels": {...}, "at":
        ...}``), in any accepted form.
    now
        Time unit of the replan.
    solver, time_limit
        Passed to the solver.
    commit_window
        Units from ``now``: each activity of ``plan`` that starts in
        ``[now, now + commit_window)`` keeps its start, unless keeping
        them leaves no plan (then the plan is ``degraded`` and its
        ``why`` names each pin it broke, cause ``commit_window``).
    stability
        ``off``, ``moves`` (each moved activity costs ``move_cost``) or
        ``lexicographic`` (fewest moves before least delay).
    move_cost
        The price of one moved activity under ``moves``, 1 to 1000.

    Returns
    -------
    tuple
        The new problem, its plan, and the difference from ``plan`` (kept,
        moved, each move with why when known, added, removed with the rule
        that removed each task).

    Raises
    ------
    InputError
        A malformed input, a setting out of its range, or a change the
        rules reject (nothing solved).
    """
    return replan_typed(
        as_problem(problem),
        as_plan(plan),
        as_change(change),
        now,
        solver=solver,
        time_limit=time_limit,
        settings=ReplanSettings(commit_window, stability, move_cost),
    )


SolveFn = Callable[..., Plan]


def replan_typed(
    problem: Problem,
    plan: Plan,
    change: Change,
    now: int,
    *,
    solver: str = "cbc",
    time_limit: float | None = None,
    solve_fn: SolveFn | None = None,
    settings: ReplanSettings | None = None,
) -> tuple[Problem, Plan, PlanDiff]:
    """One replan on typed objects: :func:`replan` once its inputs are read.

    Parameters
    ----------
    problem, plan
        The running problem and its plan (the start of a session).
    change
        From :func:`~fsw_scheduler.model.change.decode_change`.
    now
        Time unit of the replan.
    solver, time_limit
        Passed to the solver.
    solve_fn
        The solve function (default
        :func:`fsw_scheduler.solving.solve.solve`).
    settings
        The commit window and the move term (default: the paper's).

    Returns
    -------
    tuple
        The new problem, its plan and the difference with ``plan``.

    Raises
    ------
    InputError
        The change is rejected; nothing was solved.
    """
    if solve_fn is None:
        solve_fn = solve_problem
    settings = (settings or ReplanSettings()).checked()
    replan = apply_change(Schedule.begin(problem, plan), change, now)
    # What the replan may move: planned, not started by ``now``, and kept
    # by the rules (as the node counts those not yet dispatched).
    gone = {r.task for r in replan.removed} | set(replan.continuing)
    live = {t.id for t in replan.problem.tasks}
    previous = {
        a.task: a.start
        for a in plan.activities
        if a.start >= now and a.task in live and a.task not in gone
    }
    stability = Stability(
        previous=previous,
        mode=settings.stability,
        move_cost=settings.move_cost,
    )
    pins = commit_pins(replan.problem, previous, settings.commit_window)
    began = time.perf_counter()
    if not replan.problem.tasks:
        new_plan = empty_plan()
    else:
        new_plan = solve_fn(
            pinned_problem(replan.problem, pins),
            solver,
            time_limit=time_limit,
            warm=replan.warm,
            stability=stability,
        )
        if pins and new_plan.status is SolveStatus.INFEASIBLE:
            # The window left no plan: the degraded path, as the node's,
            # in what is left of the limit (it bounds the whole answer).
            left = (
                None
                if time_limit is None
                else max(0.0, time_limit - (time.perf_counter() - began))
            )
            new_plan = solve_fn(
                replan.problem,
                solver,
                time_limit=left,
                warm=replan.warm,
                stability=stability,
            )
            broken = pin_blockers(pins, new_plan, now, settings.commit_window)
            if new_plan.status.has_plan and broken:
                new_plan = new_plan.replace(
                    status=SolveStatus.DEGRADED, why=(*broken, *new_plan.why)
                )
    reasons = (
        why_moved(replan.problem, new_plan, previous)
        if new_plan.status.has_plan
        else {}
    )
    diff = diff_plans(
        plan,
        new_plan,
        replan.removed,
        continuing=replan.continuing,
        reasons=reasons,
    )
    return replan.problem, new_plan, diff


class ReplanSettings(msgspec.Struct, frozen=True):
    """The predictable-replan settings of an offline replan, with the
    names, ranges and meaning of ``run``'s (default: the paper's).

    Attributes
    ----------
    commit_window
        Units from ``now`` in which planned starts are kept.
    stability
        ``off``, ``moves`` or ``lexicographic``.
    move_cost
        The price of one moved activity under ``moves``.
    """

    commit_window: Span = 0
    stability: Mode = "off"
    move_cost: MoveCost = 5

    def checked(self) -> ReplanSettings:
        """These settings, or InputError naming each one out of its
        range (the ranges of ``run``'s settings, declared once in
        :mod:`fsw_scheduler.model.limits`)."""
        return decode_strict(
            msgspec.json.encode(self), ReplanSettings, "settings"
        )
