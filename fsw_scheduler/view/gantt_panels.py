"""The panels under a Gantt's task rows: binary lanes, resource profiles.

Each function draws on one matplotlib axis it is given, so this module
loads without matplotlib.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..model.levels import tasks_by_id
from .style import (
    CHARGE_COLOUR,
    CLOSED_COLOUR,
    DRAIN_COLOUR,
    LOST_COLOUR,
    MEASURED_COLOUR,
    PALETTE,
)
from .timeline import capacity_note, short_number

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from ..model.plan import Activity, Plan
    from ..model.problem import Problem, Task

__all__ = [
    "draw_consumable",
    "draw_lanes",
    "draw_measured",
    "draw_multiple",
]


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


def draw_multiple(
    ax: Any, problem: Problem, name: str, usage: list[float]
) -> None:
    """Usage per time unit as stairs, capacity as a dashed line (dashed
    steps when the capacity changes over time)."""
    profile = problem.resources.capacity_profile(
        name, problem.start, problem.horizon
    )
    capacity = problem.resources.peak_capacity(name)
    edges = _edges(problem)
    ax.stairs(usage, edges, fill=True, color="#4c72b0", alpha=0.35)
    ax.stairs(usage, edges, color="#4c72b0", linewidth=1.2)
    if name in problem.resources.changing:
        ax.stairs(
            profile,
            edges,
            baseline=None,
            color="#333333",
            linestyle="--",
            linewidth=1.0,
        )
    else:
        ax.axhline(capacity, color="#333333", linestyle="--", linewidth=1.0)
    over = [max(0.0, u - c) for u, c in zip(usage, profile, strict=True)]
    if any(over):
        ax.stairs(
            [c + o for c, o in zip(profile, over, strict=True)],
            edges,
            baseline=profile,
            fill=True,
            color="#d62728",
            alpha=0.5,
        )
    top = max([capacity, *usage])
    ax.set_ylim(0, top * 1.3 if top > 0 else 1)
    ax.set_ylabel("use", fontsize=8)
    words = short_number(capacity)
    if name in problem.resources.changing:
        words = f"{short_number(min(profile, default=0.0))}..{words} in steps"
    _label(
        ax,
        f"{name}  (capacity {words}, "
        f"peak {short_number(max(usage, default=0.0))})",
    )


def draw_consumable(
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
    external = draw_external(ax, problem, name)
    _label(
        ax,
        f"{name}  (initial {short_number(initial)}, "
        f"min {short_number(min(low_level, initial))}"
        f"{capacity_note(ceiling, lost)}{external}){flag}",
    )


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
        color=LOST_COLOUR,
        alpha=0.8,
        label="lost (full)",
    )
    return ceiling + max(lost)


def draw_lanes(
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
    tasks = {**past, **tasks_by_id(problem)}
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
            colour = PALETTE[y_of[name] % len(PALETTE)]
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
    _draw_closed(ax, problem, y_of)
    ax.set_yticks(range(len(lanes)), lanes, fontsize=8)
    ax.set_ylim(len(lanes) - 0.5, -0.5)
    ax.tick_params(axis="y", length=0)
    _label(ax, "who holds each binary resource")
    ax.set_ylim(len(lanes) - 0.5, -1.1)


def _runs_of(values: Sequence[float], origin: int) -> list[tuple[int, int]]:
    """``(start, length)`` of each run of true values, in time units."""
    runs: list[tuple[int, int]] = []
    for idx, value in enumerate(values):
        if not value:
            continue
        if runs and runs[-1][0] + runs[-1][1] == origin + idx:
            runs[-1] = (runs[-1][0], runs[-1][1] + 1)
        else:
            runs.append((origin + idx, 1))
    return runs


def _draw_closed(ax: Any, problem: Problem, y_of: Mapping[str, int]) -> None:
    """Hatched grey behind a binary lane where it is not available."""
    for name in problem.resources.changing:
        if name not in y_of:
            continue
        profile = problem.resources.capacity_profile(
            name, problem.start, problem.horizon
        )
        closed = _runs_of([c == 0 for c in profile], problem.start)
        ax.broken_barh(
            closed,
            (y_of[name] - 0.45, 0.9),
            facecolors=CLOSED_COLOUR,
            edgecolor="#bbbbbb",
            hatch="//",
            linewidth=0.0,
            zorder=1,
        )


def draw_external(ax: Any, problem: Problem, name: str) -> str:
    """Units a consumable's external rate charges (gold) or drains (blue),
    as bands behind its level; returns words for the panel's label."""
    rates = problem.resources.external_profile(
        name, problem.start, problem.horizon
    )
    if not any(rates):
        return ""
    for test, colour in (
        (lambda r: r > 0, CHARGE_COLOUR),
        (lambda r: r < 0, DRAIN_COLOUR),
    ):
        for start, length in _runs_of([test(r) for r in rates], problem.start):
            ax.axvspan(
                start, start + length, color=colour, alpha=0.25, zorder=0
            )
    charge = sum(r for r in rates if r > 0)
    drain = -sum(r for r in rates if r < 0)
    words = f", external +{short_number(charge)}"
    return words + (f" -{short_number(drain)}" if drain else "")


def draw_measured(ax: Any, samples: Sequence[tuple[int, float]]) -> None:
    """Measured levels (start of unit ``at``) as dots, with a legend."""
    xs = [at for at, _ in samples]
    ys = [level for _, level in samples]
    ax.plot(
        xs,
        ys,
        "o",
        color=MEASURED_COLOUR,
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
