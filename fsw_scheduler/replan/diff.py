"""What changed between two plans: moved, added and removed tasks."""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from ..model.change import Removal

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping

    from ..model.plan import Plan

__all__ = [
    "Move",
    "PlanDiff",
    "diff_plans",
    "format_diff",
]


class Move(msgspec.Struct, frozen=True):
    """A task kept in both plans at another time."""

    task: str
    old_start: int
    new_start: int
    old_end: int
    new_end: int
    why: str = ""


class PlanDiff(msgspec.Struct, frozen=True):
    """What a replan changed between two plans.

    Attributes
    ----------
    kept
        Scheduled at the same interval in both.
    continued
        Continuing (pinned) tasks: the rest of an activity already running.
    moved
        Scheduled in both at different intervals.
    added
        Scheduled only in the new plan.
    removed
        Every removal of the replan, plus old activities the solver left out
        (rule ``unscheduled``).
    """

    kept: tuple[str, ...]
    continued: tuple[str, ...]
    moved: tuple[Move, ...]
    added: tuple[str, ...]
    removed: tuple[Removal, ...]


def diff_plans(
    old: Plan,
    new: Plan,
    removed: Iterable[Removal] = (),
    *,
    continuing: Iterable[str] = (),
    reasons: Mapping[str, str] | None = None,
) -> PlanDiff:
    """Compare two plans of a session.

    Parameters
    ----------
    old, new
        The plans before and after a replan.
    removed
        The replan's removals (:attr:`Replan.removed`).
    continuing
        The replan's continuing tasks.
    reasons
        Task id to why it moved, where known (a move's ``why``).

    Returns
    -------
    PlanDiff
    """
    removed = list(removed)
    gone = {r.task for r in removed}
    continuing = set(continuing)
    before = {a.task: a for a in old.activities}
    kept, continued, moved, added = [], [], [], []
    for act in new.activities:
        prev = before.get(act.task)
        if act.task in continuing:
            continued.append(act.task)
        elif prev is None or act.task in gone:
            # A removed id scheduled again is a new task (a goal reusing
            # the id, or an executed task re-added by its tight chain).
            added.append(act.task)
        elif (prev.start, prev.end) == (act.start, act.end):
            kept.append(act.task)
        else:
            moved.append(
                Move(
                    act.task,
                    prev.start,
                    act.start,
                    prev.end,
                    act.end,
                    (reasons or {}).get(act.task, ""),
                )
            )
    now_in = {a.task for a in new.activities}
    for act in old.activities:
        if act.task not in now_in and act.task not in gone:
            removed.append(
                Removal(act.task, "unscheduled", "left out by the solver")
            )
    return PlanDiff(
        kept=tuple(kept),
        continued=tuple(continued),
        moved=tuple(moved),
        added=tuple(added),
        removed=tuple(removed),
    )


def format_diff(diff: PlanDiff, new: Plan | None = None) -> str:
    """The diff as lines for humans, one task a line.

    Parameters
    ----------
    diff
        From :func:`diff_plans`.
    new
        The new plan, to show the intervals of kept, continued and added
        tasks (omitted when not given).
    """
    spans = {
        a.task: f" [{a.start}, {a.end})"
        for a in (new.activities if new is not None else ())
    }
    lines = [f"kept       {t}{spans.get(t, '')}" for t in diff.kept]
    lines += [f"continued  {t}{spans.get(t, '')}" for t in diff.continued]
    lines += [
        f"moved      {m.task} [{m.old_start}, {m.old_end}) -> "
        f"[{m.new_start}, {m.new_end})" + (f": {m.why}" if m.why else "")
        for m in diff.moved
    ]
    lines += [f"added      {t}{spans.get(t, '')}" for t in diff.added]
    lines += [
        f"removed    {r.task} ({r.rule}{': ' + r.detail if r.detail else ''})"
        for r in diff.removed
    ]
    return "\n".join(lines)
