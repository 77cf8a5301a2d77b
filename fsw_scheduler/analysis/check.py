"""Independent plan checker: does a plan obey every rule of the problem?

:func:`check_plan` re-derives every constraint of the problem format from
the raw fields of the :class:`~fsw_scheduler.model.problem.Problem` and walks
the horizon span by span, a span being units with the same running users,
windows, capacity and external rate (so judged alike; consumable levels
are still summed unit by unit). It deliberately shares no code with the
ILP builder (no ``pulp``, nothing from ``solve`` or ``solvers``, not even
:meth:`Problem.start_bounds`): a bug in the formulation then cannot hide
itself by being repeated here. It is the oracle of the property tests and
the engine of ``fsw-scheduler check``.

Every violation is reported, not just the first. Rule names:

``coverage``
    every task exactly once across ``activities`` and ``unscheduled``;
    no unknown task ids. A group member is listed at most once (only in
    ``activities`` in the plan format); a group none of whose tasks is
    scheduled is listed in ``unscheduled`` by its id, and only then.
``length``
    ``end - start == length``.
``horizon``
    ``start >= problem.start`` and ``end <= problem.start + horizon``.
``window``
    the feasible interval ``[a, b]``: with the ``task`` reading
    ``start >= a`` and ``end <= b``; with the ``start`` reading
    ``a <= start <= b``. A task's own ``feasible_interval_applies_to``
    overrides the problem's.
``fixed_start``
    a pinned task is scheduled and starts exactly at its pin.
``mandatory``
    a task with ``schedule_cost`` 0 that is no group member is scheduled;
    a group with ``schedule_cost`` 0 has an option scheduled.
``alternatives``
    the tasks of an option are scheduled all together or not at all, and
    at most one option of a group is.
``binary``
    at most one running user of a binary resource per time unit, and
    none in a unit outside its ``available`` windows.
``multiple``
    the summed amounts of running users stay within the capacity of each
    unit (a number, or the capacity step the unit is in).
``consumable``
    the level at the end of every time unit stays >= 0; with a capacity
    the level at the end of unit ``t`` is ``min(max, level at t-1 +
    external(t) - net use in t)`` (what a full store cannot take is lost);
    ``external`` is 0 without steps and before the first one.
``precedence``
    tight: ``s_after == s_before + l_before + offset``; lax: ``>=``.
    Only checked when both tasks are scheduled.
``scope``
    ``both``: both tasks or neither are scheduled; ``at_least_first``:
    ``after`` scheduled needs ``before`` scheduled.
``objective``
    the plan's reported objective equals the recomputed one: a task left
    out costs its schedule cost unless it is a group member; a group with
    no scheduled task costs the group's, once.

Conventions for malformed plans (documented so that reports are stable):

* An activity runs over the interval it reports, ``[start, end)``; that is
  what would be dispatched. A wrong ``end`` is a ``length`` violation, and
  resources are still checked on the reported interval.
* Precedences use the problem's ``length`` of ``before`` (the formula of
  the problem format) and the first activity listed for each task.
* Activities listed twice are both counted for resources (both would be
  dispatched); activities of unknown tasks use no resource.
* Resources are walked over the horizon. Units an activity runs before the
  horizon still drain consumables (they are counted at the first unit);
  anything outside the horizon is also a ``horizon`` violation.
* A task is *scheduled* when it has an activity; everything else is *left
  out* for the objective, whether or not ``unscheduled`` lists it.
* Plans whose status carries no plan (``infeasible``, ``unknown``) are
  checked for ``coverage`` only, plus ``objective`` when they report one:
  the solver gave up or proved that mandatory tasks cannot be placed, so
  mandatory, pin and placement rules would only restate that status.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING

import msgspec

from ..model.plan import Objective, objective_weight
from .spans import (
    TOLERANCE,
    Hit,
    below_zero,
    level_after,
    resource_users,
    running_key,
    runs,
    segments,
    span_text,
    steps_at,
)

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from ..model.plan import Activity, Plan
    from ..model.problem import Consumable, Precedence, Problem, Task
    from ..model.stability import Stability

RULES = (
    "coverage",
    "length",
    "horizon",
    "window",
    "fixed_start",
    "mandatory",
    "alternatives",
    "binary",
    "multiple",
    "consumable",
    "precedence",
    "scope",
    "objective",
)
"""Every rule name :func:`check_plan` may report, in report order."""


class Violation(msgspec.Struct, frozen=True):
    """One broken rule.

    Attributes
    ----------
    rule
        One of :data:`RULES`.
    task
        The task at fault, or None when several tasks share the blame
        (resources) or the rule is about the whole plan (objective).
    time
        The first time unit concerned, or None when time plays no part.
    detail
        What is wrong, in plain words, with the numbers involved.
    """

    rule: str
    task: str | None
    time: int | None
    detail: str


class CheckReport(msgspec.Struct, frozen=True):
    """Result of :func:`check_plan`.

    Attributes
    ----------
    violations
        Every violation found, grouped by rule in :data:`RULES` order.
    objective
        The objective recomputed from the plan's activities (the
        problem format's objective), whatever the plan itself reports.
    """

    violations: tuple[Violation, ...]
    objective: Objective

    @property
    def ok(self) -> bool:
        """True when the plan breaks no rule."""
        return not self.violations

    @property
    def rules(self) -> frozenset[str]:
        """The names of the rules that are broken."""
        return frozenset(v.rule for v in self.violations)

    def of_rule(self, rule: str) -> tuple[Violation, ...]:
        """The violations of ``rule``."""
        return tuple(v for v in self.violations if v.rule == rule)


def check_plan(
    problem: Problem, plan: Plan, stability: Stability | None = None
) -> CheckReport:
    """Check ``plan`` against every constraint of ``problem``.

    Parameters
    ----------
    problem
        The problem the plan claims to solve.
    plan
        The plan to check; it may be malformed in any way (unknown or
        duplicated tasks, wrong ends, times outside the horizon).
    stability
        The previous starts and the price of moving them, for a replan
        that prices moves: the objective is recomputed with its move
        part (:mod:`fsw_scheduler.model.stability`). Default: none.

    Returns
    -------
    CheckReport
        Every violation found and the recomputed objective. See the module
        docstring for the rules and the conventions on malformed plans.
    """
    tasks = {task.id: task for task in problem.tasks}
    known = [a for a in plan.activities if a.task in tasks]
    first: dict[str, Activity] = {}
    for activity in known:
        first.setdefault(activity.task, activity)
    objective = _objective(problem, first)
    if stability is not None and stability.active:
        objective = stability.objective(
            problem,
            objective.unscheduled_cost,
            objective.delay_cost,
            {name: a.start for name, a in first.items()},
        )

    violations = list(_coverage(problem, plan))
    if plan.status.has_plan:
        violations += _placement(problem, tasks, known)
        violations += _selection(problem, first)
        violations += _alternatives(problem, first)
        violations += _binary(problem, tasks, known)
        violations += _multiple(problem, tasks, known)
        violations += _consumable(problem, tasks, known)
        violations += _precedences(problem, tasks, first)
    if plan.objective is not None and plan.objective != objective:
        violations.append(
            Violation(
                "objective",
                None,
                None,
                f"plan reports {_show(plan.objective)} but its activities "
                f"give {_show(objective)}",
            )
        )
    order = {rule: idx for idx, rule in enumerate(RULES)}
    violations.sort(key=lambda v: order.get(v.rule, len(order)))
    return CheckReport(tuple(violations), objective)


def improves(problem: Problem, plan: Plan, best: Plan) -> bool:
    """True if ``plan`` costs less than ``best`` and the checker accepts
    it (the cost first: the checker runs only on a plan worth taking)."""
    return (
        plan.objective is not None
        and best.objective is not None
        and plan.objective.total < best.objective.total
        and check_plan(problem, plan).ok
    )


def format_report(report: CheckReport) -> str:
    """Render ``report`` for a human, one violation per line.

    Parameters
    ----------
    report
        A result of :func:`check_plan`.

    Returns
    -------
    str
        A first line with the verdict and the recomputed objective, then
        one ``[rule] task @t: detail`` line per violation.
    """
    head = f"objective {_show(report.objective)}"
    if report.ok:
        return f"plan is valid; {head}"
    count = len(report.violations)
    plural = "s" * (count != 1)
    lines = [f"plan has {count} violation{plural}; {head}"]
    for v in report.violations:
        where = "".join(
            (
                f" {v.task}" if v.task is not None else "",
                f" @t={v.time}" if v.time is not None else "",
            )
        )
        lines.append(f"  [{v.rule}]{where}: {v.detail}")
    return "\n".join(lines)


# --------------------------------------------------------------------------
# Objective


def _members(problem: Problem) -> set[str]:
    return {
        name
        for group in problem.alternatives
        for option in group.options
        for name in option
    }


def _objective(problem: Problem, first: dict[str, Activity]) -> Objective:
    members = _members(problem)
    left_out = sum(
        t.schedule_cost
        for t in problem.tasks
        if t.id not in first and t.id not in members
    )
    for group in problem.alternatives:
        if not any(n in first for option in group.options for n in option):
            left_out += group.schedule_cost
    delay = sum(
        task.delay_cost * (first[task.id].start - problem.start)
        for task in problem.tasks
        if task.id in first
    )
    weight = objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    return Objective(left_out, delay, weight * left_out + delay)


def _show(objective: Objective) -> str:
    moves = (
        ""
        if objective.moves is msgspec.UNSET
        else f", moves={objective.moves}"
    )
    return (
        f"(unscheduled_cost={objective.unscheduled_cost}, "
        f"delay_cost={objective.delay_cost}{moves}, total={objective.total})"
    )


# --------------------------------------------------------------------------
# Rules on the listing and on each activity on its own


def _coverage(problem: Problem, plan: Plan) -> Iterator[Violation]:
    ids = {task.id for task in problem.tasks}
    members = _members(problem)
    group_ids = {group.id for group in problem.alternatives}
    placed = Counter(a.task for a in plan.activities)
    dropped = Counter(plan.unscheduled)
    for task in problem.tasks:
        n_placed, n_dropped = placed[task.id], dropped[task.id]
        if n_placed + n_dropped == 1:
            continue
        if n_placed + n_dropped == 0:
            if task.id in members:
                continue  # a group's tasks are not listed one by one
            detail = "appears neither in activities nor in unscheduled"
        elif n_placed and n_dropped:
            detail = (
                f"appears in both activities ({n_placed}x) and "
                f"unscheduled ({n_dropped}x)"
            )
        elif n_placed:
            detail = f"appears {n_placed} times in activities"
        else:
            detail = f"appears {n_dropped} times in unscheduled"
        yield Violation("coverage", task.id, None, detail)
    for group in problem.alternatives:
        names = [n for option in group.options for n in option]
        if not any(n in ids for n in names):
            continue
        scheduled = any(placed[n] for n in names)
        listed = dropped[group.id]
        if scheduled and listed:
            yield Violation(
                "coverage",
                group.id,
                None,
                "is listed in unscheduled but has an option scheduled",
            )
        elif listed > 1:
            yield Violation(
                "coverage",
                group.id,
                None,
                f"appears {listed} times in unscheduled",
            )
        elif not scheduled and not listed and plan.status.has_plan:
            yield Violation(
                "coverage",
                group.id,
                None,
                "no option is scheduled, and the group is not listed in "
                "unscheduled",
            )
    for where, counts in (("activities", placed), ("unscheduled", dropped)):
        for name in counts:
            known = ids | group_ids if where == "unscheduled" else ids
            if name not in known:
                yield Violation(
                    "coverage", name, None, f"unknown task id in {where}"
                )


def _placement(
    problem: Problem, tasks: dict[str, Task], known: Sequence[Activity]
) -> Iterator[Violation]:
    end = problem.start + problem.horizon
    for activity in known:
        task = tasks[activity.task]
        name, start = activity.task, activity.start
        span = f"[{start}, {activity.end})"
        if activity.end - start != task.length:
            yield Violation(
                "length",
                name,
                start,
                f"runs {span} ({activity.end - start} units) but its "
                f"length is {task.length}",
            )
        if start < problem.start or activity.end > end:
            yield Violation(
                "horizon",
                name,
                start,
                f"runs {span}, outside the horizon [{problem.start}, {end})",
            )
        yield from _window(problem, task, activity)
        if task.fixed_start is not None and start != task.fixed_start:
            yield Violation(
                "fixed_start",
                name,
                start,
                f"starts at {start} but is pinned to {task.fixed_start}",
            )


def _window(
    problem: Problem, task: Task, activity: Activity
) -> Iterator[Violation]:
    if task.feasible_interval is None:
        return
    low, high = task.feasible_interval
    reading = (
        task.feasible_interval_applies_to
        or problem.feasible_interval_applies_to
    )
    start = activity.start
    if reading == "task":
        if start < low or activity.end > high:
            yield Violation(
                "window",
                task.id,
                start,
                f"runs [{start}, {activity.end}), not inside its feasible "
                f"interval [{low}, {high}] (whole-task reading)",
            )
    elif not low <= start <= high:
        yield Violation(
            "window",
            task.id,
            start,
            f"starts at {start}, outside its feasible interval "
            f"[{low}, {high}] (start reading)",
        )


def _selection(
    problem: Problem, first: dict[str, Activity]
) -> Iterator[Violation]:
    members = _members(problem)
    for task in problem.tasks:
        if task.id in first:
            continue
        if task.fixed_start is not None:
            yield Violation(
                "fixed_start",
                task.id,
                task.fixed_start,
                f"is pinned to start at {task.fixed_start} but is not "
                "scheduled",
            )
        if task.schedule_cost == 0 and task.id not in members:
            yield Violation(
                "mandatory",
                task.id,
                None,
                "is mandatory (schedule_cost 0) but is not scheduled",
            )
    for group in problem.alternatives:
        if group.schedule_cost == 0 and not any(
            name in first for option in group.options for name in option
        ):
            yield Violation(
                "mandatory",
                group.id,
                None,
                "is a mandatory group (schedule_cost 0) but no option is "
                "scheduled",
            )


def _alternatives(
    problem: Problem, first: dict[str, Activity]
) -> Iterator[Violation]:
    for group in problem.alternatives:
        picked = []
        for idx, option in enumerate(group.options):
            placed = [name for name in option if name in first]
            if placed:
                picked.append(idx)
            if placed and len(placed) < len(option):
                missing = [name for name in option if name not in first]
                yield Violation(
                    "alternatives",
                    missing[0],
                    None,
                    f"group {group.id!r} option {idx}: {', '.join(placed)} "
                    f"scheduled without {', '.join(missing)} (an option's "
                    "tasks are scheduled all together or not at all)",
                )
        if len(picked) > 1:
            yield Violation(
                "alternatives",
                None,
                None,
                f"group {group.id!r}: options {picked} are all scheduled, "
                "at most one may be",
            )


# --------------------------------------------------------------------------
# Resources: walk the horizon span by span (see .spans)


def _available(problem: Problem, resource: str, t: int) -> bool:
    binary = problem.resources.binary
    spec = binary.get(resource) if isinstance(binary, dict) else None
    if spec is None or spec.available is None:
        return True
    return any(low <= t < high for low, high in spec.available)


def _capacity(problem: Problem, resource: str, t: int) -> float:
    value = problem.resources.multiple[resource]
    if isinstance(value, int | float):
        return float(value)
    found = steps_at(value.steps, t)
    return 0.0 if found is None else found


def _binary(
    problem: Problem, tasks: dict[str, Task], known: Sequence[Activity]
) -> Iterator[Violation]:
    binary = problem.resources.binary
    for resource in binary:
        spec = binary.get(resource) if isinstance(binary, dict) else None
        windows = (
            () if spec is None or spec.available is None else spec.available
        )
        spans = list(
            segments(
                problem,
                resource_users(tasks, known, resource),
                (t for window in windows for t in window),
            )
        )
        closed = [
            Hit(t, running_key(running), len(running), end - 1)
            for t, end, running in spans
            if running and not _available(problem, resource, t)
        ]
        for run in runs(closed):
            yield Violation(
                "binary",
                None,
                run[0].t,
                f"{resource!r} at {span_text(run)}: used by "
                f"{', '.join(run[0].key)} outside its available windows",
            )
        hits = [
            Hit(t, running_key(running), len(running), end - 1)
            for t, end, running in spans
            if len(running) > 1
        ]
        for run in runs(hits):
            yield Violation(
                "binary",
                None,
                run[0].t,
                f"{resource!r} at {span_text(run)}: {int(run[0].value)} users "
                f"at once ({', '.join(run[0].key)}), at most 1 allowed",
            )


def _multiple(
    problem: Problem, tasks: dict[str, Task], known: Sequence[Activity]
) -> Iterator[Violation]:
    for resource, value in problem.resources.multiple.items():
        steps = () if isinstance(value, int | float) else value.steps
        hits = []
        for t, end, running in segments(
            problem,
            resource_users(tasks, known, resource),
            (since for since, _ in steps),
        ):
            used = sum(amount for _, amount in running)
            if used > _capacity(problem, resource, t) + TOLERANCE:
                hits.append(Hit(t, running_key(running), used, end - 1))
        for run in runs(hits):
            capacity = _capacity(problem, resource, run[0].t)
            yield Violation(
                "multiple",
                None,
                run[0].t,
                f"{resource!r} at {span_text(run)}: use {run[0].value:g} "
                f"exceeds capacity {capacity:g} ({', '.join(run[0].key)})",
            )


def _consumable(
    problem: Problem, tasks: dict[str, Task], known: Sequence[Activity]
) -> Iterator[Violation]:
    for resource, spec in problem.resources.consumable.items():
        initial, ceiling = _initial_and_ceiling(spec)
        external = () if isinstance(spec, int | float) else spec.external
        top = math.inf if ceiling is None else ceiling
        users = resource_users(tasks, known, resource)
        # Units run before the horizon (already a horizon violation) still
        # drained the resource; count them at the first unit.
        level = initial - sum(
            amount * max(0, min(a.end, problem.start) - a.start)
            for a, amount in users
        )
        level = min(top, level)
        hits = []
        spans = segments(problem, users, (since for since, _ in external))
        for t0, end, running in spans:
            # Net use of the unit, then the ceiling: what a full store
            # cannot take is lost. The rate is the same in every unit of
            # the span, so the level after k units is level + k * rate
            # (capped once it reaches the ceiling when rising): the span
            # is judged in closed form, not unit by unit, so a long
            # horizon costs the plan's size (H = 1,000,000: 0.9 s a
            # check before).
            rate = (steps_at(external, t0) or 0.0) - sum(
                amount for _, amount in running
            )
            hits += below_zero(t0, end, level, rate, top)
            level = level_after(level, rate, end - t0, top)
        for run in runs(hits):
            lowest = min(hit.value for hit in run)
            yield Violation(
                "consumable",
                None,
                run[0].t,
                f"{resource!r} at {span_text(run)}: level below 0 (first "
                f"{run[0].value:g}, lowest {lowest:g}; initial "
                f"{initial:g}"
                + ("" if ceiling is None else f", capacity {ceiling:g}")
                + ")",
            )


def _initial_and_ceiling(
    spec: float | Consumable,
) -> tuple[float, float | None]:
    """A consumable's initial level and capacity, from its raw field.

    A plain number is the initial level with no capacity; an object has
    ``initial`` and an optional ``max``.
    """
    if isinstance(spec, int | float):
        return float(spec), None
    return float(spec.initial), None if spec.max is None else float(spec.max)


# --------------------------------------------------------------------------
# Precedences


def _precedences(
    problem: Problem, tasks: dict[str, Task], first: dict[str, Activity]
) -> Iterator[Violation]:
    for prec in problem.precedences:
        if prec.before not in tasks or prec.after not in tasks:
            continue
        before, after = first.get(prec.before), first.get(prec.after)
        yield from _scope(prec, before, after)
        if before is None or after is None:
            continue
        target = before.start + tasks[prec.before].length + prec.offset
        relation = f"{_edge(prec)}: start({prec.after}) = {after.start}"
        if prec.kind == "tight" and after.start != target:
            yield Violation(
                "precedence",
                prec.after,
                after.start,
                f"{relation}, must be exactly {target}",
            )
        elif prec.kind == "lax" and after.start < target:
            yield Violation(
                "precedence",
                prec.after,
                after.start,
                f"{relation}, must be >= {target}",
            )


def _scope(
    prec: Precedence, before: Activity | None, after: Activity | None
) -> Iterator[Violation]:
    if prec.scope == "both" and (before is None) != (after is None):
        missing, present = (
            (prec.before, prec.after)
            if before is None
            else (prec.after, prec.before)
        )
        yield Violation(
            "scope",
            missing,
            None,
            f"{_edge(prec)}: {present!r} is scheduled but {missing!r} is "
            "not (scope both: both or neither)",
        )
    elif prec.scope == "at_least_first" and after and before is None:
        yield Violation(
            "scope",
            prec.before,
            None,
            f"{_edge(prec)}: {prec.after!r} is scheduled without "
            f"{prec.before!r} (scope at_least_first)",
        )


def _edge(prec: Precedence) -> str:
    sign = "+" if prec.offset >= 0 else "-"
    return (
        f"{prec.kind} {prec.before} -> {prec.after} "
        f"(offset {sign}{abs(prec.offset)})"
    )
