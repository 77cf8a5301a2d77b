"""The paper's rescheduling rules, one function each.

Each rule is a function named ``rule_*`` whose docstring cites the paper.
They run in this order (a later rule sees the result of earlier ones):

1. :func:`rule_finished_leave`: finished tasks leave (``finished``).
2. :func:`rule_failed_activity`: a reported failure, by preemption policy
   (``failed_delete``).
3. :func:`rule_running_preemption`: running tasks, by preemption policy
   (``preemption_delete``); non-preemptible ones are pinned and continuing.
4. :func:`rule_obsolete`: a goal's ``obsoletes`` (``obsolete``).
5. :func:`rule_removal_cascade` after every removal (``tight_cascade``).
6. goal merge (:mod:`fsw_scheduler.replan.triggers`; collisions and
   unknown references reject the goal).
7. :func:`rule_tight_chain`: a preempted or failed task that is rescheduled
   brings back its executed tight partners (re-added from the catalog).
8. :func:`rule_settled_precedences`: precedences touching a finished task
   are dropped; a successor still waiting keeps its bound on the start.
9. :func:`rule_window_passed` (``window_passed``) and
   :func:`rule_defer_beyond_horizon` (kept aside, not removed).

A new rule goes here, as one more ``rule_*`` function; its place in the
order is set where the triggers run the rules
(:mod:`fsw_scheduler.replan.triggers`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import msgspec

from ..errors import FieldIssue, InputError
from ..model import groups
from ..model.change import Removal
from ..model.problem import (
    Alternative,
    Precedence,
    Problem,
    Task,
)
from .schedule import Execution, ExecutionState, Schedule

if TYPE_CHECKING:
    from collections.abc import Callable, Collection, Sequence

    from ..model.goal import Goal


@dataclass
class Work:
    """What the rules of one replan work on, and what they record.

    Built by :func:`start_work` from the schedule; each ``rule_*`` reads and
    changes it in turn, and the triggers build the new problem from it.

    Attributes
    ----------
    now
        The time unit of the replan: the start of the new problem.
    horizon
        Length of the new problem's window.
    base
        The current problem (resources, window reading).
    tasks
        The live tasks, by id: what the new problem will hold.
    precedences
        The live precedences.
    catalog, catalog_precedences
        Every task and precedence ever accepted, for re-adding.
    history
        The past executions.
    obsolete
        Ids made obsolete by goals.
    removed
        The tasks taken out, with the rule that did it.
    pinned
        Running tasks that cannot be preempted: fixed at their start.
    rescheduled
        Preempted or failed tasks planned again.
    readded
        Executed tight partners brought back from the catalog.
    deferred
        Tasks kept aside, beyond the horizon.
    runs
        Task id to the units ``[start, end)`` its finished execution ran.
    keep_running
        Whether every running task continues, as if non-preemptible (a
        replan that only corrects the world, see
        :func:`rule_running_preemption`).
    groups
        The groups of alternatives (the problem's and accepted goals').
    """

    now: int
    horizon: int
    base: Problem
    tasks: dict[str, Task]
    precedences: list[Precedence]
    catalog: dict[str, Task]
    catalog_precedences: list[Precedence]
    history: list[Execution]
    obsolete: list[str]
    removed: list[Removal] = field(default_factory=list)
    pinned: list[str] = field(default_factory=list)
    rescheduled: list[str] = field(default_factory=list)
    readded: list[str] = field(default_factory=list)
    deferred: list[str] = field(default_factory=list)
    runs: dict[str, tuple[int, int]] = field(default_factory=dict)
    keep_running: bool = False
    groups: list[Alternative] = field(default_factory=list)

    def remove(self, task_id: str, rule: str, detail: str) -> None:
        """Take ``task_id`` out of the live set and record why."""
        self.tasks.pop(task_id, None)
        if task_id in self.rescheduled:
            self.rescheduled.remove(task_id)
        self.removed.append(Removal(task_id, rule, detail))

    def frame(self) -> Problem:
        """An empty problem over the new window, for start bounds."""
        return Problem(
            horizon=self.horizon,
            tasks=(),
            start=self.now,
            feasible_interval_applies_to=(
                self.base.feasible_interval_applies_to
            ),
            resources=self.base.resources,
        )


def start_work(schedule: Schedule, now: int) -> Work:
    """The rules' working state for a replan of ``schedule`` at ``now``."""
    tasks = {t.id: t for t in (*schedule.problem.tasks, *schedule.deferred)}
    runs = {
        e.task: (e.start, e.end)
        for e in schedule.history
        if e.outcome == "completed"
    }
    return Work(
        now=now,
        horizon=schedule.horizon,
        base=schedule.problem,
        tasks=tasks,
        precedences=[*schedule.problem.precedences, *schedule.parked],
        catalog={t.id: t for t in schedule.catalog},
        catalog_precedences=list(schedule.catalog_precedences),
        history=list(schedule.history),
        obsolete=list(schedule.obsolete),
        runs=runs,
        groups=list(schedule.problem.alternatives),
    )


def rule_finished_leave(work: Work, state: ExecutionState) -> list[str]:
    """Finished tasks leave the problem (rule ``finished``).

    Paper, "Online rescheduling": the new activities "must be co-scheduled
    together with those already present in the schedule and not already
    executed". Their consumption is already in the new initial levels
    (``state.levels``); they stay in the catalog so that
    :func:`rule_tight_chain` can bring them back.

    Returns
    -------
    list of str
        The finished task ids.
    """
    finished = []
    for ts in state.tasks:
        if ts.phase != "finished":
            continue
        assert ts.since is not None and ts.until is not None
        work.history.append(
            Execution(ts.task, ts.since, ts.until, "completed")
        )
        work.runs[ts.task] = (ts.since, ts.until)
        work.remove(ts.task, "finished", f"ran over [{ts.since}, {ts.until})")
        finished.append(ts.task)
    return finished


def rule_failed_activity(
    work: Work, state: ExecutionState, task_id: str
) -> list[str]:
    """A failed activity is handled by its preemption policy.

    Paper, "Online rescheduling": unexpected events such as faults "call
    for a rescheduling procedure", and a running task is treated by its
    preemption behaviour. A failure interrupts the task, so:

    * ``from_start``: retried in full.
    * ``none``: retried in full too. The policy says the task cannot be
      interrupted, so its partial run is worthless and it cannot resume
      in the middle; a fresh run is the only way to reach its effect.
    * ``from_interrupt``: only the remaining part is rescheduled.
    * ``delete``: dropped (rule ``failed_delete``); its tight chain goes
      with it through :func:`rule_removal_cascade`.

    Returns
    -------
    list of str
        Seeds for the removal cascade (the task when deleted).
    """
    ts = state.of(task_id)
    task = work.tasks[task_id]
    since = ts.since if ts.since is not None else work.now
    until = ts.until if ts.until is not None else work.now
    work.history.append(Execution(task_id, since, until, "failed"))
    if task.preemption == "delete":
        work.remove(
            task_id, "failed_delete", f"failed at {until}, preemption delete"
        )
        return [task_id]
    if task.preemption == "from_interrupt":
        work.tasks[task_id] = _unpinned(task, task.length - ts.done)
    else:
        work.tasks[task_id] = work.catalog.get(task_id, _unpinned(task))
    work.rescheduled.append(task_id)
    return []


def rule_running_preemption(work: Work, state: ExecutionState) -> list[str]:
    """Running tasks are treated by their preemption policy.

    Paper, "Online rescheduling", the four behaviours for running tasks:

    * ``none``: "cannot be interrupted and will be concluded in the new
      schedule": pinned at ``now`` (``fixed_start``) with its remaining
      length and flagged continuing. Its feasible interval is dropped: it
      was honoured when the task started.
    * ``from_start``: "completely rescheduled": back to its full length.
    * ``from_interrupt``: "only the remaining part must be rescheduled".
    * ``delete``: "deleted from the schedule" (rule ``preemption_delete``).

    A replan that only corrects the world (measured levels, a stale plan)
    sets ``keep_running``: nothing new competes for the running tasks, so
    they all continue as if non-preemptible rather than being interrupted,
    with their tight chains, on every telemetry update.

    Returns
    -------
    list of str
        Seeds for the removal cascade (deleted tasks).
    """
    seeds = []
    for ts in state.tasks:
        if ts.phase != "running" or ts.task not in work.tasks:
            continue
        task = work.tasks[ts.task]
        remaining = task.length - ts.done
        if task.preemption == "none" or work.keep_running:
            work.tasks[ts.task] = msgspec.structs.replace(
                task,
                length=remaining,
                fixed_start=work.now,
                feasible_interval=None,
                feasible_interval_applies_to=None,
            )
            work.pinned.append(ts.task)
            continue
        assert ts.since is not None
        work.history.append(
            Execution(ts.task, ts.since, work.now, "interrupted")
        )
        if task.preemption == "delete":
            work.remove(
                ts.task,
                "preemption_delete",
                f"running at {work.now}, preemption delete",
            )
            seeds.append(ts.task)
        elif task.preemption == "from_interrupt":
            work.tasks[ts.task] = _unpinned(task, remaining)
            work.rescheduled.append(ts.task)
        else:
            work.tasks[ts.task] = work.catalog.get(ts.task, _unpinned(task))
            work.rescheduled.append(ts.task)
    return seeds


def rule_obsolete(work: Work, goal: Goal) -> list[str]:
    """A goal's ``obsoletes`` remove tasks from the pending list.

    Paper, "Online rescheduling", last case: a new goal can make tasks
    already in the schedule obsolete; "obsolete activities are removed
    from the pending list and are not included in subsequent schedules".
    The ids also leave the catalog, so no rule brings them back. A running
    task with preemption ``none`` cannot be interrupted: it finishes as
    pinned, then leaves. Naming a task never accepted rejects the goal.

    Returns
    -------
    list of str
        Seeds for the removal cascade.

    Raises
    ------
    InputError
        When an obsoleted id is unknown (path ``tasks[i].obsoletes[j]``).
    """
    issues = []
    seeds = []
    by_group = {group.id: group for group in work.groups}
    for idx, task in enumerate(goal.tasks):
        for jdx, name in enumerate(task.obsoletes):
            if name in by_group:
                # A group named: every live member of it goes.
                seeds += _obsolete_group(work, by_group[name], task, goal)
                continue
            known = (
                name in work.tasks
                or name in work.catalog
                or any(r.task == name for r in work.removed)
            )
            if not known:
                issues.append(
                    FieldIssue(
                        f"tasks[{idx}].obsoletes[{jdx}]",
                        f"unknown task {name!r}",
                    )
                )
                continue
            if name not in work.obsolete:
                work.obsolete.append(name)
            if name in work.tasks and name not in work.pinned:
                work.remove(
                    name,
                    "obsolete",
                    f"made obsolete by {task.id} of goal {goal.goal_id}",
                )
                seeds.append(name)
    if issues:
        raise InputError(issues, "goal")
    for name in goal.obsoleted:
        if name not in work.pinned:
            forget(work, name)
    return seeds


def _obsolete_group(
    work: Work, group: Alternative, task: Task, goal: Goal
) -> list[str]:
    """Rule ``obsolete`` for a group named in ``obsoletes``: the group
    leaves the replan, and so do its live members (a running member
    that cannot be interrupted finishes first, as a task would)."""
    work.groups = [g for g in work.groups if g.id != group.id]
    seeds = []
    for name in (n for option in group.options for n in option):
        if name in work.tasks and name not in work.pinned:
            work.remove(
                name,
                "obsolete",
                f"its group {group.id} made obsolete by {task.id} of goal "
                f"{goal.goal_id}",
            )
            seeds.append(name)
    return seeds


def rule_alternatives(work: Work, started: Collection[str]) -> list[str]:
    """Groups settle with what has run (rule ``alternative``).

    A dispatched, running or completed member pins its option: the other
    options of its group leave the pending list. An option one of whose
    tasks is gone (failed and deleted, obsolete, its window passed) cannot
    be completed: what is left of it leaves too
    (:func:`fsw_scheduler.model.groups.settle`).

    Returns
    -------
    list of str
        Seeds for the removal cascade.
    """
    settled, drop = groups.settle(
        tuple(work.groups), work.tasks.keys(), started
    )
    work.groups = list(settled)
    for name, why in drop.items():
        work.remove(name, "alternative", why)
    return list(drop)


def rule_removal_cascade(work: Work, seeds: Sequence[str]) -> None:
    """Removal follows tight constraints; lax constraints are dropped.

    Paper, "Online rescheduling": "When a task is removed from the
    scheduling problem, all other tasks that follow the deleted task inside
    a tight constraint are also removed from the pending activities.
    Instead, tasks that follow a lax constraint are maintained, but the
    constraint is removed." A task that *precedes* a removed one through a
    tight ``both`` constraint goes too: ``both`` means both or neither, and
    a tight predecessor only exists as its precondition (this removes the
    old SetPositionZ with AcquisitionHF in the paper's Table 2). Through a
    tight ``at_least_first`` constraint the predecessor stays. Every
    constraint touching a removed task is dropped. Pinned (continuing)
    tasks cannot be interrupted and stop the cascade. Rule
    ``tight_cascade``; it runs transitively.
    """
    work.precedences = cascade(
        work.precedences,
        seeds,
        live=lambda name: name in work.tasks and name not in work.pinned,
        remove=lambda name, detail: work.remove(name, "tight_cascade", detail),
    )


def cascade(
    precedences: Sequence[Precedence],
    seeds: Sequence[str],
    live: Callable[[str], bool],
    remove: Callable[[str, str], None],
    cause: str = "removed",
) -> list[Precedence]:
    """The removal cascade of :func:`rule_removal_cascade`, on any task set.

    Parameters
    ----------
    precedences
        The precedences among the tasks.
    seeds
        Tasks just removed.
    live
        Whether a task is still there and may be removed.
    remove
        Removes a task taken by the cascade, given the plain-words reason.
    cause
        How the reason names a seed's removal (``removed``, ``shed task``).

    Returns
    -------
    list of Precedence
        The precedences that touch no removed task.
    """
    kept = list(precedences)
    queue = list(seeds)
    while queue:
        gone = queue.pop(0)
        keep = []
        for prec in kept:
            if gone not in (prec.before, prec.after):
                keep.append(prec)
                continue
            other = prec.after if prec.before == gone else prec.before
            follows = prec.after == other
            takes = prec.kind == "tight" and (follows or prec.scope == "both")
            if takes and live(other):
                how = "follows" if follows else "tightly precedes"
                remove(
                    other,
                    f"{how} {cause} {gone} through a tight {prec.scope} "
                    "precedence",
                )
                queue.append(other)
        kept = keep
    return kept


def rule_tight_chain(work: Work) -> None:
    """A preempted task that is rescheduled brings its tight chain along.

    Paper, "Online rescheduling": "When an activity that belongs to a
    precedence sequence is preempted and rescheduled, then also all the
    other tasks in the chain, that is all the tasks involved in tight
    precedence constraints with the interrupted task, have to be
    rescheduled, even those that have already been executed." The chain
    is the set of tasks joined by tight precedences of the catalog,
    transitively, in either direction. Members still live are already in
    the problem; executed members are re-added from the catalog (full
    definition) with the catalog precedences that join them to live tasks.
    Obsolete tasks never come back.
    """
    added: list[str] = []
    for name in executed_chain(work, work.rescheduled):
        work.tasks[name] = work.catalog[name]
        added.append(name)
    if not added:
        return
    work.readded += added
    # Re-added tasks are live again: they must not be dropped as finished.
    for name in added:
        work.runs.pop(name, None)
    present = set(work.precedences)
    for prec in work.catalog_precedences:
        ends = (prec.before, prec.after)
        if (
            prec not in present
            and all(end in work.tasks for end in ends)
            and any(end in added for end in ends)
        ):
            work.precedences.append(prec)
            present.add(prec)


def executed_chain(work: Work, names: Sequence[str]) -> list[str]:
    """The executed tasks tied to ``names`` by tight precedences of the
    catalog (transitively, in either direction) that a chain brought back
    would re-add: not live, finished, in the catalog, not obsolete."""
    tight = [p for p in work.catalog_precedences if p.kind == "tight"]
    seen = set(names)
    queue = list(names)
    found: list[str] = []
    while queue:
        name = queue.pop(0)
        for prec in tight:
            if name not in (prec.before, prec.after):
                continue
            other = prec.after if prec.before == name else prec.before
            if other in seen or other in work.obsolete:
                continue
            seen.add(other)
            queue.append(other)
            if (
                other not in work.tasks
                and other in work.runs
                and (other in work.catalog)
            ):
                found.append(other)
    return found


def rule_settled_precedences(work: Work) -> tuple[list[str], list[str]]:
    """Precedences touching a finished task are dropped.

    Paper, "Online rescheduling": only tasks "not already executed" are
    co-scheduled, so a constraint with an executed task has no second end
    left in the problem. ``scope`` is settled by the execution (the
    predecessor ran). The start bound it put on a successor still waiting
    is kept, as the successor's window (``start`` reading): ``start ==
    end_before + offset`` for tight, ``>=`` for lax, where ``end_before``
    is when the predecessor really finished. A successor left with no
    start is removed (rule ``window_passed``). A tight successor whose
    required start has already passed can no longer follow its
    precondition: it is handed to :func:`rule_tight_chain`, which runs the
    precondition again, unless that would bring back a mandatory task for
    an optional successor (:func:`_reruns_mandatory`): such a successor
    is removed (``window_passed``). A precedence whose ``after`` is pinned
    (already started) is settled and dropped.

    Returns
    -------
    tuple of two lists of str
        Successors that need their tight chain run again, and seeds for
        the removal cascade.
    """
    keep = []
    redo = []
    seeds: dict[str, str] = {}
    # The work's own groups, once: not the shared index's cache, which
    # would keep each replan's passing tuple.
    index = groups.Groups(tuple(work.groups))
    for prec in work.precedences:
        before_live = prec.before in work.tasks
        after_live = prec.after in work.tasks
        if before_live and after_live and prec.after not in work.pinned:
            keep.append(prec)
            continue
        run = work.runs.get(prec.before)
        if run is None or not after_live or prec.after in work.pinned:
            continue
        bound = run[1] + prec.offset
        if prec.kind == "tight" and bound < work.now:
            if _reruns_mandatory(work, index, prec.after):
                seeds.setdefault(
                    prec.after,
                    f"its tight precondition {prec.before} ran (ended "
                    f"{run[1]}) and is mandatory: it is not run again for "
                    "an optional task",
                )
            else:
                redo.append(prec.after)
            continue
        high = None if prec.kind == "lax" else bound
        task = _bounded(work, work.tasks[prec.after], bound, high)
        if task is None:
            seeds.setdefault(
                prec.after,
                f"no start left after {prec.before} (ended {run[1]})",
            )
        else:
            work.tasks[prec.after] = task
    work.precedences = keep
    # Removed only now, so that the cascade still sees their constraints.
    for name, detail in seeds.items():
        work.remove(name, "window_passed", detail)
    return [n for n in redo if n in work.tasks], list(seeds)


def _reruns_mandatory(
    work: Work, index: groups.Groups, successor: str
) -> bool:
    """True when running ``successor``'s tight chain again would bring
    back a mandatory executed task for an optional ``successor``.

    A mandatory task that ran has met its requirement; brought back from
    the catalog it would be mandatory again, so an optional successor
    (one the plan may well leave out) would force a second run, and with
    it perhaps a problem without a plan. Such a successor leaves instead
    (replan suite, seed 147's r60-h1440-1: a 35-unit camera task run
    again for a successor the plan had left out; the replan found no
    start plan and answered ``unknown``).
    """
    if index.required(work.tasks[successor]):
        return False  # required: its precondition runs again
    return any(
        work.catalog[name].schedule_cost == 0
        for name in executed_chain(work, [successor])
    )


def rule_window_passed(work: Work) -> list[str]:
    """Tasks whose feasible interval has passed are removed.

    Paper, "Scheduling problem definition": the start is bounded to the
    feasible interval; once ``now`` is past its last allowed start (or a
    pin is in the past), the task can no longer be scheduled in any later
    horizon. Rule ``window_passed``.

    Returns
    -------
    list of str
        Seeds for the removal cascade.
    """
    seeds = []
    frame = work.frame()
    for task in list(work.tasks.values()):
        if task.id in work.pinned:
            continue
        latest = latest_start(frame, task)
        if latest < work.now:
            work.remove(
                task.id,
                "window_passed",
                f"last allowed start {latest} is before {work.now}",
            )
            seeds.append(task.id)
    return seeds


def rule_defer_beyond_horizon(work: Work) -> None:
    """Tasks that fit only after the horizon are kept aside.

    Not in the paper, whose horizon is fixed; with a rolling horizon, a
    task whose window opens after ``now + H`` is accepted but cannot be in
    this problem. It waits in :attr:`Schedule.deferred` and enters the
    first later replan whose horizon reaches it. Tight successors, tight
    ``both`` predecessors and any successor (which must start after it)
    wait with it; other constraints touching it are parked.
    """
    frame = work.frame()
    queue = []
    for task in work.tasks.values():
        earliest, latest = frame.start_bounds(task)
        if task.id not in work.pinned and earliest > latest:
            queue.append(task.id)
    waiting = set(queue)
    while queue:
        name = queue.pop(0)
        for prec in work.precedences:
            if name not in (prec.before, prec.after):
                continue
            other = prec.after if prec.before == name else prec.before
            follows = prec.after == other
            drags = follows or (prec.kind == "tight" and prec.scope == "both")
            if drags and other not in waiting and other not in work.pinned:
                waiting.add(other)
                queue.append(other)
    work.deferred = [name for name in work.tasks if name in waiting]


def _unpinned(task: Task, length: int | None = None) -> Task:
    return msgspec.structs.replace(
        task,
        length=task.length if length is None else length,
        fixed_start=None,
    )


def forget(work: Work, name: str) -> None:
    """Drop task ``name`` from the catalog, with its precedences, so that
    it is never re-added (it is obsolete, or its id is reused)."""
    work.catalog.pop(name, None)
    work.catalog_precedences = [
        p for p in work.catalog_precedences if name not in (p.before, p.after)
    ]


def latest_start(frame: Problem, task: Task) -> int:
    """Last start allowed by window and pin, ignoring the horizon end."""
    open_ended = frame.replace(horizon=10**9)
    return open_ended.start_bounds(task)[1]


def _bounded(
    work: Work, task: Task, low: int, high: int | None
) -> Task | None:
    """``task`` with its start also kept in ``[low, high]``, None if empty."""
    open_ended = work.frame().replace(horizon=10**9)
    earliest, latest = open_ended.start_bounds(task)
    earliest = max(earliest, low)
    if high is not None:
        latest = min(latest, high)
    if earliest > latest or latest < work.now:
        return None
    if earliest <= work.now and latest >= 10**9 - task.length:
        return task  # the bound is already met by any start in the horizon
    return msgspec.structs.replace(
        task,
        feasible_interval=(earliest, latest),
        feasible_interval_applies_to="start",
    )
