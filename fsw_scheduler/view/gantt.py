"""A Gantt chart of a plan, drawn with matplotlib.

matplotlib is an optional dependency (``fsw-scheduler[plot]``) and is
imported only when :func:`gantt` is called, so importing this module
stays cheap and works without it. The levels it draws come from
:mod:`fsw_scheduler.model.levels`, the same arithmetic the replan rules
and the published profiles use.

Time convention (problem format): an activity ``[start, end)`` runs in
the time units ``start .. end - 1``; a profile value at index ``i`` belongs
to time unit ``problem.start + i``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..model.levels import _task_map, lost_charge, resource_profiles
from .timeline import _capacity_note, _fmt, _left_out, _objective_line

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping, Sequence

    from ..model.plan import Activity, Plan
    from ..model.problem import Problem, Task

__all__ = [
    "gantt",
]


_INSTALL_HINT = (
    "fsw_scheduler.plot.gantt needs matplotlib; install it with "
    "pip install 'fsw-scheduler[plot]'"
)


def have_matplotlib() -> bool:
    """Whether the pictures can be drawn (matplotlib importable).

    Checked before any work is done, so that a command never solves for
    minutes and then fails on a missing optional dependency.
    """
    try:
        from matplotlib.backends.backend_agg import (  # noqa: F401
            FigureCanvasAgg,
        )
    except ImportError:
        return False
    return True


PLOT_INSTALL_HINT = "pip install 'fsw-scheduler[plot]'"


def _load_matplotlib() -> tuple[Any, Any, Any]:
    """Import the few matplotlib pieces :func:`gantt` needs.

    The figure is drawn on an explicit Agg canvas instead of through
    ``matplotlib.use("Agg")`` and pyplot: the result is the same headless
    PNG, but a library call must not switch the backend of a user's
    interactive session, and a figure that pyplot never saw cannot leak
    into its figure registry, so nothing has to be closed.
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Patch
    except ImportError as error:
        raise ImportError(_INSTALL_HINT) from error
    return Figure, FigureCanvasAgg, Patch


# Colour-blind friendly (Okabe-Ito), then tab10 for long resource lists.
_PALETTE = (
    "#0072B2",
    "#E69F00",
    "#009E73",
    "#CC79A7",
    "#56B4E9",
    "#D55E00",
    "#F0E442",
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
)


_NO_BINARY = "#7f7f7f"


_UNSCHEDULED = "#d9d9d9"


_NOW = "#c0392b"
#: A failed execution: hatched in this colour, never drawn as finished.
_FAILED = "#b03a2e"


def _colour_of(problem: Problem, task: Task | None) -> str:
    """Colour of a task: its first binary resource in declaration order."""
    if task is None:
        return _NO_BINARY
    for idx, name in enumerate(problem.resources.binary):
        if name in task.uses:
            return _PALETTE[idx % len(_PALETTE)]
    return _NO_BINARY


def _row_ids(
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
) -> Path:
    """Draw a plan as a Gantt chart with resource profiles and save a PNG.

    The top panel has one row per task in time order (first start; the
    tasks left out last, in problem order), each scheduled
    task a bar coloured by the first binary resource it uses (grey when it
    uses none) and labelled with its time span; an unscheduled task gets a
    hatched grey row with the reason from ``plan.why``. Below, one panel
    per multiple resource (usage per time unit with a dashed capacity
    line) and per consumable (level at the end of each time unit from the
    initial level at ``problem.start``, a zero line and red shading where
    the level goes below zero).

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The plan to draw.
    path
        Where to write the PNG; parent folders must exist.
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

    A panel under the tasks has one lane per binary resource, showing
    which task holds it when (executed activities faded).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    ImportError
        If matplotlib is not installed.
    ValueError
        If a plan activity names a task that is not in the problem.
    """
    Figure, FigureCanvasAgg, Patch = _load_matplotlib()
    from matplotlib.ticker import MaxNLocator

    path = Path(path)
    history = list(history or ())
    removed = dict(removed or {})
    previous = [a for a in previous or () if a.task in removed]
    measured = {k: list(v) for k, v in (measured or {}).items()}
    profiles = resource_profiles(problem, plan)
    lost = lost_charge(problem, plan)
    rows = _row_ids(problem, history, plan)
    rows += [name for name in removed if name not in rows]
    names = [*problem.resources.multiple, *problem.resources.consumable]
    lanes = list(problem.resources.binary)

    x_lo = min([problem.start, *(a.start for a in history)])
    x_hi = max([problem.end, *(a.end for a in history)])
    if now is not None:
        x_lo, x_hi = min(x_lo, now), max(x_hi, now)

    task_h = max(2.2, 0.34 * len(rows) + 0.9)
    heights = [task_h]
    if lanes:
        heights.append(0.42 * len(lanes) + 0.55)
    heights += [1.35] * len(names)
    fig = Figure(figsize=(11, sum(heights) + 0.9), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(
        len(heights),
        1,
        sharex=True,
        squeeze=False,
        gridspec_kw={"height_ratios": heights},
    )[:, 0]

    past = {t.id: t for t in past_tasks or ()}
    _draw_tasks(
        axes[0], problem, plan, rows, history, now, Patch, past, failed
    )
    if removed:
        _draw_removed(axes[0], rows, removed, previous, now, plan)
    panels = list(axes[1:])
    if lanes:
        _draw_lanes(
            panels.pop(0), problem, plan, history, now, past, x_hi - x_lo
        )
    for ax, name in zip(panels, names, strict=True):
        if name in problem.resources.multiple:
            _draw_multiple(ax, problem, name, profiles[name])
        else:
            _draw_consumable(ax, problem, name, profiles[name], lost.get(name))
            if measured.get(name):
                _draw_measured(ax, measured[name])

    for ax in axes:
        ax.set_xlim(x_lo, x_hi)
        ax.xaxis.set_major_locator(
            MaxNLocator(nbins=20, integer=True, steps=[1, 2, 5, 10])
        )
        ax.grid(axis="x", color="#e5e5e5", linewidth=0.7)
        ax.set_axisbelow(True)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        if now is not None:
            ax.axvline(now, color=_NOW, linewidth=1.4, linestyle="-", zorder=5)
    if now is not None:
        axes[0].annotate(
            f"now = {now}",
            xy=(now, 1),
            xycoords=("data", "axes fraction"),
            xytext=(3, 2),
            textcoords="offset points",
            color=_NOW,
            fontsize=9,
            va="bottom",
        )
    axes[-1].set_xlabel("time (units)")
    heading = _objective_line(plan)
    fig.suptitle(
        f"{title}\n{heading}" if title else f"Plan: {heading}",
        fontsize=12,
        x=0.02,
        ha="left",
    )
    fig.savefig(path, format="png", dpi=110)
    return path


def _draw_tasks(
    ax: Any,
    problem: Problem,
    plan: Plan,
    rows: list[str],
    history: list[Activity],
    now: int | None,
    Patch: Any,
    past: Mapping[str, Task] | None = None,
    failed: Collection[tuple[str, int]] | None = None,
) -> None:
    """Task panel: bars, unscheduled rows, history, legend."""
    tasks = {**(past or {}), **_task_map(problem)}
    y_of = {name: idx for idx, name in enumerate(rows)}
    bar_h = 0.62
    reasons = {name: blockers for name, blockers in _left_out(plan)}

    broken = set(failed or ())
    for activity in history:
        stop = activity.end if now is None else min(activity.end, now)
        if stop <= activity.start:
            continue
        lost = (activity.task, activity.start) in broken
        style: dict[str, Any] = (
            {"color": "white", "hatch": "xx", "edgecolor": _FAILED}
            if lost
            else {
                "color": _colour_of(problem, tasks.get(activity.task)),
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
                stop + 0.3, y, "failed", va="center", fontsize=7, color=_FAILED
            )

    for activity in plan.activities:
        y = y_of[activity.task]
        length = activity.end - activity.start
        ax.barh(
            y,
            length,
            left=activity.start,
            height=bar_h,
            color=_colour_of(problem, tasks.get(activity.task)),
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
            edgecolor=_UNSCHEDULED,
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
        ax.text(
            problem.start + 0.01 * problem.horizon,
            y,
            note,
            ha="left",
            va="center",
            fontsize=8,
            style="italic",
            color="#555555",
            zorder=4,
            bbox={
                "facecolor": "white",
                "edgecolor": "none",
                "pad": 1.0,
                "alpha": 0.85,
            },
        )

    ax.set_yticks(range(len(rows)), rows, fontsize=9)
    for label, name in zip(ax.get_yticklabels(), rows, strict=True):
        if name not in scheduled:
            label.set_color("#888888")
            label.set_style("italic")
    ax.set_ylim(len(rows) - 0.4, -0.6)  # first task on top
    ax.tick_params(axis="y", length=0)

    # Colours of every task drawn (executed ones from ``past`` too).
    shown = [tasks[name] for name in rows if name in tasks]
    handles = [
        Patch(
            facecolor=_PALETTE[idx % len(_PALETTE)],
            edgecolor="#333333",
            linewidth=0.6,
            label=name,
        )
        for idx, name in enumerate(problem.resources.binary)
        if any(
            _colour_of(problem, t) == _PALETTE[idx % len(_PALETTE)]
            for t in shown
        )
    ]
    if any(_colour_of(problem, t) == _NO_BINARY for t in shown):
        handles.append(Patch(facecolor=_NO_BINARY, label="no binary"))
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
                edgecolor=_UNSCHEDULED,
                hatch="///",
                label="unscheduled",
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


def _edges(problem: Problem) -> list[int]:
    """Stair edges: time unit ``t`` spans ``[t, t + 1)``."""
    return list(range(problem.start, problem.end + 1))


def _label(ax: Any, text: str) -> None:
    ax.text(
        0.005,
        0.97,
        text,
        transform=ax.transAxes,
        ha="left",
        va="top",
        fontsize=9,
        fontweight="bold",
        zorder=6,
        bbox={"facecolor": "white", "edgecolor": "none", "pad": 1.5},
    )


def _draw_multiple(
    ax: Any, problem: Problem, name: str, usage: list[float]
) -> None:
    """Usage per time unit as stairs, capacity as a dashed line."""
    capacity = problem.resources.multiple[name]
    edges = _edges(problem)
    ax.stairs(usage, edges, fill=True, color="#4c72b0", alpha=0.35)
    ax.stairs(usage, edges, color="#4c72b0", linewidth=1.2)
    ax.axhline(capacity, color="#333333", linestyle="--", linewidth=1.0)
    over = [max(0.0, u - capacity) for u in usage]
    if any(over):
        ax.stairs(
            [capacity + o for o in over],
            edges,
            baseline=capacity,
            fill=True,
            color="#d62728",
            alpha=0.5,
        )
    top = max([capacity, *usage])
    ax.set_ylim(0, top * 1.3 if top > 0 else 1)
    ax.set_ylabel("use", fontsize=8)
    _label(
        ax,
        f"{name}  (capacity {_fmt(capacity)}, "
        f"peak {_fmt(max(usage, default=0.0))})",
    )


def _draw_consumable(
    ax: Any,
    problem: Problem,
    name: str,
    levels: list[float],
    lost: list[float] | None = None,
) -> None:
    """Level after each unit as steps from the initial level, zero line.

    A level at the end of unit ``t`` is drawn over ``[t, t + 1)`` so the
    step ends where the unit ends; the initial level is the dot at
    ``problem.start``. A capacity is a dashed line, and charge lost
    because the store was full is drawn above it (:func:`_draw_ceiling`).
    """
    initial = float(problem.resources.initial(name))
    ceiling = problem.resources.ceiling(name)
    edges = _edges(problem)
    ax.stairs(levels, edges, baseline=None, color="#2a9d8f", linewidth=1.4)
    ax.plot(
        [problem.start, problem.start],
        [initial, levels[0]],
        color="#2a9d8f",
        linewidth=1.4,
    )
    ax.plot(
        [problem.start],
        [initial],
        "o",
        color="#2a9d8f",
        markersize=4,
        clip_on=False,
        zorder=4,
    )
    ax.axhline(0, color="#333333", linewidth=0.9)
    below = [min(0.0, v) for v in levels]
    if any(below):
        ax.stairs(
            below, edges, baseline=0, fill=True, color="#d62728", alpha=0.45
        )
    low = min([0.0, *levels])
    high = max([initial, *levels])
    if ceiling is not None:
        high = max(high, _draw_ceiling(ax, problem, ceiling, lost or []))
    pad = 0.3 * (high - low or 1.0)
    ax.set_ylim(low - (0.1 * pad if low < 0 else 0.05 * pad), high + pad)
    ax.set_ylabel("level", fontsize=8)
    low_level = min(levels, default=initial)
    flag = "  BELOW ZERO" if low_level < 0 else ""
    _label(
        ax,
        f"{name}  (initial {_fmt(initial)}, "
        f"min {_fmt(min(low_level, initial))}"
        f"{_capacity_note(ceiling, lost)}){flag}",
    )


_LOST = "#e9c46a"


def _draw_ceiling(
    ax: Any, problem: Problem, ceiling: float, lost: list[float]
) -> float:
    """The capacity as a dashed line, lost charge as a band above it.

    Returns the highest value drawn (for the axis limits).
    """
    ax.axhline(ceiling, color="#333333", linestyle="--", linewidth=1.0)
    if not any(lost):
        return ceiling
    ax.stairs(
        [ceiling + v for v in lost],
        _edges(problem),
        baseline=ceiling,
        fill=True,
        color=_LOST,
        alpha=0.8,
        label="lost (full)",
    )
    return ceiling + max(lost)


_REMOVED = "#9a9a9a"


_MEASURED = "#D55E00"


def _draw_removed(
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
                edgecolor=_REMOVED,
                linestyle="--",
                linewidth=0.9,
                zorder=2,
            )
            x = was.start
        ax.text(
            x,
            y,
            f" removed: {rule} ",
            ha="left",
            va="center",
            fontsize=8,
            style="italic",
            color="#555555",
            zorder=4,
            bbox={
                "facecolor": "white",
                "edgecolor": _REMOVED,
                "boxstyle": "round,pad=0.2",
                "linewidth": 0.6,
                "alpha": 0.9,
            },
        )
    for label in ax.get_yticklabels():
        if label.get_text() in removed and label.get_text() not in again:
            label.set_color(_REMOVED)
            label.set_style("italic")


def _draw_lanes(
    ax: Any,
    problem: Problem,
    plan: Plan,
    history: Sequence[Activity],
    now: int | None,
    past: Mapping[str, Task],
    x_span: float,
) -> None:
    """One lane per binary resource: which task holds it when.

    A bar is named when the name fits inside it (about 4.3 points per
    character at 7 points, on an axis about 650 points wide).
    """
    tasks = {**past, **_task_map(problem)}
    units_per_char = 4.3 * max(x_span, 1) / 650
    lanes = list(problem.resources.binary)
    y_of = {name: idx for idx, name in enumerate(lanes)}
    # Executed tasks may have left the problem; a task's uses are known
    # only from the problem, so executed bars are drawn for its tasks.
    holders: list[tuple[Activity, bool]] = [
        (a, True) for a in history if a.task in tasks
    ] + [(a, False) for a in plan.activities]
    for activity, executed in holders:
        task = tasks.get(activity.task)
        if task is None:
            continue
        stop = activity.end
        if executed and now is not None:
            stop = min(stop, now)
        if stop <= activity.start:
            continue
        for name in task.uses:
            if name not in y_of:
                continue
            colour = _PALETTE[y_of[name] % len(_PALETTE)]
            ax.barh(
                y_of[name],
                stop - activity.start,
                left=activity.start,
                height=0.7,
                color=colour,
                alpha=0.3 if executed else 0.9,
                edgecolor="#333333",
                linewidth=0.5,
                zorder=3,
            )
            width = stop - activity.start
            if width >= (len(activity.task) + 1) * units_per_char:
                ax.text(
                    activity.start + width / 2,
                    y_of[name],
                    activity.task,
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="#333333" if executed else "white",
                    fontweight="bold",
                    clip_on=True,
                    zorder=4,
                )
    ax.set_yticks(range(len(lanes)), lanes, fontsize=8)
    ax.set_ylim(len(lanes) - 0.5, -0.5)
    ax.tick_params(axis="y", length=0)
    _label(ax, "who holds each binary resource")
    ax.set_ylim(len(lanes) - 0.5, -1.1)


def _draw_measured(ax: Any, samples: Sequence[tuple[int, float]]) -> None:
    """Measured levels (start of unit ``at``) as dots, with a legend."""
    xs = [at for at, _ in samples]
    ys = [level for _, level in samples]
    ax.plot(
        xs,
        ys,
        "o",
        color=_MEASURED,
        markersize=4.5,
        markeredgecolor="white",
        markeredgewidth=0.6,
        zorder=6,
        label="measured",
    )
    low, high = ax.get_ylim()
    # Room above the highest dot for the panel's label and legend.
    top = max(ys) + 0.3 * (max(high, max(ys)) - min(low, min(ys)) or 1.0)
    ax.set_ylim(min(low, min(ys) - 0.05 * (high - low or 1.0)), max(high, top))
    ax.plot([], [], color="#2a9d8f", linewidth=1.4, label="predicted")
    ax.legend(
        loc="upper right", fontsize=7, frameon=False, ncol=2, handlelength=1.2
    )
