"""The task rows of a Gantt chart: their order, bars, notes and legend.

Each function draws on one matplotlib axis it is given; none imports
matplotlib itself (the caller passes ``Patch`` in), so this module loads
without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..model.levels import tasks_by_id
from .style import (
    FAILED_COLOUR,
    GHOST_COLOUR,
    GHOST_FILL,
    NO_BINARY_COLOUR,
    PALETTE,
    PIN_COLOUR,
    REMOVED_COLOUR,
    UNSCHEDULED_COLOUR,
    colour_of,
)
from .timeline import left_out

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping, Sequence

    from ..model.plan import Activity, Plan
    from ..model.problem import Problem, Task

__all__ = [
    "draw_legend",
    "draw_moves",
    "draw_removed",
    "draw_tasks",
    "row_ids",
]

#: Background of every other task row, and the guide line through each.
_BAND = "#f2f4f7"
_GUIDE = "#dde1e6"


def row_ids(
    problem: Problem, history: Sequence[Activity], plan: Plan | None = None
) -> list[str]:
    """Task rows in time order, as a timeline reads: by first start (what
    ran, then what is planned), then the tasks left out in problem order.
    """
    ids = [task.id for task in problem.tasks]
    seen = set(ids)
    for activity in history:
        if activity.task not in seen:
            seen.add(activity.task)
            ids.append(activity.task)
    first: dict[str, int] = {}
    for activity in [*history, *(plan.activities if plan else ())]:
        first[activity.task] = min(
            first.get(activity.task, activity.start), activity.start
        )
    place = {name: index for index, name in enumerate(ids)}
    return sorted(
        ids,
        key=lambda name: (name not in first, first.get(name, 0), place[name]),
    )


def draw_tasks(
    ax: Any,
    problem: Problem,
    plan: Plan,
    rows: list[str],
    history: list[Activity],
    now: int | None,
    past: Mapping[str, Task] | None = None,
    failed: Collection[tuple[str, int]] | None = None,
    slots: int | None = None,
) -> None:
    """Task panel: banded rows, bars, unscheduled rows, history.

    Only the activities of ``rows`` are drawn (the rows of one page);
    ``slots`` is how many rows the panel has room for (at least
    ``len(rows)``), so that pages with fewer rows keep the same pitch.
    """
    tasks = {**(past or {}), **tasks_by_id(problem)}
    y_of = {name: idx for idx, name in enumerate(rows)}
    bar_h = 0.62
    reasons = {name: blockers for name, blockers in left_out(plan)}
    _draw_bands(ax, len(rows))

    broken = set(failed or ())
    for activity in history:
        if activity.task not in y_of:
            continue
        stop = activity.end if now is None else min(activity.end, now)
        if stop <= activity.start:
            continue
        lost = (activity.task, activity.start) in broken
        style: dict[str, Any] = (
            {"color": "white", "hatch": "xx", "edgecolor": FAILED_COLOUR}
            if lost
            else {
                "color": colour_of(problem, tasks.get(activity.task)),
                "alpha": 0.3,
                "edgecolor": "#555555",
                "linestyle": ":",
            }
        )
        y = y_of[activity.task]
        ax.barh(
            y,
            stop - activity.start,
            left=activity.start,
            height=bar_h,
            linewidth=0.6,
            **style,
        )
        if lost:
            ax.text(
                stop + 0.3,
                y,
                "failed",
                va="center",
                fontsize=7,
                color=FAILED_COLOUR,
            )

    for activity in plan.activities:
        if activity.task not in y_of:
            continue
        y = y_of[activity.task]
        length = activity.end - activity.start
        ax.barh(
            y,
            length,
            left=activity.start,
            height=bar_h,
            color=colour_of(problem, tasks.get(activity.task)),
            edgecolor="#333333",
            linewidth=0.6,
            zorder=3,
        )
        span = f"{activity.start}\u2013{activity.end}"
        # Inside the bar when it is wide enough, else beside it (before
        # it when the bar ends near the right edge, so it is not cut).
        pad = 0.005 * problem.horizon + 0.2
        if length >= 0.08 * problem.horizon:
            ax.text(
                activity.start + length / 2,
                y,
                span,
                ha="center",
                va="center",
                fontsize=8,
                color="white",
                fontweight="bold",
                zorder=4,
            )
        elif activity.end > problem.end - 0.06 * problem.horizon:
            ax.text(
                activity.start - pad,
                y,
                span,
                ha="right",
                va="center",
                fontsize=8,
                color="#333333",
                zorder=4,
            )
        else:
            ax.text(
                activity.end + pad,
                y,
                span,
                ha="left",
                va="center",
                fontsize=8,
                color="#333333",
                zorder=4,
            )

    scheduled = {a.task for a in plan.activities}
    for name in rows:
        if name in scheduled or name not in reasons:
            continue
        y = y_of[name]
        ax.barh(
            y,
            problem.horizon,
            left=problem.start,
            height=bar_h,
            color="none",
            edgecolor=UNSCHEDULED_COLOUR,
            hatch="///",
            linewidth=0.0,
            zorder=1,
        )
        why = reasons[name]
        note = "unscheduled"
        if why:
            note += f": {why[0].cause} \u2013 {why[0].detail}"
            if len(note) > 90:
                note = note[:89] + "\u2026"
        _note(
            ax,
            problem.start + 0.01 * problem.horizon,
            y,
            note,
            {"edgecolor": "none", "pad": 1.0, "alpha": 0.85},
        )

    ax.set_yticks(range(len(rows)), rows, fontsize=9)
    for label, name in zip(ax.get_yticklabels(), rows, strict=True):
        if name not in scheduled:
            label.set_color("#888888")
            label.set_style("italic")
    ax.set_ylim(max(slots or 0, len(rows)) - 0.4, -0.6)  # first on top
    ax.tick_params(axis="y", length=0)


def _draw_bands(ax: Any, num_rows: int) -> None:
    """Every other row on a light band, a thin guide line through each
    row: what lets the eye follow a row from its name to a bar far away.
    """
    for y in range(0, num_rows, 2):
        ax.axhspan(y - 0.5, y + 0.5, color=_BAND, linewidth=0, zorder=0)
    for y in range(num_rows):
        ax.axhline(y, color=_GUIDE, linewidth=0.5, zorder=0.5)


def draw_legend(
    ax: Any,
    problem: Problem,
    plan: Plan,
    rows: Sequence[str],
    history: Sequence[Activity],
    past: Mapping[str, Task],
    Patch: Any,
    *,
    moved: bool = False,
    pinned: bool = False,
) -> None:
    """The legend of the task colours and styles, right of the panel.

    ``rows`` are all the rows of the chart, not only a page's: every page
    of a chart then has the same legend. ``moved`` and ``pinned`` add the
    entries of the old places and the pins (:func:`draw_moves`).
    """
    tasks = {**past, **tasks_by_id(problem)}
    scheduled = {a.task for a in plan.activities}
    reasons = {name for name, _ in left_out(plan)}

    # Colours of every task drawn (executed ones from ``past`` too).
    shown = [tasks[name] for name in rows if name in tasks]
    handles = [
        Patch(
            facecolor=PALETTE[idx % len(PALETTE)],
            edgecolor="#333333",
            linewidth=0.6,
            label=name,
        )
        for idx, name in enumerate(problem.resources.binary)
        if any(
            colour_of(problem, t) == PALETTE[idx % len(PALETTE)] for t in shown
        )
    ]
    if any(colour_of(problem, t) == NO_BINARY_COLOUR for t in shown):
        handles.append(Patch(facecolor=NO_BINARY_COLOUR, label="no binary"))
    if history:
        handles.append(
            Patch(
                facecolor="#999999",
                alpha=0.3,
                edgecolor="#555555",
                linestyle=":",
                label="executed",
            )
        )
    if any(name not in scheduled for name in reasons):
        handles.append(
            Patch(
                facecolor="none",
                edgecolor=UNSCHEDULED_COLOUR,
                hatch="///",
                label="unscheduled",
            )
        )
    if moved:
        handles.append(
            Patch(
                facecolor=GHOST_FILL,
                edgecolor=GHOST_COLOUR,
                linestyle="--",
                label="moved: old place",
            )
        )
    if pinned:
        handles.append(
            Patch(
                facecolor="none",
                edgecolor=PIN_COLOUR,
                linewidth=2.0,
                label="pinned (commit window)",
            )
        )
    if handles:
        ax.legend(
            handles=handles,
            title="first binary resource",
            title_fontsize=8,
            fontsize=8,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            frameon=False,
        )


def draw_moves(
    ax: Any,
    rows: list[str],
    plan: Plan,
    moved: Mapping[str, int],
    pinned: Collection[str],
) -> None:
    """What a replan moved and what its commit window kept.

    A moved activity (task to its old start in ``moved``) gets its old
    place ghosted on its row: a faint fill with a dashed outline, and an
    arrow to where it is now. A pinned activity gets a thick outline and
    a mark above its start: the executor and the ground can count on it.
    """
    y_of = {name: idx for idx, name in enumerate(rows)}
    bar_h = 0.62
    for activity in plan.activities:
        y = y_of.get(activity.task)
        if y is None:
            continue
        length = activity.end - activity.start
        old = moved.get(activity.task)
        if old is not None and old != activity.start:
            ax.barh(
                y,
                length,
                left=old,
                height=bar_h,
                color=GHOST_FILL,
                edgecolor=GHOST_COLOUR,
                linestyle="--",
                linewidth=1.2,
                zorder=2,
                gid=f"ghost:{activity.task}",
            )
            ax.annotate(
                "",
                # Under the centre line: clear of the bar's time label.
                xy=(
                    activity.start if old < activity.start else activity.end,
                    y + 0.2,
                ),
                xytext=(
                    old + length if old < activity.start else old,
                    y + 0.2,
                ),
                arrowprops={"arrowstyle": "->", "color": GHOST_COLOUR},
                zorder=2,
            )
        if activity.task in pinned:
            ax.barh(
                y,
                length,
                left=activity.start,
                height=bar_h,
                color="none",
                edgecolor=PIN_COLOUR,
                linewidth=2.2,
                zorder=4,
                gid=f"pin:{activity.task}",
            )
            ax.plot(
                [activity.start],
                [y - bar_h / 2 - 0.08],
                marker="v",
                markersize=5,
                color=PIN_COLOUR,
                zorder=5,
            )


def draw_removed(
    ax: Any,
    rows: list[str],
    removed: Mapping[str, str],
    previous: Sequence[Activity],
    now: int | None,
    plan: Plan,
) -> None:
    """Removed tasks: a grey dashed outline where they were planned and
    the rule that removed them, on their (greyed) rows.

    A task removed and brought back under the same id (a goal replacing
    it) keeps its new bar; the note then follows the bars.
    """
    y_of = {name: idx for idx, name in enumerate(rows)}
    where = {a.task: a for a in previous}
    again = {a.task: a for a in plan.activities}
    for name, rule in removed.items():
        if name not in y_of:
            continue
        y = y_of[name]
        was = where.get(name)
        x = now if now is not None else ax.get_xlim()[0]
        new = again.get(name)
        if new is not None:
            right = max(new.end, was.end if was is not None else new.end)
            ax.annotate(
                f"(the previous {name}: removed, {rule})",
                xy=(right, y),
                xytext=(40, 0),  # clear of the bar's own time label
                textcoords="offset points",
                ha="left",
                va="center",
                fontsize=7.5,
                style="italic",
                color="#555555",
                zorder=4,
            )
            continue
        if was is not None:
            ax.barh(
                y,
                was.end - was.start,
                left=was.start,
                height=0.62,
                color="#efefef",
                edgecolor=REMOVED_COLOUR,
                linestyle="--",
                linewidth=0.9,
                zorder=2,
            )
            x = was.start
        _note(
            ax,
            x,
            y,
            f" removed: {rule} ",
            {
                "edgecolor": REMOVED_COLOUR,
                "boxstyle": "round,pad=0.2",
                "linewidth": 0.6,
                "alpha": 0.9,
            },
        )
    for label in ax.get_yticklabels():
        if label.get_text() in removed and label.get_text() not in again:
            label.set_color(REMOVED_COLOUR)
            label.set_style("italic")


def _note(ax: Any, x: float, y: float, text: str, box: dict) -> None:
    """A small grey italic note on a white box (``box``: its style)."""
    ax.text(
        x,
        y,
        text,
        ha="left",
        va="center",
        fontsize=8,
        style="italic",
        color="#555555",
        zorder=4,
        bbox={"facecolor": "white", **box},
    )
