"""A heal merges facts: what a commander that stands down hands over.

After a partition two commanders meet; the one with the lower term stands
down. What it commanded in the meantime is a fact (the executor on its
side may have run it), and so is what its executor reported. It hands
them over (:func:`facts_of`, published on ``scheduler/facts``) and the
winner takes them into its state (:func:`merge_facts`, as a journaled
input): a completed activity is never commanded again, one its executor
reported running is kept running where it was commanded (the replan
that follows pins it), one commanded with no word back is asked about
with a cancel in the winner's term (the executor answers what ran),
and a goal the winner lacks is carried over (with what ran of it),
instead of being sent again by its sender: its sender had its
``goal_accepted``. Only a goal whose task ids are other tasks at the
winner is told to be sent again (:func:`lost_goals`).

Pure: no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.change import ExecutionReport
from ..wire.messages import CarriedGoal, Fact, Facts
from .dispatch import WAS_COMMANDED

if TYPE_CHECKING:
    from ..model.problem import Task
    from .snapshot import EngineSnapshot
    from .state import EngineState

#: States a fact handed over never overrides on the winner.
_SETTLED = ("completed", "failed", "unknown", "obsolete")


def _defined(snapshot: EngineSnapshot | None) -> dict[str, Task]:
    """Every task ``snapshot``'s schedule knows, by id (the catalog's,
    the goal's full definition, wins)."""
    schedule = snapshot.schedule if snapshot is not None else None
    if schedule is None:
        return {}
    return {
        t.id: t
        for t in (
            *schedule.problem.tasks,
            *schedule.deferred,
            *schedule.catalog,
        )
    }


def _fate(tasks: tuple[str, ...], mine: dict, theirs: dict) -> str:
    """What becomes of a goal the winner lacks: ``carried`` (none of its
    task ids is known there), ``held`` (each of its tasks is there, the
    same: a sender sent them on that side under another goal id) or
    ``told`` (a task id of it is another task there, or only some of its
    tasks are: it cannot be merged, its sender must send it again)."""
    there = [t for t in tasks if t in theirs]
    if not there:
        return "carried"
    if len(there) == len(tasks) and all(
        t in mine and mine[t] == theirs[t] for t in tasks
    ):
        return "held"
    return "told"


def lost_goals(own: EngineSnapshot, winner: EngineSnapshot) -> list[str]:
    """Goals this node took in its own term that the state which outranks
    it does not hold and cannot be handed: a task id of theirs is another
    task there, or only some of their tasks are there (a sender reused
    them on the winner's side). Each must be told, by name, to be sent
    again. (A goal none of whose task ids is there is handed over with
    the facts, :func:`facts_of`; one whose tasks are all there, the same,
    is held there already.)"""
    mine, theirs = _defined(own), _defined(winner)
    return [
        goal_id
        for goal_id, record in own.ledger.items()
        if record.term == own.term
        and goal_id not in winner.ledger
        and _fate(record.tasks, mine, theirs) == "told"
    ]


def facts_of(
    own: EngineSnapshot, winner: EngineSnapshot | None, node_id: str = ""
) -> Facts:
    """What ``own`` hands over to the commander whose state is ``winner``.

    Parameters
    ----------
    own
        The state of the node that stands down.
    winner
        The state the winner shares (None: not known yet; everything is
        handed over, the winner skips what it has).
    node_id
        The name of the node that stands down.

    Returns
    -------
    Facts
        Each commanded activity whose state the winner does not share,
        and each goal this node accepted in its term that the winner does
        not hold and none of whose task ids is known there: commanded or
        not, its sender had its ``goal_accepted`` and sends it no more (a
        standby reset with the commander may have missed the last goals;
        two sides of a split each accepted their own).
    """
    theirs = winner.lifecycle if winner is not None else {}
    facts = []
    for task, state in sorted(own.lifecycle.items()):
        if state not in WAS_COMMANDED or theirs.get(task) == state:
            continue
        span = own.sent.get(task)
        facts.append(
            Fact(
                task=task,
                state=state,  # type: ignore[arg-type]
                at=_last_at(own, task),
                start=span[0] if span else None,
                end=span[1] if span else None,
                number=own.numbers.get(task, 1),
            )
        )
    goals = []
    held = winner.ledger if winner is not None else {}
    defined, their_tasks = _defined(own), _defined(winner)
    schedule = own.schedule
    for goal_id, record in own.ledger.items():
        if (
            goal_id in held
            or record.term != own.term
            or schedule is None
            or _fate(record.tasks, defined, their_tasks) != "carried"
        ):
            continue
        ids = set(record.tasks)
        precedences = tuple(
            p
            for p in schedule.catalog_precedences
            if p.before in ids and p.after in ids
        )
        goals.append(
            CarriedGoal(
                goal_id=goal_id,
                digest=record.digest,
                at=record.at,
                tasks=tuple(defined[t] for t in record.tasks if t in defined),
                precedences=precedences,
            )
        )
    return Facts(
        term=own.term, node_id=node_id, facts=tuple(facts), goals=tuple(goals)
    )


def _last_at(snapshot: EngineSnapshot, task: str) -> int:
    """The time of the last report on ``task`` the state holds."""
    schedule = snapshot.schedule
    if schedule is not None:
        for report in reversed(schedule.reports):
            if report.task == task:
                return report.at
        for execution in reversed(schedule.history):
            if execution.task == task:
                return execution.end
    return snapshot.now or 0


def merge_facts(state: EngineState, facts: Facts) -> tuple[list[str], ...]:
    """Take ``facts`` into ``state`` (the winner's).

    Returns
    -------
    goals, merged, cancelling
        The goals carried over (now accepted here), the tasks whose
        state changed, and those whose cancel stands (to send again in
        this node's term).
    """
    schedule = state.schedule
    if schedule is None:
        return [], [], []
    now = state.clock()
    dispatches = state.dispatches
    taken: list[str] = []
    used = (
        {t.id for t in schedule.problem.tasks}
        | {t.id for t in schedule.deferred}
        | {t.id for t in schedule.catalog}
    )
    tasks = list(schedule.problem.tasks)
    precedences = list(schedule.problem.precedences)
    catalog = list(schedule.catalog)
    catalog_precedences = list(schedule.catalog_precedences)
    for goal in facts.goals:
        ids = [t.id for t in goal.tasks]
        if state.ledger.seen(goal.goal_id) is not None or used.intersection(
            ids
        ):
            continue  # held here already, or its ids are taken here
        used.update(ids)
        tasks += goal.tasks
        catalog += goal.tasks
        precedences += goal.precedences
        catalog_precedences += goal.precedences
        state.ledger.queue(
            goal.goal_id, goal.digest, goal.at, facts.term, tuple(ids)
        )
        state.ledger.accept(goal.goal_id)
        taken.append(goal.goal_id)
    if taken:
        schedule = msgspec.structs.replace(
            schedule,
            problem=schedule.problem.replace(
                tasks=tuple(tasks), precedences=tuple(precedences)
            ),
            catalog=tuple(catalog),
            catalog_precedences=tuple(catalog_precedences),
        )
    live = {t.id for t in schedule.problem.tasks}
    low = schedule.problem.start

    def clamp(at: int) -> int:
        return min(max(at, low), now)

    merged: list[str] = []
    cancelling: list[str] = []
    for fact in facts.facts:
        task = fact.task
        mine = dispatches.lifecycle.get(task)
        if task not in live or mine in _SETTLED:
            continue
        final = fact.state in ("completed", "failed", "unknown")
        if mine in ("dispatched", "running", "cancelling") and not final:
            continue  # this node's own command stands
        merged.append(task)
        if final:
            dispatches.sent.pop(task, None)
            dispatches.dispatched.pop(task, None)
            dispatches.cancelling.pop(task, None)
            dispatches.note(task, fact.state)
            schedule = schedule.with_report(
                ExecutionReport(
                    task,
                    "failed" if fact.state == "failed" else "completed",
                    clamp(fact.at),
                )
            )
            continue
        span = (
            (fact.start, fact.end)
            if fact.start is not None and fact.end is not None
            else None
        )
        if span is not None:
            dispatches.sent[task] = span
            dispatches.numbers[task] = fact.number
        steady = schedule.problem.task(task).preemption == "none"
        if span is not None and (
            fact.state == "cancelling"
            or (fact.state == "dispatched" and not steady)
        ):
            # Not to run (a cancel stands), or commanded with no word
            # back: a fence may have kept it from the executor, or not.
            # Asked with a cancel in this node's term: the answer says
            # what ran, and it is planned again from that. (One that may
            # not be interrupted is never moved: it is held running.)
            dispatches.note(task, "cancelling")
            dispatches.cancelling[task] = now
            cancelling.append(task)
            schedule = schedule.with_report(
                ExecutionReport(task, "missed", now)
            )
            continue
        dispatches.note(task, "running")
        # Running there, as its executor said: running since it was
        # commanded, for the rules (a replan pins it where it runs, never
        # commands it again).
        schedule = schedule.with_report(
            ExecutionReport(
                task, "running", clamp(span[0] if span else fact.at)
            )
        )
    state.schedule = schedule
    return taken, merged, cancelling
