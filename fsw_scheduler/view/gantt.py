"""A Gantt chart of a plan, drawn with matplotlib, in pages of 40 rows at most.

matplotlib is an optional dependency (``fsw-scheduler[plot]``) and is
imported only when :func:`gantt` is called, so importing this module
stays cheap and works without it. The levels it draws come from
:mod:`fsw_scheduler.model.levels`, the same arithmetic the replan rules
and the published profiles use. The task rows are drawn by
:mod:`~fsw_scheduler.view.gantt_rows`, the panels under them by
:mod:`~fsw_scheduler.view.gantt_panels`, and the split into pages is
decided by :mod:`~fsw_scheduler.view.pages`.

Time convention (problem format): an activity ``[start, end)`` runs in
the time units ``start .. end - 1``; a profile value at index ``i`` belongs
to time unit ``problem.start + i``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..model.levels import lost_charge, resource_profiles
from .gantt_panels import (
    draw_consumable,
    draw_lanes,
    draw_measured,
    draw_multiple,
)
from .gantt_rows import (
    draw_legend,
    draw_moves,
    draw_removed,
    draw_tasks,
    row_ids,
)
from .pages import ROWS_PER_PAGE, Page, page_path, split_rows
from .style import NOW_COLOUR, load_matplotlib
from .timeline import objective_line

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping, Sequence
    from pathlib import Path

    from ..model.plan import Activity, Moved, Plan
    from ..model.problem import Problem, Task

__all__ = [
    "gantt",
]

#: Resolution of the PNGs: a page's pixel height is its height in inches
#: times this.
DPI = 110

#: Height of one task row, in inches.
ROW_HEIGHT = 0.34

log = logging.getLogger("fsw_scheduler.view")


@dataclass(frozen=True)
class _Chart:
    """What every page of one chart shares: the data and the time range."""

    problem: Problem
    plan: Plan
    rows: list[str]
    history: list[Activity]
    now: int | None
    removed: dict[str, str]
    previous: list[Activity]
    moved: dict[str, int]
    pinned: frozenset[str]
    measured: dict[str, list[tuple[int, float]]]
    past: dict[str, Task]
    failed: Collection[tuple[str, int]] | None
    title: str | None
    x_range: tuple[int, int]
    profiles: dict[str, list[float]]
    lost: dict[str, list[float]]


def gantt(
    problem: Problem,
    plan: Plan,
    path: str | Path,
    *,
    title: str | None = None,
    now: int | None = None,
    history: Sequence[Activity] | None = None,
    removed: Mapping[str, str] | None = None,
    previous: Sequence[Activity] | None = None,
    measured: Mapping[str, Sequence[tuple[int, float]]] | None = None,
    past_tasks: Sequence[Task] | None = None,
    failed: Collection[tuple[str, int]] | None = None,
    rows_per_page: int = ROWS_PER_PAGE,
    moved: Sequence[Moved] | None = None,
    pinned: Collection[str] | None = None,
) -> list[Path]:
    """Draw a plan as a Gantt chart with resource profiles, as PNG pages.

    The top panel has one row per task in time order (first start; the
    tasks left out last, in problem order), each scheduled
    task a bar coloured by the first binary resource it uses (grey when it
    uses none) and labelled with its time span; an unscheduled task gets a
    hatched grey row with the reason from ``plan.why``. Below, one panel
    per multiple resource (usage per time unit with a dashed capacity
    line) and per consumable (level at the end of each time unit from the
    initial level at ``problem.start``, a zero line and red shading where
    the level goes below zero). A panel between them has one lane per
    binary resource, showing which task holds it when (executed activities
    faded).

    The time axis is labelled above and under the task rows, rows are
    banded with a guide line through each, so that a row can be followed
    from its name to its bar and a bar to its time, however far down the
    page it is.

    A large chart is split into pages rather than drawn as one tall figure
    of stacked panels: a page has a bounded height, so a viewer shows it
    at full size instead of shrinking a 6,000-pixel picture until its
    names cannot be read, and each page stands on its own. Every page has
    the same time range, the same row pitch (the rows are spread evenly,
    :func:`~fsw_scheduler.view.pages.split_rows`), the same legend and the
    whole resource panels, so flipping pages keeps every time at the same
    place and each task can be read against the load when it runs. The
    pages are titled "rows a-b of N (page i of n)" and the rows keep
    their time order across them.

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The plan to draw.
    path
        Where to write the PNG; parent folders must exist. A chart
        of more than ``rows_per_page`` rows is written as
        ``<stem>-1.png``, ``<stem>-2.png``, ... next to it instead
        (:func:`~fsw_scheduler.view.pages.page_path`).
    title
        First title line; the status and objective parts follow it.
    now
        Draws a vertical "now" line at this time (for replans).
    history
        Already-executed activities, drawn faded (and cut at ``now`` when
        given). Their tasks need not be in the problem; those get rows
        after the problem's tasks. The x axis widens to show them.
    removed
        Tasks a replan removed, with the rule that removed each (e.g.
        ``{"AcquisitionHF": "obsolete"}``): greyed rows, labelled with the
        rule, drawn where ``previous`` had them planned.
    previous
        The activities of the plan before, for where removed tasks were.
    measured
        Measured consumable levels, ``{resource: [(at, level), ...]}``
        (level at the start of unit ``at``), drawn as dots on the
        consumable panels against the predicted profile.
    past_tasks
        Definitions of executed tasks that are no longer in the problem,
        so their faded bars get their colours and binary lanes.
    failed
        Executions ``(task, start)`` of ``history`` that failed: drawn
        hatched in red and labelled "failed", never like a finished one.
    rows_per_page
        Most task rows on one page
        (:data:`~fsw_scheduler.view.pages.ROWS_PER_PAGE`).
    moved
        What the replan that made ``plan`` moved (a plan's ``moved``):
        each old place is ghosted on its row, a faint fill with a dashed
        outline and an arrow to the new one.
    pinned
        Tasks the replan's commit window kept at their start: drawn with
        a thick outline and a mark above the start.

    Returns
    -------
    list of Path
        The PNGs written, in page order: ``[path]`` for a chart that fits
        on one page.

    Raises
    ------
    ImportError
        If matplotlib is not installed.
    ValueError
        If a plan activity names a task that is not in the problem, or
        ``rows_per_page`` is below 1.
    """
    Figure, FigureCanvasAgg, Patch = load_matplotlib()
    history = list(history or ())
    removed = dict(removed or {})
    rows = row_ids(problem, history, plan)
    rows += [name for name in removed if name not in rows]
    x_lo = min([problem.start, *(a.start for a in history)])
    x_hi = max([problem.end, *(a.end for a in history)])
    if now is not None:
        x_lo, x_hi = min(x_lo, now), max(x_hi, now)
    chart = _Chart(
        problem=problem,
        plan=plan,
        rows=rows,
        history=history,
        now=now,
        removed=removed,
        previous=[a for a in previous or () if a.task in removed],
        moved={m.task: m.from_ for m in moved or ()},
        pinned=frozenset(pinned or ()),
        measured={k: list(v) for k, v in (measured or {}).items()},
        past={t.id: t for t in past_tasks or ()},
        failed=failed,
        title=title,
        x_range=(x_lo, x_hi),
        profiles=resource_profiles(problem, plan),
        lost=lost_charge(problem, plan),
    )
    pages = split_rows(rows, rows_per_page)
    slots = max(len(page.rows) for page in pages)
    written: list[Path] = []
    for page in pages:
        target = page_path(path, page)
        if len(pages) > 1:
            # A long plan takes seconds a page: say where the drawing is.
            log.info("drawing %s: %s", target.name, page.heading)
        fig = Figure(layout="constrained")
        FigureCanvasAgg(fig)
        _draw_page(fig, chart, page, slots, Patch)
        fig.savefig(target, format="png", dpi=DPI)
        written.append(target)
    return written


def _draw_page(
    fig: Any, chart: _Chart, page: Page, slots: int, Patch: Any
) -> None:
    """One page: its task rows, then the lanes and every resource panel.

    ``slots`` is the number of rows the task panel has room for (the
    longest page's), so that every page has the same row pitch.
    """
    from matplotlib.ticker import MaxNLocator

    problem = chart.problem
    rows = list(page.rows)
    names = [*problem.resources.multiple, *problem.resources.consumable]
    lanes = list(problem.resources.binary)
    heights = [max(2.2, ROW_HEIGHT * slots + 0.9)]
    if lanes:
        heights.append(0.42 * len(lanes) + 0.55)
    heights += [1.35] * len(names)
    fig.set_size_inches(11, sum(heights) + (1.15 if page.count > 1 else 0.9))
    axes = fig.subplots(
        len(heights),
        1,
        sharex=True,
        squeeze=False,
        gridspec_kw={"height_ratios": heights},
    )[:, 0]

    now = chart.now
    task_ax = axes[0]
    draw_tasks(
        task_ax,
        problem,
        chart.plan,
        rows,
        chart.history,
        now,
        chart.past,
        chart.failed,
        slots,
    )
    if chart.removed:
        draw_removed(
            task_ax, rows, chart.removed, chart.previous, now, chart.plan
        )
    if chart.moved or chart.pinned:
        draw_moves(task_ax, rows, chart.plan, chart.moved, chart.pinned)
    draw_legend(
        task_ax,
        problem,
        chart.plan,
        chart.rows,
        chart.history,
        chart.past,
        Patch,
        moved=bool(chart.moved),
        pinned=bool(chart.pinned),
    )
    panels = list(axes[1:])
    x_lo, x_hi = chart.x_range
    if lanes:
        draw_lanes(
            panels.pop(0),
            problem,
            chart.plan,
            chart.history,
            now,
            chart.past,
            x_hi - x_lo,
        )
    for ax, name in zip(panels, names, strict=True):
        if name in problem.resources.multiple:
            draw_multiple(ax, problem, name, chart.profiles[name])
        else:
            draw_consumable(
                ax, problem, name, chart.profiles[name], chart.lost.get(name)
            )
            if chart.measured.get(name):
                draw_measured(ax, chart.measured[name])

    def ticks() -> Any:
        return MaxNLocator(nbins=20, integer=True, steps=[1, 2, 5, 10])

    for ax in axes:
        ax.set_xlim(x_lo, x_hi)
        ax.xaxis.set_major_locator(ticks())
        ax.grid(axis="x", color="#e5e5e5", linewidth=0.7)
        ax.set_axisbelow(True)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        if now is not None:
            ax.axvline(
                now, color=NOW_COLOUR, linewidth=1.4, linestyle="-", zorder=5
            )
    # The time axis above the rows too (the same locator, so the same
    # ticks), and its labels under the rows even when panels follow.
    top = task_ax.secondary_xaxis("top")
    top.xaxis.set_major_locator(ticks())
    task_ax.tick_params(axis="x", labelbottom=True)
    if now is not None:
        task_ax.annotate(
            f"now = {now}",
            xy=(now, 1),
            xycoords=("data", "axes fraction"),
            xytext=(3, 16),  # above the top axis's labels
            textcoords="offset points",
            color=NOW_COLOUR,
            fontsize=9,
            va="bottom",
        )
    axes[-1].set_xlabel("time (units)")
    heading = objective_line(chart.plan)
    lines = [chart.title, heading] if chart.title else [f"Plan: {heading}"]
    if page.count > 1:
        lines.append(page.heading)
    fig.suptitle("\n".join(lines), fontsize=12, x=0.02, ha="left")
