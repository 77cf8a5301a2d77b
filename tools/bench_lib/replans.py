"""Replans on busy days: one goal on a 30-60 task plan, against a fresh
solve of the same new problem.

Each case draws a problem of :mod:`bench_lib.fresh`'s shape (three binary
resources, power, a battery; 30, 45 or 60 tasks over H = 1440), solves it
with the time limit, and sends one goal at :data:`GOAL_AT` (two tasks on
the problem's resources, one of them in a window, drawn from the same
seed) through :func:`fsw_scheduler.api.replan_typed`, as the node does:
the paper's replan rules build the new problem and the plan in force is
the warm plan. The same new problem is then solved from scratch with the
full limit. Both plans go through the checker; the report gives the wall
time of each, the ratio, and whether the replan's plan is no worse.
"""

from __future__ import annotations

import random
import statistics
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.api import replan_typed
from fsw_scheduler.model.change import decode_change
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.solve import solve

from . import fresh
from .generator import dump_json, problem_seed
from .report import aligned, fmt

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from fsw_scheduler.model.plan import Plan

#: Plan sizes and the horizon of the cases.
SIZES: tuple[int, ...] = (30, 45, 60)
HORIZON = 1440
#: Cases per size.
PER_SIZE = 2
#: Time unit at which the goal arrives.
GOAL_AT = 60


@dataclass
class ReplanCase:
    """One replan and the fresh solve of the same problem; seconds."""

    name: str
    num_tasks: int
    replan_s: float
    fresh_s: float
    replan_status: str
    fresh_status: str
    replan_total: int | None
    fresh_total: int | None
    replan_gap: float | None
    solver: str
    valid: bool

    @property
    def no_worse(self) -> bool:
        """True when the replan's plan costs no more than the fresh one."""
        if self.replan_total is None:
            return self.fresh_total is None
        return self.fresh_total is None or self.replan_total <= (
            self.fresh_total
        )


def goal_doc(seed: int, horizon: int = HORIZON) -> dict[str, Any]:
    """A goal of two tasks on the fresh shape's resources."""
    rng = random.Random(seed)
    longest = max(2, horizon // 16)
    first = {
        "id": f"G{seed % 1000:03d}-a",
        "length": rng.randint(1, longest),
        "delay_cost": rng.randint(1, 5),
        "schedule_cost": rng.randint(2, 5),
        "uses": {"camera": 1, "power": rng.randint(10, 36)},
    }
    low = GOAL_AT + rng.randint(0, horizon // 4)
    second = {
        "id": f"G{seed % 1000:03d}-b",
        "length": rng.randint(1, longest),
        "delay_cost": rng.randint(1, 5),
        "schedule_cost": rng.randint(2, 5),
        "uses": {"antenna": 1, "battery": rng.randint(1, 3)},
        "feasible_interval": [low, low + horizon // 3],
    }
    return {"goal_id": f"goal-{seed}", "tasks": [first, second]}


def run_cases(
    seed: int,
    time_limit: float,
    per_size: int = PER_SIZE,
    progress: Callable[[str], None] | None = None,
    sizes: Sequence[int] = SIZES,
) -> list[ReplanCase]:
    """Solve, replan and solve afresh every case of suite ``seed``."""
    cases = []
    for size in sizes:
        for index in range(per_size):
            name = f"r{size:02d}-h{HORIZON}-{index}"
            own = problem_seed(seed, name)
            problem = decode_problem(
                dump_json(fresh.generate_problem(size, HORIZON, own))
            )
            first = solve(problem, time_limit=time_limit)
            if not first.status.has_plan:
                continue  # nothing in force to replan from
            goal = decode_change(dump_json(goal_doc(own)))
            began = time.perf_counter()
            new_problem, replanned, _ = replan_typed(
                problem, first, goal, GOAL_AT, time_limit=time_limit
            )
            replan_s = time.perf_counter() - began
            began = time.perf_counter()
            afresh = solve(new_problem, time_limit=time_limit)
            fresh_s = time.perf_counter() - began
            valid = all(
                check_plan(new_problem, plan).ok
                for plan in (replanned, afresh)
                if plan.status.has_plan
            )
            case = ReplanCase(
                name=name,
                num_tasks=new_problem.num_tasks,
                replan_s=replan_s,
                fresh_s=fresh_s,
                replan_status=replanned.status.value,
                fresh_status=afresh.status.value,
                replan_total=_total(replanned),
                fresh_total=_total(afresh),
                replan_gap=None
                if replanned.stats is None
                else replanned.stats.gap,
                solver=""
                if replanned.stats is None
                else replanned.stats.solver,
                valid=valid,
            )
            if progress is not None:
                progress(
                    f"{name}: replan {replan_s:.2f} s {case.replan_status} "
                    f"{case.replan_total}, fresh {fresh_s:.2f} s "
                    f"{case.fresh_status} {case.fresh_total}"
                )
            cases.append(case)
    return cases


def _total(plan: Plan) -> int | None:
    """The plan's objective total, None without a plan."""
    return None if plan.objective is None else plan.objective.total


HEADER = (
    "case",
    "tasks",
    "replan s",
    "fresh s",
    "ratio",
    "replan",
    "fresh",
    "replan no worse",
    "replan gap",
    "solver",
)


def format_cases(cases: Sequence[ReplanCase]) -> str:
    """The cases as a table, with a line of medians."""
    rows = [
        [
            case.name,
            str(case.num_tasks),
            fmt(case.replan_s),
            fmt(case.fresh_s),
            f"{case.replan_s / case.fresh_s:.2f}" if case.fresh_s else "-",
            f"{case.replan_status} {case.replan_total}",
            f"{case.fresh_status} {case.fresh_total}",
            "yes" if case.no_worse else "NO",
            "-" if case.replan_gap is None else f"{case.replan_gap:g}",
            case.solver,
        ]
        for case in cases
    ]
    if cases:
        rows.append(
            [
                "median",
                "",
                fmt(statistics.median(c.replan_s for c in cases)),
                fmt(statistics.median(c.fresh_s for c in cases)),
                "",
                "",
                "",
                f"{sum(c.no_worse for c in cases)} of {len(cases)}",
                "",
                "",
            ]
        )
    lines = aligned([list(HEADER), *rows], left=1)
    if cases:
        lines.append(target(cases))
    return "\n".join(lines)


#: The replan target: the median replan answers within this many seconds.
MEDIAN_TARGET_S = 2.0


def target(cases: Sequence[ReplanCase]) -> str:
    """The replan target, met or not: median under
    :data:`MEDIAN_TARGET_S` and every replan's plan no worse than the
    fresh solve's with the whole limit (the cases that are not named)."""
    median = statistics.median(c.replan_s for c in cases)
    worse = [c.name for c in cases if not c.no_worse]
    fast = median < MEDIAN_TARGET_S
    verdict = "met" if fast and not worse else "NOT met"
    return (
        f"target, median under {MEDIAN_TARGET_S:g} s and every plan no "
        f"worse than the fresh solve's: {verdict} (median {median:.2f} s; "
        f"worse: {', '.join(worse) or 'none'})"
    )
