"""Late completions: what waits for an activity that runs past its end.

With ``late-completion = "push"`` the plan is flown by the facts, not
only by the clock (as Mars 2020's on-board executive waits for an
activity before it starts what depends on it):

* an activity is *held* (not commanded at its start) while something it
  depends on has not finished: a predecessor, by any of the four
  precedence kinds, that has not reported ``completed``, or an activity
  running past the end of its dispatch that holds a binary resource it
  needs, or a multiple one that the two would overfill;
* an activity still running at the end of its dispatch, with no report
  saying it ended, is taken by every replan as running on (a ``running``
  record at ``now``), never as finished on time;
* when a held activity's start has passed, the plan can no longer be
  flown as timed: one replan (trigger ``overrun``) moves what waits,
  taking each overrunning activity as running on for as long as it has
  overrun so far (at least one unit: 1, 1, 2, 4, ... replans grow
  apart, so a long overrun costs a few solves, not one per unit);
* a ``completed`` report after the end of its dispatch replans at once
  (trigger ``late_completion``) when it breaks a planned place (a
  successor or a resource sharer planned to start before the real end
  lets it) or when an overrun replan had pushed what waits on it further
  than needed;
* while an ``overrun`` or ``late_completion`` replan waits or runs, a
  held activity whose start has passed is not commanded late: that
  replan places it.

Off (the default), the plan is flown by the clock, as in the paper and in
the recordings made before this setting. Pure: no solver, no bus, no
clock but the engine's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.change import ExecutionReport

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping

    from ..model.plan import Activity
    from ..model.problem import Precedence, Task
    from ..replan.schedule import Replan, Schedule
    from .queue import SolveQueue
    from .state import EngineState

#: The setting's value that turns these rules on.
PUSH = "push"
#: The trigger of a replan caused by an activity running past its end.
OVERRUN = "overrun"
#: The trigger of a replan caused by a completion after its dispatch's end.
LATE_COMPLETION = "late_completion"
#: Lifecycle states of a command that may still run (no final answer).
_RUNNING = ("dispatched", "running", "cancelling")


def pushing(state: EngineState) -> bool:
    """Whether these rules are on (``late-completion = "push"``)."""
    return state.config.late_completion == PUSH


def overrunning(state: EngineState) -> dict[str, int]:
    """Each commanded activity past its end with no final report, with the
    end it was due at (its place in the plan, else its dispatch's)."""
    schedule, now = state.schedule, state.now
    if schedule is None or now is None:
        return {}
    dispatches = state.dispatches
    out = {}
    for task, span in sorted(dispatches.sent.items()):
        if dispatches.lifecycle.get(task) not in _RUNNING:
            continue
        placed = schedule.plan.activity(task)
        end = placed.end if placed is not None else span[1]
        if end <= now:
            out[task] = end
    return out


def note_running(state: EngineState) -> None:
    """Record each overrunning activity as running at ``now`` when no
    record says so already, so that a replan takes it as running on
    (rules: overrun, one unit left) instead of finished on time."""
    schedule, now = state.schedule, state.now
    if schedule is None or now is None:
        return
    live = {t.id for t in schedule.problem.tasks}
    for task in overrunning(state):
        placed = schedule.plan.activity(task)
        if task not in live or placed is None:
            continue
        latest = None
        for report in schedule.reports:
            if report.task == task and (
                latest is None or report.at >= latest.at
            ):
                latest = report
        if (
            latest is not None
            and latest.state == "running"
            and latest.at >= placed.start
        ):
            continue
        schedule = schedule.with_report(ExecutionReport(task, "running", now))
    state.schedule = schedule


def _precedences(schedule: Schedule) -> list[Precedence]:
    """Every precedence the engine knows: live, parked and accepted."""
    return list(
        dict.fromkeys(
            (
                *schedule.problem.precedences,
                *schedule.parked,
                *schedule.catalog_precedences,
            )
        )
    )


def _known(schedule: Schedule) -> dict[str, Task]:
    """Every task by id: the live version first, then the catalog's."""
    return {
        t.id: t
        for t in (
            *schedule.catalog,
            *schedule.deferred,
            *schedule.problem.tasks,
        )
    }


def held(state: EngineState, queue: SolveQueue) -> dict[str, str]:
    """Each activity due now that must not be commanded, and why (in
    plan order; empty when these rules are off)."""
    schedule, now = state.schedule, state.now
    if schedule is None or now is None or not pushing(state):
        return {}
    lifecycle = state.dispatches.lifecycle
    keep = set(schedule.continuing)
    due = [
        a
        for a in schedule.plan.activities
        if a.start <= now
        and a.task not in keep
        and lifecycle.get(a.task) == "planned"
    ]
    if not due:
        return {}
    late = overrunning(state)
    replanning = replan_under_way(queue)
    live = {a.task for a in schedule.plan.activities}
    known = _known(schedule)
    after: dict[str, list[Precedence]] = {}
    for prec in _precedences(schedule):
        after.setdefault(prec.after, []).append(prec)
    resources = schedule.problem.resources
    # What stands on each multiple resource now: every command not
    # answered for good, then each activity commanded in this step.
    load: dict[str, float] = {}
    for task, state_ in lifecycle.items():
        if state_ in _RUNNING and task in known:
            for name, amount in known[task].uses.items():
                if name in resources.multiple:
                    load[name] = load.get(name, 0.0) + amount
    out: dict[str, str] = {}
    for activity in due:
        why = _waits_for(activity, after, lifecycle, live, late)
        uses = known[activity.task].uses if activity.task in known else {}
        if why is None:
            why = _resource_taken(
                activity.task, uses, late, known, load, schedule, now
            )
        if why is None and activity.start < now and replanning:
            why = "its start has passed; the replan under way places it"
        if why is not None:
            out[activity.task] = why
            continue
        for name, amount in uses.items():
            if name in resources.multiple:
                load[name] = load.get(name, 0.0) + amount
    return out


def replan_under_way(queue: SolveQueue) -> bool:
    """Whether an ``overrun`` or ``late_completion`` replan is queued or
    solving."""
    pending = queue.pending
    return any(
        queue.has_trigger(name) for name in (OVERRUN, LATE_COMPLETION)
    ) or (
        pending is not None and pending.trigger in (OVERRUN, LATE_COMPLETION)
    )


def _waits_for(
    activity: Activity,
    after: dict[str, list[Precedence]],
    lifecycle: Mapping[str, str],
    live: set[str],
    late: dict[str, int],
) -> str | None:
    """Why ``activity`` waits for a predecessor (None: it does not)."""
    for prec in after.get(activity.task, ()):
        other = prec.before
        state = lifecycle.get(other, "planned")
        if state in _RUNNING:
            end = late.get(other)
            return f"follows {other} ({prec.kind}), " + (
                f"still running past its end {end}"
                if end is not None
                else "not reported completed"
            )
        if other in live and state in ("planned", "missed"):
            return f"follows {other} ({prec.kind}), which has not run yet"
    return None


def _resource_taken(
    task: str,
    uses: dict[str, float],
    late: dict[str, int],
    known: dict[str, Task],
    load: dict[str, float],
    schedule: Schedule,
    now: int,
) -> str | None:
    """Why ``task`` cannot have its resources now: an overrunning
    activity holds a binary one, or overfills a multiple one with it."""
    resources = schedule.problem.resources
    for other, end in sorted(late.items()):
        if other == task or other not in known:
            continue
        theirs = known[other].uses
        for name, amount in sorted(uses.items()):
            if amount <= 0 or theirs.get(name, 0) <= 0:
                continue
            if name in resources.binary:
                return f"{name} is held by {other}, running past its end {end}"
            if name in resources.multiple:
                capacity = resources.capacity_profile(name, now, 1)[0]
                if load.get(name, 0.0) + amount > capacity + 1e-9:
                    return (
                        f"{name} would exceed {capacity:g} with {other}, "
                        f"running past its end {end}"
                    )
    return None


def depends_on(
    schedule: Schedule,
    lifecycle: Mapping[str, str],
    task: str,
    at: int,
) -> str | None:
    """What a completion of ``task`` at ``at`` (after its dispatch's end)
    changes in the plan in force, or None when every place still holds.

    A planned successor set to start before ``at`` + offset, or a planned
    activity on one of its binary or multiple resources set to start
    before ``at``, lost its place; a plan that pushed them after an end
    later than ``at`` (an overrun replan) keeps them later than needed.
    """
    known = _known(schedule)
    placed = schedule.plan.activity(task)
    if (
        placed is not None
        and task in schedule.continuing
        and placed.end > at
        and _waiting(schedule, lifecycle, task, known)
    ):
        return f"the plan took it to run until {placed.end}"
    shared = _contended(schedule, known, task)
    follow = [p for p in _precedences(schedule) if p.before == task]
    for activity in _planned(schedule, lifecycle):
        for prec in follow:
            if (
                prec.after == activity.task
                and activity.start < at + prec.offset
            ):
                return f"{activity.task} follows it from {activity.start}"
        theirs = known[activity.task].uses if activity.task in known else {}
        if activity.start < at and any(theirs.get(n, 0) > 0 for n in shared):
            return (
                f"{activity.task} shares its resources from {activity.start}"
            )
    return None


def _contended(
    schedule: Schedule, known: dict[str, Task], task: str
) -> set[str]:
    """The binary and multiple resources ``task`` uses: those an activity
    running on holds against what waits for them."""
    resources = schedule.problem.resources
    uses = known[task].uses if task in known else {}
    return {
        n
        for n, amount in uses.items()
        if amount > 0 and (n in resources.binary or n in resources.multiple)
    }


def _planned(
    schedule: Schedule, lifecycle: Mapping[str, str]
) -> Iterable[Activity]:
    """The activities of the plan in force not commanded yet."""
    keep = set(schedule.continuing)
    for activity in schedule.plan.activities:
        if (
            activity.task not in keep
            and lifecycle.get(activity.task, "planned") == "planned"
        ):
            yield activity


def _waiting(
    schedule: Schedule,
    lifecycle: Mapping[str, str],
    task: str,
    known: dict[str, Task],
) -> bool:
    """Whether a planned activity follows ``task`` or shares one of its
    binary or multiple resources."""
    mine = _contended(schedule, known, task)
    successors = {p.after for p in _precedences(schedule) if p.before == task}
    for activity in _planned(schedule, lifecycle):
        if activity.task in successors:
            return True
        theirs = known[activity.task].uses if activity.task in known else {}
        if any(theirs.get(n, 0) > 0 for n in mine):
            return True
    return False


def carried(
    state: EngineState, before: Schedule | None, after: Schedule
) -> Schedule:
    """``after`` (the schedule of a plan just solved) with the completions
    that arrived while it was solved, for the activities it keeps running.

    A replan reads the reports in the schedule it starts from; one that
    arrives during the solve is in the lifecycle but not in the adopted
    schedule, and the next replan (the ``late_completion`` or
    ``early_completion`` it queued) would take the activity as still
    running. Only with these rules or early completions on: recordings
    made without them replay as they were.
    """
    used = pushing(state) or state.config.early_completion_gain > 0
    if not used or before is None:
        return after
    lifecycle = state.dispatches.lifecycle
    for task in after.continuing:
        if lifecycle.get(task) != "completed":
            continue
        done = [
            r
            for r in before.reports
            if r.task == task and r.state == "completed"
        ]
        if done:
            at = max(done[-1].at, after.problem.start)
            after = after.with_report(ExecutionReport(task, "completed", at))
    return after


def extended(state: EngineState, replan: Replan) -> Replan:
    """``replan`` with each overrunning activity it keeps running taken as
    running on for as long as it has overrun so far (at least one unit).

    The rules give an overrun one unit left; a replan per unit of a long
    overrun would keep the solver busy, so each replan assumes that the
    overrun lasts as long again as it has lasted since its dispatch's end.
    """
    if not pushing(state):
        return replan
    sent = state.dispatches.sent
    late = {task: sent[task][1] for task in overrunning(state)}
    problem = replan.problem
    now = problem.start
    changed: dict[str, Task] = {}
    for task in problem.tasks:
        end = late.get(task.id)
        if end is None or task.id not in replan.continuing:
            continue
        length = min(max(task.length, now - end), problem.end - problem.start)
        if length > task.length:
            changed[task.id] = msgspec.structs.replace(task, length=length)
    if not changed:
        return replan
    tasks = tuple(changed.get(t.id, t) for t in problem.tasks)
    problem = problem.replace(tasks=tasks)
    warm = replan.warm
    if warm is not None:
        warm = warm.replace(
            activities=tuple(
                msgspec.structs.replace(
                    a, end=a.start + changed[a.task].length
                )
                if a.task in changed
                else a
                for a in warm.activities
            )
        )
    following = msgspec.structs.replace(replan.following, problem=problem)
    return msgspec.structs.replace(
        replan, problem=problem, warm=warm, following=following
    )
