"""A plan as text: one bar per task, resource lines, what was left out.

Pure and needs nothing beyond the standard library (``fsw-scheduler
solve --timeline``).

Time convention (problem format): an activity ``[start, end)`` runs in
the time units ``start .. end - 1``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..model.levels import lost_charge, resource_profiles, tasks_by_id

if TYPE_CHECKING:
    from collections.abc import Collection, Sequence

    from ..model.plan import Blocker, Moved, Plan
    from ..model.problem import Problem

__all__ = [
    "capacity_note",
    "left_out",
    "objective_line",
    "short_number",
    "timeline_text",
]


_ANSI = {
    "bold": "\x1b[1m",
    "dim": "\x1b[2m",
    "red": "\x1b[31m",
    "green": "\x1b[32m",
    "off": "\x1b[0m",
}


def short_number(value: float) -> str:
    """Short number: integers without a decimal point."""
    return f"{value:g}"


def objective_line(plan: Plan) -> str:
    """``status optimal, unscheduled cost 0, delay cost 3, total 3``."""
    status = getattr(plan.status, "value", plan.status)
    parts = [f"status {status}"]
    if plan.objective is not None:
        obj = plan.objective
        parts += [
            f"unscheduled cost {obj.unscheduled_cost}",
            f"delay cost {obj.delay_cost}",
            f"total {obj.total}",
        ]
    return ", ".join(parts)


def left_out(plan: Plan) -> list[tuple[str, list[Blocker]]]:
    """Unscheduled tasks, then other blocked tasks, with their reasons.

    An infeasible plan explains mandatory tasks in ``why`` that may not be
    listed in ``unscheduled``; they are shown too.
    """
    reasons: dict[str, list[Blocker]] = {}
    for blocker in plan.why:
        reasons.setdefault(blocker.task, []).append(blocker)
    # A chosen group's reasons are its options not chosen: shown apart.
    scheduled = {a.task for a in plan.activities} | set(plan.picks)
    names = list(plan.unscheduled)
    names += [
        name
        for name in reasons
        if name not in scheduled and name not in plan.unscheduled
    ]
    return [(name, reasons.get(name, [])) for name in names]


def chosen_lines(problem: Problem, plan: Plan) -> list[str]:
    """The option each group of alternatives got, and why not the others.

    One line per group (``img: option 1 (SetLF, AcqLF)``, or ``left
    out``), then the plan's ``alternative`` reasons for the options not
    chosen, indented. Nothing for a problem without groups.
    """
    if not problem.alternatives:
        return []
    lines = ["", "alternatives:"]
    picks = plan.picks
    for group in problem.alternatives:
        pick = picks.get(group.id)
        text = (
            f"left out (cost {group.schedule_cost})"
            if pick is None
            else f"option {pick} ({', '.join(group.options[pick])})"
        )
        lines.append(f"  {group.id}: {text}")
        lines += [
            f"    {blocker.detail}"
            for blocker in plan.why
            if blocker.task == group.id and blocker.cause == "alternative"
        ]
    return lines


def _bar(start: int, end: int, origin: int, horizon: int, cells: int) -> str:
    """ASCII bar of ``[start, end)`` on ``cells`` characters.

    Cell ``c`` stands for the time ``origin + (c + 1/2) * horizon / cells``
    (its centre) and is filled when the activity runs then; an activity too
    short to cover any centre still gets the cell where it starts, so
    nothing disappears however coarse the scale. Integer arithmetic keeps
    the output exact.
    """
    lo, hi = start - origin, end - origin
    filled = [
        lo * 2 * cells <= (2 * c + 1) * horizon < hi * 2 * cells
        for c in range(cells)
    ]
    if not any(filled) and hi > 0 and lo < horizon:
        filled[min(cells - 1, max(0, lo * cells // horizon))] = True
    return "".join("#" if f else "." for f in filled)


def timeline_text(
    problem: Problem,
    plan: Plan,
    *,
    width: int | None = None,
    color: bool = False,
    moved: Sequence[Moved] | None = None,
    pinned: Collection[str] | None = None,
) -> str:
    """A fixed-width text timeline of a plan, for terminals and logs.

    Parameters
    ----------
    problem
        The problem the plan solves.
    plan
        The plan to show.
    width
        Total line width in characters (default 80, not the terminal's,
        so the output is deterministic). The bar shrinks to fit; with room
        to spare it uses a whole number of characters per time unit.
    color
        Add ANSI colours (bars green, levels below zero red). Off by
        default so the text is plain ASCII.
    moved
        What the replan that made ``plan`` moved (a plan's ``moved``):
        each old place is ghosted in its bar with ``:`` (dim with
        colours) and the line ends ``moved from <start>``.
    pinned
        Tasks the replan's commit window kept at their start: their line
        ends ``pinned``.

    Returns
    -------
    str
        A header with status and objective; one line per scheduled task,
        sorted by (start, task id), with ``start-end`` and a bar over the
        horizon; the unscheduled tasks with the reasons found in
        ``plan.why``; one line per multiple resource (peak use) and per
        consumable (lowest level and when). Ends with a newline.
    """
    paint = _ANSI if color else dict.fromkeys(_ANSI, "")
    horizon, origin = problem.horizon, problem.start
    activities = sorted(plan.activities, key=lambda a: (a.start, a.task))
    ids = [a.task for a in activities] + ["task"]
    id_w = max(len(name) for name in ids)
    num_w = len(str(max(problem.end, *(a.end for a in activities), 0)))
    span_w = max(len("time"), 2 * num_w + 1)
    prefix = id_w + 2 + span_w + 2 + 1  # "id  s-e  |"
    room = max(10, (width or 80) - prefix - 1)
    cells = horizon * (room // horizon) if room >= horizon else room

    lines = [
        f"{paint['bold']}Plan: {objective_line(plan)}{paint['off']}",
        f"horizon [{origin}, {problem.end}), "
        f"{len(activities)} scheduled, {len(plan.unscheduled)} unscheduled",
        "",
    ]
    left, right = str(origin), str(problem.end)
    ruler = left + " " * max(1, cells - len(left) - len(right)) + right
    lines.append(f"{'task':<{id_w}}  {'time':<{span_w}}  |{ruler}|")
    was = {m.task: m.from_ for m in moved or ()}
    kept = set(pinned or ())
    for act in activities:
        bar = _bar(act.start, act.end, origin, horizon, cells)
        note = ""
        old = was.get(act.task)
        if old is not None and old != act.start:
            ghost = _bar(
                old, old + act.end - act.start, origin, horizon, cells
            )
            bar = "".join(
                ":" if g == "#" and b == "." else b
                for b, g in zip(bar, ghost, strict=True)
            )
            note = f" moved from {old}"
        if act.task in kept:
            note += " pinned"
        if color:
            bar = bar.replace("#", f"{paint['green']}#{paint['off']}")
            bar = bar.replace(":", f"{paint['dim']}:{paint['off']}")
        span = f"{act.start}-{act.end}"
        lines.append(f"{act.task:<{id_w}}  {span:<{span_w}}  |{bar}|{note}")

    lines += chosen_lines(problem, plan)
    missing = left_out(plan)
    if missing:
        lines += ["", "unscheduled:"]
        tasks = tasks_by_id(problem)
        group_cost = {g.id: g.schedule_cost for g in problem.alternatives}
        for name, blockers in missing:
            task = tasks.get(name)
            cost = "" if task is None else f" (cost {task.schedule_cost})"
            if name in group_cost:
                cost = f" (group, cost {group_cost[name]})"
            if not blockers:
                lines.append(f"  {name}{cost}")
            for blocker in blockers:
                lines.append(
                    f"  {name}{cost}: {blocker.cause}: {blocker.detail}"
                )

    lines += _resource_lines(problem, plan, paint)
    return "\n".join(lines) + "\n"


def _resource_lines(
    problem: Problem, plan: Plan, paint: dict[str, str]
) -> list[str]:
    resources = problem.resources
    if not resources.multiple and not resources.consumable:
        return []
    profiles = resource_profiles(problem, plan)
    name_w = max(len(n) for n in (*resources.multiple, *resources.consumable))
    lines = ["", "resources:"]
    for name in resources.multiple:
        use = profiles[name]
        capacity = resources.capacity_profile(
            name, problem.start, problem.horizon
        )
        peak = max(use, default=0.0)
        at = use.index(peak) + problem.start if peak > 0 else None
        when = f" at t={at}" if at is not None else ""
        over = any(u > c + 1e-9 for u, c in zip(use, capacity, strict=True))
        flag = f" {paint['red']}OVER CAPACITY{paint['off']}" if over else ""
        top = resources.peak_capacity(name)
        steps = "" if name not in resources.changing else " (in steps)"
        lines.append(
            f"  {name:<{name_w}}  peak {short_number(peak)}"
            f"/{short_number(top)}{steps}{when}{flag}"
        )
    lost = lost_charge(problem, plan)
    for name, initial in resources.initial_levels.items():
        levels = profiles[name]
        low = min(levels, default=initial)
        if low >= initial:
            low, when = float(initial), f"at start t={problem.start}"
        else:
            when = f"at end of t={levels.index(low) + problem.start}"
        final = levels[-1] if levels else initial
        text = f"min {short_number(low)} {when}"
        if low < 0:
            text = f"{paint['red']}{text} BELOW ZERO{paint['off']}"
        lines.append(
            f"  {name:<{name_w}}  {text} "
            f"(initial {short_number(initial)}, final {short_number(final)}"
            f"{capacity_note(resources.ceiling(name), lost.get(name))})"
        )
    return lines


def capacity_note(ceiling: float | None, lost: list[float] | None) -> str:
    """``, capacity 10, lost 4`` for a consumable with a capacity."""
    if ceiling is None:
        return ""
    wasted = sum(lost or ())
    return f", capacity {short_number(ceiling)}" + (
        f", lost {short_number(wasted)}" if wasted > 0 else ""
    )
